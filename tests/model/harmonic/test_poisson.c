/* test_poisson.c - eq. 3-4 (model/harmonic/poisson.c) and the whole deformer (deform.c):
 *   - Poisson of the unchanged mesh (every R_t = I) returns it (1e-6 m);
 *   - a rigid rotation of all constraints rotates the whole mesh rigidly (1e-6 m): the harmonic
 *     field is that rotation everywhere, and so is every triangle's;
 *   - the deformer allocates nothing per frame (mallinfo2, plain build);
 *   - with the stretch (beyond the paper, eval --stretch): one R and one U = diag(1.3, 0.8, 1.1) at
 *     every group gives X = R U x_rest (1e-6 m: a constant gradient is reproduced exactly); U = I
 *     gives what the rotation-only deformer gives for the same (varied) rotations (1e-10 m); the
 *     stretch path allocates nothing; a deformer made without the stretch refuses it. */
#include "harmonic/harmonic_internal.h"
#include "core/laplacian.h"
#include "core/rigid.h"
#include "test.h"
#include "htube.h"

#include <malloc.h>
#include <string.h>
#include <errno.h>

int main(void)
{
    mdl_mesh *m = htube_create(25, 10);
    int nv = m->nv, nf = m->nf;
    /* bend it a little so it is not flat along any axis */
    for (int v = 0; v < nv; v++)
        m->V[3 * v + 2] += 0.2f * m->V[3 * v] * m->V[3 * v];
    double *w = calloc(3 * (size_t)nf, sizeof *w), *Rt = calloc(9 * (size_t)nf, sizeof *Rt);
    double *X = calloc(3 * (size_t)nv, sizeof *X);
    mdl__cot_weights(m->V, m->F, nf, w);
    char err[MDL_ERR_LEN] = "";
    mdl__poisson p;
    ASSERT_OK(mdl__poisson_precompute(&p, m->V, m->F, nf, nv, w, err), err);
    ASSERT_INT_EQ(p.nanchor, 1);
    for (int t = 0; t < nf; t++)
        Rt[9 * t] = Rt[9 * t + 4] = Rt[9 * t + 8] = 1;
    ASSERT_OK(mdl__poisson_solve(&p, Rt, X), "solve");
    for (int i = 0; i < 3 * nv; i++)
        ASSERT_NEAR_I(X[i], m->V[i], 1e-6, i);
    mdl__poisson_fini(&p);

    /* the deformer with 40 automatic correspondences, all rotated by one R */
    struct mdl_harmonic *h = calloc(1, sizeof *h);
    h->nv = nv;
    h->nf = nf;
    ASSERT_OK(mdl__corr_auto_k(h, m->V, m->F, nf, nv, 40, 0, err), err);
    ASSERT_INT_EQ(h->ngroups, 40); /* 40 patches */
    ASSERT(h->ncorr >= 40);
    mdl__hdeform d;
    ASSERT_OK(mdl__hdeform_init(&d, h, m->V, m->F, err), err);
    double q[4] = {0.8, 0.3, -0.4, 0.2}, R[9];
    mdl__qnorm(q);
    mdl__quat_to_mat(q, R);
    double *qg = calloc(4 * (size_t)h->ngroups, sizeof *qg);
    for (int g = 0; g < h->ngroups; g++)
        for (int c = 0; c < 4; c++)
            qg[4 * g + c] = (g % 2 ? -1 : 1) * q[c]; /* either sign: the same rotation */
    ASSERT_OK(mdl__hdeform_run(&d, qg), "deform");
    double maxe = 0;
    for (int v = 0; v < nv; v++)
        for (int c = 0; c < 3; c++) {
            double y = R[3 * c] * m->V[3 * v] + R[3 * c + 1] * m->V[3 * v + 1] + R[3 * c + 2] * m->V[3 * v + 2];
            double e = fabs(d.X[3 * v + c] - y);
            maxe = e > maxe ? e : maxe;
            ASSERT_NEAR_I(d.X[3 * v + c], y, 1e-6, 3 * v + c);
        }
    printf("rigid rotation: max deviation %.3g m\n", maxe);
    /* per frame: no allocation */
    struct mallinfo2 before = mallinfo2();
    for (int it = 0; it < 20; it++) {
        qg[0] = cos(0.1 * it);
        qg[1] = sin(0.1 * it);
        ASSERT_OK(mdl__hdeform_run(&d, qg), "deform");
    }
    struct mallinfo2 after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    ASSERT_INT_EQ(after.hblkhd, before.hblkhd);

    /* the stretch: a constant R U everywhere is reproduced exactly */
    mdl__hdeform ds;
    ASSERT_OK(mdl__hdeform_init_mode(&ds, h, m->V, m->F, 1, err), err);
    double *ug = calloc(6 * (size_t)h->ngroups, sizeof *ug);
    const double u0[6] = {1.3, 0, 0, 0.8, 0, 1.1};
    for (int g = 0; g < h->ngroups; g++) {
        for (int c = 0; c < 4; c++)
            qg[4 * g + c] = q[c];
        memcpy(ug + 6 * g, u0, sizeof u0);
    }
    ASSERT_INT_EQ(mdl__hdeform_run_stretch(&d, qg, ug), -EINVAL); /* made without it */
    ASSERT_OK(mdl__hdeform_run_stretch(&ds, qg, ug), "deform with stretch");
    maxe = 0;
    for (int v = 0; v < nv; v++)
        for (int c = 0; c < 3; c++) {
            double y = R[3 * c] * u0[0] * m->V[3 * v] + R[3 * c + 1] * u0[3] * m->V[3 * v + 1] +
                       R[3 * c + 2] * u0[5] * m->V[3 * v + 2];
            double e = fabs(ds.X[3 * v + c] - y);
            maxe = e > maxe ? e : maxe;
            ASSERT_NEAR_I(ds.X[3 * v + c], y, 1e-6, 3 * v + c);
        }
    printf("constant R U: max deviation %.3g m\n", maxe);
    /* U = I: bit for bit the rotation-only deformer, for rotations that vary over the groups */
    mdl__hdeform_reset(&d);
    mdl__hdeform_reset(&ds);
    for (int g = 0; g < h->ngroups; g++) {
        double a = 0.05 * g;
        qg[4 * g] = cos(a), qg[4 * g + 1] = sin(a) * 0.6, qg[4 * g + 2] = sin(a) * 0.8, qg[4 * g + 3] = 0;
        const double id[6] = {1, 0, 0, 1, 0, 1};
        memcpy(ug + 6 * g, id, sizeof id);
    }
    ASSERT_OK(mdl__hdeform_run(&d, qg), "deform");
    ASSERT_OK(mdl__hdeform_run_stretch(&ds, qg, ug), "deform with stretch");
    double dmax = 0;
    for (int i = 0; i < 3 * nv; i++)
        dmax = fmax(dmax, fabs(d.X[i] - ds.X[i]));
    printf("U = I against rotation-only: max difference %.3g m\n", dmax);
    ASSERT(dmax < 1e-10); /* the harmonic U of constant I is I to rounding */
    double spread = 0; /* and the rotations did vary: not a rigid copy of the rest */
    for (int v = 0; v < nv; v++)
        spread = fmax(spread, fabs(d.X[3 * v + 2] - m->V[3 * v + 2]));
    ASSERT(spread > 0.05);
    before = mallinfo2();
    for (int it = 0; it < 20; it++) {
        ug[0] = 1 + 0.01 * it;
        ASSERT_OK(mdl__hdeform_run_stretch(&ds, qg, ug), "deform with stretch");
    }
    after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    ASSERT_INT_EQ(after.hblkhd, before.hblkhd);
    free(ug);
    mdl__hdeform_fini(&ds);
    mdl__hdeform_fini(&d);
    mdl__harmonic_free(h);

    /* rings:K on a straight tube: every ring is a whole cross-section (at least `around`
     * triangles) and thin along the axis (within one ring spacing of its seed) */
    mdl_mesh *st = htube_create(25, 10);
    h = calloc(1, sizeof *h);
    h->nv = nv;
    h->nf = nf;
    ASSERT_OK(mdl__corr_auto_k(h, st->V, st->F, nf, nv, 5, 1, err), err);
    ASSERT_INT_EQ(h->ngroups, 5);
    int *cnt = calloc(5, sizeof *cnt);
    for (int i = 0; i < h->ncorr; i++) {
        const uint32_t *f = st->F + 3 * h->corr_tri[i], *f0 = st->F + 3 * h->corr_tri[h->corr_group[i]];
        double x = (st->V[3 * f[0]] + st->V[3 * f[1]] + st->V[3 * f[2]]) / 3,
               x0 = (st->V[3 * f0[0]] + st->V[3 * f0[1]] + st->V[3 * f0[2]]) / 3;
        ASSERT_LE_I(fabs(x - x0), 2.0 / 24 + 1e-6, i); /* one ring spacing of the tube */
        cnt[h->corr_group[i]]++;
    }
    for (int g = 0; g < 5; g++)
        ASSERT_INT_GE(cnt[g], 10);
    free(cnt);
    mdl__harmonic_free(h);
    mdl_mesh_destroy(st);
    free(w), free(Rt), free(X), free(qg);
    mdl_mesh_destroy(m);
    puts("poisson: ok");
    return 0;
}
