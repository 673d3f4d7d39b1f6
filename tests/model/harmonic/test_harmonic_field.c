/* test_harmonic_field.c - eq. 2 (model/harmonic/harmonic_field.c): on a tube with the first ring held
 * at Q = (1, 0, 0, 0) and the last at (0, 1, 0, 0), the interpolated w falls and q1 rises strictly
 * monotonically from ring to ring, and every ring is uniform (the tube is symmetric about its axis). */
#include "harmonic/harmonic_internal.h"
#include "core/laplacian.h"
#include "test.h"
#include "htube.h"

int main(void)
{
    int rings = 30, around = 12;
    mdl_mesh *m = htube_create(rings, around);
    double *w = calloc(3 * (size_t)m->nf, sizeof *w);
    mdl__cot_weights(m->V, m->F, m->nf, w);
    int ncv = 2 * around, *cv = calloc((size_t)ncv, sizeof *cv);
    double *Sc = calloc(4 * (size_t)ncv, sizeof *Sc), *S = calloc(4 * (size_t)m->nv, sizeof *S);
    for (int a = 0; a < around; a++) {
        cv[a] = a;
        cv[around + a] = (rings - 1) * around + a;
        Sc[4 * a] = 1;
        Sc[4 * (around + a) + 1] = 1;
    }
    char err[MDL_ERR_LEN] = "";
    mdl__hfield h;
    ASSERT_OK(mdl__hfield_precompute(&h, m->F, m->nf, m->nv, w, cv, ncv, 4, err), err);
    ASSERT_INT_EQ(h.nfree, m->nv - ncv);
    ASSERT_OK(mdl__hfield_solve(&h, Sc, S), "solve");
    double prev_w = 2, prev_x = -1;
    for (int r = 0; r < rings; r++) {
        const double *q0 = S + 4 * (size_t)(r * around);
        for (int a = 1; a < around; a++) {
            ASSERT_NEAR_I(S[4 * (size_t)(r * around + a)], q0[0], 1e-9, r * around + a);
            ASSERT_NEAR_I(S[4 * (size_t)(r * around + a) + 1], q0[1], 1e-9, r * around + a);
        }
        if (r > 0 && !(q0[0] < prev_w && q0[1] > prev_x)) {
            fprintf(stderr, "ring %d: w %.9g after %.9g, q1 %.9g after %.9g: not monotone\n", r, q0[0],
                    prev_w, q0[1], prev_x);
            return 1;
        }
        ASSERT_NEAR_I(q0[0] * q0[0] + q0[1] * q0[1], 1, 1e-12, r); /* normalised */
        prev_w = q0[0];
        prev_x = q0[1];
    }
    mdl__hfield_fini(&h);
    /* a part without a constraint is refused */
    mdl__hfield h2;
    ASSERT_INT_EQ(mdl__hfield_precompute(&h2, m->F, m->nf, m->nv, w, cv, 0, 4, err), MDL_ENUMERIC);
    free(w), free(cv), free(Sc), free(S);
    mdl_mesh_destroy(m);
    puts("harmonic_field: ok");
    return 0;
}
