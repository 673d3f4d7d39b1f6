/* sparse.h - sparse symmetric positive definite systems: assembled once, factorised once, solved
 * per frame without allocating. The only includer of SuiteSparse (CHOLMOD).
 *
 * CHOLMOD [Chen, Davis, Hager, Rajamanickam 2008, "Algorithm 887: CHOLMOD, supernodal sparse
 * Cholesky factorization and update/downdate"], used in its *simplicial* mode only
 * (Common->supernodal = CHOLMOD_SIMPLICIAL): the Core and Cholesky modules, which are LGPL-2.1+.
 * The Supernodal, Modify and MatrixOps modules are GPL; nothing here calls them (README, "Licences").
 *   A = P' L D L' P   analyse (fill-reducing ordering, AMD or METIS as CHOLMOD chooses) +
 *                     factorise at precompute;
 *   X = A \ B         cholmod_solve2 per frame, B and X n x k column-major doubles (ld = n), with
 *                     CHOLMOD's dense workspace (X, Y) allocated by one warm-up solve at precompute
 *                     and reused, so mdl__spd_solve allocates nothing (tests/model/core/test_sparse.c).
 * Doubles throughout: these are the factorisations where accuracy matters (STYLE.md Sec. 6). */
#ifndef MESHSTEER_MODEL_SPARSE_H
#define MESHSTEER_MODEL_SPARSE_H

#include <stddef.h>

typedef struct mdl_spd mdl_spd;

/* right-hand sides per solve at most: the harmonic field's 4 quaternion components, 10 with the
 * six stretch components of eval --stretch (model/harmonic/harmonic_field.c) */
#define MDL_SPD_KMAX 10

/* Factorises the n x n symmetric matrix given by nnz triplets (i, j, x) of its lower triangle
 * (i >= j; duplicates are summed; entries with i < j are refused) for solves of up to `kmax`
 * (<= MDL_SPD_KMAX) right-hand sides at once. MDL_ENUMERIC when A is not positive definite (with the column). */
int mdl__spd_create(int n, size_t nnz, const int *ti, const int *tj, const double *tx, int kmax,
                    mdl_spd **out, char *err);
void mdl__spd_destroy(mdl_spd *s);
/* X = A \ B for k <= kmax columns (B, X: n x k, column-major, ld = n; may alias). Allocates
 * nothing. Returns 0 or -EINVAL (k out of range), MDL_ENUMERIC if CHOLMOD failed. */
int mdl__spd_solve(mdl_spd *s, const double *B, double *X, int k);
/* Nonzeros of the factor L (including the diagonal) and of A's lower triangle: the bytes a
 * triangular solve reads (docs/PERFORMANCE.md). */
size_t mdl__spd_factor_nnz(const mdl_spd *s);
size_t mdl__spd_matrix_nnz(const mdl_spd *s);
/* The ordering CHOLMOD chose ("amd", "metis", "natural", ...). */
const char *mdl__spd_ordering(const mdl_spd *s);

#endif
