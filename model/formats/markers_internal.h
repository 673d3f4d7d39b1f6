/* markers_internal.h - helpers shared by the marker readers (c3d.c, trc.c, bvh.c, csv.c) and
 * markers.c. Not part of the public interface.
 *
 * Axis and unit conversion: every reader first fills mdl_markers with the file's own numbers
 * (file units, file axes), then resolves the options against the format's defaults and converts
 * once with mdl__markers_convert. The rotation that brings the file's up axis onto +Y is a proper
 * rotation (determinant +1), so a right-handed file stays right-handed:
 *   up +Y: (x, y, z) -> ( x,  y,  z)      up -Y: (x, y, z) -> ( x, -y, -z)
 *   up +Z: (x, y, z) -> ( x,  z, -y)      up -Z: (x, y, z) -> ( x, -z,  y)
 *   up +X: (x, y, z) -> (-y,  x,  z)      up -X: (x, y, z) -> ( y, -x,  z)
 * and then every coordinate is multiplied by the scale (metres per file unit). Joint rotations
 * (mdl_markers.rot) become P R P^T: their axes turn like points, without the scale. */
#ifndef MESHSTEER_MODEL_MARKERS_INTERNAL_H
#define MESHSTEER_MODEL_MARKERS_INTERNAL_H

#include "model.h"

/* Largest marker file mdl_markers_read loads into memory. */
#define MDL__MARKERS_MAX_FILE ((size_t)1 << 30)
/* Largest marker count and sample count (frames x count) any reader accepts. */
#define MDL__MARKERS_MAX_COUNT 100000
#define MDL__MARKERS_MAX_SAMPLES ((size_t)1 << 27)

/* Resolves `o` (may be NULL) against a format: *scale = o->scale, or file_scale when o->scale is 0;
 * *up = o->up, or default_up when o->up is MDL_UP_AUTO. Rejects a negative or non-finite scale and
 * an unknown axis (-EINVAL, message names `name`). file_scale 0 is allowed and returned as is (the
 * BVH reader guesses it later). */
int mdl__marker_opts_resolve(const mdl_marker_opts *o, double file_scale, int default_up,
                             double *scale, int *up, const char *name, char *err);

/* Converts every sample of m in place from file axes (`up`, an MDL_UP_* other than AUTO) and file
 * units to metres, Y up (see the table above). Invalid samples are set to (0, 0, 0). */
void mdl__markers_convert(mdl_markers *m, double scale, int up);

/* Allocates m->rot (identity quaternions) and m->parent (-1) for m's frames and count (a skeleton
 * reader's joint rotations, model.h). mdl__markers_convert turns them with the positions. Returns 0
 * or -ENOMEM. */
int mdl__markers_alloc_rot(mdl_markers *m);

/* Replaces names[i] by a copy of the n bytes at s (trimmed of surrounding spaces and control
 * characters; "M<i+1>" when nothing is left). Returns 0 or -ENOMEM. */
int mdl__markers_set_name(mdl_markers *m, int i, const char *s, size_t n);

/* Makes labels unique: the second "RKNE" becomes "RKNE#2", the third "RKNE#3" (skipping any
 * suffix already taken). Returns 0 or -ENOMEM. */
int mdl__markers_unique_names(mdl_markers *m);

#endif
