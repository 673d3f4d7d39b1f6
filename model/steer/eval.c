/* eval.c - quality of a steering model against ground-truth frames, beside the nearest-training-frame
 * baseline (DESIGN.md "Quality, measured"; the interface is documented in model.h).
 * Evaluation, not a per-frame path: it allocates freely. Noise comes from util.h's reproducible
 * stream, so that a seed reproduces a run exactly. */
#include "steer/steer_internal.h"
#include "kind.h"
#include "core/rigid.h"
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

/* RMS distance after rigid alignment of the valid markers of A onto B. */
static double marker_fit(const float *A, const float *B, const uint8_t *valid, int n, double *ya,
                         double *xb)
{
    int k = 0;
    for (int i = 0; i < n; i++)
        if (valid[i]) {
            for (int c = 0; c < 3; c++) {
                ya[3 * k + c] = A[3 * i + c];
                xb[3 * k + c] = B[3 * i + c];
            }
            k++;
        }
    if (k < 3)
        return INFINITY;
    double R[9], t[3];
    return mdl__kabsch(ya, xb, NULL, k, R, t);
}

int mdl__steer_eval(const mdl_model *model, const mdl_meshseq *seq, const int *frames, int n,
                    const mdl_eval_opts *o, mdl_eval_result *r, char *err)
{
    const struct mdl_steer *m = mdl__model_steer(model);
    memset(r, 0, sizeof *r);
    if (!m)
        return mdl__err(err, -ENOENT, "model '%s' holds no steering model", model->name);
    if (seq->nv != m->nv || seq->nf != m->nf ||
        mdl_topology_fingerprint(seq->F, seq->nf, seq->nv) != m->topology)
        return mdl__err(err, MDL_ETOPOLOGY,
                        "the mesh (%d vertices, %d triangles) does not have the topology the model "
                        "'%s' was trained on (%d vertices, %d triangles%s)",
                        seq->nv, seq->nf, m->name, m->nv, m->nf,
                        seq->nv == m->nv && seq->nf == m->nf ? ", different faces" : "");
    for (int i = 0; i < n; i++)
        if (frames[i] < 0 || frames[i] >= seq->frames)
            return mdl__err(err, -EINVAL, "frame %d is outside the sequence", frames[i]);
    for (int i = 0; i < m->ntrain; i++)
        if (m->train_frames[i] >= seq->frames)
            return mdl__err(err, -EINVAL,
                            "the model was trained on frame %d, which this sequence lacks: is it "
                            "the training sequence?",
                            m->train_frames[i]);
    int nv = m->nv, nm = m->nmarkers, rc = 0;
    mdl_steer_synth *s = NULL;
    float *V = mdl__calloc((size_t)nv * 3, sizeof *V), *dist = mdl__calloc((size_t)nv, sizeof *dist);
    float *all = mdl__calloc((size_t)nv * n, sizeof *all), *bl = mdl__calloc((size_t)nv * n, sizeof *bl);
    float *mk = mdl__calloc((size_t)nm * 3, sizeof *mk), *tmk = mdl__calloc((size_t)nm * 3, sizeof *tmk);
    float *omk = mdl__calloc((size_t)nm * 3, sizeof *omk), *gmk = mdl__calloc((size_t)nm * 3, sizeof *gmk);
    uint8_t *valid = mdl__calloc((size_t)nm, 1), *allv = mdl__calloc((size_t)nm, 1);
    double *ya = mdl__calloc((size_t)nm * 3, sizeof *ya), *xb = mdl__calloc((size_t)nm * 3, sizeof *xb);
    r->synth_us = mdl__calloc((size_t)n, sizeof(double));
    r->frame_err = mdl__calloc((size_t)n, sizeof(double));
    r->baseline_frame_err = mdl__calloc((size_t)n, sizeof(double));
    if (!V || !dist || !all || !bl || !mk || !tmk || !omk || !gmk || !valid || !allv || !ya || !xb ||
        !r->synth_us || !r->frame_err || !r->baseline_frame_err) {
        rc = mdl__err(err, -ENOMEM, "eval: out of memory");
        goto out;
    }
    if ((rc = mdl__steer_synth_create(m, &s, err)))
        goto out;
    memset(allv, 1, (size_t)nm);
    double diag = 0;
    {
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int v = 0; v < nv; v++)
            for (int c = 0; c < 3; c++) {
                lo[c] = fminf(lo[c], m->rest[3 * v + c]);
                hi[c] = fmaxf(hi[c], m->rest[3 * v + c]);
            }
        for (int c = 0; c < 3; c++)
            diag += (double)(hi[c] - lo[c]) * (hi[c] - lo[c]);
        diag = sqrt(diag);
    }
    double tdiag = 0;
    for (int c = 0; c < 3; c++)
        tdiag += (double)(m->bbox_max[c] - m->bbox_min[c]) * (m->bbox_max[c] - m->bbox_min[c]);
    tdiag = sqrt(tdiag);
    uint64_t rng = o->seed ? o->seed : 1;
    double sum = 0, msum = 0, bsum = 0;
    int nout = 0;
    for (int i = 0; i < n; i++) {
        const float *T = seq->V + (size_t)frames[i] * nv * 3;
        for (int j = 0; j < nm; j++) {
            const float *p = T + 3 * m->markers[j].vertex;
            valid[j] = !(o->drop > 0 && mdl__uniform(&rng) < o->drop);
            r->markers_dropped += !valid[j];
            for (int c = 0; c < 3; c++) {
                tmk[3 * j + c] = p[c];
                mk[3 * j + c] = p[c] + (float)(o->noise_m > 0 ? o->noise_m * mdl__gauss(&rng) : 0);
            }
        }
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        int sr = mdl__steer_synth_frame(s, mk, valid, V, NULL);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        if (sr == -EAGAIN) {
            r->frames_skipped++;
            continue;
        }
        r->synth_us[nout] = 1e6 * (double)(t1.tv_sec - t0.tv_sec) + 1e-3 * (double)(t1.tv_nsec - t0.tv_nsec);
        for (int v = 0; v < nv; v++)
            for (int c = 0; c < 3; c++) {
                float x = V[3 * v + c];
                if (!isfinite(x)) {
                    r->nan_count++;
                    continue;
                }
                double ex = fmax(m->bbox_min[c] - x, x - m->bbox_max[c]);
                if (ex / tdiag > r->max_bbox_excess)
                    r->max_bbox_excess = ex / tdiag;
            }
        double e = mdl_rigid_aligned_error(V, T, nv, dist) / diag;
        r->frame_err[nout] = e;
        sum += e;
        for (int v = 0; v < nv; v++) {
            all[(size_t)nout * nv + v] = (float)(dist[v] / diag);
            if (dist[v] / diag > r->max_err)
                r->max_err = dist[v] / diag;
        }
        for (int j = 0; j < nm; j++)
            for (int c = 0; c < 3; c++) {
                omk[3 * j + c] = V[3 * m->markers[j].vertex + c];
            }
        msum += mdl_rigid_aligned_error(omk, tmk, nm, NULL) / diag;
        /* baseline: the training frame whose rig markers fit the input markers best */
        double best = INFINITY;
        int bf = m->train_frames[0];
        for (int t = 0; t < m->ntrain; t++) {
            const float *G = seq->V + (size_t)m->train_frames[t] * nv * 3;
            for (int j = 0; j < nm; j++)
                memcpy(gmk + 3 * j, G + 3 * m->markers[j].vertex, 3 * sizeof(float));
            double f = marker_fit(gmk, mk, valid, nm, ya, xb);
            if (!isfinite(f))
                f = marker_fit(gmk, mk, allv, nm, ya, xb);
            if (f < best) {
                best = f;
                bf = m->train_frames[t];
            }
        }
        double be = mdl_rigid_aligned_error(seq->V + (size_t)bf * nv * 3, T, nv, dist) / diag;
        r->baseline_frame_err[nout] = be;
        bsum += be;
        for (int v = 0; v < nv; v++)
            bl[(size_t)nout * nv + v] = (float)(dist[v] / diag);
        nout++;
    }
    r->frames = nout;
    if (nout > 0) {
        r->mean_err = sum / nout;
        r->marker_err = msum / nout;
        r->baseline_nn_mean_err = bsum / nout;
        size_t tot = (size_t)nout * nv, k = (size_t)ceil(0.95 * (double)tot) - 1;
        qsort(all, tot, sizeof *all, cmp_float);
        qsort(bl, tot, sizeof *bl, cmp_float);
        r->p95_err = all[k];
        r->baseline_nn_p95_err = bl[k];
    }
out:
    mdl__steer_synth_destroy(s);
    free(V);
    free(dist);
    free(all);
    free(bl);
    free(mk);
    free(tmk);
    free(omk);
    free(gmk);
    free(valid);
    free(allv);
    free(ya);
    free(xb);
    if (rc)
        mdl_eval_result_fini(r);
    return rc;
}
