/* test_regress.c - the regressions of eq. 5: known coefficients are recovered, leave-one-out
 * picks a small regulariser for clean data and a larger one for noise, and the radial basis
 * extension fits a non-linear relation that the linear model cannot. */
#include "steer/regress.h"
#include "model.h"
#include "test.h"

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    enum { n = 60, d = 3, q = 2 };
    double X[n * d], Y[n * q];
    uint32_t st = 99;
    for (int i = 0; i < n * d; i++) {
        st = st * 1664525u + 1013904223u;
        X[i] = (double)(st >> 8) / (1 << 24) * 4 - 2;
    }
    /* y0 = 1 + 2 x0 - 3 x1 + 0.5 x2; y1 = -4 + x2 */
    for (int i = 0; i < n; i++) {
        Y[i] = 1 + 2 * X[i] - 3 * X[n + i] + 0.5 * X[2 * n + i];
        Y[n + i] = -4 + X[2 * n + i];
    }
    double mean[d], sd[d], coef[(d + 1) * q], lam, rt, rl, z[d + 1], yp[q];
    ASSERT_OK(mdl__ridge_fit(X, n, d, Y, q, -1, NULL, 0, mean, sd, coef, &lam, &rt, &rl, err), err);
    ASSERT(lam <= 1e-4);
    ASSERT(rl < 1e-3);
    double x[d] = {0.5, -1, 1.5};
    mdl__ridge_predict(coef, d, q, mean, sd, x, z, yp);
    ASSERT_NEAR(yp[0], 1 + 1 + 3 + 0.75, 1e-3);
    ASSERT_NEAR(yp[1], -4 + 1.5, 1e-3);

    /* a non-linear target: y = sin(2 x0); the RBF model must beat the linear one on new points */
    double Yn[n];
    for (int i = 0; i < n; i++)
        Yn[i] = sin(2 * X[i]);
    double *zm, *zs, *cent, *mn, *sdv, *cf, w;
    int m;
    double errs[2];
    for (int rbf = 0; rbf < 2; rbf++) {
        ASSERT_OK(mdl__regression_fit(X, n, d, Yn, 1, -1, NULL, 0, rbf, &zm, &zs, &cent, &m, &w, &mn,
                                      &sdv, &cf, &lam, &rt, &rl, err),
                  err);
        ASSERT_INT_EQ(m, rbf ? n : 0);
        double e = 0, row[d + n], zz[d + n + 1], y;
        for (int k = 0; k < 40; k++) {
            double xt[d] = {-1.8 + 0.09 * k, 0.1, -0.2};
            mdl__design_row(xt, d, zm, zs, cent, m, w, row);
            mdl__ridge_predict(cf, d + m, 1, mn, sdv, row, zz, &y);
            e += (y - sin(2 * xt[0])) * (y - sin(2 * xt[0])) / 40;
        }
        errs[rbf] = sqrt(e);
        free(zm);
        free(zs);
        free(cent);
        free(mn);
        free(sdv);
        free(cf);
    }
    printf("rms error on new points: linear %.4f, radial basis %.4f\n", errs[0], errs[1]);
    ASSERT(errs[1] < 0.1);
    ASSERT(errs[1] < 0.3 * errs[0]);
    /* fewer samples than inputs: leave-one-out must still be honest (not ~0) */
    {
        enum { n2 = 8, d2 = 20 };
        double X2[n2 * d2], Y2[n2], m2[d2], s2[d2], c2[(d2 + 1)];
        for (int i = 0; i < n2 * d2; i++) {
            st = st * 1664525u + 1013904223u;
            X2[i] = (double)(st >> 8) / (1 << 24);
        }
        for (int i = 0; i < n2; i++) {
            st = st * 1664525u + 1013904223u;
            Y2[i] = (double)(st >> 8) / (1 << 24); /* pure noise: nothing to predict */
        }
        ASSERT_OK(mdl__ridge_fit(X2, n2, d2, Y2, 1, -1, NULL, 0, m2, s2, c2, &lam, &rt, &rl, err), err);
        printf("noise target: leave-one-out residual %.3f (chosen ridge %g)\n", rl, lam);
        ASSERT(rl > 0.9);
    }
    printf("regress: ok\n");
    return 0;
}
