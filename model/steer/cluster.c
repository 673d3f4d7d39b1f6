/* cluster.c - near-rigid clustering of a mesh from its vertex trajectories (paper 2012 Sec. 4.5).
 *
 * The paper clusters with the clustered PCA of [Sattler et al. 2005]: a Lloyd iteration that
 * assigns each vertex trajectory to the cluster whose model reconstructs it best, and refits the
 * models. We keep that iteration but give each cluster the model the later stages need: one rigid
 * motion per frame (R_cf, t_cf). The error of vertex v under cluster c is
 *     e(v, c) = sum_f || R_cf x_v(ref) + t_cf - x_v(f) ||^2,
 * so the clusters are by construction the near-rigid parts that the shape models (Sec. 4.4) and the
 * greedy rigid alignment (Sec. 5.1) assume. The number of clusters grows by splitting the cluster
 * with the largest total error (seeded at its worst vertex) until every cluster's RMS residual is
 * below a tolerance, or a given count is reached. Clusters are kept connected on the mesh graph.
 */
#include "steer/cluster.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct cl_state {
    const double *X;  /* T x nv x 3, body frame */
    int T, nv;
    const mdl_graph *g;
    int k;
    int *part;
    double *R, *t;    /* k x T x 9, k x T x 3 (capacity kmax) */
    double *ybuf, *xbuf;
    int *list;
    int *queue;
    int *comp;
} cl_state;

static const double *frame(const cl_state *s, int f)
{
    return s->X + (size_t)f * s->nv * 3;
}

static void fit_cluster(cl_state *s, int c)
{
    int n = 0;
    for (int v = 0; v < s->nv; v++)
        if (s->part[v] == c)
            s->list[n++] = v;
    const double *ref = frame(s, 0);
    for (int i = 0; i < n; i++)
        memcpy(s->ybuf + 3 * i, ref + 3 * s->list[i], 3 * sizeof(double));
    for (int f = 0; f < s->T; f++) {
        const double *x = frame(s, f);
        for (int i = 0; i < n; i++)
            memcpy(s->xbuf + 3 * i, x + 3 * s->list[i], 3 * sizeof(double));
        double *R = s->R + ((size_t)c * s->T + f) * 9, *t = s->t + ((size_t)c * s->T + f) * 3;
        if (n > 0) {
            mdl__kabsch(s->ybuf, s->xbuf, NULL, n, R, t);
        } else {
            memset(R, 0, 9 * sizeof *R);
            R[0] = R[4] = R[8] = 1;
            t[0] = t[1] = t[2] = 0;
        }
    }
}

static double vertex_error(const cl_state *s, int v, int c)
{
    const double *y = frame(s, 0) + 3 * v;
    double e = 0;
    for (int f = 0; f < s->T; f++) {
        const double *R = s->R + ((size_t)c * s->T + f) * 9, *t = s->t + ((size_t)c * s->T + f) * 3;
        const double *x = frame(s, f) + 3 * v;
        for (int r = 0; r < 3; r++) {
            double p = R[3 * r] * y[0] + R[3 * r + 1] * y[1] + R[3 * r + 2] * y[2] + t[r] - x[r];
            e += p * p;
        }
    }
    return e;
}

/* Keeps the largest connected piece of every cluster; the other pieces and clusters smaller than
 * min_size are flooded from their neighbours (each vertex joins the adjacent cluster that fits it
 * best). Renumbers clusters to 0..k-1. */
static void make_connected(cl_state *s, int min_size)
{
    int nv = s->nv;
    int *comp = s->comp;
    for (int v = 0; v < nv; v++)
        comp[v] = -1;
    int *best_comp = mdl__calloc((size_t)s->k, sizeof(int));
    int *best_size = mdl__calloc((size_t)s->k, sizeof(int));
    int ncomp = 0;
    for (int c = 0; c < s->k; c++)
        best_comp[c] = -1;
    for (int v0 = 0; v0 < nv; v0++) {
        if (comp[v0] >= 0 || s->part[v0] < 0)
            continue;
        int c = s->part[v0], head = 0, tail = 0;
        s->queue[tail++] = v0;
        comp[v0] = ncomp;
        while (head < tail) {
            int v = s->queue[head++];
            for (int i = s->g->off[v]; i < s->g->off[v + 1]; i++) {
                int u = s->g->nbr[i];
                if (comp[u] < 0 && s->part[u] == c) {
                    comp[u] = ncomp;
                    s->queue[tail++] = u;
                }
            }
        }
        if (tail > best_size[c]) {
            best_size[c] = tail;
            best_comp[c] = ncomp;
        }
        ncomp++;
    }
    int unassigned = 0;
    for (int v = 0; v < nv; v++) {
        int c = s->part[v];
        if (c < 0)
            continue;
        if (comp[v] != best_comp[c] || best_size[c] < min_size) {
            s->part[v] = -1;
            unassigned++;
        }
    }
    /* flood: repeatedly give unassigned vertices next to assigned ones their best neighbour */
    while (unassigned > 0) {
        int changed = 0;
        for (int v = 0; v < nv; v++) {
            if (s->part[v] >= 0)
                continue;
            int bc = -1;
            double be = INFINITY;
            for (int i = s->g->off[v]; i < s->g->off[v + 1]; i++) {
                int c = s->part[s->g->nbr[i]];
                if (c >= s->k) /* assigned earlier in this sweep */
                    c -= s->k;
                if (c < 0 || c == bc)
                    continue;
                double e = vertex_error(s, v, c);
                if (e < be) {
                    be = e;
                    bc = c;
                }
            }
            if (bc >= 0) {
                s->part[v] = bc + s->k; /* mark as newly assigned this sweep */
                changed++;
            }
        }
        for (int v = 0; v < nv; v++)
            if (s->part[v] >= s->k)
                s->part[v] -= s->k;
        unassigned -= changed;
        if (!changed) { /* isolated pieces (a separate mesh component): a cluster of their own */
            for (int v = 0; v < nv; v++)
                if (s->part[v] < 0)
                    s->part[v] = 0;
            break;
        }
    }
    /* renumber */
    int *map = best_size; /* reuse */
    for (int c = 0; c < s->k; c++)
        map[c] = -1;
    int k = 0;
    for (int v = 0; v < nv; v++) {
        int c = s->part[v];
        if (map[c] < 0)
            map[c] = k++;
    }
    for (int v = 0; v < nv; v++)
        s->part[v] = map[s->part[v]];
    s->k = k;
    free(best_comp);
    free(best_size);
}

/* One Lloyd pass in which each vertex may move to a cluster of one of its neighbours. */
static int refine_pass(cl_state *s, int *next)
{
    int moved = 0;
    for (int v = 0; v < s->nv; v++) {
        int cur = s->part[v], bc = cur;
        double be = vertex_error(s, v, cur);
        for (int i = s->g->off[v]; i < s->g->off[v + 1]; i++) {
            int c = s->part[s->g->nbr[i]];
            if (c == cur || c == bc)
                continue;
            double e = vertex_error(s, v, c);
            if (e < be * 0.999) {
                be = e;
                bc = c;
            }
        }
        next[v] = bc;
        moved += bc != cur;
    }
    memcpy(s->part, next, sizeof(int) * (size_t)s->nv);
    return moved;
}

static void fit_all(cl_state *s)
{
    for (int c = 0; c < s->k; c++)
        fit_cluster(s, c);
}

/* Splits cluster c: a region grown from its worst vertex becomes cluster s->k. */
static void split(cl_state *s, int c, const double *verr)
{
    int nv = s->nv, n = 0, worst = -1;
    for (int v = 0; v < nv; v++)
        if (s->part[v] == c) {
            n++;
            if (worst < 0 || verr[v] > verr[worst])
                worst = v;
        }
    int want = n / 3 > 1 ? n / 3 : 1;
    int nc = s->k;
    /* breadth-first region inside c */
    int head = 0, tail = 0;
    s->queue[tail++] = worst;
    s->part[worst] = nc;
    while (head < tail && tail < want) {
        int v = s->queue[head++];
        for (int i = s->g->off[v]; i < s->g->off[v + 1] && tail < want; i++) {
            int u = s->g->nbr[i];
            if (s->part[u] == c) {
                s->part[u] = nc;
                s->queue[tail++] = u;
            }
        }
    }
    s->k++;
    for (int it = 0; it < 6; it++) {
        fit_cluster(s, c);
        fit_cluster(s, nc);
        int moved = 0;
        for (int v = 0; v < nv; v++) {
            if (s->part[v] != c && s->part[v] != nc)
                continue;
            int b = vertex_error(s, v, c) <= vertex_error(s, v, nc) ? c : nc;
            moved += b != s->part[v];
            s->part[v] = b;
        }
        if (!moved)
            break;
    }
}

int mdl__cluster(const double *X, int T, int nv, const mdl_graph *g, int clusters,
                 int max_clusters, double tol, int min_size, int *part, int *nparts,
                 double *part_rms, mdl_progress_fn progress, void *ud, char *err)
{
    return mdl__cluster_snap(X, T, nv, g, clusters, max_clusters, tol, min_size, part, nparts,
                             part_rms, 0, NULL, NULL, NULL, progress, ud, err);
}

int mdl__cluster_snap(const double *X, int T, int nv, const mdl_graph *g, int clusters,
                      int max_clusters, double tol, int min_size, int *part, int *nparts,
                      double *part_rms, int snap_k, int *snap_part, int *snap_n,
                      double *snap_rms, mdl_progress_fn progress, void *ud, char *err)
{
    int kmax = clusters > 0 ? clusters : max_clusters;
    if (kmax < 1)
        kmax = 1;
    cl_state s = {X, T, nv, g, 1, part, NULL, NULL, NULL, NULL, NULL, NULL, NULL};
    s.R = mdl__calloc((size_t)(kmax + 1) * T * 9, sizeof(double));
    s.t = mdl__calloc((size_t)(kmax + 1) * T * 3, sizeof(double));
    s.ybuf = mdl__calloc((size_t)nv * 3, sizeof(double));
    s.xbuf = mdl__calloc((size_t)nv * 3, sizeof(double));
    s.list = mdl__calloc((size_t)nv, sizeof(int));
    s.queue = mdl__calloc((size_t)nv, sizeof(int));
    s.comp = mdl__calloc((size_t)nv, sizeof(int));
    int *next = mdl__calloc((size_t)nv, sizeof(int));
    double *verr = mdl__calloc((size_t)nv, sizeof(double));
    double *cerr = mdl__calloc((size_t)kmax + 1, sizeof(double));
    int *csize = mdl__calloc((size_t)kmax + 1, sizeof(int));
    int rc = 0;
    if (!s.R || !s.t || !s.ybuf || !s.xbuf || !s.list || !s.queue || !s.comp || !next || !verr ||
        !cerr || !csize) {
        rc = mdl__err(err, -ENOMEM, "clustering: out of memory");
        goto out;
    }
    for (int v = 0; v < nv; v++)
        part[v] = 0;
    fit_all(&s);
    for (;;) {
        for (int c = 0; c < s.k; c++) {
            cerr[c] = 0;
            csize[c] = 0;
        }
        double worst_rms = 0;
        for (int v = 0; v < nv; v++) {
            verr[v] = vertex_error(&s, v, part[v]);
            cerr[part[v]] += verr[v];
            csize[part[v]]++;
        }
        int cw = 0;
        for (int c = 0; c < s.k; c++) {
            part_rms[c] = csize[c] ? sqrt(cerr[c] / ((double)csize[c] * T)) : 0;
            if (part_rms[c] > worst_rms)
                worst_rms = part_rms[c];
            if (cerr[c] > cerr[cw])
                cw = c;
        }
        if (progress)
            progress(ud, "clustering", (double)s.k / kmax);
        int stop = s.k >= kmax || (clusters <= 0 && worst_rms <= tol);
        if (snap_part && !*snap_n && (s.k >= snap_k || stop)) { /* where max_clusters = snap_k stops */
            memcpy(snap_part, part, sizeof *part * (size_t)nv);
            memcpy(snap_rms, part_rms, sizeof *part_rms * (size_t)s.k);
            *snap_n = s.k;
        }
        if (stop)
            break;
        int before = s.k;
        split(&s, cw, verr);
        for (int it = 0; it < 3; it++) {
            fit_all(&s);
            if (!refine_pass(&s, next))
                break;
        }
        make_connected(&s, min_size);
        fit_all(&s);
        if (s.k <= before) /* the split did not survive: the cluster cannot be split further */
            break;
    }
    *nparts = s.k;
out:
    free(s.R);
    free(s.t);
    free(s.ybuf);
    free(s.xbuf);
    free(s.list);
    free(s.queue);
    free(s.comp);
    free(next);
    free(verr);
    free(cerr);
    free(csize);
    return rc;
}
