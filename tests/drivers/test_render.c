/* test_render.c - the test camera: z-buffer depth of a known quad, the floor, the wall, projector
 * shadows on the correct side, Kinect disparity quantisation, and the world -> camera mapping. */
#include "depth.h"
#include "test.h"

#include <errno.h>

int main(void)
{
    char err[DRV_ERR_LEN] = "";
    drv_render_opts o;
    drv_render_opts_default(&o);
    o.cam_pitch = 0;
    o.cam_height = 1.0f;
    o.wall_dist = 4.0f;
    o.disparity_noise = 0;
    o.edge_dropout = 0;
    o.baseline = 0;
    o.quantise = 0;
    /* a 1 m x 1 m quad facing the camera at 2 m, centred at camera height, plus a nearer triangle
     * in front of its left half to check the z-buffer */
    const float V[] = {-0.5f, 0.5f, -2.f, 0.5f, 0.5f, -2.f, 0.5f, 1.5f, -2.f, -0.5f, 1.5f, -2.f,
                       -0.4f, 0.9f, -1.5f, -0.1f, 0.9f, -1.5f, -0.25f, 1.1f, -1.5f};
    const uint32_t F[] = {0, 1, 2, 0, 2, 3, 4, 5, 6};
    drv_render *r;
    ASSERT_OK(drv_render_create(&o, 7, &r, err), err);
    uint16_t *d = malloc(640 * 480 * sizeof *d);
    ASSERT_OK(drv_render_frame(r, V, 7, F, 3, d, err), err);
    /* centre pixel: the quad at 2 m */
    ASSERT_INT_EQ(d[240 * 640 + 320], 2000);
    /* quad covers |u - cx| <= 0.25 * 580 = 145 px */
    ASSERT_INT_EQ(d[240 * 640 + 320 + 140], 2000);
    /* the near triangle (centroid at x = -0.25, y = 0.967 -> camera y = -0.033) */
    double u, v;
    float c[3], w[3] = {-0.25f, 0.95f, -1.5f};
    drv_render_world_to_camera(r, w, c);
    ASSERT(!drv_intrinsics_project(&o.k, c, &u, &v));
    ASSERT_INT_EQ(d[(int)lround(v) * 640 + (int)lround(u)], 1500);
    /* floor at the bottom row: ray (0, -(479-239.5)/580, -1) meets y = -1 at t = 580/239.5 */
    ASSERT_NEAR(d[479 * 640 + 320], 1000.0 * 580.0 / 239.5, 1.0);
    /* the wall at the top row */
    ASSERT_INT_EQ(d[0 * 640 + 320], 4000);
    /* world -> camera with pitch: a point straight ahead along the pitched axis */
    drv_render_destroy(r);
    o.cam_pitch = 10;
    ASSERT_OK(drv_render_create(&o, 7, &r, err), err);
    float a = 10 * (float)M_PI / 180;
    float w2[3] = {0, 1.0f - 3 * sinf(a), -3 * cosf(a)};
    drv_render_world_to_camera(r, w2, c);
    ASSERT_NEAR(c[0], 0, 1e-5);
    ASSERT_NEAR(c[1], 0, 1e-5);
    ASSERT_NEAR(c[2], -3, 1e-5);
    drv_render_destroy(r);

    /* projector shadows: with the projector to the camera's +X, the wall just left of the quad is
     * in shadow, the wall just right of it is not */
    o.cam_pitch = 0;
    o.baseline = 0.075;
    ASSERT_OK(drv_render_create(&o, 7, &r, err), err);
    ASSERT_OK(drv_render_frame(r, V, 7, F, 3, d, err), err);
    int left = 0, right = 0;
    for (int x = 320 - 145 - 10; x < 320 - 145 - 2; x++)
        left += d[200 * 640 + x] == 0;
    for (int x = 320 + 145 + 2; x < 320 + 145 + 10; x++)
        right += d[200 * 640 + x] == 0;
    ASSERT_INT_EQ(left, 8);
    ASSERT_INT_EQ(right, 0);
    ASSERT_INT_EQ(d[240 * 640 + 320], 2000);
    drv_render_destroy(r);

    /* quantisation: at 2.5 m the Kinect's steps are about 2 cm; noise keeps the mean */
    o.baseline = 0;
    o.quantise = 1;
    o.disparity_noise = 0.5;
    o.wall_dist = 2.5f;
    o.floor = 0;
    ASSERT_OK(drv_render_create(&o, 7, &r, err), err);
    ASSERT_OK(drv_render_frame(r, V, 0, F, 0, d, err), err);
    double sum = 0;
    int distinct = 0, n = 0;
    uint16_t seen[64];
    for (int i = 0; i < 640 * 480; i += 97) {
        if (!d[i])
            continue;
        sum += d[i];
        n++;
        int k;
        for (k = 0; k < distinct; k++)
            if (seen[k] == d[i])
                break;
        if (k == distinct && distinct < 64)
            seen[distinct++] = d[i];
    }
    ASSERT_INT_GT(n, 1000);
    ASSERT_NEAR(sum / n, 2500, 8);
    ASSERT_INT_GE(distinct, 2);
    ASSERT_INT_LE(distinct, 8);
    for (int k = 1; k < distinct; k++) {
        int gap = abs((int)seen[k] - (int)seen[0]);
        ASSERT_INT_GE(gap, 15); /* steps of about 19 mm */
    }
    /* bad input is rejected */
    uint32_t bad[] = {0, 1, 9};
    ASSERT(drv_render_frame(r, V, 7, bad, 1, d, err) == -EINVAL);
    ASSERT(drv_render_frame(r, V, 8, F, 1, d, err) == -EINVAL);
    drv_render_destroy(r);
    drv_render_destroy(NULL);
    free(d);
    return 0;
}
