/* raster.h - a small software rasteriser for contact sheets of mesh frames (`meshsteer render`).
 *
 * Orthographic camera, per-pixel z-buffer, Gouraud-interpolated Lambert shading with a fixed key light
 * (upper left, in front of the viewer) plus ambient, triangles drawn from both sides. A sheet is a
 * grid of `cols x rows` cells of `cell_w x cell_h` pixels; every drawing call targets one cell.
 *
 * Camera (srv_camera_fit): a side view fitted to a bounding box. The view looks along -Z when the
 * box is longer in X than in Z, otherwise along -X, so the body's long axis is horizontal; the
 * camera is raised by `elevation` degrees and looks slightly down. Screen x = right, screen y = -up.
 *
 * Memory: srv_raster_create allocates the image, the z-buffer and per-vertex scratch for meshes of
 * up to max_nv vertices; the drawing calls allocate nothing. Pixels are RGB, 8 bits, row-major.
 * Errors: 0 or a negative errno, with a message in `err` (MDL_ERR_LEN bytes, may be NULL). */
#ifndef MESHSTEER_SERVER_RASTER_H
#define MESHSTEER_SERVER_RASTER_H

#include <stdint.h>

typedef struct srv_camera {
    float right[3], up[3], fwd[3]; /* orthonormal basis; fwd points into the screen */
    float center[3];               /* world point at the centre of a cell */
    float scale;                   /* pixels per metre */
    int w, h;                      /* cell size in pixels */
} srv_camera;

typedef struct srv_raster srv_raster;

/* Grows [lo, hi] (3 floats each) to include n points (n x 3). Start with lo = +inf, hi = -inf. */
void srv_bbox_extend(float lo[3], float hi[3], const float *P, int n);

/* Fits a side view of the box lo..hi into a w x h cell with a margin of `margin` (fraction of the
 * cell on each side). Returns -EINVAL for an empty box or a cell without room. */
int srv_camera_fit(srv_camera *c, const float lo[3], const float hi[3], int w, int h,
                   float elevation_deg, float margin);

/* Projects world point p: screen x, y (pixels within the cell) and depth (metres along fwd). */
void srv_camera_project(const srv_camera *c, const float p[3], float out[3]);

int srv_raster_create(int cols, int rows, int cell_w, int cell_h, int max_nv, srv_raster **out,
                      char *err);
void srv_raster_destroy(srv_raster *r);

/* Fills the whole sheet with the background colour and resets the z-buffer. */
void srv_raster_clear(srv_raster *r, const uint8_t bg[3]);

/* Draws a shaded triangle mesh (V: nv x 3, F: nf x 3) into cell `cell` (row-major cell order).
 * Returns -EINVAL if nv > max_nv, the cell does not exist, the camera's cell size differs from the
 * sheet's, or a face index is out of range. */
int srv_raster_draw_mesh(srv_raster *r, int cell, const srv_camera *c, const float *V, int nv,
                         const uint32_t *F, int nf, const uint8_t color[3], char *err);

/* The same with a colour per vertex (vertex_rgb: nv x 3), interpolated across each face. */
int srv_raster_draw_mesh_coloured(srv_raster *r, int cell, const srv_camera *c, const float *V,
                                  int nv, const uint32_t *F, int nf, const uint8_t *vertex_rgb,
                                  char *err);

/* Draws n points (P: n x 3; valid may be NULL = all) as filled discs on top of the cell. */
void srv_raster_draw_points(srv_raster *r, int cell, const srv_camera *c, const float *P,
                            const uint8_t *valid, int n, int radius, const uint8_t color[3]);

/* Writes text (digits, space, and the characters # : . - /) at pixel (x, y) of the cell, with a
 * 3x5 font scaled by `scale`. Other characters are drawn as blanks. */
void srv_raster_draw_text(srv_raster *r, int cell, int x, int y, const char *text, int scale,
                          const uint8_t color[3]);

/* The sheet's pixels (w x h x 3, row-major, valid while r lives). */
const uint8_t *srv_raster_pixels(const srv_raster *r, int *w, int *h);

/* Writes the sheet as an 8-bit RGB PNG through libpng. */
int srv_raster_write_png(const srv_raster *r, const char *path, char *err);

#endif
