/* test_bone_colours.c - a skin's bones as colour (meshsteer render --skin): bone colours are
 * distinct, a vertex's colour is the weight blend of its bones' colours, and a flat sheet skinned
 * to two bones (left half bone 0, right half bone 1, a blend between) renders with bone 0's hue on
 * the left, bone 1's on the right and the mixture in the middle, while the one-colour render has
 * the same hue everywhere. */
#include "../../server/bone_colours.h"
#include "../../server/raster.h"
#include "model.h"
#include "test.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>

enum { NX = 41, NY = 21, NV = NX * NY, NF = 2 * (NX - 1) * (NY - 1), CELL = 160 };

static void test_distinct(void)
{
    float c[64][3];
    for (int j = 0; j < 64; j++) {
        srv_bone_colour(j, c[j]);
        for (int x = 0; x < 3; x++)
            ASSERT(c[j][x] >= 0 && c[j][x] <= 1);
    }
    /* neighbouring indices far apart, every pair at least visibly apart */
    for (int j = 0; j < 64; j++)
        for (int k = j + 1; k < 64; k++) {
            double d = 0;
            for (int x = 0; x < 3; x++)
                d += (c[j][x] - c[k][x]) * (c[j][x] - c[k][x]);
            ASSERT(sqrt(d) > (k == j + 1 ? 0.5 : 0.01));
        }
}

static void test_blend(void)
{
    int bone[4] = {0, 5, 2, 7};
    double w[4] = {1, 0, 0.25, 0.75};
    uint8_t out[6];
    srv_skin_vertex_colours(2, 2, bone, w, out);
    float c0[3], c2[3], c7[3];
    srv_bone_colour(0, c0);
    srv_bone_colour(2, c2);
    srv_bone_colour(7, c7);
    for (int x = 0; x < 3; x++) {
        ASSERT_INT_EQ(out[x], (int)lroundf(255 * c0[x]));
        ASSERT(abs(out[3 + x] - (int)lroundf(255 * (0.25f * c2[x] + 0.75f * c7[x]))) <= 1);
    }
}

/* chromaticity: the colour over its sum, which the Lambert shade (a common factor) leaves alone */
static void chroma(const float c[3], double out[3])
{
    double s = c[0] + c[1] + c[2];
    for (int x = 0; x < 3; x++)
        out[x] = s > 0 ? c[x] / s : 0;
}

static double chroma_dist(const double a[3], const double b[3])
{
    return fabs(a[0] - b[0]) + fabs(a[1] - b[1]) + fabs(a[2] - b[2]);
}

static void pixel_chroma(const uint8_t *px, int w, const srv_camera *cam, int cell, float x,
                         double out[3])
{
    float p[3] = {x, 0, 0}, s[3];
    srv_camera_project(cam, p, s);
    const uint8_t *q = px + ((size_t)s[1] * w + (size_t)cell * CELL + (size_t)s[0]) * 3;
    float c[3] = {q[0], q[1], q[2]};
    ASSERT(c[0] + c[1] + c[2] < 3 * 255); /* not the white background */
    chroma(c, out);
}

static void test_sheet_regions(void)
{
    char err[MDL_ERR_LEN] = "";
    static float V[NV * 3];
    static uint32_t F[NF * 3];
    static int bone[NV * 2];
    static double w[NV * 2];
    static uint8_t rgb[NV * 3];
    for (int y = 0; y < NY; y++)
        for (int x = 0; x < NX; x++) {
            int i = y * NX + x;
            float px = -2 + 4.0f * x / (NX - 1);
            V[3 * i] = px;
            V[3 * i + 1] = -1 + 2.0f * y / (NY - 1);
            V[3 * i + 2] = 0;
            double t = fmin(1, fmax(0, (px + 0.5) / 1.0)); /* 0 left of -0.5, 1 right of 0.5 */
            bone[2 * i] = 0;
            bone[2 * i + 1] = 1;
            w[2 * i] = 1 - t;
            w[2 * i + 1] = t;
        }
    int f = 0;
    for (int y = 0; y + 1 < NY; y++)
        for (int x = 0; x + 1 < NX; x++) {
            uint32_t a = y * NX + x, b = a + 1, c = a + NX, d = c + 1;
            uint32_t tri[6] = {a, b, d, a, d, c};
            for (int k = 0; k < 6; k++)
                F[3 * f + k] = tri[k];
            f += 2;
        }
    srv_skin_vertex_colours(NV, 2, bone, w, rgb);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    srv_bbox_extend(lo, hi, V, NV);
    srv_camera cam;
    ASSERT_INT_EQ(srv_camera_fit(&cam, lo, hi, CELL, CELL * 3 / 4, 15, 0.05f), 0);
    srv_raster *r = NULL;
    ASSERT_OK(srv_raster_create(2, 1, CELL, CELL * 3 / 4, NV, &r, err), err);
    static const uint8_t bg[3] = {255, 255, 255}, body[3] = {214, 186, 150};
    srv_raster_clear(r, bg);
    ASSERT_OK(srv_raster_draw_mesh_coloured(r, 0, &cam, V, NV, F, NF, rgb, err), err);
    ASSERT_OK(srv_raster_draw_mesh(r, 1, &cam, V, NV, F, NF, body, err), err);
    ASSERT_INT_EQ(srv_raster_draw_mesh_coloured(r, 0, &cam, V, NV + 1, F, NF, rgb, err), -EINVAL);
    int wpx, hpx;
    const uint8_t *px = srv_raster_pixels(r, &wpx, &hpx);

    float c0[3], c1[3], mid[3];
    srv_bone_colour(0, c0);
    srv_bone_colour(1, c1);
    for (int x = 0; x < 3; x++)
        mid[x] = 0.5f * (c0[x] + c1[x]);
    double want0[3], want1[3], want_mid[3], got[3];
    chroma(c0, want0);
    chroma(c1, want1);
    chroma(mid, want_mid);
    ASSERT(chroma_dist(want0, want1) > 0.3);
    double tol = 0.03; /* 8-bit rounding of a shaded colour */
    pixel_chroma(px, wpx, &cam, 0, -1.5f, got);
    ASSERT(chroma_dist(got, want0) < tol);
    pixel_chroma(px, wpx, &cam, 0, 1.5f, got);
    ASSERT(chroma_dist(got, want1) < tol);
    pixel_chroma(px, wpx, &cam, 0, 0.0f, got);
    ASSERT(chroma_dist(got, want_mid) < tol);
    /* the one-colour sheet: the same hue at all three places */
    float b[3] = {body[0], body[1], body[2]};
    double want_body[3];
    chroma(b, want_body);
    for (float x = -1.5f; x <= 1.6f; x += 1.5f) {
        pixel_chroma(px, wpx, &cam, 1, x, got);
        ASSERT(chroma_dist(got, want_body) < tol);
    }
    srv_raster_destroy(r);
}

int main(void)
{
    test_distinct();
    test_blend();
    test_sheet_regions();
    puts("bone_colours: ok");
    return 0;
}
