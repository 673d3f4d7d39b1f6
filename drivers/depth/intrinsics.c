/* intrinsics.c - pinhole camera model of a Kinect v1 depth camera and its disparity <-> depth fit.
 *
 * Projection (pixel centres at integer coordinates, image y down, camera frame Y up, looking -Z):
 *   u = cx + fx X / z,  v = cy - fy Y / z,  z = -Z.
 * Disparity: the Kinect v1 reports an 11-bit raw disparity d; depth in metres follows the fit
 *   z = 1 / (3.3309495161 - 0.0030711016 d)
 * published by the OpenKinect community (valid for d < 1084). One unit of d is about 1/8 pixel of
 * stereo disparity, so depth resolution grows as z^2 (about 2 cm at 2.5 m). */
#include "../depth.h"

void drv_intrinsics_kinect1(drv_intrinsics *k)
{
    k->width = 640;
    k->height = 480;
    k->fx = 580.0;
    k->fy = 580.0;
    k->cx = 319.5;
    k->cy = 239.5;
}

void drv_intrinsics_unproject(const drv_intrinsics *k, double u, double v, double z, float p[3])
{
    p[0] = (float)((u - k->cx) * z / k->fx);
    p[1] = (float)(-(v - k->cy) * z / k->fy);
    p[2] = (float)(-z);
}

int drv_intrinsics_project(const drv_intrinsics *k, const float p[3], double *u, double *v)
{
    double z = -(double)p[2];
    if (z <= 1e-6)
        return -1;
    *u = k->cx + k->fx * p[0] / z;
    *v = k->cy - k->fy * p[1] / z;
    return 0;
}

#define KINECT_A 3.3309495161
#define KINECT_B 0.0030711016

double drv_kinect1_disparity_to_m(double d)
{
    double q = KINECT_A - KINECT_B * d;
    if (d < 0 || d >= 2047 || q <= 0)
        return 0;
    return 1.0 / q;
}

double drv_kinect1_m_to_disparity(double z)
{
    if (z <= 0)
        return 2047;
    return (KINECT_A - 1.0 / z) / KINECT_B;
}
