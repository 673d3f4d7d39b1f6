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
 * (along the body's up axis): a hand's path climbs to the shoulder, a foot's does not; and, per
 * extremum, how far its path (first pass) goes to either side along the body's `right`: an arm's
 * passes its shoulder, a neck's stays near the mid-plane; and how long its path is from its highest
 * point to the tip (below_top: a hanging arm's visible length from the shoulder, markers.c).
 * Per extremum we also keep the mean of the cells within tip_radius (a less noisy marker than the
 * single farthest cell) and an anchor, which tells left from right when the tips cross: the point
 * ANCHOR_BACK back from the tip (at most half-way) along its shortest path from the centroid in the
 * first pass. Not along its path from the nearest earlier extremum: the second foot's path to the
 * first one crosses to the other leg at the knees or the dress hem, which put both feet's anchors
 * on one leg. Not half-way either: both legs' paths from the centroid join under a dress, so
 * half-way lies near the body's midline; the distal segment (shank, forearm) stays on its side
 * when the person is turned and one leg steps forward (yaw -20: foot side 0.75 -> 0.89).
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
 *   last LIMB_BACK metres of its path; the tracker uses it for hands (markers.c). The nearer
 *   cells' mean, at the tip's depth, is where in the image the limb goes on: markers.c moves a
 *   foot on the floor under it. */
#include "depth_internal.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Bridges across an occluder span at most this much of the image (metres at the person). */
#define BRIDGE 0.15f
/* The anchor lies this far back from the tip along the path from the centroid (or half-way when
 * the path is shorter): inside the limb's distal segment (a forearm is ~0.27 m, a shank ~0.4 m). */
#define ANCHOR_BACK 0.3f

int drv__geodesic_init(drv__geodesic *ge, const drv_depth_opts *o, int n, char *err)
{
    memset(ge, 0, sizeof *ge);
    ge->n = n;
    /* The ring must hold every distance between the bucket being emptied and the farthest cell an
     * edge can reach from it: the longest edge (a cell diagonal at z_max, a depth step below
     * attach_jump with its jump_penalty, or a bridge) over the narrowest bucket (z_min). */
    const int smin = o->cell_m > 0 ? o->step_min : o->step, smax = o->cell_m > 0 ? o->step_max : o->step;
    double cell = smax * o->z_max / fmin(o->k.fx, o->k.fy);
    double longest = 2.0 * cell + fmax(o->attach_jump, o->seg_jump) + o->jump_penalty + BRIDGE +
                     o->max_jump;
    double span = longest / drv__geodesic_quantum(o, smin, o->z_min) + 2.0;
    ge->nb = 1;
    while (ge->nb < span && ge->nb < (1 << 24))
        ge->nb <<= 1;
    /* dist has a margin of a grid row and a cell on both sides: a cell on the grid's rim reads
     * its neighbours' distances through the edges it does not have (FLT_MAX, see run) */
    ge->pad = o->k.width / smin + 1;
    ge->dist_mem = malloc(((size_t)n + 2 * (size_t)ge->pad) * sizeof *ge->dist_mem);
    ge->dist = ge->dist_mem ? ge->dist_mem + ge->pad : NULL;
    ge->parent = malloc((size_t)n * sizeof *ge->parent);
    ge->next = malloc((size_t)n * sizeof *ge->next);
    ge->prev = malloc((size_t)n * sizeof *ge->prev);
    ge->slot = malloc((size_t)n * sizeof *ge->slot);
    ge->bucket = malloc((size_t)ge->nb * sizeof *ge->bucket);
    ge->full = calloc((size_t)(ge->nb + 63) / 64, sizeof *ge->full);
    ge->w = malloc((size_t)n * 8 * sizeof *ge->w);
    ge->bw = malloc((size_t)n * 2 * sizeof *ge->bw);
    ge->bt = malloc((size_t)n * 2 * sizeof *ge->bt);
    ge->h = malloc((size_t)n * sizeof *ge->h);
    ge->hmax = malloc((size_t)n * sizeof *ge->hmax);
    ge->dist0 = malloc((size_t)n * sizeof *ge->dist0);
    ge->parent0 = malloc((size_t)n * sizeof *ge->parent0);
    if (!ge->dist || !ge->parent || !ge->next || !ge->prev || !ge->slot || !ge->bucket ||
        !ge->full || !ge->w || !ge->bw || !ge->bt || !ge->h || !ge->hmax || !ge->dist0 || !ge->parent0) {
        drv__geodesic_fini(ge);
        if (err)
            snprintf(err, DRV_ERR_LEN, "depth: out of memory for the geodesic graph (%d cells)", n);
        return -ENOMEM;
    }
    for (int i = 0; i < n + 2 * ge->pad; i++)
        ge->dist_mem[i] = FLT_MAX;
    for (int i = 0; i < n; i++) {
        ge->slot[i] = -1;
        ge->parent[i] = -1;
    }
    for (int i = 0; i < ge->nb; i++)
        ge->bucket[i] = -1;
    return 0;
}

void drv__geodesic_fini(drv__geodesic *ge)
{
    free(ge->dist_mem);
    free(ge->parent);
    free(ge->next);
    free(ge->prev);
    free(ge->slot);
    free(ge->bucket);
    free(ge->full);
    free(ge->w);
    free(ge->bw);
    free(ge->bt);
    free(ge->h);
    free(ge->hmax);
    free(ge->dist0);
    free(ge->parent0);
    memset(ge, 0, sizeof *ge);
}

/* ---- Dial's bucket queue [Dial 1969, "Algorithm 360: shortest-path forest with topological
 * ordering"]: cells are kept in buckets of width q by floor(dist / q), and popped bucket after
 * bucket. When q is below the shortest edge, no cell can improve another of its own bucket, so
 * the order inside a bucket does not matter and the distances are exactly Dijkstra's - at O(1)
 * per queue operation instead of a heap's O(log n). A bitmap of the non-empty buckets lets a pop
 * skip 64 empty buckets at a time. */

float drv__geodesic_quantum(const drv_depth_opts *o, int step, float z_near)
{
    /* Neighbouring cells' sample pixels lie at least step - (b - a) pixels apart (the probe
     * offsets a, b of segment.c); half of that at the nearest depth is below any edge. */
    const int s = step, a = s / 4, b = (3 * s) / 4;
    return 0.5f * (float)(s - (b - a)) * z_near / (float)fmax(o->k.fx, o->k.fy);
}

static void queue_remove(drv__geodesic *ge, int c)
{
    int p = ge->prev[c], nx = ge->next[c];
    if (p >= 0) {
        ge->next[p] = nx;
    } else {
        int sl = ge->slot[c];
        ge->bucket[sl] = nx;
        if (nx < 0)
            ge->full[sl >> 6] &= ~(1ull << (sl & 63));
    }
    if (nx >= 0)
        ge->prev[nx] = p;
    ge->slot[c] = -1;
    ge->hn--;
}

/* Queues c at its (new, smaller) distance. */
static void queue_push(drv__geodesic *ge, int c)
{
    if (ge->slot[c] >= 0)
        queue_remove(ge, c);
    long k = (long)(ge->dist[c] * ge->iq);
    if (k - ge->cur >= ge->nb) /* cannot happen with the ring sized by init; keeps it safe */
        k = ge->cur + ge->nb - 1;
    int sl = (int)(k & (ge->nb - 1));
    ge->slot[c] = sl;
    ge->prev[c] = -1;
    ge->next[c] = ge->bucket[sl];
    if (ge->bucket[sl] >= 0)
        ge->prev[ge->bucket[sl]] = c;
    else
        ge->full[sl >> 6] |= 1ull << (sl & 63);
    ge->bucket[sl] = c;
    ge->hn++;
}

/* Pops a cell of the first non-empty bucket from `cur` on (the queue holds a cell): the bitmap
 * `full` is searched a word at a time, around the ring. */
static int queue_pop(drv__geodesic *ge)
{
    const int mask = ge->nb - 1, s = (int)(ge->cur & mask), nw = (ge->nb + 63) >> 6;
    int w = s >> 6, sl;
    uint64_t b = ge->full[w] & (~0ull << (s & 63));
    while (!b) {
        w = w + 1 < nw ? w + 1 : 0;
        b = ge->full[w];
    }
    sl = (w << 6) + __builtin_ctzll(b);
    ge->cur += (sl - s) & mask;
    int c = ge->bucket[sl];
    queue_remove(ge, c);
    return c;
}

/* The 8 neighbours (dx, dy), in an order where d and 7 - d are opposite ("NBR order"):
 * (-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1); off[] in run. */

/* The edge between person cells u and v = u's neighbour d (d = 4..7, the forward half; 7 - d
 * is the way back from v), when the rules allow it. */
static inline void edge(drv__geodesic *ge, const drv__grid *g, const float jumps[4], int u, int v,
                        int d)
{
    if (!g->person[v])
        return;
    const float zu = g->z[u], jz = fabsf(g->z[v] - zu);
    if (jz >= jumps[0] && (g->comp[v] == g->comp[u] || jz >= jumps[1]))
        return;
    const float *pu = g->P + 3 * u, *pv = g->P + 3 * v;
    float ex = pv[0] - pu[0], ey = pv[1] - pu[1], ez = pv[2] - pu[2];
    float wt = sqrtf(ex * ex + ey * ey + ez * ez) + (jz >= jumps[2] ? jumps[3] : 0.f);
    ge->w[8 * u + d] = wt;
    ge->w[8 * v + 7 - d] = wt;
}

/* This frame's graph: the weight of every edge between the person's cells (the rules of the
 * header), computed once for the ten Dijkstra runs; each edge is measured from one end and
 * mirrored to the other. Then the bridges of each cell up and down its column. */
static void edges(drv__geodesic *ge, const drv__grid *g, const drv_depth_opts *o)
{
    const int gw = g->gw, gh = g->gh;
    const int bridge = (int)(BRIDGE / (g->mean_z * (float)g->step / (float)o->k.fx));
    for (int k = 0; k < g->ncells; k++) {
        int c = g->cells[k];
        for (int d = 0; d < 8; d++)
            ge->w[8 * c + d] = FLT_MAX;
    }
    /* seg_jump, attach_jump, max_jump, jump_penalty (locals: the stores to w cannot alias them) */
    const float jumps[4] = {o->seg_jump, o->attach_jump, o->max_jump, o->jump_penalty};
    const float max_jump = o->max_jump;
    for (int k = 0, y = 0, row = 0; k < g->ncells; k++) {
        const int u = g->cells[k];
        if (u < row || u >= row + gw) { /* cells mostly ascend: the row follows them */
            y = u / gw;
            row = y * gw;
        }
        const int x = u - row;
        /* the forward half, d = 4..7: (+1, 0), (-1, +1), (0, +1), (+1, +1), where in the grid */
        const int r = x < gw - 1, dn = y < gh - 1;
        if (r)
            edge(ge, g, jumps, u, u + 1, 4);
        if (dn) {
            if (x > 0)
                edge(ge, g, jumps, u, u + gw - 1, 5);
            edge(ge, g, jumps, u, u + gw, 6);
            if (r)
                edge(ge, g, jumps, u, u + gw + 1, 7);
        }
    }
    for (int k = 0; k < g->ncells; k++) {
        const int u = g->cells[k];
        const float zu = g->z[u];
        for (int side = 0; side < 2; side++) {
            const int dy = side ? 1 : -1, d = side ? 6 : 1;
            ge->bw[2 * u + side] = FLT_MAX; /* none: an edge to itself that never relaxes */
            ge->bt[2 * u + side] = u;
            if (bridge < 2 || ge->w[8 * u + d] == FLT_MAX || !(g->z[u + dy * gw] < zu - max_jump))
                continue;
            const int x = u % gw, y = u / gw;
            for (int t = 2; t <= bridge; t++) { /* across the occluder to the first cell at zu */
                int by = y + t * dy;
                if (by < 0 || by >= gh)
                    break;
                int wc = by * gw + x;
                if (!g->person[wc])
                    break;
                if (g->z[wc] < zu - max_jump)
                    continue;
                if (fabsf(g->z[wc] - zu) < max_jump) {
                    const float *pu = g->P + 3 * u, *pw = g->P + 3 * wc;
                    float fx = pw[0] - pu[0], fy = pw[1] - pu[1], fz = pw[2] - pu[2];
                    ge->bw[2 * u + side] = sqrtf(fx * fx + fy * fy + fz * fz);
                    ge->bt[2 * u + side] = wc;
                }
                break;
            }
        }
    }
}

/* Relaxes the edge u -> v of weight wt. */
static inline void relax(drv__geodesic *ge, int u, int v, float nd, int first)
{
    if (nd < ge->dist[v]) {
        ge->dist[v] = nd;
        ge->parent[v] = u;
        if (first) {
            float hu = ge->hmax[u], hv = ge->h[v];
            ge->hmax[v] = hu > hv ? hu : hv;
        }
        queue_push(ge, v);
    }
}

/* Dijkstra from the queued cells; only improvements are expanded. With tip != NULL, sums the
 * positions of cells that end up within `radius` (they are reached from the new source). */
static void run(drv__geodesic *ge, const drv__grid *g, float radius, double *tip, int *ntip,
                int first)
{
    const int gw = g->gw;
    const int off[8] = {-gw - 1, -gw, -gw + 1, -1, 1, gw - 1, gw, gw + 1};
    while (ge->hn) {
        int u = queue_pop(ge);
        float du = ge->dist[u];
        if (tip && du < radius) {
            const float *pu = g->P + 3 * u;
            tip[0] += pu[0];
            tip[1] += pu[1];
            tip[2] += pu[2];
            (*ntip)++;
        }
        /* A missing edge weighs FLT_MAX, so du + FLT_MAX = FLT_MAX improves no distance (all
         * are at most FLT_MAX, the margin of dist included): no test for the edge. */
        const float *wu = ge->w + 8 * u;
        for (int d = 0; d < 8; d++)
            relax(ge, u, u + off[d], du + wu[d], first);
        for (int side = 0; side < 2; side++)
            relax(ge, u, ge->bt[2 * u + side], du + ge->bw[2 * u + side], first);
    }
}

/* An occluding edge at the tip: a cell within two of it, nearer to the camera by HIDDEN_JUMP or
 * more. The limb then continues behind the nearer surface; its hidden end is estimated
 * HIDDEN_REACH further along the direction of its last LIMB_BACK metres of path, and the nearer
 * cells' mean, each brought along its ray to the tip's depth, is where in the image it goes on. */
#define LIMB_BACK 0.15f
#define HIDDEN_JUMP 0.08f
#define HIDDEN_REACH 0.14f
static void hidden_end(const drv__grid *g, int e, int limb, drv__extremum *x)
{
    const int gw = g->gw, gh = g->gh, ex = e % gw, ey = e / gw;
    float occ[3] = {0, 0, 0};
    int nocc = 0;
    for (int dy = -2; dy <= 2; dy++)
        for (int dx = -2; dx <= 2; dx++) {
            int xx = ex + dx, yy = ey + dy;
            if (xx < 0 || yy < 0 || xx >= gw || yy >= gh)
                continue;
            const int c = yy * gw + xx;
            const float z = g->z[c];
            if (z > 0 && z < g->z[e] - HIDDEN_JUMP) {
                for (int a = 0; a < 3; a++)
                    occ[a] += g->P[3 * c + a] * (g->z[e] / z);
                nocc++;
            }
        }
    x->hidden_end = nocc > 0;
    for (int a = 0; a < 3; a++)
        x->occluder[a] = nocc ? occ[a] / (float)nocc : g->P[3 * e + a];
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
                          int source, const float up[3], const float right[3], drv__extremum *ex,
                          int max)
{
    if (source < 0 || source >= g->n || !g->person[source])
        return 0;
    const float *ps = g->P + 3 * source;
    float z_near = FLT_MAX;
    for (int k = 0; k < g->ncells; k++) {
        int c = g->cells[k];
        const float *p = g->P + 3 * c;
        z_near = g->z[c] < z_near ? g->z[c] : z_near;
        ge->dist[c] = FLT_MAX;
        ge->parent[c] = -1;
        ge->slot[c] = -1;
        ge->h[c] = (p[0] - ps[0]) * up[0] + (p[1] - ps[1]) * up[1] + (p[2] - ps[2]) * up[2];
    }
    ge->iq = 1.f / drv__geodesic_quantum(o, g->step, fmaxf(z_near, o->z_min));
    ge->dist[source] = 0;
    ge->hmax[source] = 0;
    ge->cur = 0; /* a source (distance 0) starts the queue over */
    queue_push(ge, source);
    edges(ge, g, o);
    run(ge, g, 0, NULL, NULL, 1);
    for (int k = 0; k < g->ncells; k++) {
        int c = g->cells[k];
        ge->dist0[c] = ge->dist[c];
        ge->parent0[c] = ge->parent[c];
    }
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
        x->geodesic0 = ge->dist0[e];
        x->path_hmax = ge->hmax[e];
        int gx = e % g->gw, gy = e / g->gw;
        /* cut by the image's edge: the farthest cell of a limb that goes on beyond the image
           lies in the grid's outermost row or column (a head whose top is a few pixels inside
           the image is not cut) */
        x->border = gx < 1 || gy < 1 || gx >= g->gw - 1 ? 1 : gy >= g->gh - 1 ? 2 : 0;
        x->top_cut = gy < 1 && gx >= 1 && gx < g->gw - 1;
        int a = e, limb = e, guard = g->ncells;
        while (ge->parent[a] >= 0 && ge->dist[ge->parent[a]] > de - LIMB_BACK && guard-- > 0)
            limb = a = ge->parent[a];
        /* the anchor: on the path from the centroid (first pass), not from the nearest earlier
           extremum (the second foot's path to the first one crosses to the other leg) */
        const float d0 = ge->dist0[e], dstop = fmaxf(0.5f * d0, d0 - ANCHOR_BACK);
        for (a = e, guard = g->ncells; ge->parent0[a] >= 0 && ge->dist0[a] > dstop && guard-- > 0;)
            a = ge->parent0[a];
        memcpy(x->anchor, g->P + 3 * a, sizeof x->anchor);
        x->path_lmax = 0;
        float hbest = -FLT_MAX;
        x->below_top = 0;
        for (a = e, guard = g->ncells; a >= 0 && guard-- > 0; a = ge->parent0[a]) {
            if (ge->h[a] > hbest) {
                hbest = ge->h[a];
                x->below_top = d0 - ge->dist0[a];
            }
            const float *p = g->P + 3 * a;
            const float l = fabsf((p[0] - ps[0]) * right[0] + (p[1] - ps[1]) * right[1] +
                                  (p[2] - ps[2]) * right[2]);
            x->path_lmax = l > x->path_lmax ? l : x->path_lmax;
        }
        hidden_end(g, e, limb, x);
        double tip[3] = {0, 0, 0};
        int ntip = 0;
        ge->dist[e] = 0;
        ge->parent[e] = -1;
        ge->cur = 0;
        queue_push(ge, e);
        run(ge, g, o->tip_radius, tip, &ntip, 0);
        for (int i = 0; i < 3; i++)
            x->tip[i] = ntip ? (float)(tip[i] / ntip) : g->P[3 * e + i];
    }
    return nex;
}
