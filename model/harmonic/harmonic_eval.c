/* harmonic_eval.c - quality of a harmonic model against a ground-truth sequence (model.h,
 * mdl_eval_run; issue 9): the template is the sequence itself. Per frame each correspondence
 * triangle's rotation is measured on the ground-truth frame (the orthogonal polar factor of its
 * deformation gradient, Sumner & Popovic 2004 Sec. 3: the fourth vertex along the normal scaled by
 * 1/sqrt of its length), a group's rotation is the sign-aligned mean of its triangles', and the
 * model deforms the rest mesh with them (Sec. 4.1). The baseline uses the same Poisson glue
 * (eq. 4) but gives every triangle the rotation of the group of its geodesically nearest
 * correspondence (the same K inputs) instead of the harmonic field: what the interpolation of eq. 2 adds. Both are scored as for the steering
 * model: per-vertex distance after best rigid alignment / rest bounding-box diagonal.
 * Evaluation, not a per-frame path: it allocates; the timed part (mdl__hdeform_run) does not.
 * `o` (noise, drops) does not apply: the inputs are rotations, not markers. */
#include "harmonic/harmonic_internal.h"
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

void mdl__tri_rotation(const float *A, const float *B, const uint32_t *f, double q[4])
{
    double D0[9], D1[9];
    const float *P[2] = {A, B};
    double *D[2] = {D0, D1};
    for (int s = 0; s < 2; s++) {
        const float *x0 = P[s] + 3 * f[0], *x1 = P[s] + 3 * f[1], *x2 = P[s] + 3 * f[2];
        double e1[3], e2[3], n[3];
        for (int c = 0; c < 3; c++) {
            e1[c] = (double)x1[c] - x0[c];
            e2[c] = (double)x2[c] - x0[c];
        }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double l = sqrt(sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]));
        for (int c = 0; c < 3; c++) {
            D[s][3 * c] = e1[c];
            D[s][3 * c + 1] = e2[c];
            D[s][3 * c + 2] = l > 0 ? n[c] / l : 0;
        }
    }
    /* Fg = D1 D0^-1 (row-major), then S = Fg^T for mdl__rot_polar (maximises tr(R S)) */
    double inv[9], det = D0[0] * (D0[4] * D0[8] - D0[5] * D0[7]) - D0[1] * (D0[3] * D0[8] - D0[5] * D0[6]) +
                         D0[2] * (D0[3] * D0[7] - D0[4] * D0[6]);
    if (!(fabs(det) > 0)) {
        q[0] = 1, q[1] = q[2] = q[3] = 0;
        return;
    }
    inv[0] = (D0[4] * D0[8] - D0[5] * D0[7]) / det;
    inv[1] = (D0[2] * D0[7] - D0[1] * D0[8]) / det;
    inv[2] = (D0[1] * D0[5] - D0[2] * D0[4]) / det;
    inv[3] = (D0[5] * D0[6] - D0[3] * D0[8]) / det;
    inv[4] = (D0[0] * D0[8] - D0[2] * D0[6]) / det;
    inv[5] = (D0[2] * D0[3] - D0[0] * D0[5]) / det;
    inv[6] = (D0[3] * D0[7] - D0[4] * D0[6]) / det;
    inv[7] = (D0[1] * D0[6] - D0[0] * D0[7]) / det;
    inv[8] = (D0[0] * D0[4] - D0[1] * D0[3]) / det;
    double Fg[9], S[9], R[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            Fg[3 * i + j] = D1[3 * i] * inv[j] + D1[3 * i + 1] * inv[3 + j] + D1[3 * i + 2] * inv[6 + j];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            S[3 * i + j] = Fg[3 * j + i];
    mdl__rot_polar(S, R);
    mdl__mat_to_quat(R, q);
    mdl__qnorm(q);
}

int mdl__harmonic_eval(const mdl_model *m, const mdl_meshseq *seq, const int *frames, int n,
                       const mdl_eval_opts *o, mdl_eval_result *r, char *err)
{
    (void)o;
    memset(r, 0, sizeof *r);
    const mdl_kind_slot *k = mdl__model_kind(m, MDL_KIND_HARMONIC);
    if (!k)
        return mdl__err(err, -ENOENT, "model '%s' holds no harmonic model", m->name);
    const struct mdl_harmonic *h = k->impl;
    if (seq->nv != m->nv || seq->nf != m->nf || mdl_topology_fingerprint(seq->F, seq->nf, seq->nv) != m->topology)
        return mdl__err(err, MDL_ETOPOLOGY, "the mesh (%d vertices, %d triangles) does not have the "
                        "topology of the model '%s' (%d vertices, %d triangles)",
                        seq->nv, seq->nf, m->name, m->nv, m->nf);
    for (int i = 0; i < n; i++)
        if (frames[i] < 0 || frames[i] >= seq->frames)
            return mdl__err(err, -EINVAL, "frame %d is outside the sequence", frames[i]);
    int nv = m->nv, nf = m->nf, rc = 0;
    mdl__hdeform d;
    memset(&d, 0, sizeof d);
    float *V = mdl__calloc(3 * (size_t)nv, sizeof *V), *dist = mdl__calloc((size_t)nv, sizeof *dist);
    float *all = mdl__calloc((size_t)nv * (size_t)(n ? n : 1), sizeof *all);
    float *bl = mdl__calloc((size_t)nv * (size_t)(n ? n : 1), sizeof *bl);
    double *qc = mdl__calloc(4 * (size_t)h->ncorr, sizeof *qc), *qg = mdl__calloc(4 * (size_t)h->ngroups, sizeof *qg);
    double *Rb = mdl__calloc(9 * (size_t)nf, sizeof *Rb);
    int *near = mdl__calloc((size_t)nf, sizeof *near);
    r->synth_us = mdl__calloc((size_t)n + 1, sizeof(double));
    r->frame_err = mdl__calloc((size_t)n + 1, sizeof(double));
    r->baseline_frame_err = mdl__calloc((size_t)n + 1, sizeof(double));
    if (!V || !dist || !all || !bl || !qc || !qg || !Rb || !near || !r->synth_us || !r->frame_err ||
        !r->baseline_frame_err) {
        rc = mdl__err(err, -ENOMEM, "eval: out of memory");
        goto out;
    }
    if ((rc = mdl__hdeform_init(&d, h, m->rest, m->F, err)) ||
        (rc = mdl__corr_nearest(h, m->rest, m->F, nf, nv, near, err)))
        goto out;
    double diag = 0;
    for (int c = 0; c < 3; c++)
        diag += (double)(m->bbox_max[c] - m->bbox_min[c]) * (m->bbox_max[c] - m->bbox_min[c]);
    diag = sqrt(diag);
    double sum = 0, bsum = 0;
    for (int i = 0; i < n; i++) {
        const float *T = seq->V + (size_t)frames[i] * nv * 3;
        for (int c = 0; c < h->ncorr; c++)
            mdl__tri_rotation(m->rest, T, m->F + 3 * (size_t)h->corr_tri[c], qc + 4 * c);
        /* a group: the sign-aligned mean of its triangles' rotations */
        memset(qg, 0, 4 * (size_t)h->ngroups * sizeof *qg);
        for (int c = 0; c < h->ncorr; c++) {
            double *g = qg + 4 * h->corr_group[c], *q = qc + 4 * c;
            double s = g[0] * q[0] + g[1] * q[1] + g[2] * q[2] + g[3] * q[3] < 0 ? -1 : 1;
            for (int j = 0; j < 4; j++)
                g[j] += s * q[j];
        }
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        rc = mdl__hdeform_run(&d, qg);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        if (rc) {
            mdl__err(err, rc, "eval: frame %d: the solve failed", frames[i]);
            goto out;
        }
        r->synth_us[i] = 1e6 * (double)(t1.tv_sec - t0.tv_sec) + 1e-3 * (double)(t1.tv_nsec - t0.tv_nsec);
        for (int v = 0; v < 3 * nv; v++) {
            V[v] = (float)d.X[v];
            r->nan_count += !isfinite(V[v]);
        }
        double e = mdl_rigid_aligned_error(V, T, nv, dist) / diag;
        r->frame_err[i] = e;
        sum += e;
        for (int v = 0; v < nv; v++) {
            all[(size_t)i * nv + v] = (float)(dist[v] / diag);
            if (dist[v] / diag > r->max_err)
                r->max_err = dist[v] / diag;
        }
        /* baseline: nearest correspondence's rotation, same glue */
        for (int t = 0; t < nf; t++)
            mdl__quat_to_mat(d.qg + 4 * h->corr_group[near[t]], Rb + 9 * (size_t)t);
        if ((rc = mdl__poisson_solve(&d.pois, Rb, d.X))) {
            mdl__err(err, rc, "eval: frame %d: the baseline solve failed", frames[i]);
            goto out;
        }
        for (int v = 0; v < 3 * nv; v++)
            V[v] = (float)d.X[v];
        double be = mdl_rigid_aligned_error(V, T, nv, dist) / diag;
        r->baseline_frame_err[i] = be;
        bsum += be;
        for (int v = 0; v < nv; v++)
            bl[(size_t)i * nv + v] = (float)(dist[v] / diag);
    }
    r->frames = n;
    r->baseline_name = "baseline_nearest";
    if (n > 0) {
        r->mean_err = sum / n;
        r->baseline_nn_mean_err = bsum / n;
        size_t tot = (size_t)n * nv, kk = (size_t)ceil(0.95 * (double)tot) - 1;
        qsort(all, tot, sizeof *all, cmp_float);
        qsort(bl, tot, sizeof *bl, cmp_float);
        r->p95_err = all[kk];
        r->baseline_nn_p95_err = bl[kk];
    }
out:
    mdl__hdeform_fini(&d);
    free(V);
    free(dist);
    free(all);
    free(bl);
    free(qc);
    free(qg);
    free(Rb);
    free(near);
    if (rc)
        mdl_eval_result_fini(r);
    return rc;
}
