/* select.c - the steering model's options chosen by leave-a-block-out cross-validation with clean
 * and noisy markers (issue 12; the procedure is in select.h). Training, not a per-frame path: it
 * allocates freely. */
#include "steer/select.h"
#include "steer/steer_internal.h"
#include "steer/kblend.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

void mdl__train_opts_resolve(const mdl_train_opts *in, mdl_train_opts *out)
{
    *out = *in;
    if (out->use_motion_dir < 0)
        out->use_motion_dir = 0;
    if (out->overlap_rings < 0)
        out->overlap_rings = 2;
    if (out->max_modes < 0)
        out->max_modes = 6;
    if (out->max_clusters < 0)
        out->max_clusters = 24;
    if (out->filter_noise < 0)
        out->filter_noise = 0;
    if (out->train_noise < 0)
        out->train_noise = 0;
    if (out->kblend < 0)
        out->kblend = 0;
}

/* What one selection works on. */
typedef struct sel_ctx {
    const mdl_meshseq *seq;
    const mdl_rig *rig;
    int K, nv, nm;
    int *tr_off, *tr;         /* per fold: its training frames */
    int *ho_off, *ho;         /* per fold: its held-out frames, in order, as indices into frames */
    const int *frames;
    double diag;              /* rest box diagonal */
    double noise;
    float *V, *mk, *gmk, *dist; /* scratch */
    uint8_t *valid;
    double *ya, *xb;
} sel_ctx;

/* Fold k holds out the blocks b (of `block` frames) with b % K == k and trains on the rest; with
 * middle_only it is scored on the middle frame of each whole held-out block only (block odd). */
static void folds_make(sel_ctx *c, const int *frames, int n, int block, int middle_only)
{
    int K = c->K;
    c->ho_off[0] = c->tr_off[0] = 0;
    for (int k = 0; k < K; k++) {
        c->ho_off[k + 1] = c->ho_off[k];
        c->tr_off[k + 1] = c->tr_off[k];
        for (int i = 0; i < n; i++) {
            int b = i / block;
            if (b % K != k)
                c->tr[c->tr_off[k + 1]++] = frames[i];
            else if (!middle_only || (i % block == block / 2 && (b + 1) * block <= n))
                c->ho[c->ho_off[k + 1]++] = i;
        }
    }
    c->frames = frames;
}

/* The error at half the validation's spacing, from the errors at the validation's spacing (e1)
 * and at twice it (e2), for an error that follows a power of the spacing: e1 * (e1 / e2). An
 * error that does not grow with the spacing is taken as it is (select.h, step 4). */
static double half_spacing(double e1, double e2)
{
    return e2 > e1 && e1 > 0 ? e1 * e1 / e2 : e1;
}

/* Summed clean and noisy errors of a fold's model on its held-out frames, and of the nearest-frame
 * baseline among the fold's training frames (eval.c's definitions). */
static int validate(sel_ctx *c, int k, const struct mdl_steer *m, double sum[4], char *err)
{
    int nv = c->nv, nm = c->nm, rc;
    const float *SV = c->seq->V;
    for (int pass = 0; pass < 2; pass++) {
        mdl_steer_synth *s;
        if ((rc = mdl__steer_synth_create(m, &s, err)))
            return rc;
        uint64_t rng = 0x5e1ec7ull + 7919ull * (uint64_t)k;
        for (int i = c->ho_off[k]; i < c->ho_off[k + 1]; i++) {
            int h = c->ho[i];
            const float *T = SV + (size_t)c->frames[h] * nv * 3;
            /* a block's first frame: the training frame before it warms the synthesis up (its
             * motion directions), unscored, as the frame before a test frame would */
            int start = i == c->ho_off[k] || c->ho[i - 1] != h - 1;
            for (int w = start && h > 0 ? 1 : 0; w >= 0; w--) {
                const float *Q = SV + (size_t)c->frames[h - w] * nv * 3;
                for (int j = 0; j < nm; j++)
                    for (int x = 0; x < 3; x++)
                        c->mk[3 * j + x] = Q[3 * c->rig->markers[j].vertex + x] +
                                           (float)(pass ? c->noise * mdl__gauss(&rng) : 0);
                (void)mdl__steer_synth_frame(s, c->mk, c->valid, c->V, NULL); /* virtual
                    markers are all valid: the reference is never missing */
            }
            double e = mdl_rigid_aligned_error(c->V, T, nv, c->dist) / c->diag;
            sum[2 * pass] += isfinite(e) ? e : 1.0;
            double best = INFINITY;
            int bf = c->tr[c->tr_off[k]];
            for (int t = c->tr_off[k]; t < c->tr_off[k + 1]; t++) {
                const float *G = SV + (size_t)c->tr[t] * nv * 3;
                for (int j = 0; j < nm; j++)
                    for (int x = 0; x < 3; x++) {
                        c->ya[3 * j + x] = G[3 * c->rig->markers[j].vertex + x];
                        c->xb[3 * j + x] = c->mk[3 * j + x];
                    }
                double R[9], tt[3], f = mdl__kabsch(c->ya, c->xb, NULL, nm, R, tt);
                if (f < best) {
                    best = f;
                    bf = c->tr[t];
                }
            }
            sum[2 * pass + 1] += mdl_rigid_aligned_error(SV + (size_t)bf * nv * 3, T, nv, c->dist) / c->diag;
        }
        mdl__steer_synth_destroy(s);
    }
    return 0;
}

static void fits_free(mdl__steer_fit **f, int K)
{
    for (int k = 0; k < K; k++) {
        mdl__steer_fit_end(f[k], NULL);
        f[k] = NULL;
    }
}

/* The K fold models with o's options; with given (per fold) their partitions, else clustered,
 * and with snap_k > 0 the partitions for max_clusters = snap_k kept too. */
static int fits_build(sel_ctx *c, const mdl_train_opts *o, mdl__steer_parts *given, int snap_k,
                      mdl__steer_fit **f, char *err)
{
    for (int k = 0; k < c->K; k++) {
        int rc = mdl__steer_fit_begin(c->seq, c->tr + c->tr_off[k], c->tr_off[k + 1] - c->tr_off[k],
                                      c->rig, NULL, o, given ? &given[k] : NULL, snap_k, &f[k], err);
        if (rc) {
            fits_free(f, k);
            return rc;
        }
    }
    return 0;
}

static void parts_free(mdl__steer_parts *p, int K)
{
    for (int k = 0; k < K; k++) {
        free(p[k].part);
        free(p[k].rms);
    }
}

static int parts_copy(mdl__steer_parts *dst, mdl__steer_parts src, int nv)
{
    dst->n = src.n;
    dst->part = mdl__calloc((size_t)nv, sizeof(int));
    dst->rms = mdl__calloc((size_t)src.n + 1, sizeof(double));
    if (!dst->part || !dst->rms)
        return -1;
    memcpy(dst->part, src.part, sizeof(int) * (size_t)nv);
    memcpy(dst->rms, src.rms, sizeof(double) * (size_t)src.n);
    return 0;
}

/* Refits the regressions of every fold with o's options and scores them into cd. */
static int score(sel_ctx *c, mdl__steer_fit **f, const mdl_train_opts *o, mdl_select_cand *cd,
                 char *err)
{
    double sum[4] = {0, 0, 0, 0};
    int n = 0, rc;
    for (int k = 0; k < c->K; k++) {
        if ((rc = mdl__steer_fit_regress(f[k], o, err)) ||
            (rc = validate(c, k, mdl__steer_fit_model(f[k]), sum, err)))
            return rc;
        n += c->ho_off[k + 1] - c->ho_off[k];
    }
    cd->use_motion_dir = o->use_motion_dir;
    cd->linear = o->linear;
    cd->ridge = o->ridge;
    cd->overlap_rings = o->overlap_rings;
    cd->max_modes = o->max_modes;
    cd->max_clusters = o->max_clusters;
    cd->filter_noise = o->filter_noise;
    cd->train_noise = o->train_noise;
    cd->kblend = o->kblend;
    cd->err_clean = sum[0] / n;
    cd->base_clean = sum[1] / n;
    cd->err_noisy = sum[2] / n;
    cd->base_noisy = sum[3] / n;
    cd->score = fmax(sum[0] / sum[1], sum[2] / sum[3]);
    return 0;
}

/* cd's validation at twice the spacing (c2) and its score at half the validation's spacing,
 * from the errors extrapolated there. */
static void extrapolate(mdl_select_cand *cd, const mdl_select_cand *c2)
{
    cd->spaced = 1;
    cd->err2_clean = c2->err_clean;
    cd->base2_clean = c2->base_clean;
    cd->err2_noisy = c2->err_noisy;
    cd->base2_noisy = c2->base_noisy;
    double clean = half_spacing(cd->err_clean, c2->err_clean) /
                   half_spacing(cd->base_clean, c2->base_clean),
           noisy = half_spacing(cd->err_noisy, c2->err_noisy) /
                   half_spacing(cd->base_noisy, c2->base_noisy);
    cd->score_spaced = fmax(clean, noisy);
}

int mdl__steer_select(const mdl_meshseq *seq, const int *frames, int n, const mdl_rig *rig,
                      const mdl_train_opts *opts, mdl_train_opts *out, mdl_select_result *res,
                      char *err)
{
    memset(res, 0, sizeof *res);
    mdl__train_opts_resolve(opts, out);
    int K = opts->select_folds > 8 ? 8 : opts->select_folds;
    while (K >= 2 && (n < K * MDL_SELECT_BLOCK || n - (n / (K * MDL_SELECT_BLOCK) + 1) * MDL_SELECT_BLOCK < 3))
        K--;
    int search_filt = opts->filter_noise < 0 && opts->select_noise > 0,
        search_tn = opts->train_noise < 0 && opts->select_noise > 0,
        search_md = opts->use_motion_dir < 0, search_lin = opts->linear < 0,
        search_ridge = opts->ridge == -1, search_ov = opts->overlap_rings < 0,
        search_modes = opts->max_modes < 0, search_cl = opts->max_clusters < 0 && opts->clusters <= 0,
        search_kb = opts->kblend < 0;
    if (K < 2 || !(search_filt || search_tn || search_md || search_lin || search_ridge || search_ov || search_modes || search_cl || search_kb))
        return 0;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    sel_ctx c = {.seq = seq, .rig = rig, .K = K, .nv = seq->nv, .nm = rig->nmarkers,
                 .noise = opts->select_noise};
    int nv = c.nv, nm = c.nm, rc = 0;
    mdl__steer_fit *best[8] = {0}, *alt[8] = {0}, *wide[8] = {0};
    sel_ctx c2 = {0}; /* the folds at twice the spacing */
    mdl__steer_parts pbase[8] = {{0}}, psnap[8] = {{0}}; /* per fold: the default and the
                                                            MDL_SELECT_FEW_PARTS partitions */
    c.tr_off = mdl__calloc((size_t)K + 1, sizeof(int));
    c.ho_off = mdl__calloc((size_t)K + 1, sizeof(int));
    c.tr = mdl__calloc((size_t)K * n, sizeof(int));
    c.ho = mdl__calloc((size_t)n, sizeof(int));
    c.V = mdl__calloc((size_t)nv * 3, sizeof(float));
    c.dist = mdl__calloc((size_t)nv, sizeof(float));
    c.mk = mdl__calloc((size_t)nm * 3, sizeof(float));
    c.valid = mdl__calloc((size_t)nm, 1);
    c.ya = mdl__calloc((size_t)nm * 3, sizeof(double));
    c.xb = mdl__calloc((size_t)nm * 3, sizeof(double));
    if (!c.tr_off || !c.ho_off || !c.tr || !c.ho || !c.V || !c.dist || !c.mk || !c.valid || !c.ya ||
        !c.xb) {
        rc = mdl__err(err, -ENOMEM, "train: option selection: out of memory");
        goto out;
    }
    memset(c.valid, 1, (size_t)nm);
    folds_make(&c, frames, n, MDL_SELECT_BLOCK, 0);
    {
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int v = 0; v < nv; v++)
            for (int x = 0; x < 3; x++) {
                lo[x] = fminf(lo[x], seq->V[(size_t)frames[0] * nv * 3 + 3 * v + x]);
                hi[x] = fmaxf(hi[x], seq->V[(size_t)frames[0] * nv * 3 + 3 * v + x]);
            }
        for (int x = 0; x < 3; x++)
            c.diag += (double)(hi[x] - lo[x]) * (hi[x] - lo[x]);
        c.diag = sqrt(c.diag);
    }
    res->folds = K;
    res->select_noise = opts->select_noise;
    mdl_train_opts cur = *out, tr;
    if ((rc = fits_build(&c, &cur, NULL, search_cl ? MDL_SELECT_FEW_PARTS : 0, best, err)) ||
        (rc = score(&c, best, &cur, &res->cand[0], err)))
        goto out;
    for (int k = 0; k < K; k++)
        if (parts_copy(&pbase[k], mdl__steer_fit_parts(best[k]), nv) ||
            (search_cl && parts_copy(&psnap[k], mdl__steer_fit_snap(best[k]), nv))) {
            rc = mdl__err(err, -ENOMEM, "train: option selection: out of memory");
            goto out;
        }
    res->ncand = 1;
    res->chosen = 0;
    double bs = res->cand[0].score;
    /* the regression options: the fold models' structure stays */
    for (int opt = -3; opt < 3; opt++) {
        if ((opt == -3 && !search_filt) || (opt >= -2 && opt <= -1 && !search_tn) ||
            (opt == 0 && !search_md) || (opt == 1 && !search_lin) || (opt == 2 && !search_ridge))
            continue;
        tr = cur;
        if (opt == -3)
            tr.filter_noise = opts->select_noise;
        else if (opt == -2 || opt == -1) /* half the validation noise, and all of it */
            tr.train_noise = opts->select_noise * (opt == -2 ? 0.5 : 1.0);
        else if (opt == 0)
            tr.use_motion_dir = !cur.use_motion_dir;
        else if (opt == 1)
            tr.linear = 1;
        else
            tr.ridge = 1;
        mdl_select_cand *cd = &res->cand[res->ncand];
        if ((rc = score(&c, best, &tr, cd, err)))
            goto out;
        if (cd->score < 0.99 * bs) {
            bs = cd->score;
            cur = tr;
            res->chosen = res->ncand;
        }
        res->ncand++;
    }
    /* the structural options: a whole fold model per candidate */
    static const int ov_alt[] = {1, 3}, mo_alt[] = {3}, cl_alt[] = {MDL_SELECT_FEW_PARTS};
    for (int opt = 0; opt < 3; opt++) {
        if ((opt == 0 && !search_ov) || (opt == 1 && !search_modes) || (opt == 2 && !search_cl))
            continue;
        const int *alts = opt == 0 ? ov_alt : opt == 1 ? mo_alt : cl_alt;
        int na = opt == 0 ? 2 : 1;
        mdl_train_opts base = cur;
        for (int a = 0; a < na && res->ncand < MDL_SELECT_MAX_CAND; a++) {
            tr = base;
            if (opt == 0)
                tr.overlap_rings = alts[a];
            else if (opt == 1)
                tr.max_modes = alts[a];
            else
                tr.max_clusters = alts[a];
            mdl_select_cand *cd = &res->cand[res->ncand];
            if ((rc = fits_build(&c, &tr, search_cl && tr.max_clusters == MDL_SELECT_FEW_PARTS ? psnap : pbase,
                                 0, alt, err)))
                goto out;
            if ((rc = score(&c, alt, &tr, cd, err)))
                goto out;
            if (cd->score < 0.99 * bs) {
                bs = cd->score;
                cur = tr;
                res->chosen = res->ncand;
                fits_free(best, K);
                memcpy(best, alt, sizeof(mdl__steer_fit *) * (size_t)K);
                memset(alt, 0, sizeof alt);
            } else {
                fits_free(alt, K);
            }
            res->ncand++;
        }
    }
    /* last, the kernel blend of the training meshes instead of the part model (kblend.h): the
     * part model's options above are chosen first, so that they are the part model's best either
     * way. The blend runs without the input filter (unless one is given): its bandwidth is relative
     * to the best frame's fit, so noisy markers already widen it (select.h, step 4). The
     * bandwidths are compared among themselves, then the best blend with the part model at the
     * test's spacing when there are frames enough (extrapolated from a validation at twice the
     * spacing as well: folds of 3-frame blocks scored on their middle frames), else at the
     * validation's. */
    static const double kb_alt[MDL_KBLEND_NH] = MDL_KBLEND_H;
    int spaced = search_kb && n >= 2 * MDL_SELECT_WIDE_BLOCK * K; /* two blocks per fold */
    if (spaced) {
        c2 = c;
        c2.tr_off = mdl__calloc((size_t)K + 1, sizeof(int));
        c2.ho_off = mdl__calloc((size_t)K + 1, sizeof(int));
        c2.tr = mdl__calloc((size_t)K * n, sizeof(int));
        c2.ho = mdl__calloc((size_t)n, sizeof(int));
        if (!c2.tr_off || !c2.ho_off || !c2.tr || !c2.ho) {
            rc = mdl__err(err, -ENOMEM, "train: option selection: out of memory");
            goto out;
        }
        folds_make(&c2, frames, n, MDL_SELECT_WIDE_BLOCK, 1);
        mdl_select_cand part2;
        if ((rc = fits_build(&c2, &cur, NULL, 0, wide, err)) ||
            (rc = score(&c2, wide, &cur, &part2, err)))
            goto out;
        extrapolate(&res->cand[res->chosen], &part2);
    }
    int kb_best = -1; /* the best blend, an index into res->cand */
    for (int a = 0; search_kb && a < MDL_KBLEND_NH && res->ncand < MDL_SELECT_MAX_CAND; a++) {
        tr = cur;
        tr.kblend = kb_alt[a];
        if (search_filt)
            tr.filter_noise = 0;
        mdl_select_cand *cd = &res->cand[res->ncand], cd2;
        if ((rc = score(&c, best, &tr, cd, err)))
            goto out;
        if (spaced) {
            if ((rc = score(&c2, wide, &tr, &cd2, err)))
                goto out;
            extrapolate(cd, &cd2);
        }
        if (kb_best < 0 || cd->score < 0.99 * res->cand[kb_best].score)
            kb_best = res->ncand;
        res->ncand++;
    }
    if (kb_best >= 0) { /* the best blend against the part model */
        const mdl_select_cand *kb = &res->cand[kb_best], *pm = &res->cand[res->chosen];
        if (spaced ? kb->score_spaced < 0.99 * pm->score_spaced : kb->score < 0.99 * pm->score) {
            cur.kblend = kb->kblend;
            cur.filter_noise = kb->filter_noise;
            res->chosen = kb_best;
        }
    }
    *out = cur;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    res->seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
out:
    fits_free(best, K);
    fits_free(alt, K);
    fits_free(wide, K);
    free(c2.tr_off);
    free(c2.ho_off);
    free(c2.tr);
    free(c2.ho);
    parts_free(pbase, K);
    parts_free(psnap, K);
    free(c.tr_off);
    free(c.ho_off);
    free(c.tr);
    free(c.ho);
    free(c.V);
    free(c.dist);
    free(c.mk);
    free(c.valid);
    free(c.ya);
    free(c.xb);
    if (rc)
        memset(res, 0, sizeof *res);
    return rc;
}
