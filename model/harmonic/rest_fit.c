/* rest_fit.c - posing the template's rest skeleton to the target's rest pose, de Aguiar et al. 2007
 * Sec. 4.1 ("both reference poses are roughly aligned a priori": the paper's user does it by hand
 * in 3ds Max) and Sec. 5 (the template is the mocap skeleton).
 *
 * A mocap rest pose is not the target's: the CMU BVH rest has the legs spread ~20 deg and the arms
 * hanging, an SMPL scan stands in a T-pose. Every bone's rotation is measured from its rest
 * direction, so the rest directions must be the target's limbs', or a vertical mocap leg leaves
 * the target's leg at the template's rest angle and the arms keep a 90 deg offset.
 *
 * Per bone, parents first (a bone's start marker is final once no unfitted bone ends at it), from
 * its start a and length L (the scaled template's):
 *   - a candidate direction d: at FIT_SAMPLES points q along the bone (0.3 .. 0.9 of L) the plane
 *     through q normal to d cuts the target into closed loops (triangles crossing the plane,
 *     joined across crossing edges); the loop whose centre c is nearest q is the limb the bone
 *     passes through there. Cost: the mean of |c - q| / r (r the loop's mean radius: 0 on a
 *     limb's axis, 1 at its surface) + FIT_SIZE r / L (a limb, not the torso it joins), plus
 *     FIT_ANGLE x the angle to the template's direction; a point outside its loop (the bone leaves
 *     the body) rules d out;
 *   - the best of the template's own direction and FIT_DIRS directions within FIT_CONE of it (a
 *     Fibonacci sphere), then of FIT_FINE within FIT_STEP of that;
 *   - a chain's first bone (its start is no bone's end and no pelvis marker: a shoulder) may first
 *     shift its start onto the limb, by the offset of its first point to its loop's centre (at most
 *     FIT_SHIFT x L: a CMU shoulder sits ~10 cm above a T-posed arm);
 *   - the bone's end and every marker below it turn about a by the shortest arc from the old
 *     direction to the new: the markers reached through bones from its end, and the twist markers
 *     of those bones that are no bone's joint (a thumb twisting a forearm goes with the hand; the
 *     other hip twisting a thigh stays); then the end moves onto the centre of the section through
 *     it, if it lies inside (a knee on the front of the knee would start the shin off its axis).
 * The root's own bones (from the rig's root marker: the pelvis) keep the template's directions: a
 * pelvis is no limb, its section is the whole hip. A bone keeps its direction when no candidate
 * meets a loop, and then reports it in `kept`. A section visits only the triangles of the grid
 * cells its plane passes (a uniform grid over the centroids). Set-up only: allocates. */
#include "harmonic/harmonic_internal.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define FIT_DIRS 400       /* directions on the whole sphere (~10 deg apart; 160 missed a thigh) */
#define FIT_CONE 100.0     /* deg from the template's direction: an arm hanging vs a T-pose is 90 */
#define FIT_ANGLE 0.1      /* cost per radian away from the template's direction */
#define FIT_SAMPLES 4      /* sections along the bone, at 0.3 .. 0.9 of its length */
#define FIT_FINE 60        /* then directions within FIT_STEP deg of the best */
#define FIT_STEP 10.0
#define FIT_SIZE 1.0       /* cost per loop radius / bone length: a limb, not the torso it joins */
#define FIT_SHIFT 0.5      /* a chain's start moves onto its limb by at most this x its length */

typedef struct fitter {
    const float *V;
    const uint32_t *F;
    int nv, nf;
    int *adj;      /* nf x 3: the triangle across edge k (F[k], F[k+1]), or -1 */
    int *cand;     /* the triangles a section crosses (found in the cells it passes) */
    int ncand;
    /* a uniform grid of cell size gh over the triangles' centroids (CSR: cell_off, cell_tri) */
    int gdim[3], ncell;
    double gorg[3], gh, trad; /* trad: the farthest corner from its triangle's centroid */
    int *cell_off, *cell_tri;
    int *bcell, nbcell; /* the cells near the bone being fitted */
    uint8_t *inball;    /* nf: the triangle is near the bone being fitted */
    double *s;     /* nv: signed distance to the plane */
    int *par;      /* nf: union-find over crossing triangles */
    double *acc;   /* nf x 4: per loop root, length-weighted sum of segment midpoints, and length */
    double *mid, *len; /* nf x 3, nf: each crossing triangle's segment midpoint and length */
} fitter;

static int uf_find(int *par, int x)
{
    while (par[x] != x)
        x = par[x] = par[par[x]];
    return x;
}

/* the edge-adjacency of the triangles: sort the 3 nf half-edges by their vertex pair */
typedef struct half {
    uint32_t lo, hi;
    int t, k;
} half;

static int half_cmp(const void *a, const void *b)
{
    const half *x = a, *y = b;
    if (x->lo != y->lo)
        return x->lo < y->lo ? -1 : 1;
    return (x->hi > y->hi) - (x->hi < y->hi);
}

static int build_adjacency(fitter *f, char *err)
{
    half *h = mdl__calloc(3 * (size_t)f->nf, sizeof *h);
    if (!h)
        return mdl__err(err, -ENOMEM, "rest fit: out of memory");
    for (int t = 0; t < f->nf; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = f->F[3 * t + k], b = f->F[3 * t + (k + 1) % 3];
            h[3 * t + k] = (half){a < b ? a : b, a < b ? b : a, t, k};
            f->adj[3 * t + k] = -1;
        }
    qsort(h, 3 * (size_t)f->nf, sizeof *h, half_cmp);
    for (size_t i = 0; i + 1 < 3 * (size_t)f->nf; i++)
        if (h[i].lo == h[i + 1].lo && h[i].hi == h[i + 1].hi) {
            f->adj[3 * h[i].t + h[i].k] = h[i + 1].t;
            f->adj[3 * h[i + 1].t + h[i + 1].k] = h[i].t;
        }
    free(h);
    return 0;
}

/* the grid: FIT_GRID cells along the longest side of the centroids' box at FIT_GRID_NF triangles,
 * growing as nf^(1/4) (a section's cost: the cells near the bone, ~ cells, plus the triangles in
 * its slab, ~ nf / cells^(1/3); both balanced there) */
#define FIT_GRID 48
#define FIT_GRID_NF 13776.0
static int build_grid(fitter *f, char *err)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double *C = mdl__calloc(3 * (size_t)f->nf, sizeof *C);
    int *cell = mdl__calloc((size_t)f->nf, sizeof *cell);
    if (!C || !cell) {
        free(C), free(cell);
        return mdl__err(err, -ENOMEM, "rest fit: out of memory");
    }
    f->trad = 0;
    for (int t = 0; t < f->nf; t++) {
        for (int j = 0; j < 3; j++) {
            C[3 * t + j] = ((double)f->V[3 * f->F[3 * t] + j] + f->V[3 * f->F[3 * t + 1] + j] +
                            f->V[3 * f->F[3 * t + 2] + j]) / 3;
            lo[j] = fmin(lo[j], C[3 * t + j]);
            hi[j] = fmax(hi[j], C[3 * t + j]);
        }
        for (int k = 0; k < 3; k++) {
            const float *p = f->V + 3 * f->F[3 * t + k];
            double dd = sqrt((p[0] - C[3 * t]) * (p[0] - C[3 * t]) + (p[1] - C[3 * t + 1]) * (p[1] - C[3 * t + 1]) +
                             (p[2] - C[3 * t + 2]) * (p[2] - C[3 * t + 2]));
            f->trad = fmax(f->trad, dd);
        }
    }
    double ext = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    f->gh = ext > 0 ? ext / (FIT_GRID * pow(fmax(1.0, f->nf / FIT_GRID_NF), 1.0 / 3)) : 1;
    f->ncell = 1;
    for (int j = 0; j < 3; j++) {
        f->gorg[j] = lo[j];
        f->gdim[j] = (int)((hi[j] - lo[j]) / f->gh) + 1;
        f->ncell *= f->gdim[j];
    }
    f->cell_off = mdl__calloc((size_t)f->ncell + 1, sizeof *f->cell_off);
    f->cell_tri = mdl__calloc((size_t)f->nf, sizeof *f->cell_tri);
    f->bcell = mdl__calloc((size_t)f->ncell, sizeof *f->bcell);
    if (!f->cell_off || !f->cell_tri || !f->bcell) {
        free(C), free(cell);
        return mdl__err(err, -ENOMEM, "rest fit: out of memory");
    }
    for (int t = 0; t < f->nf; t++) {
        int ix[3];
        for (int j = 0; j < 3; j++) {
            ix[j] = (int)((C[3 * t + j] - lo[j]) / f->gh);
            ix[j] = ix[j] < 0 ? 0 : ix[j] >= f->gdim[j] ? f->gdim[j] - 1 : ix[j];
        }
        cell[t] = ix[0] + f->gdim[0] * (ix[1] + f->gdim[1] * ix[2]);
        f->cell_off[cell[t] + 1]++;
    }
    for (int i = 0; i < f->ncell; i++)
        f->cell_off[i + 1] += f->cell_off[i];
    for (int t = 0; t < f->nf; t++)
        f->cell_tri[f->cell_off[cell[t]]++] = t;
    for (int i = f->ncell; i > 0; i--)
        f->cell_off[i] = f->cell_off[i - 1];
    f->cell_off[0] = 0;
    free(C), free(cell);
    return 0;
}

/* The section by the plane through q normal to d among f->cand: the centroid of the loop whose
 * centroid is nearest q, in c, and the loop's mean distance from it (its radius) in *r. Returns
 * the distance |q - c|, or INFINITY without any loop. */
static double section(fitter *f, const double *q, const double *d, double c[3], double *r)
{
    /* the triangles of the cells the plane passes (a cell's centre within half its diagonal and
     * a triangle's reach of the plane) */
    f->ncand = 0;
    double reach = 0.8660254037844386 * f->gh + f->trad;
    for (int i = 0; i < f->nbcell; i++) {
        int cl = f->bcell[i], x = cl % f->gdim[0], y = (cl / f->gdim[0]) % f->gdim[1],
            z = cl / (f->gdim[0] * f->gdim[1]);
        double cc[3] = {f->gorg[0] + (x + 0.5) * f->gh, f->gorg[1] + (y + 0.5) * f->gh,
                        f->gorg[2] + (z + 0.5) * f->gh};
        if (fabs((cc[0] - q[0]) * d[0] + (cc[1] - q[1]) * d[1] + (cc[2] - q[2]) * d[2]) > reach)
            continue;
        for (int j = f->cell_off[cl]; j < f->cell_off[cl + 1]; j++) {
            int t = f->cell_tri[j];
            if (!f->inball[t])
                continue;
            const uint32_t *tri = f->F + 3 * t;
            int pos = 0;
            for (int k = 0; k < 3; k++) {
                const float *p = f->V + 3 * tri[k];
                f->s[tri[k]] = ((double)p[0] - q[0]) * d[0] + ((double)p[1] - q[1]) * d[1] +
                               ((double)p[2] - q[2]) * d[2];
                pos += f->s[tri[k]] >= 0;
            }
            if (pos == 0 || pos == 3)
                continue;
            /* a crossing triangle: par[t] = t (every other stays -2) */
            f->cand[f->ncand++] = t;
            f->par[t] = t;
            memset(f->acc + 4 * (size_t)t, 0, 4 * sizeof *f->acc);
        }
    }
    for (int i = 0; i < f->ncand; i++) {
        int t = f->cand[i];
        if (f->par[t] < 0)
            continue;
        for (int k = 0; k < 3; k++) {
            int u = f->adj[3 * t + k];
            uint32_t a = f->F[3 * t + k], b = f->F[3 * t + (k + 1) % 3];
            /* u must cross too: par >= 0 was set this call, every other triangle's is -2 */
            if (u < 0 || f->par[u] < 0 || (f->s[a] >= 0) == (f->s[b] >= 0))
                continue;
            int ra = uf_find(f->par, t), rb = uf_find(f->par, u);
            if (ra != rb)
                f->par[rb] = ra;
        }
    }
    for (int i = 0; i < f->ncand; i++) {
        int t = f->cand[i];
        if (f->par[t] < 0)
            continue;
        double pt[2][3];
        int n = 0;
        for (int k = 0; k < 3 && n < 2; k++) {
            uint32_t a = f->F[3 * t + k], b = f->F[3 * t + (k + 1) % 3];
            if ((f->s[a] >= 0) == (f->s[b] >= 0))
                continue;
            double w = f->s[a] / (f->s[a] - f->s[b]);
            for (int j = 0; j < 3; j++)
                pt[n][j] = (1 - w) * f->V[3 * a + j] + w * f->V[3 * b + j];
            n++;
        }
        if (n < 2)
            continue;
        double l = sqrt((pt[0][0] - pt[1][0]) * (pt[0][0] - pt[1][0]) +
                        (pt[0][1] - pt[1][1]) * (pt[0][1] - pt[1][1]) +
                        (pt[0][2] - pt[1][2]) * (pt[0][2] - pt[1][2]));
        double *acc = f->acc + 4 * (size_t)uf_find(f->par, t);
        for (int j = 0; j < 3; j++)
            acc[j] += l * 0.5 * (pt[0][j] + pt[1][j]);
        acc[3] += l;
        for (int j = 0; j < 3; j++)
            f->mid[3 * (size_t)t + j] = 0.5 * (pt[0][j] + pt[1][j]);
        f->len[t] = l;
    }
    double best = INFINITY;
    int bestroot = -1;
    for (int i = 0; i < f->ncand; i++) {
        int t = f->cand[i];
        if (f->par[t] != t || !(f->acc[4 * (size_t)t + 3] > 0))
            continue;
        const double *acc = f->acc + 4 * (size_t)t;
        double m[3] = {acc[0] / acc[3], acc[1] / acc[3], acc[2] / acc[3]};
        double dd = sqrt((m[0] - q[0]) * (m[0] - q[0]) + (m[1] - q[1]) * (m[1] - q[1]) +
                         (m[2] - q[2]) * (m[2] - q[2]));
        if (dd < best) {
            best = dd;
            memcpy(c, m, sizeof m);
            bestroot = t;
        }
    }
    *r = 0;
    if (bestroot >= 0) {
        double w = 0;
        for (int i = 0; i < f->ncand; i++) {
            int t = f->cand[i];
            if (f->par[t] < 0 || f->len[t] <= 0 || uf_find(f->par, t) != bestroot)
                continue;
            const double *p = f->mid + 3 * (size_t)t;
            *r += f->len[t] * sqrt((p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]) +
                                   (p[2] - c[2]) * (p[2] - c[2]));
            w += f->len[t];
        }
        *r = w > 0 ? *r / w : 0;
    }
    for (int i = 0; i < f->ncand; i++)
        f->par[f->cand[i]] = -2, f->len[f->cand[i]] = 0;
    return best;
}

/* The cost of a bone from a along unit d (length L), d0 its template direction: at FIT_SAMPLES
 * points along it (0.3 .. 0.9 of L), how far the section's loop centre is from the point, over
 * the loop's radius (a bone on a limb's axis: 0; at its surface: 1) plus FIT_SIZE x the radius
 * over L (a bone crossing into the torso meets wide loops), plus FIT_ANGLE x the angle to d0. With `shift` (a chain's first bone, whose start may lie beside its limb: a mocap shoulder
 * above a T-posed arm), the start first moves by the offset of the first point to its loop's
 * centre (at most FIT_SHIFT x L), returned in off. INFINITY when a point lies outside its loop (the bone leaves the
 * body) or d is off the cone. */
static double dir_cost(fitter *f, const float *a, double L, const double *d, const double *d0,
                       double cone, int shift, double off[3])
{
    double cs = d[0] * d0[0] + d[1] * d0[1] + d[2] * d0[2], cost = 0, c[3], r;
    off[0] = off[1] = off[2] = 0;
    if (cs < cone)
        return INFINITY;
    if (shift) {
        double q[3] = {a[0] + 0.3 * L * d[0], a[1] + 0.3 * L * d[1], a[2] + 0.3 * L * d[2]};
        if (!isfinite(section(f, q, d, c, &r)))
            return INFINITY;
        for (int j = 0; j < 3; j++)
            off[j] = c[j] - q[j];
        if (off[0] * off[0] + off[1] * off[1] + off[2] * off[2] > FIT_SHIFT * FIT_SHIFT * L * L)
            return INFINITY;
    }
    for (int k = 0; k < FIT_SAMPLES; k++) {
        double t = 0.3 + 0.6 * k / (FIT_SAMPLES - 1);
        double q[3] = {a[0] + off[0] + t * L * d[0], a[1] + off[1] + t * L * d[1],
                       a[2] + off[2] + t * L * d[2]};
        double dd = section(f, q, d, c, &r);
        if (!(dd < r))
            return INFINITY;
        cost += (dd / r + FIT_SIZE * r / L) / FIT_SAMPLES;
    }
    return cost + FIT_ANGLE * acos(fmin(1, cs));
}

/* two unit vectors normal to unit d and to each other */
static void frame_of(const double *d, double *e1, double *e2)
{
    double t[3] = {fabs(d[0]) < 0.9 ? 1 : 0, fabs(d[0]) < 0.9 ? 0 : 1, 0};
    e1[0] = d[1] * t[2] - d[2] * t[1], e1[1] = d[2] * t[0] - d[0] * t[2], e1[2] = d[0] * t[1] - d[1] * t[0];
    double l = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (int j = 0; j < 3; j++)
        e1[j] /= l;
    e2[0] = d[1] * e1[2] - d[2] * e1[1], e2[1] = d[2] * e1[0] - d[0] * e1[2], e2[2] = d[0] * e1[1] - d[1] * e1[0];
}

static void rotate_about(float *p, const float *a, const double R[9])
{
    double v[3] = {(double)p[0] - a[0], (double)p[1] - a[1], (double)p[2] - a[2]};
    for (int i = 0; i < 3; i++)
        p[i] = (float)(a[i] + R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2]);
}

/* the shortest-arc rotation taking unit u onto unit v (row-major, Rodrigues) */
static void arc(const double *u, const double *v, double R[9])
{
    double k[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    double s = sqrt(k[0] * k[0] + k[1] * k[1] + k[2] * k[2]), c = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(R, I, sizeof I);
    if (s < 1e-12)
        return; /* within the cone (<= FIT_CONE < 180) only the identity is this close */
    for (int j = 0; j < 3; j++)
        k[j] /= s;
    double K[9] = {0, -k[2], k[1], k[2], 0, -k[0], -k[1], k[0], 0}, K2[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            K2[3 * i + j] = K[3 * i] * K[j] + K[3 * i + 1] * K[3 + j] + K[3 * i + 2] * K[6 + j];
    for (int i = 0; i < 9; i++)
        R[i] += s * K[i] + (1 - c) * K2[i];
}

int mdl__rest_fit(struct mdl_harmonic *h, const float *V, const uint32_t *F, int nv, int nf,
                  int *kept, char *err)
{
    int nb = h->nbones, rc = 0;
    *kept = 0;
    fitter f = {.V = V, .F = F, .nv = nv, .nf = nf};
    f.adj = mdl__calloc(3 * (size_t)nf, sizeof *f.adj);
    f.cand = mdl__calloc((size_t)nf, sizeof *f.cand);
    f.s = mdl__calloc((size_t)nv, sizeof *f.s);
    f.par = mdl__calloc((size_t)nf, sizeof *f.par);
    f.acc = mdl__calloc(4 * (size_t)nf, sizeof *f.acc);
    f.mid = mdl__calloc(3 * (size_t)nf, sizeof *f.mid);
    f.len = mdl__calloc((size_t)nf, sizeof *f.len);
    f.inball = mdl__calloc((size_t)nf, 1);
    uint8_t *done = mdl__calloc((size_t)nb + 1, 1), *below = mdl__calloc((size_t)h->nmk + 1, 1);
    uint8_t *twist_only = mdl__calloc((size_t)h->nmk + 1, 1);
    uint8_t *chain_start = mdl__calloc((size_t)h->nmk + 1, 1);
    double *dirs = mdl__calloc(3 * FIT_DIRS, sizeof *dirs);
    /* each marker's accumulated turn (for bone_fit) and the unfitted rest pose */
    double *M = mdl__calloc(9 * (size_t)h->nmk + 9, sizeof *M);
    float *orig = mdl__calloc(3 * (size_t)h->nmk + 3, sizeof *orig);
    if (!M || !orig) {
        rc = mdl__err(err, -ENOMEM, "rest fit: out of memory");
        goto out;
    }
    memcpy(orig, h->mk_rest, 3 * (size_t)h->nmk * sizeof *orig);
    for (int i = 0; i < h->nmk; i++)
        M[9 * i] = M[9 * i + 4] = M[9 * i + 8] = 1;
    if (!f.adj || !f.cand || !f.s || !f.par || !f.acc || !f.mid || !f.len || !f.inball || !done || !below || !twist_only || !chain_start || !dirs) {
        rc = mdl__err(err, -ENOMEM, "rest fit: out of memory");
        goto out;
    }
    if ((rc = build_adjacency(&f, err)) || (rc = build_grid(&f, err)))
        goto out;
    for (int o = 0; o < nb; o++)
        if (h->bone_c[o] >= 0)
            twist_only[h->bone_c[o]] = 1;
    for (int o = 0; o < nb; o++) {
        twist_only[h->bone_a[o]] = twist_only[h->bone_b[o]] = 0;
        chain_start[h->bone_a[o]] = 1;
    }
    for (int o = 0; o < nb; o++) {
        chain_start[h->bone_b[o]] = 0;
        /* the root's bones (the pelvis) keep their markers: a hip is where the pelvis puts it */
        if (h->bone_a[o] == h->root_marker && h->bone_c[o] >= 0)
            chain_start[h->bone_c[o]] = 0;
    }
    chain_start[h->root_marker] = 0;
    for (int t = 0; t < nf; t++)
        f.par[t] = -2;
    for (int i = 0; i < FIT_DIRS; i++) {
        double y = 1 - 2 * (i + 0.5) / FIT_DIRS, r = sqrt(1 - y * y), ph = i * 2.399963229728653;
        dirs[3 * i] = r * cos(ph), dirs[3 * i + 1] = y, dirs[3 * i + 2] = r * sin(ph);
    }
    double cone = cos(FIT_CONE * M_PI / 180);
    for (int pass = 0; pass < nb; pass++) {
        /* the next bone: unfitted, and no unfitted bone ends at its start */
        int g = -1;
        for (int b = 0; b < nb && g < 0; b++) {
            if (done[b])
                continue;
            int ready = 1;
            for (int o = 0; o < nb; o++)
                ready = ready && (done[o] || o == b || h->bone_b[o] != h->bone_a[b]);
            if (ready)
                g = b;
        }
        if (g < 0)
            g = pass; /* a cycle in the rig's bones: take them in order */
        while (g < nb && done[g])
            g++;
        if (g >= nb)
            break;
        done[g] = 1;
        if (h->bone_a[g] == h->root_marker)
            continue;
        float *pa = h->mk_rest + 3 * h->bone_a[g], *pb = h->mk_rest + 3 * h->bone_b[g];
        double d0[3] = {(double)pb[0] - pa[0], (double)pb[1] - pa[1], (double)pb[2] - pa[2]};
        double L = sqrt(d0[0] * d0[0] + d0[1] * d0[1] + d0[2] * d0[2]);
        if (!(L > 0))
            continue;
        for (int j = 0; j < 3; j++)
            d0[j] /= L;
        /* the triangles that any candidate's section near q can reach: within 1.6 L of a */
        double r2 = 2.56 * L * L, off0[3];
        memset(f.inball, 0, (size_t)nf);
        f.nbcell = 0;
        for (int cl = 0; cl < f.ncell; cl++) {
            int any = 0;
            for (int j = f.cell_off[cl]; j < f.cell_off[cl + 1]; j++) {
                int t = f.cell_tri[j];
                for (int k = 0; k < 3 && !f.inball[t]; k++) {
                    const float *p = V + 3 * F[3 * t + k];
                    double dd = ((double)p[0] - pa[0]) * (p[0] - pa[0]) +
                                ((double)p[1] - pa[1]) * (p[1] - pa[1]) + ((double)p[2] - pa[2]) * (p[2] - pa[2]);
                    f.inball[t] = dd <= r2;
                }
                any |= f.inball[t];
            }
            if (any)
                f.bcell[f.nbcell++] = cl;
        }
        /* the template's own direction first: an aligned template stays as it is unless a
         * direction is better by more than the sampling's grain */
        double best = dir_cost(&f, pa, L, d0, d0, cone, chain_start[h->bone_a[g]], off0);
        double bd[3] = {d0[0], d0[1], d0[2]}, boff[3] = {off0[0], off0[1], off0[2]}, off[3];
        for (int i = 0; i < FIT_DIRS; i++) {
            double cost = dir_cost(&f, pa, L, dirs + 3 * i, d0, cone, chain_start[h->bone_a[g]], off);
            if (cost < best) {
                best = cost;
                memcpy(bd, dirs + 3 * i, sizeof bd);
                memcpy(boff, off, sizeof boff);
            }
        }
        if (!isfinite(best)) {
            (*kept)++;
            continue;
        }
        /* finer, around the best: a spiral of FIT_FINE directions within FIT_STEP of it */
        double e1[3], e2[3], c0[3] = {bd[0], bd[1], bd[2]};
        frame_of(c0, e1, e2);
        for (int i = 0; i < FIT_FINE; i++) {
            double th = FIT_STEP * M_PI / 180 * sqrt((i + 0.5) / FIT_FINE), ph = i * 2.399963229728653;
            double d[3];
            for (int j = 0; j < 3; j++)
                d[j] = cos(th) * c0[j] + sin(th) * (cos(ph) * e1[j] + sin(ph) * e2[j]);
            double cost = dir_cost(&f, pa, L, d, d0, cone, chain_start[h->bone_a[g]], off);
            if (cost < best) {
                best = cost;
                memcpy(bd, d, sizeof bd);
                memcpy(boff, off, sizeof boff);
            }
        }
        double R[9];
        arc(d0, bd, R);
        /* the markers below the bone's end */
        memset(below, 0, (size_t)h->nmk);
        below[h->bone_b[g]] = 1;
        for (int grow = 1; grow;) {
            grow = 0;
            for (int o = 0; o < nb; o++) {
                int c = h->bone_c[o];
                if (below[h->bone_a[o]] && !below[h->bone_b[o]] && h->bone_b[o] != h->bone_a[g])
                    below[h->bone_b[o]] = 1, grow = 1;
                if (c >= 0 && below[h->bone_b[o]] && !below[c] && twist_only[c])
                    below[c] = 1, grow = 1;
            }
        }
        float a[3] = {pa[0], pa[1], pa[2]};
        for (int i = 0; i < h->nmk; i++)
            if (below[i]) {
                rotate_about(h->mk_rest + 3 * i, a, R);
                double T[9];
                for (int r = 0; r < 3; r++)
                    for (int c = 0; c < 3; c++)
                        T[3 * r + c] = R[3 * r] * M[9 * i + c] + R[3 * r + 1] * M[9 * i + 3 + c] +
                                       R[3 * r + 2] * M[9 * i + 6 + c];
                memcpy(M + 9 * i, T, sizeof T);
            }
        /* a chain's first bone (its start is no bone's end: a shoulder) moves onto the limb's axis
         * with everything below it; a joint between two bones stays where its parent put it */
        if (chain_start[h->bone_a[g]])
            for (int i = 0; i < h->nmk; i++)
                if (below[i] || i == h->bone_a[g])
                    for (int j = 0; j < 3; j++)
                        h->mk_rest[3 * i + j] += (float)boff[j];
        /* the end onto the axis of the limb's section through it, if it lies inside that section
         * (a knee placed on the front of the knee would start the shin off its axis) */
        double qb[3] = {pb[0], pb[1], pb[2]}, c[3], r;
        double dc = section(&f, qb, bd, c, &r);
        if (dc < r) {
            float sh[3] = {(float)(c[0] - qb[0]), (float)(c[1] - qb[1]), (float)(c[2] - qb[2])};
            for (int i = 0; i < h->nmk; i++)
                if (below[i])
                    for (int j = 0; j < 3; j++)
                        h->mk_rest[3 * i + j] += sh[j];
        }
    }
    /* C_g (bone_fit): the turns applied to the bone's end, then the arc onto its fitted direction */
    for (int g = 0; g < nb && h->bone_fit; g++) {
        const float *a0 = orig + 3 * h->bone_a[g], *b0 = orig + 3 * h->bone_b[g];
        const float *a1 = h->mk_rest + 3 * h->bone_a[g], *b1 = h->mk_rest + 3 * h->bone_b[g];
        const double *Mb = M + 9 * h->bone_b[g];
        double d0[3], d1[3], v[3], R[9], C[9];
        for (int j = 0; j < 3; j++)
            d0[j] = (double)b0[j] - a0[j], d1[j] = (double)b1[j] - a1[j];
        for (int j = 0; j < 3; j++)
            v[j] = Mb[3 * j] * d0[0] + Mb[3 * j + 1] * d0[1] + Mb[3 * j + 2] * d0[2];
        double lv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]),
               l1 = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
        memcpy(C, Mb, sizeof C);
        if (lv > 0 && l1 > 0) {
            for (int j = 0; j < 3; j++)
                v[j] /= lv, d1[j] /= l1;
            arc(v, d1, R);
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++)
                    C[3 * r + c] = R[3 * r] * Mb[c] + R[3 * r + 1] * Mb[3 + c] + R[3 * r + 2] * Mb[6 + c];
        }
        mdl__mat_to_quat(C, h->bone_fit + 4 * g);
    }
out:
    free(M), free(orig);
    free(f.adj), free(f.cand), free(f.s), free(f.par), free(f.acc), free(f.mid), free(f.len);
    free(f.inball), free(f.cell_off), free(f.cell_tri), free(f.bcell);
    free(done), free(below), free(twist_only), free(chain_start), free(dirs);
    return rc;
}
