/* test_linalg.c - the BLAS/LAPACK wrappers on problems with known answers. */
#include "core/linalg.h"
#include "model.h"
#include "test.h"

static void test_gemm(void)
{
    /* A = [1 2; 3 4] (column-major {1,3,2,4}), B = [5 6; 7 8] -> AB = [19 22; 43 50] */
    double A[4] = {1, 3, 2, 4}, B[4] = {5, 7, 6, 8}, C[4] = {0};
    mdl_la_gemm('N', 'N', 2, 2, 2, 1.0, A, 2, B, 2, 0.0, C, 2);
    ASSERT_NEAR(C[0], 19, 1e-12);
    ASSERT_NEAR(C[1], 43, 1e-12);
    ASSERT_NEAR(C[2], 22, 1e-12);
    ASSERT_NEAR(C[3], 50, 1e-12);
    /* A^T B = [1 3; 2 4][5 6; 7 8] = [26 30; 38 44] */
    mdl_la_gemm('T', 'N', 2, 2, 2, 1.0, A, 2, B, 2, 0.0, C, 2);
    ASSERT_NEAR(C[0], 26, 1e-12);
    ASSERT_NEAR(C[3], 44, 1e-12);
}

static void test_syev(void)
{
    /* [2 1; 1 2] has eigenvalues 1 and 3 with eigenvectors (1,-1)/sqrt2 and (1,1)/sqrt2. */
    double A[4] = {2, 1, 1, 2}, w[2];
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_la_syev(2, A, 2, w, err), err);
    ASSERT_NEAR(w[0], 1, 1e-12);
    ASSERT_NEAR(w[1], 3, 1e-12);
    ASSERT_NEAR(fabs(A[2]), sqrt(0.5), 1e-12);
    ASSERT_NEAR(A[2] * A[3], 0.5, 1e-12);
}

static void test_gesvd(void)
{
    /* a 3 x 2 matrix of rank 1, u v^T with u = (1, 2, 2), v = (3, 4): one singular value 15 */
    double A[6] = {3, 6, 6, 4, 8, 8}, s[2], U[6], VT[4];
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_la_gesvd(3, 2, A, 3, s, U, 3, VT, 2, err), err);
    ASSERT_NEAR(s[0], 15, 1e-12);
    ASSERT_NEAR(s[1], 0, 1e-12);
    ASSERT_NEAR(fabs(U[1]), 2.0 / 3, 1e-12);
    ASSERT_NEAR(U[0] * VT[0] * s[0], 3, 1e-12);   /* U s VT reproduces A(0,0) */
    ASSERT_NEAR(U[2] * VT[2] * s[0], 8, 1e-12);   /* and A(2,1) */
}

static void test_cholesky(void)
{
    /* [4 2; 2 3] x = [2; 1] -> x = [0.5; 0] */
    double A[4] = {4, 2, 2, 3}, b[2] = {2, 1};
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_la_potrf(2, A, 2, err), err);
    ASSERT_OK(mdl_la_potrs(2, 1, A, 2, b, 2, err), err);
    ASSERT_NEAR(b[0], 0.5, 1e-12);
    ASSERT_NEAR(b[1], 0.0, 1e-12);
    /* not positive definite: reported with its index */
    double N[4] = {1, 2, 2, 1};
    int r = mdl_la_potrf(2, N, 2, err);
    ASSERT_INT_EQ(r, MDL_ENUMERIC);
    ASSERT(strstr(err, "index 2") != NULL);
}

static void test_potrs1(void)
{
    /* a 4x4 SPD system (ld 5, so the leading dimension is honoured): the substitution agrees
     * with LAPACK's dpotrs on the same factor */
    double A[20] = {0}, b[4] = {1, -2, 3, 0.5}, b0[4] = {1, -2, 3, 0.5}, c[4];
    double M[4][4] = {{6, 1, 0.5, 0}, {1, 5, 1, 0.3}, {0.5, 1, 4, 0.2}, {0, 0.3, 0.2, 3}};
    char err[MDL_ERR_LEN] = "";
    for (int r = 0; r < 4; r++)
        for (int k = 0; k < 4; k++)
            A[r + 5 * k] = M[r][k];
    ASSERT_OK(mdl_la_potrf(4, A, 5, err), err);
    for (int r = 0; r < 4; r++)
        c[r] = b[r];
    ASSERT_OK(mdl_la_potrs(4, 1, A, 5, c, 4, err), err);
    ASSERT_INT_EQ(mdl_la_potrs1(4, A, 5, b), 0);
    for (int r = 0; r < 4; r++) {
        ASSERT_NEAR(b[r], c[r], 1e-12);
        double s = 0; /* and it solves the system */
        for (int k = 0; k < 4; k++)
            s += M[r][k] * b[k];
        ASSERT_NEAR(s, b0[r], 1e-12);
    }
    /* a zero pivot is refused, the right-hand side is not trusted */
    double Z[4] = {0, 0, 0, 1}, z[2] = {1, 1};
    ASSERT_INT_EQ(mdl_la_potrs1(2, Z, 2, z), MDL_ENUMERIC);
}

int main(void)
{
    test_gemm();
    test_syev();
    test_gesvd();
    test_cholesky();
    test_potrs1();
    printf("linalg: ok\n");
    return 0;
}
