/* test_laplacian.c - the cotangent Laplacian (model/core/laplacian.c): it maps constants to zero,
 * it is symmetric (as assembled, and as a dense check of the triplets), and on a flat regular grid
 * its interior rows are the 5-point stencil (cot 45 deg = 1 gives weights of 1 on the axis edges,
 * 0 on the diagonals). */
#include "core/laplacian.h"
#include "test.h"
#include "../harmonic/htube.h"

static void dense(const int *ti, const int *tj, const double *tx, size_t n, int nv, double *A)
{
    memset(A, 0, sizeof(double) * (size_t)nv * nv);
    for (size_t e = 0; e < n; e++) {
        ASSERT(ti[e] >= tj[e]);
        A[(size_t)ti[e] * nv + tj[e]] += tx[e];
        if (ti[e] != tj[e])
            A[(size_t)tj[e] * nv + ti[e]] += tx[e];
    }
}

int main(void)
{
    mdl_mesh *m = htube_create(9, 7);
    int nv = m->nv, nf = m->nf;
    double *w = calloc(3 * (size_t)nf, sizeof *w), *tx = calloc(3 * (size_t)nf + nv, sizeof *tx);
    int *ti = calloc(3 * (size_t)nf + nv, sizeof *ti), *tj = calloc(3 * (size_t)nf + nv, sizeof *tj);
    double *A = calloc((size_t)nv * nv, sizeof *A), *A2 = calloc((size_t)nv * nv, sizeof *A2);
    mdl__cot_weights(m->V, m->F, nf, w);
    size_t n = mdl__laplacian_triplets(w, m->F, nf, nv, ti, tj, tx);
    ASSERT_INT_EQ(n, 3 * (size_t)nf + nv);
    dense(ti, tj, tx, n, nv, A);
    for (int i = 0; i < nv; i++) {
        double s = 0, x = 0;
        for (int j = 0; j < nv; j++) {
            s += A[(size_t)i * nv + j];
            x += A[(size_t)i * nv + j] * (m->V[3 * j] * 2.0 + 0.5); /* L (a x + b) on a line... */
            ASSERT_NEAR_I(A[(size_t)i * nv + j], A[(size_t)j * nv + i], 1e-12, i * nv + j);
        }
        ASSERT_NEAR_I(s, 0, 1e-9, i); /* constants -> 0 */
        (void)x;
    }
    /* also for a perturbed mesh (irregular triangles, obtuse angles) */
    for (int v = 0; v < nv; v++)
        for (int c = 0; c < 3; c++)
            m->V[3 * v + c] += (float)(0.02 * sin(7.1 * v + 1.3 * c));
    mdl__cot_weights(m->V, m->F, nf, w);
    n = mdl__laplacian_triplets(w, m->F, nf, nv, ti, tj, tx);
    dense(ti, tj, tx, n, nv, A2);
    for (int i = 0; i < nv; i++) {
        double s = 0;
        for (int j = 0; j < nv; j++)
            s += A2[(size_t)i * nv + j];
        ASSERT_NEAR_I(s, 0, 1e-9, i);
    }
    /* a flat unit grid of right triangles: interior rows are the 5-point stencil */
    {
        int g = 5, gv = g * g, gf = 2 * (g - 1) * (g - 1), k = 0;
        float *V = calloc(3 * (size_t)gv, sizeof *V);
        uint32_t *F = calloc(3 * (size_t)gf, sizeof *F);
        for (int y = 0; y < g; y++)
            for (int x = 0; x < g; x++) {
                V[3 * (y * g + x)] = (float)x;
                V[3 * (y * g + x) + 1] = (float)y;
            }
        for (int y = 0; y + 1 < g; y++)
            for (int x = 0; x + 1 < g; x++) {
                uint32_t a = (uint32_t)(y * g + x), b = a + 1, c = a + (uint32_t)g, d = c + 1;
                uint32_t t[6] = {a, b, d, a, d, c};
                memcpy(F + 3 * k, t, sizeof t);
                k += 2;
            }
        double *gw = calloc(3 * (size_t)gf, sizeof *gw), *gx = calloc(3 * (size_t)gf + gv, sizeof *gx);
        int *gi = calloc(3 * (size_t)gf + gv, sizeof *gi), *gj = calloc(3 * (size_t)gf + gv, sizeof *gj);
        double *G = calloc((size_t)gv * gv, sizeof *G);
        mdl__cot_weights(V, F, gf, gw);
        size_t gn = mdl__laplacian_triplets(gw, F, gf, gv, gi, gj, gx);
        dense(gi, gj, gx, gn, gv, G);
        int c = 2 * g + 2;
        ASSERT_NEAR(G[(size_t)c * gv + c], 4, 1e-9);
        ASSERT_NEAR(G[(size_t)c * gv + c + 1], -1, 1e-9);
        ASSERT_NEAR(G[(size_t)c * gv + c + g], -1, 1e-9);
        ASSERT_NEAR(G[(size_t)c * gv + c + g + 1], 0, 1e-9);
        free(V), free(F), free(gw), free(gx), free(gi), free(gj), free(G);
    }
    free(w), free(tx), free(ti), free(tj), free(A), free(A2);
    mdl_mesh_destroy(m);
    puts("laplacian: ok");
    return 0;
}
