/* adapt.c - variance matching and best-frame fit (paper 2012 Sec. 4.2, eq. 3-4; see adapt.h). */
#include "steer/adapt.h"
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

static void mean_sd(const double *x, int n, double *m, double *sd)
{
    double s = 0, v = 0;
    for (int i = 0; i < n; i++)
        s += x[i];
    s /= n;
    for (int i = 0; i < n; i++)
        v += (x[i] - s) * (x[i] - s);
    *m = s;
    *sd = n > 1 ? sqrt(v / (n - 1)) : 0;
}

static double sgn(double x)
{
    return (x > 0) - (x < 0);
}

int mdl__adapt_limb(const double *Fm, int FM, const double *Fv, int T, int d, int theta_idx,
                    double *scale, double *shift, int *map, char *err)
{
    if (FM < 2 || T < 2)
        return mdl__err(err, -EINVAL, "pose adaption needs at least 2 frames on each side (%d, %d)",
                        FM, T);
    for (int j = 0; j < d; j++) {
        double mm, sm, mv, sv;
        mean_sd(Fm + (size_t)j * FM, FM, &mm, &sm);
        mean_sd(Fv + (size_t)j * T, T, &mv, &sv);
        scale[j] = sm > 1e-9 ? sv / sm : 0;
        shift[j] = mv - scale[j] * mm;
    }
    double *Dm = mdl__calloc((size_t)FM, sizeof *Dm), *Dv = mdl__calloc((size_t)T, sizeof *Dv);
    if (!Dm || !Dv) {
        free(Dm);
        free(Dv);
        return mdl__err(err, -ENOMEM, "pose adaption: out of memory");
    }
    const double *tm = Fm + (size_t)theta_idx * FM, *tv = Fv + (size_t)theta_idx * T;
    for (int j = 0; j < FM; j++)
        Dm[j] = j + 1 < FM ? tm[j + 1] - tm[j] : tm[j] - tm[j - 1];
    for (int i = 0; i < T; i++)
        Dv[i] = i + 1 < T ? tv[i + 1] - tv[i] : tv[i] - tv[i - 1];
    double m, sdm, sdv, mtv, sdtv;
    mean_sd(Dm, FM, &m, &sdm);
    mean_sd(Dv, T, &m, &sdv);
    mean_sd(tv, T, &mtv, &sdtv);
    if (!(sdm > 1e-12))
        sdm = 1;
    if (!(sdv > 1e-12))
        sdv = 1;
    if (!(sdtv > 1e-12))
        sdtv = 1;
    for (int j = 0; j < FM; j++) {
        double dm = Dm[j] / sdm, th = scale[theta_idx] * tm[j] + shift[theta_idx];
        double best = INFINITY;
        int bi = 0;
        for (int i = 0; i < T; i++) {
            double dv = Dv[i] / sdv;
            double c = fabs(dm - dv) + 0.5 * (1 - sgn(dm * dv)) + fabs(th - tv[i]) / sdtv;
            if (c < best) {
                best = c;
                bi = i;
            }
        }
        map[j] = bi;
    }
    free(Dm);
    free(Dv);
    return 0;
}
