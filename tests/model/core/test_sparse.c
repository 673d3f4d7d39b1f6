/* test_sparse.c - CHOLMOD behind sparse.h: a 1-D Poisson matrix (tridiagonal 2, -1) solved against
 * a known solution for 1..4 right-hand sides, an indefinite matrix refused with MDL_ENUMERIC, and
 * the solve allocating nothing (the heap in use is unchanged after 50 solves; mallinfo2 does not see
 * ASan's allocator, so this part is meaningful in the plain build). */
#include "core/sparse.h"
#include "model.h"
#include <errno.h>
#include "test.h"

#include <malloc.h>

int main(void)
{
    int n = 200;
    int *ti = calloc(2 * (size_t)n, sizeof *ti), *tj = calloc(2 * (size_t)n, sizeof *tj);
    double *tx = calloc(2 * (size_t)n, sizeof *tx);
    size_t k = 0;
    for (int i = 0; i < n; i++) {
        ti[k] = tj[k] = i;
        tx[k++] = 2.0 + (i == 0 ? 1 : 0);
        if (i > 0) {
            ti[k] = i;
            tj[k] = i - 1;
            tx[k++] = -1.0;
        }
    }
    char err[MDL_ERR_LEN] = "";
    mdl_spd *s = NULL;
    ASSERT_OK(mdl__spd_create(n, k, ti, tj, tx, 4, &s, err), err);
    ASSERT(mdl__spd_factor_nnz(s) >= (size_t)n);
    double *x = calloc(4 * (size_t)n, sizeof *x), *b = calloc(4 * (size_t)n, sizeof *b);
    for (int c = 0; c < 4; c++)
        for (int i = 0; i < n; i++)
            x[(size_t)c * n + i] = sin(0.1 * i * (c + 1)) + c;
    for (int c = 0; c < 4; c++)
        for (int i = 0; i < n; i++) {
            double v = (2.0 + (i == 0)) * x[(size_t)c * n + i];
            if (i > 0)
                v -= x[(size_t)c * n + i - 1];
            if (i + 1 < n)
                v -= x[(size_t)c * n + i + 1];
            b[(size_t)c * n + i] = v;
        }
    double *y = calloc(4 * (size_t)n, sizeof *y);
    for (int kk = 1; kk <= 4; kk++) {
        ASSERT_OK(mdl__spd_solve(s, b, y, kk), "solve");
        for (size_t i = 0; i < (size_t)kk * n; i++)
            ASSERT_NEAR_I(y[i], x[i], 1e-8, i);
    }
    ASSERT_INT_EQ(mdl__spd_solve(s, b, y, 5), -EINVAL);
    struct mallinfo2 before = mallinfo2();
    for (int it = 0; it < 50; it++) {
        ASSERT_OK(mdl__spd_solve(s, b, y, 1 + it % 4), "solve");
    }
    struct mallinfo2 after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    ASSERT_INT_EQ(after.hblkhd, before.hblkhd);
    mdl__spd_destroy(s);
    /* indefinite: diagonal -1 */
    for (size_t e = 0; e < k; e++)
        if (ti[e] == tj[e])
            tx[e] = ti[e] == 50 ? -1.0 : tx[e];
    s = NULL;
    ASSERT_INT_EQ(mdl__spd_create(n, k, ti, tj, tx, 1, &s, err), MDL_ENUMERIC);
    ASSERT(s == NULL);
    /* an upper-triangle entry is refused */
    int bi = 0, bj = 1;
    double bx = 1;
    ASSERT_INT_EQ(mdl__spd_create(2, 1, &bi, &bj, &bx, 1, &s, err), -EINVAL);
    mdl__spd_destroy(NULL);
    free(ti), free(tj), free(tx), free(x), free(b), free(y);
    puts("sparse: ok");
    return 0;
}
