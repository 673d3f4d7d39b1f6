/* segment.c - foreground segmentation of a depth image into "the person".
 *
 * 1. Sampling: the image is cut into step x step cells; each cell keeps the nearest valid reading
 *    among four probe pixels (nearest, so that thin limbs survive downsampling), back-projected into
 *    the Y-up camera frame, and gated to [z_min, z_max].
 * 2. Floor: RANSAC (Fischler & Bolles 1981) over the cells of the lower two thirds of the image;
 *    a hypothesis is a plane through three cells whose normal is within floor_max_tilt of +Y; its
 *    score is the number of inliers (|n.p + d| < floor_tol) on a fixed random subset (scoring
 *    stops once the plane is rejected or can no longer win), and planes
 *    with more than 5% of the subset below them are rejected (a floor has nothing below it, a
 *    slice through the body has half of it). The best plane, refined by least squares, is accepted when a quarter of the subset lies on it; cells on or below it are dropped.
 * 3. Person: connected components of the remaining cells (8-neighbour, neighbours connected when
 *    their depths differ by less than seg_jump); among the components with at least min_area m^2
 *    and a quarter of the largest component's area, the nearest (smallest mean depth) is the
 *    person, so a second person standing behind is ignored.
 * 4. Occluded limbs: a component of at most attach_frac of the person's area that touches the
 *    person (8-neighbour) across a depth step below attach_jump joins it - a leg stretched behind
 *    the other is seen only below the knee, 0.3 m behind the front leg. The centroid stays that of
 *    the main component.
 * 5. Arm loops (drv__segment_arm_loops): with a hand on the hip, the arm and the torso enclose a
 *    hole of background and the hand is no geodesic extremum (the arm is a loop). Holes are the
 *    4-connected non-person cells that do not reach the image border. A hole beside the torso
 *    (its centre 0.06 .. 0.45 m to the side, -0.25 .. +0.45 m above the centroid) of 0.002 ..
 *    0.08 m^2 whose rim spans less than LOOP_DEPTH in depth (an arm reaching forward past the
 *    torso leaves a gap too, but its rim is half arm, half torso far behind) gives a hand: its lowest cell B is where the wrist meets the hip; its cell farthest
 *    to the side O lies inside the elbow, so O -> B is the forearm's direction, and the finger tips
 *    lie a hand's length (LOOP_HAND m) beyond B along it, on the body. The forearm's depth along
 *    O -> B is a least-squares line through the hole's rim cells beside that chord, on its side
 *    away from the hole's middle (at least LOOP_RIM_MIN of them, between O and B): its slope
 *    (depth per metre across the image) and its depth at B go with the hand (markers.c places it
 *    in front of the body or behind the hip from them).
 *    A forearm that comes towards the camera (the line falls faster than DRV__LOOP_TOWARD) holds
 *    its hand in front of the body, and the hole's lowest cell is then where the forearm's upper
 *    rim meets the torso in the image, not the contact: pjump turned to -20 degrees, hands before
 *    the belly, has the forearm pass below the hole to the hand, and the walk along O -> B went
 *    on into the belly, 10-12 cm from the hand (3.5 m, frames 171-196). Such a hand is found on
 *    the forearm's own surface instead: from the line's rim cells, a flood over neighbours (8)
 *    whose depths differ by less than SURFACE_STEPS of the sensor's depth steps (one step is a
 *    surface's quantisation, two an occluding edge: the hand before the belly is 10-17 cm in
 *    front of it), within a hand's length (LOOP_HAND) of B, and the hand is the flooded cell
 *    farthest from O - the forearm's far end from the elbow (hand_in_front). pjump at -20
 *    degrees, hands within 10 cm 0.865 / 0.874 / 0.839 / 0.778 -> 0.896 / 0.887 / 0.868 / 0.820
 *    at 2.0 / 2.5 / 3.2 / 3.5 m; the SMPL run's 0.461 -> 0.539 (docs/PERFORMANCE.md). Farther
 *    than a hand's length the flood reaches the upper arm and the torso (at 3.5 m, with a fixed
 *    4 cm step: 0.10 m 0.820, 0.15 m 0.813, 0.18 m 0.757, 0.25 m 0.713); at 3.5 m one depth step
 *    gives 0.815 (the quantised steps of a tilted forearm stop it), two 0.797 (it crosses onto
 *    the belly).
 *    Slits: a person turned side-on with a hand on the near hip holds the forearm in front of the
 *    torso's side, and no background shows between them: the arm and the torso close the loop
 *    across an occluding edge (a depth step over drv_depth_opts.max_jump, 0.08 m), not around a
 *    hole. The step is the options' max_jump as given, not the geodesic graph's, which grows
 *    with distance to three of the sensor's depth steps (markers.c; 0.088 m at 3.2 m, 0.105 m at
 *    3.5 m) so that a slope's quantised depth stays connected: a forearm's edge against the hip
 *    does not step farther at a greater distance, and with the graph's threshold samba's slits
 *    at -58 degrees broke into pieces of 0.14-0.16 m at 3.2 m (docs/PERFORMANCE.md). Between the
 *    two thresholds the graph still has an edge; the slit pass reads only this step. On a side
 *    where no hole of background gave a hand, a second pass also counts as open the person cells
 *    on either side of such a step (both sides, so that a diagonal edge's cells are 4-connected)
 *    and looks for holes again, measured as above;
 *    such a slit must span LOOP_SLIT (0.2 m) along up: from the upper arm down the forearm to the
 *    hip it is longer (samba at -58 degrees, hand on the hip: 0.21-0.34 m), while an upper arm
 *    held before the chest leaves short ones (pjump facing: 0.07-0.18 m, hands 11-22 cm off when
 *    taken). The first pass alone sees background holes: the slit pass would open a loop whose
 *    hand is behind the hip (the arm behind the torso, a step at the contact) to the outside.
 *    A slit's hand is a guess - the hand itself is not told from the hip it rests on - and is
 *    reported inferred (markers.c).
 */
#include "depth_internal.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

double drv__rand01(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return (double)((x * 0x2545F4914F6CDD1DULL) >> 11) * (1.0 / 9007199254740992.0);
}

int drv__grid_init(drv__grid *g, const drv_depth_opts *o, char *err)
{
    memset(g, 0, sizeof *g);
    const int smin = o->cell_m > 0 ? o->step_min : o->step;
    if (o->step < 1 || o->k.width < o->step || o->k.height < o->step || o->k.width > 8192 ||
        o->k.height > 8192 ||
        (o->cell_m > 0 && (o->step_min < 1 || o->step_max < o->step_min ||
                           o->step < o->step_min || o->step > o->step_max ||
                           o->k.width < o->step_max || o->k.height < o->step_max))) {
        if (err)
            snprintf(err, DRV_ERR_LEN,
                     "depth: bad image size %dx%d or step %d (adaptive: %g m, steps %d..%d)",
                     o->k.width, o->k.height, o->step, o->cell_m, o->step_min, o->step_max);
        return -EINVAL;
    }
    g->nmax = (o->k.width / smin) * (o->k.height / smin);
    size_t n = (size_t)g->nmax;
    g->P = malloc(n * 3 * sizeof *g->P);
    g->z = malloc(n * sizeof *g->z);
    g->probe = malloc(n);
    g->comp = malloc(n * sizeof *g->comp);
    g->person = malloc(n);
    g->stack = malloc(n * sizeof *g->stack);
    g->cells = malloc(n * sizeof *g->cells);
    g->c_area = malloc(n * sizeof *g->c_area);
    g->c_sumz = malloc(n * sizeof *g->c_sumz);
    g->c_count = malloc(n * sizeof *g->c_count);
    g->c_first = malloc(n * sizeof *g->c_first);
    g->c_last = malloc(n * sizeof *g->c_last);
    g->hole = malloc(n * sizeof *g->hole);
    g->hole_cells = malloc(n * sizeof *g->hole_cells);
    if (!g->P || !g->z || !g->probe || !g->comp || !g->person || !g->stack || !g->cells ||
        !g->c_area || !g->c_sumz || !g->c_count || !g->c_first || !g->c_last || !g->hole || !g->hole_cells) {
        drv__grid_fini(g);
        if (err)
            snprintf(err, DRV_ERR_LEN, "depth: out of memory for a %dx%d grid", o->k.width,
                     o->k.height);
        return -ENOMEM;
    }
    memset(g->person, 0, n);
    drv__grid_set_step(g, o, o->step);
    return 0;
}

void drv__grid_pixel(const drv__grid *g, int cell, int *u, int *v)
{
    const int s = g->step, a = s / 4, db = (3 * s) / 4 - a, k = g->probe[cell];
    *u = cell % g->gw * s + a + (k & 1) * db;
    *v = cell / g->gw * s + a + (k >> 1) * db;
}

int drv__grid_choose_step(const drv_depth_opts *o, int step, float z)
{
    if (!(o->cell_m > 0) || !(z > 0))
        return step;
    const float ideal = o->cell_m * (float)o->k.fx / z;
    if (fabsf(ideal - (float)step) < 0.75f) /* hysteresis: no flicker between two sizes */
        return step;
    int s = (int)lroundf(ideal);
    return s < o->step_min ? o->step_min : s > o->step_max ? o->step_max : s;
}

void drv__grid_set_step(drv__grid *g, const drv_depth_opts *o, int step)
{
    g->step = step;
    g->gw = o->k.width / step;
    g->gh = o->k.height / step;
    g->n = g->gw * g->gh;
}

void drv__grid_fini(drv__grid *g)
{
    free(g->P);
    free(g->z);
    free(g->probe);
    free(g->comp);
    free(g->person);
    free(g->stack);
    free(g->cells);
    free(g->c_area);
    free(g->c_sumz);
    free(g->c_count);
    free(g->c_first);
    free(g->c_last);
    free(g->hole);
    free(g->hole_cells);
    memset(g, 0, sizeof *g);
}

void drv__segment_sample(drv__grid *g, const drv_depth_opts *o, const uint16_t *depth_mm)
{
    const int W = o->k.width, s = g->step, gw = g->gw;
    const int a = s / 4, b = (3 * s) / 4, db = b - a;
    const uint16_t zmin = (uint16_t)fminf(65535.f, o->z_min * 1000.f);
    const uint16_t zmax = (uint16_t)fminf(65535.f, o->z_max * 1000.f);
    const float ifx = (float)(1.0 / o->k.fx), ify = (float)(1.0 / o->k.fy);
    const float cx = (float)o->k.cx, cy = (float)o->k.cy;
    /* Branch-free: a probe's key is (d - lo) mod 2^16 << 2 | its index, so that the smallest key
     * is the nearest reading in the gate [lo, zmax] (the first probe on ties), and a smallest
     * key of lim or more means that no probe passed. lo is at least 1: 0 is no reading. */
    const uint32_t lo = zmin ? zmin : 1u;
    const uint32_t lim = zmax >= lo ? (zmax - lo + 1u) << 2 : 0u; /* keys below it passed */
    memset(g->comp, 0xff, (size_t)g->n * sizeof *g->comp); /* -1 */
    memset(g->person, 0, (size_t)g->n);
    for (int gy = 0; gy < g->gh; gy++) {
        const int va = gy * s + a;
        const uint16_t *ra = depth_mm + (size_t)va * W + a, *rb = ra + (size_t)db * W;
        uint8_t *probe = g->probe + gy * gw;
        float *zr = g->z + gy * gw, *P = g->P + 3 * gy * gw;
        const float fy[2] = {-((float)va - cy), -((float)(va + db) - cy)};
        for (int gx = 0, u0 = 0; gx < gw; gx++, u0 += s) {
            uint32_t k0 = (uint32_t)(uint16_t)(ra[u0] - lo) << 2;
            uint32_t k1 = (uint32_t)(uint16_t)(ra[u0 + db] - lo) << 2 | 1u;
            uint32_t k2 = (uint32_t)(uint16_t)(rb[u0] - lo) << 2 | 2u;
            uint32_t k3 = (uint32_t)(uint16_t)(rb[u0 + db] - lo) << 2 | 3u;
            uint32_t m01 = k0 < k1 ? k0 : k1, m23 = k2 < k3 ? k2 : k3;
            uint32_t m = m01 < m23 ? m01 : m23;
            const int ok = m < lim, k = ok ? (int)(m & 3u) : 0, bu = u0 + a + (k & 1) * db;
            probe[gx] = (uint8_t)k;
            if (!ok) {
                zr[gx] = 0;
                continue;
            }
            float z = (float)((m >> 2) + lo) * 0.001f;
            zr[gx] = z;
            P[3 * gx] = ((float)bu - cx) * z * ifx;
            P[3 * gx + 1] = fy[k >> 1] * z * ify;
            P[3 * gx + 2] = -z;
        }
    }
}

#define FLOOR_SUBSET 256

int drv__segment_floor(drv__grid *g, const drv_depth_opts *o, uint64_t *rng, float plane[4])
{
    /* candidates: valid cells of the lower two thirds, listed in g->stack */
    int nc = 0;
    for (int i = (g->gh / 3) * g->gw; i < g->n; i++)
        if (g->z[i] > 0)
            g->stack[nc++] = i;
    if (nc < 64)
        return 0;
    /* a fixed random subset for scoring */
    int m = nc < FLOOR_SUBSET ? nc : FLOOR_SUBSET;
    float sub[3 * FLOOR_SUBSET]; /* their points, contiguous */
    for (int k = 0; k < m; k++)
        memcpy(sub + 3 * k, g->P + 3 * g->stack[(int)(drv__rand01(rng) * nc)], 3 * sizeof *sub);
    const float tol = o->floor_tol;
    const float cos_tilt = cosf(o->floor_max_tilt * (float)M_PI / 180.f);
    int best = 0;
    float bp[4] = {0, 1, 0, 0};
    for (int it = 0; it < o->floor_iters; it++) {
        const float *A = g->P + 3 * g->stack[(int)(drv__rand01(rng) * nc)];
        const float *B = g->P + 3 * g->stack[(int)(drv__rand01(rng) * nc)];
        const float *C = g->P + 3 * g->stack[(int)(drv__rand01(rng) * nc)];
        float e1[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]};
        float e2[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
        float nx = e1[1] * e2[2] - e1[2] * e2[1];
        float ny = e1[2] * e2[0] - e1[0] * e2[2];
        float nz = e1[0] * e2[1] - e1[1] * e2[0];
        float len = sqrtf(nx * nx + ny * ny + nz * nz);
        if (len < 1e-6f)
            continue;
        if (ny < 0)
            len = -len;
        nx /= len;
        ny /= len;
        nz /= len;
        if (ny < cos_tilt)
            continue;
        float d = -(nx * A[0] + ny * A[1] + nz * A[2]);
        /* score on the subset; stop as soon as too much lies below (a floor has (almost)
         * nothing below it) or the rest of the subset could not beat the best */
        int cnt = 0, below = 0, k = 0;
        const int below_max = m / 20;
        for (; k < m && below <= below_max && cnt + (m - k) > best; k++) {
            const float *p = sub + 3 * k;
            float h = nx * p[0] + ny * p[1] + nz * p[2] + d;
            cnt += fabsf(h) < tol;
            below += h < 0 && !(fabsf(h) < tol);
        }
        if (below > below_max || cnt <= best)
            continue;
        if (cnt > best) {
            best = cnt;
            bp[0] = nx;
            bp[1] = ny;
            bp[2] = nz;
            bp[3] = d;
        }
    }
    if (best * 4 < m)
        return 0;
    /* refine: least squares y = a x + b z + c over all inliers (the floor is near-horizontal) */
    double S[3][3], r[3];
    double sxx = 0, sxz = 0, szz = 0, sx = 0, sz = 0, sxy = 0, szy = 0, sy = 0;
    int cnt = 0;
    for (int k = 0; k < nc; k++) {
        const float *p = g->P + 3 * g->stack[k];
        if (fabsf(bp[0] * p[0] + bp[1] * p[1] + bp[2] * p[2] + bp[3]) >= tol)
            continue;
        /* the sums of q q^T and q y for q = (x, z, 1), y: S is symmetric */
        const double x = p[0], y = p[1], zz = p[2];
        sxx += x * x;
        sxz += x * zz;
        szz += zz * zz;
        sx += x;
        sz += zz;
        sxy += x * y;
        szy += zz * y;
        sy += y;
        cnt++;
    }
    S[0][0] = sxx;
    S[0][1] = S[1][0] = sxz;
    S[0][2] = S[2][0] = sx;
    S[1][1] = szz;
    S[1][2] = S[2][1] = sz;
    S[2][2] = cnt;
    r[0] = sxy;
    r[1] = szy;
    r[2] = sy;
    double det = S[0][0] * (S[1][1] * S[2][2] - S[1][2] * S[2][1]) -
                 S[0][1] * (S[1][0] * S[2][2] - S[1][2] * S[2][0]) +
                 S[0][2] * (S[1][0] * S[2][1] - S[1][1] * S[2][0]);
    if (cnt >= 16 && fabs(det) > 1e-12) {
        double x[3];
        for (int c = 0; c < 3; c++) { /* Cramer's rule */
            double M[3][3];
            memcpy(M, S, sizeof M);
            for (int i = 0; i < 3; i++)
                M[i][c] = r[i];
            x[c] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                    M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                    M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) / det;
        }
        /* y = a x + b z + c  <=>  -a x + y - b z - c = 0 */
        double len = sqrt(x[0] * x[0] + 1.0 + x[1] * x[1]);
        float np[4] = {(float)(-x[0] / len), (float)(1.0 / len), (float)(-x[1] / len),
                       (float)(-x[2] / len)};
        if (np[1] >= cos_tilt)
            memcpy(bp, np, sizeof bp);
    }
    memcpy(plane, bp, sizeof bp);
    for (int i = 0; i < g->n; i++) {
        const float *p = g->P + 3 * i;
        if (g->z[i] > 0 && bp[0] * p[0] + bp[1] * p[1] + bp[2] * p[2] + bp[3] < tol)
            g->z[i] = 0;
    }
    return 1;
}

/* Marks the component of cell i (a neighbour of the person's cell j) for attaching when it is
 * small and lies across a step below attach_jump: c_count < 0; [alo, ahi] grows to hold it. */
static inline void attach_across(drv__grid *g, const drv_depth_opts *o, int j, int i, int best,
                                 float amax_attach, int *nattach, int *alo, int *ahi)
{
    const int c = g->comp[i];
    if (c < 0 || c == best || g->c_count[c] < 0 || g->c_area[c] > amax_attach ||
        fabsf(g->z[i] - g->z[j]) >= o->attach_jump)
        return;
    g->c_count[c] = -g->c_count[c];
    (*nattach)++;
    *alo = g->c_first[c] < *alo ? g->c_first[c] : *alo;
    *ahi = g->c_last[c] > *ahi ? g->c_last[c] : *ahi;
}

int drv__segment_person(drv__grid *g, const drv_depth_opts *o)
{
    const int gw = g->gw, gh = g->gh;
    const float jump = o->seg_jump;
    const double sx = g->step / o->k.fx, sy = g->step / o->k.fy;
    const int off[8] = {-gw - 1, -gw, -gw + 1, -1, 1, gw - 1, gw, gw + 1}; /* the scan order */
    int ncomp = 0;
    for (int i = 0; i < g->n; i++) {
        if (g->z[i] <= 0 || g->comp[i] >= 0)
            continue;
        int c = ncomp++, top = 0, count = 0, last = i; /* i: its first cell in scan order */
        double area = 0, sumz = 0;
        g->comp[i] = c;
        g->stack[top++] = i;
        while (top) {
            int j = g->stack[--top];
            float zj = g->z[j];
            count++;
            last = j > last ? j : last;
            area += zj * sx * zj * sy;
            sumz += zj;
            int x = j % gw, y = j / gw;
            if (x > 0 && y > 0 && x < gw - 1 && y < gh - 1) { /* inside: no bounds to test */
                for (int d = 0; d < 8; d++) {
                    int k = j + off[d];
                    if (g->comp[k] >= 0 || g->z[k] <= 0 || fabsf(g->z[k] - zj) >= jump)
                        continue;
                    g->comp[k] = c;
                    g->stack[top++] = k;
                }
                continue;
            }
            for (int dy = -1; dy <= 1; dy++) {
                int yy = y + dy;
                if (yy < 0 || yy >= gh)
                    continue;
                for (int dx = -1; dx <= 1; dx++) {
                    int xx = x + dx;
                    if (xx < 0 || xx >= gw || (dx == 0 && dy == 0))
                        continue;
                    int k = yy * gw + xx;
                    if (g->comp[k] >= 0 || g->z[k] <= 0 || fabsf(g->z[k] - zj) >= jump)
                        continue;
                    g->comp[k] = c;
                    g->stack[top++] = k;
                }
            }
        }
        g->c_area[c] = (float)area;
        g->c_sumz[c] = (float)sumz;
        g->c_count[c] = count;
        g->c_first[c] = i;
        g->c_last[c] = last;
    }
    g->ncells = 0;
    g->mean_z = 0;
    float amax = 0;
    for (int c = 0; c < ncomp; c++)
        if (g->c_area[c] > amax)
            amax = g->c_area[c];
    int best = -1;
    float bestz = 0;
    for (int c = 0; c < ncomp; c++) {
        if (g->c_area[c] < o->min_area || g->c_area[c] * 4 < amax)
            continue;
        float mz = g->c_sumz[c] / (float)g->c_count[c];
        if (best < 0 || mz < bestz) {
            best = c;
            bestz = mz;
        }
    }
    if (best < 0)
        return 0;
    double cs[3] = {0, 0, 0};
    for (int i = g->c_first[best]; i <= g->c_last[best]; i++) {
        if (g->comp[i] != best)
            continue;
        g->person[i] = 1;
        g->cells[g->ncells++] = i;
        cs[0] += g->P[3 * i];
        cs[1] += g->P[3 * i + 1];
        cs[2] += g->P[3 * i + 2];
    }
    for (int a = 0; a < 3; a++)
        g->centroid[a] = (float)(cs[a] / g->ncells);
    /* occluded limbs: c_count[c] < 0 marks a component to attach */
    const int nmain = g->ncells;
    const float amax_attach = o->attach_frac * g->c_area[best];
    int nattach = 0, alo = g->n, ahi = -1; /* the attached components lie in [alo, ahi] */
    const int off9[9] = {-gw - 1, -gw, -gw + 1, -1, 0, 1, gw - 1, gw, gw + 1};
    for (int k = 0, y = 0, row = 0; k < nmain && o->attach_jump > 0; k++) {
        const int j = g->cells[k];
        if (j >= row + gw) { /* the main component's cells ascend: the row follows them */
            y = j / gw;
            row = y * gw;
        }
        const int x = j - row;
        if (x > 0 && y > 0 && x < gw - 1 && y < gh - 1) { /* inside: no bounds to test */
            const int32_t *cj = g->comp + j;
            if (((cj[-gw - 1] ^ best) | (cj[-gw] ^ best) | (cj[-gw + 1] ^ best) | (cj[-1] ^ best) |
                 (cj[1] ^ best) | (cj[gw - 1] ^ best) | (cj[gw] ^ best) | (cj[gw + 1] ^ best)) == 0)
                continue; /* all around is the person */
            for (int d = 0; d < 9; d++)
                attach_across(g, o, j, j + off9[d], best, amax_attach, &nattach, &alo, &ahi);
            continue;
        }
        for (int dy = -1; dy <= 1; dy++) {
            int yy = y + dy;
            if (yy < 0 || yy >= gh)
                continue;
            for (int dx = -1; dx <= 1; dx++) {
                int xx = x + dx;
                if (xx < 0 || xx >= gw)
                    continue;
                attach_across(g, o, j, yy * gw + xx, best, amax_attach, &nattach, &alo, &ahi);
            }
        }
    }
    for (int i = alo; i <= ahi; i++) {
        int c = g->comp[i];
        if (c >= 0 && c != best && g->c_count[c] < 0) {
            g->person[i] = 1;
            g->cells[g->ncells++] = i;
        }
    }
    g->mean_z = bestz;
    return g->ncells;
}

#define LOOP_HAND 0.10f
#define LOOP_DEPTH 0.25f
#define LOOP_MAX_HOLES 64
#define LOOP_RIM_MIN 3.f /* rim cells for the forearm's depth line */
#define LOOP_SLIT 0.2f   /* metres along up: the shortest slit (see the header) */
#define SOLID (-3)       /* drv__grid.hole: a person cell that closes holes */
#define FOREARM (-4)     /* drv__grid.hole: a SOLID cell taken for the forearm's surface (restored
                            to SOLID before the hole is left) */
/* Neighbouring cells of one surface differ by at most one of the sensor's depth steps (the
 * surface's own tilt across a cell aside); two steps or more is an occluding edge. Halfway: */
#define SURFACE_STEPS 1.5f

/* The hand of a forearm held in front of the body (see the header, step 5): the forearm's
 * surface is flooded from the depth line's rim cells, g->stack[0..nseed) (at least one, marked
 * FOREARM in g->hole; the stack receives the flooded cells after them), over neighbours (8) that
 * are SOLID, lie within `reach` cells (a hand's length) of B (bx, by) and differ in depth by
 * less than `surface` metres; the hand is the flooded cell farthest from O (ox, oy) in the image.
 * Leaves every flooded cell SOLID again and returns the hand's cell. */
static int hand_in_front(drv__grid *g, int nseed, float surface, int bx, int by, float reach,
                         float ox, float oy)
{
    const int gw = g->gw, gh = g->gh;
    int head = 0, tail = nseed, hand = g->stack[0];
    float far = -1.f;
    while (head < tail) {
        const int j = g->stack[head++], x = j % gw, y = j / gw;
        const float du = (float)x - ox, dv = (float)y - oy;
        if (du * du + dv * dv > far) {
            far = du * du + dv * dv;
            hand = j;
        }
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                const int xx = x + dx, yy = y + dy, i = yy * gw + xx;
                if (xx < 0 || yy < 0 || xx >= gw || yy >= gh || g->hole[i] != SOLID ||
                    fabsf(g->z[i] - g->z[j]) >= surface ||
                    (float)((xx - bx) * (xx - bx) + (yy - by) * (yy - by)) > reach * reach)
                    continue;
                g->hole[i] = FOREARM;
                g->stack[tail++] = i;
            }
    }
    for (int k = 0; k < tail; k++)
        g->hole[g->stack[k]] = SOLID;
    return hand;
}

/* One pass of drv__segment_arm_loops: slit = 0 finds holes of background; slit = 1 also counts as
 * open the person cells on either side of an occluding edge (slits), needs every hole to span
 * LOOP_SLIT along up and skips the sides skip[0] (-X) and skip[1] (+X). */
static int find_loops(drv__grid *g, const drv_depth_opts *o, const float up[3],
                      const float right[3], int slit, const int skip[2], drv__extremum *ex, int max)
{
    const int gw = g->gw, gh = g->gh;
    if (g->ncells == 0 || max <= 0)
        return 0;
    /* work inside the person's bounding box grown by a cell (all beyond it is outside) */
    int x0 = gw, x1 = -1, y0 = gh, y1 = -1;
    for (int k = 0, y = 0, row = 0; k < g->ncells; k++) { /* cells ascend: row follows them */
        const int c = g->cells[k];
        if (c < row || c >= row + gw) {
            y = c / gw;
            row = y * gw;
        }
        const int x = c - row;
        x0 = x < x0 ? x : x0;
        x1 = x > x1 ? x : x1;
        y0 = y < y0 ? y : y0;
        y1 = y > y1 ? y : y1;
    }
    x0 = x0 > 0 ? x0 - 1 : 0;
    y0 = y0 > 0 ? y0 - 1 : 0;
    x1 = x1 < gw - 1 ? x1 + 1 : gw - 1;
    y1 = y1 < gh - 1 ? y1 + 1 : gh - 1;
    /* open cells (-1): not the person's, or, for slits, the person's on either side of a depth
     * step over max_jump (see the header); the rest SOLID. The outside:
     * flood from the box's rim through open cells (4-neighbour); -2 = outside. The stack holds
     * y << 16 | x (no division per cell). */
    int top = 0;
    const float jump = o->max_jump;
    for (int y = y0; y <= y1; y++) {
        const int rim = y == y0 || y == y1;
        for (int x = x0; x <= x1; x++) {
            int i = y * gw + x;
            g->hole[i] = g->person[i] ? SOLID : -1;
            if (slit && g->person[i]) {
                const float zi = g->z[i];
                if ((x > 0 && g->person[i - 1] && fabsf(g->z[i - 1] - zi) > jump) ||
                    (x < gw - 1 && g->person[i + 1] && fabsf(g->z[i + 1] - zi) > jump) ||
                    (y > 0 && g->person[i - gw] && fabsf(g->z[i - gw] - zi) > jump) ||
                    (y < gh - 1 && g->person[i + gw] && fabsf(g->z[i + gw] - zi) > jump))
                    g->hole[i] = -1;
            }
            if (g->hole[i] == -1 && (rim || x == x0 || x == x1)) {
                g->hole[i] = -2;
                g->stack[top++] = y << 16 | x;
            }
        }
    }
    while (top) {
        const int p = g->stack[--top], x = p & 0xffff, y = p >> 16, j = y * gw + x;
        if (x < x1 && g->hole[j + 1] == -1) {
            g->hole[j + 1] = -2;
            g->stack[top++] = p + 1;
        }
        if (x > x0 && g->hole[j - 1] == -1) {
            g->hole[j - 1] = -2;
            g->stack[top++] = p - 1;
        }
        if (y < y1 && g->hole[j + gw] == -1) {
            g->hole[j + gw] = -2;
            g->stack[top++] = p + (1 << 16);
        }
        if (y > y0 && g->hole[j - gw] == -1) {
            g->hole[j - gw] = -2;
            g->stack[top++] = p - (1 << 16);
        }
    }
    static const int d4[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    /* the holes, one at a time: flood, then measure */
    const float z = g->mean_z;
    const float cell_m = z * (float)g->step / (float)o->k.fx; /* a cell's size at the person */
    const float surface = SURFACE_STEPS * (float)(drv_kinect1_disparity_to_m(
                                                      drv_kinect1_m_to_disparity(z) + 1.0) - z);
    /* the centroid's pixel, in cells */
    float cu = (float)(o->k.cx + g->centroid[0] / -g->centroid[2] * o->k.fx) / (float)g->step;
    float cv = (float)(o->k.cy - g->centroid[1] / -g->centroid[2] * o->k.fy) / (float)g->step;
    /* image-plane directions of the body frame (cells): up and right */
    float ux = up[0], uy = -up[1], rx = right[0], ry = -right[1];
    float un = sqrtf(ux * ux + uy * uy), rn = sqrtf(rx * rx + ry * ry);
    if (un < 1e-3f || rn < 1e-3f)
        return 0;
    ux /= un, uy /= un, rx /= rn, ry /= rn;
    int nout = 0, nh = 0;
    /* the box's cells row by row (x wraps to x0 and y steps on at the row's end) */
    for (int y = y0, x = x0; y <= y1 && nh < LOOP_MAX_HOLES;
         x = x < x1 ? x + 1 : x0, y += x == x0) {
        const int s0 = y * gw + x;
        if (g->hole[s0] != -1)
            continue;
        int id = nh++, count = 0, b = s0, oc = s0;
        float bh = FLT_MAX, ol = 0, su = 0, sv = 0, zlo = FLT_MAX, zhi = 0;
        g->hole[s0] = id;
        g->stack[top++] = s0;
        while (top) {
            int j = g->stack[--top], x = j % gw, y = j / gw;
            g->hole_cells[count++] = j;
            su += (float)x;
            sv += (float)y;
            for (int k = 0; k < 4; k++) {
                int xx = x + d4[k][0], yy = y + d4[k][1];
                if (xx < 0 || yy < 0 || xx >= gw || yy >= gh)
                    continue;
                int i = yy * gw + xx;
                if (g->hole[i] == SOLID) { /* the loop's rim */
                    const float zi = g->z[i];
                    zlo = zi < zlo ? zi : zlo;
                    zhi = zi > zhi ? zi : zhi;
                    continue;
                }
                if (g->hole[i] != -1)
                    continue;
                g->hole[i] = id;
                g->stack[top++] = i;
            }
        }
        float area = (float)count * cell_m * cell_m;
        if (area < 0.002f || area > 0.08f || zhi - zlo > LOOP_DEPTH)
            continue;
        float hu = su / (float)count - cu, hv = sv / (float)count - cv;
        float side = (hu * rx + hv * ry) * cell_m, height = (hu * ux + hv * uy) * cell_m;
        if (fabsf(side) < 0.06f || fabsf(side) > 0.45f || height < -0.25f || height > 0.45f)
            continue;
        if (skip[side > 0])
            continue;
        float sg = side > 0 ? 1.f : -1.f;
        /* B: the lowest cell; O: the one farthest to the side (second pass over the hole) */
        float hh = -FLT_MAX; /* the highest cell's height */
        for (int k = 0; k < count; k++) {
            int i = g->hole_cells[k];
            float du = (float)(i % gw) - cu, dv = (float)(i / gw) - cv;
            float h = du * ux + dv * uy, l = sg * (du * rx + dv * ry);
            if (h < bh) {
                bh = h;
                b = i;
            }
            hh = h > hh ? h : hh;
            if (l > ol) {
                ol = l;
                oc = i;
            }
        }
        /* a slit runs from the upper arm down the forearm to the hip */
        if (slit && (hh - bh + 1.f) * cell_m < LOOP_SLIT)
            continue;
        float fu = (float)(b % gw - oc % gw), fv = (float)(b / gw - oc / gw);
        float fn = sqrtf(fu * fu + fv * fv);
        if (fn < 1.f)
            continue;
        fu /= fn, fv /= fn;
        /* walk from B along the forearm for a hand's length, staying on the body */
        float reach = LOOP_HAND / cell_m;
        int tip = -1;
        for (float t = 1.f; t <= reach + 0.5f; t += 1.f) {
            int x = (int)lroundf((float)(b % gw) + fu * t), y = (int)lroundf((float)(b / gw) + fv * t);
            if (x < 0 || y < 0 || x >= gw || y >= gh)
                break;
            int i = y * gw + x;
            if (g->person[i])
                tip = i;
            else if (tip >= 0)
                break;
        }
        if (tip < 0)
            continue;
        /* the forearm's depth from the elbow (t = 0 at O) to the contact (t = 1 at B): a
         * least-squares line through the rim cells beside the chord O -> B on its side away from
         * the hole's middle (the torso's and the upper arm's rim lie on the other side) */
        const float ox = (float)(oc % gw), oy = (float)(oc / gw);
        const float cx = (float)(b % gw) - ox, cy = (float)(b / gw) - oy; /* O -> B, cells */
        const float c2 = cx * cx + cy * cy;
        const float mx = su / (float)count - ox, my = sv / (float)count - oy;
        const float inner = cx * my - cy * mx > 0 ? 1.f : -1.f; /* the hole's side of the chord */
        float n = 0, st = 0, sz = 0, stt = 0, stz = 0;
        int nseed = 0; /* the distinct rim cells of the line, kept in g->stack (hand_in_front) */
        for (int k = 0; k < count; k++) {
            const int j = g->hole_cells[k], x = j % gw, y = j / gw;
            for (int d = 0; d < 4; d++) {
                const int xx = x + d4[d][0], yy = y + d4[d][1];
                if (xx < 0 || yy < 0 || xx >= gw || yy >= gh ||
                    (g->hole[yy * gw + xx] != SOLID && g->hole[yy * gw + xx] != FOREARM))
                    continue;
                const float px = (float)xx - ox, py = (float)yy - oy;
                const float t = (px * cx + py * cy) / c2;
                if (t < 0.f || t > 1.f || inner * (cx * py - cy * px) > 0.f)
                    continue;
                const float zr = g->z[yy * gw + xx];
                if (g->hole[yy * gw + xx] == SOLID) {
                    g->hole[yy * gw + xx] = FOREARM;
                    g->stack[nseed++] = yy * gw + xx;
                }
                n += 1.f;
                st += t;
                sz += zr;
                stt += t * t;
                stz += t * zr;
            }
        }
        const float den = n * stt - st * st;
        drv__extremum *e = &ex[nout++];
        memset(e, 0, sizeof *e);
        if (n >= LOOP_RIM_MIN && den > 1e-6f) {
            const float sl = (n * stz - st * sz) / den; /* metres of depth per O -> B */
            e->loop_rim = (int)n;
            e->loop_slope = sl / (sqrtf(c2) * cell_m);
            e->loop_z = (sz - sl * st) / n + sl; /* the line's depth at B */
        }
        if (e->loop_rim && e->loop_slope <= -DRV__LOOP_TOWARD)
            tip = hand_in_front(g, nseed, surface, b % gw, b / gw, reach, ox, oy);
        else
            for (int k = 0; k < nseed; k++)
                g->hole[g->stack[k]] = SOLID;
        e->cell = tip;
        e->loop = side > 0 ? 1 : -1;
        e->loop_slit = slit;
        memcpy(e->tip, g->P + 3 * tip, sizeof e->tip);
        memcpy(e->anchor, e->tip, sizeof e->anchor);
        if (nout == max)
            break;
    }
    return nout;
}

int drv__segment_arm_loops(drv__grid *g, const drv_depth_opts *o, const float up[3],
                           const float right[3], drv__extremum *ex, int max)
{
    static const int none[2] = {0, 0};
    int n = find_loops(g, o, up, right, 0, none, ex, max);
    if (n < max) { /* then slits, on a side without a hole */
        int taken[2] = {0, 0};
        for (int i = 0; i < n; i++)
            taken[ex[i].loop > 0] = 1;
        n += find_loops(g, o, up, right, 1, taken, ex + n, max - n);
    }
    return n;
}
