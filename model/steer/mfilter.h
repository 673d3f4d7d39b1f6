/* mfilter.h - a causal filter on the input markers of the steering model's synthesis (issue 12:
 * marker noise on the pelvis and neck enters every limb's parameters through the body frame).
 *
 * Each marker coordinate is followed by an alpha-beta filter, the steady state of a Kalman filter
 * for a constant-velocity target driven by white acceleration [Kalata 1984, "The tracking index: a
 * generalized parameter for alpha-beta and alpha-beta-gamma target trackers", IEEE Trans. AES 20(2)]:
 *
 *   predict  x' = x + v          (one input frame)
 *   update   r = z - x',  x = x' + alpha r,  v = v + beta r
 *
 * with the tracking index lambda = sigma_a / sigma_n (acceleration per frame^2 over measurement
 * noise), r = (4 + lambda - sqrt(8 lambda + lambda^2)) / 4, alpha = 1 - r^2,
 * beta = 2 (2 - alpha) - 4 sqrt(1 - alpha).
 * sigma_a comes from the data: per marker, the RMS per-axis second difference of its trajectory
 * over successive training frames (so the cut-off follows each marker's own motion: a hand keeps
 * alpha near 1, the pelvis is smoothed more). The input is assumed to arrive at the spacing of
 * the training frames. sigma_n is the noise the model is made for (the option selection's
 * validation noise, select.h); 0 switches the filter off (alpha = 1, beta = 0).
 *
 * A marker that did not accelerate in training (lambda -> 0 gives alpha = beta = 0: the filter
 * would never move again) is still followed: lambda >= MDL_MFILTER_MIN_INDEX, alpha >= 0.13, a
 * time constant of about 8 frames. The people and the horse (docs/PERFORMANCE.md) have alpha >=
 * 0.54 on every marker, so the bound does not act on them.
 *
 * paper -> code: gain[2 j] = alpha_j, gain[2 j + 1] = beta_j.
 */
#ifndef MESHSTEER_STEER_MFILTER_H
#define MESHSTEER_STEER_MFILTER_H

#include <stddef.h>
#include <stdint.h>

#define MDL_MFILTER_MIN_INDEX 0.01

/* Gains (nm x 2) from `frames` successive marker frames P (nm x 3 floats each, `stride` apart). */
void mdl__mfilter_train(const float *P, int frames, size_t stride, int nm, double sigma_n,
                        double *gain);

/* One step for nm markers: z (nm x 3) measured where valid[j] (NULL = all), x and v (nm x 3) the
 * state, init (nm) 0 until a marker's first measurement (which it takes as is). A marker not
 * valid in this frame keeps its state. Allocates nothing. */
void mdl__mfilter_step(const double *gain, int nm, const float *z, const uint8_t *valid, double *x,
                       double *v, uint8_t *init);

#endif
