/* test_raster.c - the contact-sheet rasteriser: the z-buffer keeps the nearer surface whatever the
 * drawing order, the camera fit keeps everything inside its cell, and a sheet of the built-in
 * example written to PNG and read back through libpng shows a shaded creature of plausible size in
 * every cell with background in the corners. */
#include "../../server/raster.h"
#include "model.h"
#include "test.h"

#include <errno.h>
#include <png.h>
#include <stdint.h>
#include <unistd.h>

static const uint8_t bg[3] = {255, 255, 255};
static const uint8_t grey[3] = {200, 180, 160};

/* Two overlapping squares at different depths, drawn in both orders. */
static void test_zbuffer(void)
{
    char err[MDL_ERR_LEN] = "";
    /* near square at z = +0.5 (the side camera looks along -Z, so larger z is nearer), far at -0.5 */
    float V[8 * 3] = {-1, -1, 0.5f, 1, -1, 0.5f, 1, 1, 0.5f, -1, 1, 0.5f,
                      -0.5f, -0.5f, -0.5f, 1.5f, -0.5f, -0.5f, 1.5f, 1.5f, -0.5f, -0.5f, 1.5f, -0.5f};
    uint32_t near_f[6] = {0, 1, 2, 0, 2, 3}, far_f[6] = {4, 5, 6, 4, 6, 7};
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    srv_bbox_extend(lo, hi, V, 8);
    srv_camera cam;
    ASSERT_INT_EQ(srv_camera_fit(&cam, lo, hi, 64, 64, 0, 0.05f), 0);
    ASSERT_NEAR(cam.fwd[2], -1, 1e-6);
    srv_raster *r = NULL;
    ASSERT_OK(srv_raster_create(2, 1, 64, 64, 8, &r, err), err);
    srv_raster_clear(r, bg);
    static const uint8_t red[3] = {255, 0, 0}, blue[3] = {0, 0, 255};
    ASSERT_OK(srv_raster_draw_mesh(r, 0, &cam, V, 8, near_f, 2, red, err), err);
    ASSERT_OK(srv_raster_draw_mesh(r, 0, &cam, V, 8, far_f, 2, blue, err), err);
    ASSERT_OK(srv_raster_draw_mesh(r, 1, &cam, V, 8, far_f, 2, blue, err), err);
    ASSERT_OK(srv_raster_draw_mesh(r, 1, &cam, V, 8, near_f, 2, red, err), err);
    int w, h;
    const uint8_t *px = srv_raster_pixels(r, &w, &h);
    ASSERT_INT_EQ(w, 128);
    ASSERT_INT_EQ(h, 64);
    /* the world point (0.8, 0.8) is covered by both squares: red wins in both cells */
    for (int cell = 0; cell < 2; cell++) {
        float p[3] = {0.8f, 0.8f, 0.5f}, s[3];
        srv_camera_project(&cam, p, s);
        const uint8_t *q = px + ((size_t)s[1] * w + cell * 64 + (size_t)s[0]) * 3;
        ASSERT(q[0] > 0 && q[2] == 0);
        /* (1.3, 1.3) only the far square covers */
        float p2[3] = {1.3f, 1.3f, -0.5f};
        srv_camera_project(&cam, p2, s);
        q = px + ((size_t)s[1] * w + cell * 64 + (size_t)s[0]) * 3;
        ASSERT(q[2] > 0 && q[0] == 0);
    }
    /* bad arguments */
    ASSERT_INT_EQ(srv_raster_draw_mesh(r, 2, &cam, V, 8, near_f, 2, red, err), -EINVAL);
    ASSERT_INT_EQ(srv_raster_draw_mesh(r, 0, &cam, V, 9, near_f, 2, red, err), -EINVAL);
    uint32_t bad[3] = {0, 1, 8};
    ASSERT_INT_EQ(srv_raster_draw_mesh(r, 0, &cam, V, 8, bad, 1, red, err), -EINVAL);
    srv_raster_destroy(r);
    srv_raster_destroy(NULL);
    float empty_lo[3] = {1, 1, 1}, empty_hi[3] = {0, 0, 0};
    ASSERT_INT_EQ(srv_camera_fit(&cam, empty_lo, empty_hi, 64, 64, 0, 0.05f), -EINVAL);
}

static uint8_t *read_png(const char *path, int *w, int *h)
{
    FILE *f = fopen(path, "rb");
    ASSERT(f);
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    ASSERT(png && info);
    if (setjmp(png_jmpbuf(png))) {
        fprintf(stderr, "libpng failed reading %s\n", path);
        exit(1);
    }
    png_init_io(png, f);
    png_read_info(png, info);
    ASSERT_INT_EQ(png_get_color_type(png, info), PNG_COLOR_TYPE_RGB);
    ASSERT_INT_EQ(png_get_bit_depth(png, info), 8);
    *w = (int)png_get_image_width(png, info);
    *h = (int)png_get_image_height(png, info);
    uint8_t *px = malloc((size_t)*w * *h * 3);
    ASSERT(px);
    for (int y = 0; y < *h; y++)
        png_read_row(png, px + (size_t)y * *w * 3, NULL);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    fclose(f);
    return px;
}

static void test_example_sheet(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s = NULL;
    ASSERT_OK(mdl_example_create(40, &s, NULL, err), err);
    const int cols = 3, rows = 2, cw = 200, ch = 150, pick[6] = {0, 7, 14, 21, 28, 35};
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < 6; i++)
        srv_bbox_extend(lo, hi, s->V + (size_t)pick[i] * s->nv * 3, s->nv);
    srv_camera cam;
    ASSERT_INT_EQ(srv_camera_fit(&cam, lo, hi, cw, ch, 15, 0.04f), 0);
    ASSERT_NEAR(cam.right[0], 1, 1e-6); /* the creature is long in X: side view, head to the right */
    srv_raster *r = NULL;
    ASSERT_OK(srv_raster_create(cols, rows, cw, ch, s->nv, &r, err), err);
    srv_raster_clear(r, bg);
    for (int i = 0; i < 6; i++) {
        ASSERT_OK(srv_raster_draw_mesh(r, i, &cam, s->V + (size_t)pick[i] * s->nv * 3, s->nv, s->F,
                                       s->nf, grey, err), err);
        /* every vertex projects inside its cell */
        for (int v = 0; v < s->nv; v++) {
            float q[3];
            srv_camera_project(&cam, s->V + ((size_t)pick[i] * s->nv + v) * 3, q);
            ASSERT(q[0] >= 0 && q[0] <= cw && q[1] >= 0 && q[1] <= ch);
        }
        char label[16];
        snprintf(label, sizeof label, "%d", pick[i]);
        static const uint8_t black[3] = {0, 0, 0};
        srv_raster_draw_text(r, i, 4, ch - 14, label, 2, black);
    }
    char path[] = "/tmp/meshsteer-test-raster-XXXXXX";
    int fd = mkstemp(path);
    ASSERT(fd >= 0);
    close(fd);
    ASSERT_OK(srv_raster_write_png(r, path, err), err);
    int w, h;
    uint8_t *px = read_png(path, &w, &h);
    unlink(path);
    ASSERT_INT_EQ(w, cols * cw);
    ASSERT_INT_EQ(h, rows * ch);
    int rw, rh;
    ASSERT(!memcmp(px, srv_raster_pixels(r, &rw, &rh), (size_t)w * h * 3));

    for (int cell = 0; cell < 6; cell++) {
        int ox = (cell % cols) * cw, oy = (cell / cols) * ch, filled = 0;
        int xmin = cw, xmax = -1, ymin = ch, ymax = -1, levels[256] = {0}, nlevels = 0;
        for (int y = 0; y < ch - 16; y++) /* above the label */
            for (int x = 0; x < cw; x++) {
                const uint8_t *q = px + ((size_t)(oy + y) * w + ox + x) * 3;
                if (q[0] == 255 && q[1] == 255 && q[2] == 255)
                    continue;
                filled++;
                xmin = x < xmin ? x : xmin;
                xmax = x > xmax ? x : xmax;
                ymin = y < ymin ? y : ymin;
                ymax = y > ymax ? y : ymax;
                if (!levels[q[0]]++)
                    nlevels++;
            }
        double frac = (double)filled / (cw * ch);
        printf("cell %d: silhouette %.1f%% of the cell, box %d..%d x %d..%d, %d shades\n", cell,
               100 * frac, xmin, xmax, ymin, ymax, nlevels);
        ASSERT(frac > 0.15 && frac < 0.6);
        ASSERT(xmax - xmin > 0.7 * cw);          /* fitted: the body fills the width */
        ASSERT(xmax - xmin > ymax - ymin);       /* long axis horizontal */
        ASSERT(nlevels > 40);                    /* shaded, not flat */
        for (int k = 0; k < 4; k++) {            /* the top corners are background */
            const uint8_t *q = px + ((size_t)(oy + 1 + k) * w + ox + 1 + k) * 3;
            ASSERT(q[0] == 255 && q[1] == 255 && q[2] == 255);
            q = px + ((size_t)(oy + 1 + k) * w + ox + cw - 2 - k) * 3;
            ASSERT(q[0] == 255 && q[1] == 255 && q[2] == 255);
        }
    }
    /* the frames differ: the legs move */
    int differ = 0;
    for (int y = 0; y < ch; y++)
        for (int x = 0; x < cw; x++)
            differ += memcmp(px + ((size_t)y * w + x) * 3, px + ((size_t)y * w + cw + x) * 3, 3) != 0;
    printf("pixels that differ between frames 0 and 7: %d\n", differ);
    ASSERT(differ > 200);
    free(px);
    srv_raster_destroy(r);
    free(s->V);
    free(s->F);
    free(s);
}

int main(void)
{
    test_zbuffer();
    test_example_sheet();
    return 0;
}
