/* test_merge.c - Zheng 2013 Sec. 4.2 (model/variations/merge.c): the polar decomposition
 * recovers a rotation and a stretch; eq. 14 moves a component rigidly so that its bones keep
 * their pose relative to the cut node while the cut node follows the anchor, and the anchor's
 * bones are untouched; eq. 13 averages the two stretches of the cut node and keeps the anchor's
 * rotation and translation; D_C of eq. 12 is 0 for rigid bones (threshold 0.05 x 3) and the sum
 * of squared stretch differences otherwise. */
#include "model.h"
#include "test.h"
#include "variations/variations.h"
#include "fit.h"

static uint64_t rng = 777;
static double uni(void)
{
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng >> 11) / 9007199254740992.0;
}

static void random_rigid(double M[12])
{
    double w[3] = {4 * uni() - 2, 4 * uni() - 2, 4 * uni() - 2};
    mdl__so3_exp(w, M);
    for (int a = 0; a < 3; a++)
        M[9 + a] = 2 * uni() - 1;
}

int main(void)
{
    /* polar: F = R S */
    for (int trial = 0; trial < 50; trial++) {
        double R[12], S[9], F[9], U[9], S2[9];
        random_rigid(R);
        double a[9];
        for (int k = 0; k < 9; k++)
            a[k] = 0.6 * uni() - 0.3;
        for (int r = 0; r < 3; r++) /* S = I + sym(a) */
            for (int c = 0; c < 3; c++)
                S[3 * r + c] = (r == c) + 0.5 * (a[3 * r + c] + a[3 * c + r]);
        mdl__mat3_mul(R, S, F);
        mdl__polar(F, U, S2);
        for (int k = 0; k < 9; k++) {
            ASSERT_NEAR(U[k], R[k], 1e-9);
            ASSERT_NEAR(S2[k], S[k], 1e-9);
        }
    }

    /* eq. 14 with rigid bones: anchor of 4 bones, a component {1, 2, 3} cut at bone 1 */
    int bones[3] = {1, 2, 3};
    mdl__vcomp c = {.g = NULL, .nb = 3, .bones = bones, .parent = 0, .cut = 1, .cut_local = 0};
    for (int trial = 0; trial < 50; trial++) {
        double T[4 * 12], T0[4 * 12], Tc[3 * 12];
        for (int b = 0; b < 4; b++)
            random_rigid(T + 12 * b);
        for (int b = 0; b < 3; b++)
            random_rigid(Tc + 12 * b);
        memcpy(T0, T, sizeof T);
        mdl__merge_frame(&c, Tc, T);
        /* the anchor's bone 0 untouched, the cut node kept where the anchor had it */
        for (int k = 0; k < 12; k++) {
            ASSERT_NEAR(T[k], T0[k], 0);
            ASSERT_NEAR(T[12 + k], T0[12 + k], 1e-12);
        }
        /* the component's bones relative to the cut node as in the component */
        for (int b = 1; b < 3; b++) {
            double want[12], got[12];
            vt_relative(Tc, Tc + 12 * b, want);
            vt_relative(T + 12, T + 12 * bones[b], got);
            for (int k = 0; k < 12; k++)
                ASSERT_NEAR(got[k], want[k], 1e-9);
        }
        /* D_C: rigid bones have identity stretches */
        double thr = 0;
        double dc = mdl__merge_cost(T0 + 12, 0, Tc, 0, 3, &thr);
        ASSERT_NEAR(dc, 0, 1e-18);
        ASSERT_NEAR(thr, 0.05 * 3, 1e-9);
    }

    /* eq. 13 with stretches: F_c = 1/2 U_i (S_i + S_j), t_c = t_i */
    {
        double T[4 * 12] = {0}, Tc[3 * 12] = {0}, R[12], Q[12];
        random_rigid(R);
        random_rigid(Q);
        double Si[9] = {1.2, 0.1, 0, 0.1, 0.9, 0, 0, 0, 1}, Sj[9] = {0.8, 0, 0, 0, 1.1, 0.05, 0, 0.05, 1};
        mdl__mat3_mul(R, Si, T + 12);
        memcpy(T + 12 + 9, R + 9, 3 * sizeof(double));
        mdl__mat3_mul(Q, Sj, Tc);
        memcpy(Tc + 9, Q + 9, 3 * sizeof(double));
        for (int b = 1; b < 3; b++)
            random_rigid(Tc + 12 * b);
        double Fi[12];
        memcpy(Fi, T + 12, sizeof Fi);
        double thr = 0, dc = mdl__merge_cost(Fi, 0, Tc, 0, 1, &thr), want = 0, mx = 0, ni = 0, nj = 0;
        for (int k = 0; k < 9; k++) {
            want += (Si[k] - Sj[k]) * (Si[k] - Sj[k]);
            ni += Si[k] * Si[k];
            nj += Sj[k] * Sj[k];
        }
        mx = ni > nj ? ni : nj;
        ASSERT_NEAR(dc, want, 1e-9);
        ASSERT_NEAR(thr, 0.05 * mx, 1e-9);
        mdl__merge_frame(&c, Tc, T);
        double Sm[9], F[9];
        for (int k = 0; k < 9; k++)
            Sm[k] = 0.5 * (Si[k] + Sj[k]);
        mdl__mat3_mul(R, Sm, F);
        for (int k = 0; k < 9; k++)
            ASSERT_NEAR(T[12 + k], F[k], 1e-9);
        for (int a = 0; a < 3; a++)
            ASSERT_NEAR(T[12 + 9 + a], R[9 + a], 0);
        /* the rest of the component moved by U_i U_j^T = R Q^T */
        double G[9], Fb[9];
        mdl__mat3_mul_t(R, Q, G);
        mdl__mat3_mul(G, Tc + 24, Fb);
        for (int k = 0; k < 9; k++)
            ASSERT_NEAR(T[36 + k], Fb[k], 1e-9);
    }
    printf("merge: ok\n");
    return 0;
}
