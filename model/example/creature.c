/* creature.c - the built-in example: a procedurally generated four-legged creature.
 *
 * Everything here is our own construction, deterministic (no random numbers, no clocks), so that the
 * demo and the tests run with nothing outside the repository:
 *
 *   1. Shape. The rest surface is the zero set of a signed-distance-like field f(p): the smooth union
 *      (polynomial smooth minimum, blend width SMIN_K) of 14 tapered capsules, one per bone: hind and
 *      front body (elliptic cross-section), neck, head, two tail segments and two segments for each of
 *      the four legs. Y up, the creature faces +X, its right side is +Z, metres; about 1.7 m long.
 *   2. Polygonisation. Marching tetrahedra on a regular grid (spacing GRID_H) with the Freudenthal
 *      (Kuhn) split of every cube into 6 tetrahedra around its main diagonal. Neighbouring cubes split
 *      their shared faces the same way, so the surface is a closed 2-manifold; one vertex per crossed
 *      grid edge (shared through an edge table), triangles oriented so that their normal points from
 *      the inside corner to the outside corner of a crossed edge (outward). The crossing parameter is
 *      clamped to [T_CLAMP, 1 - T_CLAMP]: vertices then lie strictly inside their edges, which
 *      guarantees that no triangle is degenerate. Only the largest connected component is kept.
 *   3. Skinning. Linear blend skinning, v' = sum_b w_b(v) G_b (v + bulge(v)); the weights are
 *      w_b ~ exp(-(d_b(v) - min_c d_c(v)) / WEIGHT_SIGMA), d_b the distance of the rest vertex to bone
 *      b's capsule surface, cut below WEIGHT_CUT, at most 4 per vertex, normalised.
 *   4. Bulging. Before skinning, rest vertices of each upper leg move radially away from the bone axis
 *      by BULGE_LEG * w_upper * bump(s) * (knee flexion / KNEE_REF) (a muscle that swells, mostly on
 *      the back of the leg, as the knee bends), and neck vertices on the underside by BULGE_NECK times
 *      the neck's lift: per-part shape changes that are not rigid, for the model to learn.
 *   5. Motion. A gait in place: each leg swings at the hip with its own phase offset, the knee flexes
 *      during the swing phase, the body bobs twice per cycle, the spine pitches, neck and head nod,
 *      the tail swishes sideways. The example sequence is a walk; the marker recording is a trot at a
 *      different rate, amplitude and starting phase.
 *
 * Allocation: outputs are allocated with malloc exactly as the owners' destroy functions expect
 * (model.h): mdl_meshseq struct, V, F; mdl_rig struct, markers, limb_off, limb_idx; mdl_markers
 * struct, P, valid, names and each names[i].
 */
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EX_FPS 30.0
#define GRID_H 0.053       /* polygonisation grid spacing (m); gives about 4800 vertices */
#define SMIN_K 0.05        /* smooth-union blend width (m) */
#define T_CLAMP 0.02       /* edge crossing parameter clamp */
#define WEIGHT_SIGMA 0.025 /* skinning weight falloff (m) */
#define WEIGHT_CUT 0.01
#define BULGE_LEG 0.28     /* relative radius growth of the upper leg at full knee flexion */
#define BULGE_NECK 0.12
#define KNEE_REF 0.7       /* knee flexion (rad) at which the leg bulge is BULGE_LEG */
#define MAX_FRAMES 100000

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ------------------------------------------------------------------ skeleton */

enum {
    B_HIND, B_FRONT, B_NECK, B_HEAD, B_TAIL1, B_TAIL2,
    B_LF_UP, B_LF_LO, B_RF_UP, B_RF_LO, B_LH_UP, B_LH_LO, B_RH_UP, B_RH_LO,
    NBONES
};
enum { LEG_LF, LEG_RF, LEG_LH, LEG_RH, NLEGS };

/* One bone = one tapered capsule a->b (radii ra->rb); the bone rotates about a. zs < 1 narrows the
 * cross-section sideways (an elliptic body, deeper than wide). */
typedef struct bone {
    int parent;
    double a[3], b[3];
    double ra, rb, zs;
} bone;

static const bone skel[NBONES] = {
    [B_HIND] = {-1, {-0.02, 0.94, 0}, {-0.42, 0.92, 0}, 0.21, 0.20, 0.8},
    [B_FRONT] = {B_HIND, {-0.02, 0.94, 0}, {0.36, 0.97, 0}, 0.21, 0.19, 0.8},
    [B_NECK] = {B_FRONT, {0.40, 1.02, 0}, {0.60, 1.29, 0}, 0.12, 0.095, 0.85},
    [B_HEAD] = {B_NECK, {0.60, 1.29, 0}, {0.80, 1.22, 0}, 0.10, 0.075, 0.9},
    [B_TAIL1] = {B_HIND, {-0.52, 1.00, 0}, {-0.72, 0.87, 0}, 0.075, 0.07, 1.0},
    [B_TAIL2] = {B_TAIL1, {-0.72, 0.87, 0}, {-0.86, 0.64, 0}, 0.07, 0.065, 1.0},
    [B_LF_UP] = {B_FRONT, {0.30, 0.82, -0.14}, {0.33, 0.48, -0.14}, 0.095, 0.075, 1.0},
    [B_LF_LO] = {B_LF_UP, {0.33, 0.48, -0.14}, {0.31, 0.10, -0.14}, 0.068, 0.065, 1.0},
    [B_RF_UP] = {B_FRONT, {0.30, 0.82, 0.14}, {0.33, 0.48, 0.14}, 0.095, 0.075, 1.0},
    [B_RF_LO] = {B_RF_UP, {0.33, 0.48, 0.14}, {0.31, 0.10, 0.14}, 0.068, 0.065, 1.0},
    [B_LH_UP] = {B_HIND, {-0.36, 0.82, -0.14}, {-0.40, 0.48, -0.14}, 0.105, 0.075, 1.0},
    [B_LH_LO] = {B_LH_UP, {-0.40, 0.48, -0.14}, {-0.37, 0.10, -0.14}, 0.068, 0.065, 1.0},
    [B_RH_UP] = {B_HIND, {-0.36, 0.82, 0.14}, {-0.40, 0.48, 0.14}, 0.105, 0.075, 1.0},
    [B_RH_LO] = {B_RH_UP, {-0.40, 0.48, 0.14}, {-0.37, 0.10, 0.14}, 0.068, 0.065, 1.0},
};

static const int leg_up[NLEGS] = {B_LF_UP, B_RF_UP, B_LH_UP, B_RH_UP};

/* Signed distance (approximate) of p to bone b's tapered capsule; *s gets the axis parameter. */
static double capsule_dist(const bone *bn, const double p[3], double *s_out)
{
    double d[3], q[3];
    for (int i = 0; i < 3; i++) {
        d[i] = bn->b[i] - bn->a[i];
        q[i] = p[i] - bn->a[i];
    }
    double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    double s = (q[0] * d[0] + q[1] * d[1] + q[2] * d[2]) / dd;
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    double e[3];
    for (int i = 0; i < 3; i++)
        e[i] = q[i] - s * d[i];
    e[2] /= bn->zs;
    if (s_out)
        *s_out = s;
    return sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) - (bn->ra + s * (bn->rb - bn->ra));
}

static double smin(double a, double b, double k)
{
    double h = k - fabs(a - b);
    if (h <= 0)
        return a < b ? a : b;
    h /= k;
    return (a < b ? a : b) - h * h * k * 0.25;
}

static double field(const double p[3])
{
    double f = capsule_dist(&skel[0], p, NULL);
    for (int b = 1; b < NBONES; b++)
        f = smin(f, capsule_dist(&skel[b], p, NULL), SMIN_K);
    return f;
}

/* ------------------------------------------------------------------ rest mesh */

typedef struct creature {
    int nv, nf;
    float *rest;    /* nv x 3 */
    uint32_t *F;    /* nf x 3 */
    float *W;       /* nv x NBONES skinning weights, rows sum to 1 */
} creature;

static void creature_fini(creature *c)
{
    free(c->rest);
    free(c->F);
    free(c->W);
    memset(c, 0, sizeof *c);
}

typedef struct grow {
    void *p;
    size_t n, cap, elem;
} grow;

static int grow_push(grow *g, const void *x)
{
    if (g->n == g->cap) {
        size_t cap = g->cap ? g->cap * 2 : 4096;
        void *p = realloc(g->p, cap * g->elem);
        if (!p)
            return -ENOMEM;
        g->p = p;
        g->cap = cap;
    }
    memcpy((char *)g->p + g->n * g->elem, x, g->elem);
    g->n++;
    return 0;
}

static int uf_find(int *parent, int x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* Marching tetrahedra over the grid, then the largest component. Fills c->rest, c->F, nv, nf. */
static int polygonise(creature *c, char *err)
{
    double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
    for (int b = 0; b < NBONES; b++) {
        double r = skel[b].ra > skel[b].rb ? skel[b].ra : skel[b].rb;
        for (int i = 0; i < 3; i++) {
            double m0 = fmin(skel[b].a[i], skel[b].b[i]) - r, m1 = fmax(skel[b].a[i], skel[b].b[i]) + r;
            lo[i] = fmin(lo[i], m0);
            hi[i] = fmax(hi[i], m1);
        }
    }
    int n[3];
    double o[3];
    for (int i = 0; i < 3; i++) {
        o[i] = lo[i] - 2 * GRID_H;
        n[i] = (int)ceil((hi[i] - lo[i]) / GRID_H) + 5;
    }
    size_t ng = (size_t)n[0] * n[1] * n[2];
    double *fv = mdl__calloc(ng, sizeof *fv);
    int *edge_vert = malloc(ng * 7 * sizeof *edge_vert);
    grow verts = {NULL, 0, 0, sizeof(float) * 3}, tris = {NULL, 0, 0, sizeof(uint32_t) * 3};
    int *parent = NULL, *count = NULL, *remap = NULL;
    int rc = -ENOMEM;
    if (!fv || !edge_vert)
        goto out;
    for (size_t i = 0; i < ng * 7; i++)
        edge_vert[i] = -1;
    for (int k = 0; k < n[2]; k++)
        for (int j = 0; j < n[1]; j++)
            for (int i = 0; i < n[0]; i++) {
                double p[3] = {o[0] + i * GRID_H, o[1] + j * GRID_H, o[2] + k * GRID_H};
                fv[i + (size_t)n[0] * (j + (size_t)n[1] * k)] = field(p);
            }

    static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int k = 0; k + 1 < n[2]; k++)
        for (int j = 0; j + 1 < n[1]; j++)
            for (int i = 0; i + 1 < n[0]; i++) {
                size_t gi[8];
                double cp[8][3], cf[8];
                for (int bits = 0; bits < 8; bits++) {
                    int ii = i + (bits & 1), jj = j + (bits >> 1 & 1), kk = k + (bits >> 2 & 1);
                    gi[bits] = ii + (size_t)n[0] * (jj + (size_t)n[1] * kk);
                    cp[bits][0] = o[0] + ii * GRID_H;
                    cp[bits][1] = o[1] + jj * GRID_H;
                    cp[bits][2] = o[2] + kk * GRID_H;
                    cf[bits] = fv[gi[bits]];
                }
                for (int t = 0; t < 6; t++) {
                    int q[4] = {0, 1 << perm[t][0], (1 << perm[t][0]) | (1 << perm[t][1]), 7};
                    int in[4], nin = 0, out_[4], nout = 0;
                    for (int v = 0; v < 4; v++) {
                        if (cf[q[v]] < 0)
                            in[nin++] = q[v];
                        else
                            out_[nout++] = q[v];
                    }
                    if (nin == 0 || nin == 4)
                        continue;
                    /* Crossed edges as (inside corner, outside corner) pairs, in triangle order. */
                    int e[2][3][2], ntri;
                    if (nin == 1) {
                        ntri = 1;
                        for (int v = 0; v < 3; v++) {
                            e[0][v][0] = in[0];
                            e[0][v][1] = out_[v];
                        }
                    } else if (nin == 3) {
                        ntri = 1;
                        for (int v = 0; v < 3; v++) {
                            e[0][v][0] = in[v];
                            e[0][v][1] = out_[0];
                        }
                    } else { /* quad ac, ad, bd, bc */
                        int a = in[0], b = in[1], cc = out_[0], d = out_[1];
                        int quad[4][2] = {{a, cc}, {a, d}, {b, d}, {b, cc}};
                        static const int split[2][3] = {{0, 1, 2}, {0, 2, 3}};
                        ntri = 2;
                        for (int tt = 0; tt < 2; tt++)
                            for (int v = 0; v < 3; v++) {
                                e[tt][v][0] = quad[split[tt][v]][0];
                                e[tt][v][1] = quad[split[tt][v]][1];
                            }
                    }
                    for (int tt = 0; tt < ntri; tt++) {
                        uint32_t tri[3];
                        float pos[3][3];
                        for (int v = 0; v < 3; v++) {
                            int u0 = e[tt][v][0], u1 = e[tt][v][1];
                            int lo_c = u0 & u1, hi_c = u0 | u1; /* Kuhn corners are nested */
                            size_t key = gi[lo_c] * 7 + (size_t)((hi_c ^ lo_c) - 1);
                            double tpar = cf[lo_c] / (cf[lo_c] - cf[hi_c]);
                            tpar = tpar < T_CLAMP ? T_CLAMP : tpar > 1 - T_CLAMP ? 1 - T_CLAMP : tpar;
                            for (int x = 0; x < 3; x++)
                                pos[v][x] = (float)(cp[lo_c][x] + tpar * (cp[hi_c][x] - cp[lo_c][x]));
                            if (edge_vert[key] < 0) {
                                if (verts.n >= INT32_MAX)
                                    goto out;
                                edge_vert[key] = (int)verts.n;
                                if ((rc = grow_push(&verts, pos[v])) != 0)
                                    goto out;
                                rc = -ENOMEM;
                            }
                            tri[v] = (uint32_t)edge_vert[key];
                        }
                        /* Orient: the normal points from the inside corner to the outside corner of
                         * the first vertex's edge (that edge crosses the triangle's plane once). */
                        double ab[3], ac[3], dir[3];
                        for (int x = 0; x < 3; x++) {
                            ab[x] = pos[1][x] - pos[0][x];
                            ac[x] = pos[2][x] - pos[0][x];
                            dir[x] = cp[e[tt][0][1]][x] - cp[e[tt][0][0]][x];
                        }
                        double nrm[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                                         ab[0] * ac[1] - ab[1] * ac[0]};
                        if (nrm[0] * dir[0] + nrm[1] * dir[1] + nrm[2] * dir[2] < 0) {
                            uint32_t sw = tri[1];
                            tri[1] = tri[2];
                            tri[2] = sw;
                        }
                        if ((rc = grow_push(&tris, tri)) != 0)
                            goto out;
                        rc = -ENOMEM;
                    }
                }
            }

    /* Keep the largest connected component (stray blobs cannot occur with these capsules, but the
     * guarantee is cheap). */
    int nv = (int)verts.n, nf = (int)tris.n;
    const uint32_t *T = tris.p;
    const float *P = verts.p;
    parent = malloc((size_t)nv * sizeof *parent);
    count = mdl__calloc((size_t)nv, sizeof *count);
    remap = malloc((size_t)nv * sizeof *remap);
    if (!parent || !count || !remap)
        goto out;
    for (int v = 0; v < nv; v++)
        parent[v] = v;
    for (int f = 0; f < nf; f++)
        for (int x = 1; x < 3; x++) {
            int r0 = uf_find(parent, (int)T[3 * f]), r1 = uf_find(parent, (int)T[3 * f + x]);
            if (r0 != r1)
                parent[r0 < r1 ? r1 : r0] = r0 < r1 ? r0 : r1;
        }
    int best = -1;
    for (int v = 0; v < nv; v++) {
        int r = uf_find(parent, v);
        if (++count[r] > (best < 0 ? 0 : count[best]))
            best = r;
    }
    int kv = 0, kf = 0;
    for (int v = 0; v < nv; v++)
        remap[v] = uf_find(parent, v) == best ? kv++ : -1;
    for (int f = 0; f < nf; f++)
        kf += remap[T[3 * f]] >= 0;
    c->rest = malloc((size_t)kv * 3 * sizeof *c->rest);
    c->F = malloc((size_t)kf * 3 * sizeof *c->F);
    if (!c->rest || !c->F)
        goto out;
    for (int v = 0; v < nv; v++)
        if (remap[v] >= 0)
            memcpy(c->rest + 3 * remap[v], P + 3 * v, 3 * sizeof(float));
    kf = 0;
    for (int f = 0; f < nf; f++)
        if (remap[T[3 * f]] >= 0) {
            for (int x = 0; x < 3; x++)
                c->F[3 * kf + x] = (uint32_t)remap[T[3 * f + x]];
            kf++;
        }
    c->nv = kv;
    c->nf = kf;
    rc = 0;
out:
    if (rc)
        mdl__err(err, rc, "example: out of memory while polygonising the creature");
    free(fv);
    free(edge_vert);
    free(verts.p);
    free(tris.p);
    free(parent);
    free(count);
    free(remap);
    return rc;
}

static int skin_weights(creature *c, char *err)
{
    c->W = mdl__calloc((size_t)c->nv * NBONES, sizeof *c->W);
    if (!c->W)
        return mdl__err(err, -ENOMEM, "example: out of memory for skinning weights");
    for (int v = 0; v < c->nv; v++) {
        double p[3] = {c->rest[3 * v], c->rest[3 * v + 1], c->rest[3 * v + 2]};
        double d[NBONES], dmin = 1e9, w[NBONES];
        for (int b = 0; b < NBONES; b++) {
            d[b] = capsule_dist(&skel[b], p, NULL);
            dmin = fmin(dmin, d[b]);
        }
        for (int b = 0; b < NBONES; b++) {
            w[b] = exp(-(d[b] - dmin) / WEIGHT_SIGMA);
            if (w[b] < WEIGHT_CUT)
                w[b] = 0;
        }
        /* at most 4 influences: drop the smallest until 4 remain (ties: the higher bone index) */
        for (;;) {
            int nz = 0, small = -1;
            for (int b = 0; b < NBONES; b++)
                if (w[b] > 0) {
                    nz++;
                    if (small < 0 || w[b] <= w[small])
                        small = b;
                }
            if (nz <= 4)
                break;
            w[small] = 0;
        }
        double sum = 0;
        for (int b = 0; b < NBONES; b++)
            sum += w[b];
        for (int b = 0; b < NBONES; b++)
            c->W[(size_t)v * NBONES + b] = (float)(w[b] / sum);
    }
    return 0;
}

static int creature_init(creature *c, char *err)
{
    memset(c, 0, sizeof *c);
    int rc = polygonise(c, err);
    if (!rc)
        rc = skin_weights(c, err);
    if (rc)
        creature_fini(c);
    return rc;
}

/* ------------------------------------------------------------------ motion */

typedef struct gait {
    double hz;            /* gait cycles per second */
    double phase0;        /* phase at frame 0, in cycles */
    double leg_phase[NLEGS];
    double hip_amp, knee_amp, knee_base;
    double bob, pitch, neck_amp, tail_amp;
} gait;

/* The example sequence: a walk (lateral sequence LH, LF, RH, RF). */
static const gait walk = {0.8, 0.0, {0.25, 0.75, 0.0, 0.5}, 0.38, 0.75, 0.05, 0.022, 0.035, 0.14, 0.3};
/* The marker recording: a trot (diagonal pairs), slightly smaller strides. */
static const gait trot = {0.8, 0.37, {0.0, 0.5, 0.5, 0.0}, 0.32, 0.62, 0.08, 0.018, 0.03, 0.1, 0.22};

typedef struct xform {
    double R[9]; /* row-major 3x3 */
    double t[3];
} xform;

static void rot_axis(double R[9], int axis, double ang)
{
    double c = cos(ang), s = sin(ang);
    memset(R, 0, 9 * sizeof *R);
    int i = (axis + 1) % 3, j = (axis + 2) % 3;
    R[axis * 3 + axis] = 1;
    R[i * 3 + i] = c;
    R[i * 3 + j] = -s;
    R[j * 3 + i] = s;
    R[j * 3 + j] = c;
}

/* Bone transforms G_b (rest space -> posed space) and the pose parameters of time t (seconds). */
typedef struct pose {
    xform G[NBONES];
    double knee_flex[NLEGS]; /* >= 0, radians */
    double neck_lift;        /* >= 0 */
} pose;

static void pose_at(const gait *g, double t, pose *ps)
{
    double ph = g->phase0 + g->hz * t;
    double ang[NBONES] = {0};
    int axis[NBONES];
    for (int b = 0; b < NBONES; b++)
        axis[b] = 2; /* most joints bend about the lateral axis Z */
    double w2 = 2 * M_PI * 2 * ph;
    ang[B_FRONT] = g->pitch * sin(w2);
    ang[B_NECK] = g->neck_amp * sin(w2 + 0.6);
    ang[B_HEAD] = -0.6 * g->neck_amp * sin(w2 + 0.9);
    axis[B_TAIL1] = axis[B_TAIL2] = 1; /* the tail swishes about Y */
    ang[B_TAIL1] = g->tail_amp * sin(2 * M_PI * ph);
    ang[B_TAIL2] = 0.8 * g->tail_amp * sin(2 * M_PI * ph - 0.9);
    for (int l = 0; l < NLEGS; l++) {
        double psi = 2 * M_PI * (ph + g->leg_phase[l]);
        double swing = 0.5 + 0.5 * cos(psi); /* 1 mid-swing (leg moving forward), 0 mid-stance */
        double flex = g->knee_base + g->knee_amp * swing * swing;
        ang[leg_up[l]] = g->hip_amp * sin(psi) + (l >= LEG_LH ? 0.06 : -0.04);
        ang[leg_up[l] + 1] = -flex; /* the lower leg folds backward */
        ps->knee_flex[l] = flex;
    }
    ps->neck_lift = 0.5 + 0.5 * sin(w2 + 0.6);
    for (int b = 0; b < NBONES; b++) {
        xform L;
        rot_axis(L.R, axis[b], ang[b]);
        const double *a = skel[b].a;
        for (int i = 0; i < 3; i++)
            L.t[i] = a[i] - (L.R[i * 3] * a[0] + L.R[i * 3 + 1] * a[1] + L.R[i * 3 + 2] * a[2]);
        if (b == B_HIND) {
            L.t[1] += g->bob * cos(w2);
            ps->G[b] = L;
            continue;
        }
        const xform *P = &ps->G[skel[b].parent]; /* parents come first */
        xform *G = &ps->G[b];
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++)
                G->R[i * 3 + j] = P->R[i * 3] * L.R[j] + P->R[i * 3 + 1] * L.R[3 + j] +
                                  P->R[i * 3 + 2] * L.R[6 + j];
            G->t[i] = P->R[i * 3] * L.t[0] + P->R[i * 3 + 1] * L.t[1] + P->R[i * 3 + 2] * L.t[2] +
                      P->t[i];
        }
    }
}

/* Radial offset of rest point p from bone b's axis and the axis parameter s. */
static void radial(int b, const double p[3], double r[3], double *s)
{
    capsule_dist(&skel[b], p, s);
    for (int i = 0; i < 3; i++)
        r[i] = p[i] - (skel[b].a[i] + *s * (skel[b].b[i] - skel[b].a[i]));
}

/* Poses the creature: out (nv x 3) = LBS of the bulged rest shape. */
static void creature_pose(const creature *c, const gait *g, double t, float *out)
{
    pose ps;
    pose_at(g, t, &ps);
    for (int v = 0; v < c->nv; v++) {
        const float *W = c->W + (size_t)v * NBONES;
        double p[3] = {c->rest[3 * v], c->rest[3 * v + 1], c->rest[3 * v + 2]}, q[3] = {p[0], p[1], p[2]};
        for (int l = 0; l < NLEGS; l++) {
            int b = leg_up[l];
            if (W[b] <= 0)
                continue;
            double r[3], s;
            radial(b, p, r, &s);
            double rn = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
            double back = rn > 0 ? -r[0] / rn : 0; /* 1 on the back of the leg */
            double bump = exp(-((s - 0.6) / 0.25) * ((s - 0.6) / 0.25));
            double k = BULGE_LEG * W[b] * bump * (0.6 + 0.4 * fmax(back, 0.0)) * ps.knee_flex[l] / KNEE_REF;
            for (int i = 0; i < 3; i++)
                q[i] += k * r[i];
        }
        if (W[B_NECK] > 0) {
            double r[3], s;
            radial(B_NECK, p, r, &s);
            double rn = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
            double under = rn > 0 ? fmax(-r[1] / rn, 0.0) : 0;
            double bump = exp(-((s - 0.45) / 0.3) * ((s - 0.45) / 0.3));
            double k = BULGE_NECK * W[B_NECK] * bump * under * ps.neck_lift;
            for (int i = 0; i < 3; i++)
                q[i] += k * r[i];
        }
        double o[3] = {0, 0, 0};
        for (int b = 0; b < NBONES; b++) {
            if (W[b] <= 0)
                continue;
            const xform *G = &ps.G[b];
            for (int i = 0; i < 3; i++)
                o[i] += W[b] * (G->R[i * 3] * q[0] + G->R[i * 3 + 1] * q[1] + G->R[i * 3 + 2] * q[2] + G->t[i]);
        }
        for (int i = 0; i < 3; i++)
            out[3 * v + i] = (float)o[i];
    }
}

static int make_seq(const creature *c, const gait *g, int frames, mdl_meshseq **out, char *err)
{
    mdl_meshseq *s = calloc(1, sizeof *s);
    if (s) {
        s->V = malloc((size_t)frames * c->nv * 3 * sizeof *s->V);
        s->F = malloc((size_t)c->nf * 3 * sizeof *s->F);
    }
    if (!s || !s->V || !s->F) {
        if (s) {
            free(s->V);
            free(s->F);
        }
        free(s);
        return mdl__err(err, -ENOMEM, "example: out of memory for %d frames", frames);
    }
    s->nv = c->nv;
    s->nf = c->nf;
    s->frames = frames;
    s->fps = EX_FPS;
    memcpy(s->F, c->F, (size_t)c->nf * 3 * sizeof *s->F);
    for (int f = 0; f < frames; f++)
        creature_pose(c, g, f / EX_FPS, s->V + (size_t)f * c->nv * 3);
    *out = s;
    return 0;
}

/* ------------------------------------------------------------------ rig */

static const char *const marker_names[] = {"lf_foot", "rf_foot", "lh_foot", "rh_foot",
                                           "head",    "tail",    "withers", "croup"};
enum { M_LF, M_RF, M_LH, M_RH, M_HEAD, M_TAIL, M_WITHERS, M_CROUP, NMARKERS };

static int nearest_vertex(const creature *c, const double p[3])
{
    int best = 0;
    double bd = 1e30;
    for (int v = 0; v < c->nv; v++) {
        double d = 0;
        for (int i = 0; i < 3; i++)
            d += (c->rest[3 * v + i] - p[i]) * (c->rest[3 * v + i] - p[i]);
        if (d < bd) {
            bd = d;
            best = v;
        }
    }
    return best;
}

/* The point at distance r beyond bone b's end b, along the bone. */
static void bone_tip(int b, double r, double p[3])
{
    double d[3], n = 0;
    for (int i = 0; i < 3; i++) {
        d[i] = skel[b].b[i] - skel[b].a[i];
        n += d[i] * d[i];
    }
    n = sqrt(n);
    for (int i = 0; i < 3; i++)
        p[i] = skel[b].b[i] + r * d[i] / n;
}

static int make_rig(const creature *c, mdl_rig **out, char *err)
{
    static const int limbs[6][2] = {{M_WITHERS, M_LF}, {M_WITHERS, M_RF}, {M_CROUP, M_LH},
                                    {M_CROUP, M_RH},   {M_WITHERS, M_HEAD}, {M_CROUP, M_TAIL}};
    mdl_rig *r = calloc(1, sizeof *r);
    if (r) {
        r->markers = calloc(NMARKERS, sizeof *r->markers);
        r->limb_off = malloc(7 * sizeof *r->limb_off);
        r->limb_idx = malloc(12 * sizeof *r->limb_idx);
    }
    if (!r || !r->markers || !r->limb_off || !r->limb_idx) {
        if (r) {
            free(r->markers);
            free(r->limb_off);
            free(r->limb_idx);
        }
        free(r);
        return mdl__err(err, -ENOMEM, "example: out of memory for the rig");
    }
    double p[3];
    static const int lower[4] = {B_LF_LO, B_RF_LO, B_LH_LO, B_RH_LO};
    for (int m = 0; m < NMARKERS; m++) {
        switch (m) {
        case M_LF: case M_RF: case M_LH: case M_RH:
            memcpy(p, skel[lower[m]].b, sizeof p);
            p[1] -= skel[lower[m]].rb;
            break;
        case M_HEAD:
            bone_tip(B_HEAD, skel[B_HEAD].rb, p);
            break;
        case M_TAIL:
            bone_tip(B_TAIL2, skel[B_TAIL2].rb, p);
            break;
        case M_WITHERS:
            memcpy(p, skel[B_FRONT].b, sizeof p);
            p[1] += skel[B_FRONT].rb;
            break;
        default: /* croup */
            memcpy(p, skel[B_HIND].b, sizeof p);
            p[1] += skel[B_HIND].rb;
            break;
        }
        snprintf(r->markers[m].name, MDL_NAME_LEN, "%s", marker_names[m]);
        snprintf(r->markers[m].source, MDL_NAME_LEN, "%s", marker_names[m]);
        r->markers[m].vertex = nearest_vertex(c, p);
    }
    r->nmarkers = NMARKERS;
    r->nref = 2;
    r->ref[0] = M_WITHERS;
    r->ref[1] = M_CROUP;
    r->ref[2] = -1;
    r->nlimbs = 6;
    for (int l = 0; l <= 6; l++)
        r->limb_off[l] = 2 * l;
    for (int l = 0; l < 6; l++) {
        r->limb_idx[2 * l] = limbs[l][0];
        r->limb_idx[2 * l + 1] = limbs[l][1];
    }
    *out = r;
    return 0;
}

/* ------------------------------------------------------------------ public */

int mdl_example_create(int frames, mdl_meshseq **seq, mdl_rig **rig, char *err)
{
    if (seq)
        *seq = NULL;
    if (rig)
        *rig = NULL;
    if (frames < 1 || frames > MAX_FRAMES)
        return mdl__err(err, -EINVAL, "example: %d frames is outside 1..%d", frames, MAX_FRAMES);
    creature c;
    int rc = creature_init(&c, err);
    if (rc)
        return rc;
    mdl_meshseq *s = NULL;
    mdl_rig *r = NULL;
    if (seq)
        rc = make_seq(&c, &walk, frames, &s, err);
    if (!rc && rig)
        rc = make_rig(&c, &r, err);
    creature_fini(&c);
    if (rc) {
        if (s) {
            free(s->V);
            free(s->F);
            free(s);
        }
        return rc;
    }
    if (seq)
        *seq = s;
    if (rig)
        *rig = r;
    return 0;
}

int mdl_example_markers(const mdl_rig *rig, int frames, double speed, mdl_markers **out,
                        mdl_meshseq **truth, char *err)
{
    *out = NULL;
    if (truth)
        *truth = NULL;
    if (frames < 1 || frames > MAX_FRAMES)
        return mdl__err(err, -EINVAL, "example: %d frames is outside 1..%d", frames, MAX_FRAMES);
    if (!(speed > 0 && speed <= 10))
        return mdl__err(err, -EINVAL, "example: gait speed %g is outside (0, 10]", speed);
    if (!rig || rig->nmarkers < 1)
        return mdl__err(err, -EINVAL, "example: the rig has no markers");
    creature c;
    int rc = creature_init(&c, err);
    if (rc)
        return rc;
    for (int m = 0; m < rig->nmarkers; m++)
        if (rig->markers[m].vertex < 0 || rig->markers[m].vertex >= c.nv) {
            rc = mdl__err(err, -EINVAL, "example: rig marker '%s' has vertex %d, the creature has %d",
                          rig->markers[m].name, rig->markers[m].vertex, c.nv);
            creature_fini(&c);
            return rc;
        }
    gait g = trot;
    g.hz *= speed;
    mdl_meshseq *s = NULL;
    rc = make_seq(&c, &g, frames, &s, err);
    creature_fini(&c);
    if (rc)
        return rc;
    mdl_markers *mk = calloc(1, sizeof *mk);
    if (mk) {
        mk->P = malloc((size_t)frames * rig->nmarkers * 3 * sizeof *mk->P);
        mk->valid = malloc((size_t)frames * rig->nmarkers);
        mk->names = calloc((size_t)rig->nmarkers, sizeof *mk->names);
    }
    int ok = mk && mk->P && mk->valid && mk->names;
    for (int m = 0; ok && m < rig->nmarkers; m++)
        ok = (mk->names[m] = strdup(rig->markers[m].source[0] ? rig->markers[m].source
                                                              : rig->markers[m].name)) != NULL;
    if (!ok) {
        if (mk) {
            for (int m = 0; mk->names && m < rig->nmarkers; m++)
                free(mk->names[m]);
            free(mk->names);
            free(mk->P);
            free(mk->valid);
            free(mk);
        }
        free(s->V);
        free(s->F);
        free(s);
        return mdl__err(err, -ENOMEM, "example: out of memory for %d marker frames", frames);
    }
    mk->frames = frames;
    mk->count = rig->nmarkers;
    mk->fps = EX_FPS;
    for (int f = 0; f < frames; f++)
        for (int m = 0; m < rig->nmarkers; m++) {
            memcpy(mk->P + ((size_t)f * rig->nmarkers + m) * 3,
                   s->V + ((size_t)f * s->nv + rig->markers[m].vertex) * 3, 3 * sizeof(float));
            mk->valid[(size_t)f * rig->nmarkers + m] = 1;
        }
    *out = mk;
    if (truth) {
        *truth = s;
    } else {
        free(s->V);
        free(s->F);
        free(s);
    }
    return 0;
}
