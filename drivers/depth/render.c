/* render.c - the test camera (see ../depth.h for the model).
 *
 * Rasterisation: per triangle, vertices projected with the pinhole model of depth.h; pixels whose
 * centres lie inside (edge functions, either winding) get 1/z interpolated linearly in screen
 * space (perspective-correct), the nearest wins (z-buffer).
 * Projector shadows: the scene is rasterised a second time from the projector's position; a camera
 * pixel whose 3D point lies behind the projector's nearest surface (by more than 1 cm + 1% of its
 * depth) is not lit by the pattern and has no reading.
 * Quantisation: z -> raw disparity d = (3.3309495 - 1/z) / 0.0030711 (depth.h), plus Gaussian noise
 * N(0, disparity_noise^2), rounded to an integer, and back to millimetres. */
#include "../depth.h"

#include "depth_internal.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct drv_render {
    drv_render_opts o;
    int max_v;
    float *cv;      /* max_v x 3 camera-frame vertices */
    float *zb;      /* W x H camera z-buffer (metres, FLT_MAX = empty) */
    float *pz;      /* W x H projector z-buffer */
    float cp, sp;   /* cos, sin of the pitch */
    uint64_t rng;
};

void drv_render_opts_default(drv_render_opts *o)
{
    memset(o, 0, sizeof *o);
    drv_intrinsics_kinect1(&o->k);
    o->cam_height = 1.0f;
    o->cam_pitch = 5.0f;
    o->floor = 1;
    o->wall_dist = 4.6f;
    o->min_range = 0.5f;
    o->max_range = 6.0f;
    o->disparity_noise = 0.35;
    o->baseline = 0.075;
    o->edge_dropout = 0.3;
    o->quantise = 1;
    o->seed = 0x72656e64u;
}

int drv_render_create(const drv_render_opts *o, int max_vertices, drv_render **out, char *err)
{
    *out = NULL;
    if (o->k.width < 1 || o->k.height < 1 || o->k.width > 8192 || o->k.height > 8192 ||
        !(o->k.fx > 0) || !(o->k.fy > 0) || max_vertices < 0 || !(o->max_range > o->min_range)) {
        if (err)
            snprintf(err, DRV_ERR_LEN, "depth render: bad options (%dx%d, fx %g, range %g..%g m)",
                     o->k.width, o->k.height, o->k.fx, o->min_range, o->max_range);
        return -EINVAL;
    }
    drv_render *r = calloc(1, sizeof *r);
    if (!r)
        goto oom;
    r->o = *o;
    r->max_v = max_vertices;
    size_t np = (size_t)o->k.width * o->k.height;
    r->cv = malloc(((size_t)max_vertices + 1) * 3 * sizeof *r->cv);
    r->zb = malloc(np * sizeof *r->zb);
    r->pz = malloc(np * sizeof *r->pz);
    if (!r->cv || !r->zb || !r->pz)
        goto oom;
    double a = o->cam_pitch * M_PI / 180.0;
    r->cp = (float)cos(a);
    r->sp = (float)sin(a);
    r->rng = o->seed ? o->seed : 1;
    *out = r;
    return 0;
oom:
    drv_render_destroy(r);
    if (err)
        snprintf(err, DRV_ERR_LEN, "depth render: out of memory");
    return -ENOMEM;
}

void drv_render_destroy(drv_render *r)
{
    if (!r)
        return;
    free(r->cv);
    free(r->zb);
    free(r->pz);
    free(r);
}

void drv_render_world_to_camera(const drv_render *r, const float w[3], float c[3])
{
    /* c = Rx(pitch) (w - C), C = (0, cam_height, 0) */
    float x = w[0], y = w[1] - r->o.cam_height, z = w[2];
    c[0] = x;
    c[1] = y * r->cp - z * r->sp;
    c[2] = y * r->sp + z * r->cp;
}

void drv_render_place(const float *V, int nv, float yaw, float pivot_x, float pivot_z,
                      const float t[3], float *out)
{
    float c = cosf(yaw), s = sinf(yaw);
    for (int i = 0; i < nv; i++) {
        float x = V[3 * i] - pivot_x, y = V[3 * i + 1], z = V[3 * i + 2] - pivot_z;
        out[3 * i] = c * x + s * z + pivot_x + t[0];
        out[3 * i + 1] = y + t[1];
        out[3 * i + 2] = -s * x + c * z + pivot_z + t[2];
    }
}

/* Rasterises the triangles with camera-frame vertices cv shifted by -ox along X into zb. */
static void raster(const drv_render *r, const float *cv, const uint32_t *F, int nf, float ox,
                   float *zb)
{
    const drv_intrinsics *k = &r->o.k;
    const int W = k->width, H = k->height;
    for (int f = 0; f < nf; f++) {
        float u[3], v[3], iz[3];
        int ok = 1;
        for (int j = 0; j < 3; j++) {
            const float *p = cv + 3 * F[3 * f + j];
            float z = -p[2];
            if (z < 0.05f) {
                ok = 0;
                break;
            }
            iz[j] = 1.f / z;
            u[j] = (float)(k->cx + k->fx * (p[0] - ox) * iz[j]);
            v[j] = (float)(k->cy - k->fy * p[1] * iz[j]);
        }
        if (!ok)
            continue;
        float area = (u[1] - u[0]) * (v[2] - v[0]) - (u[2] - u[0]) * (v[1] - v[0]);
        if (fabsf(area) < 1e-9f)
            continue;
        int x0 = (int)ceilf(fminf(u[0], fminf(u[1], u[2])));
        int x1 = (int)floorf(fmaxf(u[0], fmaxf(u[1], u[2])));
        int y0 = (int)ceilf(fminf(v[0], fminf(v[1], v[2])));
        int y1 = (int)floorf(fmaxf(v[0], fmaxf(v[1], v[2])));
        if (x0 < 0)
            x0 = 0;
        if (y0 < 0)
            y0 = 0;
        if (x1 > W - 1)
            x1 = W - 1;
        if (y1 > H - 1)
            y1 = H - 1;
        float ia = 1.f / area;
        for (int y = y0; y <= y1; y++) {
            for (int x = x0; x <= x1; x++) {
                float w0 = ((u[1] - x) * (v[2] - y) - (u[2] - x) * (v[1] - y)) * ia;
                float w1 = ((u[2] - x) * (v[0] - y) - (u[0] - x) * (v[2] - y)) * ia;
                float w2 = 1.f - w0 - w1;
                if (w0 < 0 || w1 < 0 || w2 < 0)
                    continue;
                float z = 1.f / (w0 * iz[0] + w1 * iz[1] + w2 * iz[2]);
                float *d = zb + (size_t)y * W + x;
                if (z < *d)
                    *d = z;
            }
        }
    }
}

static double gauss(uint64_t *s)
{
    double u1 = drv__rand01(s), u2 = drv__rand01(s);
    if (u1 < 1e-300)
        u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
}

int drv_render_frame(drv_render *r, const float *V, int nv, const uint32_t *F, int nf,
                     uint16_t *out, char *err)
{
    const drv_intrinsics *k = &r->o.k;
    const int W = k->width, H = k->height;
    const size_t np = (size_t)W * H;
    if (nv < 0 || nv > r->max_v || nf < 0 || (nf && !F) || (nv && !V)) {
        if (err)
            snprintf(err, DRV_ERR_LEN, "depth render: %d vertices (at most %d), %d triangles", nv,
                     r->max_v, nf);
        return -EINVAL;
    }
    for (int f = 0; f < 3 * nf; f++)
        if (F[f] >= (uint32_t)nv) {
            if (err)
                snprintf(err, DRV_ERR_LEN, "depth render: triangle %d uses vertex %u of %d", f / 3,
                         F[f], nv);
            return -EINVAL;
        }
    for (int i = 0; i < nv; i++)
        drv_render_world_to_camera(r, V + 3 * i, r->cv + 3 * i);
    for (size_t i = 0; i < np; i++)
        r->zb[i] = r->pz[i] = FLT_MAX;
    raster(r, r->cv, F, nf, 0, r->zb);
    const float b = (float)r->o.baseline;
    if (b != 0)
        raster(r, r->cv, F, nf, b, r->pz);
    /* floor and wall: ray d_c = ((u-cx)/fx, -(v-cy)/fy, -1) in the camera frame, in the world
     * d_w = Rx(-pitch) d_c; the depth along the axis equals the ray parameter t */
    if (r->o.floor || r->o.wall_dist > 0) {
        for (int y = 0; y < H; y++) {
            float dy = (float)(-(y - k->cy) / k->fy);
            for (int x = 0; x < W; x++) {
                float wy = dy * r->cp + (-1.f) * r->sp;  /* Rx(-a): y' = y c + z s */
                float wz = -dy * r->sp + (-1.f) * r->cp; /*         z' = -y s + z c */
                float t = FLT_MAX;
                if (r->o.floor && wy < 0)
                    t = -r->o.cam_height / wy;
                if (r->o.wall_dist > 0 && wz < 0) {
                    float tw = -r->o.wall_dist / wz;
                    if (tw < t)
                        t = tw;
                }
                float *d = r->zb + (size_t)y * W + x;
                if (t < *d)
                    *d = t;
            }
        }
    }
    /* shadows, dropouts, quantisation */
    for (int y = 0; y < H; y++) {
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * W + x;
            float z = r->zb[i];
            out[i] = 0;
            if (z < r->o.min_range || z > r->o.max_range)
                continue;
            if (b != 0) {
                double pu = k->cx + k->fx * ((x - k->cx) / k->fx * z - b) / z;
                int qx = (int)lround(pu);
                if (qx >= 0 && qx < W) {
                    float pzv = r->pz[(size_t)y * W + qx];
                    if (pzv < z - 0.01f - 0.01f * z)
                        continue;
                }
            }
            if (r->o.edge_dropout > 0) {
                float tol = 0.05f + 0.02f * z;
                int edge = (x > 0 && fabsf(r->zb[i - 1] - z) > tol) ||
                           (x < W - 1 && fabsf(r->zb[i + 1] - z) > tol) ||
                           (y > 0 && fabsf(r->zb[i - W] - z) > tol) ||
                           (y < H - 1 && fabsf(r->zb[i + W] - z) > tol);
                if (edge && drv__rand01(&r->rng) < r->o.edge_dropout)
                    continue;
            }
            double zq = z;
            if (r->o.quantise) {
                double d = drv_kinect1_m_to_disparity(z);
                if (r->o.disparity_noise > 0)
                    d += r->o.disparity_noise * gauss(&r->rng);
                d = floor(d + 0.5);
                zq = drv_kinect1_disparity_to_m(d);
                if (zq <= 0)
                    continue;
            }
            long mm = lround(zq * 1000.0);
            out[i] = (uint16_t)(mm > 65535 ? 0 : mm);
        }
    }
    return 0;
}
