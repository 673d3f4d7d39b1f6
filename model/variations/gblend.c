/* gblend.c - the gradient-domain blend of a splice (Zheng 2013 Sec. 3.3, "Solving Local-Frame
 * Bone Positions" and Fig. 7), on the key vertices' deformation gradients (keys.c, weight_grad.c,
 * defgrad.c):
 *
 *   Poisson   d~_i''(t) = g(t) over the window, g the finite differences of the precomputed
 *             d_i of the frames shown, with d~_i fixed at both ends. A walk streams its frames
 *             (the daemon's idle source shows each as it is made), so the window is the L =
 *             o.blend output frames after the splice: d~_i(0) is what frame i showed, d~_i(L) =
 *             d_i(j + L). With g the new segment's own second differences, d~_i = d_i(j + k) +
 *             h_k (d~_i(0) - d_i(j)) where h solves the same tridiagonal system with g = 0,
 *             h_0 = 1, h_L = 0 (dgtsv; one solve for every coordinate and every splice, at
 *             analysis). The rotation part is carried on the rotation group: U~_i(j + k) =
 *             Exp(h_k omega_i) U_i(j + k), omega_i = Phi(U~_i(i) U_i(j)^T) (its axis-angle
 *             difference, exact near angle pi where subtracting Phi vectors is not), the strain
 *             part additively: S~_i = S_i(j + k) + h_k (S~_i(i) - S_i(j)); D~_i = U~_i S~_i.
 *   eq. (9)   G p = d~: eq. 8 is linear in the local bone positions {F_b->r, t_b->r} of the
 *             non-reference bones, and row r of every D_i depends only on row r of the F_b and
 *             entry r of the t_b, through one matrix A (3 rows per key vertex, 4 (|B| - 1)
 *             columns) shared by the three rows: D_i[r, c] = sum_b sum_k F_b[r, k] (w_ib
 *             delta_kc + v_bar_ik dw_ib[c]) + t_b[r] dw_ib[c] (+ b_r's constant part). Solved
 *             for the change X from the input frame's own bones: min |A X - (D~ - D(j + k))|^2 +
 *             |Lambda^1/2 (X - X_lin)|^2, Lambda = 1e-6 diag(A^T A) (+ 1e-12 max diag(A^T A) for
 *             a column no key vertex sees), X_lin the linear blend's change (blend.c): a bone
 *             coordinate no key vertex's gradient determines (a translation that no weight
 *             gradient couples to b_r) follows the linear blend instead of jumping to the input
 *             frame's. A^T A + Lambda depends only on the rest pose, the weights and their
 *             gradients: factored once (dpotrf); per frame one dpotrs with 3 right-hand sides.
 *   affine    The paper keeps the solved F_b->r affine; the bone file, the glTF export, the merge
 *             of components (eq. 13) and the daemon's compact frames carry rotations, so we
 *             project F_b->r to its polar rotation U and keep where the bone's rest centroid c_b
 *             goes: t = F c_b + t_F - U c_b. Eq. 10 then as in blend.c.
 * Frames outside a window are the input's (X = 0). Per step: no allocation (scratch in the
 * walker's mdl__vblend); the graph's arrays are read-only after the build. */
#include "variations/variations.h"
#include "core/linalg.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GB_LAMBDA 1e-6

void mdl__gblend_fini(struct mdl_variations *g)
{
    free(g->key_v);
    free(g->key_x);
    free(g->kb_off);
    free(g->kb_bone);
    free(g->kb_w);
    free(g->kb_g);
    free(g->kD);
    free(g->kd);
    free(g->ucol);
    free(g->gN);
    free(g->glam);
    free(g->hramp);
    g->key_v = g->kb_off = g->kb_bone = g->ucol = NULL;
    g->key_x = g->kb_w = g->kb_g = g->kD = g->kd = g->gN = g->glam = g->hramp = NULL;
    g->nkey = g->nu = 0;
}

/* the coefficients of key vertex i's bone entry k: a[alpha][c], alpha 0..2 the row of F_b, 3 t_b */
static void coeffs(const struct mdl_variations *g, int i, int k, double a[4][3])
{
    const double *x = g->key_x + 3 * (size_t)i, *gr = g->kb_g + 3 * (size_t)k;
    double w = g->kb_w[k];
    for (int al = 0; al < 3; al++)
        for (int c = 0; c < 3; c++)
            a[al][c] = (al == c ? w : 0) + x[al] * gr[c];
    for (int c = 0; c < 3; c++)
        a[3][c] = gr[c];
}

static int factor(struct mdl_variations *g, char *err)
{
    int nu = g->nu;
    g->gN = mdl__calloc((size_t)nu * nu, sizeof *g->gN);
    g->glam = mdl__calloc((size_t)nu, sizeof *g->glam);
    if (!g->gN || !g->glam)
        return mdl__err(err, -ENOMEM, "variations: out of memory for eq. 9");
    double *N = g->gN;
    for (int i = 0; i < g->nkey; i++)
        for (int k = g->kb_off[i]; k < g->kb_off[i + 1]; k++) {
            int qa = g->ucol[g->kb_bone[k]];
            if (qa < 0)
                continue;
            double a[4][3];
            coeffs(g, i, k, a);
            for (int l = g->kb_off[i]; l < g->kb_off[i + 1]; l++) {
                int qb = g->ucol[g->kb_bone[l]];
                if (qb < 0)
                    continue;
                double bb[4][3];
                coeffs(g, i, l, bb);
                for (int al = 0; al < 4; al++)
                    for (int be = 0; be < 4; be++)
                        N[(qa + al) + (size_t)nu * (qb + be)] +=
                            a[al][0] * bb[be][0] + a[al][1] * bb[be][1] + a[al][2] * bb[be][2];
            }
        }
    double mx = 0;
    for (int q = 0; q < nu; q++)
        mx = fmax(mx, N[q + (size_t)nu * q]);
    if (!(mx > 0))
        return mdl__err(err, -EDOM, "variations: eq. 9 has no equations (no key vertex moves)");
    for (int q = 0; q < nu; q++) {
        g->glam[q] = GB_LAMBDA * N[q + (size_t)nu * q] + 1e-12 * mx;
        N[q + (size_t)nu * q] += g->glam[q];
    }
    return mdl_la_potrf(nu, N, nu, err);
}

/* the window's shape: h'' = 0, h_0 = 1, h_L = 0 (the tridiagonal system of the 1-D Poisson
 * blend, unknowns h_1 .. h_{L-1}) */
static int ramp(struct mdl_variations *g, char *err)
{
    int L = g->o.blend, n = L - 1, rc = 0;
    g->hramp = mdl__calloc((size_t)L + 1, sizeof *g->hramp);
    if (!g->hramp)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    g->hramp[0] = 1;
    g->hramp[L] = 0;
    if (n < 1)
        return 0;
    double *dl = mdl__calloc((size_t)n, sizeof *dl), *dg = mdl__calloc((size_t)n, sizeof *dg),
           *du = mdl__calloc((size_t)n, sizeof *du);
    if (!dl || !dg || !du) {
        rc = mdl__err(err, -ENOMEM, "variations: out of memory");
        goto out;
    }
    for (int k = 0; k < n; k++) {
        dl[k] = du[k] = 1;
        dg[k] = -2;
        g->hramp[1 + k] = 0;
    }
    g->hramp[1] -= g->hramp[0]; /* the known ends moved to the right-hand side */
    g->hramp[n] -= g->hramp[L];
    rc = mdl_la_gtsv(n, 1, dl, dg, du, g->hramp + 1, n, err);
    g->hramp[0] = 1;
out:
    free(dl);
    free(dg);
    free(du);
    return rc;
}

int mdl__gblend_build(struct mdl_variations *g, const mdl__vskin *s, const int *map, char *err)
{
    int rc = mdl__keys_select(g, s, map, err);
    if (!rc)
        rc = mdl__weight_grads(g, s, map, err);
    if (!rc)
        rc = mdl__defgrads(g, err);
    if (rc)
        return rc;
    g->ucol = mdl__calloc((size_t)g->nb, sizeof *g->ucol);
    if (!g->ucol)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    g->nu = 0;
    for (int b = 0; b < g->nb; b++) {
        g->ucol[b] = b == g->ref ? -1 : g->nu;
        g->nu += b == g->ref ? 0 : 4;
    }
    rc = factor(g, err);
    if (!rc)
        rc = ramp(g, err);
    return rc;
}

int mdl__gblend_solve(const struct mdl_variations *g, const double *R, const double *X0, double *X)
{
    int nu = g->nu;
    memset(X, 0, 3 * (size_t)nu * sizeof *X);
    for (int i = 0; i < g->nkey; i++) {
        const double *Ri = R + 9 * (size_t)i;
        for (int k = g->kb_off[i]; k < g->kb_off[i + 1]; k++) {
            int q = g->ucol[g->kb_bone[k]];
            if (q < 0)
                continue;
            double a[4][3];
            coeffs(g, i, k, a);
            for (int r = 0; r < 3; r++)
                for (int al = 0; al < 4; al++)
                    X[q + al + (size_t)nu * r] +=
                        a[al][0] * Ri[3 * r] + a[al][1] * Ri[3 * r + 1] + a[al][2] * Ri[3 * r + 2];
        }
    }
    if (X0)
        for (int r = 0; r < 3; r++)
            for (int q = 0; q < nu; q++)
                X[q + (size_t)nu * r] += g->glam[q] * X0[q + (size_t)nu * r];
    return mdl_la_potrs(nu, 3, g->gN, nu, X, nu, NULL);
}

/* the shown rotation and strain of key i at input frame c with the offsets at weight h */
static void shown(const mdl__vblend *b, const struct mdl_variations *v, int c, int i, double h,
                  double U[9], double S[9])
{
    const double *d = v->kd + 9 * ((size_t)c * v->nkey + i);
    double Uc[9];
    mdl__so3_exp(d, Uc);
    const double *ds = b->kdS + 6 * (size_t)i;
    double s6[6];
    for (int a = 0; a < 6; a++)
        s6[a] = d[3 + a] + h * ds[a];
    S[0] = s6[0], S[1] = S[3] = s6[1], S[2] = S[6] = s6[2];
    S[4] = s6[3], S[5] = S[7] = s6[4], S[8] = s6[5];
    if (h == 0) {
        memcpy(U, Uc, sizeof Uc);
        return;
    }
    double w[3] = {h * b->kom[3 * i], h * b->kom[3 * i + 1], h * b->kom[3 * i + 2]}, E[9];
    mdl__so3_exp(w, E);
    mdl__mat3_mul(E, Uc, U);
}

void mdl__gblend_splice(mdl__vblend *b, const struct mdl_variations *v, int i, int j, double h)
{
    for (int k = 0; k < v->nkey; k++) {
        double Ui[9], Si[9], Uj[9], Sj[9], E[9];
        shown(b, v, i, k, h, Ui, Si);
        const double *dj = v->kd + 9 * ((size_t)j * v->nkey + k);
        mdl__so3_exp(dj, Uj);
        (void)Sj;
        mdl__mat3_mul_t(Ui, Uj, E);
        mdl__so3_log(E, b->kom + 3 * k);
        const double s6[6] = {Si[0], Si[1], Si[2], Si[4], Si[5], Si[8]};
        for (int a = 0; a < 6; a++)
            b->kdS[6 * k + a] = s6[a] - dj[3 + a];
    }
}

void mdl__gblend_local(const mdl__vblend *b, const struct mdl_variations *v, int c, double h,
                       double *L)
{
    int nu = v->nu;
    for (int i = 0; i < v->nkey; i++) {
        double U[9], S[9], D[9];
        shown(b, v, c, i, h, U, S);
        mdl__mat3_mul(U, S, D);
        const double *D0 = v->kD + 9 * ((size_t)c * v->nkey + i);
        for (int a = 0; a < 9; a++)
            b->R[9 * i + a] = D[a] - D0[a];
    }
    const double *LR = v->LR + 9 * (size_t)c * v->nb, *Lt = v->Lt + 3 * (size_t)c * v->nb;
    for (int k = 0; k < v->nb; k++) {
        int q = v->ucol[k];
        if (q < 0)
            continue;
        const double *M = L + 12 * (size_t)k;
        for (int r = 0; r < 3; r++) {
            for (int a = 0; a < 3; a++)
                b->X0[q + a + (size_t)nu * r] = M[3 * r + a] - LR[9 * k + 3 * r + a];
            b->X0[q + 3 + (size_t)nu * r] = M[9 + r] - Lt[3 * k + r];
        }
    }
    if (mdl__gblend_solve(v, b->R, b->X0, b->X))
        return; /* a factor that solved at analysis does not fail: keep the linear blend's */
    for (int k = 0; k < v->nb; k++) {
        int q = v->ucol[k];
        if (q < 0)
            continue;
        double F[9], t[3], U[9], S[9], x[3];
        const double *cc = v->centre + 3 * (size_t)k;
        for (int r = 0; r < 3; r++) {
            for (int a = 0; a < 3; a++)
                F[3 * r + a] = LR[9 * k + 3 * r + a] + b->X[q + a + (size_t)nu * r];
            t[r] = Lt[3 * k + r] + b->X[q + 3 + (size_t)nu * r];
        }
        mdl__polar(F, U, S);
        double *M = L + 12 * (size_t)k;
        for (int r = 0; r < 3; r++)
            x[r] = F[3 * r] * cc[0] + F[3 * r + 1] * cc[1] + F[3 * r + 2] * cc[2] + t[r];
        memcpy(M, U, sizeof U);
        for (int r = 0; r < 3; r++)
            M[9 + r] = x[r] - (U[3 * r] * cc[0] + U[3 * r + 1] * cc[1] + U[3 * r + 2] * cc[2]);
    }
}
