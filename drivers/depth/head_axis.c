/* head_axis.c - the top of a head (or of a neck cut flat) on its axis, from its silhouette.
 *
 * The ground truth of a head marker is the top of the head on its axis (rigs/samba-depth.json; on
 * pjump's headless scan, the centre of the flat cut that closes the neck). The extremum that
 * found the head is wherever the head's visible surface ends farthest from the centroid: the
 * forehead's top seen from a camera below the head, the back rim of the cut when the performer
 * leans towards the camera. A fixed push along the viewing ray (drv_depth_opts.head_offset, half
 * a head's depth) is right for the first and wrong for the second: pjump leaning 34 cm towards
 * the camera was 13-18 cm off (docs/PERFORMANCE.md).
 *
 * What holds in both: seen across its axis, a head or a neck is round, so its silhouette in each
 * image row that crosses it, left and right, lies at the depth of its axis, whichever way it
 * faces (a ball's or a cylinder's contour generator is the circle through its centre,
 * perpendicular to the ray), and midway between them lies the axis. So:
 *   1. a = the head's direction, from the centroid to its tip (the trunk and the neck: the
 *      longest baseline there is). Not from the extremum's anchor (geodesic.c, 0.3 m back along
 *      its path): a neck foreshortened towards the camera is shorter than that, and its anchor
 *      lies on a shoulder - pjump landing bent forward, frames 121-126, anchors 7-15 cm to one
 *      side or the other, a tilted 23-32 degrees from frame to frame, the marker's x with it.
 *      The head's cells are the person's cells within HEAD_REACH of the extremum, in space and
 *      in geodesic distance from the centroid (not a hand held beside the head: its path is
 *      longer);
 *   2. top = the highest of them along a;
 *   3. in every grid row, the leftmost and rightmost head cell within HEAD_SPAN below the top:
 *      their mean, pushed back along its viewing ray (below), is a point on the axis, at its
 *      depth;
 *   4. the marker: the mean of those points moved along a up to the top.
 * The outermost head cell of a row is not the silhouette itself: a cell's reading is the nearest
 * of its four probes, a quarter and three quarters of the cell across (segment.c), and the
 * silhouette lies beyond the outermost probe that hits the head by up to half a cell; on a
 * convex head the inner probe of the rim cell is the nearer one whenever both hit. The rim's
 * reading lies on average d = half a cell inside the silhouette, on a section of radius r =
 * w + d about the axis (w: half the row's width between its rims), where the surface is
 * sqrt(r^2 - w^2) = sqrt(2 w d + d^2) nearer than the axis - 3.5 cm for a 14 cm wide head at
 * 2.5 m. Without it every head was placed 4-7 cm too near the camera (samba, the SMPL takes);
 * with it and the direction from the centroid, the median head error over samba's grid is
 * 2.4-4.3 cm, not 5.5-8.2, and over pjump's 3.6-6.9, not 4.2-7.1 (docs/PERFORMANCE.md, "The head
 * on its axis: its direction from the centroid"). A row wider than a head is long (HEAD_REACH)
 * runs through the shoulders, not across a head: no correction.
 * A row whose end meets a nearer surface (an arm raised in front of the head: the SMPL man's
 * lambada turned -20 degrees, the visible head a 7 cm sliver) does not end at the head's
 * silhouette; the head is then placed as before, half a head behind its visible top
 * (markers.c, head_offset), and so is a head with no row two cells wide.
 * Rows run across the axis when the head is upright in the image (standing, leaning, turned);
 * a person lying down is outside what this tracker is for. Not from a paper: the geometry of
 * a surface of revolution seen in silhouette. Measured on samba, pjump and the SMPL takes
 * (docs/PERFORMANCE.md, "The head on its axis"). */
#include "depth_internal.h"

#include <float.h>
#include <math.h>

/* metres: the head's cells lie this close to its extremum, in space and in geodesic distance
 * from the centroid: a head's length (depth_internal.h) */
#define HEAD_REACH DRV__HEAD_REACH
/* metres below the top along the head's direction whose silhouette is used: down to the head's
 * widest part, about half its height (0.1 m), and a grid cell more (0.017 m at 2.5 m). Measured at
 * 0.08-0.16 m over both grids: pjump's heads, mean of the 2.0-3.5 m cells at -20..+20 degrees,
 * peak here, 0.12-0.16 within 0.003 (docs/PERFORMANCE.md) */
#define HEAD_SPAN 0.12f

static int head_cell(const drv__grid *g, const drv__geodesic *ge, const drv__extremum *x, int c)
{
    if (!g->person[c] || !(fabsf(ge->dist0[c] - x->geodesic0) <= HEAD_REACH))
        return 0;
    const float *pc = g->P + 3 * c, *pe = g->P + 3 * x->cell;
    const float d[3] = {pc[0] - pe[0], pc[1] - pe[1], pc[2] - pe[2]};
    return d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= HEAD_REACH * HEAD_REACH;
}

static float along(const float *p, const float a[3])
{
    return p[0] * a[0] + p[1] * a[1] + p[2] * a[2];
}

/* Cell c, the outermost of a row's head cells on the side of step (-1 or +1), ends at an
 * occluding edge: the cell beyond it is nearer by more than jump (an arm raised in front of the
 * head), so the row's end is not the head's silhouette. */
static int occluded(const drv__grid *g, int c, int step, float jump)
{
    const int xx = c % g->gw + step;
    if (xx < 0 || xx >= g->gw)
        return 0;
    const float zn = g->z[c + step];
    return zn > 0 && zn < g->z[c] - jump;
}

int drv__head_on_axis(const drv__grid *g, const drv__geodesic *ge, const drv_depth_opts *o,
                      const drv__extremum *x, float p[3])
{
    const float *c0 = g->centroid;
    float a[3] = {x->tip[0] - c0[0], x->tip[1] - c0[1], x->tip[2] - c0[2]};
    const float n = sqrtf(along(a, a));
    if (!(n > 0.05f)) /* no direction to speak of */
        return 0;
    for (int i = 0; i < 3; i++)
        a[i] /= n;
    const float *pe = g->P + 3 * x->cell;
    const float cell = (float)g->step * -pe[2] / o->k.fx; /* metres across a cell at the head */
    const float jump = drv__depth_max_jump(o, -pe[2]);
    if (!(cell > 0))
        return 0;
    const int w = (int)ceilf(HEAD_REACH / cell), gx = x->cell % g->gw, gy = x->cell / g->gw;
    const int x0 = gx - w < 0 ? 0 : gx - w, x1 = gx + w >= g->gw ? g->gw - 1 : gx + w;
    const int y0 = gy - w < 0 ? 0 : gy - w, y1 = gy + w >= g->gh ? g->gh - 1 : gy + w;
    float top = -FLT_MAX;
    for (int yy = y0; yy <= y1; yy++)
        for (int xx = x0; xx <= x1; xx++) {
            const int c = yy * g->gw + xx;
            if (head_cell(g, ge, x, c))
                top = fmaxf(top, along(g->P + 3 * c, a));
        }
    double m[3] = {0, 0, 0};
    int rows = 0;
    const float rim_in = 0.5f * cell; /* metres: the rim's reading inside the silhouette */
    for (int yy = y0; yy <= y1; yy++) {
        int lo = -1, hi = -1;
        for (int xx = x0; xx <= x1; xx++) {
            const int c = yy * g->gw + xx;
            if (!head_cell(g, ge, x, c) || along(g->P + 3 * c, a) < top - HEAD_SPAN)
                continue;
            if (lo < 0)
                lo = c;
            hi = c;
        }
        if (lo < 0 || hi == lo) /* no width in this row */
            continue;
        if (occluded(g, lo, -1, jump) || occluded(g, hi, +1, jump))
            return 0; /* part of the head is hidden: its silhouette is not its own */
        /* the rims' mid-point, pushed back to the axis's depth along its ray (see the header) */
        const float *pl = g->P + 3 * lo, *ph = g->P + 3 * hi;
        const float q[3] = {0.5f * (pl[0] + ph[0]), 0.5f * (pl[1] + ph[1]), 0.5f * (pl[2] + ph[2])};
        const float dx = ph[0] - pl[0], dz = ph[2] - pl[2], hw = 0.5f * sqrtf(dx * dx + dz * dz);
        const float back = 2.f * hw > HEAD_REACH ? 0.f : sqrtf(2.f * hw * rim_in + rim_in * rim_in);
        const float s = 1.f + back / sqrtf(along(q, q));
        for (int i = 0; i < 3; i++)
            m[i] += q[i] * s;
        rows++;
    }
    if (!rows)
        return 0;
    for (int i = 0; i < 3; i++)
        p[i] = (float)(m[i] / rows);
    const float up = top - along(p, a);
    for (int i = 0; i < 3; i++)
        p[i] += up * a[i];
    return 1;
}
