/* overlay.h - test helper: writes a depth image with markers drawn on it as a PNG (libpng).
 * Depth is shown as grey (near = bright), the tracked person's cells tinted, markers as coloured
 * squares: head red, lhand green, rhand blue, lfoot yellow, rfoot magenta, torso white, unlabelled
 * extrema grey. Ground truth (optional) as hollow squares. */
#ifndef MESHSTEER_TEST_OVERLAY_H
#define MESHSTEER_TEST_OVERLAY_H

#include "depth.h"

#include <math.h>
#include <png.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static const uint8_t overlay_colors[DRV_DEPTH_NLABELS][3] = {
    {255, 40, 40}, {40, 255, 40}, {60, 120, 255}, {255, 255, 0}, {255, 0, 255}, {255, 255, 255}};

static void overlay_box(uint8_t *rgb, int W, int H, int u, int v, int r, const uint8_t c[3], int hollow)
{
    for (int y = v - r; y <= v + r; y++)
        for (int x = u - r; x <= u + r; x++) {
            if (x < 0 || y < 0 || x >= W || y >= H)
                continue;
            if (hollow && x != u - r && x != u + r && y != v - r && y != v + r)
                continue;
            uint8_t *p = rgb + 3 * ((size_t)y * W + x);
            p[0] = c[0];
            p[1] = c[1];
            p[2] = c[2];
        }
}

/* gt: DRV_DEPTH_NLABELS x 3 ground-truth points (camera frame) or NULL; gt_valid likewise. */
static int overlay_write_png(const char *path, const drv_intrinsics *k, const uint16_t *depth,
                             const drv_depth_tracker *t, const drv_depth_result *r,
                             const float (*gt)[3], const uint8_t *gt_valid)
{
    const int W = k->width, H = k->height;
    uint8_t *rgb = malloc((size_t)W * H * 3);
    if (!rgb)
        return -1;
    int step, gw, gh;
    const uint8_t *person;
    drv_depth_tracker_grid(t, &step, &gw, &gh, &person);
    for (int v = 0; v < H; v++)
        for (int u = 0; u < W; u++) {
            uint16_t d = depth[(size_t)v * W + u];
            uint8_t g = d ? (uint8_t)(255 - (d > 5000 ? 5000 : d) * 200 / 5000) : 0;
            uint8_t *p = rgb + 3 * ((size_t)v * W + u);
            p[0] = p[1] = p[2] = g;
            int gx = u / step, gy = v / step;
            if (gx < gw && gy < gh && person[gy * gw + gx]) {
                p[0] = (uint8_t)(g * 0.6);
                p[2] = (uint8_t)(g * 0.6 + 60);
            }
        }
    static const uint8_t grey[3] = {150, 150, 150};
    for (int i = 0; i < r->nextrema; i++) {
        int l = r->extremum_label[i];
        overlay_box(rgb, W, H, r->extremum_px[i][0], r->extremum_px[i][1], l >= 0 ? 6 : 3,
                    l >= 0 ? overlay_colors[l] : grey, 0);
    }
    for (int l = 0; l < DRV_DEPTH_NLABELS; l++) {
        double u, v;
        if (r->valid[l] && !drv_intrinsics_project(k, r->xyz[l], &u, &v))
            overlay_box(rgb, W, H, (int)lround(u), (int)lround(v), 3, overlay_colors[l], 0);
        if (gt && gt_valid[l] && !drv_intrinsics_project(k, gt[l], &u, &v))
            overlay_box(rgb, W, H, (int)lround(u), (int)lround(v), 9, overlay_colors[l], 1);
    }
    FILE *f = fopen(path, "wb");
    if (!f) {
        free(rgb);
        return -1;
    }
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fclose(f);
        free(rgb);
        return -1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)W, (png_uint_32)H, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int v = 0; v < H; v++)
        png_write_row(png, rgb + 3 * (size_t)v * W);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(f);
    free(rgb);
    return 0;
}

#endif
