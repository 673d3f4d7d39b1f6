/* kblend.h - kernel blend of the training meshes in marker space: a synthesis the option
 * selection may choose instead of the part-based model (issue 12).
 *
 * Our extension, not the paper's method. Vögele et al. 2012 predict each part's pose and shape by
 * regression from the markers (Sec. 4.3, eq. 5) and name non-linear regression as the remedy for
 * its artefacts (Sec. 6); the nearest training frame by marker fit is the baseline every model is
 * measured against (DESIGN.md). This is the kernel (Nadaraya-Watson) regression between the two,
 * over whole training meshes: with the plain seven-marker human rigs the part model stays at 0.74-
 * 0.90 of the baseline clean and 1.26-1.41 under 10 mm noise, while this blend reached 0.47 / 0.59
 * (samba-7) and 0.43 / 0.53 (pjump-7) in a first measurement (docs/PERFORMANCE.md); on the horse
 * (0.63) the part model (0.41) is better. The selection (select.h) decides per sequence.
 *
 * For input markers x (nm x 3, the valid ones) and training frame g with rig markers y_g and mesh
 * G_g (nv x 3):
 *   (R_g, t_g) = argmin sum_j |R y_gj + t - x_j|^2       (Kabsch, rigid.h)
 *   f_g        = RMS residual of that fit,  f* = min_g f_g
 *   w_g        = exp(-(f_g^2 - f*^2) / (2 (h f*)^2))      (balloon bandwidth h f*, h = option)
 *   V          = sum_g w_g (R_g G_g + t_g) / sum_g w_g     (frames with w_g < MDL_KBLEND_WMIN
 *                                                          are skipped)
 * The bandwidth follows the nearest residual, so the blend has no length scale of its own: when
 * one frame fits much better than the others it is the nearest frame; when several fit about as
 * well (between two training poses, or under marker noise, which raises every f_g alike) it
 * averages them. h is the one constant, chosen by the cross-validation among MDL_KBLEND_H.
 *
 * paper -> code: none (our extension); y_g -> kb_mk (ntrain x nm x 3 floats), G_g -> kb_V
 * (ntrain x nv x 3 floats), h -> kb_h (struct mdl_steer, steer_internal.h).
 * Floats for the stored frames (as the mesh sequence), doubles for the fits and the sums.
 */
#ifndef MESHSTEER_STEER_KBLEND_H
#define MESHSTEER_STEER_KBLEND_H

#include <stdint.h>

/* the bandwidth factors the option selection tries (select.h) */
#define MDL_KBLEND_H {0.5, 0.7, 1.0}
#define MDL_KBLEND_NH 3

#define MDL_KBLEND_WMIN 1e-3 /* weights below this (of the nearest frame's 1) are left out */

/* Scratch the per-frame blend needs: doubles, for ntrain frames and nm markers. */
#define MDL_KBLEND_SCRATCH(ntrain, nm) ((size_t)(ntrain) * 13 + (size_t)(nm) * 6)

/* One frame: P (nm x 3) the input markers, use (nm) which of them to fit (at least 3), kb_V,
 * kb_mk, h as above; scratch of MDL_KBLEND_SCRATCH doubles; Vout (nv x 3). Allocates nothing.
 * Returns 0, or -EAGAIN with fewer than 3 markers to fit (Vout untouched). */
int mdl__kblend_frame(const float *kb_V, const float *kb_mk, int ntrain, int nv, int nm, double h,
                      const float *P, const uint8_t *use, double *scratch, float *Vout);

#endif
