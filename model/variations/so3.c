/* so3.c - Phi of Zheng 2013 Sec. 3.2: the matrix logarithm of a rotation as a 3 x 1 axis-angle
 * vector (the Lie algebra so(3)), and the exponential back; small 3x3 products. Through the unit
 * quaternion (rigid.c), which stays exact near angle 0 and near pi, where the trace formula
 * acos((tr R - 1) / 2) loses its axis. Row-major 3x3, as in rigid.h. */
#include "variations/variations.h"
#include "core/rigid.h"

#include <math.h>

void mdl__so3_log(const double R[9], double w[3])
{
    double q[4];
    mdl__mat_to_quat(R, q);
    if (q[0] < 0)
        for (int c = 0; c < 4; c++)
            q[c] = -q[c];
    double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    /* angle = 2 atan2(s, w); w = angle * axis, axis = v / s; for small s, angle / s -> 2 / w */
    double k = s > 1e-12 ? 2 * atan2(s, q[0]) / s : 2 / q[0];
    for (int c = 0; c < 3; c++)
        w[c] = k * q[1 + c];
}

void mdl__so3_exp(const double w[3], double R[9])
{
    double th = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double q[4];
    q[0] = cos(th / 2);
    double k = th > 1e-12 ? sin(th / 2) / th : 0.5;
    for (int c = 0; c < 3; c++)
        q[1 + c] = k * w[c];
    mdl__quat_to_mat(q, R);
}

void mdl__mat3_mul(const double A[9], const double B[9], double C[9])
{
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
}

void mdl__mat3_mul_t(const double A[9], const double B[9], double C[9])
{
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            C[3 * r + c] =
                A[3 * r] * B[3 * c] + A[3 * r + 1] * B[3 * c + 1] + A[3 * r + 2] * B[3 * c + 2];
}
