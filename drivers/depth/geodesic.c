/* geodesic.c - accumulative geodesic extrema of a body surface seen in depth.
 *
 * [Plagemann, Ganapathi, Koller, Thrun 2010, "Real-time identification and localization of body
 * parts from depth images", Sec. III] and [Baak, Mueller, Bharaj, Seidel, Theobalt 2011, "A
 * data-driven approach for real-time full body pose reconstruction from a depth camera", Sec. 4]:
 * on the graph of surface points (here: the person's grid cells, 8-neighbour edges weighted by
 * their 3D distance, edges only between cells whose depths differ by less than max_jump; steps
 * up to seg_jump cost jump_penalty extra, so parts seen only across a depth step - legs under a
 * dress hem - stay reachable without short-cutting a hand in front of the body),
 *   1. d(v) = geodesic distance from the body centroid c (Dijkstra);
 *   2. the farthest point e_k = argmax d(v) is the next extremum;
 *   3. e_k joins the sources with distance 0: d(v) <- min(d(v), dist(e_k, v)); go to 2.
 * Step 3 is done incrementally: a Dijkstra from e_k alone that only expands cells whose distance
 * decreases, which gives exactly the multi-source distances at a fraction of a full run.
 * paper -> code: c -> `source`, d -> ge->dist, e_k -> ex[k].cell.
 * The first pass also records, per cell, the highest point of its shortest path from the source
 * (along the body's up axis): a hand's path climbs to the shoulder, a foot's does not.
 * Per extremum we also keep the mean of the cells within tip_radius (a less noisy marker than the
 * single farthest cell) and an anchor: the point half-way back along its shortest path, which lies
 * on the limb near its root (shoulder or hip side) and tells left from right when limbs cross.
 *
 * Two departures for occlusion (not in the papers; measured on samba with `meshsteer depth-eval`):
 * - Bridges: a forearm held across the chest cuts the torso's surface in two in the image, and
 *   the only paths between the halves cross two depth steps (2 x jump_penalty), which makes the
 *   head and the other arm look a metre farther than they are. Where a cell's neighbour in the
 *   same image column is nearer by max_jump or more (an occluder), the graph gets an edge from
 *   the cell straight across the occluder to the first cell of the column at its own depth
 *   (within max_jump), at most BRIDGE metres away, weighted by the 3D distance: the surface
 *   goes on behind. Only along columns: limbs that cross the torso are near horizontal, while
 *   looking sideways across a leg would join it to the other leg.
 * - Hidden ends: a hand resting on the far hip ends, in the image, where the forearm disappears
 *   behind the torso. An extremum with a nearer surface within two cells of it is marked
 *   hidden_end, with an estimate of the real end HIDDEN_REACH further along the direction of the
 *   last LIMB_BACK metres of its path; the tracker uses it for hands (markers.c). */
#include "depth_internal.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int drv__geodesic_init(drv__geodesic *ge, int n, char *err)
{
    memset(ge, 0, sizeof *ge);
    ge->n = n;
    ge->dist = malloc((size_t)n * sizeof *ge->dist);
    ge->parent = malloc((size_t)n * sizeof *ge->parent);
    ge->heap = malloc((size_t)n * sizeof *ge->heap);
    ge->pos = malloc((size_t)n * sizeof *ge->pos);
    ge->h = malloc((size_t)n * sizeof *ge->h);
    ge->hmax = malloc((size_t)n * sizeof *ge->hmax);
    if (!ge->dist || !ge->parent || !ge->heap || !ge->pos || !ge->h || !ge->hmax) {
        drv__geodesic_fini(ge);
        if (err)
            snprintf(err, DRV_ERR_LEN, "depth: out of memory for the geodesic graph (%d cells)", n);
        return -ENOMEM;
    }
    for (int i = 0; i < n; i++) {
        ge->dist[i] = FLT_MAX;
        ge->pos[i] = -1;
        ge->parent[i] = -1;
    }
    return 0;
}

void drv__geodesic_fini(drv__geodesic *ge)
{
    free(ge->dist);
    free(ge->parent);
    free(ge->heap);
    free(ge->pos);
    free(ge->h);
    free(ge->hmax);
    memset(ge, 0, sizeof *ge);
}

/* ---- indexed binary min-heap on ge->dist */

static void heap_up(drv__geodesic *ge, int i)
{
    int c = ge->heap[i];
    float d = ge->dist[c];
    while (i > 0) {
        int p = (i - 1) / 2;
        if (ge->dist[ge->heap[p]] <= d)
            break;
        ge->heap[i] = ge->heap[p];
        ge->pos[ge->heap[i]] = i;
        i = p;
    }
    ge->heap[i] = c;
    ge->pos[c] = i;
}

static void heap_down(drv__geodesic *ge, int i)
{
    int c = ge->heap[i];
    float d = ge->dist[c];
    for (;;) {
        int l = 2 * i + 1, m = i;
        float dm = d;
        if (l < ge->hn && ge->dist[ge->heap[l]] < dm) {
            m = l;
            dm = ge->dist[ge->heap[l]];
        }
        if (l + 1 < ge->hn && ge->dist[ge->heap[l + 1]] < dm)
            m = l + 1;
        if (m == i)
            break;
        ge->heap[i] = ge->heap[m];
        ge->pos[ge->heap[i]] = i;
        i = m;
    }
    ge->heap[i] = c;
    ge->pos[c] = i;
}

static void heap_push(drv__geodesic *ge, int c)
{
    if (ge->pos[c] >= 0) {
        heap_up(ge, ge->pos[c]);
        return;
    }
    ge->heap[ge->hn] = c;
    ge->pos[c] = ge->hn++;
    heap_up(ge, ge->pos[c]);
}

static int heap_pop(drv__geodesic *ge)
{
    int c = ge->heap[0];
    ge->pos[c] = -1;
    if (--ge->hn > 0) {
        ge->heap[0] = ge->heap[ge->hn];
        ge->pos[ge->heap[0]] = 0;
        heap_down(ge, 0);
    }
    return c;
}

/* Bridges across an occluder span at most this much of the image (metres at the person). */
#define BRIDGE 0.15f

/* Dijkstra from the queued cells; only improvements are expanded. With tip != NULL, sums the
 * positions of cells that end up within `radius` (they are reached from the new source). */
static void run(drv__geodesic *ge, const drv__grid *g, const drv_depth_opts *o, float radius,
                double *tip, int *ntip, int first)
{
    const int gw = g->gw, gh = g->gh;
    const int bridge = (int)(BRIDGE / (g->mean_z * (float)g->step / (float)o->k.fx));
    while (ge->hn) {
        int u = heap_pop(ge);
        float du = ge->dist[u];
        const float *pu = g->P + 3 * u;
        float zu = g->z[u];
        if (tip && du < radius) {
            tip[0] += pu[0];
            tip[1] += pu[1];
            tip[2] += pu[2];
            (*ntip)++;
        }
        int x = u % gw, y = u / gw;
        for (int dy = -1; dy <= 1; dy++) {
            int yy = y + dy;
            if (yy < 0 || yy >= gh)
                continue;
            for (int dx = -1; dx <= 1; dx++) {
                int xx = x + dx;
                if (xx < 0 || xx >= gw || (dx == 0 && dy == 0))
                    continue;
                int v = yy * gw + xx;
                if (!g->person[v])
                    continue;
                float jz = fabsf(g->z[v] - zu);
                if (jz >= o->seg_jump && (g->comp[v] == g->comp[u] || jz >= o->attach_jump))
                    continue;
                const float *pv = g->P + 3 * v;
                float ex = pv[0] - pu[0], ey = pv[1] - pu[1], ez = pv[2] - pu[2];
                float nd = du + sqrtf(ex * ex + ey * ey + ez * ez) +
                           (jz >= o->max_jump ? o->jump_penalty : 0.f);
                if (nd < ge->dist[v]) {
                    ge->dist[v] = nd;
                    ge->parent[v] = u;
                    if (first)
                        ge->hmax[v] = fmaxf(ge->hmax[u], ge->h[v]);
                    heap_push(ge, v);
                }
                if (bridge > 1 && dx == 0 && g->z[v] < zu - o->max_jump) { /* look across it */
                    for (int t = 2; t <= bridge; t++) {
                        int bx = x + t * dx, by = y + t * dy;
                        if (bx < 0 || by < 0 || bx >= gw || by >= gh)
                            break;
                        int w = by * gw + bx;
                        if (!g->person[w])
                            break;
                        if (g->z[w] < zu - o->max_jump)
                            continue;
                        if (fabsf(g->z[w] - zu) < o->max_jump) {
                            const float *pw = g->P + 3 * w;
                            float fx = pw[0] - pu[0], fy = pw[1] - pu[1], fz = pw[2] - pu[2];
                            float bd = du + sqrtf(fx * fx + fy * fy + fz * fz);
                            if (bd < ge->dist[w]) {
                                ge->dist[w] = bd;
                                ge->parent[w] = u;
                                if (first)
                                    ge->hmax[w] = fmaxf(ge->hmax[u], ge->h[w]);
                                heap_push(ge, w);
                            }
                        }
                        break;
                    }
                }
            }
        }
    }
}

/* An occluding edge at the tip: a cell within two of it, nearer to the camera by HIDDEN_JUMP or
 * more. The limb then continues behind the nearer surface; its hidden end is estimated
 * HIDDEN_REACH further along the direction of its last LIMB_BACK metres of path. */
#define LIMB_BACK 0.15f
#define HIDDEN_JUMP 0.08f
#define HIDDEN_REACH 0.14f
static void hidden_end(const drv__grid *g, int e, int limb, drv__extremum *x)
{
    const int gw = g->gw, gh = g->gh, ex = e % gw, ey = e / gw;
    x->hidden_end = 0;
    for (int dy = -2; dy <= 2 && !x->hidden_end; dy++)
        for (int dx = -2; dx <= 2; dx++) {
            int xx = ex + dx, yy = ey + dy;
            if (xx < 0 || yy < 0 || xx >= gw || yy >= gh)
                continue;
            float z = g->z[yy * gw + xx];
            if (z > 0 && z < g->z[e] - HIDDEN_JUMP) {
                x->hidden_end = 1;
                break;
            }
        }
    const float *pe = g->P + 3 * e, *pl = g->P + 3 * limb;
    float d[3] = {pe[0] - pl[0], pe[1] - pl[1], pe[2] - pl[2]};
    float n = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (n < 0.05f) {
        x->hidden_end = 0;
        return;
    }
    for (int a = 0; a < 3; a++)
        x->hidden[a] = pe[a] + d[a] / n * HIDDEN_REACH;
}

int drv__geodesic_extrema(drv__geodesic *ge, const drv__grid *g, const drv_depth_opts *o,
                          int source, const float up[3], drv__extremum *ex, int max)
{
    if (source < 0 || source >= g->n || !g->person[source])
        return 0;
    const float *ps = g->P + 3 * source;
    for (int k = 0; k < g->ncells; k++) {
        int c = g->cells[k];
        const float *p = g->P + 3 * c;
        ge->dist[c] = FLT_MAX;
        ge->parent[c] = -1;
        ge->pos[c] = -1;
        ge->h[c] = (p[0] - ps[0]) * up[0] + (p[1] - ps[1]) * up[1] + (p[2] - ps[2]) * up[2];
    }
    ge->hn = 0;
    ge->dist[source] = 0;
    ge->hmax[source] = 0;
    heap_push(ge, source);
    run(ge, g, o, 0, NULL, NULL, 1);
    int nex = 0;
    while (nex < max) {
        int e = -1;
        float de = 0;
        for (int k = 0; k < g->ncells; k++) {
            int c = g->cells[k];
            float d = ge->dist[c];
            if (d < FLT_MAX && d > de) {
                de = d;
                e = c;
            }
        }
        if (e < 0 || de < o->min_extent)
            break;
        drv__extremum *x = &ex[nex++];
        x->cell = e;
        x->geodesic = de;
        x->path_hmax = ge->hmax[e];
        int gx = e % g->gw, gy = e / g->gw;
        int bx = g->gw / 40 + 1, by = g->gh / 40 + 1; /* 2.5% of the image, at least a cell */
        x->border = gx < bx || gy < by || gx >= g->gw - bx ? 1 : gy >= g->gh - by ? 2 : 0;
        int a = e, limb = e, guard = g->ncells;
        while (ge->parent[a] >= 0 && ge->dist[a] > 0.5f * de && guard-- > 0) {
            a = ge->parent[a];
            if (ge->dist[a] > de - LIMB_BACK)
                limb = a;
        }
        memcpy(x->anchor, g->P + 3 * a, sizeof x->anchor);
        hidden_end(g, e, limb, x);
        double tip[3] = {0, 0, 0};
        int ntip = 0;
        ge->dist[e] = 0;
        ge->parent[e] = -1;
        heap_push(ge, e);
        run(ge, g, o, o->tip_radius, tip, &ntip, 0);
        for (int i = 0; i < 3; i++)
            x->tip[i] = ntip ? (float)(tip[i] / ntip) : g->P[3 * e + i];
    }
    return nex;
}
