/* kblend.c - kernel blend of the training meshes in marker space (kblend.h). */
#include "steer/kblend.h"
#include "core/rigid.h"

#include <errno.h>
#include <math.h>
#include <string.h>

int mdl__kblend_frame(const float *kb_V, const float *kb_mk, int ntrain, int nv, int nm, double h,
                      const float *P, const uint8_t *use, double *scratch, float *Vout)
{
    double *fit = scratch, *RT = fit + ntrain, *ya = RT + 12 * (size_t)ntrain, *xb = ya + 3 * (size_t)nm;
    int n = 0;
    for (int j = 0; j < nm; j++)
        if (use[j]) {
            for (int c = 0; c < 3; c++)
                xb[3 * n + c] = P[3 * j + c];
            n++;
        }
    if (n < 3 || ntrain < 1)
        return -EAGAIN;
    double best = INFINITY;
    for (int g = 0; g < ntrain; g++) {
        const float *y = kb_mk + (size_t)g * nm * 3;
        int k = 0;
        for (int j = 0; j < nm; j++)
            if (use[j]) {
                for (int c = 0; c < 3; c++)
                    ya[3 * k + c] = y[3 * j + c];
                k++;
            }
        fit[g] = mdl__kabsch(ya, xb, NULL, n, RT + 12 * g, RT + 12 * g + 9);
        if (fit[g] < best)
            best = fit[g];
    }
    double hb = h * best;
    if (!(hb > 1e-9)) /* an exact match: the nearest frame alone */
        hb = 1e-9;
    double W = 0;
    for (int g = 0; g < ntrain; g++) {
        double d = (fit[g] - best) * (fit[g] + best) / (2 * hb * hb);
        fit[g] = d < -log(MDL_KBLEND_WMIN) ? exp(-d) : 0; /* now the weight */
        W += fit[g];
    }
    memset(Vout, 0, sizeof(float) * 3 * (size_t)nv);
    for (int g = 0; g < ntrain; g++) {
        if (fit[g] <= 0)
            continue;
        double w = fit[g] / W;
        const double *R = RT + 12 * g, *t = R + 9;
        float A[12];
        for (int c = 0; c < 9; c++)
            A[c] = (float)(w * R[c]);
        for (int c = 0; c < 3; c++)
            A[9 + c] = (float)(w * t[c]);
        const float *G = kb_V + (size_t)g * nv * 3;
        for (int v = 0; v < nv; v++) {
            const float *p = G + 3 * v;
            float *o = Vout + 3 * v;
            for (int r = 0; r < 3; r++)
                o[r] += A[3 * r] * p[0] + A[3 * r + 1] * p[1] + A[3 * r + 2] * p[2] + A[9 + r];
        }
    }
    return 0;
}
