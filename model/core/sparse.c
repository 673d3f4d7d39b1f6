/* sparse.c - sparse SPD factorisation and allocation-free solves with CHOLMOD (sparse.h). */
#include "core/sparse.h"
#include "core/util.h"
#include "model.h"

#include <suitesparse/cholmod.h>

#include <errno.h>
#include <stdlib.h>
#include <string.h>

struct mdl_spd {
    int n, kmax;
    cholmod_common c;
    cholmod_factor *L;
    cholmod_dense *X[MDL_SPD_KMAX], *Y, *E; /* solve2 workspace, one X per column count 1..kmax */
    size_t anz;
};

static const char *status_name(int st)
{
    switch (st) {
    case CHOLMOD_NOT_INSTALLED: return "method not installed";
    case CHOLMOD_OUT_OF_MEMORY: return "out of memory";
    case CHOLMOD_TOO_LARGE: return "integer overflow";
    case CHOLMOD_INVALID: return "invalid input";
    case CHOLMOD_NOT_POSDEF: return "matrix not positive definite";
    case CHOLMOD_DSMALL: return "tiny diagonal";
    default: return "error";
    }
}

int mdl__spd_create(int n, size_t nnz, const int *ti, const int *tj, const double *tx, int kmax,
                    mdl_spd **out, char *err)
{
    *out = NULL;
    if (n < 1 || kmax < 1 || kmax > MDL_SPD_KMAX)
        return mdl__err(err, -EINVAL, "sparse: size %d, %d right-hand sides (1..%d)", n, kmax,
                        MDL_SPD_KMAX);
    for (size_t e = 0; e < nnz; e++)
        if (ti[e] < tj[e] || tj[e] < 0 || ti[e] >= n)
            return mdl__err(err, -EINVAL, "sparse: entry %zu (%d, %d) is not in the lower triangle "
                            "of a %d x %d matrix", e, ti[e], tj[e], n, n);
    mdl_spd *s = mdl__calloc(1, sizeof *s);
    if (!s)
        return mdl__err(err, -ENOMEM, "sparse: out of memory");
    s->n = n;
    s->kmax = kmax;
    cholmod_start(&s->c);
    s->c.print = 0;               /* a library never prints */
    s->c.error_handler = NULL;
    s->c.supernodal = CHOLMOD_SIMPLICIAL; /* LGPL modules only (sparse.h) */
    s->c.final_ll = 0;            /* keep L D L' */
    int rc = 0;
    cholmod_sparse *A = NULL;
    cholmod_triplet *T = cholmod_allocate_triplet((size_t)n, (size_t)n, nnz ? nnz : 1, -1,
                                                  CHOLMOD_REAL, &s->c);
    if (!T) {
        rc = mdl__err(err, -ENOMEM, "sparse: %s", status_name(s->c.status));
        goto out;
    }
    memcpy(T->i, ti, nnz * sizeof(int));
    memcpy(T->j, tj, nnz * sizeof(int));
    memcpy(T->x, tx, nnz * sizeof(double));
    T->nnz = nnz;
    A = cholmod_triplet_to_sparse(T, nnz, &s->c);
    if (!A) {
        rc = mdl__err(err, -ENOMEM, "sparse: assembly: %s", status_name(s->c.status));
        goto out;
    }
    s->anz = cholmod_nnz(A, &s->c);
    s->L = cholmod_analyze(A, &s->c);
    if (!s->L) {
        rc = mdl__err(err, MDL_ENUMERIC, "sparse: analysis: %s", status_name(s->c.status));
        goto out;
    }
    cholmod_factorize(A, s->L, &s->c);
    if (s->c.status != CHOLMOD_OK || s->L->minor < (size_t)n) {
        rc = mdl__err(err, MDL_ENUMERIC, "sparse: factorisation of the %d x %d matrix: %s at column %zu",
                      n, n, status_name(s->c.status), (size_t)s->L->minor);
        goto out;
    }
    /* L D L' factorises indefinite matrices too: refuse a non-positive or vanishing pivot d_j
     * (the first entry of column j of a simplicial LDL' factor) */
    {
        const int *Lp = s->L->p;
        const double *Lx = s->L->x;
        double dmax = 0;
        for (int j = 0; j < n; j++)
            dmax = Lx[Lp[j]] > dmax ? Lx[Lp[j]] : dmax;
        for (int j = 0; j < n; j++)
            if (!(Lx[Lp[j]] > 1e-13 * dmax)) {
                rc = mdl__err(err, MDL_ENUMERIC, "sparse: the %d x %d matrix is not positive "
                              "definite (pivot %g at column %d)", n, n, Lx[Lp[j]], j);
                goto out;
            }
    }
    /* warm-up solves size CHOLMOD's workspace for every column count, so solves allocate nothing */
    double *b = mdl__calloc((size_t)n * (size_t)kmax, sizeof *b);
    if (!b) {
        rc = mdl__err(err, -ENOMEM, "sparse: out of memory");
        goto out;
    }
    for (int k = 1; k <= kmax && !rc; k++) {
        cholmod_dense B = {.nrow = (size_t)n, .ncol = (size_t)k, .nzmax = (size_t)n * (size_t)k,
                           .d = (size_t)n, .x = b, .z = NULL, .xtype = CHOLMOD_REAL,
                           .dtype = CHOLMOD_DOUBLE};
        if (!cholmod_solve2(CHOLMOD_A, s->L, &B, NULL, &s->X[k - 1], NULL, &s->Y, &s->E, &s->c))
            rc = mdl__err(err, MDL_ENUMERIC, "sparse: solve: %s", status_name(s->c.status));
    }
    free(b);
out:
    cholmod_free_sparse(&A, &s->c);
    cholmod_free_triplet(&T, &s->c);
    if (rc) {
        mdl__spd_destroy(s);
        return rc;
    }
    *out = s;
    return 0;
}

void mdl__spd_destroy(mdl_spd *s)
{
    if (!s)
        return;
    for (int k = 0; k < MDL_SPD_KMAX; k++)
        cholmod_free_dense(&s->X[k], &s->c);
    cholmod_free_dense(&s->Y, &s->c);
    cholmod_free_dense(&s->E, &s->c);
    cholmod_free_factor(&s->L, &s->c);
    cholmod_finish(&s->c);
    free(s);
}

int mdl__spd_solve(mdl_spd *s, const double *B, double *X, int k)
{
    if (k < 1 || k > s->kmax)
        return -EINVAL;
    size_t n = (size_t)s->n;
    cholmod_dense Bd = {.nrow = n, .ncol = (size_t)k, .nzmax = n * (size_t)k, .d = n,
                        .x = (void *)B, .z = NULL, .xtype = CHOLMOD_REAL, .dtype = CHOLMOD_DOUBLE};
    cholmod_dense *Xw = s->X[k - 1];
    if (!cholmod_solve2(CHOLMOD_A, s->L, &Bd, NULL, &s->X[k - 1], NULL, &s->Y, &s->E, &s->c))
        return MDL_ENUMERIC;
    /* the workspace had the right size, so CHOLMOD reused it (checked: it must not move) */
    if (s->X[k - 1] != Xw)
        return MDL_ENUMERIC;
    memcpy(X, s->X[k - 1]->x, n * (size_t)k * sizeof(double));
    return 0;
}

size_t mdl__spd_factor_nnz(const mdl_spd *s)
{
    return s->L ? (size_t)s->c.lnz : 0;
}

size_t mdl__spd_matrix_nnz(const mdl_spd *s)
{
    return s->anz;
}

const char *mdl__spd_ordering(const mdl_spd *s)
{
    switch (s->L ? s->L->ordering : -1) {
    case CHOLMOD_NATURAL: return "natural";
    case CHOLMOD_GIVEN: return "given";
    case CHOLMOD_AMD: return "amd";
    case CHOLMOD_METIS: return "metis";
    case CHOLMOD_NESDIS: return "nesdis";
    case CHOLMOD_COLAMD: return "colamd";
    case CHOLMOD_POSTORDERED: return "postordered";
    default: return "unknown";
    }
}
