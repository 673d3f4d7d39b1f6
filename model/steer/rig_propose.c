/* rig_propose.c - a rig proposed from the mesh alone (issue 12, "A rig without counting
 * vertices"): markers, reference edge and limbs of DESIGN.md "The rig file" for a human or a
 * quadruped, from one pose of the mesh and its up axis.
 *
 * Everything is measured on the surface graph (core/meshgraph.c: Dijkstra along mesh edges, the
 * same idea the depth tracker uses on its depth grid), because geodesic distance barely changes
 * when a body moves its limbs: what is found in one frame is found, give or take a neighbouring
 * vertex, in every other frame of the sequence.
 *
 *   1. Centre c: the vertex of the largest connected part whose mean geodesic distance to 32
 *      points spread over it (farthest-point sampling from its first vertex) is least: a point
 *      of the trunk in any pose (the vertex nearest the centroid lands on a hand resting on the
 *      hip). D_c = geodesic distance from c; R = max D_c.
 *   2. Extremities by farthest-point sampling: the candidate is argmax_v min(D_c(v), distance
 *      to every earlier candidate); stop when that falls below 0.2 R. From the candidate, climb
 *      D_c to its local maximum (steps to the farthest vertex within a geodesic radius of
 *      0.1 R); that maximum is a new tip unless it lies within 0.2 R of a tip already taken (a
 *      point on a flank climbs to a limb found before; the cut-off neck of a headless scan is
 *      a flat cap whose farthest point is on its rim, not where sampling lands first). The tip
 *      is then the middle of its cap (the vertex nearest the centroid of the vertices within
 *      0.1 R whose D_c is within 0.03 R of the top): on a flat crown the top wanders with the
 *      pose, the middle does not.
 *   3. Human (5 tips): each tip is first refined, twice over the five: the middle of the top
 *      (within REFINE_CAP = 0.01 R of the maximum) of the mean geodesic distance from the other
 *      four tips, within REFINE_REACH = 0.2 R of it. That mean depends on the tips alone, not on
 *      the centre, which wanders over the trunk with the pose, and every other tip's geodesic
 *      arrives through the limb, so its top is a point at the limb's end. Worst distance over
 *      every 10th frame proposed alone from frame 0's proposal (test_rig_propose.c): pjump's
 *      head 23.3 -> 11.8 cm, samba's feet 5.4 -> 0.9 cm, the worst marker 0.118 -> 0.064 of the
 *      height on pjump, 0.064 -> 0.061 on samba. A quadruped's tips are not refined: the horse's
 *      hooves gained 1-5 cm, but its withers, placed from the legs' roots, then split between two
 *      spots (the medoids of two sets of frames 2.7 -> 11.1 cm apart).
 *      head = the tip of least summed geodesic distance to the other four (the neck is shorter
 *      than any limb), its marker the highest vertex within 0.1 R of it (as the hand rigs place
 *      it); feet = the two tips farthest from the head; hands = the other two.
 *      Quadruped (6 tips): hooves = the four lowest tips along up; front hooves = the pair nearer
 *      the muzzle end; muzzle vs tail: the end whose cross-section (the ring of vertices at
 *      geodesic distance 0.15 L..0.2 L from the tip, L = D_c(tip)) is the wider. The muzzle
 *      marker: the middle of the part of that end (within 0.35 R of its tip) farthest from the
 *      withers (the end's tip may be an ear; the ears stand a head's length nearer the withers).
 *   4. Forward f (unit, perpendicular to up): human: the toes. Per foot, the leg's axis a runs
 *      from the centroid of the ring at 0.25 L..0.3 L from the tip (ankle) to that of the ring at
 *      0.4 L..0.45 L (shin); the tip's offset from that axis points where the foot points.
 *      Quadruped: from the hind legs' roots to the front legs' roots (rings at 0.5 L..0.55 L).
 *      Assumption: people face where their toes point; the head is the thicker end of a quadruped.
 *      left = up x f (right-handed, so a person facing +X with Y up has her left at -Z).
 *   5. Sides: of a pair of tips, the one whose limb root (the ring at 0.5 L..0.55 L from the tip:
 *      elbow, knee, hock; a ring further up wraps the trunk) lies further along `left` is the
 *      left one; so crossed hands or feet do not swap.
 *   6. Trunk markers. Human: a mid-line is where the geodesic distances to the two feet (or
 *      hands) differ as they do at the head, within w = max(0.02 R, 2 x mean edge length).
 *      pelvis = the front-most (along f) vertex of the feet's mid-line whose distances to the
 *      head and to the feet differ least (within 0.02 R: half-way between head and feet, on the
 *      belly); neck = the front-most vertex of the hands' mid-line at 0.30..0.36 of the head's
 *      distance to the pelvis from the head (the base of the neck), measured from the pelvis
 *      (0.64..0.70 of it, and nearer the head than the pelvis is): the head's tip sits on a flat
 *      top (a crown, a cut neck) and moves over it with the pose, and a band measured from it
 *      moves too (pjump frame 132: the tip 12 cm down the front of the neck, the band reached the
 *      cut's top rim, and the neck proposed from that frame lay 34.8 cm from the medoid's; 18.3 cm
 *      measured from the pelvis). One frame alone, every frame: samba's neck median / p90 / max
 *      1.6 / 4.3 / 5.0 -> 1.6 / 2.5 / 4.0 cm from the medoid's, pjump's 4.5 / 8.9 / 34.8 -> 4.3
 *      / 8.4 / 18.3 cm.
 *      Quadruped: withers = the middle of the top (within 0.03 R of the highest, along up) of
 *      the slab, 0.03 R thick across f, through the front legs' roots; croup = the vertex, on the
 *      shortest path from the tail's tip to the withers (along the rump and the back), of least
 *      summed geodesic distance to the hind hooves: over the hips, found by geodesic distances
 *      only, since the slab through the hind legs' roots follows their swing.
 *   7. Checks (a wrong --up, a mesh without the body's tips): fewer tips than the body needs; a
 *      human whose feet are not below the head by at least a third of the head-foot geodesic
 *      distance; a quadruped with fewer than three of its four lowest tips hanging below their
 *      legs' roots (by 0.3 of the geodesic way there), or whose withers and croup are not above
 *      its hooves by a third of a leg; a forward direction parallel to up.
 *
 * Body "auto": a quadruped stands on four tips, a person on two: the fourth-lowest of the first
 * six tips lies within 0.3 of the body's height above the lowest vertex -> quadruped; when the
 * body so chosen fails the checks of step 7, the other body is tried.
 *
 * Names and sources: a human gets head, lhand, rhand, lfoot, rfoot (sources as the depth
 * tracker publishes them), pelvis and neck; reference pelvis -> neck; limbs neck-head, neck-hands,
 * pelvis-feet (rigs/samba-7.json). A quadruped gets withers, croup, lf/rf/lh/rh_hoof, muzzle,
 * tail; reference croup -> withers; limbs as rigs/horse.json.
 *
 * Several frames (mdl_rig_propose_frames): each frame proposed alone, then per marker the medoid
 * (the member of least summed distance to the others, as in Kaufman & Rousseeuw's k-medoids) of
 * its vertices over the frames of the majority body, measured in the first frame. Refused unless
 * more than half the frames were proposed as that body: with a wrong --up, 4 of horse-gallop's
 * 24 frames pass a quadruped's checks (step 7) and one frame alone would not.
 *
 * Training-time only: allocates (one distance field per tip, about 15 fields of nv doubles). */
#include "model.h"
#include "core/meshgraph.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_TIPS 8
#define CENTRE_SAMPLES 32 /* points whose mean geodesic distance the centre minimises */
#define CLIMB_STEPS 8 /* hill-climbing steps of 0.1 R from a candidate to its tip */
#define CAP 0.03       /* a tip is the middle of its cap: D_c within this (per R) of the top */
/* a human's tips refined (step 3): the middle of the top REFINE_CAP (per R) of the mean distance
 * from the other four tips, within REFINE_REACH (per R; tips are 0.2 R apart) of the tip */
#define REFINE_CAP 0.01
#define REFINE_REACH 0.2
/* the neck: its band of geodesic distance from the head, per head-to-pelvis distance */
#define NECK_LO 0.30
#define NECK_HI 0.36

typedef struct prop {
    const float *V;
    int nv;
    mdl_graph g;
    uint8_t *part; /* the largest connected part */
    double up[3];
    double R;      /* max geodesic distance from the centre */
    double edge;   /* mean edge length */
} prop;

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double vdot(const prop *p, int v, const double d[3])
{
    const float *x = p->V + 3 * (size_t)v;
    return x[0] * d[0] + x[1] * d[1] + x[2] * d[2];
}

static int normalise(double a[3])
{
    double n = sqrt(dot3(a, a));
    if (!(n > 1e-12))
        return -1;
    for (int k = 0; k < 3; k++)
        a[k] /= n;
    return 0;
}

/* Removes the component along up (unit). */
static void flatten(const prop *p, double a[3])
{
    double u = dot3(a, p->up);
    for (int k = 0; k < 3; k++)
        a[k] -= u * p->up[k];
}

/* Centroid of the part's vertices with lo <= D < hi; -1 when there are none. */
static int ring_centroid(const prop *p, const double *D, double lo, double hi, double c[3])
{
    double n = 0;
    c[0] = c[1] = c[2] = 0;
    for (int v = 0; v < p->nv; v++)
        if (p->part[v] && D[v] >= lo && D[v] < hi) {
            for (int k = 0; k < 3; k++)
                c[k] += p->V[3 * (size_t)v + k];
            n++;
        }
    if (n == 0)
        return -1;
    for (int k = 0; k < 3; k++)
        c[k] /= n;
    return 0;
}

/* Mean distance of the ring's vertices from its centroid (the limb's cross-section radius). */
static double ring_radius(const prop *p, const double *D, double lo, double hi)
{
    double c[3], s = 0, n = 0;
    if (ring_centroid(p, D, lo, hi, c))
        return 0;
    for (int v = 0; v < p->nv; v++)
        if (p->part[v] && D[v] >= lo && D[v] < hi) {
            const float *x = p->V + 3 * (size_t)v;
            double d[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]};
            s += sqrt(dot3(d, d));
            n++;
        }
    return n > 0 ? s / n : 0;
}

/* Marks the largest connected part of the graph (breadth first). */
static int largest_part(prop *p, char *err)
{
    int nv = p->nv, *label = malloc((size_t)nv * sizeof *label),
        *queue = malloc((size_t)nv * sizeof *queue);
    p->part = calloc((size_t)nv, 1);
    if (!label || !queue || !p->part) {
        free(label);
        free(queue);
        return mdl__err(err, -ENOMEM, "rig: out of memory");
    }
    for (int v = 0; v < nv; v++)
        label[v] = -1;
    int best = -1, best_n = 0, nl = 0;
    for (int s = 0; s < nv; s++) {
        if (label[s] >= 0 || p->g.off[s] == p->g.off[s + 1])
            continue; /* labelled, or a vertex no face uses */
        int head = 0, tail = 0;
        queue[tail++] = s;
        label[s] = nl;
        while (head < tail) {
            int v = queue[head++];
            for (int i = p->g.off[v]; i < p->g.off[v + 1]; i++) {
                int u = p->g.nbr[i];
                if (label[u] < 0) {
                    label[u] = nl;
                    queue[tail++] = u;
                }
            }
        }
        if (tail > best_n) {
            best_n = tail;
            best = nl;
        }
        nl++;
    }
    for (int v = 0; v < nv; v++)
        p->part[v] = best >= 0 && label[v] == best;
    free(label);
    free(queue);
    if (best_n < 4)
        return mdl__err(err, -EINVAL, "rig: the mesh has no faces to measure along");
    return 0;
}

static int geodesic(const prop *p, int src, double *D, char *err)
{
    return mdl__geodesic(&p->g, p->V, &src, 1, p->part, D, err);
}

/* The extremities (step 2): tips[] in farthest-point order; returns how many. */
/* The extremities (step 2): tips[] in farthest-point order; returns how many, or an error.
 * near: min(D_c, distances to every candidate so far); Dt: scratch (nv each). */
static int find_tips(const prop *p, const double *Dc, double *near, double *Dt, int *tips,
                     char *err)
{
    int n = 0, e = 0;
    double *tipnear = malloc((size_t)p->nv * sizeof *tipnear); /* distance to the tips taken */
    if (!tipnear)
        return mdl__err(err, -ENOMEM, "rig: out of memory");
    memcpy(near, Dc, (size_t)p->nv * sizeof *near);
    for (int v = 0; v < p->nv; v++)
        tipnear[v] = INFINITY;
    for (int it = 0; it < 2 * MAX_TIPS && n < MAX_TIPS; it++) {
        int best = -1;
        for (int v = 0; v < p->nv; v++)
            if (p->part[v] && isfinite(near[v]) && (best < 0 || near[v] > near[best]))
                best = v;
        if (best < 0 || near[best] < 0.2 * p->R)
            break;
        /* climb D_c to its local maximum within 0.1 R: the tip the candidate belongs to */
        int cur = best, top = 0;
        for (int step = 0; step < CLIMB_STEPS && !top; step++) {
            if ((e = geodesic(p, cur, Dt, err)) != 0)
                goto out;
            for (int v = 0; v < p->nv; v++)
                if (Dt[v] < near[v])
                    near[v] = Dt[v];
            int m = cur;
            for (int v = 0; v < p->nv; v++)
                if (p->part[v] && Dt[v] < 0.1 * p->R && Dc[v] > Dc[m])
                    m = v;
            if (m == cur)
                top = 1;
            cur = m;
        }
        /* a new tip if the climb reached a maximum, not within 0.2 R of a tip already taken */
        if (top && tipnear[cur] >= 0.2 * p->R) {
            /* the cap's middle rather than its highest vertex: a flat crown or cut has its
             * maximum anywhere on it, its middle in one place from any pose */
            double c[3] = {0, 0, 0}, cn = 0, bd = INFINITY;
            for (int v = 0; v < p->nv; v++)
                if (p->part[v] && Dt[v] < 0.1 * p->R && Dc[v] >= Dc[cur] - CAP * p->R) {
                    for (int k = 0; k < 3; k++)
                        c[k] += p->V[3 * (size_t)v + k];
                    cn++;
                }
            int mid = cur;
            for (int v = 0; v < p->nv; v++)
                if (p->part[v] && Dt[v] < 0.1 * p->R && Dc[v] >= Dc[cur] - CAP * p->R) {
                    const float *x = p->V + 3 * (size_t)v;
                    double d[3] = {x[0] - c[0] / cn, x[1] - c[1] / cn, x[2] - c[2] / cn};
                    if (dot3(d, d) < bd) {
                        bd = dot3(d, d);
                        mid = v;
                    }
                }
            cur = mid;
            if ((e = geodesic(p, cur, Dt, err)) != 0)
                goto out;
            for (int v = 0; v < p->nv; v++) {
                if (Dt[v] < tipnear[v])
                    tipnear[v] = Dt[v];
                if (Dt[v] < near[v])
                    near[v] = Dt[v];
            }
            tips[n++] = cur;
        }
    }
    e = n;
out:
    free(tipnear);
    return e;
}

/* Root of the limb ending at `tip` (field D of that tip, length L): the ring at 0.5..0.55 L (elbow,
 * knee, hock: still on the limb, where a ring further up would wrap the trunk). */
static int limb_root(const prop *p, const double *D, double L, double c[3])
{
    return ring_centroid(p, D, 0.5 * L, 0.55 * L, c);
}

/* Orders the pair (a, b) as (left, right) by their limbs' roots. */
static void side_pair(const prop *p, const double left[3], const double *Da, const double *Db,
                      double La, double Lb, int *a, int *b)
{
    double ra[3], rb[3];
    int ea = limb_root(p, Da, La, ra), eb = limb_root(p, Db, Lb, rb);
    double sa = ea ? vdot(p, *a, left) : dot3(ra, left), sb = eb ? vdot(p, *b, left) : dot3(rb, left);
    if (sa < sb) {
        int t = *a;
        *a = *b;
        *b = t;
    }
}

static int set_marker(mdl_rig *r, int i, const char *name, const char *source, int vertex)
{
    mdl_rig_marker *m = &r->markers[i];
    snprintf(m->name, sizeof m->name, "%s", name);
    snprintf(m->source, sizeof m->source, "%s", source ? source : name);
    m->vertex = vertex;
    return 0;
}

/* A rig of nm markers (names/sources/vertices), reference (2 indices) and two-marker limbs. */
static int make_rig(mdl_rig **out, int nm, const char *const *names, const char *const *sources,
                    const int *vertex, int ref0, int ref1, int nl, const int (*limbs)[2], char *err)
{
    mdl_rig *r = calloc(1, sizeof *r);
    if (!r)
        return mdl__err(err, -ENOMEM, "rig: out of memory");
    r->markers = calloc((size_t)nm, sizeof *r->markers);
    r->limb_off = calloc((size_t)nl + 1, sizeof *r->limb_off);
    r->limb_idx = calloc(2 * (size_t)nl, sizeof *r->limb_idx);
    if (!r->markers || !r->limb_off || !r->limb_idx) {
        mdl_rig_destroy(r);
        return mdl__err(err, -ENOMEM, "rig: out of memory");
    }
    r->nmarkers = nm;
    for (int i = 0; i < nm; i++)
        set_marker(r, i, names[i], sources ? sources[i] : NULL, vertex[i]);
    r->nref = 2;
    r->ref[0] = ref0;
    r->ref[1] = ref1;
    r->nlimbs = nl;
    for (int l = 0; l < nl; l++) {
        r->limb_off[l + 1] = 2 * (l + 1);
        r->limb_idx[2 * l] = limbs[l][0];
        r->limb_idx[2 * l + 1] = limbs[l][1];
    }
    *out = r;
    return 0;
}

/* Front-most (along f) vertex among those with sel[v]; -1 if none. */
static int front_most(const prop *p, const uint8_t *sel, const double f[3])
{
    int best = -1;
    double bd = -INFINITY;
    for (int v = 0; v < p->nv; v++)
        if (sel[v]) {
            double d = vdot(p, v, f);
            if (d > bd) {
                bd = d;
                best = v;
            }
        }
    return best;
}

/* The middle of the top of field F over the part's vertices with Dreg < rad: the vertex, among
 * those within `cap` of F's maximum over that set, nearest their centroid. A region's centre, not
 * its one extreme vertex, which wanders over a flat top (a crown, a back) with the pose. -1 if the
 * set is empty. */
static int top_middle(const prop *p, const double *F, const double *Dreg, double rad, double cap)
{
    double top = -INFINITY, c[3] = {0, 0, 0}, n = 0, bd = INFINITY;
    for (int v = 0; v < p->nv; v++)
        if (p->part[v] && Dreg[v] < rad && F[v] > top)
            top = F[v];
    if (!isfinite(top))
        return -1;
    for (int v = 0; v < p->nv; v++)
        if (p->part[v] && Dreg[v] < rad && F[v] >= top - cap) {
            for (int k = 0; k < 3; k++)
                c[k] += p->V[3 * (size_t)v + k];
            n++;
        }
    int best = -1;
    for (int v = 0; v < p->nv; v++)
        if (p->part[v] && Dreg[v] < rad && F[v] >= top - cap) {
            const float *x = p->V + 3 * (size_t)v;
            double d[3] = {x[0] - c[0] / n, x[1] - c[1] / n, x[2] - c[2] / n};
            if (dot3(d, d) < bd) {
                bd = dot3(d, d);
                best = v;
            }
        }
    return best;
}

/* Along the shortest path from `from` to the source of the distance field Dto (traced back down
 * Dto: each step to the neighbour u of least Dto[u] + |u - v|, Dijkstra's predecessor), the
 * vertex of least Da + Db; -1 if the path is broken. */
static int path_min(const prop *p, const double *Dto, int from, int to, const double *Da,
                    const double *Db)
{
    int v = from, best = -1;
    double bs = INFINITY;
    for (int step = 0; step < p->nv; step++) {
        if (Da[v] + Db[v] < bs) {
            bs = Da[v] + Db[v];
            best = v;
        }
        if (v == to)
            return best;
        int next = -1;
        double nd = INFINITY;
        for (int i = p->g.off[v]; i < p->g.off[v + 1]; i++) {
            int u = p->g.nbr[i];
            const float *x = p->V + 3 * (size_t)u, *y = p->V + 3 * (size_t)v;
            double d[3] = {x[0] - y[0], x[1] - y[1], x[2] - y[2]};
            if (p->part[u] && Dto[u] < Dto[v] && Dto[u] + sqrt(dot3(d, d)) < nd) {
                nd = Dto[u] + sqrt(dot3(d, d));
                next = u;
            }
        }
        if (next < 0)
            return -1;
        v = next;
    }
    return -1;
}

typedef struct work {
    double *Dc, *near, *Dt[MAX_TIPS], *tmp;
    uint8_t *sel;
} work;

/* Each of the n tips again as the middle of the top of the mean geodesic distance from the other
 * n - 1 tips (step 3), its distance field recomputed; twice, since each move changes the others'
 * fields. That mean depends on the tips only, not on the centre (which wanders over the trunk
 * from pose to pose), and its top is a point, not a plateau: at the end of a limb, every other
 * tip's geodesic arrives through the limb. */
static int refine_tips(const prop *p, work *w, int *tips, int n, char *err)
{
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i < n; i++) {
            for (int v = 0; v < p->nv; v++) {
                double s = 0;
                for (int j = 0; j < n; j++)
                    if (j != i)
                        s += w->Dt[j][v];
                w->tmp[v] = s / (n - 1);
            }
            int t = top_middle(p, w->tmp, w->Dt[i], REFINE_REACH * p->R, REFINE_CAP * p->R);
            if (t < 0 || t == tips[i])
                continue;
            tips[i] = t;
            int e = geodesic(p, t, w->Dt[i], err);
            if (e)
                return e;
        }
    return 0;
}

static int propose_human(prop *p, work *w, int *tips, mdl_rig **out, mdl_rig_proposal *info,
                         char *err)
{
    int e, nt = 5;
    if ((e = refine_tips(p, w, tips, nt, err)) != 0)
        return e;
    /* head: the least summed geodesic distance to the other tips (the trunk is shorter than a
     * limb: about 5.6 m summed for samba's head against 6.9 for a hand and 7.8 for a foot) */
    int h = 0;
    double hs_best = INFINITY;
    for (int i = 0; i < nt; i++) {
        double sum = 0;
        for (int j = 0; j < nt; j++)
            sum += w->Dt[j][tips[i]];
        if (sum < hs_best) {
            hs_best = sum;
            h = i;
        }
    }
    /* feet: the two farthest from the head */
    int rest[4], nr = 0;
    for (int i = 0; i < nt; i++)
        if (i != h)
            rest[nr++] = i;
    const double *Dh = w->Dt[h];
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++)
            if (Dh[tips[rest[j]]] > Dh[tips[rest[i]]]) {
                int t = rest[i];
                rest[i] = rest[j];
                rest[j] = t;
            }
    int f0 = rest[0], f1 = rest[1], h0 = rest[2], h1 = rest[3];
    /* forward from the toes (step 4) */
    double fwd[3] = {0, 0, 0};
    for (int k = 0; k < 2; k++) {
        int fi = k ? f1 : f0, t = tips[fi];
        double L = w->Dc[t], c1[3], c2[3];
        if (ring_centroid(p, w->Dt[fi], 0.25 * L, 0.3 * L, c1) ||
            ring_centroid(p, w->Dt[fi], 0.4 * L, 0.45 * L, c2))
            continue;
        double a[3] = {c2[0] - c1[0], c2[1] - c1[1], c2[2] - c1[2]};
        if (normalise(a))
            continue;
        const float *x = p->V + 3 * (size_t)t;
        double o[3] = {x[0] - c1[0], x[1] - c1[1], x[2] - c1[2]};
        double oa = dot3(o, a);
        for (int q = 0; q < 3; q++)
            fwd[q] += o[q] - oa * a[q];
    }
    flatten(p, fwd);
    if (normalise(fwd))
        return mdl__err(err, -EINVAL, "rig: cannot tell which way the feet point (is --up right?)");
    double left[3] = {p->up[1] * fwd[2] - p->up[2] * fwd[1], p->up[2] * fwd[0] - p->up[0] * fwd[2],
                      p->up[0] * fwd[1] - p->up[1] * fwd[0]};
    /* the head must be above the feet */
    double fh = 0.5 * (vdot(p, tips[f0], p->up) + vdot(p, tips[f1], p->up));
    double need = (Dh[tips[f0]] + Dh[tips[f1]]) / 6;
    if (vdot(p, tips[h], p->up) - fh < need)
        return mdl__err(err, -EINVAL,
                        "rig: the head (vertex %d) is not above the feet (vertices %d, %d) along "
                        "the up axis by a third of their geodesic distance (%.3g < %.3g): the body "
                        "lies down in this frame, or --up is wrong",
                        tips[h], tips[f0], tips[f1], vdot(p, tips[h], p->up) - fh, need);
    /* sides (step 5) */
    int lf = tips[f0], rf = tips[f1], lh = tips[h0], rh = tips[h1];
    const double *Dlf = w->Dt[f0], *Drf = w->Dt[f1], *Dlh = w->Dt[h0], *Drh = w->Dt[h1];
    {
        int a = f0, b = f1;
        side_pair(p, left, w->Dt[f0], w->Dt[f1], w->Dc[lf], w->Dc[rf], &a, &b);
        if (a != f0) {
            lf = tips[f1], rf = tips[f0];
            Dlf = w->Dt[f1], Drf = w->Dt[f0];
        }
        a = h0, b = h1;
        side_pair(p, left, w->Dt[h0], w->Dt[h1], w->Dc[lh], w->Dc[rh], &a, &b);
        if (a != h0) {
            lh = tips[h1], rh = tips[h0];
            Dlh = w->Dt[h1], Drh = w->Dt[h0];
        }
    }
    /* the mid-line and the trunk markers (step 6) */
    /* the head marker: the highest vertex (along up) within 0.1 R of the head's refined tip, as
     * the hand rigs place it. The refined tip matters on pjump's scan, cut at the neck by a
     * slanted face: the unrefined tip lay on the face's back rim in frame 0 and on its front
     * rim, 12 cm lower, in most other frames, and the highest vertex near it followed */
    int head = tips[h];
    for (int v = 0; v < p->nv; v++)
        if (p->part[v] && Dh[v] < 0.1 * p->R && vdot(p, v, p->up) > vdot(p, head, p->up))
            head = v;
    double wid = fmax(0.02 * p->R, 2 * p->edge);
    double dh0 = Dlh[head] - Drh[head], df0 = Dlf[head] - Drf[head];
    /* pelvis: on the feet's mid-line, half-way between the head and the feet, front-most */
    double dmin = INFINITY;
    for (int v = 0; v < p->nv; v++) {
        int mid = p->part[v] && fabs(Dlf[v] - Drf[v] - df0) <= wid;
        w->tmp[v] = mid ? fabs(Dh[v] - 0.5 * (Dlf[v] + Drf[v])) : INFINITY;
        if (w->tmp[v] < dmin)
            dmin = w->tmp[v];
    }
    for (int v = 0; v < p->nv; v++)
        w->sel[v] = w->tmp[v] <= dmin + 0.02 * p->R;
    int pelvis = front_most(p, w->sel, fwd);
    if (pelvis < 0)
        return mdl__err(err, -EINVAL, "rig: found no pelvis on the mid-line between the feet");
    /* neck: on the hands' mid-line, about a third of the way from the head to the pelvis,
     * measured from the pelvis (step 6) */
    double dp = Dh[pelvis];
    double *Dp = w->near; /* scratch: the tips are found */
    if ((e = geodesic(p, pelvis, Dp, err)) != 0)
        return e;
    for (int v = 0; v < p->nv; v++)
        w->sel[v] = p->part[v] && fabs(Dlh[v] - Drh[v] - dh0) <= wid &&
                    Dp[v] >= (1 - NECK_HI) * dp && Dp[v] <= (1 - NECK_LO) * dp && Dh[v] < dp;
    int neck = front_most(p, w->sel, fwd);
    if (neck < 0 || pelvis < 0)
        return mdl__err(err, -EINVAL, "rig: found no neck or pelvis on the mid-line");
    static const char *const names[] = {"head", "lhand", "rhand", "lfoot", "rfoot", "pelvis", "neck"};
    static const int limbs[][2] = {{6, 0}, {6, 1}, {6, 2}, {5, 3}, {5, 4}};
    int vert[7] = {head, lh, rh, lf, rf, pelvis, neck};
    if ((e = make_rig(out, 7, names, NULL, vert, 5, 6, 5, limbs, err)) != 0)
        return e;
    for (int q = 0; q < 3; q++) {
        info->forward[q] = (float)fwd[q];
        info->left[q] = (float)left[q];
    }
    return 0;
}

static int propose_quadruped(prop *p, work *w, const int *tips, mdl_rig **out,
                             mdl_rig_proposal *info, char *err)
{
    int e, nt = 6;
    int ord[6];
    for (int i = 0; i < nt; i++)
        ord[i] = i;
    for (int i = 0; i < nt; i++) /* by height, lowest first */
        for (int j = i + 1; j < nt; j++)
            if (vdot(p, tips[ord[j]], p->up) < vdot(p, tips[ord[i]], p->up)) {
                int t = ord[i];
                ord[i] = ord[j];
                ord[j] = t;
            }
    int hoof[4] = {ord[0], ord[1], ord[2], ord[3]}, end[2] = {ord[4], ord[5]};
    /* muzzle: the wider end */
    double rad[2];
    for (int k = 0; k < 2; k++) {
        double L = w->Dc[tips[end[k]]];
        rad[k] = ring_radius(p, w->Dt[end[k]], 0.15 * L, 0.2 * L);
    }
    int mi = rad[0] >= rad[1] ? end[0] : end[1], ti = rad[0] >= rad[1] ? end[1] : end[0];
    /* front hooves: the two nearer the muzzle */
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++)
            if (w->Dt[mi][tips[hoof[j]]] < w->Dt[mi][tips[hoof[i]]]) {
                int t = hoof[i];
                hoof[i] = hoof[j];
                hoof[j] = t;
            }
    double root[4][3];
    for (int i = 0; i < 4; i++)
        if (limb_root(p, w->Dt[hoof[i]], w->Dc[tips[hoof[i]]], root[i]))
            for (int q = 0; q < 3; q++)
                root[i][q] = p->V[3 * (size_t)tips[hoof[i]] + q];
    /* legs hang: at least three hooves lie below their legs' roots by 0.3 of the way there */
    int hanging = 0;
    for (int i = 0; i < 4; i++) {
        int t = tips[hoof[i]];
        double drop = dot3(root[i], p->up) - vdot(p, t, p->up);
        if (drop >= 0.3 * 0.5 * w->Dc[t])
            hanging++;
    }
    if (hanging < 3)
        return mdl__err(err, -EINVAL,
                        "rig: %d of the four lowest extremities (vertices %d, %d, %d, %d) hang "
                        "below their legs along the up axis (need 3): this is not a quadruped "
                        "standing along --up, or --up is wrong",
                        hanging, tips[hoof[0]], tips[hoof[1]], tips[hoof[2]], tips[hoof[3]]);
    double front[3], hind[3], fwd[3];
    for (int q = 0; q < 3; q++) {
        front[q] = 0.5 * (root[0][q] + root[1][q]);
        hind[q] = 0.5 * (root[2][q] + root[3][q]);
        fwd[q] = front[q] - hind[q];
    }
    flatten(p, fwd);
    if (normalise(fwd))
        return mdl__err(err, -EINVAL, "rig: the front and hind legs are not apart across the up "
                                      "axis (is --up right?)");
    double left[3] = {p->up[1] * fwd[2] - p->up[2] * fwd[1], p->up[2] * fwd[0] - p->up[0] * fwd[2],
                      p->up[0] * fwd[1] - p->up[1] * fwd[0]};
    int idx[4];
    for (int pr = 0; pr < 2; pr++) { /* sides: root further along left is left */
        int a = 2 * pr, b = 2 * pr + 1;
        if (dot3(root[a], left) >= dot3(root[b], left)) {
            idx[2 * pr] = tips[hoof[a]];
            idx[2 * pr + 1] = tips[hoof[b]];
        } else {
            idx[2 * pr] = tips[hoof[b]];
            idx[2 * pr + 1] = tips[hoof[a]];
        }
    }
    /* withers and croup: the top of the slab through the legs' roots */
    int top[2] = {-1, -1};
    for (int k = 0; k < 2; k++) {
        double s = dot3(k ? hind : front, fwd), best = -INFINITY;
        for (int v = 0; v < p->nv; v++)
            if (p->part[v] && fabs(vdot(p, v, fwd) - s) <= 0.015 * p->R) {
                double hgt = vdot(p, v, p->up);
                if (hgt > best) {
                    best = hgt;
                    top[k] = v;
                }
            }
        if (top[k] < 0)
            return mdl__err(err, -EINVAL, "rig: found no back above the %s legs",
                            k ? "hind" : "front");
        /* the middle of the slab's top, not its highest vertex: a back is nearly level (horse-
         * gallop: 3 cm over 36 cm), so its highest vertex wanders along it with the pose */
        for (int v = 0; v < p->nv; v++) {
            w->tmp[v] = vdot(p, v, p->up);
            w->near[v] = fabs(vdot(p, v, fwd) - s); /* scratch: the tips are found */
        }
        int m = top_middle(p, w->tmp, w->near, 0.015 * p->R, CAP * p->R);
        if (m >= 0)
            top[k] = m;
    }
    double hoofh = 0;
    for (int i = 0; i < 4; i++)
        hoofh += vdot(p, idx[i], p->up) / 4;
    double leg = 0;
    for (int i = 0; i < 4; i++)
        leg += w->Dc[idx[i]] / 4;
    for (int k = 0; k < 2; k++)
        if (vdot(p, top[k], p->up) - hoofh < leg / 3)
            return mdl__err(err, -EINVAL,
                            "rig: the %s (vertex %d) is not above the hooves along the up axis by "
                            "a third of a leg (%.3g < %.3g): the body lies down in this frame, or "
                            "--up is wrong",
                            k ? "croup" : "withers", top[k], vdot(p, top[k], p->up) - hoofh, leg / 3);
    /* muzzle: the farthest tip of the head from the withers may be an ear (horse-gallop frames
     * 10 and 30: an ear 36 cm from the muzzle); the muzzle is the middle of the part of the head
     * (within 0.35 R of its tip) farthest from the withers, which the ears are not: they stand on
     * the poll, a head's length nearer the withers along the neck's crest */
    int muzzle = tips[mi];
    if ((e = geodesic(p, top[0], w->tmp, err)) != 0)
        return e;
    {
        int m = top_middle(p, w->tmp, w->Dt[mi], 0.35 * p->R, CAP * p->R);
        if (m >= 0)
            muzzle = m;
    }
    /* croup: the slab over the hind legs follows their swing (horse-gallop: its top moved 36 cm
     * along the back between frames). Geodesic distances barely change with the pose, so: the
     * vertex, on the shortest path from the tail's tip to the withers (which runs along the top
     * of the rump and the back), of least summed geodesic distance to the two hind hooves (over
     * the hips). The path is traced back down the withers' distance field. */
    {
        int best = path_min(p, w->tmp, tips[ti], top[0], w->Dt[hoof[2]], w->Dt[hoof[3]]);
        if (best >= 0 && vdot(p, best, p->up) - hoofh >= leg / 3)
            top[1] = best;
    }
    static const char *const names[] = {"withers", "croup", "lf_hoof", "rf_hoof",
                                        "lh_hoof", "rh_hoof", "muzzle",  "tail"};
    static const int limbs[][2] = {{0, 2}, {0, 3}, {1, 4}, {1, 5}, {0, 6}, {1, 7}};
    int vert[8] = {top[0], top[1], idx[0], idx[1], idx[2], idx[3], muzzle, tips[ti]};
    if ((e = make_rig(out, 8, names, NULL, vert, 1, 0, 6, limbs, err)) != 0)
        return e;
    for (int q = 0; q < 3; q++) {
        info->forward[q] = (float)fwd[q];
        info->left[q] = (float)left[q];
    }
    return 0;
}

int mdl_rig_propose(const float *V, int nv, const uint32_t *F, int nf, const float up[3], int body,
                    mdl_rig **out, mdl_rig_proposal *info, char *err)
{
    *out = NULL;
    mdl_rig_proposal dummy;
    if (!info)
        info = &dummy;
    memset(info, 0, sizeof *info);
    if (nv < 4 || nf < 2)
        return mdl__err(err, -EINVAL, "rig: the mesh has %d vertices and %d faces", nv, nf);
    if (body != MDL_BODY_AUTO && body != MDL_BODY_HUMAN && body != MDL_BODY_QUADRUPED)
        return mdl__err(err, -EINVAL, "rig: unknown body %d", body);
    for (int f = 0; f < 3 * nf; f++)
        if (F[f] >= (uint32_t)nv)
            return mdl__err(err, -EINVAL, "rig: face %d uses vertex %u of %d", f / 3, F[f], nv);
    prop p = {.V = V, .nv = nv};
    for (int k = 0; k < 3; k++)
        p.up[k] = up[k];
    if (normalise(p.up))
        return mdl__err(err, -EINVAL, "rig: the up axis is zero");
    work w;
    memset(&w, 0, sizeof w);
    int e = mdl__graph_init(&p.g, nv, F, nf, err);
    if (e)
        return e;
    if ((e = largest_part(&p, err)) != 0)
        goto done;
    w.Dc = malloc((size_t)nv * sizeof(double));
    w.near = malloc((size_t)nv * sizeof(double));
    w.tmp = malloc((size_t)nv * sizeof(double));
    w.sel = calloc((size_t)nv, 1);
    for (int i = 0; i < MAX_TIPS; i++)
        w.Dt[i] = malloc((size_t)nv * sizeof(double));
    int ok = w.Dc && w.near && w.tmp && w.sel;
    for (int i = 0; i < MAX_TIPS; i++)
        ok = ok && w.Dt[i];
    if (!ok) {
        e = mdl__err(err, -ENOMEM, "rig: out of memory");
        goto done;
    }
    /* step 1: the centre, the vertex of least mean geodesic distance to CENTRE_SAMPLES points
     * spread over the surface by farthest-point sampling (from the part's first vertex) */
    double el = 0, ne = 0;
    int first = -1;
    for (int v = 0; v < nv; v++)
        if (p.part[v]) {
            if (first < 0)
                first = v;
            for (int i = p.g.off[v]; i < p.g.off[v + 1]; i++) {
                const float *a = V + 3 * (size_t)v, *b = V + 3 * (size_t)p.g.nbr[i];
                double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
                el += sqrt(dot3(d, d));
                ne++;
            }
        }
    p.edge = ne > 0 ? el / ne : 0;
    for (int v = 0; v < nv; v++) {
        w.near[v] = INFINITY;
        w.Dc[v] = 0; /* the sum of distances to the samples */
    }
    int sample = first;
    for (int k = 0; k < CENTRE_SAMPLES; k++) {
        if ((e = geodesic(&p, sample, w.tmp, err)) != 0)
            goto done;
        int far = sample;
        for (int v = 0; v < nv; v++)
            if (p.part[v]) {
                w.Dc[v] += w.tmp[v];
                if (w.tmp[v] < w.near[v])
                    w.near[v] = w.tmp[v];
                if (w.near[v] > w.near[far])
                    far = v;
            }
        sample = far;
    }
    int centre = first;
    for (int v = 0; v < nv; v++)
        if (p.part[v] && w.Dc[v] < w.Dc[centre])
            centre = v;
    if ((e = geodesic(&p, centre, w.Dc, err)) != 0)
        goto done;
    p.R = 0;
    for (int v = 0; v < nv; v++)
        if (p.part[v] && isfinite(w.Dc[v]) && w.Dc[v] > p.R)
            p.R = w.Dc[v];
    if (!(p.R > 0)) {
        e = mdl__err(err, -EINVAL, "rig: the mesh has no extent");
        goto done;
    }
    /* step 2: the tips */
    int tips[MAX_TIPS];
    int ntips = find_tips(&p, w.Dc, w.near, w.tmp, tips, err);
    if (ntips < 0) {
        e = ntips;
        goto done;
    }
    info->centre = centre;
    info->ntips = ntips;
    memcpy(info->tips, tips, (size_t)ntips * sizeof *tips);
    /* auto: the fourth-lowest of the first six tips near the ground -> four legs */
    double lo = INFINITY, hi = -INFINITY;
    for (int v = 0; v < nv; v++)
        if (p.part[v]) {
            double h = vdot(&p, v, p.up);
            lo = fmin(lo, h);
            hi = fmax(hi, h);
        }
    info->height = hi - lo;
    double hs[MAX_TIPS];
    int m = ntips < 6 ? ntips : 6;
    for (int i = 0; i < m; i++)
        hs[i] = vdot(&p, tips[i], p.up) - lo;
    for (int i = 0; i < m; i++)
        for (int j = i + 1; j < m; j++)
            if (hs[j] < hs[i]) {
                double t = hs[i];
                hs[i] = hs[j];
                hs[j] = t;
            }
    info->fourth_lowest = m >= 4 && hi > lo ? hs[3] / (hi - lo) : 1;
    int autob = body == MDL_BODY_AUTO;
    if (autob)
        body = m >= 6 && info->fourth_lowest < 0.3 ? MDL_BODY_QUADRUPED : MDL_BODY_HUMAN;
    info->body = body;
    int need = body == MDL_BODY_HUMAN ? 5 : 6;
    if (ntips < need) {
        e = mdl__err(err, -EINVAL,
                     "rig: found %d geodesic extremities of the surface (a %s needs %d: %s)", ntips,
                     body == MDL_BODY_HUMAN ? "human" : "quadruped", need,
                     body == MDL_BODY_HUMAN ? "head, two hands, two feet"
                                            : "four hooves, muzzle, tail");
        goto done;
    }
    for (int i = 0; i < (ntips < 6 ? ntips : 6); i++)
        if ((e = geodesic(&p, tips[i], w.Dt[i], err)) != 0)
            goto done;
    int htips[MAX_TIPS]; /* a human refines its tips (and their fields) */
    memcpy(htips, tips, sizeof htips);
    e = body == MDL_BODY_HUMAN ? propose_human(&p, &w, htips, out, info, err)
                               : propose_quadruped(&p, &w, tips, out, info, err);
    /* auto: when the body the layout suggests fails its checks (a galloping horse with three
     * hooves in the air), the other one; the first body's message if both fail */
    if (autob && e == -EINVAL && ntips >= 6) {
        char err2[MDL_ERR_LEN];
        int other = body == MDL_BODY_HUMAN ? MDL_BODY_QUADRUPED : MDL_BODY_HUMAN;
        int e2 = 0;
        for (int i = 0; i < 6 && other == MDL_BODY_QUADRUPED && !e2; i++) /* the unrefined tips */
            e2 = geodesic(&p, tips[i], w.Dt[i], err2);
        if (!e2)
            e2 = other == MDL_BODY_HUMAN ? propose_human(&p, &w, htips, out, info, err2)
                                         : propose_quadruped(&p, &w, tips, out, info, err2);
        if (e2 == 0) {
            info->body = other;
            e = 0;
        } else if (e2 == -ENOMEM) {
            e = mdl__err(err, e2, "%s", err2);
        }
    }
done:
    free(w.Dc);
    free(w.near);
    free(w.tmp);
    free(w.sel);
    for (int i = 0; i < MAX_TIPS; i++)
        free(w.Dt[i]);
    free(p.part);
    mdl__graph_fini(&p.g);
    return e;
}

/* Several frames: each proposed alone, then per marker the medoid of its vertices (measured in the
 * first frame), over the frames of the majority body. A marker's vertex in one frame can sit on
 * either side of a flat region (a crown, a back, a cut neck); the medoid is the vertex the
 * majority of frames cluster around, so it changes little with the set of frames. */
int mdl_rig_propose_frames(const float *V, int nv, int nframes, const int *frame_no,
                           const uint32_t *F, int nf, const float up[3], int body, mdl_rig **out,
                           mdl_rig_proposal *info, int *nused, char *err)
{
    *out = NULL;
    if (nused)
        *nused = 0;
    if (nframes < 1)
        return mdl__err(err, -EINVAL, "rig: no frames to propose from");
    mdl_rig **rigs = calloc((size_t)nframes, sizeof *rigs);
    mdl_rig_proposal *infos = calloc((size_t)nframes, sizeof *infos);
    int *cand = malloc((size_t)nframes * sizeof *cand), e = 0, nb[3] = {0, 0, 0};
    char first_err[MDL_ERR_LEN] = "";
    if (!rigs || !infos || !cand) {
        e = mdl__err(err, -ENOMEM, "rig: out of memory");
        goto done;
    }
    for (int k = 0; k < nframes; k++) {
        char e1[MDL_ERR_LEN] = "";
        int r = mdl_rig_propose(V + (size_t)k * nv * 3, nv, F, nf, up, body, &rigs[k], &infos[k], e1);
        if (r == -ENOMEM) {
            e = mdl__err(err, r, "%s", e1);
            goto done;
        }
        if (r) {
            if (!first_err[0])
                snprintf(first_err, sizeof first_err, "frame %d: %s", frame_no ? frame_no[k] : k,
                         e1);
            rigs[k] = NULL;
            continue;
        }
        nb[infos[k].body]++;
    }
    int chosen = nb[MDL_BODY_QUADRUPED] > nb[MDL_BODY_HUMAN] ? MDL_BODY_QUADRUPED : MDL_BODY_HUMAN;
    int ref = -1, n = 0;
    for (int k = 0; k < nframes; k++)
        if (rigs[k] && infos[k].body == chosen) {
            if (ref < 0)
                ref = k;
            n++;
        }
    if (ref < 0) {
        e = mdl__err(err, -EINVAL, "rig: every frame was refused (%s)", first_err);
        goto done;
    }
    if (2 * n <= nframes) { /* a body most frames refuse is a guess (a wrong --up, a few poses) */
        e = mdl__err(err, -EINVAL,
                     "rig: only %d of %d frames could be proposed as a %s; the first refused: %s", n,
                     nframes, chosen == MDL_BODY_HUMAN ? "human" : "quadruped", first_err);
        goto done;
    }
    mdl_rig *r = rigs[ref];
    for (int i = 0; i < r->nmarkers; i++) {
        int nc = 0;
        for (int k = 0; k < nframes; k++)
            if (rigs[k] && infos[k].body == chosen)
                cand[nc++] = rigs[k]->markers[i].vertex; /* same body: same names, same order */
        double best = INFINITY;
        int bv = r->markers[i].vertex;
        for (int a = 0; a < nc; a++) {
            const float *x = V + 3 * (size_t)cand[a];
            double s = 0;
            for (int b = 0; b < nc; b++) {
                const float *y = V + 3 * (size_t)cand[b];
                double d[3] = {x[0] - y[0], x[1] - y[1], x[2] - y[2]};
                s += sqrt(dot3(d, d));
            }
            if (s < best) {
                best = s;
                bv = cand[a];
            }
        }
        r->markers[i].vertex = bv;
    }
    *out = r;
    rigs[ref] = NULL;
    if (info)
        *info = infos[ref];
    if (nused)
        *nused = n;
done:
    if (rigs)
        for (int k = 0; k < nframes; k++)
            mdl_rig_destroy(rigs[k]);
    free(rigs);
    free(infos);
    free(cand);
    return e;
}
