/* transitions.c - candidate transitions of one example animation (Zheng 2013 Sec. 3.2), on the
 * bones of its skin (model.h mdl_variations_build).
 *
 *   reference bone   b_r = argmax_b sum_i w_ib (the most influential bone)
 *   eq. (2)          R_i->r(t) = R_r(t)^T R_i(t),  t_i->r(t) = R_r(t)^T (t_i(t) - t_r(t))
 *   eq. (3)          A_r = [p_b^t], p_b^t = [t_b->r(t); Phi(R_b->r(t))], 6 (|B| - 1) x N over the
 *                    non-reference bones (the reference bone's own row is identically zero)
 *   eq. (4)          A_r ~ U_r S_r V_r^T = U_r Q_r, truncated where s_k < svd_tol s_1 (0.005);
 *                    q_t = column t of Q_r = S_r V_r^T
 *   eq. (6)          r_t = [R_r(t)^T (t_r(t-1) - t_r(t)); Phi(R_r(t)^T R_r(t-1))]
 *   eq. (5)          D(i, j) = |q_i - q_j|^2 + alpha |qdot_i - qdot_j|^2 + beta |r_i - r_j|^2,
 *                    qdot_t = q_t - q_{t-1}, alpha = max |q|^2 / max |qdot|^2,
 *                    beta = max |q|^2 / max |r|^2
 *   candidates       D(i, j) < T_c = tc_factor max_i D(i, i-1); the printed text says 40, we
 *                    default to 1/40 (docs/MODEL.md: with any D that is a squared distance
 *                    between smoothly changing states, 40 max_i D(i, i-1) admits every pair of
 *                    frames up to about 6 apart, and on horse-gallop and samba it is above the
 *                    largest D of all pairs, while 1/40 gives the horse exactly its pairs of
 *                    corresponding frames, the paper's finding)
 * (the printed text of alpha reads max|q|^2 / max|q|^2; balancing the terms "so that none of them
 * dominates" needs the velocity's maximum below, as beta has the r's.)
 * D needs frames i - 1 and j - 1, so frame 0 is no endpoint. Where the paper keeps every pair below
 * T_c, we keep, per source frame i, the local minima of D(i, .) with |i - j| > min_gap: T_c is 40
 * times a neighbour's cost, so every frame's own neighbours would pass it, and a valley of D
 * would give a run of near-duplicate transitions. A target j needs a frame j + 1 to continue with.
 * Then the frames from which a walk can go on for ever (alive) are found by a fixed point
 * (Kovar 2002's pruning to the part of the graph without dead ends).
 * Analysis, not a per-frame path: it allocates freely. */
#include "variations/variations.h"
#include "kind.h"
#include "skin/skin_internal.h"
#include "core/linalg.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void mdl_variations_opts_default(mdl_variations_opts *o)
{
    memset(o, 0, sizeof *o);
    o->svd_tol = 0.005;
    o->tc_factor = 1.0 / 40;
    o->threshold = 0;
    o->min_gap = 3;
    o->blend = 8;
    o->blend_linear = 1; /* the gradient blend is as smooth on our data at 40x the cost: MODEL.md */
    o->jump_prob = 0.2;
    o->temperature = 0.1;
    o->min_segment = 8;
    o->start = -1;
    o->components = 1;
    o->te_factor = 0.1;
}

void mdl_variations_destroy(mdl_variations *v)
{
    if (!v)
        return;
    free(v->T);
    free(v->LR);
    free(v->Lt);
    free(v->Q);
    free(v->rvec);
    free(v->off);
    free(v->to);
    free(v->cost);
    free(v->alive);
    free(v->rest);
    free(v->bone);
    free(v->w);
    free(v->centre);
    free(v->wsum);
    mdl__gblend_fini(v);
    mdl__components_fini(v);
    free(v);
}

static double sq_dist(const double *a, const double *b, int n)
{
    double s = 0;
    for (int k = 0; k < n; k++)
        s += (a[k] - b[k]) * (a[k] - b[k]);
    return s;
}

double mdl__variations_cost(const struct mdl_variations *v, int i, int j)
{
    int r = v->rank;
    const double *qi = v->Q + (size_t)r * i, *qj = v->Q + (size_t)r * j;
    double a = 0, b = 0;
    for (int k = 0; k < r; k++) {
        double d = qi[k] - qj[k];
        double dd = (qi[k] - qi[k - r]) - (qj[k] - qj[k - r]);
        a += d * d;
        b += dd * dd;
    }
    return a + v->alpha * b + v->beta * sq_dist(v->rvec + 6 * (size_t)i, v->rvec + 6 * (size_t)j, 6);
}

double mdl_variations_cost(const mdl_variations *v, int i, int j)
{
    if (!v || i < 1 || j < 1 || i >= v->nframes || j >= v->nframes)
        return NAN;
    return mdl__variations_cost(v, i, j);
}

void mdl_variations_get_stats(const mdl_variations *v, mdl_variations_stats *st)
{
    memset(st, 0, sizeof *st);
    st->bones = v->nb;
    st->frames = v->nframes;
    st->ref_bone = v->ref;
    st->rank = v->rank;
    st->transitions = v->ntrans;
    st->alive_frames = v->nalive;
    st->alpha = v->alpha;
    st->beta = v->beta;
    st->max_adjacent = v->max_adjacent;
    st->tc = v->tc;
    st->components = v->ncomp > 1 ? v->ncomp : 1;
    st->single_transitions = v->ntrans;
    st->key_vertices = v->nkey;
    if (v->ncomp > 1) {
        st->transitions = 0;
        st->key_vertices = 0;
        for (int c = 0; c < v->ncomp; c++) {
            st->transitions += v->comp[c].g->ntrans;
            st->key_vertices += v->comp[c].g->nkey;
        }
    }
}

int mdl_variations_transition(const mdl_variations *v, int k, int *from, int *to, double *cost)
{
    if (!v || k < 0 || k >= v->ntrans)
        return -ERANGE;
    int i = 0;
    while (v->off[i + 1] <= k)
        i++;
    if (from)
        *from = i;
    if (to)
        *to = v->to[k];
    if (cost)
        *cost = v->cost[k];
    return 0;
}

/* eq. (2) for every frame and bone, and r_t of eq. (6) */
static void local_frames(struct mdl_variations *v)
{
    int nb = v->nb;
    for (int t = 0; t < v->nframes; t++) {
        const double *Tr = v->T + 12 * ((size_t)t * nb + v->ref);
        for (int b = 0; b < nb; b++) {
            const double *Tb = v->T + 12 * ((size_t)t * nb + b);
            double *R = v->LR + 9 * ((size_t)t * nb + b), *tl = v->Lt + 3 * ((size_t)t * nb + b);
            double d[3] = {Tb[9] - Tr[9], Tb[10] - Tr[10], Tb[11] - Tr[11]};
            for (int r = 0; r < 3; r++) {
                for (int c = 0; c < 3; c++)
                    R[3 * r + c] = Tr[r] * Tb[c] + Tr[3 + r] * Tb[3 + c] + Tr[6 + r] * Tb[6 + c];
                tl[r] = Tr[r] * d[0] + Tr[3 + r] * d[1] + Tr[6 + r] * d[2];
            }
        }
        double *rv = v->rvec + 6 * (size_t)t;
        if (t == 0) {
            memset(rv, 0, 6 * sizeof *rv);
            continue;
        }
        const double *Tp = v->T + 12 * ((size_t)(t - 1) * nb + v->ref);
        double d[3] = {Tp[9] - Tr[9], Tp[10] - Tr[10], Tp[11] - Tr[11]}, M[9];
        for (int r = 0; r < 3; r++) {
            rv[r] = Tr[r] * d[0] + Tr[3 + r] * d[1] + Tr[6 + r] * d[2];
            for (int c = 0; c < 3; c++)
                M[3 * r + c] = Tr[r] * Tp[c] + Tr[3 + r] * Tp[3 + c] + Tr[6 + r] * Tp[6 + c];
        }
        mdl__so3_log(M, rv + 3);
    }
}

/* eq. (3)-(4): Q (nframes x rank) */
static int reduce(struct mdl_variations *v, char *err)
{
    int N = v->nframes, m = 6 * (v->nb - 1), mn = m < N ? m : N;
    double *A = mdl__calloc((size_t)m * N, sizeof *A), *s = mdl__calloc(mn, sizeof *s);
    double *U = mdl__calloc((size_t)m * mn, sizeof *U), *VT = mdl__calloc((size_t)mn * N, sizeof *VT);
    int rc = 0;
    if (!A || !s || !U || !VT) {
        rc = mdl__err(err, -ENOMEM, "variations: out of memory");
        goto out;
    }
    for (int t = 0; t < N; t++)
        for (int b = 0, row = 0; b < v->nb; b++) {
            if (b == v->ref)
                continue;
            double *col = A + (size_t)m * t + row;
            memcpy(col, v->Lt + 3 * ((size_t)t * v->nb + b), 3 * sizeof *col);
            mdl__so3_log(v->LR + 9 * ((size_t)t * v->nb + b), col + 3);
            row += 6;
        }
    rc = mdl_la_gesvd(m, N, A, m, s, U, m, VT, mn, err);
    if (rc)
        goto out;
    int r = 0;
    while (r < mn && s[r] > 0 && s[r] >= v->o.svd_tol * s[0])
        r++;
    if (r < 1)
        r = 1;
    v->rank = r;
    v->Q = mdl__calloc((size_t)N * r, sizeof *v->Q);
    if (!v->Q) {
        rc = mdl__err(err, -ENOMEM, "variations: out of memory");
        goto out;
    }
    for (int t = 0; t < N; t++)
        for (int k = 0; k < r; k++)
            v->Q[(size_t)r * t + k] = s[k] * VT[k + (size_t)mn * t];
out:
    free(A);
    free(s);
    free(U);
    free(VT);
    return rc;
}

/* eq. (5) weights, T_c, the candidates, and the frames without dead ends */
static int find_transitions(struct mdl_variations *v, char *err)
{
    int N = v->nframes, r = v->rank;
    double mq = 0, mqd = 0, mr = 0;
    for (int t = 0; t < N; t++) {
        const double *q = v->Q + (size_t)r * t;
        double a = 0, b = 0;
        for (int k = 0; k < r; k++) {
            a += q[k] * q[k];
            if (t > 0)
                b += (q[k] - q[k - r]) * (q[k] - q[k - r]);
        }
        mq = fmax(mq, a);
        mqd = fmax(mqd, b);
        const double zero[6] = {0};
        mr = fmax(mr, sq_dist(v->rvec + 6 * (size_t)t, zero, 6));
    }
    v->alpha = mqd > 0 ? mq / mqd : 0;
    v->beta = mr > 0 ? mq / mr : 0;
    double *D = mdl__calloc((size_t)N * N, sizeof *D);
    if (!D)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    for (int i = 1; i < N; i++)
        for (int j = 1; j < N; j++)
            D[(size_t)N * i + j] = mdl__variations_cost(v, i, j);
    v->max_adjacent = 0;
    for (int i = 2; i < N; i++)
        v->max_adjacent = fmax(v->max_adjacent, D[(size_t)N * i + i - 1]);
    v->tc = v->o.threshold > 0 ? v->o.threshold : v->o.tc_factor * v->max_adjacent;
    v->off = mdl__calloc((size_t)N + 1, sizeof *v->off);
    v->to = mdl__calloc((size_t)N * N, sizeof *v->to);
    v->cost = mdl__calloc((size_t)N * N, sizeof *v->cost);
    v->alive = mdl__calloc(N, sizeof *v->alive);
    if (!v->off || !v->to || !v->cost || !v->alive) {
        free(D);
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    }
    int n = 0;
    for (int i = 0; i < N; i++) {
        v->off[i] = n;
        if (i < 1)
            continue;
        const double *row = D + (size_t)N * i;
        for (int j = 2; j + 1 < N; j++) {
            if (abs(i - j) <= v->o.min_gap || !(row[j] < v->tc))
                continue;
            if (row[j - 1] < row[j] || row[j + 1] < row[j])
                continue;
            v->to[n] = j;
            v->cost[n] = row[j];
            n++;
        }
    }
    v->off[N] = n;
    v->ntrans = n;
    free(D);
    mdl__variations_alive(v, NULL);
    return 0;
}

void mdl__variations_alive(struct mdl_variations *v, const uint8_t *blocked)
{
    int N = v->nframes;
    /* alive: a successor (i + 1, or j + 1 of a transition (i, j)) is alive; fixed point from all
     * frames not blocked */
    for (int i = 0; i < N; i++)
        v->alive[i] = !blocked || !blocked[i];
    for (int changed = 1; changed;) {
        changed = 0;
        for (int i = N - 1; i >= 0; i--) {
            if (!v->alive[i])
                continue;
            int ok = i + 1 < N && v->alive[i + 1];
            for (int k = v->off[i]; !ok && k < v->off[i + 1]; k++)
                ok = v->alive[v->to[k] + 1];
            if (!ok) {
                v->alive[i] = 0;
                changed = 1;
            }
        }
    }
    v->nalive = 0;
    for (int i = 0; i < N; i++)
        v->nalive += v->alive[i];
}

int mdl__variations_analyse(struct mdl_variations *v, char *err)
{
    v->ref = 0;
    for (int b = 1; b < v->nb; b++)
        if (v->wsum[b] > v->wsum[v->ref])
            v->ref = b;
    size_t nt = (size_t)v->nframes * v->nb;
    v->LR = mdl__calloc(9 * nt, sizeof *v->LR);
    v->Lt = mdl__calloc(3 * nt, sizeof *v->Lt);
    v->rvec = mdl__calloc(6 * (size_t)v->nframes, sizeof *v->rvec);
    if (!v->LR || !v->Lt || !v->rvec)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    local_frames(v);
    int rc = reduce(v, err);
    if (!rc)
        rc = find_transitions(v, err);
    return rc;
}

int mdl_variations_build(const mdl_model *m, const mdl_variations_opts *o, mdl_variations **out,
                         char *err)
{
    *out = NULL;
    int nb, K, N;
    const int *bone;
    const double *w, *T;
    if (mdl_skin_get(m, &nb, &K, &N, &bone, &w, &T))
        return mdl__err(err, -ENOENT, "variations: the model holds no skin");
    if (N < 4)
        return mdl__err(err, -EDOM, "variations: the skin has %d frames; at least 4 are needed", N);
    if (nb < 2)
        return mdl__err(err, -EDOM, "variations: the skin has %d bone; at least 2 are needed", nb);
    if (N > 16384) /* D is N x N doubles */
        return mdl__err(err, -EDOM, "variations: the skin has %d frames; at most 16384", N);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    struct mdl_variations *v = mdl__calloc(1, sizeof *v);
    if (!v)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    if (o)
        v->o = *o;
    else
        mdl_variations_opts_default(&v->o);
    if (!(v->o.svd_tol >= 0 && v->o.svd_tol < 1) || v->o.min_gap < 0 || v->o.blend < 0 ||
        !(v->o.jump_prob >= 0 && v->o.jump_prob <= 1) || !(v->o.temperature >= 0) || v->o.min_segment < 0 ||
        v->o.start >= N || !(v->o.tc_factor > 0 || v->o.threshold > 0) ||
        v->o.components < 0 || v->o.components > 1 || v->o.ground < 0 || v->o.ground > 1 ||
        v->o.blend_linear < 0 || v->o.blend_linear > 1 || !(v->o.te_factor >= 0 && v->o.te_factor <= 1)) {
        mdl_variations_destroy(v);
        return mdl__err(err, -EINVAL, "variations: options out of range");
    }
    v->nb = nb;
    v->nframes = N;
    v->nv = info.nv;
    v->K = K;
    size_t nt = (size_t)N * nb, nk = (size_t)info.nv * K;
    v->T = mdl__calloc(12 * nt, sizeof *v->T);
    v->rest = mdl__calloc(3 * (size_t)info.nv, sizeof *v->rest);
    v->bone = mdl__calloc(nk, sizeof *v->bone);
    v->w = mdl__calloc(nk, sizeof *v->w);
    v->centre = mdl__calloc(3 * (size_t)nb, sizeof *v->centre);
    double *wsum = v->wsum = mdl__calloc(nb, sizeof *wsum);
    int rc = 0;
    if (!v->T || !v->rest || !v->bone || !v->w || !v->centre || !wsum) {
        rc = mdl__err(err, -ENOMEM, "variations: out of memory");
        goto out;
    }
    memcpy(v->T, T, 12 * nt * sizeof *v->T);
    memcpy(v->rest, info.rest, 3 * (size_t)info.nv * sizeof *v->rest);
    memcpy(v->bone, bone, nk * sizeof *v->bone);
    for (size_t i = 0; i < nk; i++) {
        v->w[i] = (float)w[i];
        wsum[bone[i]] += w[i];
        for (int c = 0; c < 3; c++)
            v->centre[3 * bone[i] + c] += w[i] * info.rest[3 * (i / K) + c];
    }
    for (int b = 0; b < nb; b++)
        for (int c = 0; c < 3; c++)
            v->centre[3 * b + c] = wsum[b] > 0 ? v->centre[3 * b + c] / wsum[b] : 0;
    rc = mdl__variations_analyse(v, err);
    const mdl__vskin sk = {info.nv, K, info.nf, info.rest, bone, w, info.F};
    if (!rc && !v->o.blend_linear && v->o.blend > 0)
        rc = mdl__gblend_build(v, &sk, NULL, err);
    if (!rc && v->o.components == 0)
        rc = mdl__components_build(v, bone, w, &sk, err);
out:
    if (rc) {
        mdl_variations_destroy(v);
        return rc;
    }
    *out = v;
    return 0;
}

int mdl_variations_attach(mdl_model *m, const mdl_variations_opts *o, uint64_t seed, char *err)
{
    const mdl_kind_slot *slot = mdl__model_kind(m, MDL_KIND_SKIN);
    if (!slot)
        return mdl__err(err, -ENOENT, "variations: the model holds no skin");
    mdl_variations *v = NULL;
    mdl_variations_opts one;
    if (o)
        one = *o;
    else
        mdl_variations_opts_default(&one);
    int rc = mdl_variations_build(m, &one, &v, err);
    if (rc)
        return rc;
    /* the walk the skin's synthesis will make must start (every component's graph can go on) */
    mdl__vwalk w;
    rc = mdl__vwalk_init(&w, v, seed, err);
    if (!rc)
        mdl__vwalk_fini(&w);
    mdl_variations_opts vo = v->o;
    mdl_variations_destroy(v);
    if (rc)
        return rc;
    struct mdl_skin *k = slot->impl;
    k->has_vars = 1;
    k->vars = vo; /* components, te_factor and ground included (the SKIN trailer's version 2) */
    k->vars_seed = seed;
    return 0;
}

int mdl_variations_attached(const mdl_model *m, mdl_variations_opts *o, uint64_t *seed)
{
    const mdl_kind_slot *slot = mdl__model_kind(m, MDL_KIND_SKIN);
    const struct mdl_skin *k = slot ? slot->impl : NULL;
    if (!k || !k->has_vars)
        return 0;
    if (o)
        *o = k->vars;
    if (seed)
        *seed = k->vars_seed;
    return 1;
}
