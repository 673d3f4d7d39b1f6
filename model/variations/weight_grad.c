/* weight_grad.c - the weight gradients dw_ib / dv_bar_i at the key vertices (Zheng 2013
 * Appendix A), by constrained least squares so that the unit sum of the weights carries over to
 * their gradients exactly:
 *
 *   eq. (16)   dw_ib/dv_bar_i . (v_j - v_i) ~ w_jb - w_ib   for the P neighbours v_j of v_i (its
 *              1-ring), each row weighted by 1 / |v_j - v_i| ("a closer neighbor results in a
 *              better approximation")
 *   eq. (17)   the rows of all the vertex's related bones stacked, block-diagonal with the same
 *              block A_i per bone, solved
 *   eq. (15)   subject to sum_b dw_ib/dv_bar_i = 0 (dgglse: the generalised RQ factorisation
 *              projects onto the constraint's space, as the paper's QR of (15) does)
 *
 * The related bones are those with a weight at v_i or at one of its neighbours. The weights live
 * on the surface only ("the LBS model only defines w_ib on the mesh surface not in the 3D
 * space"), so the 1-ring says nothing about the gradient along the normal, and on a nearly flat
 * ring A_i is nearly singular there; we add one row per bone asking the normal component to be 0
 * (the vertex normal, area-weighted over the ring's faces; weight the mean of the ring's rows).
 * That is our choice, not the paper's; it changes nothing of the constraint (15). A key vertex
 * with fewer than 2 neighbours, or a single related bone, gets zero gradients (then (15) holds
 * trivially and eq. 8 is sum_b w_ib R_b).
 * Analysis: allocates freely. */
#include "variations/variations.h"
#include "core/linalg.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_int(const void *a, const void *b)
{
    int x = *(const int *)a, y = *(const int *)b;
    return (x > y) - (x < y);
}

int mdl__weight_grads(struct mdl_variations *g, const mdl__vskin *s, const int *map, char *err)
{
    int nk = g->nkey, rc = 0;
    int *kidx = mdl__calloc((size_t)s->nv, sizeof *kidx);
    int *noff = mdl__calloc((size_t)nk + 1, sizeof *noff);
    double *nrm = mdl__calloc(3 * (size_t)nk, sizeof *nrm);
    int *nbr = NULL, *pos = mdl__calloc((size_t)g->nb, sizeof *pos);
    int *lb = mdl__calloc((size_t)s->K, sizeof *lb), *rb = NULL;
    double *lw = mdl__calloc((size_t)s->K, sizeof *lw), *W = NULL, *A = NULL, *B = NULL, *c = NULL,
           *d = NULL, *x = NULL;
    g->key_x = mdl__calloc(3 * (size_t)nk, sizeof *g->key_x);
    g->kb_off = mdl__calloc((size_t)nk + 1, sizeof *g->kb_off);
    if (!kidx || !noff || !nrm || !pos || !lb || !lw || !g->key_x || !g->kb_off)
        goto oom;
    for (int v = 0; v < s->nv; v++)
        kidx[v] = -1;
    for (int i = 0; i < nk; i++) {
        kidx[g->key_v[i]] = i;
        for (int a = 0; a < 3; a++)
            g->key_x[3 * i + a] = s->rest[3 * (size_t)g->key_v[i] + a];
    }
    /* the 1-rings (each neighbour twice, deduplicated below) and the area-weighted normals */
    for (int f = 0; f < s->nf; f++)
        for (int k = 0; k < 3; k++)
            if (kidx[s->F[3 * (size_t)f + k]] >= 0)
                noff[kidx[s->F[3 * (size_t)f + k]] + 1] += 2;
    for (int i = 0; i < nk; i++)
        noff[i + 1] += noff[i];
    nbr = mdl__calloc((size_t)noff[nk] + 1, sizeof *nbr);
    int *fill = mdl__calloc((size_t)nk + 1, sizeof *fill);
    if (!nbr || !fill) {
        free(fill);
        goto oom;
    }
    for (int f = 0; f < s->nf; f++) {
        const uint32_t *t = s->F + 3 * (size_t)f;
        const float *p0 = s->rest + 3 * (size_t)t[0], *p1 = s->rest + 3 * (size_t)t[1],
                    *p2 = s->rest + 3 * (size_t)t[2];
        double e1[3], e2[3], n[3];
        for (int a = 0; a < 3; a++) {
            e1[a] = (double)p1[a] - p0[a];
            e2[a] = (double)p2[a] - p0[a];
        }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        for (int k = 0; k < 3; k++) {
            int i = kidx[t[k]];
            if (i < 0)
                continue;
            nbr[noff[i] + fill[i]++] = (int)t[(k + 1) % 3];
            nbr[noff[i] + fill[i]++] = (int)t[(k + 2) % 3];
            for (int a = 0; a < 3; a++)
                nrm[3 * i + a] += n[a];
        }
    }
    free(fill);
    int maxp = 0;
    for (int i = 0; i < nk; i++) { /* sort, unique, in place (the count kept in fill's place) */
        int *L = nbr + noff[i], n = noff[i + 1] - noff[i], u = 0;
        qsort(L, n, sizeof *L, cmp_int);
        for (int k = 0; k < n; k++)
            if (u == 0 || L[k] != L[u - 1])
                L[u++] = L[k];
        for (int k = u; k < n; k++)
            L[k] = -1;
        maxp = u > maxp ? u : maxp;
    }
    int maxm = s->K * (maxp + 1);
    if (maxm > g->nb)
        maxm = g->nb;
    rb = mdl__calloc((size_t)maxm + 1, sizeof *rb);
    W = mdl__calloc((size_t)(maxp + 1) * (maxm + 1), sizeof *W);
    size_t rows = (size_t)maxm * (maxp + 1) + 1, cols = 3 * (size_t)maxm + 3;
    A = mdl__calloc(rows * cols, sizeof *A);
    B = mdl__calloc(3 * cols, sizeof *B);
    c = mdl__calloc(rows, sizeof *c);
    d = mdl__calloc(3, sizeof *d);
    x = mdl__calloc(cols, sizeof *x);
    /* at most maxm bones per key vertex */
    g->kb_bone = mdl__calloc((size_t)nk * maxm + 1, sizeof *g->kb_bone);
    g->kb_w = mdl__calloc((size_t)nk * maxm + 1, sizeof *g->kb_w);
    g->kb_g = mdl__calloc(3 * ((size_t)nk * maxm + 1), sizeof *g->kb_g);
    if (!rb || !W || !A || !B || !c || !d || !x || !g->kb_bone || !g->kb_w || !g->kb_g)
        goto oom;
    for (int b = 0; b < g->nb; b++)
        pos[b] = -1;
    int at = 0;
    for (int i = 0; i < nk; i++) {
        g->kb_off[i] = at;
        const int *L = nbr + noff[i];
        int P = 0;
        while (P < noff[i + 1] - noff[i] && L[P] >= 0)
            P++;
        /* the related bones and the weights W (vertex: 0 = v_i, 1 + j = neighbour j; x bone) */
        int m = 0;
        for (int q = 0; q <= P; q++) {
            int vtx = q == 0 ? g->key_v[i] : L[q - 1];
            int n = mdl__vskin_vertex(s, map, vtx, lb, lw);
            for (int k = 0; k < n; k++)
                if (pos[lb[k]] < 0 && m < maxm) {
                    pos[lb[k]] = m;
                    rb[m++] = lb[k];
                }
        }
        memset(W, 0, sizeof *W * (size_t)(maxp + 1) * (maxm + 1));
        for (int q = 0; q <= P; q++) {
            int vtx = q == 0 ? g->key_v[i] : L[q - 1];
            int n = mdl__vskin_vertex(s, map, vtx, lb, lw);
            for (int k = 0; k < n; k++)
                W[(size_t)q * maxm + pos[lb[k]]] = lw[k];
        }
        for (int q = 0; q < m; q++) {
            g->kb_bone[at + q] = rb[q];
            g->kb_w[at + q] = W[q];
            memset(g->kb_g + 3 * (size_t)(at + q), 0, 3 * sizeof *g->kb_g);
        }
        double *nn = nrm + 3 * i, len = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        if (m > 1 && P >= 2 && len > 0) {
            int R = m * (P + 1), n = 3 * m;
            const double *xi = g->key_x + 3 * i;
            double wmean = 0;
            memset(A, 0, sizeof *A * (size_t)R * n);
            memset(B, 0, sizeof *B * 3 * (size_t)n);
            for (int j = 0; j < P; j++) {
                const float *pj = s->rest + 3 * (size_t)L[j];
                double e[3] = {pj[0] - xi[0], pj[1] - xi[1], pj[2] - xi[2]};
                double el = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
                double om = el > 0 ? 1 / el : 0;
                wmean += om / P;
                for (int q = 0; q < m; q++) {
                    int row = q * (P + 1) + j;
                    for (int a = 0; a < 3; a++)
                        A[row + (size_t)R * (3 * q + a)] = om * e[a];
                    c[row] = om * (W[(size_t)(j + 1) * maxm + q] - W[q]);
                }
            }
            for (int q = 0; q < m; q++) {
                int row = q * (P + 1) + P;
                for (int a = 0; a < 3; a++)
                    A[row + (size_t)R * (3 * q + a)] = wmean * nn[a] / len;
                c[row] = 0;
                for (int a = 0; a < 3; a++)
                    B[a + 3 * (size_t)(3 * q + a)] = 1;
            }
            d[0] = d[1] = d[2] = 0;
            rc = mdl_la_gglse(R, n, 3, A, R, B, 3, c, d, x, err);
            if (rc) {
                char why[200];
                snprintf(why, sizeof why, "%s", err ? err : "");
                rc = mdl__err(err, rc, "variations: weight gradients at key vertex %d (mesh vertex "
                              "%d, %d neighbours, %d bones): %s", i, g->key_v[i], P, m, why);
                goto out;
            }
            for (int q = 0; q < m; q++)
                memcpy(g->kb_g + 3 * (size_t)(at + q), x + 3 * q, 3 * sizeof *x);
        }
        for (int q = 0; q < m; q++)
            pos[rb[q]] = -1;
        at += m;
    }
    g->kb_off[nk] = at;
    goto out;
oom:
    rc = mdl__err(err, -ENOMEM, "variations: out of memory for weight gradients");
out:
    free(kidx);
    free(noff);
    free(nrm);
    free(nbr);
    free(pos);
    free(lb);
    free(lw);
    free(rb);
    free(W);
    free(A);
    free(B);
    free(c);
    free(d);
    free(x);
    return rc;
}
