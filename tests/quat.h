/* quat.h - tests: the rotation matrix (row-major) of a unit quaternion (w, x, y, z), in double, as
 * the params encoding's formula uses it (model.h mdl_params_layout, docs/PROTOCOL.md 2b). */
#ifndef MESHSTEER_TESTS_QUAT_H
#define MESHSTEER_TESTS_QUAT_H

static inline void test_quat_matrix(const float q[4], double R[9])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z);
    R[1] = 2 * (x * y - w * z);
    R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z);
    R[4] = 1 - 2 * (x * x + z * z);
    R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y);
    R[7] = 2 * (y * z + w * x);
    R[8] = 1 - 2 * (x * x + y * y);
}

#endif
