/* tri_tri.h - do two triangles in space intersect (share a point)?
 *
 * Möller, "A Fast Triangle-Triangle Intersection Test", J. Graphics Tools 2(2), 1997, Sec. 2:
 * first the plane rejection: with d_i the signed distances of one triangle's corners to the
 * other's plane (the orientation det[b - a, c - a, x - a] over the plane's corners a, b, c), all
 * of one sign means no intersection (tested both ways). Then, where Möller compares the two
 * triangles' intervals on the planes' intersection line, the equivalent edge form is used:
 * two non-coplanar triangles meet iff an edge of one crosses the other (the ends of the common
 * interval on that line are points of an edge of one triangle inside the other), and a segment
 * pq that straddles the plane of abc (d_p d_q <= 0) crosses abc iff the three orientations
 * det[q - p, x - p, y - p] over the edges xy of abc have one sign (zero included: touching
 * counts). Coplanar triangles (Möller Sec. 2.1): projected on the axis plane where their area is
 * largest, they meet iff two edges cross or a corner of one lies in the other. "Within" is
 * closed: touching triangles intersect. A distance below 1e-7 of the triangles' size counts as
 * on the plane. A degenerate triangle (zero area) is tested by its edges against the other;
 * two degenerate ones never meet. Doubles throughout (the inputs are float); allocates nothing. */
#ifndef MESHSTEER_MODEL_TRI_TRI_H
#define MESHSTEER_MODEL_TRI_TRI_H

/* 1 when triangle (p0, p1, p2) and triangle (q0, q1, q2) (float xyz each) share a point. */
int mdl__tri_tri(const float *p0, const float *p1, const float *p2, const float *q0,
                 const float *q1, const float *q2);

#endif
