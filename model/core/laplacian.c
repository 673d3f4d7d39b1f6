/* laplacian.c - the cotangent Laplacian (laplacian.h; Desbrun et al. 2002 Sec. 3). */
#include "core/laplacian.h"

#include <math.h>

static double cot_at(const float *p, const float *q, const float *r)
{
    /* the cotangent of the angle at p of triangle p q r */
    double u[3], v[3];
    for (int c = 0; c < 3; c++) {
        u[c] = (double)q[c] - p[c];
        v[c] = (double)r[c] - p[c];
    }
    double d = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2], z = u[0] * v[1] - u[1] * v[0];
    double s = sqrt(x * x + y * y + z * z);
    if (!(s > 0))
        return 0; /* a degenerate triangle contributes nothing */
    double ct = d / s;
    return ct > MDL_COT_MAX ? MDL_COT_MAX : ct < -MDL_COT_MAX ? -MDL_COT_MAX : ct;
}

void mdl__cot_weights(const float *V, const uint32_t *F, int nf, double *w)
{
    for (int t = 0; t < nf; t++) {
        const float *a = V + 3 * (size_t)F[3 * t], *b = V + 3 * (size_t)F[3 * t + 1],
                    *c = V + 3 * (size_t)F[3 * t + 2];
        w[3 * t] = 0.5 * cot_at(a, b, c);
        w[3 * t + 1] = 0.5 * cot_at(b, c, a);
        w[3 * t + 2] = 0.5 * cot_at(c, a, b);
    }
}

size_t mdl__laplacian_triplets(const double *w, const uint32_t *F, int nf, int nv, int *ti,
                               int *tj, double *tx)
{
    size_t n = 0;
    for (int v = 0; v < nv; v++) {
        ti[n] = tj[n] = v;
        tx[n++] = 0;
    }
    for (int t = 0; t < nf; t++)
        for (int k = 0; k < 3; k++) {
            int i = (int)F[3 * t + (k + 1) % 3], j = (int)F[3 * t + (k + 2) % 3];
            double x = w[3 * t + k];
            tx[i] += x; /* the diagonal entries are the first nv triplets */
            tx[j] += x;
            ti[n] = i > j ? i : j;
            tj[n] = i > j ? j : i;
            tx[n++] = -x;
        }
    return n;
}
