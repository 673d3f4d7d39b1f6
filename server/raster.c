/* raster.c - software rasteriser for contact sheets: orthographic projection, edge-function
 * triangle scan conversion over the triangle's pixel bounding box (sample at pixel centres),
 * per-pixel z-buffer, Gouraud-interpolated Lambert intensity, PNG output through libpng.
 * See raster.h for the conventions. */
#include "srv_err.h"
#include "raster.h"
#include "model.h"

#include <errno.h>
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define AMBIENT 0.22f
#define DIFFUSE 0.78f

struct srv_raster {
    int cols, rows, cell_w, cell_h, w, h, max_nv;
    uint8_t *rgb;  /* h x w x 3 */
    float *z;      /* h x w depth along fwd; +inf = empty */
    float *scr;    /* max_nv x 3: screen x, y, depth */
    float *nrm;    /* max_nv x 3: accumulated normals */
    float *shade;  /* max_nv: vertex intensity */
};

static float dot3(const float a[3], const float b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const float a[3], const float b[3], float o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

void srv_bbox_extend(float lo[3], float hi[3], const float *P, int n)
{
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            float v = P[3 * i + k];
            if (v < lo[k])
                lo[k] = v;
            if (v > hi[k])
                hi[k] = v;
        }
}

int srv_camera_fit(srv_camera *c, const float lo[3], const float hi[3], int w, int h,
                   float elevation_deg, float margin)
{
    for (int k = 0; k < 3; k++)
        if (!(lo[k] <= hi[k]) || !isfinite(lo[k]) || !isfinite(hi[k]))
            return -EINVAL;
    if (w < 4 || h < 4 || !(margin >= 0 && margin < 0.45f))
        return -EINVAL;
    float f0[3], e = elevation_deg * (float)M_PI / 180.0f;
    if (hi[0] - lo[0] >= hi[2] - lo[2]) { /* long axis X: look along -Z, +X to the right */
        f0[0] = 0, f0[1] = 0, f0[2] = -1;
        c->right[0] = 1, c->right[1] = 0, c->right[2] = 0;
    } else { /* long axis Z: look along -X, -Z to the right */
        f0[0] = -1, f0[1] = 0, f0[2] = 0;
        c->right[0] = 0, c->right[1] = 0, c->right[2] = -1;
    }
    for (int k = 0; k < 3; k++)
        c->fwd[k] = cosf(e) * f0[k];
    c->fwd[1] -= sinf(e); /* raised camera looks down */
    cross3(c->right, c->fwd, c->up);
    float ext_x = 0, ext_y = 0;
    for (int k = 0; k < 3; k++)
        c->center[k] = 0.5f * (lo[k] + hi[k]);
    for (int corner = 0; corner < 8; corner++) {
        float p[3];
        for (int k = 0; k < 3; k++)
            p[k] = ((corner >> k) & 1 ? hi[k] : lo[k]) - c->center[k];
        ext_x = fmaxf(ext_x, fabsf(dot3(p, c->right)));
        ext_y = fmaxf(ext_y, fabsf(dot3(p, c->up)));
    }
    float room_x = (float)w * (1 - 2 * margin) * 0.5f, room_y = (float)h * (1 - 2 * margin) * 0.5f;
    float sx = ext_x > 0 ? room_x / ext_x : INFINITY, sy = ext_y > 0 ? room_y / ext_y : INFINITY;
    c->scale = fminf(sx, sy);
    if (!isfinite(c->scale))
        c->scale = 1; /* a single point */
    c->w = w;
    c->h = h;
    return 0;
}

void srv_camera_project(const srv_camera *c, const float p[3], float out[3])
{
    float d[3] = {p[0] - c->center[0], p[1] - c->center[1], p[2] - c->center[2]};
    out[0] = 0.5f * (float)c->w + dot3(d, c->right) * c->scale;
    out[1] = 0.5f * (float)c->h - dot3(d, c->up) * c->scale;
    out[2] = dot3(d, c->fwd);
}

int srv_raster_create(int cols, int rows, int cell_w, int cell_h, int max_nv, srv_raster **out,
                      char *err)
{
    *out = NULL;
    if (cols < 1 || rows < 1 || cell_w < 8 || cell_h < 8 || max_nv < 0)
        return srv_err(err, -EINVAL, "raster: invalid sheet %d x %d cells of %d x %d pixels", cols,
                    rows, cell_w, cell_h);
    if ((long long)cols * cell_w > 32768 || (long long)rows * cell_h > 32768)
        return srv_err(err, -EINVAL, "raster: sheet of %lld x %lld pixels is larger than 32768 x 32768",
                    (long long)cols * cell_w, (long long)rows * cell_h);
    srv_raster *r = calloc(1, sizeof *r);
    if (!r)
        return srv_err(err, -ENOMEM, "raster: out of memory");
    r->cols = cols;
    r->rows = rows;
    r->cell_w = cell_w;
    r->cell_h = cell_h;
    r->w = cols * cell_w;
    r->h = rows * cell_h;
    r->max_nv = max_nv;
    size_t px = (size_t)r->w * r->h, nv = max_nv > 0 ? (size_t)max_nv : 1;
    r->rgb = malloc(px * 3);
    r->z = malloc(px * sizeof *r->z);
    r->scr = malloc(nv * 3 * sizeof *r->scr);
    r->nrm = malloc(nv * 3 * sizeof *r->nrm);
    r->shade = malloc(nv * sizeof *r->shade);
    if (!r->rgb || !r->z || !r->scr || !r->nrm || !r->shade) {
        srv_raster_destroy(r);
        return srv_err(err, -ENOMEM, "raster: out of memory for a %d x %d sheet", cols * cell_w,
                    rows * cell_h);
    }
    static const uint8_t white[3] = {255, 255, 255};
    srv_raster_clear(r, white);
    *out = r;
    return 0;
}

void srv_raster_destroy(srv_raster *r)
{
    if (!r)
        return;
    free(r->rgb);
    free(r->z);
    free(r->scr);
    free(r->nrm);
    free(r->shade);
    free(r);
}

void srv_raster_clear(srv_raster *r, const uint8_t bg[3])
{
    size_t px = (size_t)r->w * r->h;
    for (size_t i = 0; i < px; i++) {
        memcpy(r->rgb + 3 * i, bg, 3);
        r->z[i] = INFINITY;
    }
}

static float edge(const float *a, const float *b, float px, float py)
{
    return (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]);
}

/* rgb: the colour of vertex i at rgb + i * stride (stride 0: one colour for all) */
static int draw_mesh(srv_raster *r, int cell, const srv_camera *c, const float *V, int nv,
                     const uint32_t *F, int nf, const uint8_t *rgb, size_t stride, char *err)
{
    if (nv < 0 || nv > r->max_nv)
        return srv_err(err, -EINVAL, "raster: %d vertices, the sheet was sized for %d", nv, r->max_nv);
    if (cell < 0 || cell >= r->cols * r->rows)
        return srv_err(err, -EINVAL, "raster: no cell %d", cell);
    if (c->w != r->cell_w || c->h != r->cell_h)
        return srv_err(err, -EINVAL, "raster: camera for %d x %d cells, sheet cells are %d x %d", c->w,
                    c->h, r->cell_w, r->cell_h);
    for (int f = 0; f < 3 * nf; f++)
        if (F[f] >= (uint32_t)nv)
            return srv_err(err, -EINVAL, "raster: face %d uses vertex %u of %d", f / 3, F[f], nv);

    /* vertex normals (area-weighted), screen positions, Lambert intensity per vertex */
    memset(r->nrm, 0, (size_t)nv * 3 * sizeof *r->nrm);
    for (int f = 0; f < nf; f++) {
        const float *a = V + 3 * F[3 * f], *b = V + 3 * F[3 * f + 1], *d = V + 3 * F[3 * f + 2];
        float u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]}, n[3];
        cross3(u, v, n);
        for (int k = 0; k < 3; k++)
            for (int x = 0; x < 3; x++)
                r->nrm[3 * F[3 * f + k] + x] += n[x];
    }
    /* key light: from the upper left, in front of the viewer */
    float L[3];
    for (int k = 0; k < 3; k++)
        L[k] = -0.45f * c->right[k] + 0.65f * c->up[k] - 0.62f * c->fwd[k];
    float ln = sqrtf(dot3(L, L));
    for (int k = 0; k < 3; k++)
        L[k] /= ln;
    for (int i = 0; i < nv; i++) {
        srv_camera_project(c, V + 3 * i, r->scr + 3 * i);
        float *n = r->nrm + 3 * i, len = sqrtf(dot3(n, n));
        float d = len > 0 ? dot3(n, L) / len : 0;
        /* two-sided: a normal facing away from the viewer is flipped */
        if (len > 0 && dot3(n, c->fwd) > 0)
            d = -d;
        r->shade[i] = AMBIENT + DIFFUSE * (d > 0 ? d : 0);
    }

    int ox = (cell % r->cols) * r->cell_w, oy = (cell / r->cols) * r->cell_h;
    for (int f = 0; f < nf; f++) {
        const float *p0 = r->scr + 3 * F[3 * f], *p1 = r->scr + 3 * F[3 * f + 1], *p2 = r->scr + 3 * F[3 * f + 2];
        float area = edge(p0, p1, p2[0], p2[1]);
        if (!(fabsf(area) > 1e-9f))
            continue; /* degenerate on screen (or NaN) */
        float xmin = fminf(p0[0], fminf(p1[0], p2[0])), xmax = fmaxf(p0[0], fmaxf(p1[0], p2[0]));
        float ymin = fminf(p0[1], fminf(p1[1], p2[1])), ymax = fmaxf(p0[1], fmaxf(p1[1], p2[1]));
        int x0 = (int)fmaxf(0.0f, floorf(xmin)), x1 = (int)fminf((float)r->cell_w - 1, ceilf(xmax));
        int y0 = (int)fmaxf(0.0f, floorf(ymin)), y1 = (int)fminf((float)r->cell_h - 1, ceilf(ymax));
        float s0 = r->shade[F[3 * f]], s1 = r->shade[F[3 * f + 1]], s2 = r->shade[F[3 * f + 2]];
        const uint8_t *c0 = rgb + stride * F[3 * f], *c1 = rgb + stride * F[3 * f + 1],
                      *c2 = rgb + stride * F[3 * f + 2];
        float inv = 1.0f / area;
        for (int y = y0; y <= y1; y++)
            for (int x = x0; x <= x1; x++) {
                float px = (float)x + 0.5f, py = (float)y + 0.5f;
                float b0 = edge(p1, p2, px, py) * inv, b1 = edge(p2, p0, px, py) * inv;
                float b2 = 1.0f - b0 - b1;
                if (b0 < 0 || b1 < 0 || b2 < 0)
                    continue;
                float z = b0 * p0[2] + b1 * p1[2] + b2 * p2[2];
                size_t idx = (size_t)(oy + y) * r->w + (size_t)(ox + x);
                if (!(z < r->z[idx]))
                    continue;
                r->z[idx] = z;
                float s = b0 * s0 + b1 * s1 + b2 * s2;
                for (int k = 0; k < 3; k++) {
                    /* Gouraud: shade and colour both interpolated */
                    float v = stride ? b0 * s0 * c0[k] + b1 * s1 * c1[k] + b2 * s2 * c2[k]
                                     : (float)c0[k] * s;
                    r->rgb[3 * idx + k] = (uint8_t)(v > 255 ? 255 : v < 0 ? 0 : v + 0.5f);
                }
            }
    }
    return 0;
}

int srv_raster_draw_mesh(srv_raster *r, int cell, const srv_camera *c, const float *V, int nv,
                         const uint32_t *F, int nf, const uint8_t color[3], char *err)
{
    return draw_mesh(r, cell, c, V, nv, F, nf, color, 0, err);
}

int srv_raster_draw_mesh_coloured(srv_raster *r, int cell, const srv_camera *c, const float *V,
                                  int nv, const uint32_t *F, int nf, const uint8_t *vertex_rgb,
                                  char *err)
{
    return draw_mesh(r, cell, c, V, nv, F, nf, vertex_rgb, 3, err);
}

static void put(srv_raster *r, int cell, int x, int y, const uint8_t color[3])
{
    if (cell < 0 || cell >= r->cols * r->rows || x < 0 || y < 0 || x >= r->cell_w || y >= r->cell_h)
        return;
    size_t idx = (size_t)((cell / r->cols) * r->cell_h + y) * r->w + (size_t)((cell % r->cols) * r->cell_w + x);
    memcpy(r->rgb + 3 * idx, color, 3);
}

void srv_raster_draw_points(srv_raster *r, int cell, const srv_camera *c, const float *P,
                            const uint8_t *valid, int n, int radius, const uint8_t color[3])
{
    for (int i = 0; i < n; i++) {
        if (valid && !valid[i])
            continue;
        float s[3];
        srv_camera_project(c, P + 3 * i, s);
        if (!(fabsf(s[0]) < 1e6f && fabsf(s[1]) < 1e6f))
            continue;
        int cx = (int)floorf(s[0]), cy = (int)floorf(s[1]);
        for (int dy = -radius; dy <= radius; dy++)
            for (int dx = -radius; dx <= radius; dx++)
                if (dx * dx + dy * dy <= radius * radius)
                    put(r, cell, cx + dx, cy + dy, color);
    }
}

/* 3x5 glyphs, one row per 3 bits (MSB = left), top row first. */
static const char font_chars[] = "0123456789#:.-/";
static const uint8_t font[][5] = {
    {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
    {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7},
    {5, 7, 5, 7, 5}, {0, 2, 0, 2, 0}, {0, 0, 0, 0, 2}, {0, 0, 7, 0, 0}, {1, 1, 2, 4, 4},
};

void srv_raster_draw_text(srv_raster *r, int cell, int x, int y, const char *text, int scale,
                          const uint8_t color[3])
{
    if (scale < 1)
        scale = 1;
    for (int i = 0; text[i]; i++) {
        const char *g = strchr(font_chars, text[i]);
        if (g && text[i]) {
            const uint8_t *rows = font[g - font_chars];
            for (int gy = 0; gy < 5; gy++)
                for (int gx = 0; gx < 3; gx++)
                    if (rows[gy] >> (2 - gx) & 1)
                        for (int sy = 0; sy < scale; sy++)
                            for (int sx = 0; sx < scale; sx++)
                                put(r, cell, x + (4 * i + gx) * scale + sx, y + gy * scale + sy, color);
        }
    }
}

const uint8_t *srv_raster_pixels(const srv_raster *r, int *w, int *h)
{
    *w = r->w;
    *h = r->h;
    return r->rgb;
}

typedef struct png_ctx {
    jmp_buf jmp;
    char msg[256];
} png_ctx;

static void png_on_error(png_structp png, png_const_charp msg)
{
    png_ctx *ctx = png_get_error_ptr(png);
    snprintf(ctx->msg, sizeof ctx->msg, "%s", msg);
    longjmp(ctx->jmp, 1);
}

static void png_on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

int srv_raster_write_png(const srv_raster *r, const char *path, char *err)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return srv_err(err, -errno, "%s: cannot create: %s", path, strerror(errno));
    png_ctx ctx;
    ctx.msg[0] = 0;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &ctx, png_on_error, png_on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, NULL);
        fclose(f);
        return srv_err(err, -ENOMEM, "%s: out of memory for libpng", path);
    }
    if (setjmp(ctx.jmp)) {
        png_destroy_write_struct(&png, &info);
        fclose(f);
        return srv_err(err, -EIO, "%s: libpng: %s", path, ctx.msg);
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)r->w, (png_uint_32)r->h, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < r->h; y++)
        png_write_row(png, r->rgb + (size_t)y * r->w * 3);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    if (fclose(f) != 0)
        return srv_err(err, -errno, "%s: write failed: %s", path, strerror(errno));
    return 0;
}
