/* poisson.c - gluing the fragmented mesh back together, eq. (3)-(4) of de Aguiar et al. 2007
 * Sec. 4.1 (steps 3-6).
 *
 * Every triangle t of M, rotated by its own R_t, is a fragment of M'. The cotangent Laplacian of the
 * fragment applied to its coordinates gives, at corner k (vertex i, other corners j, l):
 *     R_t e_{t,k},   e_{t,k} = w^t_l (x_i - x_j) + w^t_j (x_i - x_l)   (rest positions x;
 * the cotangents w^t are those of the rest triangle, which a rotation does not change). Summing these
 * 3 nT vectors by the connectivity of M gives U_reduced (nV x 3), and
 *     L X = U_reduced                                                    (eq. 4)
 * is solved for x, y and z at once with the prefactored cotangent Laplacian L of M. L has the
 * constants in its null space (the translation degree of freedom): one anchor vertex per connected
 * part is held at R_t x_rest for one of its triangles t, which also makes an unrotated mesh come
 * back exactly where it was (and a rigidly rotated one rotated about the origin). The caller moves
 * the result to the template's global position (Sec. 5). */
#include "harmonic/harmonic_internal.h"
#include "core/laplacian.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void mdl__poisson_fini(mdl__poisson *p)
{
    free(p->row);
    free(p->anchor);
    free(p->anchor_tri);
    free(p->anchor_rest);
    free(p->coup_r);
    free(p->coup_a);
    free(p->coup_w);
    free(p->e);
    free(p->B);
    free(p->xa);
    mdl__spd_destroy(p->spd);
    memset(p, 0, sizeof *p);
}

static int uf_find(int *par, int x)
{
    while (par[x] != x) {
        par[x] = par[par[x]];
        x = par[x];
    }
    return x;
}

int mdl__poisson_precompute(mdl__poisson *p, const float *rest, const uint32_t *F, int nf, int nv,
                            const double *w, char *err)
{
    memset(p, 0, sizeof *p);
    p->nv = nv;
    p->nf = nf;
    p->F = F;
    size_t cap = 3 * (size_t)nf + (size_t)nv;
    int *ti = mdl__calloc(cap, sizeof *ti), *tj = mdl__calloc(cap, sizeof *tj);
    double *tx = mdl__calloc(cap, sizeof *tx);
    int *par = mdl__calloc((size_t)nv, sizeof *par), *vtri = mdl__calloc((size_t)nv, sizeof *vtri);
    p->row = mdl__calloc((size_t)nv, sizeof *p->row);
    p->e = mdl__calloc(9 * (size_t)nf, sizeof *p->e);
    int rc = 0;
    if (!ti || !tj || !tx || !par || !vtri || !p->row || !p->e) {
        rc = mdl__err(err, -ENOMEM, "poisson: out of memory");
        goto out;
    }
    for (int v = 0; v < nv; v++) {
        par[v] = v;
        vtri[v] = -1;
    }
    for (int t = 0; t < nf; t++)
        for (int k = 0; k < 3; k++) {
            int a = uf_find(par, (int)F[3 * t + k]), b = uf_find(par, (int)F[3 * t + (k + 1) % 3]);
            if (a != b)
                par[a > b ? a : b] = a > b ? b : a;
            if (vtri[F[3 * t + k]] < 0)
                vtri[F[3 * t + k]] = t;
        }
    /* the anchors: the root (smallest vertex) of every connected part */
    for (int v = 0; v < nv; v++)
        p->nanchor += uf_find(par, v) == v;
    p->anchor = mdl__calloc((size_t)p->nanchor, sizeof *p->anchor);
    p->anchor_tri = mdl__calloc((size_t)p->nanchor, sizeof *p->anchor_tri);
    p->anchor_rest = mdl__calloc(3 * (size_t)p->nanchor, sizeof *p->anchor_rest);
    p->xa = mdl__calloc(3 * (size_t)p->nanchor, sizeof *p->xa);
    if (!p->anchor || !p->anchor_tri || !p->anchor_rest || !p->xa) {
        rc = mdl__err(err, -ENOMEM, "poisson: out of memory");
        goto out;
    }
    int na = 0, nfree = 0;
    for (int v = 0; v < nv; v++) {
        if (uf_find(par, v) == v) {
            p->anchor[na] = v;
            p->anchor_tri[na] = vtri[v];
            for (int c = 0; c < 3; c++)
                p->anchor_rest[3 * na + c] = rest[3 * v + c];
            p->row[v] = -(na + 1);
            na++;
        } else {
            p->row[v] = nfree++;
        }
    }
    p->nfree = nfree;
    /* e_{t,k} (eq. 3 at the rest pose) */
    for (int t = 0; t < nf; t++)
        for (int k = 0; k < 3; k++) {
            const float *xi = rest + 3 * (size_t)F[3 * t + k], *xj = rest + 3 * (size_t)F[3 * t + (k + 1) % 3],
                        *xl = rest + 3 * (size_t)F[3 * t + (k + 2) % 3];
            double wl = w[3 * t + (k + 2) % 3], wj = w[3 * t + (k + 1) % 3];
            for (int c = 0; c < 3; c++)
                p->e[9 * (size_t)t + 3 * k + c] = wl * ((double)xi[c] - xj[c]) + wj * ((double)xi[c] - xl[c]);
        }
    size_t n = mdl__laplacian_triplets(w, F, nf, nv, ti, tj, tx), k = 0, ncoup = 0;
    for (size_t e = 0; e < n; e++)
        ncoup += (p->row[ti[e]] >= 0) != (p->row[tj[e]] >= 0);
    p->coup_r = mdl__calloc(ncoup + 1, sizeof *p->coup_r);
    p->coup_a = mdl__calloc(ncoup + 1, sizeof *p->coup_a);
    p->coup_w = mdl__calloc(ncoup + 1, sizeof *p->coup_w);
    p->B = mdl__calloc(3 * (size_t)(nfree ? nfree : 1), sizeof *p->B);
    if (!p->coup_r || !p->coup_a || !p->coup_w || !p->B) {
        rc = mdl__err(err, -ENOMEM, "poisson: out of memory");
        goto out;
    }
    for (size_t e = 0; e < n; e++) {
        int ri = p->row[ti[e]], rj = p->row[tj[e]];
        if (ri >= 0 && rj >= 0) {
            ti[k] = ri > rj ? ri : rj;
            tj[k] = ri > rj ? rj : ri;
            tx[k++] = tx[e];
        } else if (ri >= 0 || rj >= 0) {
            p->coup_r[p->ncoup] = ri >= 0 ? ri : rj;
            p->coup_a[p->ncoup] = ri >= 0 ? -rj - 1 : -ri - 1;
            p->coup_w[p->ncoup++] = -tx[e];
        }
    }
    if (nfree > 0)
        rc = mdl__spd_create(nfree, k, ti, tj, tx, 3, &p->spd, err);
out:
    free(ti);
    free(tj);
    free(tx);
    free(par);
    free(vtri);
    if (rc)
        mdl__poisson_fini(p);
    return rc;
}

static inline void rot3(const double *R, const double *x, double *y)
{
    y[0] = R[0] * x[0] + R[1] * x[1] + R[2] * x[2];
    y[1] = R[3] * x[0] + R[4] * x[1] + R[5] * x[2];
    y[2] = R[6] * x[0] + R[7] * x[1] + R[8] * x[2];
}

int mdl__poisson_solve(mdl__poisson *p, const double *Rt, double *X)
{
    size_t nfr = (size_t)p->nfree;
    double *B = p->B;
    memset(B, 0, 3 * nfr * sizeof *B);
    /* steps 3-5: U_reduced, the rotated fragments' differential coordinates summed per vertex */
    for (int t = 0; t < p->nf; t++) {
        const double *R = Rt + 9 * (size_t)t, *e = p->e + 9 * (size_t)t;
        for (int k = 0; k < 3; k++) {
            int r = p->row[p->F[3 * t + k]];
            if (r < 0)
                continue;
            double u[3];
            rot3(R, e + 3 * k, u);
            B[r] += u[0];
            B[nfr + r] += u[1];
            B[2 * nfr + r] += u[2];
        }
    }
    for (int a = 0; a < p->nanchor; a++) {
        static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        rot3(p->anchor_tri[a] >= 0 ? Rt + 9 * (size_t)p->anchor_tri[a] : I, p->anchor_rest + 3 * a,
             p->xa + 3 * a);
    }
    for (int e = 0; e < p->ncoup; e++) {
        const double *xa = p->xa + 3 * p->coup_a[e];
        int r = p->coup_r[e];
        B[r] += p->coup_w[e] * xa[0];
        B[nfr + r] += p->coup_w[e] * xa[1];
        B[2 * nfr + r] += p->coup_w[e] * xa[2];
    }
    /* step 6: L X = U_reduced (eq. 4) */
    if (nfr > 0) {
        int rc = mdl__spd_solve(p->spd, B, B, 3);
        if (rc)
            return rc;
    }
    for (int v = 0; v < p->nv; v++) {
        int r = p->row[v];
        if (r >= 0) {
            X[3 * (size_t)v] = B[r];
            X[3 * (size_t)v + 1] = B[nfr + r];
            X[3 * (size_t)v + 2] = B[2 * nfr + r];
        } else {
            memcpy(X + 3 * (size_t)v, p->xa + 3 * (size_t)(-r - 1), 3 * sizeof *X);
        }
    }
    return 0;
}
