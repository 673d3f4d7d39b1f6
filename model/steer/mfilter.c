/* mfilter.c - alpha-beta filter of the input markers, gains from the training motion (mfilter.h,
 * Kalata 1984). */
#include "steer/mfilter.h"

#include <math.h>

void mdl__mfilter_train(const float *P, int frames, size_t stride, int nm, double sigma_n,
                        double *gain)
{
    for (int j = 0; j < nm; j++) {
        double s2 = 0;
        int n = 0;
        for (int f = 1; f + 1 < frames; f++)
            for (int c = 0; c < 3; c++) {
                double a = (double)P[(f + 1) * stride + 3 * j + c] - 2.0 * P[f * stride + 3 * j + c] +
                           (double)P[(f - 1) * stride + 3 * j + c];
                s2 += a * a;
                n++;
            }
        double alpha = 1, beta = 0;
        if (sigma_n > 0 && n > 0) {
            double lam = fmax(sqrt(s2 / n) / sigma_n, MDL_MFILTER_MIN_INDEX);
            double r = (4 + lam - sqrt(8 * lam + lam * lam)) / 4;
            alpha = 1 - r * r;
            beta = 2 * (2 - alpha) - 4 * sqrt(1 - alpha);
        }
        gain[2 * j] = alpha;
        gain[2 * j + 1] = beta;
    }
}

void mdl__mfilter_step(const double *gain, int nm, const float *z, const uint8_t *valid, double *x,
                       double *v, uint8_t *init)
{
    for (int j = 0; j < nm; j++) {
        if (valid && !valid[j])
            continue;
        const float *p = z + 3 * j;
        if (!init[j]) {
            for (int c = 0; c < 3; c++) {
                x[3 * j + c] = p[c];
                v[3 * j + c] = 0;
            }
            init[j] = 1;
            continue;
        }
        double a = gain[2 * j], b = gain[2 * j + 1];
        for (int c = 0; c < 3; c++) {
            double xp = x[3 * j + c] + v[3 * j + c], r = p[c] - xp;
            x[3 * j + c] = xp + a * r;
            v[3 * j + c] += b * r;
        }
    }
}
