/* test_shape.c - the per-part PCA of eq. 6 reconstructs its training shapes, orders modes by
 * variance and reports the explained fraction. */
#include "steer/shape.h"
#include "model.h"
#include "test.h"

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    enum { m = 30, F = 10 };
    double X[m * F], base[m], m1[m], m2[m];
    for (int i = 0; i < m; i++) {
        base[i] = sin(i);
        m1[i] = cos(0.3 * i);
        m2[i] = (i % 3) - 1.0;
    }
    /* shapes = base + a_f m1 + b_f m2 with var(a) >> var(b): two modes explain everything */
    for (int f = 0; f < F; f++)
        for (int i = 0; i < m; i++)
            X[f * m + i] = base[i] + 2.0 * sin(f) * m1[i] + 0.2 * cos(3 * f) * m2[i];
    double mean[m], *V, *s2, expl;
    int k;
    ASSERT_OK(mdl__pca(X, m, F, 0.999999, 8, mean, &V, &s2, &k, &expl, err), err);
    ASSERT_INT_EQ(k, 2);
    ASSERT(s2[0] > s2[1]);
    ASSERT(expl > 0.999999);
    for (int f = 0; f < F; f++) {
        double lam[2] = {0, 0};
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < m; i++)
                lam[j] += V[j * m + i] * (X[f * m + i] - mean[i]);
        for (int i = 0; i < m; i++) {
            double rec = mean[i] + lam[0] * V[i] + lam[1] * V[m + i];
            ASSERT_NEAR_I(rec, X[f * m + i], 1e-9, f * m + i);
        }
    }
    /* modes are orthonormal */
    double dot = 0, n0 = 0;
    for (int i = 0; i < m; i++) {
        dot += V[i] * V[m + i];
        n0 += V[i] * V[i];
    }
    ASSERT_NEAR(dot, 0, 1e-9);
    ASSERT_NEAR(n0, 1, 1e-9);
    free(V);
    free(s2);
    /* keeping 90 %: only the dominant mode */
    ASSERT_OK(mdl__pca(X, m, F, 0.9, 8, mean, &V, &s2, &k, &expl, err), err);
    ASSERT_INT_EQ(k, 1);
    ASSERT(expl >= 0.9 && expl < 1);
    free(V);
    free(s2);
    printf("shape: ok\n");
    return 0;
}
