/* adapt.h - pose adaption between a marker recording and the mesh sequence (paper 2012 Sec. 4.2).
 *
 * Variance matching: every limb feature of the recording is mapped affinely so that its mean and
 * standard deviation equal those of the same feature on the mesh's virtual markers,
 *     f' = scale * f + shift,  scale = sd_v / sd_m,  shift = mean_v - scale * mean_m,
 * "the variances within both sets need to agree" (Sec. 4.2). The same map is applied to live input.
 *
 * Best-frame fit, eq. (3)-(4): for each recording frame j the mesh frame
 *     f*(j) = argmin_i |D_m(j) - D_v(i)| + sigma/2 (1 - sgn(D_m(j) D_v(i)))  [+ |theta'_m(j) - theta_v(i)|]
 * where theta is the limb angle alpha_1 against e_ref and D its forward difference. Because the
 * recording and the mesh are sampled at different rates, D_m and D_v are each divided by their own
 * standard deviation (so sigma = 1 in these units), and the bracketed angle-conformity term (ours,
 * with theta'_m variance-matched and both divided by sd(theta_v)) keeps the fit in phase: eq. (4)
 * alone matches angular velocity only.
 *
 * Fm: FM x d column-major (ld FM); Fv: T x d column-major (ld T); theta_idx: the feature index of
 * alpha_1. Outputs scale, shift (d) and map (FM). Training only: allocates. */
#ifndef MESHSTEER_MODEL_ADAPT_H
#define MESHSTEER_MODEL_ADAPT_H

int mdl__adapt_limb(const double *Fm, int FM, const double *Fv, int T, int d, int theta_idx,
                    double *scale, double *shift, int *map, char *err);

#endif
