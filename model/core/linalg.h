/* linalg.h - the one door to BLAS and LAPACK(E).
 *
 * Only linalg.c includes cblas.h and lapacke.h. Matrices are column-major with an explicit leading
 * dimension. LAPACK routines are called through LAPACKE_*_work with LAPACK_COL_MAJOR and
 * caller-provided workspace (STYLE.md Sec. 6): the row-major and high-level LAPACKE paths allocate.
 * Return values: 0, -EINVAL when LAPACK reports an illegal argument (our bug, info < 0), or
 * MDL_ENUMERIC when the factorisation fails (info > 0); `err` then names the routine and info.
 *
 * Small fixed-size kernels (3x3 rotations, 4x4 symmetric eigenproblems) are written by hand in
 * rigid.c because a LAPACK call costs more than the arithmetic at that size. */
#ifndef MESHSTEER_MODEL_LINALG_H
#define MESHSTEER_MODEL_LINALG_H

/* C = alpha * op(A) * op(B) + beta * C. ta/tb: 'N' or 'T'. C is m x n, op(A) m x k, op(B) k x n. */
void mdl_la_gemm(char ta, char tb, int m, int n, int k, double alpha, const double *A, int lda,
                 const double *B, int ldb, double beta, double *C, int ldc);
/* y = alpha * op(A) * x + beta * y; A is m x n. */
void mdl_la_gemv(char ta, int m, int n, double alpha, const double *A, int lda, const double *x,
                 double beta, double *y);
/* Single-precision y = alpha * op(A) * x + beta * y. */
void mdl_la_sgemv(char ta, int m, int n, float alpha, const float *A, int lda, const float *x,
                  float beta, float *y);

/* Symmetric eigendecomposition (dsyev, upper): A (n x n) is replaced by eigenvectors, w gets the
 * eigenvalues in ascending order. Allocates its workspace (training only). */
int mdl_la_syev(int n, double *A, int lda, double *w, char *err);

/* Thin singular value decomposition (dgesvd, jobu = jobvt = 'S'): A (m x n, overwritten) =
 * U diag(s) VT with U m x min(m,n) (ldu), s min(m,n) descending, VT min(m,n) x n (ldvt).
 * Allocates its workspace (analysis only). MDL_ENUMERIC when the QR iteration does not converge. */
int mdl_la_gesvd(int m, int n, double *A, int lda, double *s, double *U, int ldu, double *VT,
                 int ldvt, char *err);

/* Equality-constrained least squares (dgglse): min |A x - c| subject to B x = d, A m x n, B p x n
 * (p <= n <= m + p, B of full row rank, [A; B] of full column rank); A, B, c, d are overwritten,
 * x gets n values. Allocates its workspace (analysis only). */
int mdl_la_gglse(int m, int n, int p, double *A, int lda, double *B, int ldb, double *c, double *d,
                 double *x, char *err);
/* Tridiagonal solve (dgtsv): dl (n - 1 below), dg (n), du (n - 1 above) are overwritten by the
 * factorisation, B (n x nrhs, ldb) by the solution. No allocation. */
int mdl_la_gtsv(int n, int nrhs, double *dl, double *dg, double *du, double *B, int ldb, char *err);

/* Cholesky factorisation of a symmetric positive definite matrix (dpotrf, upper), then solves with
 * it (dpotrs) for nrhs right-hand sides. No allocation: usable per frame. */
int mdl_la_potrf(int n, double *A, int lda, char *err);
int mdl_la_potrs(int n, int nrhs, const double *A, int lda, double *B, int ldb, char *err);
/* The same solve for one right-hand side by plain substitution (U^T y = b, then U x = y, with the
 * upper factor U from mdl_la_potrf), for the few-mode systems solved every frame, where the LAPACK
 * call costs more than the arithmetic. Returns MDL_ENUMERIC for a non-positive diagonal. */
int mdl_la_potrs1(int n, const double *U, int ldu, double *b);
/* The upper Cholesky factor (A = U^T U, in place, upper triangle) by hand, for the tiny systems
 * solved once per vertex (skin/ssdr_weights.c) where a LAPACK call costs more than the
 * arithmetic. Returns MDL_ENUMERIC with the failing pivot not positive. */
int mdl_la_potrf1(int n, double *A, int lda);

#endif
