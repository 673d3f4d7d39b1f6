/* segrot.h - shared by test_bvh.c and test_asf_amc.c: a skeleton reader's joint rotations
 * (mdl_markers.rot, parent) reproduce its positions. For every marker i with a parent p and every
 * frame f: p_i(f) - p_p(f) = R_i(f) (p_i - p_p)(rest), within tol (m); R_i(f) a unit quaternion.
 * Returns the largest error. */
#ifndef MESHSTEER_TEST_SEGROT_H
#define MESHSTEER_TEST_SEGROT_H

#include "model.h"
#include "test.h"

#include <math.h>

static double segrot_check(const mdl_markers *m, const mdl_markers *rest, double tol)
{
    ASSERT(m->rot && m->parent && rest->rot && rest->parent);
    ASSERT_INT_EQ(m->count, rest->count);
    double worst = 0;
    for (int f = 0; f < m->frames; f++)
        for (int i = 0; i < m->count; i++) {
            int p = m->parent[i];
            ASSERT_INT_EQ(p, rest->parent[i]);
            const float *q = m->rot + 4 * ((size_t)f * m->count + i);
            double n = (double)q[0] * q[0] + (double)q[1] * q[1] + (double)q[2] * q[2] + (double)q[3] * q[3];
            ASSERT_NEAR_I(n, 1, 1e-5, i);
            if (p < 0)
                continue;
            double v[3], w[3], t[3];
            for (int c = 0; c < 3; c++) {
                v[c] = (double)rest->P[3 * i + c] - rest->P[3 * p + c];
                w[c] = (double)m->P[3 * ((size_t)f * m->count + i) + c] -
                       m->P[3 * ((size_t)f * m->count + p) + c];
            }
            /* R v = v + 2 q0 (u x v) + 2 u x (u x v), u the vector part */
            double u[3] = {q[1], q[2], q[3]};
            double c1[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
            double c2[3] = {u[1] * c1[2] - u[2] * c1[1], u[2] * c1[0] - u[0] * c1[2], u[0] * c1[1] - u[1] * c1[0]};
            for (int c = 0; c < 3; c++)
                t[c] = v[c] + 2 * q[0] * c1[c] + 2 * c2[c];
            double e = sqrt((t[0] - w[0]) * (t[0] - w[0]) + (t[1] - w[1]) * (t[1] - w[1]) +
                            (t[2] - w[2]) * (t[2] - w[2]));
            worst = fmax(worst, e);
        }
    ASSERT_LE(worst, tol);
    return worst;
}

#endif
