/* regress.c - ridge-regularised multivariate linear regression with closed-form leave-one-out
 * selection of the regulariser (paper 2012 eq. 5; see regress.h). */
#include "steer/regress.h"
#include "core/linalg.h"
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double grid[] = {1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 3e-2, 0.1, 0.3, 1, 3, 10, 100};

/* Solves for B (d x q) with (Z^T Z + lam I) B = Z^T Yc; returns train and LOO errors (weighted). */
/* Solves k x k A e = r for `q` right-hand sides (columns of r, ld k) in place, by Gaussian
 * elimination with partial pivoting; A is destroyed. Returns -1 when singular. */
static int small_solve(double *A, int k, double *r, int q)
{
    for (int c = 0; c < k; c++) {
        int piv = c;
        for (int i = c + 1; i < k; i++)
            if (fabs(A[c * k + i]) > fabs(A[c * k + piv]))
                piv = i;
        if (!(fabs(A[c * k + piv]) > 1e-12))
            return -1;
        if (piv != c) {
            for (int j = 0; j < k; j++) {
                double t = A[j * k + c];
                A[j * k + c] = A[j * k + piv];
                A[j * k + piv] = t;
            }
            for (int j = 0; j < q; j++) {
                double t = r[j * k + c];
                r[j * k + c] = r[j * k + piv];
                r[j * k + piv] = t;
            }
        }
        for (int i = c + 1; i < k; i++) {
            double f = A[c * k + i] / A[c * k + c];
            for (int j = c; j < k; j++)
                A[j * k + i] -= f * A[j * k + c];
            for (int j = 0; j < q; j++)
                r[j * k + i] -= f * r[j * k + c];
        }
    }
    for (int c = k - 1; c >= 0; c--)
        for (int j = 0; j < q; j++) {
            double v = r[j * k + c];
            for (int i = c + 1; i < k; i++)
                v -= A[i * k + c] * r[j * k + i];
            r[j * k + c] = v / A[c * k + c];
        }
    return 0;
}

/* Solves (Z^T Z + lam n I) B = Z^T Yc and accumulates per-column training and leave-one-out
 * errors. Leave-one-out is exact for ridge regression with an unpenalised intercept: the residual
 * of a left-out group g (rows g, g + gs, g + 2 gs, ... when gs > 0, else the single row g) is
 * e_g = [(I - H)_gg]^{-1} r_g, with r = (I - H) Yc the training residual. Groups hold the noisy
 * copies of one frame (train.c), which must leave together or they leak into each other's fit.
 * With many samples (n > d), I - H = I - 1 1^T / n - Z G^{-1} Z^T from the primal factor; with
 * few (n <= d) the dual form, which stays exact as lam -> 0: I - H = lam' (Z Z^T + lam' I)^{-1}
 * - 1 1^T / n. K and M are n x n scratch (dual), Rr n x q scratch. */
static int solve_one(const double *Z, int n, int d, const double *Yc, int q, const double *yw,
                     double lam, int gs, double *G, double *B, double *W, double *K, double *M,
                     double *Rr, double *col_train, double *col_loo, char *err)
{
    double lp = lam * n;
    mdl_la_gemm('T', 'N', d, d, n, 1.0, Z, n, Z, n, 0.0, G, d);
    for (int i = 0; i < d; i++)
        G[i * d + i] += lp;
    int r = mdl_la_potrf(d, G, d, err);
    if (r)
        return r;
    mdl_la_gemm('T', 'N', d, q, n, 1.0, Z, n, Yc, n, 0.0, B, d);
    if ((r = mdl_la_potrs(d, q, G, d, B, d, err)))
        return r;
    int dual = n <= d;
    if (dual) {
        mdl_la_gemm('N', 'T', n, n, d, 1.0, Z, n, Z, n, 0.0, K, n);
        for (int i = 0; i < n; i++)
            K[i * n + i] += lp;
        if ((r = mdl_la_potrf(n, K, n, err)))
            return r;
        for (int i = 0; i < n * n; i++)
            M[i] = 0;
        for (int i = 0; i < n; i++)
            M[i * n + i] = 1;
        if ((r = mdl_la_potrs(n, n, K, n, M, n, err)))
            return r;
        mdl_la_gemm('N', 'N', n, q, n, lp, M, n, Yc, n, 0.0, Rr, n);
    } else {
        /* W = G^{-1} Z^T (d x n) */
        for (int i = 0; i < n; i++)
            for (int j = 0; j < d; j++)
                W[i * d + j] = Z[j * n + i];
        if ((r = mdl_la_potrs(d, n, G, d, W, d, err)))
            return r;
        memcpy(Rr, Yc, sizeof(double) * (size_t)n * q);
        mdl_la_gemm('N', 'N', n, q, d, -1.0, Z, n, B, d, 1.0, Rr, n);
    }
    int k = gs > 0 ? n / gs : 1, ng = gs > 0 ? gs : n;
    double A[MDL_MAX_GROUP * MDL_MAX_GROUP], e[MDL_MAX_GROUP * 64];
    for (int c = 0; c < q; c++) {
        col_loo[c] = col_train[c] = 0;
        for (int i = 0; i < n; i++)
            col_train[c] += yw[c] * Rr[c * n + i] * Rr[c * n + i];
    }
    for (int g = 0; g < ng; g++) {
        /* (I - H)_gg */
        for (int a = 0; a < k; a++)
            for (int b = 0; b < k; b++) {
                int ia = g + a * ng, ib = g + b * ng;
                double v;
                if (dual) {
                    v = lp * M[ib * n + ia] - 1.0 / n;
                } else {
                    v = (ia == ib) - 1.0 / n;
                    for (int j = 0; j < d; j++)
                        v -= Z[j * n + ia] * W[ib * d + j];
                }
                A[b * k + a] = v;
            }
        double Ac[MDL_MAX_GROUP * MDL_MAX_GROUP];
        for (int c0 = 0; c0 < q; c0 += 64) {
            int qc = q - c0 < 64 ? q - c0 : 64;
            memcpy(Ac, A, sizeof(double) * (size_t)k * k);
            for (int c = 0; c < qc; c++)
                for (int a = 0; a < k; a++)
                    e[c * k + a] = Rr[(c0 + c) * n + g + a * ng];
            if (small_solve(Ac, k, e, qc)) { /* a sample the fit cannot do without */
                for (int c = 0; c < qc; c++)
                    col_loo[c0 + c] += 1e12 * yw[c0 + c];
                continue;
            }
            for (int c = 0; c < qc; c++)
                for (int a = 0; a < k; a++)
                    col_loo[c0 + c] += yw[c0 + c] * e[c * k + a] * e[c * k + a];
        }
    }
    return 0;
}

int mdl__ridge_fit(const double *X, int n, int d, const double *Y, int q, double ridge,
                   const double *colw, int gs, double *mean, double *sd, double *coef, double *chosen,
                   double *rms_train, double *rms_loo, char *err)
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
    double *G2 = n <= d ? mdl__calloc((size_t)n * n, sizeof *G2) : mdl__calloc(1, sizeof *G2);
    double *B2 = n <= d ? mdl__calloc((size_t)n * n, sizeof *B2) : mdl__calloc(1, sizeof *B2);
    double *Rr = mdl__calloc((size_t)n * q, sizeof *Rr);
    int rc = 0;
    if (gs < 0 || (gs > 0 && (n % gs != 0 || n / gs > MDL_MAX_GROUP)))
        gs = 0;
    if (!Z || !Yc || !ymean || !yw || !G || !B || !Bbest || !W || !G2 || !B2 || !Rr) {
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
        yw[c] = colw ? colw[c] : (v / n > 1e-18 ? 1 / (v / n) : 0);
        wsum += yw[c] * v;
    }
    if (!(wsum > 0))
        wsum = 1;
    if (d == 0) {
        for (int c = 0; c < q; c++)
            coef[c] = ymean[c];
        *chosen = 0;
        *rms_train = *rms_loo = 1;
        goto out;
    }
    /* the regulariser is chosen per output column: each column keeps the solution whose
     * leave-one-out error is smallest for it */
    double *ct = mdl__calloc((size_t)q, sizeof *ct), *cl = mdl__calloc((size_t)q, sizeof *cl);
    double *bt = mdl__calloc((size_t)q, sizeof *bt), *bl = mdl__calloc((size_t)q, sizeof *bl);
    double *lam_c = mdl__calloc((size_t)q, sizeof *lam_c);
    if (!ct || !cl || !bt || !bl || !lam_c) {
        free(lam_c);
        free(ct);
        free(cl);
        free(bt);
        free(bl);
        rc = mdl__err(err, -ENOMEM, "regression: out of memory");
        goto out;
    }
    for (int c = 0; c < q; c++)
        bl[c] = INFINITY;
    int ng = ridge < 0 ? (int)(sizeof grid / sizeof *grid) : 1;
    for (int g = 0; g < ng; g++) {
        double lam = ridge < 0 ? grid[g] : ridge;
        char e2[MDL_ERR_LEN];
        int r = solve_one(Z, n, d, Yc, q, yw, lam, gs, G, B, W, G2, B2, Rr, ct, cl, e2);
        if (r) {
            if (ridge >= 0) {
                rc = mdl__err(err, r, "regression: %s", e2);
                break;
            }
            continue;
        }
        for (int c = 0; c < q; c++)
            if (cl[c] < bl[c]) {
                bl[c] = cl[c];
                bt[c] = ct[c];
                lam_c[c] = lam;
                memcpy(Bbest + (size_t)c * d, B + (size_t)c * d, sizeof *B * (size_t)d);
            }
    }
    double tl = 0, tt = 0, lsum = 0;
    int found = 1;
    for (int c = 0; c < q; c++) {
        if (!isfinite(bl[c]))
            found = 0;
        tl += bl[c];
        tt += bt[c];
        lsum += log(lam_c[c] > 0 ? lam_c[c] : 1e-300);
    }
    *chosen = exp(lsum / q); /* geometric mean of the per-column choices (report) */
    free(ct);
    free(cl);
    free(bt);
    free(bl);
    free(lam_c);
    if (rc)
        goto out;
    if (!found) {
        rc = mdl__err(err, MDL_ENUMERIC, "regression: no regularisation gave a solvable system");
        goto out;
    }
    for (int c = 0; c < q; c++) {
        coef[c * (d + 1)] = ymean[c];
        for (int j = 0; j < d; j++)
            coef[c * (d + 1) + 1 + j] = Bbest[c * d + j];
    }
    /* relative residuals (weighted over columns): 0 = perfect, 1 = no better than the mean */
    *rms_train = sqrt(tt / wsum);
    *rms_loo = sqrt(tl / wsum);
out:
    free(Z);
    free(Yc);
    free(ymean);
    free(yw);
    free(G);
    free(B);
    free(Bbest);
    free(W);
    free(G2);
    free(B2);
    free(Rr);
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

void mdl__design_row(const double *x, int d, const double *zmean, const double *zsd,
                     const double *cent, int m, double width, double *row)
{
    for (int j = 0; j < d; j++)
        row[j] = x[j];
    double inv = 1.0 / (2 * width * width);
    for (int c = 0; c < m; c++) {
        double s = 0;
        for (int j = 0; j < d; j++) {
            double z = (x[j] - zmean[j]) / zsd[j] - cent[(size_t)c * d + j];
            s += z * z;
        }
        row[d + c] = exp(-s * inv);
    }
}

int mdl__regression_fit(const double *X, int n, int d, const double *Y, int q, double ridge,
                        const double *colw, int gs, int use_rbf, double **zmean, double **zsd, double **cent, int *m,
                        double *width, double **mean, double **sd, double **coef, double *chosen,
                        double *rms_train, double *rms_loo, char *err)
{
    int mm = use_rbf && d > 0 ? (n < MDL_RBF_MAX_CENTRES ? n : MDL_RBF_MAX_CENTRES) : 0;
    int nx = d + mm, rc = 0;
    *zmean = mdl__calloc((size_t)d + 1, sizeof(double));
    *zsd = mdl__calloc((size_t)d + 1, sizeof(double));
    *cent = mdl__calloc((size_t)mm * d + 1, sizeof(double));
    *mean = mdl__calloc((size_t)nx + 1, sizeof(double));
    *sd = mdl__calloc((size_t)nx + 1, sizeof(double));
    *coef = mdl__calloc((size_t)(nx + 1) * q, sizeof(double));
    double *D = mdl__calloc((size_t)n * (nx ? nx : 1), sizeof(double));
    double *row = mdl__calloc((size_t)nx + 1, sizeof(double));
    double *xi = mdl__calloc((size_t)d + 1, sizeof(double));
    double *bm = mdl__calloc((size_t)nx + 1, sizeof(double)), *bs = mdl__calloc((size_t)nx + 1, sizeof(double));
    double *bc = mdl__calloc((size_t)(nx + 1) * q, sizeof(double));
    if (!*zmean || !*zsd || !*cent || !*mean || !*sd || !*coef || !D || !row || !xi || !bm || !bs || !bc) {
        rc = mdl__err(err, -ENOMEM, "regression: out of memory");
        goto out;
    }
    for (int j = 0; j < d; j++) {
        double s = 0, v = 0;
        for (int i = 0; i < n; i++)
            s += X[(size_t)j * n + i];
        s /= n;
        for (int i = 0; i < n; i++)
            v += (X[(size_t)j * n + i] - s) * (X[(size_t)j * n + i] - s);
        v = sqrt(v / n);
        (*zmean)[j] = s;
        (*zsd)[j] = v > 1e-9 ? v : 1;
    }
    for (int c = 0; c < mm; c++) { /* centres evenly spread over the samples */
        int i = (int)((long long)c * n / mm);
        for (int j = 0; j < d; j++)
            (*cent)[(size_t)c * d + j] = (X[(size_t)j * n + i] - (*zmean)[j]) / (*zsd)[j];
    }
    static const double widths[] = {0.5, 1, 2, 4};
    int nw = mm ? (int)(sizeof widths / sizeof *widths) : 1;
    double best = INFINITY;
    for (int w = 0; w < nw; w++) {
        double width_w = mm ? widths[w] * sqrt((double)d) : 1;
        for (int i = 0; i < n; i++) {
            for (int j = 0; j < d; j++)
                xi[j] = X[(size_t)j * n + i];
            mdl__design_row(xi, d, *zmean, *zsd, *cent, mm, width_w, row);
            for (int j = 0; j < nx; j++)
                D[(size_t)j * n + i] = row[j];
        }
        double ch, rt, rl;
        char e2[MDL_ERR_LEN];
        int r = mdl__ridge_fit(D, n, nx, Y, q, ridge, colw, gs, *mean, *sd, *coef, &ch, &rt, &rl, e2);
        if (r) {
            if (!mm) {
                rc = mdl__err(err, r, "%s", e2);
                goto out;
            }
            continue;
        }
        if (rl < best) {
            best = rl;
            *width = width_w;
            *chosen = ch;
            *rms_train = rt;
            *rms_loo = rl;
            memcpy(bm, *mean, sizeof(double) * (size_t)nx);
            memcpy(bs, *sd, sizeof(double) * (size_t)nx);
            memcpy(bc, *coef, sizeof(double) * (size_t)(nx + 1) * q);
        }
    }
    if (!isfinite(best)) {
        rc = mdl__err(err, MDL_ENUMERIC, "regression: no kernel width gave a solvable system");
        goto out;
    }
    memcpy(*mean, bm, sizeof(double) * (size_t)nx);
    memcpy(*sd, bs, sizeof(double) * (size_t)nx);
    memcpy(*coef, bc, sizeof(double) * (size_t)(nx + 1) * q);
    *m = mm;
out:
    free(D);
    free(row);
    free(xi);
    free(bm);
    free(bs);
    free(bc);
    return rc;
}
