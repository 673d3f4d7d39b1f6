/* ssdr_weights.c - the weight update of SSDR [Le & Deng 2012, the weights sub-problem] (ssdr.h).
 *
 * With every bone transform fixed, the weights of vertex i are independent of all others:
 *   min_w || A_i w - v_i ||^2   s.t.  w >= 0,  1^T w = 1,  ||w||_0 <= K
 * (A_i: 3F x nb, column j the frames of [R_j^t | T_j^t] p~_i stacked). Le & Deng solve it as a
 * non-negative least-squares problem with the affinity constraint over all bones, keep the K
 * largest weights, and solve again on those K only. We do the same, on the normal equations
 * (Q = A^T A, c = A^T v, formed as in ssdr.h without building A), with an active-set method
 * [Lawson & Hanson 1974, "Solving Least Squares Problems", Ch. 23, NNLS] extended by the equality
 * 1^T w = 1: on the passive set P the equality-constrained minimiser is
 *   z = Q_PP^-1 (c_P - lambda 1),  lambda = (1^T Q_PP^-1 c_P - 1) / (1^T Q_PP^-1 1),
 * and a bone j outside P enters when its gradient g_j = (Q w - c)_j lies below the common
 * gradient of P (the KKT conditions of the simplex). Every iterate stays on the simplex, so the
 * unit sum holds to rounding; it is renormalised at the end (Zheng 2013 Sec. 3.3 needs it exact).
 * The optional smoothness term (Dem Bones' weightsSmooth idea) adds lambda_s |w - wbar_i|^2,
 * wbar_i the mean of the neighbours' weights of the previous sweep (Jacobi, so the result does not
 * depend on the order the vertices are solved in).
 * A tiny ridge (1e-12 of the largest diagonal) keeps Q_PP definite when two bones move alike. */
#include "skin/ssdr.h"
#include "core/linalg.h"

#include <math.h>
#include <string.h>

size_t mdl__ssdr_nnls_scratch(int n)
{
    /* qcol n*n, L n*n, w n, g n, dq n, flags n, z n, a n, b n, allowed n, cur n */
    return (size_t)n * n * 2 + 10 * (size_t)n + 8;
}

/* The active-set solve over the allowed candidates; returns |P| and leaves the weights in w[] (n). */
static int active_set(int n, const double *c, double (*qf)(void *, int, int), void *ctx,
                      double ridge, const unsigned char *allowed, double *S, int *P)
{
    double *qcol = S, *L = qcol + (size_t)n * n, *w = L + (size_t)n * n, *g = w + n, *dq = g + n,
           *flag = dq + n, *z = flag + n, *a = z + n, *b = a + n;
    int np = 0;
    int j0 = -1;
    double best = INFINITY;
    for (int j = 0; j < n; j++) {
        w[j] = 0;
        flag[j] = 0; /* 0 out, 1 in P, -1 banned */
        if (!allowed[j])
            continue;
        dq[j] = qf(ctx, j, j);
        double e = dq[j] - 2 * c[j];
        if (e < best) {
            best = e;
            j0 = j;
        }
    }
    if (j0 < 0)
        return 0;
    double dmax = 0;
    for (int j = 0; j < n; j++)
        if (allowed[j] && fabs(dq[j]) > dmax)
            dmax = fabs(dq[j]);
    double tol = 1e-13 * (dmax + 1e-300);
#define LOADCOL(p, jj)                                                                             \
    do {                                                                                           \
        for (int k = 0; k < n; k++)                                                                \
            qcol[(size_t)(p) * n + k] =                                                            \
                allowed[k] ? (k == (jj) ? dq[k] : qf(ctx, k, (jj))) + (k == (jj) ? ridge : 0) : 0; \
    } while (0)
    P[np] = j0;
    LOADCOL(np, j0);
    np++;
    flag[j0] = 1;
    w[j0] = 1;
    for (int outer = 0; outer < 3 * n + 3; outer++) {
        double gam = 0;
        for (int k = 0; k < n; k++) {
            if (!allowed[k])
                continue;
            double v = -c[k];
            for (int p = 0; p < np; p++)
                v += qcol[(size_t)p * n + k] * w[P[p]];
            g[k] = v;
        }
        for (int p = 0; p < np; p++)
            gam += w[P[p]] * g[P[p]];
        int js = -1;
        double gmin = gam - tol;
        for (int k = 0; k < n; k++)
            if (allowed[k] && flag[k] == 0 && g[k] < gmin) {
                gmin = g[k];
                js = k;
            }
        if (js < 0)
            break;
        P[np] = js;
        LOADCOL(np, js);
        np++;
        flag[js] = 1;
        for (int inner = 0; inner < 3 * n + 3; inner++) {
            /* the equality-constrained minimiser on P */
            for (int r = 0; r < np; r++)
                for (int q = 0; q < np; q++)
                    L[r + (size_t)q * np] = qcol[(size_t)q * n + P[r]];
            int ok = mdl_la_potrf1(np, L, np) == 0;
            if (ok) {
                for (int r = 0; r < np; r++) {
                    a[r] = c[P[r]];
                    b[r] = 1;
                }
                ok = mdl_la_potrs1(np, L, np, a) == 0 && mdl_la_potrs1(np, L, np, b) == 0;
            }
            double sa = 0, sb = 0;
            if (ok) {
                for (int r = 0; r < np; r++) {
                    sa += a[r];
                    sb += b[r];
                }
                ok = sb > 0;
            }
            if (!ok) { /* numerically singular: drop the newest bone and stop growing */
                np--;
                flag[P[np]] = -1;
                w[P[np]] = 0;
                break;
            }
            double lam = (sa - 1) / sb, alpha = 1;
            int feasible = 1;
            for (int r = 0; r < np; r++) {
                z[r] = a[r] - lam * b[r];
                if (z[r] <= 0) {
                    feasible = 0;
                    double wp = w[P[r]], t = wp / (wp - z[r]);
                    if (t < alpha)
                        alpha = t;
                }
            }
            if (feasible) {
                for (int r = 0; r < np; r++)
                    w[P[r]] = z[r];
                break;
            }
            for (int r = 0; r < np; r++)
                w[P[r]] += alpha * (z[r] - w[P[r]]);
            /* drop the bones that reached zero */
            int keep = 0;
            for (int r = 0; r < np; r++) {
                int j = P[r];
                if (w[j] <= 1e-15 && z[r] <= 0) {
                    w[j] = 0;
                    flag[j] = j == js ? -1 : 0;
                    continue;
                }
                if (keep != r) {
                    P[keep] = j;
                    memcpy(qcol + (size_t)keep * n, qcol + (size_t)r * n, (size_t)n * sizeof *qcol);
                }
                keep++;
            }
            np = keep;
            if (np == 0) { /* cannot happen on the simplex; be safe */
                P[0] = j0;
                LOADCOL(0, j0);
                np = 1;
                w[j0] = 1;
                flag[j0] = 1;
                break;
            }
        }
    }
#undef LOADCOL
    return np;
}

int mdl__ssdr_nnls(int n, const double *c, double (*qf)(void *ctx, int j, int k), void *ctx,
                   int K, double ridge, double *scratch, int *out_bone, double *out_w)
{
    unsigned char *allowed = (unsigned char *)(scratch + mdl__ssdr_nnls_scratch(n) - 2 * (size_t)n - 4);
    int *P = (int *)(scratch + mdl__ssdr_nnls_scratch(n) - (size_t)n - 2);
    double *w = scratch + 2 * (size_t)n * n;
    memset(allowed, 1, (size_t)n);
    int np = active_set(n, c, qf, ctx, ridge, allowed, scratch, P);
    if (np > K) {
        /* keep the K largest and solve again on them alone */
        memset(allowed, 0, (size_t)n);
        for (int s = 0; s < K; s++) {
            int bj = -1;
            for (int r = 0; r < np; r++)
                if (!allowed[P[r]] && (bj < 0 || w[P[r]] > w[bj]))
                    bj = P[r];
            allowed[bj] = 1;
        }
        np = active_set(n, c, qf, ctx, ridge, allowed, scratch, P);
    }
    /* out: by descending weight, renormalised to a unit sum */
    double sum = 0;
    for (int r = 0; r < np; r++)
        sum += w[P[r]];
    int cnt = 0;
    for (int s = 0; s < np && s < K; s++) {
        int bj = -1;
        for (int r = 0; r < np; r++)
            if (w[P[r]] >= 0 && (bj < 0 || w[P[r]] > w[bj]))
                bj = P[r];
        out_bone[cnt] = bj;
        out_w[cnt] = w[bj] / sum;
        w[bj] = -1;
        cnt++;
    }
    double s2 = 0;
    for (int r = 1; r < cnt; r++)
        s2 += out_w[r];
    out_w[0] = 1 - s2; /* the largest absorbs the rounding: the sum is 1 to one ulp */
    return cnt;
}

/* ------------------------------------------------------------------ the normal equations */

void mdl__ssdr_normal_setup(mdl__ssdr *s)
{
    int nf = s->nf, nb = s->nb, ldm = 3 * nf;
    for (int t = 0; t < nf; t++)
        for (int j = 0; j < nb; j++) {
            const double *T = s->T + 12 * ((size_t)t * nb + j);
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 4; b++)
                    s->M[(3 * t + a) + (size_t)ldm * (4 * j + b)] = b < 3 ? T[3 * a + b] : T[9 + a];
        }
    mdl_la_gemm('T', 'N', 4 * nb, 4 * nb, ldm, 1, s->M, ldm, s->M, ldm, 0, s->G, 4 * nb);
}

double mdl__ssdr_q(const mdl__ssdr *s, const double pt[4], int j, int k)
{
    size_t L = 4 * (size_t)s->nb;
    const double *G = s->G + 4 * (size_t)j + L * 4 * (size_t)k;
    double v = 0;
    for (int d = 0; d < 4; d++) {
        const double *col = G + L * d;
        v += pt[d] * (pt[0] * col[0] + pt[1] * col[1] + pt[2] * col[2] + pt[3] * col[3]);
    }
    return v;
}

void mdl__ssdr_block_cd(mdl__ssdr *s, int i0, int i1, double *y, double *c, double *d)
{
    int m = i1 - i0, nb = s->nb, ldm = 3 * s->nf;
    mdl_la_gemm('N', 'N', m, 4 * nb, ldm, 1, s->X + i0, s->nv, s->M, ldm, 0, y, m);
    for (int ii = 0; ii < m; ii++) {
        const double *u = s->U + 3 * (size_t)(i0 + ii);
        double pt[4] = {u[0], u[1], u[2], 1};
        for (int j = 0; j < nb; j++) {
            const double *yj = y + ii + (size_t)m * 4 * j;
            c[(size_t)ii * nb + j] = yj[0] * pt[0] + yj[m] * pt[1] + yj[2 * (size_t)m] * pt[2] +
                                     yj[3 * (size_t)m] * pt[3];
            if (d)
                d[(size_t)ii * nb + j] = mdl__ssdr_q(s, pt, j, j);
        }
    }
}

/* ------------------------------------------------------------------ the sweep */

typedef struct vctx {
    const mdl__ssdr *s;
    const int *cand; /* local index -> bone */
    double pt[4];
    double lam;
} vctx;

static double vq(void *ctx, int j, int k)
{
    vctx *v = ctx;
    return mdl__ssdr_q(v->s, v->pt, v->cand[j], v->cand[k]) + (j == k ? v->lam : 0);
}

/* w^T Q w - 2 c^T w over K slots (bones mapped to local indices by loc) */
static double objective(vctx *v, const double *c, const int *loc, const int *b, const double *w,
                        int K)
{
    double e = 0;
    for (int p = 0; p < K; p++) {
        if (w[p] == 0)
            continue;
        e -= 2 * c[loc[b[p]]] * w[p];
        for (int q = 0; q < K; q++)
            if (w[q] != 0)
                e += w[p] * w[q] * vq(v, loc[b[p]], loc[b[q]]);
    }
    return e;
}

static void weights_block(void *ctx, int bi, int worker)
{
    mdl__ssdr *s = ctx;
    int nb = s->nb, K = s->K, ld = 3 * s->nf;
    int i0 = bi * SSDR_BLOCK, i1 = i0 + SSDR_BLOCK < s->nv ? i0 + SSDR_BLOCK : s->nv;
    double *S = s->Sw + (size_t)worker * s->sw_len;
    double *cv = S, *scratch = cv + nb;
    int *stamp = s->mark + (size_t)worker * 3 * nb, *cand = stamp + nb, *loc = cand + nb;
    for (int i = i0; i < i1; i++) {
        /* the candidates: bones weighted at i or at a neighbour */
        int nc = 0;
        for (int e = s->g_off ? s->g_off[i] - 1 : -1; e < (s->g_off ? s->g_off[i + 1] : 0); e++) {
            int u = e < (s->g_off ? s->g_off[i] : 0) ? i : s->g_nbr[e];
            for (int q = 0; q < K; q++) {
                int j = s->bone[(size_t)K * u + q];
                if (s->w[(size_t)K * u + q] > 0 && stamp[j] != i + 1) {
                    stamp[j] = i + 1;
                    loc[j] = nc;
                    cand[nc++] = j;
                }
            }
        }
        /* c_j = sum_b p~_b (Xt[:, i] . M[:, 4j + b]) */
        const double *x = s->Xt + (size_t)ld * i, *u = s->U + 3 * (size_t)i;
        vctx v = {s, cand, {u[0], u[1], u[2], 1}, 0};
        for (int n = 0; n < nc; n++) {
            const double *m0 = s->M + (size_t)ld * 4 * cand[n];
            double a0 = 0, a1 = 0, a2 = 0, a3 = 0, b0 = 0, b1 = 0, b2 = 0, b3 = 0;
            int r = 0;
            for (; r + 1 < ld; r += 2) {
                a0 += x[r] * m0[r];
                a1 += x[r] * m0[r + ld];
                a2 += x[r] * m0[r + 2 * (size_t)ld];
                a3 += x[r] * m0[r + 3 * (size_t)ld];
                b0 += x[r + 1] * m0[r + 1];
                b1 += x[r + 1] * m0[r + 1 + ld];
                b2 += x[r + 1] * m0[r + 1 + 2 * (size_t)ld];
                b3 += x[r + 1] * m0[r + 1 + 3 * (size_t)ld];
            }
            for (; r < ld; r++) {
                a0 += x[r] * m0[r];
                a1 += x[r] * m0[r + ld];
                a2 += x[r] * m0[r + 2 * (size_t)ld];
                a3 += x[r] * m0[r + 3 * (size_t)ld];
            }
            cv[n] = (a0 + b0) * v.pt[0] + (a1 + b1) * v.pt[1] + (a2 + b2) * v.pt[2] + (a3 + b3);
        }
        if (s->smooth > 0 && s->g_off && s->g_off[i + 1] > s->g_off[i]) {
            int deg = s->g_off[i + 1] - s->g_off[i];
            v.lam = s->smooth;
            for (int e = s->g_off[i]; e < s->g_off[i + 1]; e++) {
                int nu = s->g_nbr[e];
                for (int q = 0; q < K; q++)
                    if (s->w[(size_t)K * nu + q] > 0)
                        cv[loc[s->bone[(size_t)K * nu + q]]] +=
                            s->smooth * s->w[(size_t)K * nu + q] / deg;
            }
        }
        double dmax = 0;
        for (int n = 0; n < nc; n++) {
            double dj = vq(&v, n, n);
            if (dj > dmax)
                dmax = dj;
        }
        int *ob = s->new_bone + (size_t)K * i;
        double *ow = s->new_w + (size_t)K * i;
        int cnt = mdl__ssdr_nnls(nc, cv, vq, &v, K, 1e-12 * dmax, scratch, ob, ow);
        for (int q = 0; q < cnt; q++)
            ob[q] = cand[ob[q]];
        for (int q = cnt; q < K; q++) {
            ob[q] = ob[0];
            ow[q] = 0;
        }
        /* Keeping the K largest is not the K-sparse optimum: never accept weights worse than the
         * previous ones, so that the error of the alternation cannot grow. */
        const int *pb = s->bone + (size_t)K * i;
        const double *pw = s->w + (size_t)K * i;
        if (objective(&v, cv, loc, pb, pw, K) < objective(&v, cv, loc, ob, ow, K)) {
            memcpy(ob, pb, (size_t)K * sizeof *ob);
            memcpy(ow, pw, (size_t)K * sizeof *ow);
        }
    }
}

void mdl__ssdr_weights(mdl__ssdr *s)
{
    mdl__ssdr_normal_setup(s);
    for (int q = 0; q < s->workers * s->nb; q++)
        s->mark[(size_t)3 * s->nb * (q / s->nb) + q % s->nb] = 0;
    mdl__ssdr_parallel(s, (s->nv + SSDR_BLOCK - 1) / SSDR_BLOCK, weights_block, s);
    size_t nk = (size_t)s->nv * s->K;
    memcpy(s->bone, s->new_bone, nk * sizeof *s->bone);
    memcpy(s->w, s->new_w, nk * sizeof *s->w);
}
