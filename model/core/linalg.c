/* linalg.c - thin wrappers over CBLAS and LAPACKE (column-major, *_work variants), and a
 * triangular solve for tiny systems. */
#include "core/linalg.h"
#include "model.h"
#include "core/util.h"

#include <cblas.h>
#include <errno.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>

static enum CBLAS_TRANSPOSE tr(char t)
{
    return (t == 'T' || t == 't') ? CblasTrans : CblasNoTrans;
}

void mdl_la_gemm(char ta, char tb, int m, int n, int k, double alpha, const double *A, int lda,
                 const double *B, int ldb, double beta, double *C, int ldc)
{
    cblas_dgemm(CblasColMajor, tr(ta), tr(tb), m, n, k, alpha, A, lda, B, ldb, beta, C, ldc);
}

void mdl_la_gemv(char ta, int m, int n, double alpha, const double *A, int lda, const double *x,
                 double beta, double *y)
{
    cblas_dgemv(CblasColMajor, tr(ta), m, n, alpha, A, lda, x, 1, beta, y, 1);
}

void mdl_la_sgemv(char ta, int m, int n, float alpha, const float *A, int lda, const float *x,
                  float beta, float *y)
{
    cblas_sgemv(CblasColMajor, tr(ta), m, n, alpha, A, lda, x, 1, beta, y, 1);
}

static int check_info(const char *routine, lapack_int info, char *err)
{
    if (info < 0)
        return mdl__err(err, -EINVAL, "%s: illegal argument %d", routine, (int)-info);
    if (info > 0)
        return mdl__err(err, MDL_ENUMERIC, "%s: failed at index %d", routine, (int)info);
    return 0;
}

int mdl_la_syev(int n, double *A, int lda, double *w, char *err)
{
    double q;
    lapack_int info = LAPACKE_dsyev_work(LAPACK_COL_MAJOR, 'V', 'U', n, A, lda, w, &q, -1);
    if (info != 0)
        return check_info("dsyev (workspace query)", info, err);
    lapack_int lwork = (lapack_int)q;
    double *work = malloc(sizeof(double) * (size_t)(lwork > 1 ? lwork : 1));
    if (!work)
        return mdl__err(err, -ENOMEM, "dsyev: out of memory for workspace");
    info = LAPACKE_dsyev_work(LAPACK_COL_MAJOR, 'V', 'U', n, A, lda, w, work, lwork);
    free(work);
    return check_info("dsyev", info, err);
}

int mdl_la_gesvd(int m, int n, double *A, int lda, double *s, double *U, int ldu, double *VT,
                 int ldvt, char *err)
{
    double q;
    lapack_int info = LAPACKE_dgesvd_work(LAPACK_COL_MAJOR, 'S', 'S', m, n, A, lda, s, U, ldu, VT,
                                          ldvt, &q, -1);
    if (info != 0)
        return check_info("dgesvd (workspace query)", info, err);
    lapack_int lwork = (lapack_int)q;
    double *work = malloc(sizeof(double) * (size_t)(lwork > 1 ? lwork : 1));
    if (!work)
        return mdl__err(err, -ENOMEM, "dgesvd: out of memory for workspace");
    info = LAPACKE_dgesvd_work(LAPACK_COL_MAJOR, 'S', 'S', m, n, A, lda, s, U, ldu, VT, ldvt, work,
                               lwork);
    free(work);
    return check_info("dgesvd", info, err);
}

int mdl_la_gglse(int m, int n, int p, double *A, int lda, double *B, int ldb, double *c, double *d,
                 double *x, char *err)
{
    double q;
    lapack_int info = LAPACKE_dgglse_work(LAPACK_COL_MAJOR, m, n, p, A, lda, B, ldb, c, d, x, &q, -1);
    if (info != 0)
        return check_info("dgglse (workspace query)", info, err);
    lapack_int lwork = (lapack_int)q;
    double *work = malloc(sizeof(double) * (size_t)(lwork > 1 ? lwork : 1));
    if (!work)
        return mdl__err(err, -ENOMEM, "dgglse: out of memory for workspace");
    info = LAPACKE_dgglse_work(LAPACK_COL_MAJOR, m, n, p, A, lda, B, ldb, c, d, x, work, lwork);
    free(work);
    return check_info("dgglse", info, err);
}

int mdl_la_gtsv(int n, int nrhs, double *dl, double *dg, double *du, double *B, int ldb, char *err)
{
    return check_info("dgtsv", LAPACKE_dgtsv_work(LAPACK_COL_MAJOR, n, nrhs, dl, dg, du, B, ldb), err);
}

int mdl_la_potrf(int n, double *A, int lda, char *err)
{
    return check_info("dpotrf", LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'U', n, A, lda), err);
}

int mdl_la_potrs(int n, int nrhs, const double *A, int lda, double *B, int ldb, char *err)
{
    return check_info("dpotrs",
                      LAPACKE_dpotrs_work(LAPACK_COL_MAJOR, 'U', n, nrhs, A, lda, B, ldb), err);
}

int mdl_la_potrs1(int n, const double *U, int ldu, double *b)
{
    for (int i = 0; i < n; i++) {
        double d = U[i + (size_t)i * ldu], v = b[i];
        if (!(d > 0))
            return MDL_ENUMERIC;
        for (int r = 0; r < i; r++)
            v -= U[r + (size_t)i * ldu] * b[r];
        b[i] = v / d;
    }
    for (int i = n - 1; i >= 0; i--) {
        double v = b[i];
        for (int c = i + 1; c < n; c++)
            v -= U[i + (size_t)c * ldu] * b[c];
        b[i] = v / U[i + (size_t)i * ldu];
    }
    return 0;
}

int mdl_la_potrf1(int n, double *A, int lda)
{
    for (int j = 0; j < n; j++) {
        for (int i = 0; i <= j; i++) {
            double v = A[i + (size_t)j * lda];
            for (int r = 0; r < i; r++)
                v -= A[r + (size_t)i * lda] * A[r + (size_t)j * lda];
            if (i < j) {
                A[i + (size_t)j * lda] = v / A[i + (size_t)i * lda];
            } else {
                if (!(v > 0))
                    return MDL_ENUMERIC;
                A[j + (size_t)j * lda] = sqrt(v);
            }
        }
    }
    return 0;
}

void mdl_set_blas_threads(int n)
{
    openblas_set_num_threads(n);
}
