/* regress.c - ridge-regularised multivariate linear regression with closed-form leave-one-out
 * selection of the regulariser (paper 2012 eq. 5; see regress.h). */
#include "regress.h"
#include "linalg.h"
#include "model.h"
#include "util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double grid[] = {1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 3e-2, 0.1, 0.3, 1, 3, 10, 100};

/* Solves for B (d x q) with (Z^T Z + lam I) B = Z^T Yc; returns train and LOO errors (weighted). */
static int solve_one(const double *Z, int n, int d, const double *Yc, int q, const double *yw,
                     double lam, double *G, double *B, double *W, double *err_train,
                     double *err_loo, char *err)
{
    mdl_la_gemm('T', 'N', d, d, n, 1.0, Z, n, Z, n, 0.0, G, d);
    for (int i = 0; i < d; i++)
        G[i * d + i] += lam * n;
    int r = mdl_la_potrf(d, G, d, err);
    if (r)
        return r;
    mdl_la_gemm('T', 'N', d, q, n, 1.0, Z, n, Yc, n, 0.0, B, d);
    if ((r = mdl_la_potrs(d, q, G, d, B, d, err)))
        return r;
    /* W = G^{-1} Z^T (d x n); h_ii = z_i . W_i */
    for (int i = 0; i < n; i++)
        for (int j = 0; j < d; j++)
            W[i * d + j] = Z[j * n + i];
    if ((r = mdl_la_potrs(d, n, G, d, W, d, err)))
        return r;
    double et = 0, el = 0;
    for (int i = 0; i < n; i++) {
        double h = 0;
        for (int j = 0; j < d; j++)
            h += Z[j * n + i] * W[i * d + j];
        double denom = 1 - h;
        if (denom < 1e-6)
            denom = 1e-6;
        for (int c = 0; c < q; c++) {
            double pred = 0;
            for (int j = 0; j < d; j++)
                pred += Z[j * n + i] * B[c * d + j];
            double res = Yc[c * n + i] - pred;
            et += yw[c] * res * res;
            el += yw[c] * (res / denom) * (res / denom);
        }
    }
    *err_train = et;
    *err_loo = el;
    return 0;
}

int mdl__ridge_fit(const double *X, int n, int d, const double *Y, int q, double ridge,
                   double *mean, double *sd, double *coef, double *chosen, double *rms_train,
                   double *rms_loo, char *err)
{
    if (n < 1 || d < 0 || q < 1)
        return mdl__err(err, -EINVAL, "regression: %d samples, %d inputs, %d outputs", n, d, q);
    int dd = d > 0 ? d : 1;
    double *Z = mdl__calloc((size_t)n * dd, sizeof *Z);
    double *Yc = mdl__calloc((size_t)n * q, sizeof *Yc);
    double *ymean = mdl__calloc((size_t)q, sizeof *ymean);
    double *yw = mdl__calloc((size_t)q, sizeof *yw);
    double *G = mdl__calloc((size_t)dd * dd, sizeof *G);
    double *B = mdl__calloc((size_t)dd * q, sizeof *B);
    double *Bbest = mdl__calloc((size_t)dd * q, sizeof *Bbest);
    double *W = mdl__calloc((size_t)dd * n, sizeof *W);
    int rc = 0;
    if (!Z || !Yc || !ymean || !yw || !G || !B || !Bbest || !W) {
        rc = mdl__err(err, -ENOMEM, "regression: out of memory");
        goto out;
    }
    for (int j = 0; j < d; j++) {
        double m = 0, v = 0;
        for (int i = 0; i < n; i++)
            m += X[j * n + i];
        m /= n;
        for (int i = 0; i < n; i++)
            v += (X[j * n + i] - m) * (X[j * n + i] - m);
        v = sqrt(v / n);
        mean[j] = m;
        sd[j] = v > 1e-9 ? v : 1; /* constant features contribute nothing */
        for (int i = 0; i < n; i++)
            Z[j * n + i] = v > 1e-9 ? (X[j * n + i] - m) / sd[j] : 0;
    }
    double wsum = 0;
    for (int c = 0; c < q; c++) {
        double m = 0, v = 0;
        for (int i = 0; i < n; i++)
            m += Y[c * n + i];
        m /= n;
        for (int i = 0; i < n; i++) {
            Yc[c * n + i] = Y[c * n + i] - m;
            v += Yc[c * n + i] * Yc[c * n + i];
        }
        ymean[c] = m;
        yw[c] = v / n > 1e-18 ? 1 / (v / n) : 0;
        wsum += yw[c] > 0;
    }
    if (wsum == 0)
        wsum = 1;
    if (d == 0) {
        for (int c = 0; c < q; c++)
            coef[c] = ymean[c];
        *chosen = 0;
        *rms_train = *rms_loo = 1;
        goto out;
    }
    double best = INFINITY, best_lam = ridge, best_t = 0;
    int ng = ridge < 0 ? (int)(sizeof grid / sizeof *grid) : 1;
    for (int g = 0; g < ng; g++) {
        double lam = ridge < 0 ? grid[g] : ridge, et, el;
        char e2[MDL_ERR_LEN];
        int r = solve_one(Z, n, d, Yc, q, yw, lam, G, B, W, &et, &el, e2);
        if (r) {
            if (ridge >= 0) {
                rc = mdl__err(err, r, "regression: %s", e2);
                goto out;
            }
            continue;
        }
        if (el < best) {
            best = el;
            best_lam = lam;
            best_t = et;
            memcpy(Bbest, B, sizeof *B * (size_t)d * q);
        }
    }
    if (!isfinite(best)) {
        rc = mdl__err(err, MDL_ENUMERIC, "regression: no regularisation gave a solvable system");
        goto out;
    }
    for (int c = 0; c < q; c++) {
        coef[c * (d + 1)] = ymean[c];
        for (int j = 0; j < d; j++)
            coef[c * (d + 1) + 1 + j] = Bbest[c * d + j];
    }
    *chosen = best_lam;
    /* relative residuals: 0 = perfect, 1 = no better than the mean */
    *rms_train = sqrt(best_t / (n * wsum));
    *rms_loo = sqrt(best / (n * wsum));
out:
    free(Z);
    free(Yc);
    free(ymean);
    free(yw);
    free(G);
    free(B);
    free(Bbest);
    free(W);
    return rc;
}

void mdl__ridge_predict(const double *coef, int d, int q, const double *mean, const double *sd,
                        const double *x, double *z, double *y)
{
    z[0] = 1;
    for (int j = 0; j < d; j++)
        z[1 + j] = (x[j] - mean[j]) / sd[j];
    mdl_la_gemv('T', d + 1, q, 1.0, coef, d + 1, z, 0.0, y);
}
