/* ssdr_transforms.c - the bone transformation update of SSDR [Le & Deng 2012, the transforms
 * sub-problem] (ssdr.h).
 *
 * With the weights and every other bone fixed, the transform of bone j in frame t solves
 *   min_{R,T} sum_i || q_i - w_ij (R p_i + T) ||^2,   q_i = v_i^t - sum_{k != j} w_ik (R_k p_i + T_k)
 * a weighted orthogonal Procrustes problem with the closed form (Le & Deng's derivation):
 *   pbar = sum_i w_ij^2 p_i / sum_i w_ij^2,   qbar = sum_i w_ij q_i / sum_i w_ij^2,
 *   R = the rotation maximising tr(R^T sum_i w_ij q_i (p_i - pbar)^T)   (polar factor / Horn,
 *       core/rigid.h),   T = qbar - R pbar.
 * Frames are independent; bones are updated one after the other (block coordinate descent), each
 * with the residual r_i = v_i - sum_k w_ik (R_k p_i + T_k) kept current, so one bone costs a pass
 * over its support only. A bone without support keeps its transform. */
#include "skin/ssdr.h"
#include "core/linalg.h"
#include "core/rigid.h"

#include <math.h>
#include <string.h>

void mdl__ssdr_supports(mdl__ssdr *s)
{
    int nb = s->nb, K = s->K, nv = s->nv;
    memset(s->sup_off, 0, ((size_t)nb + 1) * sizeof *s->sup_off);
    for (size_t q = 0; q < (size_t)nv * K; q++)
        if (s->w[q] > 0)
            s->sup_off[s->bone[q] + 1]++;
    for (int j = 0; j < nb; j++)
        s->sup_off[j + 1] += s->sup_off[j];
    int *at = s->label; /* borrowed as a cursor: nb <= nv */
    for (int j = 0; j < nb; j++)
        at[j] = s->sup_off[j];
    for (int i = 0; i < nv; i++)
        for (int q = 0; q < K; q++) {
            double w = s->w[(size_t)K * i + q];
            if (w > 0) {
                int j = s->bone[(size_t)K * i + q], e = at[j]++;
                s->sup_v[e] = i;
                s->sup_w[e] = w;
            }
        }
    for (int j = 0; j < nb; j++) {
        double w2 = 0, u[3] = {0, 0, 0};
        for (int e = s->sup_off[j]; e < s->sup_off[j + 1]; e++) {
            double ww = s->sup_w[e] * s->sup_w[e];
            const double *p = s->U + 3 * (size_t)s->sup_v[e];
            w2 += ww;
            for (int c = 0; c < 3; c++)
                u[c] += ww * p[c];
        }
        s->sup_w2[j] = w2;
        for (int c = 0; c < 3; c++)
            s->sup_ubar[3 * j + c] = w2 > 0 ? u[c] / w2 : 0;
    }
    /* restore the labels: the bone of largest weight (slot 0 holds it, ssdr_weights.c) */
    for (int i = 0; i < nv; i++)
        s->label[i] = s->bone[(size_t)K * i];
}

static inline void apply(const double *T, const double *p, double *o)
{
    for (int a = 0; a < 3; a++)
        o[a] = T[3 * a] * p[0] + T[3 * a + 1] * p[1] + T[3 * a + 2] * p[2] + T[9 + a];
}

double mdl__ssdr_transforms_frame(mdl__ssdr *s, int t, int sweeps, double *r, double *max_sq)
{
    int nv = s->nv, nb = s->nb, K = s->K;
    const double *X0 = s->X + (size_t)nv * 3 * t;
    double *Tf = s->T + 12 * (size_t)t * nb;
    for (int i = 0; i < nv; i++) {
        double acc[3] = {X0[i], X0[i + nv], X0[i + 2 * (size_t)nv]}, o[3];
        for (int q = 0; q < K; q++) {
            double w = s->w[(size_t)K * i + q];
            if (w == 0)
                continue;
            apply(Tf + 12 * (size_t)s->bone[(size_t)K * i + q], s->U + 3 * (size_t)i, o);
            for (int c = 0; c < 3; c++)
                acc[c] -= w * o[c];
        }
        memcpy(r + 3 * (size_t)i, acc, sizeof acc);
    }
    for (int sw = 0; sw < sweeps; sw++)
        for (int j = 0; j < nb; j++) {
            int e0 = s->sup_off[j], e1 = s->sup_off[j + 1];
            if (e1 == e0 || !(s->sup_w2[j] > 0))
                continue;
            double *T = Tf + 12 * (size_t)j;
            const double *ub = s->sup_ubar + 3 * (size_t)j;
            double S[9] = {0}, wq[3] = {0, 0, 0}, o[3];
            for (int e = e0; e < e1; e++) {
                int i = s->sup_v[e];
                double w = s->sup_w[e], q[3];
                const double *p = s->U + 3 * (size_t)i;
                apply(T, p, o);
                for (int c = 0; c < 3; c++) {
                    q[c] = w * (r[3 * (size_t)i + c] + w * o[c]);
                    wq[c] += q[c];
                }
                /* S[3a + b] = sum w (p - pbar)_a q_b  (source p, target q: rigid.h) */
                for (int a = 0; a < 3; a++) {
                    double pa = p[a] - ub[a];
                    S[3 * a] += pa * q[0];
                    S[3 * a + 1] += pa * q[1];
                    S[3 * a + 2] += pa * q[2];
                }
            }
            double R[9], Tn[12];
            mdl__rot_polar(S, R);
            memcpy(Tn, R, sizeof R);
            for (int a = 0; a < 3; a++)
                Tn[9 + a] = wq[a] / s->sup_w2[j] -
                            (R[3 * a] * ub[0] + R[3 * a + 1] * ub[1] + R[3 * a + 2] * ub[2]);
            double on[3];
            for (int e = e0; e < e1; e++) {
                int i = s->sup_v[e];
                double w = s->sup_w[e];
                const double *p = s->U + 3 * (size_t)i;
                apply(T, p, o);
                apply(Tn, p, on);
                for (int c = 0; c < 3; c++)
                    r[3 * (size_t)i + c] += w * (o[c] - on[c]);
            }
            memcpy(T, Tn, sizeof Tn);
        }
    double E = 0, mx = 0;
    for (int i = 0; i < nv; i++) {
        const double *ri = r + 3 * (size_t)i;
        double e = ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2];
        E += e;
        if (e > mx)
            mx = e;
    }
    if (max_sq)
        *max_sq = mx;
    return E;
}

/* ------------------------------------------------------------------ the fast update
 *
 * With p~ = (p, 1) and M_k = [R_k | T_k] (3 x 4), the sums the closed form needs are linear in the
 * frame's data (Le & Deng's precomputation):
 *   Sfull_j = sum_i w_ij q_i p~_i^T = B_j - sum_{k != j} M_k C_jk,
 *   B_j = sum_i w_ij v_i p~_i^T (a pass over the bone's support, all frames at once),
 *   C_jk = sum_i w_ij w_ik p~_i p~_i^T (frame-independent, 4 x 4),
 * so sum_i w_ij q_i is Sfull_j's last column, the cross-covariance is
 *   S = sum_i w_ij (p_i - pbar) q_i^T = (Sfull_j[:, 0:3] - wq pbar^T)^T,
 * and the frame's error is E_t = sum_i |v_i|^2 - 2 sum_j <M_j, B_j> + sum_jk <M_j C_jk, M_k>. */


/* B_j = sum over the support of bone j of w_ij Xt[:, i] p~_i^T: one bone per task, so the sums
 * are formed in the same order whatever the workers */
static void b_bone(void *ctx, int j, int worker)
{
    mdl__ssdr *s = ctx;
    (void)worker;
    int ld = 3 * s->nf;
    double *B0 = s->B + (size_t)ld * 4 * j;
    memset(B0, 0, (size_t)ld * 4 * sizeof *B0);
    for (int e = s->sup_off[j]; e < s->sup_off[j + 1]; e++) {
        int i = s->sup_v[e];
        double w = s->sup_w[e];
        const double *p = s->U + 3 * (size_t)i, *x = s->Xt + (size_t)ld * i;
        double c0 = w * p[0], c1 = w * p[1], c2 = w * p[2];
        for (int r = 0; r < ld; r++) {
            double v = x[r];
            B0[r] += c0 * v;
            B0[r + ld] += c1 * v;
            B0[r + 2 * (size_t)ld] += c2 * v;
            B0[r + 3 * (size_t)ld] += w * v;
        }
    }
}

static void sums_setup(mdl__ssdr *s)
{
    int nv = s->nv, nb = s->nb, K = s->K;
    memset(s->C, 0, (size_t)nb * nb * 16 * sizeof *s->C);
    for (int i = 0; i < nv; i++) {
        const double *u = s->U + 3 * (size_t)i;
        double pt[4] = {u[0], u[1], u[2], 1}, pp[16];
        for (int b = 0; b < 4; b++)
            for (int d = 0; d < 4; d++)
                pp[4 * b + d] = pt[b] * pt[d];
        for (int q = 0; q < K; q++) {
            double wq = s->w[(size_t)K * i + q];
            if (wq == 0)
                continue;
            int j = s->bone[(size_t)K * i + q];
            for (int r = 0; r < K; r++) {
                double wr = s->w[(size_t)K * i + r];
                if (wr == 0)
                    continue;
                double *C = s->C + 16 * ((size_t)j * nb + s->bone[(size_t)K * i + r]);
                for (int e = 0; e < 16; e++)
                    C[e] += wq * wr * pp[e];
            }
        }
    }
    for (int j = 0; j < nb; j++) {
        s->cnum[j] = 0;
        for (int k = 0; k < nb; k++)
            if (k != j && s->C[16 * ((size_t)j * nb + k) + 15] != 0)
                s->cadj[(size_t)j * nb + s->cnum[j]++] = k;
    }
    mdl__ssdr_parallel(s, nb, b_bone, s);
}

/* Sfull = B_j - sum_{k in adj} M_k C_jk (or all k with self = 1: sum over k including j) */
static void sfull(const mdl__ssdr *s, int t, int j, int self, double Sf[12])
{
    int nb = s->nb, ld = 3 * s->nf;
    const double *Tf = s->T + 12 * (size_t)t * nb;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 4; b++)
            Sf[4 * a + b] = s->B[(3 * t + a) + (size_t)ld * (4 * j + b)];
    for (int n = 0; n < s->cnum[j] + self; n++) {
        int k = n < s->cnum[j] ? s->cadj[(size_t)j * nb + n] : j;
        const double *T = Tf + 12 * (size_t)k, *C = s->C + 16 * ((size_t)j * nb + k);
        for (int a = 0; a < 3; a++) {
            double m[4] = {T[3 * a], T[3 * a + 1], T[3 * a + 2], T[9 + a]};
            for (int d = 0; d < 4; d++)
                Sf[4 * a + d] -= m[0] * C[d] + m[1] * C[4 + d] + m[2] * C[8 + d] + m[3] * C[12 + d];
        }
    }
}

static void trans_fast(void *ctx, int t, int worker)
{
    mdl__ssdr *s = ctx;
    (void)worker;
    int nb = s->nb, ld = 3 * s->nf;
    double *Tf = s->T + 12 * (size_t)t * nb;
    for (int sw = 0; sw < s->trans_sweeps; sw++)
        for (int j = 0; j < nb; j++) {
            if (!(s->sup_w2[j] > 0))
                continue;
            double Sf[12], S[9], R[9];
            sfull(s, t, j, 0, Sf);
            const double *ub = s->sup_ubar + 3 * (size_t)j;
            double wq[3] = {Sf[3], Sf[7], Sf[11]};
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    S[3 * a + b] = Sf[4 * b + a] - wq[b] * ub[a];
            mdl__rot_polar(S, R);
            double *T = Tf + 12 * (size_t)j;
            memcpy(T, R, sizeof R);
            for (int a = 0; a < 3; a++)
                T[9 + a] = wq[a] / s->sup_w2[j] -
                           (R[3 * a] * ub[0] + R[3 * a + 1] * ub[1] + R[3 * a + 2] * ub[2]);
        }
    /* E_t = vv - 2 sum_j <M_j, B_j> + sum_j <M_j, sum_k M_k C_jk>: with Sf(self) = B_j - sum_k M_k
     * C_jk, E_t = vv - sum_j <M_j, B_j> - sum_j <M_j, Sf_j>... written out: */
    double E = s->vvt[t];
    for (int j = 0; j < nb; j++) {
        if (!(s->sup_w2[j] > 0))
            continue;
        double Sf[12];
        sfull(s, t, j, 1, Sf);
        const double *T = Tf + 12 * (size_t)j;
        for (int a = 0; a < 3; a++) {
            double m[4] = {T[3 * a], T[3 * a + 1], T[3 * a + 2], T[9 + a]};
            for (int b = 0; b < 4; b++) {
                double Bv = s->B[(3 * t + a) + (size_t)ld * (4 * j + b)];
                /* <M,B> - 2<M,B> + <M, B - Sf> = -<M, Sf>  -  <M,B> + <M,B>: E = vv - <M,B> - <M,Sf> */
                E -= m[b] * (Bv + Sf[4 * a + b]);
            }
        }
    }
    s->ferr[t] = E > 0 ? E : 0;
}

typedef struct tctx {
    mdl__ssdr *s;
    int sweeps;
} tctx;

static void trans_frame(void *ctx, int t, int worker)
{
    tctx *c = ctx;
    mdl__ssdr *s = c->s;
    s->ferr[t] = mdl__ssdr_transforms_frame(s, t, c->sweeps, s->Rw + (size_t)worker * 3 * s->nv,
                                            &s->fmax[t]);
}

double mdl__ssdr_transforms(mdl__ssdr *s, int sweeps, double *max_sq)
{
    mdl__ssdr_supports(s);
    sums_setup(s);
    int keep = s->trans_sweeps;
    s->trans_sweeps = sweeps;
    mdl__ssdr_parallel(s, s->nf, trans_fast, s);
    s->trans_sweeps = keep;
    double E = 0, mx = 0;
    if (max_sq) { /* the explicit residuals, for the largest error (and an exact E) */
        tctx c = {s, 0};
        mdl__ssdr_parallel(s, s->nf, trans_frame, &c);
        for (int t = 0; t < s->nf; t++)
            if (s->fmax[t] > mx)
                mx = s->fmax[t];
        *max_sq = mx;
    }
    for (int t = 0; t < s->nf; t++)
        E += s->ferr[t];
    return E;
}
