/* test_gblend.c - Zheng 2013 Sec. 3.3's gradient-domain blend (model/variations/keys.c,
 * weight_grad.c, defgrad.c, gblend.c), on the looping example (looping.h) and horse-gallop's
 * 22-bone skin (skip 77 if absent):
 *   - key vertices: every bone's max-weight vertex is one;
 *   - Appendix A: the weight gradients at every key vertex sum to 0 over the bones (eq. 15) within
 *     1e-12, and are not all 0 (the weights do vary);
 *   - eq. 8: every bone moved by one affine {F, t} (the reference bone too) gives D_i = F at
 *     every key vertex (the property Appendix A is for), and eq. 8 of an input frame is what the
 *     analysis stored, d_i its polar coordinates;
 *   - eq. 9: the bones of another input frame recovered from their own exact gradients (round
 *     trip, no pull toward them);
 *   - a splice between two identical segments (i, i) changes no output frame;
 *   - the window's shape from the tridiagonal solve: h_0 = 1, h_L = 0, h'' = 0. */
#include "model.h"
#include "test.h"
#include "fit.h"
#include "looping.h"
#include "variations/variations.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void check_graph(const struct mdl_variations *v, const char *name)
{
    ASSERT_INT_GT(v->nkey, 0);
    /* key vertices: the max-weight vertex of each bone is among them ("Selection of Key
     * Vertices"; a component's graph keeps no skin of its own: checked on the whole) */
    for (int b = 0; v->bone && b < v->nb; b++) {
        int best = -1;
        double bw = 0;
        for (int i = 0; i < v->nv; i++)
            for (int s = 0; s < v->K; s++)
                if (v->bone[(size_t)v->K * i + s] == b && v->w[(size_t)v->K * i + s] > bw) {
                    bw = v->w[(size_t)v->K * i + s];
                    best = i;
                }
        if (best < 0)
            continue;
        int found = 0;
        for (int k = 0; k < v->nkey; k++) /* a tie may pick another vertex of the same weight */
            for (int q = v->kb_off[k]; q < v->kb_off[k + 1]; q++)
                found |= v->key_v[k] == best ||
                         (v->kb_bone[q] == b && fabs(v->kb_w[q] - bw) < 1e-6);
        ASSERT_INT_EQ(found, 1);
    }
    /* eq. 15: sum_b dw_ib/dv_bar = 0 exactly (to rounding); the gradients are not all 0 */
    double worst = 0, largest = 0;
    int moving = 0;
    for (int k = 0; k < v->nkey; k++) {
        double s[3] = {0, 0, 0}, wsum = 0;
        for (int q = v->kb_off[k]; q < v->kb_off[k + 1]; q++) {
            for (int a = 0; a < 3; a++) {
                s[a] += v->kb_g[3 * q + a];
                largest = fmax(largest, fabs(v->kb_g[3 * q + a]));
            }
            wsum += v->kb_w[q];
        }
        ASSERT_NEAR(wsum, 1, 1e-9);
        for (int a = 0; a < 3; a++)
            worst = fmax(worst, fabs(s[a]));
        moving += v->kb_off[k + 1] - v->kb_off[k] > 1;
    }
    printf("%s: %d key vertices (%d with several bones), |sum_b dw/dv| <= %.2g (gradients up to "
           "%.3g)\n", name, v->nkey, moving, worst, largest);
    ASSERT_LE(worst, 1e-12);
    ASSERT_GT(largest, 0.1);

    /* eq. 8 under one affine map of all bones: D = F */
    const double F[9] = {1.3, 0.2, -0.1, -0.3, 0.9, 0.4, 0.25, -0.15, 1.1}, t[3] = {0.7, -2, 0.4};
    double *LR = calloc(9 * (size_t)v->nb, sizeof *LR), *Lt = calloc(3 * (size_t)v->nb, sizeof *Lt);
    for (int b = 0; b < v->nb; b++) {
        memcpy(LR + 9 * b, F, sizeof F);
        memcpy(Lt + 3 * b, t, sizeof t);
    }
    double werr = 0;
    for (int k = 0; k < v->nkey; k++) {
        double D[9];
        mdl__defgrad(v, k, LR, Lt, D);
        for (int a = 0; a < 9; a++)
            werr = fmax(werr, fabs(D[a] - F[a]));
    }
    printf("%s: all bones one affine map F: max |D_i - F| = %.2g\n", name, werr);
    ASSERT_LE(werr, 1e-9);
    free(LR);
    free(Lt);

    /* the stored D_i(t) and d_i(t) */
    int c = v->nframes / 3, c2 = v->nframes / 3 + 7;
    for (int k = 0; k < v->nkey; k++) {
        double D[9], U[9], S[9], DS[9];
        mdl__defgrad(v, k, v->LR + 9 * (size_t)c * v->nb, v->Lt + 3 * (size_t)c * v->nb, D);
        const double *d = v->kd + 9 * ((size_t)c * v->nkey + k);
        for (int a = 0; a < 9; a++)
            ASSERT_NEAR(D[a], v->kD[9 * ((size_t)c * v->nkey + k) + a], 1e-12);
        mdl__so3_exp(d, U);
        const double Sf[9] = {d[3], d[4], d[5], d[4], d[6], d[7], d[5], d[7], d[8]};
        memcpy(S, Sf, sizeof S);
        mdl__mat3_mul(U, S, DS);
        for (int a = 0; a < 9; a++)
            ASSERT_NEAR(DS[a], D[a], 1e-9);
    }

    /* eq. 9 round trip: frame c2's bones from frame c2's gradients, as a change from frame c's,
     * with no pull toward the answer (X0 = 0) */
    double *R = calloc(9 * (size_t)v->nkey, sizeof *R), *X = calloc(3 * (size_t)v->nu, sizeof *X);
    for (int k = 0; k < v->nkey; k++)
        for (int a = 0; a < 9; a++)
            R[9 * k + a] = v->kD[9 * ((size_t)c2 * v->nkey + k) + a] - v->kD[9 * ((size_t)c * v->nkey + k) + a];
    ASSERT_OK(mdl__gblend_solve(v, R, NULL, X), "eq. 9");
    double rerr = 0, terr = 0, change = 0;
    for (int b = 0; b < v->nb; b++) {
        int q = v->ucol[b];
        if (q < 0)
            continue;
        for (int r = 0; r < 3; r++) {
            for (int a = 0; a < 3; a++) {
                double want = v->LR[9 * ((size_t)c2 * v->nb + b) + 3 * r + a] -
                              v->LR[9 * ((size_t)c * v->nb + b) + 3 * r + a];
                rerr = fmax(rerr, fabs(X[q + a + (size_t)v->nu * r] - want));
                change = fmax(change, fabs(want));
            }
            double want = v->Lt[3 * ((size_t)c2 * v->nb + b) + r] - v->Lt[3 * ((size_t)c * v->nb + b) + r];
            terr = fmax(terr, fabs(X[q + 3 + (size_t)v->nu * r] - want));
        }
    }
    printf("%s: eq. 9 recovers frame %d's bones from frame %d's by their gradients: rotation "
           "entries within %.2g (the change is up to %.3g), translations within %.2g\n", name, c2,
           c, rerr, change, terr);
    ASSERT_LE(rerr, 0.02 * change);
    free(R);
    free(X);

    /* the window's shape */
    int L = v->o.blend;
    ASSERT_NEAR(v->hramp[0], 1, 0);
    ASSERT_NEAR(v->hramp[L], 0, 0);
    for (int k = 1; k < L; k++)
        ASSERT_NEAR(v->hramp[k - 1] - 2 * v->hramp[k] + v->hramp[k + 1], 0, 1e-12);
}

/* a splice between two identical segments changes nothing */
static void check_identity_splice(const struct mdl_variations *v, double *tol_out)
{
    mdl__vblend a, b;
    ASSERT_INT_EQ(mdl__vblend_init(&a, v), 0);
    ASSERT_INT_EQ(mdl__vblend_init(&b, v), 0);
    double *Ta = calloc(12 * (size_t)v->nb, sizeof *Ta), *Tb = calloc(12 * (size_t)v->nb, sizeof *Tb);
    int i = v->nframes / 2, L = v->o.blend;
    /* a: frames i - 3 .. i, a splice (i, i), then i + 1 ..; b the same without the splice */
    double worst = 0;
    for (int f = i - 3; f <= i + L + 2 && f < v->nframes; f++) {
        mdl__vblend_pose(&a, v, f, Ta);
        mdl__vblend_pose(&b, v, f, Tb);
        for (int k = 0; k < 12 * v->nb; k++)
            worst = fmax(worst, fabs(Ta[k] - Tb[k]));
        if (f == i)
            mdl__vblend_splice(&a, v, i, i);
        mdl__vblend_advance(&a);
        mdl__vblend_advance(&b);
    }
    *tol_out = worst;
    ASSERT_LE(worst, 1e-9);
    free(Ta);
    free(Tb);
    mdl__vblend_fini(&a);
    mdl__vblend_fini(&b);
}

static void test_looping(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s = NULL;
    mdl_model *m = lp_fit(90, 30, 3, &s, err);
    ASSERT_OK(m ? 0 : -1, err);
    mdl_variations *v = NULL;
    mdl_variations_opts og;
    mdl_variations_opts_default(&og);
    ASSERT_INT_EQ(og.blend_linear, 1); /* the default: linear (docs/MODEL.md) */
    og.blend_linear = 0;
    ASSERT_OK(mdl_variations_build(m, &og, &v, err), err);
    ASSERT_INT_EQ(v->o.blend_linear, 0);
    check_graph(v, "looping");
    double tol = 0;
    check_identity_splice(v, &tol);
    printf("looping: a splice (i, i) changes the frames after it by %.2g\n", tol);
    /* the linear blend builds no key vertices */
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    o.blend_linear = 1;
    mdl_variations *vl = NULL;
    ASSERT_OK(mdl_variations_build(m, &o, &vl, err), err);
    ASSERT_INT_EQ(vl->nkey, 0);
    mdl_variations_destroy(vl);
    mdl_variations_destroy(v);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
}

static void test_horse(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_model *m = vt_fit_skin("meshes/horse-gallop", NULL, 22);
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    o.components = 0;
    o.blend_linear = 0; /* the gradient blend (not the default) */
    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
    check_graph(v, "horse");
    double tol = 0;
    check_identity_splice(v, &tol);
    printf("horse: a splice (i, i) changes the frames after it by %.2g\n", tol);
    ASSERT_INT_GT(v->ncomp, 1);
    for (int c = 0; c < v->ncomp; c++) { /* each component's own key vertices */
        char name[32];
        snprintf(name, sizeof name, "horse component %d", c);
        check_graph(v->comp[c].g, name);
    }
    mdl_variations_destroy(v);
    mdl_model_destroy(m);
}

int main(void)
{
    mdl_set_blas_threads(1);
    test_looping();
    test_horse();
    printf("gblend: ok\n");
    return 0;
}
