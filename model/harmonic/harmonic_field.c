/* harmonic_field.c - harmonic interpolation of scalar fields over the mesh, eq. (1)-(2) of de Aguiar
 * et al. 2007 Sec. 4.1.
 *
 * Each quaternion component of Q = [w q1 q2 q3] (eq. 1) is a scalar field S with nabla^2 S = 0
 * (eq. 2) and Dirichlet values at the correspondence triangles' vertices. With L the cotangent
 * Laplacian (core/laplacian.h) and the vertices split into free (f) and constrained (c):
 *     L_ff S_f = -L_fc S_c,
 * factorised once per correspondence set (L_ff is SPD when every connected part of the mesh holds a
 * constrained vertex) and solved per frame for all four components in one 4-column solve. Each
 * vertex's interpolated quaternion is normalised afterwards.
 * Beyond the paper (eval --stretch, docs/MODEL.md): six more scalar fields, the components of a
 * symmetric stretch, ride along as columns 5-10 of the same solve (the factor is the same; only the
 * right-hand side is wider); they are not normalised. */
#include "harmonic/harmonic_internal.h"
#include "core/laplacian.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int find(int *par, int x)
{
    while (par[x] != x)
        x = par[x] = par[par[x]];
    return x;
}

void mdl__hfield_fini(mdl__hfield *h)
{
    free(h->row);
    free(h->cv);
    free(h->coup_r);
    free(h->coup_c);
    free(h->coup_w);
    free(h->B);
    mdl__spd_destroy(h->spd);
    memset(h, 0, sizeof *h);
}

int mdl__hfield_precompute(mdl__hfield *h, const uint32_t *F, int nf, int nv, const double *w,
                           const int *cv, int ncv, int ncomp, char *err)
{
    memset(h, 0, sizeof *h);
    if (ncomp != 4 && ncomp != MDL_HFIELD_NCOMP_STRETCH)
        return mdl__err(err, -EINVAL, "harmonic field: %d components (4 or %d)", ncomp,
                        MDL_HFIELD_NCOMP_STRETCH);
    h->nv = nv;
    h->ncv = ncv;
    h->ncomp = ncomp;
    size_t cap = 3 * (size_t)nf + (size_t)nv;
    int *ti = mdl__calloc(cap, sizeof *ti), *tj = mdl__calloc(cap, sizeof *tj);
    double *tx = mdl__calloc(cap, sizeof *tx);
    h->row = mdl__calloc((size_t)nv, sizeof *h->row);
    h->cv = mdl__calloc((size_t)ncv + 1, sizeof *h->cv);
    int rc = 0;
    if (!ti || !tj || !tx || !h->row || !h->cv) {
        rc = mdl__err(err, -ENOMEM, "harmonic field: out of memory");
        goto out;
    }
    for (int v = 0; v < nv; v++)
        h->row[v] = 0;
    for (int c = 0; c < ncv; c++) {
        if (cv[c] < 0 || cv[c] >= nv || h->row[cv[c]] < 0) {
            rc = mdl__err(err, -EINVAL, "harmonic field: constrained vertex %d (#%d) is out of range "
                          "or repeated", cv[c], c);
            goto out;
        }
        h->cv[c] = cv[c];
        h->row[cv[c]] = -(c + 1);
    }
    int nfree = 0;
    for (int v = 0; v < nv; v++)
        if (h->row[v] >= 0)
            h->row[v] = nfree++;
    h->nfree = nfree;
    /* every connected part needs a constrained vertex (a singular L_ff may factorise with a tiny
     * pivot instead of failing, so check the topology) */
    for (int v = 0; v < nv; v++)
        ti[v] = v;
    for (int t = 0; t < nf; t++)
        for (int k = 1; k < 3; k++) {
            int a = find(ti, (int)F[3 * t]), b = find(ti, (int)F[3 * t + k]);
            if (a != b)
                ti[a] = b;
        }
    for (int v = 0; v < nv; v++)
        tj[v] = 0;
    for (int c = 0; c < ncv; c++)
        tj[find(ti, cv[c])] = 1;
    for (int v = 0; v < nv; v++)
        if (!tj[find(ti, v)]) {
            rc = mdl__err(err, MDL_ENUMERIC, "harmonic field (eq. 2): the connected part of vertex "
                          "%d holds no correspondence, so its field is undetermined", v);
            goto out;
        }
    size_t n = mdl__laplacian_triplets(w, F, nf, nv, ti, tj, tx);
    /* split: free-free entries into the matrix, free-constrained into the coupling */
    size_t nff = 0, ncoup = 0;
    for (size_t e = 0; e < n; e++) {
        int ri = h->row[ti[e]], rj = h->row[tj[e]];
        if (ri >= 0 && rj >= 0)
            nff++;
        else if ((ri >= 0) != (rj >= 0))
            ncoup++;
    }
    h->coup_r = mdl__calloc(ncoup + 1, sizeof *h->coup_r);
    h->coup_c = mdl__calloc(ncoup + 1, sizeof *h->coup_c);
    h->coup_w = mdl__calloc(ncoup + 1, sizeof *h->coup_w);
    h->B = mdl__calloc((size_t)ncomp * (size_t)(nfree ? nfree : 1), sizeof *h->B);
    if (!h->coup_r || !h->coup_c || !h->coup_w || !h->B) {
        rc = mdl__err(err, -ENOMEM, "harmonic field: out of memory");
        goto out;
    }
    size_t k = 0;
    for (size_t e = 0; e < n; e++) {
        int ri = h->row[ti[e]], rj = h->row[tj[e]];
        if (ri >= 0 && rj >= 0) {
            ti[k] = ri > rj ? ri : rj;
            tj[k] = ri > rj ? rj : ri;
            tx[k++] = tx[e];
        } else if (ri >= 0 || rj >= 0) {
            h->coup_r[h->ncoup] = ri >= 0 ? ri : rj;
            h->coup_c[h->ncoup] = ri >= 0 ? -rj - 1 : -ri - 1;
            h->coup_w[h->ncoup++] = -tx[e];
        }
    }
    if (nfree > 0) {
        rc = mdl__spd_create(nfree, k, ti, tj, tx, ncomp, &h->spd, err);
        if (rc == MDL_ENUMERIC) {
            char tmp[MDL_ERR_LEN];
            snprintf(tmp, sizeof tmp, "%s", err ? err : "");
            rc = mdl__err(err, MDL_ENUMERIC, "harmonic field (eq. 2): %s: does every connected part "
                          "of the mesh hold a correspondence?", tmp);
        }
    }
out:
    free(ti);
    free(tj);
    free(tx);
    if (rc)
        mdl__hfield_fini(h);
    return rc;
}

int mdl__hfield_solve_n(mdl__hfield *h, const double *Sc, double *S, int ncomp)
{
    if (ncomp != 4 && ncomp != h->ncomp)
        return -EINVAL;
    int nf = h->nfree;
    if (nf > 0) {
        memset(h->B, 0, (size_t)ncomp * (size_t)nf * sizeof *h->B);
        for (int e = 0; e < h->ncoup; e++) {
            const double *s = Sc + (size_t)ncomp * h->coup_c[e];
            double wgt = h->coup_w[e];
            double *b = h->B + h->coup_r[e];
            for (int c = 0; c < ncomp; c++)
                b[(size_t)c * nf] += wgt * s[c];
        }
        int rc = mdl__spd_solve(h->spd, h->B, h->B, ncomp);
        if (rc)
            return rc;
    }
    for (int v = 0; v < h->nv; v++) {
        int r = h->row[v];
        double *q = S + (size_t)ncomp * v;
        if (r >= 0) {
            for (int c = 0; c < ncomp; c++)
                q[c] = h->B[(size_t)c * nf + r];
        } else {
            memcpy(q, Sc + (size_t)ncomp * (size_t)(-r - 1), (size_t)ncomp * sizeof *q);
        }
        mdl__qnorm(q);
    }
    return 0;
}

int mdl__hfield_solve(mdl__hfield *h, const double *Sc, double *S)
{
    return mdl__hfield_solve_n(h, Sc, S, 4);
}
