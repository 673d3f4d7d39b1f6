/* train.c - the analysis phase of paper 2012 (Fig. 2, Sec. 4): from an example mesh sequence and
 * marker trajectories to the part-based pose and shape model.
 *
 *   1. virtual markers tau(m) and the body frame of every training frame (Sec. 4.1, posefeat.h)
 *   2. near-rigid clustering, extended by overlap rings (Sec. 4.5, cluster.c)
 *   3. virtual skeleton H (cluster adjacency), limb paths in H between the clusters of successive
 *      limb markers: the control points of eq. (2)
 *   4. every cluster joins the limbs whose path crosses it; clusters on several paths are
 *      duplicated per limb ("shared clusters", Sec. 5.3); the others join the nearest limb in H
 *   5. per cluster: rigid alignment of every frame to the reference frame, then PCA (Sec. 4.4, eq. 6)
 *   6. pose parameters per instance: the cluster's rotation as a unit quaternion and its
 *      translation, both in the body frame (Table 1's q_j composed along the limb path: we regress
 *      the composed rotation directly so that errors do not accumulate along the chain), plus its
 *      shape coefficients s
 *   7. with a separate recording: pose adaption (Sec. 4.2, adapt.c)
 *   8. per limb, one regression from the limb's marker parameters to all its instances' pose and
 *      shape parameters: Phi^l and Psi^l of eq. (1)/(5) (regress.c)
 *   9. precomputations for synthesis: greedy alignment order (Sec. 5.1), overlap sets and Cholesky
 *      factors of eq. (7) (Sec. 5.2), geodesic blend weights of eq. (8) (Sec. 5.3)
 */
#include "steer/adapt.h"
#include "steer/cluster.h"
#include "steer/posefeat.h"
#include "core/meshgraph.h"
#include "core/linalg.h"
#include "steer/steer_internal.h"
#include "steer/regress.h"
#include "core/rigid.h"
#include "steer/shape.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

void mdl_train_opts_default(mdl_train_opts *o)
{
    memset(o, 0, sizeof *o);
    o->clusters = 0;
    o->max_clusters = 24;
    o->rigid_tol = 0.004;
    o->overlap_rings = 2;
    o->explained = 0.95;
    o->max_modes = 6;
    o->ridge = -1;
    o->beta = 0.5;
    o->iterations = 1;
    o->use_motion_dir = 0;
    o->marker_weight = -1;
    o->linear = -1;
    o->relax = 4;
    o->align_samples = 16;
    o->train_noise = 0;
    o->noise_copies = 4;
    o->name = "model";
}

#define ALLOC(p, n)                                                                                \
    do {                                                                                           \
        (p) = mdl__calloc((size_t)(n), sizeof *(p));                                               \
        if (!(p)) {                                                                                \
            rc = mdl__err(err, -ENOMEM, "train: out of memory");                                   \
            goto out;                                                                              \
        }                                                                                          \
    } while (0)

static void progress(const mdl_train_opts *o, const char *stage, double f)
{
    if (o->progress)
        o->progress(o->progress_ud, stage, f);
}

/* body coordinates of all vertices of one frame: R^T (x - o) */
static void frame_to_body(const float *V, int nv, const double R[9], const double o[3], double *out)
{
    for (int v = 0; v < nv; v++) {
        double d[3] = {V[3 * v] - o[0], V[3 * v + 1] - o[1], V[3 * v + 2] - o[2]};
        for (int c = 0; c < 3; c++)
            out[3 * v + c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
    }
}

/* BFS shortest path in the part graph from a to b; appends parts (excluding a) to path. */
static int part_path(int nparts, const int *adj_off, const int *adj, int a, int b, int *prev,
                     int *queue, int *path, int *len)
{
    for (int p = 0; p < nparts; p++)
        prev[p] = -2;
    int head = 0, tail = 0;
    queue[tail++] = a;
    prev[a] = -1;
    while (head < tail && prev[b] == -2) {
        int p = queue[head++];
        for (int i = adj_off[p]; i < adj_off[p + 1]; i++)
            if (prev[adj[i]] == -2) {
                prev[adj[i]] = p;
                queue[tail++] = adj[i];
            }
    }
    if (prev[b] == -2)
        return -1;
    int n = 0;
    for (int p = b; p != a; p = prev[p])
        queue[n++] = p;
    for (int i = n - 1; i >= 0; i--)
        path[(*len)++] = queue[i];
    return 0;
}

int mdl__steer_train(const mdl_meshseq *seq, const int *frames, int nframes, const mdl_rig *rig,
                     const mdl_markers *markers, const mdl_train_opts *opts, struct mdl_steer **out,
                     char *err)
{
    mdl_train_opts defo;
    if (!opts) {
        mdl_train_opts_default(&defo);
        opts = &defo;
    }
    *out = NULL;
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int nv = seq->nv, T = nframes, rc = 0, nm = rig->nmarkers;
    if (T < 3)
        return mdl__err(err, -EINVAL, "train: %d training frames; at least 3 are needed", T);
    for (int i = 0; i < T; i++)
        if (frames[i] < 0 || frames[i] >= seq->frames)
            return mdl__err(err, -EINVAL, "train: frame %d is outside the sequence (0..%d)",
                            frames[i], seq->frames - 1);
    for (int i = 0; i < nm; i++)
        if (rig->markers[i].vertex < 0 || rig->markers[i].vertex >= nv)
            return mdl__err(err, -EINVAL, "train: rig marker '%s' uses vertex %d; the mesh has %d",
                            rig->markers[i].name, rig->markers[i].vertex, nv);
    if (rig->nlimbs < 1 || rig->nref < 2)
        return mdl__err(err, -EINVAL, "train: the rig needs a reference edge and at least one limb");

    struct mdl_steer *m = mdl__calloc(1, sizeof *m);
    if (!m)
        return mdl__err(err, -ENOMEM, "train: out of memory");
    mdl_graph g = {0};
    double *X = NULL, *Xl = NULL, *Rb = NULL, *ob = NULL, *pR = NULL, *pt = NULL, *feat = NULL;
    float *Pv = NULL;
    int *adj_off = NULL, *adj = NULL, *prev = NULL, *queue = NULL, *inst_of = NULL;
    int *part_limbs = NULL, *nearest = NULL, *vinst_cnt = NULL, *placed = NULL;
    int *mk_map = NULL, *lmap = NULL;
    uint8_t *mark = NULL, *gsel = NULL;
    double *dist = NULL, *bd = NULL, **pmodes = NULL, **psig = NULL;
    double *Fm = NULL, *Fv = NULL, *Xr = NULL, *Yr = NULL, *targets = NULL, *colw = NULL;
    float *Pm = NULL, *Pn = NULL;

    snprintf(m->name, sizeof m->name, "%s", opts->name ? opts->name : "model");
    m->nv = nv;
    m->nf = seq->nf;
    m->fps = seq->fps;
    m->beta = opts->beta;
    m->iterations = opts->iterations;
    m->use_motion_dir = opts->use_motion_dir;
    m->prior_weight = 0.05;
    m->marker_weight = opts->marker_weight >= 0 ? opts->marker_weight : (markers ? 0 : 1);
    m->relax = opts->relax;
    m->virtual_markers = markers == NULL;
    m->ntrain = T;
    ALLOC(m->train_frames, T);
    memcpy(m->train_frames, frames, sizeof(int) * (size_t)T);
    ALLOC(m->F, 3 * (size_t)seq->nf);
    memcpy(m->F, seq->F, sizeof(uint32_t) * 3 * (size_t)seq->nf);
    m->topology = mdl_topology_fingerprint(seq->F, seq->nf, nv);
    ALLOC(m->rest, 3 * (size_t)nv);
    memcpy(m->rest, seq->V + (size_t)frames[0] * nv * 3, sizeof(float) * 3 * (size_t)nv);
    for (int k = 0; k < 3; k++) {
        m->bbox_min[k] = INFINITY;
        m->bbox_max[k] = -INFINITY;
    }
    for (int i = 0; i < T; i++) {
        const float *V = seq->V + (size_t)frames[i] * nv * 3;
        for (int v = 0; v < nv; v++)
            for (int k = 0; k < 3; k++) {
                if (V[3 * v + k] < m->bbox_min[k])
                    m->bbox_min[k] = V[3 * v + k];
                if (V[3 * v + k] > m->bbox_max[k])
                    m->bbox_max[k] = V[3 * v + k];
            }
    }
    /* the rig */
    m->nmarkers = nm;
    ALLOC(m->markers, nm);
    memcpy(m->markers, rig->markers, sizeof *m->markers * (size_t)nm);
    m->nref = rig->nref;
    for (int k = 0; k < 3; k++) /* unused slots are stored as 0 */
        m->ref[k] = k < rig->nref ? rig->ref[k] : 0;
    m->nlimbs = rig->nlimbs;
    ALLOC(m->limb_off, rig->nlimbs + 1);
    memcpy(m->limb_off, rig->limb_off, sizeof(int) * (size_t)(rig->nlimbs + 1));
    ALLOC(m->limb_idx, rig->limb_off[rig->nlimbs]);
    memcpy(m->limb_idx, rig->limb_idx, sizeof(int) * (size_t)rig->limb_off[rig->nlimbs]);

    /* 1. virtual markers and body frames */
    progress(opts, "body frames", 0);
    ALLOC(Pv, (size_t)T * nm * 3);
    ALLOC(Rb, (size_t)T * 9);
    ALLOC(ob, (size_t)T * 3);
    ALLOC(X, (size_t)T * nv * 3);
    for (int i = 0; i < T; i++) {
        const float *V = seq->V + (size_t)frames[i] * nv * 3;
        for (int j = 0; j < nm; j++)
            memcpy(Pv + ((size_t)i * nm + j) * 3, V + 3 * rig->markers[j].vertex, 3 * sizeof(float));
    }
    m->axis_mesh = mdl__ref_axis(Pv, T, (size_t)nm * 3, m->ref);
    for (int i = 0; i < T; i++) {
        const float *V = seq->V + (size_t)frames[i] * nv * 3;
        if (mdl__body_frame(Pv + (size_t)i * nm * 3, m->nref, m->ref, m->axis_mesh, Rb + 9 * i, ob + 3 * i)) {
            rc = mdl__err(err, -EINVAL,
                          "train: the reference markers coincide in training frame %d", frames[i]);
            goto out;
        }
        frame_to_body(V, nv, Rb + 9 * i, ob + 3 * i, X + (size_t)i * nv * 3);
    }
    memcpy(m->place_R, Rb, sizeof m->place_R);
    memcpy(m->place_o, ob, sizeof m->place_o);

    /* 2. clustering */
    if ((rc = mdl__graph_init(&g, nv, seq->F, seq->nf, err)))
        goto out;
    double diag = 0;
    for (int k = 0; k < 3; k++)
        diag += (m->bbox_max[k] - m->bbox_min[k]) * (m->bbox_max[k] - m->bbox_min[k]);
    diag = sqrt(diag);
    int maxk = opts->clusters > 0 ? opts->clusters : opts->max_clusters;
    ALLOC(m->part, nv);
    ALLOC(m->part_rms, maxk + 1);
    int min_size = nv / 400 > 8 ? nv / 400 : 8;
    if ((rc = mdl__cluster(X, T, nv, &g, opts->clusters, opts->max_clusters, opts->rigid_tol * diag,
                           min_size, m->part, &m->nparts, m->part_rms, opts->progress,
                           opts->progress_ud, err)))
        goto out;
    int P = m->nparts;

    /* overlaps: rings of neighbours around every part */
    ALLOC(mark, nv);
    ALLOC(queue, nv + P + 1);
    ALLOC(m->pv_off, P + 1);
    {
        size_t cap = (size_t)nv * 2, n = 0;
        ALLOC(m->pv_idx, cap);
        for (int p = 0; p < P; p++) {
            memset(mark, 0, (size_t)nv);
            int cnt = 0;
            for (int v = 0; v < nv; v++)
                if (m->part[v] == p) {
                    mark[v] = 1;
                    queue[cnt++] = v;
                }
            int start = 0;
            for (int r = 0; r < opts->overlap_rings; r++) {
                int end = cnt;
                for (int i = start; i < end; i++) {
                    int v = queue[i];
                    for (int e = g.off[v]; e < g.off[v + 1]; e++)
                        if (!mark[g.nbr[e]]) {
                            mark[g.nbr[e]] = 1;
                            queue[cnt++] = g.nbr[e];
                        }
                }
                start = end;
            }
            if (n + (size_t)cnt > cap) {
                cap = (n + (size_t)cnt) * 2;
                int *nn = realloc(m->pv_idx, cap * sizeof *nn);
                if (!nn) {
                    rc = mdl__err(err, -ENOMEM, "train: out of memory");
                    goto out;
                }
                m->pv_idx = nn;
            }
            m->pv_off[p] = (int)n;
            memcpy(m->pv_idx + n, queue, sizeof(int) * (size_t)cnt);
            n += (size_t)cnt;
        }
        m->pv_off[P] = (int)n;
    }

    /* 3. virtual skeleton H: parts joined by a mesh edge */
    ALLOC(adj_off, P + 1);
    {
        uint8_t *A = mdl__calloc((size_t)P * P, 1);
        if (!A) {
            rc = mdl__err(err, -ENOMEM, "train: out of memory");
            goto out;
        }
        for (int v = 0; v < nv; v++)
            for (int e = g.off[v]; e < g.off[v + 1]; e++) {
                int a = m->part[v], b = m->part[g.nbr[e]];
                if (a != b)
                    A[a * P + b] = A[b * P + a] = 1;
            }
        int n = 0;
        for (int p = 0; p < P * P; p++)
            n += A[p];
        adj = mdl__calloc((size_t)n + 1, sizeof *adj);
        if (!adj) {
            free(A);
            rc = mdl__err(err, -ENOMEM, "train: out of memory");
            goto out;
        }
        n = 0;
        for (int a = 0; a < P; a++) {
            adj_off[a] = n;
            for (int b = 0; b < P; b++)
                if (A[a * P + b])
                    adj[n++] = b;
        }
        adj_off[P] = n;
        free(A);
    }

    /* limb paths in H (eq. 2) */
    int L = m->nlimbs;
    ALLOC(prev, P);
    ALLOC(m->lpath_off, L + 1);
    ALLOC(m->lpath, (size_t)L * (P + 1) * 2);
    ALLOC(part_limbs, (size_t)P * L); /* part_limbs[p * L + l] = 1 when p belongs to limb l */
    {
        int n = 0;
        for (int l = 0; l < L; l++) {
            m->lpath_off[l] = n;
            const int *path = m->limb_idx + m->limb_off[l];
            int plen = m->limb_off[l + 1] - m->limb_off[l];
            int first = m->part[m->markers[path[0]].vertex];
            m->lpath[n++] = first;
            for (int j = 0; j + 1 < plen; j++) {
                int a = m->part[m->markers[path[j]].vertex];
                int b = m->part[m->markers[path[j + 1]].vertex];
                if (a == b)
                    continue;
                int before = n;
                if (part_path(P, adj_off, adj, a, b, prev, queue, m->lpath, &n)) {
                    /* different mesh components: join the end's part directly */
                    n = before;
                    m->lpath[n++] = b;
                }
            }
            /* remove repeated parts (a path may revisit) while keeping order */
            int w = m->lpath_off[l];
            for (int i = m->lpath_off[l]; i < n; i++) {
                int dup = 0;
                for (int k = m->lpath_off[l]; k < w; k++)
                    dup |= m->lpath[k] == m->lpath[i];
                if (!dup)
                    m->lpath[w++] = m->lpath[i];
            }
            n = w;
            for (int i = m->lpath_off[l]; i < n; i++)
                part_limbs[m->lpath[i] * L + l] = 1;
        }
        m->lpath_off[L] = n;
    }
    /* control points (eq. 2): marker vertex, virtual joints, marker vertex */
    ALLOC(m->lctrl, 3 * ((size_t)m->lpath_off[L] + L));
    for (int l = 0; l < L; l++) {
        double *c = m->lctrl + 3 * ((size_t)m->lpath_off[l] + l);
        int a0 = m->limb_idx[m->limb_off[l]], a1 = m->limb_idx[m->limb_off[l + 1] - 1], k = 1;
        for (int x = 0; x < 3; x++)
            c[x] = m->rest[3 * m->markers[a0].vertex + x];
        for (int i = m->lpath_off[l]; i + 1 < m->lpath_off[l + 1]; i++, k++) {
            /* gamma(e): barycentre of the vertices where the two parts (with overlaps) meet */
            int pa = m->lpath[i], pb = m->lpath[i + 1], cnt = 0;
            double g[3] = {0, 0, 0};
            memset(mark, 0, (size_t)nv);
            for (int j = m->pv_off[pa]; j < m->pv_off[pa + 1]; j++)
                mark[m->pv_idx[j]] = 1;
            for (int j = m->pv_off[pb]; j < m->pv_off[pb + 1]; j++)
                if (mark[m->pv_idx[j]]) {
                    for (int x = 0; x < 3; x++)
                        g[x] += m->rest[3 * m->pv_idx[j] + x];
                    cnt++;
                }
            for (int x = 0; x < 3; x++)
                c[3 * k + x] = cnt ? g[x] / cnt : 0.5 * (c[3 * (k - 1) + x] + m->rest[3 * m->markers[a1].vertex + x]);
        }
        for (int x = 0; x < 3; x++)
            c[3 * k + x] = m->rest[3 * m->markers[a1].vertex + x];
    }
    /* 4. parts off every path join the nearest limb in H (BFS from all path parts) */
    ALLOC(nearest, P);
    {
        for (int p = 0; p < P; p++)
            nearest[p] = -1;
        int head = 0, tail = 0;
        for (int l = 0; l < L; l++)
            for (int i = m->lpath_off[l]; i < m->lpath_off[l + 1]; i++) {
                int p = m->lpath[i];
                if (nearest[p] < 0) {
                    nearest[p] = l;
                    queue[tail++] = p;
                }
            }
        while (head < tail) {
            int p = queue[head++];
            for (int i = adj_off[p]; i < adj_off[p + 1]; i++)
                if (nearest[adj[i]] < 0) {
                    nearest[adj[i]] = nearest[p];
                    queue[tail++] = adj[i];
                }
        }
        for (int p = 0; p < P; p++) {
            int any = 0;
            for (int l = 0; l < L; l++)
                any |= part_limbs[p * L + l];
            if (!any)
                part_limbs[p * L + (nearest[p] >= 0 ? nearest[p] : 0)] = 1;
        }
    }
    /* instances */
    int NI = 0;
    for (int i = 0; i < P * L; i++)
        NI += part_limbs[i];
    m->ninst = NI;
    ALLOC(m->inst_part, NI);
    ALLOC(m->inst_limb, NI);
    ALLOC(m->inst_out, NI);
    ALLOC(m->inst_shared, NI);
    ALLOC(inst_of, (size_t)P * L);
    {
        int n = 0;
        for (int l = 0; l < L; l++)
            for (int p = 0; p < P; p++)
                if (part_limbs[p * L + l]) {
                    int cnt = 0;
                    for (int k = 0; k < L; k++)
                        cnt += part_limbs[p * L + k];
                    m->inst_part[n] = p;
                    m->inst_limb[n] = l;
                    m->inst_shared[n] = cnt > 1;
                    inst_of[p * L + l] = n;
                    n++;
                }
    }

    /* 5. per part: rigid alignment to the reference frame and PCA (eq. 6) */
    ALLOC(m->pmodes, P);
    ALLOC(m->pm_off, P + 1);
    ALLOC(m->ps_off, P + 1);
    ALLOC(m->part_explained, P);
    ALLOC(pR, (size_t)P * T * 9);
    ALLOC(pt, (size_t)P * T * 3);
    ALLOC(pmodes, P);
    ALLOC(psig, P);
    ALLOC(m->part_mean, 3 * (size_t)m->pv_off[P]);
    {
        int maxn = 0;
        for (int p = 0; p < P; p++)
            if (m->pv_off[p + 1] - m->pv_off[p] > maxn)
                maxn = m->pv_off[p + 1] - m->pv_off[p];
        double *ybuf, *xbuf, *mean;
        ALLOC(Xl, (size_t)3 * maxn * T);
        ybuf = mdl__calloc((size_t)3 * maxn, sizeof *ybuf);
        xbuf = mdl__calloc((size_t)3 * maxn, sizeof *xbuf);
        mean = mdl__calloc((size_t)3 * maxn, sizeof *mean);
        if (!ybuf || !xbuf || !mean) {
            free(ybuf);
            free(xbuf);
            free(mean);
            rc = mdl__err(err, -ENOMEM, "train: out of memory");
            goto out;
        }
        int mo = 0;
        for (int p = 0; p < P; p++) {
            progress(opts, "shape models", (double)p / P);
            int n = m->pv_off[p + 1] - m->pv_off[p];
            const int *idx = m->pv_idx + m->pv_off[p];
            for (int i = 0; i < n; i++)
                memcpy(ybuf + 3 * i, X + 3 * (size_t)idx[i], 3 * sizeof(double));
            for (int f = 0; f < T; f++) {
                const double *Xf = X + (size_t)f * nv * 3;
                for (int i = 0; i < n; i++)
                    memcpy(xbuf + 3 * i, Xf + 3 * (size_t)idx[i], 3 * sizeof(double));
                double *R = pR + ((size_t)p * T + f) * 9, *t = pt + ((size_t)p * T + f) * 3;
                mdl__kabsch(ybuf, xbuf, NULL, n, R, t);
                double *col = Xl + (size_t)f * 3 * n;
                for (int i = 0; i < n; i++) { /* local = R^T (x - t) */
                    double d[3] = {xbuf[3 * i] - t[0], xbuf[3 * i + 1] - t[1], xbuf[3 * i + 2] - t[2]};
                    for (int c = 0; c < 3; c++)
                        col[3 * i + c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
                }
            }
            int k;
            double expl;
            char e2[MDL_ERR_LEN];
            int r = mdl__pca(Xl, 3 * n, T, opts->explained, opts->max_modes, mean, &pmodes[p],
                             &psig[p], &k, &expl, e2);
            if (r) {
                free(ybuf);
                free(xbuf);
                free(mean);
                rc = mdl__err(err, r, "train: part %d: %s", p, e2);
                goto out;
            }
            for (int i = 0; i < 3 * n; i++)
                m->part_mean[3 * (size_t)m->pv_off[p] + i] = (float)mean[i];
            m->pmodes[p] = k;
            m->part_explained[p] = expl;
            m->pm_off[p] = mo;
            mo += 3 * n * k;
            m->ps_off[p + 1] = m->ps_off[p] + k;
        }
        m->pm_off[P] = mo;
        free(ybuf);
        free(xbuf);
        free(mean);
        ALLOC(m->part_modes, mo + 1);
        ALLOC(m->part_sigma2, m->ps_off[P] + 1);
        for (int p = 0; p < P; p++) {
            int n = m->pv_off[p + 1] - m->pv_off[p], k = m->pmodes[p];
            for (int i = 0; i < 3 * n * k; i++)
                m->part_modes[m->pm_off[p] + i] = (float)pmodes[p][i];
            for (int j = 0; j < k; j++)
                m->part_sigma2[m->ps_off[p] + j] = psig[p][j];
        }
    }

    /* 6. targets per part and frame: quaternion (hemisphere-aligned), translation, shape coefs */
    int maxk_modes = 0;
    for (int p = 0; p < P; p++)
        if (m->pmodes[p] > maxk_modes)
            maxk_modes = m->pmodes[p];
    int tdim = 7 + maxk_modes; /* per part per frame */
    ALLOC(targets, (size_t)P * T * tdim);
    for (int p = 0; p < P; p++) {
        int n = m->pv_off[p + 1] - m->pv_off[p], k = m->pmodes[p];
        const int *idx = m->pv_idx + m->pv_off[p];
        const float *mean = m->part_mean + 3 * (size_t)m->pv_off[p];
        double qref[4] = {0, 0, 0, 0};
        for (int f = 0; f < T; f++) {
            double *tg = targets + ((size_t)p * T + f) * tdim;
            const double *R = pR + ((size_t)p * T + f) * 9, *t = pt + ((size_t)p * T + f) * 3;
            double q[4];
            mdl__mat_to_quat(R, q);
            if (f == 0)
                memcpy(qref, q, sizeof q);
            if (q[0] * qref[0] + q[1] * qref[1] + q[2] * qref[2] + q[3] * qref[3] < 0)
                for (int c = 0; c < 4; c++)
                    q[c] = -q[c];
            memcpy(tg, q, sizeof q);
            memcpy(tg + 4, t, 3 * sizeof(double));
            const double *Xf = X + (size_t)f * nv * 3;
            for (int j = 0; j < k; j++) {
                const float *V = m->part_modes + m->pm_off[p] + (size_t)j * 3 * n;
                double s = 0;
                for (int i = 0; i < n; i++) {
                    const double *x = Xf + 3 * (size_t)idx[i];
                    double d[3] = {x[0] - t[0], x[1] - t[1], x[2] - t[2]};
                    for (int c = 0; c < 3; c++) {
                        double lc = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
                        s += V[3 * i + c] * (lc - mean[3 * i + c]);
                    }
                }
                tg[7 + j] = s;
            }
        }
    }

    /* 7-8. features, pose adaption and the regressions per limb */
    ALLOC(m->reg, L);
    int FM = 0, stride = 1;
    if (markers) {
        ALLOC(mk_map, nm);
        for (int j = 0; j < nm; j++) {
            mk_map[j] = mdl_markers_find(markers, m->markers[j].source);
            if (mk_map[j] < 0) {
                rc = mdl__err(err, -EINVAL,
                              "train: rig marker '%s' wants source '%s', which the marker file does "
                              "not have",
                              m->markers[j].name, m->markers[j].source);
                goto out;
            }
        }
        m->place_mode = 1;
        /* samples at most ~25 Hz: consecutive mocap frames are near-duplicates, which would let
         * leave-one-out choose an over-fitting regulariser; and at most 4000 of them */
        stride = markers->fps > 37.5 ? (int)lround(markers->fps / 25.0) : 1;
        if (markers->frames / stride > 4000)
            stride = (markers->frames + 3999) / 4000;
        FM = (markers->frames + stride - 1) / stride;
        ALLOC(Pm, (size_t)FM * nm * 3);
        ALLOC(lmap, FM);
        /* hold invalid samples at the last valid position (first valid one at the start) */
        for (int j = 0; j < nm; j++) {
            int src = mk_map[j], last = -1;
            for (int f = 0; f < markers->frames && last < 0; f++)
                if (markers->valid[(size_t)f * markers->count + src])
                    last = f;
            if (last < 0) {
                rc = mdl__err(err, -EINVAL, "train: marker '%s' is never valid in the recording",
                              m->markers[j].source);
                goto out;
            }
            for (int i = 0; i < FM; i++) {
                int f = i * stride;
                for (int ff = last + 1; ff <= f; ff++)
                    if (markers->valid[(size_t)ff * markers->count + src])
                        last = ff;
                memcpy(Pm + ((size_t)i * nm + j) * 3, markers->P + ((size_t)last * markers->count + src) * 3,
                       3 * sizeof(float));
            }
        }
        m->axis_rec = mdl__ref_axis(Pm, FM, (size_t)nm * 3, m->ref);
    }
    {
        int maxd = 0;
        for (int l = 0; l < L; l++) {
            int d = mdl__limb_nfeat(m->limb_off[l + 1] - m->limb_off[l], m->use_motion_dir);
            if (d > maxd)
                maxd = d;
        }
        /* with virtual markers, noisy copies of every training frame teach the regressions that
         * marker noise of about train_noise metres should not move the result (data augmentation
         * in place of a noise model): copy a > 0 of frame i has every marker jittered */
        int copies = !markers && opts->train_noise > 0 ? opts->noise_copies : 0;
        if (copies > MDL_MAX_GROUP - 1)
            copies = MDL_MAX_GROUP - 1;
        if (copies < 0)
            copies = 0;
        int nsamp = markers ? FM : T * (1 + copies);
        if (copies) {
            ALLOC(Pn, (size_t)T * copies * nm * 3);
            uint64_t rng = 0x5eed5eedull;
            for (size_t i = 0; i < (size_t)T * copies * nm * 3; i++)
                Pn[i] = Pv[i % ((size_t)T * nm * 3)] + (float)(opts->train_noise * mdl__gauss(&rng));
        }
        ALLOC(Fv, (size_t)T * maxd);
        ALLOC(Fm, (size_t)(FM > 0 ? FM : 1) * maxd);
        ALLOC(feat, maxd);
        ALLOC(Xr, (size_t)nsamp * maxd);
        for (int l = 0; l < L; l++) {
            progress(opts, "regression", (double)l / L);
            mdl_limb_reg *rg = &m->reg[l];
            const int *path = m->limb_idx + m->limb_off[l];
            int plen = m->limb_off[l + 1] - m->limb_off[l];
            int d = mdl__limb_nfeat(plen, m->use_motion_dir);
            rg->nin = d;
            ALLOC(rg->feat_scale, d);
            ALLOC(rg->feat_shift, d);
            for (int i = 0; i < T; i++) {
                mdl__limb_features(Pv + (size_t)i * nm * 3, i > 0 ? Pv + (size_t)(i - 1) * nm * 3 : NULL,
                                   path, plen, Rb + 9 * i, ob + 3 * i, m->use_motion_dir, feat);
                for (int j = 0; j < d; j++)
                    Fv[(size_t)j * T + i] = feat[j];
            }
            if (markers) {
                double R[9], o[3];
                for (int i = 0; i < FM; i++) {
                    const float *Pi = Pm + (size_t)i * nm * 3;
                    if (mdl__body_frame(Pi, m->nref, m->ref, m->axis_rec, R, o)) {
                        rc = mdl__err(err, -EINVAL,
                                      "train: the reference markers coincide in recording frame %d",
                                      i * stride);
                        goto out;
                    }
                    mdl__limb_features(Pi, i > 0 ? Pi - (size_t)nm * 3 : NULL, path, plen, R, o,
                                       m->use_motion_dir, feat);
                    for (int j = 0; j < d; j++)
                        Fm[(size_t)j * FM + i] = feat[j];
                }
                if (l == 0) { /* the recording's first body frame: reference for placement */
                    mdl__body_frame(Pm, m->nref, m->ref, m->axis_rec, R, o);
                    m->rec_heading = mdl__body_heading(R);
                    memcpy(m->rec_origin, o, sizeof o);
                }
                if ((rc = mdl__adapt_limb(Fm, FM, Fv, T, d, 4, rg->feat_scale, rg->feat_shift, lmap,
                                          err)))
                    goto out;
                for (int j = 0; j < d; j++)
                    for (int i = 0; i < FM; i++)
                        Xr[(size_t)j * FM + i] = rg->feat_scale[j] * Fm[(size_t)j * FM + i] + rg->feat_shift[j];
            } else {
                for (int j = 0; j < d; j++) {
                    rg->feat_scale[j] = 1;
                    rg->feat_shift[j] = 0;
                }
                for (int j = 0; j < d; j++)
                    memcpy(Xr + (size_t)j * nsamp, Fv + (size_t)j * T, sizeof(double) * (size_t)T);
                for (int a = 0; a < copies; a++)
                    for (int i = 0; i < T; i++) {
                        const float *Pi = Pn + ((size_t)a * T + i) * nm * 3;
                        double R[9], o[3];
                        if (mdl__body_frame(Pi, m->nref, m->ref, m->axis_mesh, R, o)) {
                            memcpy(R, Rb + 9 * i, sizeof R);
                            memcpy(o, ob + 3 * i, sizeof o);
                        }
                        mdl__limb_features(Pi, i > 0 ? Pi - (size_t)nm * 3 : NULL, path, plen, R, o,
                                           m->use_motion_dir, feat);
                        for (int j = 0; j < d; j++)
                            Xr[(size_t)j * nsamp + (size_t)(a + 1) * T + i] = feat[j];
                    }
            }
            /* outputs: every instance of this limb: q (4), t (3), s (k) */
            int q = 0;
            for (int i = 0; i < NI; i++)
                if (m->inst_limb[i] == l) {
                    m->inst_out[i] = q;
                    q += 7 + m->pmodes[m->inst_part[i]];
                }
            rg->nout = q;
            free(Yr);
            Yr = mdl__calloc((size_t)nsamp * q, sizeof *Yr);
            if (!Yr) {
                rc = mdl__err(err, -ENOMEM, "train: out of memory");
                goto out;
            }
            for (int i = 0; i < NI; i++) {
                if (m->inst_limb[i] != l)
                    continue;
                int p = m->inst_part[i], k = m->pmodes[p];
                for (int s = 0; s < nsamp; s++) {
                    int f = markers ? lmap[s] : s % T;
                    const double *tg = targets + ((size_t)p * T + f) * tdim;
                    for (int c = 0; c < 7 + k; c++)
                        Yr[(size_t)(m->inst_out[i] + c) * nsamp + s] = tg[c];
                }
            }
            /* what an error in each output costs in vertex space: a quaternion error dq turns the
             * part by about 2|dq| radians, moving n_p vertices at RMS radius r_p; a translation
             * error moves n_p vertices; shape coefficients are lengths along unit modes */
            free(colw);
            colw = mdl__calloc((size_t)q, sizeof *colw);
            if (!colw) {
                rc = mdl__err(err, -ENOMEM, "train: out of memory");
                goto out;
            }
            for (int i = 0; i < NI; i++) {
                if (m->inst_limb[i] != l)
                    continue;
                int p = m->inst_part[i], np = m->pv_off[p + 1] - m->pv_off[p], k = m->pmodes[p];
                const float *mean = m->part_mean + 3 * (size_t)m->pv_off[p];
                double c[3] = {0, 0, 0}, r2 = 0;
                for (int j = 0; j < np; j++)
                    for (int x = 0; x < 3; x++)
                        c[x] += mean[3 * j + x] / np;
                for (int j = 0; j < np; j++)
                    for (int x = 0; x < 3; x++)
                        r2 += (mean[3 * j + x] - c[x]) * (mean[3 * j + x] - c[x]) / np;
                double *w = colw + m->inst_out[i];
                for (int x = 0; x < 4; x++)
                    w[x] = 4 * r2 * np;
                for (int x = 4; x < 7; x++)
                    w[x] = np;
                for (int x = 7; x < 7 + k; x++)
                    w[x] = 1;
            }
            if ((rc = mdl__regression_fit(Xr, nsamp, d, Yr, q, opts->ridge, colw,
                                          copies ? T : 0, opts->linear < 0 ? markers == NULL : !opts->linear, &rg->zmean,
                                          &rg->zsd, &rg->cent, &rg->ncent, &rg->width, &rg->in_mean,
                                          &rg->in_sd, &rg->coef, &rg->ridge, &rg->rms_train,
                                          &rg->rms_loo, err)))
                goto out;
        }
    }

    /* 9a. how many instances hold each vertex */
    ALLOC(vinst_cnt, nv);
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i];
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            vinst_cnt[m->pv_idx[j]]++;
    }
    /* 9a'. the alignment sample: the alignment and shape steps read each instance's shared
     * vertices; an evenly spread subset of at most opts->align_samples of them per instance (and
     * every other instance's copy of those vertices) constrains them as well at a fraction of the
     * per-frame cost */
    ALLOC(gsel, nv);
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i], ns = 0;
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            ns += vinst_cnt[m->pv_idx[j]] > 1;
        int stride = opts->align_samples > 0 && ns > opts->align_samples
                         ? (ns + opts->align_samples - 1) / opts->align_samples
                         : 1;
        int k = 0;
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            if (vinst_cnt[m->pv_idx[j]] > 1 && k++ % stride == 0)
                gsel[m->pv_idx[j]] = 1;
    }
    /* 9b. greedy alignment order (Sec. 5.1): largest first, then most overlap with what is placed */
    ALLOC(m->order, NI);
    ALLOC(m->order_ov_off, NI + 1);
    ALLOC(placed, NI);
    {
        int cap = 0;
        for (int i = 0; i < NI; i++)
            cap += m->pv_off[m->inst_part[i] + 1] - m->pv_off[m->inst_part[i]];
        ALLOC(m->order_ov, cap + 1);
        memset(mark, 0, (size_t)nv);
        int n = 0;
        for (int step = 0; step < NI; step++) {
            int best = -1, bestov = -1, bestsize = -1;
            for (int i = 0; i < NI; i++) {
                if (placed[i])
                    continue;
                int p = m->inst_part[i], ov = 0, size = m->pv_off[p + 1] - m->pv_off[p];
                if (step > 0)
                    for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                        ov += mark[m->pv_idx[j]];
                if (ov > bestov || (ov == bestov && size > bestsize)) {
                    best = i;
                    bestov = ov;
                    bestsize = size;
                }
            }
            placed[best] = 1;
            m->order[step] = best;
            m->order_ov_off[step] = n;
            int p = m->inst_part[best];
            if (step > 0)
                for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                    if (mark[m->pv_idx[j]] && gsel[m->pv_idx[j]])
                        m->order_ov[n++] = j - m->pv_off[p];
            for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                mark[m->pv_idx[j]] = 1;
        }
        m->order_ov_off[NI] = n;
    }
    /* 9c. shape optimisation (eq. 7): overlap vertices and the Cholesky factor per instance */
    ALLOC(m->sov_off, NI + 1);
    ALLOC(m->chol_off, NI + 1);
    {
        int n = 0, c = 0;
        for (int i = 0; i < NI; i++) {
            int p = m->inst_part[i], k = m->pmodes[p];
            for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                n += vinst_cnt[m->pv_idx[j]] > 1 && gsel[m->pv_idx[j]];
            c += k * k;
        }
        ALLOC(m->sov, n + 1);
        ALLOC(m->chol, c + 1);
        n = c = 0;
        for (int i = 0; i < NI; i++) {
            int p = m->inst_part[i], k = m->pmodes[p], np = m->pv_off[p + 1] - m->pv_off[p];
            m->sov_off[i] = n;
            m->chol_off[i] = c;
            for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                if (vinst_cnt[m->pv_idx[j]] > 1 && gsel[m->pv_idx[j]])
                    m->sov[n++] = j - m->pv_off[p];
            double *A = m->chol + c;
            const float *V = m->part_modes + m->pm_off[p];
            for (int a = 0; a < k; a++)
                for (int b = 0; b < k; b++) {
                    double s = 0;
                    for (int o = m->sov_off[i]; o < n; o++)
                        for (int x = 0; x < 3; x++)
                            s += (double)V[(size_t)a * 3 * np + 3 * m->sov[o] + x] *
                                 V[(size_t)b * 3 * np + 3 * m->sov[o] + x];
                    A[b * k + a] = s;
                }
            for (int a = 0; a < k; a++)
                A[a * k + a] += m->beta / m->part_sigma2[m->ps_off[p] + a];
            if (k > 0 && (rc = mdl_la_potrf(k, A, k, err)))
                goto out;
            c += k * k;
        }
        m->sov_off[NI] = n;
        m->chol_off[NI] = c;
    }
    /* 9d. blend weights, eq. (8): geodesic distance of every vertex of an instance to its anchor
     * (the limb boundary for shared clusters, the instance's own exclusive vertices otherwise) */
    progress(opts, "blend weights", 0);
    ALLOC(m->blend_off, nv + 1);
    for (int v = 0; v < nv; v++)
        m->blend_off[v + 1] = m->blend_off[v] + vinst_cnt[v];
    ALLOC(m->blend_inst, m->blend_off[nv]);
    ALLOC(m->blend_local, m->blend_off[nv]);
    ALLOC(m->blend_w, m->blend_off[nv]);
    ALLOC(bd, m->blend_off[nv]);
    ALLOC(dist, nv);
    {
        int *fill = mdl__calloc((size_t)nv, sizeof *fill);
        int *src = mdl__calloc((size_t)nv, sizeof *src);
        uint8_t *in_limb = mdl__calloc((size_t)nv, 1);
        if (!fill || !src || !in_limb) {
            free(fill);
            free(src);
            free(in_limb);
            rc = mdl__err(err, -ENOMEM, "train: out of memory");
            goto out;
        }
        for (int i = 0; i < NI; i++) {
            progress(opts, "blend weights", (double)i / NI);
            int p = m->inst_part[i], l = m->inst_limb[i];
            memset(mark, 0, (size_t)nv);
            for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                mark[m->pv_idx[j]] = 1;
            int ns = 0;
            if (m->inst_shared[i]) {
                memset(in_limb, 0, (size_t)nv);
                for (int o = 0; o < NI; o++)
                    if (m->inst_limb[o] == l && m->inst_part[o] != p)
                        for (int j = m->pv_off[m->inst_part[o]]; j < m->pv_off[m->inst_part[o] + 1]; j++)
                            in_limb[m->pv_idx[j]] = 1;
                for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                    if (in_limb[m->pv_idx[j]])
                        src[ns++] = m->pv_idx[j];
            } else {
                for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                    if (vinst_cnt[m->pv_idx[j]] == 1)
                        src[ns++] = m->pv_idx[j];
            }
            if (ns == 0)
                for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                    if (m->part[m->pv_idx[j]] == p)
                        src[ns++] = m->pv_idx[j];
            if ((rc = mdl__geodesic(&g, m->rest, src, ns, mark, dist, err)))
                break;
            for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++) {
                int v = m->pv_idx[j], s = m->blend_off[v] + fill[v]++;
                m->blend_inst[s] = i;
                m->blend_local[s] = j - m->pv_off[p];
                bd[s] = dist[v];
            }
        }
        free(fill);
        free(src);
        free(in_limb);
        if (rc)
            goto out;
        /* w_l = prod_{i != l} d_i / sum_j prod_{i != j} d_i  (eq. 8 for two, its generalisation) */
        for (int v = 0; v < nv; v++) {
            int a = m->blend_off[v], b = m->blend_off[v + 1], zeros = 0, finite = 0;
            for (int s = a; s < b; s++) {
                zeros += bd[s] <= 1e-12;
                finite += isfinite(bd[s]);
            }
            double tot = 0;
            for (int s = a; s < b; s++) {
                double w;
                if (zeros)
                    w = bd[s] <= 1e-12;
                else if (!finite)
                    w = 1;
                else if (!isfinite(bd[s]))
                    w = 0;
                else {
                    w = 1;
                    for (int r = a; r < b; r++)
                        if (r != s && isfinite(bd[r]))
                            w *= bd[r];
                }
                m->blend_w[s] = (float)w;
                tot += w;
            }
            for (int s = a; s < b; s++)
                m->blend_w[s] = tot > 0 ? (float)(m->blend_w[s] / tot) : (float)(1.0 / (b - a));
        }
    }

    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    m->train_seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    progress(opts, "done", 1);
out:
    mdl__graph_fini(&g);
    free(X);
    free(Xl);
    free(Rb);
    free(ob);
    free(pR);
    free(pt);
    free(feat);
    free(Pv);
    free(adj_off);
    free(adj);
    free(prev);
    free(queue);
    free(inst_of);
    free(part_limbs);
    free(nearest);
    free(vinst_cnt);
    free(placed);
    free(mk_map);
    free(lmap);
    free(mark);
    free(gsel);
    free(dist);
    free(bd);
    if (pmodes)
        for (int p = 0; p < m->nparts; p++)
            free(pmodes[p]);
    if (psig)
        for (int p = 0; p < m->nparts; p++)
            free(psig[p]);
    free(pmodes);
    free(psig);
    free(Fm);
    free(Fv);
    free(Xr);
    free(Yr);
    free(colw);
    free(targets);
    free(Pm);
    free(Pn);
    if (rc) {
        mdl__steer_free(m);
        return rc;
    }
    *out = m;
    return 0;
}
