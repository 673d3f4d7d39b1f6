/* train.c - the analysis phase of paper 2012 (Fig. 2, Sec. 4): from an example mesh sequence and
 * marker trajectories to the part-based pose and shape model. One static function per stage, in
 * this order; a train_state carries what one stage hands to the next:
 *
 *   train_setup         the inputs checked; mesh, box and rig (G, e_ref, Sec. 4.1) copied
 *   1. train_frames     virtual markers tau(m) and the body frame of every training frame
 *                       (Sec. 4.1, posefeat.h); every frame in its body frame
 *   2. train_parts      near-rigid clustering (Sec. 4.5, cluster.c), extended by overlap rings
 *   3. train_skeleton   virtual skeleton H (cluster adjacency), limb paths in H between the
 *                       clusters of successive limb markers and their control points (eq. 2);
 *                       every cluster joins the limbs whose path crosses it, clusters on several
 *                       paths are duplicated per limb ("shared clusters", Sec. 5.3), the others
 *                       join the nearest limb in H
 *   4. train_part_poses per cluster and frame: rigid alignment to the reference frame (Sec. 4.4)
 *   5. train_shape_models  per cluster: PCA of the aligned shapes (Sec. 4.4, eq. 6)
 *   6. train_targets    pose parameters per instance: the cluster's rotation as a unit quaternion
 *                       and its translation, both in the body frame (Table 1's q_j composed along
 *                       the limb path: we regress the composed rotation directly so that errors do
 *                       not accumulate along the chain), plus its shape coefficients s
 *   7. train_recording  with a separate recording: its markers resampled; then
 *      train_regressions per limb, the marker parameters (Table 1), pose adaption (Sec. 4.2,
 *                       adapt.c) and one regression from them to all the limb's instances' pose
 *                       and shape parameters: Phi^l and Psi^l of eq. (1)/(5) (regress.c)
 *   8. train_precompute for synthesis: greedy alignment order (Sec. 5.1), overlap sets and
 *                       Cholesky factors of eq. (7) (Sec. 5.2), geodesic blend weights of eq. (8)
 *                       (Sec. 5.3)
 *
 * Every stage allocates what it fills and returns 0 or a negative code with err set; on error
 * mdl__steer_train frees the partly built model and the state.
 */
#include "steer/adapt.h"
#include "steer/cluster.h"
#include "steer/posefeat.h"
#include "steer/heading.h"
#include "core/meshgraph.h"
#include "core/linalg.h"
#include "steer/steer_internal.h"
#include "steer/regress.h"
#include "core/rigid.h"
#include "steer/shape.h"
#include "steer/select.h"
#include "steer/mfilter.h"
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
    o->max_clusters = -1;
    o->rigid_tol = 0.004;
    o->overlap_rings = -1;
    o->explained = 0.95;
    o->max_modes = -1;
    o->ridge = -1;
    o->beta = 0.5;
    o->iterations = 1;
    o->use_motion_dir = -1;
    o->marker_weight = -1;
    o->linear = -1;
    o->relax = 4;
    o->align_samples = 16;
    o->train_noise = -1;
    o->noise_copies = 4;
    o->select_folds = 0; /* the library keeps training fast; `meshsteer train` sets MDL_SELECT_FOLDS */
    o->select_noise = MDL_SELECT_NOISE;
    o->filter_noise = -1;
    o->kblend = -1;
    o->name = "model";
}

/* What training carries from one stage to the next. Each stage fills its own fields (and the
 * model's) and reads those of the stages before it; train_state_fini frees what is not the
 * model's. */
typedef struct train_state {
    /* inputs */
    const mdl_meshseq *seq;
    const int *frames;
    int T;                  /* training frames */
    const mdl_rig *rig;
    const mdl_markers *markers; /* NULL: virtual markers */
    const mdl_train_opts *opts;
    int nv, nm;
    struct mdl_steer *m;    /* the model being built */
    /* frames: virtual markers and body frames (train_frames) */
    float *Pv;              /* T x nm x 3: the rig vertices of every training frame */
    double *Rb, *ob;        /* T x 9, T x 3: body frame of every training frame */
    double *X;              /* T x nv x 3: every training frame in its body frame */
    /* parts (train_parts) */
    mdl_graph g;            /* the mesh's edge graph */
    uint8_t *mark;          /* nv, scratch */
    int *queue;             /* nv + nparts + 1, scratch */
    /* skeleton (train_skeleton) */
    int *adj_off, *adj;     /* part adjacency H: nparts + 1 offsets into adj */
    int *part_limbs;        /* nparts x nlimbs: 1 when the part belongs to the limb */
    /* pose parameters (train_part_poses) */
    double *pR, *pt;        /* nparts x T x 9, nparts x T x 3: part rigid transforms */
    /* regression targets (train_targets) */
    double *targets;        /* nparts x T x tdim: q (4), t (3), shape coefficients */
    int tdim;
    /* a marker recording (train_recording) */
    int FM, stride;         /* samples of the recording, and its frame stride */
    float *Pm;              /* FM x nm x 3, model marker order, invalid samples held */
    int *lmap;              /* FM: training frame each sample is mapped to (adapt.h) */
    /* precompute (precompute_*) */
    int *vinst_cnt;         /* nv: instances holding each vertex */
    /* the option selection (train_parts) */
    const mdl__steer_parts *given; /* a partition to use instead of clustering, or NULL */
    int snap_k;             /* > 0: keep the partition max_clusters = snap_k would give */
    mdl__steer_parts snap;
    uint8_t *gsel;          /* nv: vertex in the alignment sample */
} train_state;

static void train_state_fini(train_state *st)
{
    mdl__graph_fini(&st->g);
    free(st->Pv);
    free(st->Rb);
    free(st->ob);
    free(st->X);
    free(st->mark);
    free(st->queue);
    free(st->adj_off);
    free(st->adj);
    free(st->part_limbs);
    free(st->pR);
    free(st->pt);
    free(st->targets);
    free(st->Pm);
    free(st->lmap);
    free(st->vinst_cnt);
    free(st->snap.part);
    free(st->snap.rms);
    free(st->gsel);
}

static int oom(char *err)
{
    return mdl__err(err, -ENOMEM, "train: out of memory");
}

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

/* The checks of the inputs, and what the model copies of them: mesh (the first training frame is
 * the rest pose), the box of all training frames, the rig (marker graph G and e_ref, Sec. 4.1) and
 * the options synthesis reads. */
static int train_setup(train_state *st, char *err)
{
    const mdl_meshseq *seq = st->seq;
    const mdl_rig *rig = st->rig;
    const mdl_train_opts *opts = st->opts;
    int nv = st->nv, T = st->T, nm = st->nm;
    if (T < 3)
        return mdl__err(err, -EINVAL, "train: %d training frames; at least 3 are needed", T);
    for (int i = 0; i < T; i++)
        if (st->frames[i] < 0 || st->frames[i] >= seq->frames)
            return mdl__err(err, -EINVAL, "train: frame %d is outside the sequence (0..%d)",
                            st->frames[i], seq->frames - 1);
    for (int i = 0; i < nm; i++)
        if (rig->markers[i].vertex < 0 || rig->markers[i].vertex >= nv)
            return mdl__err(err, -EINVAL, "train: rig marker '%s' uses vertex %d; the mesh has %d",
                            rig->markers[i].name, rig->markers[i].vertex, nv);
    if (rig->nlimbs < 1 || rig->nref < 2)
        return mdl__err(err, -EINVAL, "train: the rig needs a reference edge and at least one limb");

    struct mdl_steer *m = mdl__calloc(1, sizeof *m);
    if (!m)
        return oom(err);
    st->m = m;
    snprintf(m->name, sizeof m->name, "%s", opts->name ? opts->name : "model");
    m->nv = nv;
    m->nf = seq->nf;
    m->fps = seq->fps;
    m->beta = opts->beta;
    m->iterations = opts->iterations;
    m->use_motion_dir = opts->use_motion_dir;
    m->prior_weight = 0.05;
    m->marker_weight = opts->marker_weight >= 0 ? opts->marker_weight : (st->markers ? 0 : 1);
    m->relax = opts->relax;
    m->virtual_markers = st->markers == NULL;
    m->ntrain = T;
    m->train_frames = mdl__calloc((size_t)T, sizeof *m->train_frames);
    m->F = mdl__calloc(3 * (size_t)seq->nf, sizeof *m->F);
    m->rest = mdl__calloc(3 * (size_t)nv, sizeof *m->rest);
    m->markers = mdl__calloc((size_t)nm, sizeof *m->markers);
    m->limb_off = mdl__calloc((size_t)rig->nlimbs + 1, sizeof *m->limb_off);
    m->limb_idx = mdl__calloc((size_t)rig->limb_off[rig->nlimbs], sizeof *m->limb_idx);
    if (!m->train_frames || !m->F || !m->rest || !m->markers || !m->limb_off || !m->limb_idx)
        return oom(err);
    memcpy(m->train_frames, st->frames, sizeof(int) * (size_t)T);
    memcpy(m->F, seq->F, sizeof(uint32_t) * 3 * (size_t)seq->nf);
    m->topology = mdl_topology_fingerprint(seq->F, seq->nf, nv);
    memcpy(m->rest, seq->V + (size_t)st->frames[0] * nv * 3, sizeof(float) * 3 * (size_t)nv);
    for (int k = 0; k < 3; k++) {
        m->bbox_min[k] = INFINITY;
        m->bbox_max[k] = -INFINITY;
    }
    for (int i = 0; i < T; i++) {
        const float *V = seq->V + (size_t)st->frames[i] * nv * 3;
        for (int v = 0; v < nv; v++)
            for (int k = 0; k < 3; k++) {
                if (V[3 * v + k] < m->bbox_min[k])
                    m->bbox_min[k] = V[3 * v + k];
                if (V[3 * v + k] > m->bbox_max[k])
                    m->bbox_max[k] = V[3 * v + k];
            }
    }
    m->nmarkers = nm;
    memcpy(m->markers, rig->markers, sizeof *m->markers * (size_t)nm);
    m->nref = rig->nref;
    for (int k = 0; k < 3; k++) /* unused slots are stored as 0 */
        m->ref[k] = k < rig->nref ? rig->ref[k] : 0;
    m->nlimbs = rig->nlimbs;
    memcpy(m->limb_off, rig->limb_off, sizeof(int) * (size_t)(rig->nlimbs + 1));
    memcpy(m->limb_idx, rig->limb_idx, sizeof(int) * (size_t)rig->limb_off[rig->nlimbs]);
    return 0;
}

/* Stage 1, frames (Sec. 4.1): the virtual markers tau(m) of every training frame, its body frame
 * (posefeat.h: e_ref and the secondary axis chosen once for the mesh), and every frame's vertices
 * in that body frame, which is what the clustering and the shape models see. */
static int train_frames(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int nv = st->nv, T = st->T, nm = st->nm;
    progress(st->opts, "body frames", 0);
    st->Pv = mdl__calloc((size_t)T * nm * 3, sizeof *st->Pv);
    st->Rb = mdl__calloc((size_t)T * 9, sizeof *st->Rb);
    st->ob = mdl__calloc((size_t)T * 3, sizeof *st->ob);
    st->X = mdl__calloc((size_t)T * nv * 3, sizeof *st->X);
    if (!st->Pv || !st->Rb || !st->ob || !st->X)
        return oom(err);
    for (int i = 0; i < T; i++) {
        const float *V = st->seq->V + (size_t)st->frames[i] * nv * 3;
        for (int j = 0; j < nm; j++)
            memcpy(st->Pv + ((size_t)i * nm + j) * 3, V + 3 * st->rig->markers[j].vertex,
                   3 * sizeof(float));
    }
    m->axis_mesh = mdl__ref_axis(st->Pv, T, (size_t)nm * 3, m->ref);
    if (m->axis_mesh == 1 && m->nref == 2) { /* an upright edge: the heading from all markers */
        m->hd_mesh = mdl__calloc((size_t)nm * 4, sizeof *m->hd_mesh);
        if (!m->hd_mesh)
            return oom(err);
        /* the noise the model is made for: the selection's (0 without it) */
        double noise = !st->markers && st->opts->select_folds > 0 ? st->opts->select_noise : 0;
        int rc = mdl__heading_train(st->Pv, T, (size_t)nm * 3, nm, m->ref, noise, m->hd_mesh);
        if (rc)
            return mdl__err(err, rc, "train: the heading fit failed (%d)", rc);
        m->axis_mesh = MDL_AXIS_FIT;
    }
    for (int i = 0; i < T; i++) {
        const float *V = st->seq->V + (size_t)st->frames[i] * nv * 3;
        if (mdl__body_frame_any(st->Pv + (size_t)i * nm * 3, NULL, nm, m->nref, m->ref, m->axis_mesh,
                                m->hd_mesh, st->Rb + 9 * i, st->ob + 3 * i))
            return mdl__err(err, -EINVAL, "train: the reference markers coincide in training frame %d",
                            st->frames[i]);
        frame_to_body(V, nv, st->Rb + 9 * i, st->ob + 3 * i, st->X + (size_t)i * nv * 3);
    }
    memcpy(m->place_R, st->Rb, sizeof m->place_R);
    memcpy(m->place_o, st->ob, sizeof m->place_o);
    return 0;
}

/* Stage 2, parts (Sec. 4.5): near-rigid clustering of the body-frame vertex trajectories
 * (cluster.c), then the overlaps: every part grown by opts->overlap_rings rings of mesh
 * neighbours (m->pv_off, m->pv_idx: core vertices first, then the rings). */
static int train_parts(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    const mdl_train_opts *opts = st->opts;
    int nv = st->nv, rc;
    if ((rc = mdl__graph_init(&st->g, nv, st->seq->F, st->seq->nf, err)))
        return rc;
    double diag = 0;
    for (int k = 0; k < 3; k++)
        diag += (m->bbox_max[k] - m->bbox_min[k]) * (m->bbox_max[k] - m->bbox_min[k]);
    diag = sqrt(diag);
    int maxk = opts->clusters > 0 ? opts->clusters : opts->max_clusters;
    m->part = mdl__calloc((size_t)nv, sizeof *m->part);
    m->part_rms = mdl__calloc((size_t)maxk + 1, sizeof *m->part_rms);
    if (!m->part || !m->part_rms)
        return oom(err);
    int min_size = nv / 400 > 8 ? nv / 400 : 8;
    if (st->given) { /* the option selection's: the same frames clustered once */
        memcpy(m->part, st->given->part, sizeof *m->part * (size_t)nv);
        memcpy(m->part_rms, st->given->rms, sizeof *m->part_rms * (size_t)st->given->n);
        m->nparts = st->given->n;
    } else {
        if (st->snap_k > 0) {
            st->snap.part = mdl__calloc((size_t)nv, sizeof *st->snap.part);
            st->snap.rms = mdl__calloc((size_t)maxk + 1, sizeof *st->snap.rms);
            if (!st->snap.part || !st->snap.rms)
                return oom(err);
        }
        if ((rc = mdl__cluster_snap(st->X, st->T, nv, &st->g, opts->clusters, opts->max_clusters,
                                    opts->rigid_tol * diag, min_size, m->part, &m->nparts,
                                    m->part_rms, st->snap_k, st->snap.part, &st->snap.n,
                                    st->snap.rms, opts->progress, opts->progress_ud, err)))
            return rc;
    }
    int P = m->nparts;

    const mdl_graph *g = &st->g;
    st->mark = mdl__calloc((size_t)nv, 1);
    st->queue = mdl__calloc((size_t)nv + P + 1, sizeof *st->queue);
    m->pv_off = mdl__calloc((size_t)P + 1, sizeof *m->pv_off);
    size_t cap = (size_t)nv * 2, n = 0;
    m->pv_idx = mdl__calloc(cap, sizeof *m->pv_idx);
    if (!st->mark || !st->queue || !m->pv_off || !m->pv_idx)
        return oom(err);
    uint8_t *mark = st->mark;
    int *queue = st->queue;
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
                for (int e = g->off[v]; e < g->off[v + 1]; e++)
                    if (!mark[g->nbr[e]]) {
                        mark[g->nbr[e]] = 1;
                        queue[cnt++] = g->nbr[e];
                    }
            }
            start = end;
        }
        if (n + (size_t)cnt > cap) {
            cap = (n + (size_t)cnt) * 2;
            int *nn = realloc(m->pv_idx, cap * sizeof *nn);
            if (!nn)
                return oom(err);
            m->pv_idx = nn;
        }
        m->pv_off[p] = (int)n;
        memcpy(m->pv_idx + n, queue, sizeof(int) * (size_t)cnt);
        n += (size_t)cnt;
    }
    m->pv_off[P] = (int)n;
    return 0;
}

/* Stage 3a, the virtual skeleton H (Sec. 4.1, 4.5): two parts are adjacent when a mesh edge joins
 * them (st->adj_off, st->adj). */
static int skeleton_graph(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int P = m->nparts, nv = st->nv;
    const mdl_graph *g = &st->g;
    st->adj_off = mdl__calloc((size_t)P + 1, sizeof *st->adj_off);
    uint8_t *A = mdl__calloc((size_t)P * P, 1);
    if (!st->adj_off || !A) {
        free(A);
        return oom(err);
    }
    for (int v = 0; v < nv; v++)
        for (int e = g->off[v]; e < g->off[v + 1]; e++) {
            int a = m->part[v], b = m->part[g->nbr[e]];
            if (a != b)
                A[a * P + b] = A[b * P + a] = 1;
        }
    int n = 0;
    for (int p = 0; p < P * P; p++)
        n += A[p];
    st->adj = mdl__calloc((size_t)n + 1, sizeof *st->adj);
    if (!st->adj) {
        free(A);
        return oom(err);
    }
    n = 0;
    for (int a = 0; a < P; a++) {
        st->adj_off[a] = n;
        for (int b = 0; b < P; b++)
            if (A[a * P + b])
                st->adj[n++] = b;
    }
    st->adj_off[P] = n;
    free(A);
    return 0;
}

/* Stage 3b, limb paths (eq. 2): for every limb, the parts along shortest paths in H between the
 * parts of its successive markers, without repeats (m->lpath_off, m->lpath); every part on a path
 * belongs to that limb (st->part_limbs). */
static int skeleton_limb_paths(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int P = m->nparts, L = m->nlimbs;
    int *prev = mdl__calloc((size_t)P, sizeof *prev);
    m->lpath_off = mdl__calloc((size_t)L + 1, sizeof *m->lpath_off);
    m->lpath = mdl__calloc((size_t)L * (P + 1) * 2, sizeof *m->lpath);
    st->part_limbs = mdl__calloc((size_t)P * L, sizeof *st->part_limbs);
    if (!prev || !m->lpath_off || !m->lpath || !st->part_limbs) {
        free(prev);
        return oom(err);
    }
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
            if (part_path(P, st->adj_off, st->adj, a, b, prev, st->queue, m->lpath, &n)) {
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
            st->part_limbs[m->lpath[i] * L + l] = 1;
    }
    m->lpath_off[L] = n;
    free(prev);
    return 0;
}

/* Stage 3c, the control points of eq. (2) in the rest pose (m->lctrl): the limb's first marker
 * vertex, the virtual joints gamma(e) at the barycentres of the vertices where successive parts
 * of its path (with overlaps) meet, and its last marker vertex. */
static int skeleton_control_points(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int L = m->nlimbs, nv = st->nv;
    uint8_t *mark = st->mark;
    m->lctrl = mdl__calloc(3 * ((size_t)m->lpath_off[L] + L), sizeof *m->lctrl);
    if (!m->lctrl)
        return oom(err);
    for (int l = 0; l < L; l++) {
        double *c = m->lctrl + 3 * ((size_t)m->lpath_off[l] + l);
        int a0 = m->limb_idx[m->limb_off[l]], a1 = m->limb_idx[m->limb_off[l + 1] - 1], k = 1;
        for (int x = 0; x < 3; x++)
            c[x] = m->rest[3 * m->markers[a0].vertex + x];
        for (int i = m->lpath_off[l]; i + 1 < m->lpath_off[l + 1]; i++, k++) {
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
    return 0;
}

/* Stage 3d, instances (Sec. 5.3): a part off every limb path joins the nearest limb in H (BFS
 * from all path parts); a part in several limbs (a shared cluster) gets one instance per limb
 * (m->inst_part, inst_limb, inst_shared). */
static int skeleton_instances(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int P = m->nparts, L = m->nlimbs;
    int *part_limbs = st->part_limbs, *queue = st->queue;
    int *nearest = mdl__calloc((size_t)P, sizeof *nearest);
    if (!nearest)
        return oom(err);
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
        for (int i = st->adj_off[p]; i < st->adj_off[p + 1]; i++)
            if (nearest[st->adj[i]] < 0) {
                nearest[st->adj[i]] = nearest[p];
                queue[tail++] = st->adj[i];
            }
    }
    for (int p = 0; p < P; p++) {
        int any = 0;
        for (int l = 0; l < L; l++)
            any |= part_limbs[p * L + l];
        if (!any)
            part_limbs[p * L + (nearest[p] >= 0 ? nearest[p] : 0)] = 1;
    }
    free(nearest);
    int NI = 0;
    for (int i = 0; i < P * L; i++)
        NI += part_limbs[i];
    m->ninst = NI;
    m->inst_part = mdl__calloc((size_t)NI, sizeof *m->inst_part);
    m->inst_limb = mdl__calloc((size_t)NI, sizeof *m->inst_limb);
    m->inst_out = mdl__calloc((size_t)NI, sizeof *m->inst_out);
    m->inst_shared = mdl__calloc((size_t)NI, sizeof *m->inst_shared);
    if (!m->inst_part || !m->inst_limb || !m->inst_out || !m->inst_shared)
        return oom(err);
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
                n++;
            }
    return 0;
}

/* Stage 3, the skeleton: H, the limb paths and control points of eq. (2), the instances. */
static int train_skeleton(train_state *st, char *err)
{
    int rc;
    if ((rc = skeleton_graph(st, err)) || (rc = skeleton_limb_paths(st, err)) ||
        (rc = skeleton_control_points(st, err)) || (rc = skeleton_instances(st, err)))
        return rc;
    return 0;
}

/* Stage 4, pose parameters of every part (Sec. 4.4): the rigid transform (R, t) that best maps the
 * part's vertices in the reference frame (the first training frame) onto those of frame f, all in
 * the body frame (absolute orientation, rigid.h): st->pR, st->pt. */
static int train_part_poses(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int P = m->nparts, T = st->T, nv = st->nv, maxn = 0;
    for (int p = 0; p < P; p++)
        if (m->pv_off[p + 1] - m->pv_off[p] > maxn)
            maxn = m->pv_off[p + 1] - m->pv_off[p];
    st->pR = mdl__calloc((size_t)P * T * 9, sizeof *st->pR);
    st->pt = mdl__calloc((size_t)P * T * 3, sizeof *st->pt);
    double *ybuf = mdl__calloc((size_t)3 * maxn, sizeof *ybuf);
    double *xbuf = mdl__calloc((size_t)3 * maxn, sizeof *xbuf);
    if (!st->pR || !st->pt || !ybuf || !xbuf) {
        free(ybuf);
        free(xbuf);
        return oom(err);
    }
    for (int p = 0; p < P; p++) {
        int n = m->pv_off[p + 1] - m->pv_off[p];
        const int *idx = m->pv_idx + m->pv_off[p];
        for (int i = 0; i < n; i++)
            memcpy(ybuf + 3 * i, st->X + 3 * (size_t)idx[i], 3 * sizeof(double));
        for (int f = 0; f < T; f++) {
            const double *Xf = st->X + (size_t)f * nv * 3;
            for (int i = 0; i < n; i++)
                memcpy(xbuf + 3 * i, Xf + 3 * (size_t)idx[i], 3 * sizeof(double));
            mdl__kabsch(ybuf, xbuf, NULL, n, st->pR + ((size_t)p * T + f) * 9,
                        st->pt + ((size_t)p * T + f) * 3);
        }
    }
    free(ybuf);
    free(xbuf);
    return 0;
}

/* Stage 5, shape models (Sec. 4.4, eq. 6): per part, every frame taken back into the part's local
 * frame, x_local = R^T (x - t), then PCA (shape.c): mean x_bar, eigenshapes V and variances
 * sigma^2, keeping opts->explained of the variance and at most opts->max_modes modes. */
static int train_shape_models(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    const mdl_train_opts *opts = st->opts;
    int P = m->nparts, T = st->T, nv = st->nv, maxn = 0, rc = 0;
    for (int p = 0; p < P; p++)
        if (m->pv_off[p + 1] - m->pv_off[p] > maxn)
            maxn = m->pv_off[p + 1] - m->pv_off[p];
    m->pmodes = mdl__calloc((size_t)P, sizeof *m->pmodes);
    m->pm_off = mdl__calloc((size_t)P + 1, sizeof *m->pm_off);
    m->ps_off = mdl__calloc((size_t)P + 1, sizeof *m->ps_off);
    m->part_explained = mdl__calloc((size_t)P, sizeof *m->part_explained);
    m->part_mean = mdl__calloc(3 * (size_t)m->pv_off[P], sizeof *m->part_mean);
    double **pmodes = mdl__calloc((size_t)P, sizeof *pmodes);
    double **psig = mdl__calloc((size_t)P, sizeof *psig);
    double *Xl = mdl__calloc((size_t)3 * maxn * T, sizeof *Xl);
    double *mean = mdl__calloc((size_t)3 * maxn, sizeof *mean);
    if (!m->pmodes || !m->pm_off || !m->ps_off || !m->part_explained || !m->part_mean || !pmodes ||
        !psig || !Xl || !mean) {
        rc = oom(err);
        goto out;
    }
    int mo = 0;
    for (int p = 0; p < P; p++) {
        progress(opts, "shape models", (double)p / P);
        int n = m->pv_off[p + 1] - m->pv_off[p];
        const int *idx = m->pv_idx + m->pv_off[p];
        for (int f = 0; f < T; f++) {
            const double *Xf = st->X + (size_t)f * nv * 3;
            const double *R = st->pR + ((size_t)p * T + f) * 9, *t = st->pt + ((size_t)p * T + f) * 3;
            double *col = Xl + (size_t)f * 3 * n;
            for (int i = 0; i < n; i++) { /* local = R^T (x - t) */
                const double *x = Xf + 3 * (size_t)idx[i];
                double d[3] = {x[0] - t[0], x[1] - t[1], x[2] - t[2]};
                for (int c = 0; c < 3; c++)
                    col[3 * i + c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
            }
        }
        int k;
        double expl;
        char e2[MDL_ERR_LEN];
        int r = mdl__pca(Xl, 3 * n, T, opts->explained, opts->max_modes, mean, &pmodes[p], &psig[p],
                         &k, &expl, e2);
        if (r) {
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
    m->part_modes = mdl__calloc((size_t)mo + 1, sizeof *m->part_modes);
    m->part_sigma2 = mdl__calloc((size_t)m->ps_off[P] + 1, sizeof *m->part_sigma2);
    if (!m->part_modes || !m->part_sigma2) {
        rc = oom(err);
        goto out;
    }
    for (int p = 0; p < P; p++) {
        int n = m->pv_off[p + 1] - m->pv_off[p], k = m->pmodes[p];
        for (int i = 0; i < 3 * n * k; i++)
            m->part_modes[m->pm_off[p] + i] = (float)pmodes[p][i];
        for (int j = 0; j < k; j++)
            m->part_sigma2[m->ps_off[p] + j] = psig[p][j];
    }
out:
    if (pmodes)
        for (int p = 0; p < P; p++)
            free(pmodes[p]);
    if (psig)
        for (int p = 0; p < P; p++)
            free(psig[p]);
    free(pmodes);
    free(psig);
    free(Xl);
    free(mean);
    return rc;
}

/* Stage 6, the regression targets per part and training frame (Table 1, Sec. 4.3): the part's
 * rotation as a unit quaternion (on the hemisphere of the first frame's, so that it varies
 * smoothly), its translation, both in the body frame (we regress the rotation composed along the
 * limb path directly so that errors do not accumulate along the chain), and its shape
 * coefficients s = V^T (x_local - x_bar) (eq. 6). */
static int train_targets(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int P = m->nparts, T = st->T, nv = st->nv, maxk_modes = 0;
    for (int p = 0; p < P; p++)
        if (m->pmodes[p] > maxk_modes)
            maxk_modes = m->pmodes[p];
    int tdim = st->tdim = 7 + maxk_modes; /* per part per frame */
    st->targets = mdl__calloc((size_t)P * T * tdim, sizeof *st->targets);
    if (!st->targets)
        return oom(err);
    for (int p = 0; p < P; p++) {
        int n = m->pv_off[p + 1] - m->pv_off[p], k = m->pmodes[p];
        const int *idx = m->pv_idx + m->pv_off[p];
        const float *mean = m->part_mean + 3 * (size_t)m->pv_off[p];
        double qref[4] = {0, 0, 0, 0};
        for (int f = 0; f < T; f++) {
            double *tg = st->targets + ((size_t)p * T + f) * tdim;
            const double *R = st->pR + ((size_t)p * T + f) * 9, *t = st->pt + ((size_t)p * T + f) * 3;
            double q[4];
            mdl__mat_to_quat(R, q);
            if (f == 0)
                memcpy(qref, q, sizeof q);
            if (q[0] * qref[0] + q[1] * qref[1] + q[2] * qref[2] + q[3] * qref[3] < 0)
                for (int c = 0; c < 4; c++)
                    q[c] = -q[c];
            memcpy(tg, q, sizeof q);
            memcpy(tg + 4, t, 3 * sizeof(double));
            const double *Xf = st->X + (size_t)f * nv * 3;
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
    return 0;
}

/* Stage 7a, a marker recording of another performer (Sec. 4.2): its markers in the model's order,
 * sampled at most ~25 Hz (consecutive mocap frames are near-duplicates, which would let
 * leave-one-out choose an over-fitting regulariser) and at most 4000 samples; invalid samples are
 * held at the last valid position. Also the recording's secondary body axis and its first body
 * frame, the reference of ground-locked placement (steer_internal.h, place_mode). */
static int train_recording(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    const mdl_markers *markers = st->markers;
    int nm = st->nm;
    int *mk_map = mdl__calloc((size_t)nm, sizeof *mk_map);
    if (!mk_map)
        return oom(err);
    for (int j = 0; j < nm; j++) {
        mk_map[j] = mdl_markers_find(markers, m->markers[j].source);
        if (mk_map[j] < 0) {
            free(mk_map);
            return mdl__err(err, -EINVAL,
                            "train: rig marker '%s' wants source '%s', which the marker file does "
                            "not have",
                            m->markers[j].name, m->markers[j].source);
        }
    }
    m->place_mode = 1;
    int stride = markers->fps > 37.5 ? (int)lround(markers->fps / 25.0) : 1;
    if (markers->frames / stride > 4000)
        stride = (markers->frames + 3999) / 4000;
    int FM = (markers->frames + stride - 1) / stride;
    st->stride = stride;
    st->FM = FM;
    st->Pm = mdl__calloc((size_t)FM * nm * 3, sizeof *st->Pm);
    st->lmap = mdl__calloc((size_t)FM, sizeof *st->lmap);
    if (!st->Pm || !st->lmap) {
        free(mk_map);
        return oom(err);
    }
    for (int j = 0; j < nm; j++) {
        int src = mk_map[j], last = -1;
        for (int f = 0; f < markers->frames && last < 0; f++)
            if (markers->valid[(size_t)f * markers->count + src])
                last = f;
        if (last < 0) {
            free(mk_map);
            return mdl__err(err, -EINVAL, "train: marker '%s' is never valid in the recording",
                            m->markers[j].source);
        }
        for (int i = 0; i < FM; i++) {
            int f = i * stride;
            for (int ff = last + 1; ff <= f; ff++)
                if (markers->valid[(size_t)ff * markers->count + src])
                    last = ff;
            memcpy(st->Pm + ((size_t)i * nm + j) * 3,
                   markers->P + ((size_t)last * markers->count + src) * 3, 3 * sizeof(float));
        }
    }
    free(mk_map);
    m->axis_rec = mdl__ref_axis(st->Pm, FM, (size_t)nm * 3, m->ref);
    if (m->axis_rec == 1 && m->nref == 2) {
        m->hd_rec = mdl__calloc((size_t)nm * 4, sizeof *m->hd_rec);
        if (!m->hd_rec)
            return oom(err);
        int rc = mdl__heading_train(st->Pm, FM, (size_t)nm * 3, nm, m->ref, 0, m->hd_rec);
        if (rc)
            return mdl__err(err, rc, "train: the recording's heading fit failed (%d)", rc);
        m->axis_rec = MDL_AXIS_FIT;
    }
    double R[9], o[3];
    if (mdl__body_frame_any(st->Pm, NULL, nm, m->nref, m->ref, m->axis_rec, m->hd_rec, R, o))
        return mdl__err(err, -EINVAL, "train: the reference markers coincide in recording frame %d", 0);
    m->rec_heading = mdl__body_heading(R);
    memcpy(m->rec_origin, o, sizeof o);
    return 0;
}

/* Scratch of the regression stage, sized for the largest limb. */
typedef struct reg_scratch {
    int maxd, copies, nsamp;
    float *Pn;              /* copies x T x nm x 3: noisy copies of the virtual markers */
    double *Fv;             /* d x T, column-major: features of the virtual markers */
    double *Fm;             /* d x FM: features of the recording */
    double *feat;           /* maxd */
    double *Xr;             /* d x nsamp: the regression's inputs */
} reg_scratch;

/* Stage 7b, the inputs of limb l's regression: its marker parameters (Table 1, posefeat.h) in
 * every training frame; with a recording, the recording's parameters mapped onto the mesh's by
 * pose adaption (Sec. 4.2, adapt.c: rg->feat_scale, feat_shift, and st->lmap); otherwise the
 * training frames themselves and their noisy copies. Fills sc->Xr (d x nsamp). */
static int limb_inputs(train_state *st, int l, reg_scratch *sc, char *err)
{
    struct mdl_steer *m = st->m;
    mdl_limb_reg *rg = &m->reg[l];
    int T = st->T, nm = st->nm, FM = st->FM, nsamp = sc->nsamp, rc;
    const int *path = m->limb_idx + m->limb_off[l];
    int plen = m->limb_off[l + 1] - m->limb_off[l];
    int d = rg->nin;
    double *feat = sc->feat, *Fv = sc->Fv, *Fm = sc->Fm, *Xr = sc->Xr;
    for (int i = 0; i < T; i++) {
        mdl__limb_features(st->Pv + (size_t)i * nm * 3, i > 0 ? st->Pv + (size_t)(i - 1) * nm * 3 : NULL,
                           path, plen, st->Rb + 9 * i, st->ob + 3 * i, m->use_motion_dir, feat);
        for (int j = 0; j < d; j++)
            Fv[(size_t)j * T + i] = feat[j];
    }
    if (st->markers) {
        double R[9], o[3];
        for (int i = 0; i < FM; i++) {
            const float *Pi = st->Pm + (size_t)i * nm * 3;
            if (mdl__body_frame_any(Pi, NULL, nm, m->nref, m->ref, m->axis_rec, m->hd_rec, R, o))
                return mdl__err(err, -EINVAL,
                                "train: the reference markers coincide in recording frame %d",
                                i * st->stride);
            mdl__limb_features(Pi, i > 0 ? Pi - (size_t)nm * 3 : NULL, path, plen, R, o,
                               m->use_motion_dir, feat);
            for (int j = 0; j < d; j++)
                Fm[(size_t)j * FM + i] = feat[j];
        }
        if ((rc = mdl__adapt_limb(Fm, FM, Fv, T, d, 4, rg->feat_scale, rg->feat_shift, st->lmap, err)))
            return rc;
        for (int j = 0; j < d; j++)
            for (int i = 0; i < FM; i++)
                Xr[(size_t)j * FM + i] = rg->feat_scale[j] * Fm[(size_t)j * FM + i] + rg->feat_shift[j];
        return 0;
    }
    for (int j = 0; j < d; j++) {
        rg->feat_scale[j] = 1;
        rg->feat_shift[j] = 0;
    }
    for (int j = 0; j < d; j++)
        memcpy(Xr + (size_t)j * nsamp, Fv + (size_t)j * T, sizeof(double) * (size_t)T);
    for (int a = 0; a < sc->copies; a++)
        for (int i = 0; i < T; i++) {
            const float *Pi = sc->Pn + ((size_t)a * T + i) * nm * 3;
            double R[9], o[3];
            if (mdl__body_frame_any(Pi, NULL, nm, m->nref, m->ref, m->axis_mesh, m->hd_mesh, R, o)) {
                memcpy(R, st->Rb + 9 * i, sizeof R);
                memcpy(o, st->ob + 3 * i, sizeof o);
            }
            mdl__limb_features(Pi, i > 0 ? Pi - (size_t)nm * 3 : NULL, path, plen, R, o,
                               m->use_motion_dir, feat);
            for (int j = 0; j < d; j++)
                Xr[(size_t)j * nsamp + (size_t)(a + 1) * T + i] = feat[j];
        }
    return 0;
}

/* Stage 7c, limb l's regression Phi^l, Psi^l of eq. (1)/(5) (regress.c): from its inputs to the
 * pose and shape targets of all its instances, q (4), t (3), s (k) each (m->inst_out gives their
 * offsets). Each output is weighted by what an error in it costs in vertex space: a quaternion
 * error dq turns the part by about 2|dq| radians, moving n_p vertices at RMS radius r_p; a
 * translation error moves n_p vertices; shape coefficients are lengths along unit modes. */
static int limb_regression(train_state *st, int l, const reg_scratch *sc, char *err)
{
    struct mdl_steer *m = st->m;
    const mdl_train_opts *opts = st->opts;
    mdl_limb_reg *rg = &m->reg[l];
    int NI = m->ninst, T = st->T, nsamp = sc->nsamp, tdim = st->tdim, rc;
    int q = 0;
    for (int i = 0; i < NI; i++)
        if (m->inst_limb[i] == l) {
            m->inst_out[i] = q;
            q += 7 + m->pmodes[m->inst_part[i]];
        }
    rg->nout = q;
    double *Yr = mdl__calloc((size_t)nsamp * q, sizeof *Yr);
    double *colw = mdl__calloc((size_t)q, sizeof *colw);
    if (!Yr || !colw) {
        free(Yr);
        free(colw);
        return oom(err);
    }
    for (int i = 0; i < NI; i++) {
        if (m->inst_limb[i] != l)
            continue;
        int p = m->inst_part[i], k = m->pmodes[p];
        for (int s = 0; s < nsamp; s++) {
            int f = st->markers ? st->lmap[s] : s % T;
            const double *tg = st->targets + ((size_t)p * T + f) * tdim;
            for (int c = 0; c < 7 + k; c++)
                Yr[(size_t)(m->inst_out[i] + c) * nsamp + s] = tg[c];
        }
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
    int use_rbf = opts->linear < 0 ? st->markers == NULL : !opts->linear;
    rc = mdl__regression_fit(sc->Xr, nsamp, rg->nin, Yr, q, opts->ridge, colw, sc->copies ? T : 0,
                             use_rbf, &rg->zmean, &rg->zsd, &rg->cent, &rg->ncent, &rg->width,
                             &rg->in_mean, &rg->in_sd, &rg->coef, &rg->ridge, &rg->rms_train,
                             &rg->rms_loo, err);
    free(Yr);
    free(colw);
    return rc;
}

/* Stage 7, the regressions, one per limb (Sec. 4.2-4.3). With virtual markers and
 * opts->train_noise > 0, noisy copies of every training frame teach the regressions that marker
 * noise of about train_noise metres should not move the result (data augmentation in place of a
 * noise model): copy a > 0 of frame i has every marker jittered. */
static int train_regressions(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    const mdl_train_opts *opts = st->opts;
    int L = m->nlimbs, T = st->T, nm = st->nm, FM = st->FM, rc = 0;
    reg_scratch sc = {0};
    m->reg = mdl__calloc((size_t)L, sizeof *m->reg);
    if (!m->reg)
        return oom(err);
    for (int l = 0; l < L; l++) {
        int d = mdl__limb_nfeat(m->limb_off[l + 1] - m->limb_off[l], m->use_motion_dir);
        if (d > sc.maxd)
            sc.maxd = d;
    }
    int copies = !st->markers && opts->train_noise > 0 ? opts->noise_copies : 0;
    if (copies > MDL_MAX_GROUP - 1)
        copies = MDL_MAX_GROUP - 1;
    if (copies < 0)
        copies = 0;
    sc.copies = copies;
    sc.nsamp = st->markers ? FM : T * (1 + copies);
    if (copies) {
        sc.Pn = mdl__calloc((size_t)T * copies * nm * 3, sizeof *sc.Pn);
        if (!sc.Pn)
            return oom(err);
        uint64_t rng = 0x5eed5eedull;
        for (size_t i = 0; i < (size_t)T * copies * nm * 3; i++)
            sc.Pn[i] = st->Pv[i % ((size_t)T * nm * 3)] + (float)(opts->train_noise * mdl__gauss(&rng));
    }
    sc.Fv = mdl__calloc((size_t)T * sc.maxd, sizeof *sc.Fv);
    sc.Fm = mdl__calloc((size_t)(FM > 0 ? FM : 1) * sc.maxd, sizeof *sc.Fm);
    sc.feat = mdl__calloc((size_t)sc.maxd, sizeof *sc.feat);
    sc.Xr = mdl__calloc((size_t)sc.nsamp * sc.maxd, sizeof *sc.Xr);
    if (!sc.Fv || !sc.Fm || !sc.feat || !sc.Xr) {
        rc = oom(err);
        goto out;
    }
    for (int l = 0; l < L; l++) {
        progress(opts, "regression", (double)l / L);
        mdl_limb_reg *rg = &m->reg[l];
        rg->nin = mdl__limb_nfeat(m->limb_off[l + 1] - m->limb_off[l], m->use_motion_dir);
        rg->feat_scale = mdl__calloc((size_t)rg->nin, sizeof *rg->feat_scale);
        rg->feat_shift = mdl__calloc((size_t)rg->nin, sizeof *rg->feat_shift);
        if (!rg->feat_scale || !rg->feat_shift) {
            rc = oom(err);
            goto out;
        }
        if ((rc = limb_inputs(st, l, &sc, err)) || (rc = limb_regression(st, l, &sc, err)))
            goto out;
    }
out:
    free(sc.Pn);
    free(sc.Fv);
    free(sc.Fm);
    free(sc.feat);
    free(sc.Xr);
    return rc;
}

/* Stage 8a, the alignment sample: how many instances hold each vertex (st->vinst_cnt); the
 * alignment and shape steps read each instance's shared vertices, and an evenly spread subset of
 * at most opts->align_samples of them per instance (and every other instance's copy of those
 * vertices, st->gsel) constrains them as well at a fraction of the per-frame cost. */
static int precompute_align_sample(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    const mdl_train_opts *opts = st->opts;
    int NI = m->ninst, nv = st->nv;
    st->vinst_cnt = mdl__calloc((size_t)nv, sizeof *st->vinst_cnt);
    st->gsel = mdl__calloc((size_t)nv, 1);
    if (!st->vinst_cnt || !st->gsel)
        return oom(err);
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i];
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            st->vinst_cnt[m->pv_idx[j]]++;
    }
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i], ns = 0;
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            ns += st->vinst_cnt[m->pv_idx[j]] > 1;
        int stride = opts->align_samples > 0 && ns > opts->align_samples
                         ? (ns + opts->align_samples - 1) / opts->align_samples
                         : 1;
        int k = 0;
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            if (st->vinst_cnt[m->pv_idx[j]] > 1 && k++ % stride == 0)
                st->gsel[m->pv_idx[j]] = 1;
    }
    return 0;
}

/* Stage 8b, the greedy alignment order (Sec. 5.1): the largest instance first, then always the one
 * with most overlap with what is placed (m->order), and each step's overlap vertices within the
 * alignment sample (m->order_ov_off, m->order_ov: local indices). */
static int precompute_order(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int NI = m->ninst, nv = st->nv, cap = 0;
    uint8_t *mark = st->mark;
    for (int i = 0; i < NI; i++)
        cap += m->pv_off[m->inst_part[i] + 1] - m->pv_off[m->inst_part[i]];
    m->order = mdl__calloc((size_t)NI, sizeof *m->order);
    m->order_ov_off = mdl__calloc((size_t)NI + 1, sizeof *m->order_ov_off);
    m->order_ov = mdl__calloc((size_t)cap + 1, sizeof *m->order_ov);
    int *placed = mdl__calloc((size_t)NI, sizeof *placed);
    if (!m->order || !m->order_ov_off || !m->order_ov || !placed) {
        free(placed);
        return oom(err);
    }
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
                if (mark[m->pv_idx[j]] && st->gsel[m->pv_idx[j]])
                    m->order_ov[n++] = j - m->pv_off[p];
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            mark[m->pv_idx[j]] = 1;
    }
    m->order_ov_off[NI] = n;
    free(placed);
    return 0;
}

/* Stage 8c, shape optimisation (Sec. 5.2, eq. 7): per instance its overlap vertices O within the
 * alignment sample (m->sov_off, m->sov) and the upper Cholesky factor of the normal matrix
 * V_O^T V_O + beta diag(1 / sigma^2), which depends only on the model (m->chol_off, m->chol). */
static int precompute_shape_factors(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    int NI = m->ninst, n = 0, c = 0, rc;
    const int *vinst_cnt = st->vinst_cnt;
    const uint8_t *gsel = st->gsel;
    m->sov_off = mdl__calloc((size_t)NI + 1, sizeof *m->sov_off);
    m->chol_off = mdl__calloc((size_t)NI + 1, sizeof *m->chol_off);
    if (!m->sov_off || !m->chol_off)
        return oom(err);
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i], k = m->pmodes[p];
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
            n += vinst_cnt[m->pv_idx[j]] > 1 && gsel[m->pv_idx[j]];
        c += k * k;
    }
    m->sov = mdl__calloc((size_t)n + 1, sizeof *m->sov);
    m->chol = mdl__calloc((size_t)c + 1, sizeof *m->chol);
    if (!m->sov || !m->chol)
        return oom(err);
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
            return rc;
        c += k * k;
    }
    m->sov_off[NI] = n;
    m->chol_off[NI] = c;
    return 0;
}

/* Stage 8d, blend weights (Sec. 5.3, eq. 8): the geodesic distance d_i of every vertex of an
 * instance to its anchor (the limb boundary for shared clusters, the instance's own exclusive
 * vertices otherwise), then per vertex w_l = prod_{i != l} d_i / sum_j prod_{i != j} d_i (eq. 8
 * for two instances, its generalisation for more): m->blend_off, blend_inst, blend_local,
 * blend_w. */
static int precompute_blend(train_state *st, char *err)
{
    struct mdl_steer *m = st->m;
    const mdl_train_opts *opts = st->opts;
    int NI = m->ninst, nv = st->nv, rc = 0;
    const int *vinst_cnt = st->vinst_cnt;
    uint8_t *mark = st->mark;
    progress(opts, "blend weights", 0);
    m->blend_off = mdl__calloc((size_t)nv + 1, sizeof *m->blend_off);
    if (!m->blend_off)
        return oom(err);
    for (int v = 0; v < nv; v++)
        m->blend_off[v + 1] = m->blend_off[v] + vinst_cnt[v];
    size_t nb = (size_t)m->blend_off[nv];
    m->blend_inst = mdl__calloc(nb, sizeof *m->blend_inst);
    m->blend_local = mdl__calloc(nb, sizeof *m->blend_local);
    m->blend_w = mdl__calloc(nb, sizeof *m->blend_w);
    double *bd = mdl__calloc(nb, sizeof *bd);
    double *dist = mdl__calloc((size_t)nv, sizeof *dist);
    int *fill = mdl__calloc((size_t)nv, sizeof *fill);
    int *src = mdl__calloc((size_t)nv, sizeof *src);
    uint8_t *in_limb = mdl__calloc((size_t)nv, 1);
    if (!m->blend_inst || !m->blend_local || !m->blend_w || !bd || !dist || !fill || !src || !in_limb) {
        rc = oom(err);
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
        if ((rc = mdl__geodesic(&st->g, m->rest, src, ns, mark, dist, err)))
            goto out;
        for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++) {
            int v = m->pv_idx[j], s = m->blend_off[v] + fill[v]++;
            m->blend_inst[s] = i;
            m->blend_local[s] = j - m->pv_off[p];
            bd[s] = dist[v];
        }
    }
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
out:
    free(bd);
    free(dist);
    free(fill);
    free(src);
    free(in_limb);
    return rc;
}

/* Stage 8, precomputations for synthesis (Sec. 5). */
static int train_precompute(train_state *st, char *err)
{
    int rc;
    if ((rc = precompute_align_sample(st, err)) || (rc = precompute_order(st, err)) ||
        (rc = precompute_shape_factors(st, err)) || (rc = precompute_blend(st, err)))
        return rc;
    return 0;
}

/* The regressions of a model in training (stage 7), freed so that they can be fitted again. */
static void free_regressions(struct mdl_steer *m)
{
    if (!m->reg)
        return;
    for (int l = 0; l < m->nlimbs; l++) {
        mdl_limb_reg *rg = &m->reg[l];
        free(rg->feat_scale);
        free(rg->feat_shift);
        free(rg->zmean);
        free(rg->zsd);
        free(rg->cent);
        free(rg->in_mean);
        free(rg->in_sd);
        free(rg->coef);
    }
    free(m->reg);
    m->reg = NULL;
}

struct mdl__steer_fit {
    train_state st;
    mdl_train_opts opts;   /* the options of the stages before the regressions */
    struct timespec t0;
};

void mdl__steer_fit_end(mdl__steer_fit *f, struct mdl_steer **out)
{
    if (!f)
        return;
    if (out && f->st.m) {
        struct timespec t1;
        clock_gettime(CLOCK_MONOTONIC, &t1);
        f->st.m->train_seconds = (double)(t1.tv_sec - f->t0.tv_sec) +
                                 1e-9 * (double)(t1.tv_nsec - f->t0.tv_nsec);
        *out = f->st.m;
        f->st.m = NULL;
    }
    mdl__steer_free(f->st.m);
    train_state_fini(&f->st);
    free(f);
}

int mdl__steer_fit_begin(const mdl_meshseq *seq, const int *frames, int nframes, const mdl_rig *rig,
                         const mdl_markers *markers, const mdl_train_opts *opts,
                         const mdl__steer_parts *given, int snap_k, mdl__steer_fit **out,
                         char *err)
{
    *out = NULL;
    mdl__steer_fit *f = mdl__calloc(1, sizeof *f);
    if (!f)
        return oom(err);
    clock_gettime(CLOCK_MONOTONIC, &f->t0);
    f->opts = *opts;
    f->st = (train_state){.seq = seq, .frames = frames, .T = nframes, .rig = rig, .markers = markers,
                          .opts = &f->opts, .nv = seq->nv, .nm = rig->nmarkers,
                          .given = given, .snap_k = snap_k};
    train_state *st = &f->st;
    int rc;
    if ((rc = train_setup(st, err)) || (rc = train_frames(st, err)) || (rc = train_parts(st, err)) ||
        (rc = train_skeleton(st, err)) || (rc = train_part_poses(st, err)) ||
        (rc = train_shape_models(st, err)) || (rc = train_targets(st, err)) ||
        (markers && (rc = train_recording(st, err))) || (rc = train_precompute(st, err))) {
        mdl__steer_fit_end(f, NULL);
        return rc;
    }
    *out = f;
    return 0;
}

int mdl__steer_fit_regress(mdl__steer_fit *f, const mdl_train_opts *o, char *err)
{
    train_state *st = &f->st;
    free_regressions(st->m);
    f->opts.use_motion_dir = o->use_motion_dir;
    f->opts.linear = o->linear;
    f->opts.ridge = o->ridge;
    f->opts.train_noise = o->train_noise;
    f->opts.noise_copies = o->noise_copies;
    st->m->use_motion_dir = o->use_motion_dir;
    /* the input filter (synthesis only, mfilter.h), from the rig's motion in the training frames */
    struct mdl_steer *m = st->m;
    free(m->mfilt);
    m->mfilt = NULL;
    m->filter_noise = 0;
    if (!st->markers && o->filter_noise > 0) {
        m->mfilt = mdl__calloc((size_t)st->nm * 2, sizeof *m->mfilt);
        if (!m->mfilt)
            return oom(err);
        mdl__mfilter_train(st->Pv, st->T, (size_t)st->nm * 3, st->nm, o->filter_noise, m->mfilt);
        m->filter_noise = o->filter_noise;
    }
    /* the kernel blend (kblend.h): the training meshes and their rig vertices */
    free(m->kb_V);
    free(m->kb_mk);
    m->kb_V = m->kb_mk = NULL;
    m->kb_h = 0;
    if (!st->markers && o->kblend > 0) {
        size_t fr = (size_t)st->nv * 3;
        m->kb_V = mdl__calloc((size_t)st->T * fr, sizeof *m->kb_V);
        m->kb_mk = mdl__calloc((size_t)st->T * st->nm * 3, sizeof *m->kb_mk);
        if (!m->kb_V || !m->kb_mk)
            return oom(err);
        for (int i = 0; i < st->T; i++)
            memcpy(m->kb_V + i * fr, st->seq->V + (size_t)st->frames[i] * fr, fr * sizeof(float));
        memcpy(m->kb_mk, st->Pv, sizeof(float) * (size_t)st->T * st->nm * 3);
        m->kb_h = o->kblend;
    }
    return train_regressions(st, err);
}

const struct mdl_steer *mdl__steer_fit_model(const mdl__steer_fit *f)
{
    return f->st.m;
}

mdl__steer_parts mdl__steer_fit_parts(const mdl__steer_fit *f)
{
    return (mdl__steer_parts){f->st.m->nparts, f->st.m->part, f->st.m->part_rms};
}

mdl__steer_parts mdl__steer_fit_snap(const mdl__steer_fit *f)
{
    return f->st.snap;
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
    mdl_train_opts ro;
    mdl_select_result *sel = NULL;
    int rc;
    if (!markers && opts->select_folds > 0) { /* the options left at -1 chosen by the data */
        sel = mdl__calloc(1, sizeof *sel);
        if (!sel)
            return oom(err);
        progress(opts, "option selection", 0);
        if ((rc = mdl__steer_select(seq, frames, nframes, rig, opts, &ro, sel, err))) {
            free(sel);
            return rc;
        }
        if (sel->folds == 0) {
            free(sel);
            sel = NULL;
        }
    } else {
        mdl__train_opts_resolve(opts, &ro);
    }
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    mdl__steer_fit *f;
    if ((rc = mdl__steer_fit_begin(seq, frames, nframes, rig, markers, &ro, NULL, 0, &f, err))) {
        free(sel);
        return rc;
    }
    if ((rc = mdl__steer_fit_regress(f, &ro, err))) {
        mdl__steer_fit_end(f, NULL);
        free(sel);
        return rc;
    }
    progress(opts, "done", 1);
    mdl__steer_fit_end(f, out);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    /* the training time includes the selection */
    (*out)->train_seconds = (sel ? sel->seconds : 0) + (double)(t1.tv_sec - t0.tv_sec) +
                            1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    (*out)->sel = sel;
    return 0;
}
