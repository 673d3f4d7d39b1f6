/* lbs.c - linear blend skinning in double precision (Zheng et al. 2013, Sec. 3.1, eq. 1):
 * v_i = sum_b w_ib (R_b v̄_i + t_b), with K weight slots per vertex (bone index, weight; unused
 * slots weigh 0) and the bone transforms as mdl_skin_get gives them (nb x 12: R row-major, then
 * t), from the fit's own numbers (mdl_skin_get): the CLI's checks of the fitted frames and the
 * tests' fixtures. The daemon's player (play.c) and the variations' walk (walk.c) skin from
 * their own float copies of the weights on their per-frame paths. Allocates nothing. */
#include "model.h"

void mdl_skin_lbs(int nv, int K, const int *bone, const double *w, const float *rest,
                  const double *T, float *V)
{
    for (int i = 0; i < nv; i++) {
        const float *p = rest + 3 * (size_t)i;
        double o[3] = {0, 0, 0};
        for (int s = 0; s < K; s++) {
            const double wt = w[(size_t)K * i + s];
            if (wt == 0)
                continue;
            const double *M = T + 12 * (size_t)bone[(size_t)K * i + s];
            for (int c = 0; c < 3; c++)
                o[c] += wt * (M[3 * c] * p[0] + M[3 * c + 1] * p[1] + M[3 * c + 2] * p[2] + M[9 + c]);
        }
        for (int c = 0; c < 3; c++)
            V[3 * (size_t)i + c] = (float)o[c];
    }
}
