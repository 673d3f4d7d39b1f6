/* heading.h - the body frame of a marker source whose reference edge points up (a human's
 * pelvis -> neck), from all the markers that are present.
 *
 * With a two-marker reference edge e_ref (paper 2012 Sec. 4.1) only the first axis of the body
 * frame is fixed; posefeat.h's fixed world axis (+Z for an upright edge) does not turn when the
 * performer turns. Here the whole frame comes from a weighted rigid fit (absolute orientation,
 * [Horn 1987], rigid.h) of the current markers p_j onto their canonical configuration c_j, learned
 * at training:
 *
 *   min_{R,o} sum_j w_j || R c_j + o - p_j ||^2      (j over the markers present)
 *
 * R's columns are the body axes, o the body origin (world = R body + o, as posefeat.h). C and w
 * come from a generalised Procrustes fit over the training frames: C is the mean of the aligned
 * configurations, in the gauge of its own reference edge (e1 along it, e2 from +Z, origin at the
 * first reference marker: the frame posefeat.h would give C), and
 * w_j = 1 / (s_j^2 + eps^2 + 3 sigma^2) with s_j^2 the variance of marker j about C, so that
 * markers that move less relative to the body (pelvis, neck, feet under a dancer) decide the frame
 * more; eps = MDL_HEADING_EPS keeps one still marker from deciding alone, and sigma is the marker
 * noise (per axis) the model is made for: the weights are then the inverse of each marker's whole
 * expected variance about C at synthesis, its motion plus its noise (the steering model passes
 * the option selection's validation noise, select.h, and 0 without the selection; samba-7 and
 * pjump-7 with the selection's options, 10 mm: clean 0.918 -> 0.902 and 0.750 -> 0.737 of the
 * baseline, 10 mm noise 1.449 -> 1.412 and 1.284 -> 1.262).
 * Ours, beyond "the reference edge fixing the first axis": the edge is fitted too. With e1 taken
 * from the two reference markers alone, 10 mm marker noise on those two markers alone raised the
 * samba error (rigs/samba-7.json) from 0.68 % to 1.40 % of the diagonal; the fit averages it over
 * all markers.
 *
 * paper -> code: c_j -> hd[4 j + 0..2] (body coordinates), w_j -> hd[4 j + 3]; nmarkers x 4 doubles.
 * With fewer than three weighted markers present the reference edge alone gives the frame.
 */
#ifndef MESHSTEER_STEER_HEADING_H
#define MESHSTEER_STEER_HEADING_H

#include <stddef.h>
#include <stdint.h>

#define MDL_AXIS_FIT 2        /* posefeat.h's axis values 0, 1, and this: heading fitted here */
#define MDL_HEADING_EPS 0.02  /* metres */

/* Learns C and w (hd, nm x 4) from `frames` marker frames P (nm x 3 floats each, `stride` floats
 * apart). Allocates only a T x nm x 3 scratch: -ENOMEM, or -EINVAL when no frame has a body
 * frame. */
int mdl__heading_train(const float *P, int frames, size_t stride, int nm, const int *ref,
                       double noise, double *hd);

/* Body frame (posefeat.h conventions, R's columns e1 e2 e3, world = R body + o) of markers P
 * (nm x 3) with the fitted heading; valid (nm, NULL = all) excludes missing markers from the
 * fit. -1 when the reference edge is degenerate. Allocates nothing. */
int mdl__heading_frame(const float *P, const uint8_t *valid, int nm, const int *ref,
                       const double *hd, double R[9], double o[3]);

/* The body frame of a marker source of the steering model: axis MDL_AXIS_FIT (with hd) through
 * mdl__heading_frame, axes 0 and 1 through mdl__body_frame (posefeat.h). */
int mdl__body_frame_any(const float *P, const uint8_t *valid, int nm, int nref, const int *ref,
                        int axis, const double *hd, double R[9], double o[3]);

#endif
