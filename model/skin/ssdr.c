/* ssdr.c - SSDR's alternation [Le & Deng 2012] and mdl_skin_fit (model.h, ssdr.h).
 *
 * After the clustering initialisation (ssdr_init.c) every iteration updates all weights with the
 * transforms fixed (ssdr_weights.c), then all transforms with the weights fixed
 * (ssdr_transforms.c); each update solves its block exactly (the weights never get worse, see
 * ssdr_weights.c), so the fitting error E never grows. The loop stops after o->iterations, or
 * when the RMSE improved by less than o->tolerance (relative) o->patience times in a row (Dem
 * Bones' stopping rule, so the two compare on equal terms), whichever comes first: it always ends.
 * Training only: allocates at create. */
#include "skin/ssdr.h"
#include "skin/skin_internal.h"
#include "kind.h"
#include "core/meshgraph.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

void mdl_skin_opts_default(mdl_skin_opts *o)
{
    memset(o, 0, sizeof *o);
    o->bones = 20;
    o->max_influences = 4;
    o->iterations = 100;
    o->tolerance = 1e-3;
    o->patience = 3;
    o->init_iterations = 5;
    o->transform_sweeps = 2;
    o->smooth = 0;
    o->seed = 1;
    o->workers = 1;
}

void mdl__ssdr_parallel(mdl__ssdr *s, int n, mdl_parallel_body body, void *ctx)
{
    if (s->par && s->workers > 1 && n > 1) {
        s->par(s->par_ud, n, body, ctx);
        return;
    }
    for (int i = 0; i < n; i++)
        body(ctx, i, 0);
}

void mdl__ssdr_destroy(mdl__ssdr *s)
{
    if (!s)
        return;
    free(s->U);
    free(s->X);
    free(s->vv);
    free(s->T);
    free(s->bone);
    free(s->w);
    free(s->M);
    free(s->G);
    free(s->Yw);
    free(s->Rw);
    free(s->Sw);
    free(s->new_bone);
    free(s->new_w);
    free(s->label);
    free(s->verr);
    free(s->ferr);
    free(s->fmax);
    free(s->sup_off);
    free(s->sup_v);
    free(s->sup_w);
    free(s->sup_ubar);
    free(s->sup_w2);
    free(s->B);
    free(s->C);
    free(s->vvt);
    free(s->cadj);
    free(s->cnum);
    free(s->Xt);
    free(s->mark);
    free(s);
}

int mdl__ssdr_create(const mdl_meshseq *seq, const int *frames, int nf, const float *rest, int nb,
                     int K, const mdl_skin_opts *o, mdl__ssdr **out, char *err)
{
    *out = NULL;
    mdl__ssdr *s = mdl__calloc(1, sizeof *s);
    if (!s)
        return mdl__err(err, -ENOMEM, "out of memory");
    int nv = seq->nv;
    s->nv = nv;
    s->nf = nf;
    s->nb = nb;
    s->K = K;
    s->workers = o && o->parallel && o->workers > 1 ? o->workers : 1;
    s->par = o ? o->parallel : NULL;
    s->par_ud = o ? o->parallel_ud : NULL;
    size_t W = (size_t)s->workers, NK = (size_t)nv * K, L = 4 * (size_t)nb;
    s->sw_len = 2 * (size_t)SSDR_BLOCK * nb + mdl__ssdr_nnls_scratch(nb) + nb + 8;
    s->U = mdl__calloc(3 * (size_t)nv, sizeof *s->U);
    s->X = mdl__calloc((size_t)nv * 3 * nf, sizeof *s->X);
    s->vv = mdl__calloc(nv, sizeof *s->vv);
    s->T = mdl__calloc((size_t)nf * nb * 12, sizeof *s->T);
    s->bone = mdl__calloc(NK, sizeof *s->bone);
    s->w = mdl__calloc(NK, sizeof *s->w);
    s->M = mdl__calloc(3 * (size_t)nf * L, sizeof *s->M);
    s->G = mdl__calloc(L * L, sizeof *s->G);
    s->Yw = mdl__calloc(W * SSDR_BLOCK * L, sizeof *s->Yw);
    s->Rw = mdl__calloc(W * 3 * nv, sizeof *s->Rw);
    s->Sw = mdl__calloc(W * s->sw_len, sizeof *s->Sw);
    s->new_bone = mdl__calloc(NK > (size_t)nv ? NK : (size_t)nv, sizeof *s->new_bone);
    s->new_w = mdl__calloc(NK, sizeof *s->new_w);
    s->label = mdl__calloc((size_t)nv + nb, sizeof *s->label);
    s->verr = mdl__calloc(nv, sizeof *s->verr);
    s->ferr = mdl__calloc(nf, sizeof *s->ferr);
    s->fmax = mdl__calloc(nf, sizeof *s->fmax);
    s->sup_off = mdl__calloc((size_t)nb + 1, sizeof *s->sup_off);
    s->sup_v = mdl__calloc(NK, sizeof *s->sup_v);
    s->sup_w = mdl__calloc(NK, sizeof *s->sup_w);
    s->sup_ubar = mdl__calloc(3 * (size_t)nb, sizeof *s->sup_ubar);
    s->sup_w2 = mdl__calloc(nb, sizeof *s->sup_w2);
    s->B = mdl__calloc(3 * (size_t)nf * L, sizeof *s->B);
    s->C = mdl__calloc((size_t)nb * nb * 16, sizeof *s->C);
    s->vvt = mdl__calloc(nf, sizeof *s->vvt);
    s->cadj = mdl__calloc((size_t)nb * nb, sizeof *s->cadj);
    s->cnum = mdl__calloc(nb, sizeof *s->cnum);
    s->Xt = mdl__calloc((size_t)nv * 3 * nf, sizeof *s->Xt);
    s->mark = mdl__calloc(W * 3 * nb, sizeof *s->mark);
    if (!s->Xt || !s->mark || !s->B || !s->C || !s->vvt || !s->cadj || !s->cnum ||!s->U || !s->X || !s->vv || !s->T || !s->bone || !s->w || !s->M || !s->G || !s->Yw ||
        !s->Rw || !s->Sw || !s->new_bone || !s->new_w || !s->label || !s->verr || !s->ferr ||
        !s->fmax || !s->sup_off || !s->sup_v || !s->sup_w || !s->sup_ubar || !s->sup_w2) {
        mdl__ssdr_destroy(s);
        return mdl__err(err, -ENOMEM, "skin: out of memory (%d vertices, %d frames, %d bones)", nv,
                        nf, nb);
    }
    for (int i = 0; i < 3 * nv; i++)
        s->U[i] = rest[i];
    for (int t = 0; t < nf; t++) {
        const float *V = seq->V + (size_t)frames[t] * nv * 3;
        double *X0 = s->X + (size_t)nv * 3 * t;
        for (int i = 0; i < nv; i++)
            for (int a = 0; a < 3; a++) {
                double x = V[3 * i + a];
                X0[i + (size_t)nv * a] = x;
                s->Xt[(3 * (size_t)t + a) + 3 * (size_t)nf * i] = x;
                s->vv[i] += x * x;
                s->vvt[t] += x * x;
            }
    }
    for (int t = 0; t < nf; t++)
        for (int j = 0; j < nb; j++) {
            double *T = s->T + 12 * ((size_t)t * nb + j);
            T[0] = T[4] = T[8] = 1;
        }
    *out = s;
    return 0;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double rest_diag(const float *rest, int nv)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < nv; i++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fmin(lo[c], rest[3 * i + c]);
            hi[c] = fmax(hi[c], rest[3 * i + c]);
        }
    double d = 0;
    for (int c = 0; c < 3; c++)
        d += (hi[c] - lo[c]) * (hi[c] - lo[c]);
    return sqrt(d);
}

static void progress(const mdl_skin_opts *o, const char *stage, double f)
{
    if (o->progress)
        o->progress(o->progress_ud, stage, f);
}

int mdl_skin_fit(const mdl_meshseq *seq, const int *frames, int n, const mdl_skin_opts *o,
                 mdl_model **out, char *err)
{
    *out = NULL;
    mdl_skin_opts def;
    if (!o) {
        mdl_skin_opts_default(&def);
        o = &def;
    }
    if (n < 1)
        return mdl__err(err, -EINVAL, "skin: no frames to fit");
    for (int i = 0; i < n; i++)
        if (frames[i] < 0 || frames[i] >= seq->frames)
            return mdl__err(err, -EINVAL, "skin: frame %d is outside the sequence (%d frames)",
                            frames[i], seq->frames);
    if (o->bones < 1 || o->bones > 65535)
        return mdl__err(err, -EINVAL, "skin: %d bones: need 1..65535", o->bones);
    if (o->max_influences < 1 || o->max_influences > 64)
        return mdl__err(err, -EINVAL, "skin: %d influences: need 1..64", o->max_influences);
    if (o->iterations < 0 || o->patience < 1 || !(o->tolerance >= 0) || !(o->smooth >= 0) ||
        o->init_iterations < 0 || o->transform_sweeps < 1)
        return mdl__err(err, -EINVAL, "skin: bad options (iterations %d, patience %d, tolerance "
                        "%g, smooth %g)", o->iterations, o->patience, o->tolerance, o->smooth);
    double t0 = now_s();
    int nv = seq->nv, nb = o->bones, K = o->max_influences < nb ? o->max_influences : nb;
    const float *rest = o->rest ? o->rest : seq->V + (size_t)frames[0] * nv * 3;
    double diag = rest_diag(rest, nv);
    mdl__ssdr *s = NULL;
    mdl_graph g = {0};
    int rc = mdl__ssdr_create(seq, frames, n, rest, nb, K, o, &s, err);
    if (rc)
        return rc;
    s->trans_sweeps = o->transform_sweeps;
    rc = mdl__graph_init(&g, nv, seq->F, seq->nf, err);
    if (rc)
        goto fail;
    s->g_off = g.off;
    s->g_nbr = g.nbr;
    s->smooth = o->smooth * n * diag * diag;
    progress(o, "skin: initialisation", 0);
    rc = mdl__ssdr_init(s, o->init_iterations, err);
    if (rc)
        goto fail;
    double mx = 0, E = mdl__ssdr_transforms(s, 1, NULL);
    double rmse = sqrt(E / ((double)nv * n)), prev = rmse;
    int it = 0, stall = 0;
    for (; it < o->iterations; it++) {
        progress(o, "skin: fitting", (double)it / o->iterations);
        mdl__ssdr_weights(s);
        E = mdl__ssdr_transforms(s, o->transform_sweeps, it + 1 == o->iterations ? &mx : NULL);
        rmse = sqrt(E / ((double)nv * n));
        stall = prev - rmse < o->tolerance * prev ? stall + 1 : 0;
        prev = rmse;
        if (stall >= o->patience) {
            it++;
            break;
        }
    }
    progress(o, "skin: fitting", 1);
    if (!(mx > 0)) /* the exact residuals, for the largest error */
        E = mdl__ssdr_transforms(s, 0, &mx), rmse = sqrt(E / ((double)nv * n));

    struct mdl_skin *k = mdl__calloc(1, sizeof *k);
    if (!k) {
        rc = mdl__err(err, -ENOMEM, "out of memory");
        goto fail;
    }
    k->nv = nv;
    k->nb = nb;
    k->K = K;
    k->nframes = n;
    k->bone = mdl__calloc((size_t)nv * K, sizeof *k->bone);
    k->w = mdl__calloc((size_t)nv * K, sizeof *k->w);
    k->T = mdl__calloc((size_t)n * nb * 12, sizeof *k->T);
    k->frames = mdl__calloc(n, sizeof *k->frames);
    k->part = mdl__calloc(nv, sizeof *k->part);
    if (!k->bone || !k->w || !k->T || !k->frames || !k->part) {
        mdl__skin_free(k);
        rc = mdl__err(err, -ENOMEM, "out of memory");
        goto fail;
    }
    memcpy(k->bone, s->bone, (size_t)nv * K * sizeof *k->bone);
    memcpy(k->w, s->w, (size_t)nv * K * sizeof *k->w);
    memcpy(k->T, s->T, (size_t)n * nb * 12 * sizeof *k->T);
    memcpy(k->frames, frames, (size_t)n * sizeof *k->frames);
    for (int i = 0; i < nv; i++)
        k->part[i] = k->bone[(size_t)K * i];
    k->st.bones = nb;
    k->st.max_influences = K;
    k->st.frames = n;
    k->st.vertices = nv;
    k->st.iterations = it;
    k->st.rmse = rmse;
    k->st.diag = diag;
    k->st.rmse_over_diag = diag > 0 ? rmse / diag : 0;
    k->st.max_err = sqrt(mx);
    mdl__ssdr_destroy(s);
    s = NULL;
    mdl__graph_fini(&g);
    rc = mdl__model_create(o->name ? o->name : "skin", rest, nv, seq->F, seq->nf, seq->fps, NULL,
                           NULL, NULL, out, err);
    if (rc) {
        mdl__skin_free(k);
        return rc;
    }
    k->st.seconds = now_s() - t0;
    rc = mdl__model_add_kind(*out, &mdl__skin_kind, k, err);
    if (rc) {
        mdl_model_destroy(*out);
        *out = NULL;
    }
    return rc;
fail:
    mdl__ssdr_destroy(s);
    mdl__graph_fini(&g);
    return rc;
}
