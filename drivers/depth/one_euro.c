/* one_euro.c - the One Euro filter [Casiez, Roussel, Vogel 2012, "1 Euro Filter: A Simple
 * Speed-based Low-pass Filter for Noisy Input in Interactive Systems", CHI, Sec. 3]:
 *   alpha(fc, T) = 1 / (1 + tau / T),  tau = 1 / (2 pi fc)
 *   dx_hat_i = alpha(dcutoff) (x_i - x_hat_{i-1}) / T + (1 - alpha(dcutoff)) dx_hat_{i-1}
 *   fc_i = min_cutoff + beta |dx_hat_i|
 *   x_hat_i = alpha(fc_i) x_i + (1 - alpha(fc_i)) x_hat_{i-1}
 * A low cutoff removes jitter when the marker is still; the cutoff rises with speed, so fast
 * motion is followed with little lag. Units: seconds, metres, Hz. */
#include "depth_internal.h"

#include <math.h>

static double alpha(double cutoff, double T)
{
    double tau = 1.0 / (2.0 * M_PI * cutoff);
    return 1.0 / (1.0 + tau / T);
}

void drv_one_euro_init(drv_one_euro *f, double min_cutoff, double beta, double dcutoff)
{
    f->min_cutoff = min_cutoff;
    f->beta = beta;
    f->dcutoff = dcutoff;
    drv_one_euro_reset(f);
}

void drv_one_euro_reset(drv_one_euro *f)
{
    f->init = 0;
    f->x = f->dx = 0;
    f->t_us = 0;
}

double drv_one_euro_filter(drv_one_euro *f, double x, uint64_t t_us)
{
    if (!f->init) { /* the first sample passes through */
        f->init = 1;
        f->x = x;
        f->dx = 0;
        f->t_us = t_us;
        return x;
    }
    if (t_us <= f->t_us) /* no time has passed: keep the estimate */
        return f->x;
    double T = (double)(t_us - f->t_us) * 1e-6;
    f->t_us = t_us;
    double a_d = alpha(f->dcutoff, T);
    f->dx = a_d * (x - f->x) / T + (1.0 - a_d) * f->dx;
    double fc = f->min_cutoff + f->beta * fabs(f->dx);
    double a = alpha(fc, T);
    f->x = a * x + (1.0 - a) * f->x;
    return f->x;
}
