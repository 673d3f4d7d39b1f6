/* correspondences.c - choosing the correspondence triangles, de Aguiar et al. 2007 Sec. 4.2.
 *
 * The paper's user marks 140-220 triangles, half of them added automatically in the cross-section of
 * cylindrical parts. Here:
 *   - auto:K (a model measured on its own sequence): K triangles spread by farthest-point sampling
 *     of the rest centroids, every connected part first getting one; each is its own group;
 *   - bones (a template skeleton, rest poses aligned beforehand, Sec. 4.1 "roughly aligned"): each
 *     target triangle belongs to the nearest bone segment; per bone, up to `per_bone` of its
 *     triangles away from the joints (segment parameter 0.2..0.8) are picked by farthest-point
 *     sampling, which spreads them around the limb's cross-section and along it. A user-given
 *     triangle of a bone is completed by its cross-section: the bone's triangles in the slab through
 *     its centroid normal to the bone (half-thickness: the mean edge length).
 * Also the geodesically nearest correspondence of every triangle (the eval baseline). Set-up only:
 * allocates. */
#include "harmonic/harmonic_internal.h"
#include "core/meshgraph.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef CORR_T0
#define CORR_T0 0.2 /* a bone's automatic triangles lie within CORR_T0 .. 1 - CORR_T0 of it */
#endif
#ifndef AUTO_PATCH
#define AUTO_PATCH 0.45
#endif

static void centroid(const float *V, const uint32_t *F, int t, double c[3])
{
    for (int k = 0; k < 3; k++)
        c[k] = ((double)V[3 * F[3 * t] + k] + V[3 * F[3 * t + 1] + k] + V[3 * F[3 * t + 2] + k]) / 3;
}

static double d2(const double *a, const double *b)
{
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

static int find(int *par, int x)
{
    while (par[x] != x)
        x = par[x] = par[par[x]];
    return x;
}

/* farthest-point sampling among cand (n triangles) starting from the `nseed` seeds already in
 * out[0..nseed); appends until `want` in total. mind: scratch of n doubles. Returns the count. */
static int fps(const double *C, const int *cand, int n, int *out, int nseed, int want, double *mind)
{
    for (int i = 0; i < n; i++) {
        mind[i] = INFINITY;
        for (int s = 0; s < nseed; s++) {
            double d = d2(C + 3 * cand[i], C + 3 * out[s]);
            mind[i] = d < mind[i] ? d : mind[i];
        }
    }
    int k = nseed;
    while (k < want) {
        int b = -1;
        for (int i = 0; i < n; i++)
            if (mind[i] > 0 && (b < 0 || mind[i] > mind[b]))
                b = i;
        if (b < 0)
            break;
        out[k++] = cand[b];
        for (int i = 0; i < n; i++) {
            double d = d2(C + 3 * cand[i], C + 3 * cand[b]);
            mind[i] = d < mind[i] ? d : mind[i];
        }
    }
    return k;
}

#ifndef RING_AXIS
#define RING_AXIS 2.0 /* x the mean seed spacing: the neighbourhood whose principal axis a ring is cut across */
#endif
#ifndef RING_R
#define RING_R 0.5    /* x the mean seed spacing: how far a ring reaches from its seed */
#endif

/* The rings of rings:K (Sec. 4.2's cross-sections, found automatically): for each seed, the
 * principal axis of the triangle centroids within RING_AXIS x spacing of it (the limb's direction
 * on a limb), then the triangles reached from the seed through vertex-sharing neighbours whose
 * centroids lie in the slab through the seed normal to that axis (half-thickness: the mean edge
 * length) and within RING_R x spacing. lab[t]: the seed of triangle t, or -1; a triangle belongs
 * to the first ring that reaches it. */
static int rings_grow(const double *C, const float *rest, const uint32_t *F, int nf, int nv,
                      const int *seed, int n, double spacing, int *lab, char *err)
{
    int *vo = mdl__calloc((size_t)nv + 1, sizeof *vo), *vt = mdl__calloc(3 * (size_t)nf, sizeof *vt);
    int *queue = mdl__calloc((size_t)nf, sizeof *queue);
    if (!vo || !vt || !queue) {
        free(vo), free(vt), free(queue);
        return mdl__err(err, -ENOMEM, "rings: out of memory");
    }
    double elen = 0;
    for (int t = 0; t < nf; t++)
        for (int k = 0; k < 3; k++) {
            vo[F[3 * t + k] + 1]++;
            const float *a = rest + 3 * F[3 * t + k], *b = rest + 3 * F[3 * t + (k + 1) % 3];
            elen += sqrt(((double)a[0] - b[0]) * (a[0] - b[0]) + ((double)a[1] - b[1]) * (a[1] - b[1]) +
                         ((double)a[2] - b[2]) * (a[2] - b[2])) / (3.0 * nf);
        }
    for (int v = 0; v < nv; v++)
        vo[v + 1] += vo[v];
    for (int t = 0; t < nf; t++)
        for (int k = 0; k < 3; k++)
            vt[vo[F[3 * t + k]]++] = t;
    for (int v = nv; v > 0; v--)
        vo[v] = vo[v - 1];
    vo[0] = 0;
    for (int t = 0; t < nf; t++)
        lab[t] = -1;
    for (int i = 0; i < n; i++)
        lab[seed[i]] = i;
    double ra2 = RING_AXIS * spacing * RING_AXIS * spacing, rr2 = RING_R * spacing * RING_R * spacing;
    for (int i = 0; i < n; i++) {
        const double *c0 = C + 3 * seed[i];
        double m[3] = {0}, S[9] = {0}, w = 0;
        for (int t = 0; t < nf; t++)
            if (d2(C + 3 * t, c0) <= ra2) {
                for (int a = 0; a < 3; a++)
                    m[a] += C[3 * t + a];
                w++;
            }
        for (int a = 0; a < 3; a++)
            m[a] /= w;
        for (int t = 0; t < nf; t++)
            if (d2(C + 3 * t, c0) <= ra2)
                for (int a = 0; a < 3; a++)
                    for (int b = 0; b < 3; b++)
                        S[3 * a + b] += (C[3 * t + a] - m[a]) * (C[3 * t + b] - m[b]);
        /* the principal axis by power iteration */
        double ax[3] = {1, 1, 1};
        for (int it = 0; it < 60; it++) {
            double y[3];
            for (int a = 0; a < 3; a++)
                y[a] = S[3 * a] * ax[0] + S[3 * a + 1] * ax[1] + S[3 * a + 2] * ax[2];
            double l = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
            if (!(l > 0))
                break;
            for (int a = 0; a < 3; a++)
                ax[a] = y[a] / l;
        }
        int qh = 0, qt = 0;
        queue[qt++] = seed[i];
        while (qh < qt) {
            int t = queue[qh++];
            for (int k = 0; k < 3; k++) {
                int v = (int)F[3 * t + k];
                for (int j = vo[v]; j < vo[v + 1]; j++) {
                    int u = vt[j];
                    if (lab[u] >= 0)
                        continue;
                    const double *c = C + 3 * u;
                    double sd = (c[0] - c0[0]) * ax[0] + (c[1] - c0[1]) * ax[1] + (c[2] - c0[2]) * ax[2];
                    if (fabs(sd) < elen && d2(c, c0) <= rr2) {
                        lab[u] = i;
                        queue[qt++] = u;
                    }
                }
            }
        }
    }
    free(vo), free(vt), free(queue);
    return 0;
}

int mdl__corr_auto_k(struct mdl_harmonic *h, const float *rest, const uint32_t *F, int nf, int nv,
                     int k, int rings, char *err)
{
    if (k < 1 || k > nf)
        return mdl__err(err, -EINVAL, "auto:%d: K must be within 1..%d (the triangles)", k, nf);
    double *C = mdl__calloc(3 * (size_t)nf, sizeof *C), *mind = mdl__calloc((size_t)nf, sizeof *mind);
    int *par = mdl__calloc((size_t)nv, sizeof *par), *cand = mdl__calloc((size_t)nf, sizeof *cand);
    int *out = mdl__calloc((size_t)nf + 1, sizeof *out), *seen = mdl__calloc((size_t)nv, sizeof *seen);
    int rc = 0;
    if (!C || !mind || !par || !cand || !out || !seen) {
        rc = mdl__err(err, -ENOMEM, "auto:%d: out of memory", k);
        goto done;
    }
    for (int v = 0; v < nv; v++)
        par[v] = v;
    for (int t = 0; t < nf; t++) {
        centroid(rest, F, t, C + 3 * t);
        cand[t] = t;
        int a = find(par, (int)F[3 * t]);
        for (int j = 1; j < 3; j++) {
            int b = find(par, (int)F[3 * t + j]);
            if (a != b)
                par[b] = a;
        }
    }
    /* one seed per connected part: its first triangle */
    int ns = 0;
    for (int t = 0; t < nf; t++) {
        int r = find(par, (int)F[3 * t]);
        if (!seen[r]) {
            seen[r] = 1;
            out[ns++] = t;
        }
    }
    int n = fps(C, cand, nf, out, ns, k > ns ? k : ns, mind);
    /* each seed's patch: the triangles nearer to it than to any other seed and within
     * AUTO_PATCH x the mean distance between neighbouring seeds (the paper's correspondences are
     * patches and cross-section rings, not single triangles: a lone triangle holds a harmonic field
     * only in its immediate neighbourhood) */
    double spacing = 0;
    for (int i = 0; i < n; i++) {
        double b = INFINITY;
        for (int j = 0; j < n; j++)
            if (j != i && d2(C + 3 * out[i], C + 3 * out[j]) < b)
                b = d2(C + 3 * out[i], C + 3 * out[j]);
        spacing += n > 1 ? sqrt(b) / n : 0;
    }
    double rad2 = AUTO_PATCH * spacing * AUTO_PATCH * spacing;
    int nc = 0;
    if (rings) {
        rc = rings_grow(C, rest, F, nf, nv, out, n, spacing, cand, err);
        if (rc)
            goto done;
        for (int t = 0; t < nf; t++)
            nc += cand[t] >= 0;
    }
    for (int t = 0; t < nf && !rings; t++) {
        int b = 0;
        double bd = INFINITY;
        for (int i = 0; i < n; i++) {
            double d = d2(C + 3 * t, C + 3 * out[i]);
            if (d < bd) {
                bd = d;
                b = i;
            }
        }
        cand[t] = bd <= rad2 || out[b] == t ? b : -1;
        nc += cand[t] >= 0;
    }
    free(h->corr_tri);
    free(h->corr_group);
    h->corr_tri = mdl__calloc((size_t)nc, sizeof(int));
    h->corr_group = mdl__calloc((size_t)nc, sizeof(int));
    double *pos = mdl__calloc(3 * (size_t)n, sizeof *pos);
    if (!h->corr_tri || !h->corr_group || !pos) {
        free(pos);
        rc = mdl__err(err, -ENOMEM, "auto:%d: out of memory", k);
        goto done;
    }
    /* the seeds first (correspondence i < n is seed i), then the rest of the patches */
    for (int i = 0; i < n; i++) {
        h->corr_tri[i] = out[i];
        h->corr_group[i] = i;
        memcpy(pos + 3 * i, C + 3 * out[i], 3 * sizeof *pos);
    }
    int at = n;
    for (int t = 0; t < nf; t++)
        if (cand[t] >= 0 && out[cand[t]] != t) {
            h->corr_tri[at] = t;
            h->corr_group[at++] = cand[t];
        }
    h->ncorr = at;
    h->ngroups = n;
    h->auto_k = k;
    rc = mdl__candy_tree(h, pos, err);
    free(pos);
done:
    free(C);
    free(mind);
    free(par);
    free(cand);
    free(out);
    free(seen);
    return rc;
}

/* distance^2 from c to segment a-b, and the segment parameter */
static double seg_d2(const double *c, const float *a, const float *b, double *tp)
{
    double ab[3], ac[3], l2 = 0, t = 0;
    for (int k = 0; k < 3; k++) {
        ab[k] = (double)b[k] - a[k];
        ac[k] = c[k] - a[k];
        l2 += ab[k] * ab[k];
        t += ab[k] * ac[k];
    }
    t = l2 > 0 ? t / l2 : 0;
    double tc = t < 0 ? 0 : t > 1 ? 1 : t, d = 0;
    for (int k = 0; k < 3; k++)
        d += (ac[k] - tc * ab[k]) * (ac[k] - tc * ab[k]);
    *tp = t;
    return d;
}

int mdl__corr_bones(struct mdl_harmonic *h, const float *rest, const uint32_t *F, int nf,
                    int per_bone, const int *given_off, const int *given_idx, char *err)
{
    int nb = h->nbones, rc = 0;
    double *C = mdl__calloc(3 * (size_t)nf, sizeof *C), *tpar = mdl__calloc((size_t)nf, sizeof *tpar);
    double *mind = mdl__calloc((size_t)nf, sizeof *mind);
    int *near = mdl__calloc((size_t)nf, sizeof *near), *cand = mdl__calloc((size_t)nf, sizeof *cand);
    int *pick = mdl__calloc((size_t)nf + 1, sizeof *pick);
    int *ctri = mdl__calloc((size_t)nf + 1, sizeof *ctri), *cgrp = mdl__calloc((size_t)nf + 1, sizeof *cgrp);
    uint8_t *used = mdl__calloc((size_t)nf, 1);
    double *pos = mdl__calloc(3 * (size_t)nb + 3, sizeof *pos);
    if (!C || !tpar || !mind || !near || !cand || !pick || !ctri || !cgrp || !used || !pos) {
        rc = mdl__err(err, -ENOMEM, "harmonic correspondences: out of memory");
        goto done;
    }
    double elen = 0;
    for (int t = 0; t < nf; t++) {
        centroid(rest, F, t, C + 3 * t);
        const float *a = rest + 3 * F[3 * t], *b = rest + 3 * F[3 * t + 1];
        elen += sqrt(((double)a[0] - b[0]) * (a[0] - b[0]) + ((double)a[1] - b[1]) * (a[1] - b[1]) +
                     ((double)a[2] - b[2]) * (a[2] - b[2]));
        double best = INFINITY;
        near[t] = -1;
        for (int g = 0; g < nb; g++) {
            const float *pa = h->mk_rest + 3 * h->bone_a[g], *pb = h->mk_rest + 3 * h->bone_b[g];
            double tp, d = seg_d2(C + 3 * t, pa, pb, &tp);
            if (d < best) {
                best = d;
                near[t] = g;
                tpar[t] = tp;
            }
        }
    }
    elen = nf ? elen / nf : 0;
    int nc = 0;
    for (int g = 0; g < nb; g++) {
        const float *pa = h->mk_rest + 3 * h->bone_a[g], *pb = h->mk_rest + 3 * h->bone_b[g];
        for (int c = 0; c < 3; c++)
            pos[3 * g + c] = 0.5 * ((double)pa[c] + pb[c]);
        int np = 0;
        if (given_off && given_off[g + 1] > given_off[g]) {
            /* user triangles, each completed by its cross-section (Sec. 4.2) */
            double dir[3], l = 0;
            for (int c = 0; c < 3; c++) {
                dir[c] = (double)pb[c] - pa[c];
                l += dir[c] * dir[c];
            }
            l = sqrt(l);
            for (int j = given_off[g]; j < given_off[g + 1]; j++) {
                int t0 = given_idx[j];
                if (t0 < 0 || t0 >= nf) {
                    rc = mdl__err(err, -EINVAL, "correspondences: bone %d: triangle %d is not in "
                                  "0..%d", g, t0, nf - 1);
                    goto done;
                }
                for (int t = 0; t < nf; t++) {
                    if (used[t] || !(t == t0 || (near[t] == g && l > 0)))
                        continue;
                    double s = 0;
                    for (int c = 0; c < 3; c++)
                        s += (C[3 * t + c] - C[3 * t0 + c]) * dir[c] / l;
                    if (t == t0 || fabs(s) < elen) {
                        used[t] = 1;
                        ctri[nc] = t;
                        cgrp[nc++] = g;
                    }
                }
            }
            continue;
        }
        for (int t = 0; t < nf; t++)
            if (near[t] == g && tpar[t] >= CORR_T0 && tpar[t] <= 1 - CORR_T0 && !used[t])
                cand[np++] = t;
        if (np == 0 || per_bone < 1)
            continue;
        /* seed: the candidate nearest the middle of the bone */
        int s = 0;
        for (int i = 1; i < np; i++)
            if (fabs(tpar[cand[i]] - 0.5) < fabs(tpar[cand[s]] - 0.5))
                s = i;
        pick[0] = cand[s];
        int k = fps(C, cand, np, pick, 1, per_bone, mind);
        for (int i = 0; i < k; i++) {
            used[pick[i]] = 1;
            ctri[nc] = pick[i];
            cgrp[nc++] = g;
        }
    }
    if (nc == 0) {
        rc = mdl__err(err, -EINVAL, "harmonic correspondences: no target triangle lies along any "
                      "bone: are the template and the target aligned?");
        goto done;
    }
    free(h->corr_tri);
    free(h->corr_group);
    h->corr_tri = mdl__calloc((size_t)nc, sizeof(int));
    h->corr_group = mdl__calloc((size_t)nc, sizeof(int));
    if (!h->corr_tri || !h->corr_group) {
        rc = mdl__err(err, -ENOMEM, "harmonic correspondences: out of memory");
        goto done;
    }
    memcpy(h->corr_tri, ctri, (size_t)nc * sizeof(int));
    memcpy(h->corr_group, cgrp, (size_t)nc * sizeof(int));
    h->ncorr = nc;
    h->ngroups = nb;
    rc = mdl__candy_tree(h, pos, err);
done:
    free(C);
    free(tpar);
    free(mind);
    free(near);
    free(cand);
    free(pick);
    free(ctri);
    free(cgrp);
    free(used);
    free(pos);
    return rc;
}

/* ------------------------------------------------------------------ nearest correspondence */

typedef struct heap_item {
    double d;
    int v;
} heap_item;

static void heap_push(heap_item *h, int *n, double d, int v)
{
    int i = (*n)++;
    while (i > 0 && h[(i - 1) / 2].d > d) {
        h[i] = h[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    h[i].d = d;
    h[i].v = v;
}

static heap_item heap_pop(heap_item *h, int *n)
{
    heap_item top = h[0], last = h[--(*n)];
    int i = 0;
    for (;;) {
        int c = 2 * i + 1;
        if (c >= *n)
            break;
        if (c + 1 < *n && h[c + 1].d < h[c].d)
            c++;
        if (h[c].d >= last.d)
            break;
        h[i] = h[c];
        i = c;
    }
    h[i] = last;
    return top;
}

int mdl__corr_nearest(const struct mdl_harmonic *h, const float *rest, const uint32_t *F, int nf,
                      int nv, int *near, char *err)
{
    mdl_graph g;
    int rc = mdl__graph_init(&g, nv, F, nf, err);
    if (rc)
        return rc;
    double *dist = mdl__calloc((size_t)nv, sizeof *dist);
    int *lab = mdl__calloc((size_t)nv, sizeof *lab);
    size_t cap = (size_t)g.off[nv] + 3 * (size_t)h->ncorr + 1;
    heap_item *hp = mdl__calloc(cap, sizeof *hp);
    if (!dist || !lab || !hp) {
        rc = mdl__err(err, -ENOMEM, "nearest correspondence: out of memory");
        goto done;
    }
    for (int v = 0; v < nv; v++) {
        dist[v] = INFINITY;
        lab[v] = -1;
    }
    int n = 0;
    for (int i = 0; i < h->ncorr; i++)
        for (int k = 0; k < 3; k++) {
            int v = (int)F[3 * h->corr_tri[i] + k];
            if (dist[v] > 0) {
                dist[v] = 0;
                lab[v] = i;
                heap_push(hp, &n, 0, v);
            }
        }
    while (n > 0) {
        heap_item it = heap_pop(hp, &n);
        if (it.d > dist[it.v])
            continue;
        for (int j = g.off[it.v]; j < g.off[it.v + 1]; j++) {
            int u = g.nbr[j];
            const float *a = rest + 3 * it.v, *b = rest + 3 * u;
            double d = it.d + sqrt(((double)a[0] - b[0]) * (a[0] - b[0]) + ((double)a[1] - b[1]) * (a[1] - b[1]) +
                                   ((double)a[2] - b[2]) * (a[2] - b[2]));
            if (d < dist[u] && n < (int)cap) {
                dist[u] = d;
                lab[u] = lab[it.v];
                heap_push(hp, &n, d, u);
            }
        }
    }
    for (int t = 0; t < nf; t++) {
        int best = (int)F[3 * t];
        for (int k = 1; k < 3; k++)
            if (dist[F[3 * t + k]] < dist[best])
                best = (int)F[3 * t + k];
        near[t] = lab[best] >= 0 ? lab[best] : 0;
    }
    /* a correspondence triangle is its own nearest */
    for (int i = 0; i < h->ncorr; i++)
        near[h->corr_tri[i]] = i;
done:
    free(dist);
    free(lab);
    free(hp);
    mdl__graph_fini(&g);
    return rc;
}
