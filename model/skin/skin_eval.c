/* skin_eval.c - the skin kind's evaluation (model.h mdl_eval_run): generalisation, not just
 * compression. The weights stay as fitted; for every evaluated frame only the bone transforms are
 * fitted (the Procrustes update of ssdr_transforms.c, started from the rigid fit of each bone's
 * vertices of largest weight, swept until E changes by less than 1e-7 relatively or 60 sweeps),
 * and every vertex is compared with the ground truth (no alignment: the bones carry the global
 * motion). Errors are fractions of the rest box diagonal, as for the other kinds; rmse is in mesh
 * units. The baseline is the nearest fitted frame of the example (DESIGN.md "Quality,
 * measured"): the fitted ground-truth frame closest to the evaluated one after rigid alignment.
 * Evaluation, not a per-frame path: it allocates freely. */
#include "skin/skin_internal.h"
#include "skin/ssdr.h"
#include "kind.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static double now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e6 + ts.tv_nsec * 1e-3;
}

int mdl__skin_eval(const mdl_model *m, const mdl_meshseq *seq, const int *frames, int n,
                   const mdl_eval_opts *o, mdl_eval_result *r, char *err)
{
    (void)o;
    memset(r, 0, sizeof *r);
    const mdl_kind_slot *slot = mdl__model_kind(m, MDL_KIND_SKIN);
    if (!slot)
        return mdl__err(err, -ENOENT, "model '%s' holds no skin", m->name);
    const struct mdl_skin *k = slot->impl;
    if (seq->nv != m->nv || seq->nf != m->nf ||
        mdl_topology_fingerprint(seq->F, seq->nf, seq->nv) != m->topology)
        return mdl__err(err, MDL_ETOPOLOGY,
                        "the mesh (%d vertices, %d triangles) does not have the topology of the "
                        "skin '%s' (%d vertices, %d triangles)", seq->nv, seq->nf, m->name, m->nv,
                        m->nf);
    if (n < 1)
        return mdl__err(err, -EINVAL, "no frames to evaluate");
    for (int i = 0; i < n; i++)
        if (frames[i] < 0 || frames[i] >= seq->frames)
            return mdl__err(err, -EINVAL, "frame %d is outside the sequence", frames[i]);
    int nv = m->nv, K = k->K;
    mdl__ssdr *s = NULL;
    int rc = mdl__ssdr_create(seq, frames, n, m->rest, k->nb, K, NULL, &s, err);
    if (rc)
        return rc;
    float *dist = mdl__calloc((size_t)n * nv, sizeof *dist);
    double *res = mdl__calloc(3 * (size_t)nv, sizeof *res);
    r->synth_us = mdl__calloc(n, sizeof *r->synth_us);
    r->frame_err = mdl__calloc(n, sizeof *r->frame_err);
    r->baseline_frame_err = mdl__calloc(n, sizeof *r->baseline_frame_err);
    float *bd = mdl__calloc(nv, sizeof *bd);
    if (!dist || !res || !r->synth_us || !r->frame_err || !r->baseline_frame_err || !bd) {
        rc = mdl__err(err, -ENOMEM, "out of memory");
        goto out;
    }
    double diag = 0;
    for (int c = 0; c < 3; c++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int i = 0; i < nv; i++) {
            lo = fmin(lo, m->rest[3 * i + c]);
            hi = fmax(hi, m->rest[3 * i + c]);
        }
        diag += (hi - lo) * (hi - lo);
    }
    diag = sqrt(diag);
    double sumsq = 0, sumd = 0, mx = 0;
    for (int f = 0; f < n; f++) {
        double t0 = now_us();
        /* start: each bone's rigid fit of the vertices it dominates (one-hot weights) */
        for (int i = 0; i < nv; i++)
            for (int q = 0; q < K; q++) {
                s->bone[(size_t)K * i + q] = k->bone[(size_t)K * i];
                s->w[(size_t)K * i + q] = q == 0;
            }
        mdl__ssdr_supports(s);
        mdl__ssdr_transforms_frame(s, f, 1, res, NULL);
        memcpy(s->bone, k->bone, (size_t)nv * K * sizeof *s->bone);
        memcpy(s->w, k->w, (size_t)nv * K * sizeof *s->w);
        mdl__ssdr_supports(s);
        double E = INFINITY;
        for (int sw = 0; sw < 60; sw += 5) {
            double e = mdl__ssdr_transforms_frame(s, f, 5, res, NULL);
            int done = E - e <= 1e-7 * e;
            E = e;
            if (done)
                break;
        }
        r->synth_us[f] = now_us() - t0;
        double fs = 0;
        for (int i = 0; i < nv; i++) {
            const double *ri = res + 3 * (size_t)i;
            double e2 = ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2], d = sqrt(e2);
            dist[(size_t)f * nv + i] = (float)(d / diag);
            sumsq += e2;
            fs += d;
            if (d > mx)
                mx = d;
            if (!isfinite(d))
                r->nan_count++;
        }
        sumd += fs;
        r->frame_err[f] = fs / nv / diag;
        /* the nearest fitted frame of the example */
        double best = INFINITY;
        for (int g = 0; g < k->nframes; g++) {
            if (k->frames[g] >= seq->frames)
                continue;
            double e = mdl_rigid_aligned_error(seq->V + (size_t)k->frames[g] * nv * 3,
                                               seq->V + (size_t)frames[f] * nv * 3, nv, bd);
            if (e < best)
                best = e;
        }
        r->baseline_frame_err[f] = isfinite(best) ? best / diag : 0;
        r->baseline_nn_mean_err += r->baseline_frame_err[f] / n;
    }
    r->frames = n;
    r->mean_err = sumd / ((double)n * nv) / diag;
    r->max_err = mx / diag;
    r->rmse = sqrt(sumsq / ((double)n * nv));
    r->rmse_over_diag = r->rmse / diag;
    qsort(dist, (size_t)n * nv, sizeof *dist, cmp_float);
    r->p95_err = dist[(size_t)(0.95 * ((double)n * nv - 1))];
    double *bf = mdl__calloc(n, sizeof *bf);
    if (bf) {
        memcpy(bf, r->baseline_frame_err, (size_t)n * sizeof *bf);
        for (int a = 1; a < n; a++) /* insertion sort: n is small */
            for (int b = a; b > 0 && bf[b - 1] > bf[b]; b--) {
                double x = bf[b];
                bf[b] = bf[b - 1];
                bf[b - 1] = x;
            }
        r->baseline_nn_p95_err = bf[(int)(0.95 * (n - 1))];
        free(bf);
    }
out:
    if (rc)
        mdl_eval_result_fini(r);
    free(dist);
    free(res);
    free(bd);
    mdl__ssdr_destroy(s);
    return rc;
}
