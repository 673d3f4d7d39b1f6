/* head_crown.c - the top of a head cut off from the face by an arm in front of it.
 *
 * With a hand raised above the head and the forearm across the forehead (the SMPL man's lambada
 * turned -20 and -35 degrees), the forearm, nearer the camera than the head by more than the
 * geodesic graph's jump, splits the visible head in two: the face below the arm, joined to the
 * neck, and the crown above it, joined only to the arm. The crown is then an extremum of its own
 * whose geodesic runs up the arm and back down (accumulative geodesic 1.9-2.1 m, against the
 * face's 0.7-1.0 m in lambada's frames 486-544), too long to be labelled a head (label.c costs a
 * head 1 per 0.1 m beyond 1 m); the face's extremum was labelled the head instead, its marker
 * 11-26 cm from the head's top, and reported valid (0.115 of lambada's valid heads at -20
 * degrees had no head within 10 cm).
 *
 * The test: an unlabelled extremum in view, not an arm loop's hand, that lies within HEAD_REACH
 * of the labelled head's tip in space - within a head's length of it (head_axis.c) - but more than
 * HEAD_REACH farther from the centroid along the surface, so reached around an occluder rather
 * than over the head, and at least CROWN_RISE higher along the body's up. The highest such is the
 * head's top; markers.c places the head half a head (head_offset) behind it, as for any head
 * whose silhouette is not its own. Not from a paper: the geometry of an occluded surface in a
 * geodesic graph. A hand held on the top of the head passes the test too, and its tip is then
 * within a hand's thickness of the head's top. */
#include "depth_internal.h"

/* metres: a head's length, as head_axis.c's (depth_internal.h) */
#define HEAD_REACH DRV__HEAD_REACH
/* metres: how much higher than the labelled point the crown must be. Measured at 0 and 0.05 m on
 * lambada at 2.5 m: heads within 10 cm at -20 degrees 0.921 / 0.928, at -35 0.602 / 0.596 */
#define CROWN_RISE 0.05f

int drv__head_crown(const drv__extremum *ex, int nex, const int label[5], int head,
                    const float up[3])
{
    const drv__extremum *h = &ex[head];
    int best = -1;
    float best_rise = CROWN_RISE;
    for (int f = 0; f < nex; f++) {
        const drv__extremum *x = &ex[f];
        int used = 0;
        for (int k = 0; k < 5; k++)
            used |= label[k] == f;
        if (used || x->border || x->loop || !(x->geodesic0 > h->geodesic0 + HEAD_REACH))
            continue;
        const float d[3] = {x->tip[0] - h->tip[0], x->tip[1] - h->tip[1], x->tip[2] - h->tip[2]};
        const float rise = d[0] * up[0] + d[1] * up[1] + d[2] * up[2];
        const float dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if (dd <= HEAD_REACH * HEAD_REACH && rise > best_rise) {
            best = f;
            best_rise = rise;
        }
    }
    return best;
}
