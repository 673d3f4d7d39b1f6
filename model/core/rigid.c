/* rigid.c - absolute orientation by unit quaternions [Horn 1987] and the aligned error metric.
 * See rigid.h for the equations. */
#include "core/rigid.h"
#include "model.h"

#include <math.h>
#include <string.h>

/* Largest-eigenvalue eigenvector of a symmetric 4x4 matrix by cyclic Jacobi rotations. */
static void sym4_max_eigvec(const double Nin[16], double v[4])
{
    double a[4][4], V[4][4];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            a[i][j] = Nin[4 * i + j];
            V[i][j] = i == j;
        }
    for (int sweep = 0; sweep < 32; sweep++) {
        double off = 0, diag = 0;
        for (int i = 0; i < 4; i++) {
            diag += a[i][i] * a[i][i];
            for (int j = i + 1; j < 4; j++)
                off += a[i][j] * a[i][j];
        }
        if (off <= 1e-30 * (diag + 1e-300))
            break;
        for (int p = 0; p < 3; p++)
            for (int q = p + 1; q < 4; q++) {
                if (fabs(a[p][q]) < 1e-300)
                    continue;
                double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 4; k++) { /* columns p, q */
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 4; k++) { /* rows p, q */
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 4; k++) {
                    double vkp = V[k][p], vkq = V[k][q];
                    V[k][p] = c * vkp - s * vkq;
                    V[k][q] = s * vkp + c * vkq;
                }
            }
    }
    int best = 0;
    for (int i = 1; i < 4; i++)
        if (a[i][i] > a[best][best])
            best = i;
    for (int k = 0; k < 4; k++)
        v[k] = V[k][best];
}

void mdl__quat_to_mat(const double q[4], double R[9])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    double n = w * w + x * x + y * y + z * z;
    double s = n > 0 ? 2 / n : 0;
    R[0] = 1 - s * (y * y + z * z);
    R[1] = s * (x * y - w * z);
    R[2] = s * (x * z + w * y);
    R[3] = s * (x * y + w * z);
    R[4] = 1 - s * (x * x + z * z);
    R[5] = s * (y * z - w * x);
    R[6] = s * (x * z - w * y);
    R[7] = s * (y * z + w * x);
    R[8] = 1 - s * (x * x + y * y);
}

void mdl__mat_to_quat(const double R[9], double q[4])
{
    /* Horn's matrix with S = R^T gives the quaternion of R robustly for any trace. */
    double S[9] = {R[0], R[3], R[6], R[1], R[4], R[7], R[2], R[5], R[8]};
    double tmp[9];
    mdl__rot_from_cov(S, q, tmp);
}

void mdl__rot_from_cov(const double S[9], double q[4], double R[9])
{
    double Sxx = S[0], Sxy = S[1], Sxz = S[2];
    double Syx = S[3], Syy = S[4], Syz = S[5];
    double Szx = S[6], Szy = S[7], Szz = S[8];
    double N[16] = {
        Sxx + Syy + Szz, Syz - Szy,        Szx - Sxz,        Sxy - Syx,
        Syz - Szy,       Sxx - Syy - Szz,  Sxy + Syx,        Szx + Sxz,
        Szx - Sxz,       Sxy + Syx,        -Sxx + Syy - Szz, Syz + Szy,
        Sxy - Syx,       Szx + Sxz,        Syz + Szy,        -Sxx - Syy + Szz,
    };
    sym4_max_eigvec(N, q);
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(n > 0)) {
        q[0] = 1;
        q[1] = q[2] = q[3] = 0;
        n = 1;
    }
    for (int k = 0; k < 4; k++)
        q[k] /= n;
    if (q[0] < 0)
        for (int k = 0; k < 4; k++)
            q[k] = -q[k];
    mdl__quat_to_mat(q, R);
}

int mdl__rot_polar(const double S[9], double R[9])
{
    double q[4];
    /* maximising tr(R S) = tr(R^T S^T): R is the orthogonal polar factor of A = S^T, found by
     * Newton's iteration X <- (g X + X^{-T} / g) / 2 with Higham's scaling
     * g = (|X^{-1}|_F / |X|_F)^{1/2}, which converges quadratically from X = A whenever A is
     * non-singular. A reflection (det A <= 0) or no convergence falls back to Horn. */
    double X[9] = {S[0], S[3], S[6], S[1], S[4], S[7], S[2], S[5], S[8]};
    double det = X[0] * (X[4] * X[8] - X[5] * X[7]) - X[1] * (X[3] * X[8] - X[5] * X[6]) +
                 X[2] * (X[3] * X[7] - X[4] * X[6]);
    double fro = 0;
    for (int k = 0; k < 9; k++)
        fro += X[k] * X[k];
    if (!(det > 1e-12 * fro * sqrt(fro))) {
        mdl__rot_from_cov(S, q, R);
        return -1;
    }
    for (int it = 0; it < 30; it++) {
        /* cofactor matrix C: X^{-T} = C / det */
        double C[9] = {X[4] * X[8] - X[5] * X[7], X[5] * X[6] - X[3] * X[8], X[3] * X[7] - X[4] * X[6],
                       X[2] * X[7] - X[1] * X[8], X[0] * X[8] - X[2] * X[6], X[1] * X[6] - X[0] * X[7],
                       X[1] * X[5] - X[2] * X[4], X[2] * X[3] - X[0] * X[5], X[0] * X[4] - X[1] * X[3]};
        double d = X[0] * C[0] + X[1] * C[1] + X[2] * C[2];
        if (!(d > 0))
            break;
        double fx = 0, fi = 0;
        /* unrolled (GCC leaves these 9-step loops rolled at -O2), so X and C stay in registers */
#pragma GCC unroll 9
        for (int k = 0; k < 9; k++) {
            fx += X[k] * X[k];
            fi += C[k] * C[k];
        }
        fi /= d * d;
        double g = sqrt(sqrt(fi / fx)), h = 1 / (d * g);
        double change = 0;
#pragma GCC unroll 9
        for (int k = 0; k < 9; k++) {
            double nx = 0.5 * (g * X[k] + h * C[k]);
            change += (nx - X[k]) * (nx - X[k]);
            X[k] = nx;
        }
        /* quadratic convergence: a step of size e leaves an error of about e^2 / 2, so a step
         * below 1e-8 leaves X orthogonal to rounding */
        if (change < 1e-16) {
            memcpy(R, X, sizeof X);
            return it + 1;
        }
    }
    mdl__rot_from_cov(S, q, R);
    return -1;
}

double mdl__kabsch(const double *y, const double *x, const double *w, int n, double R[9],
                   double t[3])
{
    double cy[3] = {0}, cx[3] = {0}, ws = 0;
    for (int i = 0; i < n; i++) {
        double wi = w ? w[i] : 1;
        for (int k = 0; k < 3; k++) {
            cy[k] += wi * y[3 * i + k];
            cx[k] += wi * x[3 * i + k];
        }
        ws += wi;
    }
    if (!(ws > 0)) {
        memset(R, 0, 9 * sizeof *R);
        R[0] = R[4] = R[8] = 1;
        t[0] = t[1] = t[2] = 0;
        return 0;
    }
    for (int k = 0; k < 3; k++) {
        cy[k] /= ws;
        cx[k] /= ws;
    }
    double S[9] = {0};
    for (int i = 0; i < n; i++) {
        double wi = w ? w[i] : 1;
        double a[3] = {y[3 * i] - cy[0], y[3 * i + 1] - cy[1], y[3 * i + 2] - cy[2]};
        double b[3] = {x[3 * i] - cx[0], x[3 * i + 1] - cx[1], x[3 * i + 2] - cx[2]};
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                S[3 * r + c] += wi * a[r] * b[c];
    }
    double q[4];
    mdl__rot_from_cov(S, q, R);
    for (int k = 0; k < 3; k++)
        t[k] = cx[k] - (R[3 * k] * cy[0] + R[3 * k + 1] * cy[1] + R[3 * k + 2] * cy[2]);
    double e = 0;
    for (int i = 0; i < n; i++) {
        double wi = w ? w[i] : 1;
        for (int k = 0; k < 3; k++) {
            double p = R[3 * k] * y[3 * i] + R[3 * k + 1] * y[3 * i + 1] + R[3 * k + 2] * y[3 * i + 2] + t[k];
            double d = p - x[3 * i + k];
            e += wi * d * d;
        }
    }
    return sqrt(e / ws);
}

/* Best rigid alignment of A onto B (Kabsch over all points), then per-point distances. */
double mdl_rigid_aligned_error(const float *A, const float *B, int n, float *dist)
{
    if (n <= 0)
        return 0;
    double ca[3] = {0}, cb[3] = {0};
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            ca[k] += A[3 * i + k];
            cb[k] += B[3 * i + k];
        }
    for (int k = 0; k < 3; k++) {
        ca[k] /= n;
        cb[k] /= n;
    }
    double S[9] = {0};
    for (int i = 0; i < n; i++) {
        double a[3] = {A[3 * i] - ca[0], A[3 * i + 1] - ca[1], A[3 * i + 2] - ca[2]};
        double b[3] = {B[3 * i] - cb[0], B[3 * i + 1] - cb[1], B[3 * i + 2] - cb[2]};
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                S[3 * r + c] += a[r] * b[c];
    }
    double q[4], R[9];
    mdl__rot_from_cov(S, q, R);
    double sum = 0;
    for (int i = 0; i < n; i++) {
        double a[3] = {A[3 * i] - ca[0], A[3 * i + 1] - ca[1], A[3 * i + 2] - ca[2]};
        double d2 = 0;
        for (int k = 0; k < 3; k++) {
            double p = R[3 * k] * a[0] + R[3 * k + 1] * a[1] + R[3 * k + 2] * a[2] + cb[k];
            double d = p - B[3 * i + k];
            d2 += d * d;
        }
        double d = sqrt(d2);
        if (dist)
            dist[i] = (float)d;
        sum += d;
    }
    return sum / n;
}
