/* synth.c - the synthesis phase of paper 2012 (Fig. 3, Sec. 5), one frame at a time.
 *
 *   1. marker parameters M* of every limb (Table 1, posefeat.c), pose-adapted (Sec. 4.2)
 *   2. Phi(M*) and Psi(M*): each instance's rotation (unit quaternion), translation and shape
 *      prior lambda+ (eq. 1, 5); lambda+ is clamped to +-3 sigma (the Gaussian model of eq. 6)
 *   3. alternating least squares (Sec. 5, after [XZY*07, BBW*11]):
 *        a. greedy rigid alignment (Sec. 5.1): instances in the precomputed order, each aligned
 *           by its overlap with what is already placed (absolute orientation, rigid.h), with the
 *           predicted rotation as a prior; an instance without overlap keeps its prediction;
 *        b. shape optimisation (Sec. 5.2, eq. 7): per instance
 *             min_lambda sum_{i in O} ||x_i - x_hat_i(lambda)||^2 + beta sum_k (lambda_k - lambda+_k)^2 / sigma_k^2
 *           where x_i are the other instances' positions of the overlap vertices O, taken into the
 *           instance's local frame. The normal matrix V_O^T V_O + beta diag(1/sigma^2) depends only
 *           on the model and is factored at training; per frame this is two triangular solves.
 *      `iterations` shape steps, each followed by a new alignment.
 *   4. blending of shared clusters and overlaps with the precomputed weights of eq. (8) (Sec. 5.3)
 *   5. placement in the markers' body frame (reference edge).
 *
 * Missing markers: a marker that is invalid in a frame is held at its last valid position
 * (counted in info->markers_held); a marker never seen makes its limbs use the training mean of
 * their parameters; without a reference edge the last body frame is kept (info->reference_lost).
 * Everything is allocated in mdl_synth_create; mdl_synth_frame allocates nothing.
 */
#include "posefeat.h"
#include "linalg.h"
#include "model_internal.h"
#include "regress.h"
#include "rigid.h"
#include "util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct mdl_synth {
    const struct mdl_model *m;
    float *P, *Pprev, *Plast;  /* nmarkers x 3: this frame, previous frame, last valid */
    uint8_t *seen;             /* nmarkers: ever valid */
    int have_prev, have_body;
    double Rb[9], ob[3];
    double *feat, *z, *out;    /* scratch: max features, max features + 1, max outputs */
    double *iq, *iR, *it;      /* per instance: predicted quaternion, rotation, translation */
    double *lam, *lamp;        /* per instance modes (offset inst_lam) */
    int *inst_lam;             /* ninst + 1 */
    int *inst_pos;             /* ninst + 1: offsets (in vertices) into pos */
    float *pos;                /* positions of every instance's vertices, body frame */
    double *acc;               /* nv x 3 */
    int *cnt;                  /* nv */
    double *ybuf, *xbuf;       /* overlap scratch, 3 x max part size */
    double *rhs;               /* max modes */
};

void mdl_synth_destroy(mdl_synth *s)
{
    if (!s)
        return;
    free(s->P);
    free(s->Pprev);
    free(s->Plast);
    free(s->seen);
    free(s->feat);
    free(s->z);
    free(s->out);
    free(s->iq);
    free(s->iR);
    free(s->it);
    free(s->lam);
    free(s->lamp);
    free(s->inst_lam);
    free(s->inst_pos);
    free(s->pos);
    free(s->acc);
    free(s->cnt);
    free(s->ybuf);
    free(s->xbuf);
    free(s->rhs);
    free(s);
}

int mdl_synth_create(const mdl_model *m, mdl_synth **out, char *err)
{
    *out = NULL;
    mdl_synth *s = mdl__calloc(1, sizeof *s);
    if (!s)
        return mdl__err(err, -ENOMEM, "synth: out of memory");
    s->m = m;
    int nm = m->nmarkers, NI = m->ninst, maxd = 1, maxo = 1, maxk = 1, maxn = 1;
    for (int l = 0; l < m->nlimbs; l++) {
        if (m->reg[l].nin > maxd)
            maxd = m->reg[l].nin;
        if (m->reg[l].nout > maxo)
            maxo = m->reg[l].nout;
    }
    for (int p = 0; p < m->nparts; p++) {
        if (m->pmodes[p] > maxk)
            maxk = m->pmodes[p];
        if (m->pv_off[p + 1] - m->pv_off[p] > maxn)
            maxn = m->pv_off[p + 1] - m->pv_off[p];
    }
    s->P = mdl__calloc((size_t)nm * 3, sizeof(float));
    s->Pprev = mdl__calloc((size_t)nm * 3, sizeof(float));
    s->Plast = mdl__calloc((size_t)nm * 3, sizeof(float));
    s->seen = mdl__calloc((size_t)nm, 1);
    s->feat = mdl__calloc((size_t)maxd, sizeof(double));
    s->z = mdl__calloc((size_t)maxd + 1, sizeof(double));
    s->out = mdl__calloc((size_t)maxo, sizeof(double));
    s->iq = mdl__calloc((size_t)NI * 4, sizeof(double));
    s->iR = mdl__calloc((size_t)NI * 9, sizeof(double));
    s->it = mdl__calloc((size_t)NI * 3, sizeof(double));
    s->inst_lam = mdl__calloc((size_t)NI + 1, sizeof(int));
    s->inst_pos = mdl__calloc((size_t)NI + 1, sizeof(int));
    if (s->inst_lam && s->inst_pos)
        for (int i = 0; i < NI; i++) {
            int p = m->inst_part[i];
            s->inst_lam[i + 1] = s->inst_lam[i] + m->pmodes[p];
            s->inst_pos[i + 1] = s->inst_pos[i] + m->pv_off[p + 1] - m->pv_off[p];
        }
    s->lam = mdl__calloc((size_t)(s->inst_lam ? s->inst_lam[NI] : 0) + 1, sizeof(double));
    s->lamp = mdl__calloc((size_t)(s->inst_lam ? s->inst_lam[NI] : 0) + 1, sizeof(double));
    s->pos = mdl__calloc((size_t)(s->inst_pos ? s->inst_pos[NI] : 0) * 3 + 1, sizeof(float));
    s->acc = mdl__calloc((size_t)m->nv * 3, sizeof(double));
    s->cnt = mdl__calloc((size_t)m->nv, sizeof(int));
    s->ybuf = mdl__calloc((size_t)maxn * 3, sizeof(double));
    s->xbuf = mdl__calloc((size_t)maxn * 3, sizeof(double));
    s->rhs = mdl__calloc((size_t)maxk, sizeof(double));
    if (!s->P || !s->Pprev || !s->Plast || !s->seen || !s->feat || !s->z || !s->out || !s->iq ||
        !s->iR || !s->it || !s->inst_lam || !s->inst_pos || !s->lam || !s->lamp || !s->pos ||
        !s->acc || !s->cnt || !s->ybuf || !s->xbuf || !s->rhs) {
        mdl_synth_destroy(s);
        return mdl__err(err, -ENOMEM, "synth: out of memory");
    }
    *out = s;
    return 0;
}

void mdl_synth_reset(mdl_synth *s)
{
    memset(s->seen, 0, (size_t)s->m->nmarkers);
    s->have_prev = 0;
    s->have_body = 0;
}

/* Positions of local vertex j of instance i: R (mean + V lambda) + t. */
static void inst_local_shape(const mdl_synth *s, int i, int j, double y[3])
{
    const struct mdl_model *m = s->m;
    int p = m->inst_part[i], k = m->pmodes[p], n = m->pv_off[p + 1] - m->pv_off[p];
    const float *mean = m->part_mean + 3 * ((size_t)m->pv_off[p] + j);
    const float *V = m->part_modes + m->pm_off[p] + 3 * (size_t)j;
    const double *lam = s->lam + s->inst_lam[i];
    y[0] = mean[0];
    y[1] = mean[1];
    y[2] = mean[2];
    for (int a = 0; a < k; a++) {
        const float *va = V + (size_t)a * 3 * n;
        y[0] += lam[a] * va[0];
        y[1] += lam[a] * va[1];
        y[2] += lam[a] * va[2];
    }
}

/* Writes all of instance i's vertices (body frame) into pos, and adds them to acc/cnt. */
static void inst_emit(mdl_synth *s, int i, int accumulate)
{
    const struct mdl_model *m = s->m;
    int p = m->inst_part[i], n = m->pv_off[p + 1] - m->pv_off[p];
    const double *R = s->iR + 9 * i, *t = s->it + 3 * i;
    float *out = s->pos + 3 * (size_t)s->inst_pos[i];
    const int *idx = m->pv_idx + m->pv_off[p];
    for (int j = 0; j < n; j++) {
        double y[3];
        inst_local_shape(s, i, j, y);
        for (int r = 0; r < 3; r++) {
            double x = R[3 * r] * y[0] + R[3 * r + 1] * y[1] + R[3 * r + 2] * y[2] + t[r];
            out[3 * j + r] = (float)x;
            if (accumulate)
                s->acc[3 * (size_t)idx[j] + r] += x;
        }
        if (accumulate)
            s->cnt[idx[j]]++;
    }
}

/* Sec. 5.1: greedy rigid alignment with the predicted rotations as a prior. */
static void align_all(mdl_synth *s)
{
    const struct mdl_model *m = s->m;
    memset(s->acc, 0, sizeof(double) * 3 * (size_t)m->nv);
    memset(s->cnt, 0, sizeof(int) * (size_t)m->nv);
    for (int step = 0; step < m->ninst; step++) {
        int i = m->order[step], p = m->inst_part[i];
        const int *idx = m->pv_idx + m->pv_off[p];
        int a = m->order_ov_off[step], b = m->order_ov_off[step + 1], n = b - a;
        double Rp[9];
        mdl__quat_to_mat(s->iq + 4 * i, Rp);
        if (n >= 3) {
            for (int o = 0; o < n; o++) {
                int j = m->order_ov[a + o], v = idx[j];
                inst_local_shape(s, i, j, s->ybuf + 3 * o);
                for (int r = 0; r < 3; r++)
                    s->xbuf[3 * o + r] = s->acc[3 * (size_t)v + r] / s->cnt[v];
            }
            double cy[3] = {0}, cx[3] = {0};
            for (int o = 0; o < n; o++)
                for (int r = 0; r < 3; r++) {
                    cy[r] += s->ybuf[3 * o + r];
                    cx[r] += s->xbuf[3 * o + r];
                }
            for (int r = 0; r < 3; r++) {
                cy[r] /= n;
                cx[r] /= n;
            }
            double S[9] = {0}, spread = 0;
            for (int o = 0; o < n; o++) {
                double yy[3], xx[3];
                for (int r = 0; r < 3; r++) {
                    yy[r] = s->ybuf[3 * o + r] - cy[r];
                    xx[r] = s->xbuf[3 * o + r] - cx[r];
                    spread += yy[r] * yy[r];
                }
                for (int r = 0; r < 3; r++)
                    for (int c = 0; c < 3; c++)
                        S[3 * r + c] += yy[r] * xx[c];
            }
            /* prior: + mu * Rp^T (rigid.h) */
            double mu = m->prior_weight * spread;
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++)
                    S[3 * r + c] += mu * Rp[3 * c + r];
            double q[4];
            double *R = s->iR + 9 * i, *t = s->it + 3 * i;
            mdl__rot_from_cov(S, q, R);
            for (int r = 0; r < 3; r++)
                t[r] = cx[r] - (R[3 * r] * cy[0] + R[3 * r + 1] * cy[1] + R[3 * r + 2] * cy[2]);
        } else {
            memcpy(s->iR + 9 * i, Rp, sizeof Rp);
            /* translation stays as predicted (set in mdl_synth_frame) */
        }
        inst_emit(s, i, 1);
    }
}

/* Sec. 5.2, eq. (7), for every instance with modes. */
static void optimise_shapes(mdl_synth *s)
{
    const struct mdl_model *m = s->m;
    for (int i = 0; i < m->ninst; i++) {
        int p = m->inst_part[i], k = m->pmodes[p], n = m->pv_off[p + 1] - m->pv_off[p];
        if (k == 0)
            continue;
        const int *idx = m->pv_idx + m->pv_off[p];
        const double *R = s->iR + 9 * i, *t = s->it + 3 * i;
        const float *pos = s->pos + 3 * (size_t)s->inst_pos[i];
        const double *sig2 = m->part_sigma2 + m->ps_off[p];
        const double *lamp = s->lamp + s->inst_lam[i];
        for (int a = 0; a < k; a++)
            s->rhs[a] = m->beta * lamp[a] / sig2[a];
        for (int o = m->sov_off[i]; o < m->sov_off[i + 1]; o++) {
            int j = m->sov[o], v = idx[j];
            if (s->cnt[v] < 2)
                continue;
            double x[3], d[3], loc[3];
            for (int r = 0; r < 3; r++) { /* mean of the other instances' positions */
                x[r] = (s->acc[3 * (size_t)v + r] - pos[3 * j + r]) / (s->cnt[v] - 1);
                d[r] = x[r] - t[r];
            }
            for (int c = 0; c < 3; c++)
                loc[c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
            const float *mean = m->part_mean + 3 * ((size_t)m->pv_off[p] + j);
            const float *V = m->part_modes + m->pm_off[p] + 3 * (size_t)j;
            for (int a = 0; a < k; a++) {
                const float *va = V + (size_t)a * 3 * n;
                s->rhs[a] += va[0] * (loc[0] - mean[0]) + va[1] * (loc[1] - mean[1]) +
                             va[2] * (loc[2] - mean[2]);
            }
        }
        if (mdl_la_potrs(k, 1, m->chol + m->chol_off[i], k, s->rhs, k, NULL) == 0)
            memcpy(s->lam + s->inst_lam[i], s->rhs, sizeof(double) * (size_t)k);
    }
}

int mdl_synth_frame(mdl_synth *s, const float *markers, const uint8_t *valid, float *Vout,
                    mdl_synth_info *info)
{
    const struct mdl_model *m = s->m;
    int nm = m->nmarkers, missing = 0, held = 0;
    mdl_synth_info dummy;
    if (!info)
        info = &dummy;
    memset(info, 0, sizeof *info);
    for (int j = 0; j < nm; j++) {
        const float *p = markers + 3 * j;
        int ok = (!valid || valid[j]) && isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
        if (ok) {
            memcpy(s->Plast + 3 * j, p, 3 * sizeof(float));
            s->seen[j] = 1;
        } else {
            missing++;
            held += s->seen[j];
        }
        memcpy(s->P + 3 * j, s->Plast + 3 * j, 3 * sizeof(float));
    }
    info->markers_missing = missing;
    info->markers_held = held;
    int refok = 1;
    for (int r = 0; r < m->nref; r++)
        refok &= s->seen[m->ref[r]];
    double R[9], o[3];
    if (refok && mdl__body_frame(s->P, m->nref, m->ref, R, o) == 0) {
        memcpy(s->Rb, R, sizeof R);
        memcpy(s->ob, o, sizeof o);
        s->have_body = 1;
    } else {
        info->reference_lost = 1;
        if (!s->have_body)
            return -EAGAIN;
    }
    /* 1-2. parameters and predictions per limb */
    for (int l = 0; l < m->nlimbs; l++) {
        const mdl_limb_reg *rg = &m->reg[l];
        const int *path = m->limb_idx + m->limb_off[l];
        int plen = m->limb_off[l + 1] - m->limb_off[l], all = 1;
        for (int j = 0; j < plen; j++)
            all &= s->seen[path[j]];
        if (all) {
            mdl__limb_features(s->P, s->have_prev ? s->Pprev : NULL, path, plen, s->Rb, s->ob,
                               m->use_motion_dir, s->feat);
            for (int j = 0; j < rg->nin; j++)
                s->feat[j] = rg->feat_scale[j] * s->feat[j] + rg->feat_shift[j];
        } else {
            for (int j = 0; j < rg->nin; j++)
                s->feat[j] = rg->in_mean[j];
        }
        mdl__ridge_predict(rg->coef, rg->nin, rg->nout, rg->in_mean, rg->in_sd, s->feat, s->z, s->out);
        for (int i = 0; i < m->ninst; i++) {
            if (m->inst_limb[i] != l)
                continue;
            const double *y = s->out + m->inst_out[i];
            double *q = s->iq + 4 * i, nq = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3]);
            for (int c = 0; c < 4; c++)
                q[c] = nq > 1e-9 ? y[c] / nq : (c == 0);
            for (int c = 0; c < 3; c++)
                s->it[3 * i + c] = y[4 + c];
            int p = m->inst_part[i], k = m->pmodes[p];
            const double *sig2 = m->part_sigma2 + m->ps_off[p];
            for (int a = 0; a < k; a++) {
                double lim = 3 * sqrt(sig2[a]), v = y[7 + a];
                v = v > lim ? lim : v < -lim ? -lim : v;
                s->lamp[s->inst_lam[i] + a] = v;
                s->lam[s->inst_lam[i] + a] = v;
            }
        }
    }
    memcpy(s->Pprev, s->P, sizeof(float) * 3 * (size_t)nm);
    s->have_prev = 1;
    /* 3. alternate alignment and shape optimisation */
    align_all(s);
    for (int it = 0; it < m->iterations; it++) {
        optimise_shapes(s);
        align_all(s);
    }
    /* 4-5. blend (eq. 8) and place in the markers' frame */
    for (int v = 0; v < m->nv; v++) {
        double x[3] = {0, 0, 0};
        for (int b = m->blend_off[v]; b < m->blend_off[v + 1]; b++) {
            const float *p = s->pos + 3 * ((size_t)s->inst_pos[m->blend_inst[b]] + m->blend_local[b]);
            float w = m->blend_w[b];
            x[0] += w * p[0];
            x[1] += w * p[1];
            x[2] += w * p[2];
        }
        for (int r = 0; r < 3; r++)
            Vout[3 * v + r] = (float)(s->Rb[3 * r] * x[0] + s->Rb[3 * r + 1] * x[1] +
                                      s->Rb[3 * r + 2] * x[2] + s->ob[r]);
    }
    return 0;
}
