/* render.h - the test camera: rasterises a mesh into Kinect-v1-like depth (render.c).
 *
 * World: metres, Y up, the floor is y = 0. The camera stands at (0, cam_height, 0) looking along
 * world -Z, pitched down by cam_pitch degrees; its frame is the Y-up camera frame of depth.h.
 * Per frame: z-buffer rasterisation (perspective-correct depth), a floor plane and an optional back
 * wall, then the Kinect's ways of failing: shadows of the IR projector (it sits `baseline` metres
 * to the camera's +X, so surfaces it cannot see give no reading, left of foreground objects),
 * dropouts at depth edges, raw 11-bit disparity quantisation with Gaussian disparity noise
 * (about 2 cm depth steps at 2.5 m), and the valid range. Output: millimetres, 0 = no reading.
 * All buffers are allocated at create (for up to max_vertices vertices). */
#ifndef MESHSTEER_DRIVERS_DEPTH_RENDER_H
#define MESHSTEER_DRIVERS_DEPTH_RENDER_H

#include "depth.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct drv_render_opts {
    drv_intrinsics k;
    float cam_height;        /* metres above the floor */
    float cam_pitch;         /* degrees, positive = looking down */
    int floor;               /* 1: render the floor y = 0 */
    float wall_dist;         /* a back wall at world z = -wall_dist; 0 = none */
    float min_range, max_range; /* metres; no reading outside */
    double disparity_noise;  /* sigma of Gaussian noise on raw disparity (units of 1/8 pixel) */
    double baseline;         /* projector offset along the camera's +X (metres); 0 = no shadows */
    double edge_dropout;     /* probability that a pixel at a depth edge has no reading */
    int quantise;            /* 1: Kinect v1 raw disparity quantisation */
    uint64_t seed;           /* noise seed; frames are deterministic per seed and frame order */
} drv_render_opts;

void drv_render_opts_default(drv_render_opts *o);

typedef struct drv_render drv_render;

int drv_render_create(const drv_render_opts *o, int max_vertices, drv_render **out, char *err);
void drv_render_destroy(drv_render *r);
/* V: nv x 3 world positions; F: nf x 3 0-based triangles; out: width x height millimetres. */
int drv_render_frame(drv_render *r, const float *V, int nv, const uint32_t *F, int nf,
                     uint16_t *out, char *err);
/* World point -> the camera frame (metres, Y up, looking -Z). */
void drv_render_world_to_camera(const drv_render *r, const float w[3], float c[3]);

/* Moves a mesh into the scene: rotates it about the vertical axis by yaw (radians, around the
 * point (pivot_x, *, pivot_z)), then translates by t. V, out: nv x 3 (may be the same array). */
void drv_render_place(const float *V, int nv, float yaw, float pivot_x, float pivot_z,
                      const float t[3], float *out);

#ifdef __cplusplus
}
#endif
#endif
