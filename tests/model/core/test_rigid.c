/* test_rigid.c - absolute orientation recovers known rigid transforms; quaternions round-trip;
 * the aligned error metric ignores rigid motion and measures everything else. */
#include "core/rigid.h"
#include "model.h"
#include "test.h"

static void rot_axis_angle(const double ax[3], double ang, double R[9])
{
    double n = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    double q[4] = {cos(ang / 2), sin(ang / 2) * ax[0] / n, sin(ang / 2) * ax[1] / n, sin(ang / 2) * ax[2] / n};
    mdl__quat_to_mat(q, R);
}

int main(void)
{
    /* a known transform of a random point cloud is recovered exactly */
    enum { N = 50 };
    double y[3 * N], x[3 * N], R[9], Rt[9], t[3], tt[3] = {0.3, -1.2, 2.5};
    const double ax[3] = {0.2, -0.7, 0.4};
    uint32_t st = 12345;
    for (int i = 0; i < 3 * N; i++) {
        st = st * 1103515245u + 12345u;
        y[i] = (double)(st >> 8) / (1 << 24) - 0.5;
    }
    for (int trial = 0; trial < 8; trial++) {
        double ang = -3.0 + 0.85 * trial; /* includes angles beyond pi/2 and near pi */
        rot_axis_angle(ax, ang, Rt);
        for (int i = 0; i < N; i++)
            for (int r = 0; r < 3; r++)
                x[3 * i + r] = Rt[3 * r] * y[3 * i] + Rt[3 * r + 1] * y[3 * i + 1] + Rt[3 * r + 2] * y[3 * i + 2] + tt[r];
        double rms = mdl__kabsch(y, x, NULL, N, R, t);
        ASSERT_NEAR(rms, 0, 1e-9);
        for (int k = 0; k < 9; k++)
            ASSERT_NEAR_I(R[k], Rt[k], 1e-9, k);
        for (int k = 0; k < 3; k++)
            ASSERT_NEAR_I(t[k], tt[k], 1e-9, k);
        /* quaternion round trip */
        double q[4], R2[9];
        mdl__mat_to_quat(Rt, q);
        mdl__quat_to_mat(q, R2);
        for (int k = 0; k < 9; k++)
            ASSERT_NEAR_I(R2[k], Rt[k], 1e-9, k);
    }
    /* a rotation prior decides the rotation about the axis of collinear points */
    {
        double S[9] = {0}, q[4], Rp[9], Rout[9];
        rot_axis_angle((double[3]){1, 0, 0}, 0.7, Rp);
        /* points along x only: S = sum y x^T has only the xx entry */
        S[0] = 2.0;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                S[3 * r + c] += 0.01 * Rp[3 * c + r];
        mdl__rot_from_cov(S, q, Rout);
        for (int k = 0; k < 9; k++)
            ASSERT_NEAR_I(Rout[k], Rp[k], 1e-6, k);
    }
    /* the aligned error is zero for a rigidly moved copy and equals a known offset otherwise */
    {
        float A[3 * N], B[3 * N];
        for (int i = 0; i < N; i++)
            for (int r = 0; r < 3; r++) {
                A[3 * i + r] = (float)y[3 * i + r];
                B[3 * i + r] = (float)x[3 * i + r];
            }
        ASSERT_NEAR(mdl_rigid_aligned_error(A, B, N, NULL), 0, 1e-5);
        /* scaling about the centroid cannot be removed by a rigid motion */
        double c[3] = {0};
        for (int i = 0; i < N; i++)
            for (int r = 0; r < 3; r++)
                c[r] += A[3 * i + r] / N;
        double expect = 0;
        for (int i = 0; i < N; i++) {
            double d = 0;
            for (int r = 0; r < 3; r++) {
                B[3 * i + r] = (float)(c[r] + 1.1 * (A[3 * i + r] - c[r]));
                d += (B[3 * i + r] - A[3 * i + r]) * (B[3 * i + r] - A[3 * i + r]);
            }
            expect += sqrt(d) / N;
        }
        float dist[N];
        ASSERT_NEAR(mdl_rigid_aligned_error(A, B, N, dist), expect, 1e-5);
    }
    printf("rigid: ok\n");
    return 0;
}
