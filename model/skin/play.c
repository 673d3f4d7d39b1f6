/* play.c - the skin kind's synthesis (MDL_INPUT_CLOCK), skinned by linear blending (Le & Deng
 * 2012's model, ssdr.h (LBS)):
 *   v_i(t) = sum_s w_is (R_b(t) p_i + t_b(t)),   b = bone of slot s,
 * with R_b(t), t_b(t) between two frames a = floor(t fps) and a + 1 by normalised quaternion lerp
 * and linear translation. The frames are
 *   - without variations: the fitted bone animation, looping (a mod n, a + 1 mod n: the loop
 *     closes with whatever jump the example has);
 *   - with variations (mdl_variations_attach): frames a and a + 1 of an endless random walk on
 *     the example's transition graph (Zheng 2013, variations/), rebuilt here at create. The walk
 *     only steps forward: a later t steps it on (more than 100000 frames ahead, it carries on from
 *     where it is), an earlier t replays it from its start, so equal clocks give equal frames.
 * This is what the daemon's idle source plays. Per frame: no allocation, float (the walk's own
 * steps are double). */
#include "skin/skin_internal.h"
#include "variations/variations.h"
#include "kind.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct skin_play {
    int nv, nb, K, nframes;
    double fps;
    float *rest;   /* nv x 3 */
    int *bone;     /* nv x K */
    float *w;      /* nv x K */
    float *q;      /* nframes x nb x 4 (w, x, y, z) */
    float *tr;     /* nframes x nb x 3 */
    float *M;      /* nb x 12 scratch: the blended transforms of the current time */
    /* with variations */
    mdl_variations *vars;
    mdl__vwalk walk;
    int walking;
    uint64_t seed;
    double *Ta, *Tb;   /* nb x 12: walk frames at - 1 and at */
    long long at;      /* -1: not started */
    float *wq, *wt;    /* 2 x nb x 4, 2 x nb x 3: Ta, Tb as quaternions and translations */
    /* the compact form (mdl_synth_params): one shape (the rest pose), a piece per bone */
    float *prm;        /* nb x 7: the last frame's quaternion and translation of each bone */
    int have_params;
    int part_off[2], nmodes[1], mode_off[1];
    int *inst_part;    /* nb zeros */
    int *slot_entry, *slot_inst; /* nv x K: the vertex and its bone, -1 where the weight is 0 */
} skin_play;

void mdl__skin_synth_destroy(void *state)
{
    skin_play *p = state;
    if (!p)
        return;
    free(p->rest);
    free(p->bone);
    free(p->w);
    free(p->q);
    free(p->tr);
    free(p->M);
    if (p->walking)
        mdl__vwalk_fini(&p->walk);
    mdl_variations_destroy(p->vars);
    free(p->Ta);
    free(p->Tb);
    free(p->wq);
    free(p->wt);
    free(p->prm);
    free(p->inst_part);
    free(p->slot_entry);
    free(p->slot_inst);
    free(p);
}

int mdl__skin_synth_create(const mdl_model *m, const void *impl, void **state, char *err)
{
    const struct mdl_skin *k = impl;
    *state = NULL;
    skin_play *p = mdl__calloc(1, sizeof *p);
    if (!p)
        return mdl__err(err, -ENOMEM, "skin synthesis: out of memory");
    p->nv = k->nv;
    p->nb = k->nb;
    p->K = k->K;
    p->nframes = k->nframes;
    p->fps = m->fps > 0 ? m->fps : 30;
    size_t nk = (size_t)k->nv * k->K, nt = (size_t)k->nframes * k->nb;
    p->rest = mdl__calloc(3 * (size_t)k->nv, sizeof *p->rest);
    p->bone = mdl__calloc(nk, sizeof *p->bone);
    p->w = mdl__calloc(nk, sizeof *p->w);
    p->q = mdl__calloc(4 * nt, sizeof *p->q);
    p->tr = mdl__calloc(3 * nt, sizeof *p->tr);
    p->M = mdl__calloc(12 * (size_t)k->nb, sizeof *p->M);
    p->prm = mdl__calloc(7 * (size_t)k->nb, sizeof *p->prm);
    p->inst_part = mdl__calloc((size_t)k->nb, sizeof *p->inst_part);
    p->slot_entry = mdl__calloc(nk + 1, sizeof *p->slot_entry);
    p->slot_inst = mdl__calloc(nk + 1, sizeof *p->slot_inst);
    if (!p->rest || !p->bone || !p->w || !p->q || !p->tr || !p->M || !p->prm || !p->inst_part ||
        !p->slot_entry || !p->slot_inst) {
        mdl__skin_synth_destroy(p);
        return mdl__err(err, -ENOMEM, "skin synthesis: out of memory");
    }
    memcpy(p->rest, m->rest, 3 * (size_t)k->nv * sizeof *p->rest);
    memcpy(p->bone, k->bone, nk * sizeof *p->bone);
    for (size_t i = 0; i < nk; i++)
        p->w[i] = (float)k->w[i];
    for (size_t i = 0; i < nk; i++) {
        int used = p->w[i] != 0;
        p->slot_entry[i] = used ? (int)(i / (size_t)k->K) : -1;
        p->slot_inst[i] = used ? p->bone[i] : -1;
    }
    p->part_off[1] = k->nv;
    for (size_t f = 0; f < nt; f++) {
        double q[4];
        mdl__mat_to_quat(k->T + 12 * f, q);
        double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        for (int c = 0; c < 4; c++)
            p->q[4 * f + c] = (float)(q[c] / n);
        for (int c = 0; c < 3; c++)
            p->tr[3 * f + c] = (float)k->T[12 * f + 9 + c];
    }
    if (k->has_vars) {
        int rc = mdl_variations_build(m, &k->vars, &p->vars, err);
        if (!rc)
            rc = mdl__vwalk_init(&p->walk, p->vars, k->vars_seed, err);
        if (rc) {
            mdl__skin_synth_destroy(p);
            return rc;
        }
        p->walking = 1;
        p->seed = k->vars_seed;
        p->at = -1;
        p->Ta = mdl__calloc(12 * (size_t)k->nb, sizeof *p->Ta);
        p->Tb = mdl__calloc(12 * (size_t)k->nb, sizeof *p->Tb);
        p->wq = mdl__calloc(8 * (size_t)k->nb, sizeof *p->wq);
        p->wt = mdl__calloc(6 * (size_t)k->nb, sizeof *p->wt);
        if (!p->Ta || !p->Tb || !p->wq || !p->wt) {
            mdl__skin_synth_destroy(p);
            return mdl__err(err, -ENOMEM, "skin synthesis: out of memory");
        }
    }
    *state = p;
    return 0;
}

/* the walk's frames n and n + 1 into wq, wt (slots 0 and 1) */
static void walk_to(skin_play *p, long long n)
{
    if (p->at < 0 || n + 1 < p->at) {
        mdl__vwalk_reset(&p->walk, p->seed);
        mdl__vwalk_step(&p->walk, p->Tb);
        p->at = 0;
    }
    if (n + 1 - p->at > 100000)
        p->at = n; /* far ahead: carry on from here */
    while (p->at < n + 1) {
        memcpy(p->Ta, p->Tb, 12 * (size_t)p->nb * sizeof *p->Ta);
        mdl__vwalk_step(&p->walk, p->Tb);
        p->at++;
    }
    for (int s = 0; s < 2; s++)
        for (int j = 0; j < p->nb; j++) {
            const double *M = (s ? p->Tb : p->Ta) + 12 * (size_t)j;
            double q[4];
            mdl__mat_to_quat(M, q);
            double nq = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            for (int c = 0; c < 4; c++)
                p->wq[4 * ((size_t)s * p->nb + j) + c] = (float)(q[c] / nq);
            for (int c = 0; c < 3; c++)
                p->wt[3 * ((size_t)s * p->nb + j) + c] = (float)M[9 + c];
        }
}

void mdl__skin_synth_reset(void *state)
{
    (void)state; /* a clock-driven kind keeps no history */
}

int mdl__skin_synth_frame(void *state, const mdl_synth_input *in, float *V, mdl_synth_info *info)
{
    skin_play *p = state;
    if (info)
        memset(info, 0, sizeof *info);
    if (!in || !isfinite(in->t))
        return -EINVAL;
    const float *Q0, *Q1, *T0, *T1; /* frames a and b: nb x 4 quaternions, nb x 3 translations */
    float al;
    if (p->walking) {
        double f = in->t * p->fps;
        if (!(f >= 0))
            f = 0;
        if (f > 4e15)
            f = 4e15;
        long long n = (long long)f;
        walk_to(p, n);
        al = (float)(f - (double)n);
        Q0 = p->wq;
        Q1 = p->wq + 4 * (size_t)p->nb;
        T0 = p->wt;
        T1 = p->wt + 3 * (size_t)p->nb;
    } else {
        double f = fmod(in->t * p->fps, (double)p->nframes);
        if (f < 0)
            f += p->nframes;
        int a = (int)f;
        if (a >= p->nframes)
            a = p->nframes - 1;
        int b = (a + 1) % p->nframes;
        al = (float)(f - a);
        Q0 = p->q + 4 * (size_t)a * p->nb;
        Q1 = p->q + 4 * (size_t)b * p->nb;
        T0 = p->tr + 3 * (size_t)a * p->nb;
        T1 = p->tr + 3 * (size_t)b * p->nb;
    }
    for (int j = 0; j < p->nb; j++) {
        const float *qa = Q0 + 4 * (size_t)j, *qb = Q1 + 4 * (size_t)j;
        const float *ta = T0 + 3 * (size_t)j, *tb = T1 + 3 * (size_t)j;
        float sg = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3] < 0 ? -1.f : 1.f;
        float q[4], n = 0;
        for (int c = 0; c < 4; c++) {
            q[c] = (1 - al) * qa[c] + al * sg * qb[c];
            n += q[c] * q[c];
        }
        n = 1 / sqrtf(n);
        float w = q[0] * n, x = q[1] * n, y = q[2] * n, z = q[3] * n;
        float *M = p->M + 12 * (size_t)j;
        M[0] = 1 - 2 * (y * y + z * z);
        M[1] = 2 * (x * y - w * z);
        M[2] = 2 * (x * z + w * y);
        M[3] = 2 * (x * y + w * z);
        M[4] = 1 - 2 * (x * x + z * z);
        M[5] = 2 * (y * z - w * x);
        M[6] = 2 * (x * z - w * y);
        M[7] = 2 * (y * z + w * x);
        M[8] = 1 - 2 * (x * x + y * y);
        for (int c = 0; c < 3; c++)
            M[9 + c] = (1 - al) * ta[c] + al * tb[c];
        float *pr = p->prm + 7 * (size_t)j;
        pr[0] = w;
        pr[1] = x;
        pr[2] = y;
        pr[3] = z;
        memcpy(pr + 4, M + 9, 3 * sizeof *M);
    }
    for (int i = 0; i < p->nv; i++) {
        const float *u = p->rest + 3 * (size_t)i;
        float o[3] = {0, 0, 0};
        for (int s = 0; s < p->K; s++) {
            float w = p->w[(size_t)p->K * i + s];
            if (w == 0)
                continue;
            const float *M = p->M + 12 * (size_t)p->bone[(size_t)p->K * i + s];
            for (int c = 0; c < 3; c++)
                o[c] += w * (M[3 * c] * u[0] + M[3 * c + 1] * u[1] + M[3 * c + 2] * u[2] + M[9 + c]);
        }
        memcpy(V + 3 * (size_t)i, o, sizeof o);
    }
    p->have_params = 1;
    return 0;
}

int mdl__skin_synth_params_layout(const void *state, mdl_params_layout *out)
{
    const skin_play *p = state;
    out->ninst = p->nb;
    out->nparts = 1;
    out->part_off = p->part_off;
    out->mean = p->rest;
    out->nmodes = p->nmodes;
    out->mode_off = p->mode_off;
    out->modes = p->rest; /* no modes: never read */
    out->inst_part = p->inst_part;
    out->slots = p->K;
    out->slot_entry = p->slot_entry;
    out->slot_inst = p->slot_inst;
    out->slot_w = p->w;
    out->nparams = 7 * p->nb;
    return 0;
}

int mdl__skin_synth_params(const void *state, float *out)
{
    const skin_play *p = state;
    if (!p->have_params)
        return -EAGAIN;
    memcpy(out, p->prm, 7 * (size_t)p->nb * sizeof *out);
    return 0;
}
