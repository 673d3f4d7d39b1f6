/* posefeat.h - pose parameters of the marker graph (paper 2012 Sec. 4.1, Table 1).
 *
 * Body frame: origin at the first reference marker; axis e1 along the reference edge e_ref;
 * e2 a secondary axis made orthogonal to e1: with a third reference marker the normal of the
 * reference triangle crossed with e1, otherwise a fixed world axis, +Y (axis 0) or, for a
 * reference edge that itself points up such as a human's hips-to-neck, +Z (axis 1). The axis is
 * chosen once per marker source (mdl__ref_axis), never per frame: switching per frame would make
 * the frame jump whenever the edge crosses the threshold. e3 = e1 x e2. For a two-marker edge that
 * points up the steering model does not use this fixed axis but fits the whole frame to all
 * markers (heading.h, axis value MDL_AXIS_FIT).
 * R's columns are (e1, e2, e3): world = R * body + o.
 *
 * Features of a limb path p_G = (m_1 .. m_p), all in the body frame:
 *   for each edge e_j = m_{j+1} - m_j: its unit direction (3) and its length |e_j| (1)   [Table 1]
 *   alpha_1, the angle between e_ref and e_1                                             [Table 1]
 *   alpha_j, the angles between successive edges (j > 1)                                 [Table 1]
 *   the position of m_p relative to the body origin (3)          [ours: eases linear regression]
 *   optionally d_{m_i}, the unit direction of movement of every marker (3 each)           [Table 1]
 *     (backward differences m(f) - m(f-1), so that live input needs no future frame; softly
 *     normalised, v / sqrt(|v|^2 + eps^2) with eps = MDL_MOTION_EPS, so that it fades out for
 *     movements at the scale of marker noise instead of turning noise into a unit vector)
 */
#ifndef MESHSTEER_MODEL_POSEFEAT_H
#define MESHSTEER_MODEL_POSEFEAT_H

#include "model.h"

#define MDL_MOTION_EPS 0.01 /* metres per frame */

/* Body frame from marker positions P (nmarkers x 3). Returns -1 when degenerate. */
int mdl__body_frame(const float *P, int nref, const int *ref, int axis, double R[9], double o[3]);

/* The secondary axis for a marker source: 1 when the reference edge points mostly up (mean
 * |e1 . Y| > 0.7 over the given frames, each nmarkers x 3 floats, `stride` floats apart). */
int mdl__ref_axis(const float *P, int frames, size_t stride, const int *ref);

int mdl__limb_nfeat(int path_len, int use_motion);

/* Heading of a body frame about +Y (radians): the direction of its most horizontal axis among e1
 * and e3 in the ground plane. */
double mdl__body_heading(const double R[9]);

/* path: marker indices (path_len). P, Pprev: nmarkers x 3 (Pprev may be NULL). R, o: body frame.
 * Rprev, oprev: body frame of Pprev (used for motion directions). feat: mdl__limb_nfeat values. */
void mdl__limb_features(const float *P, const float *Pprev, const int *path, int path_len,
                        const double R[9], const double o[3], int use_motion, double *feat);

#endif
