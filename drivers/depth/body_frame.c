/* body_frame.c - which way the person faces, from the depth surface of the torso.
 *
 * The body frame of the labelling (label.c) is up (the floor normal) and the person's left. A
 * person turned by a yaw has their left along the camera's +X turned by that yaw, and a hand
 * reaching forward then moves along the camera's X as much as a hand moving sideways: measured
 * along the camera's X, lateral offsets mix side and depth. As a Kinect skeleton tracker does, we
 * take the body frame from the body: the torso's surface (the chest and belly seen by the camera)
 * is a shallow arc whose horizontal cross-section runs along the shoulder line, across the
 * facing direction.
 *
 * Per frame: the person's cells between TORSO_LOW and TORSO_HIGH above the centroid and within
 * TORSO_HALF of it along the current left axis are the torso sample; in the horizontal plane
 * (basis a = the camera's +X made orthogonal to up, b = a x up, towards the camera) their 2x2
 * covariance's major axis (closed form, theta = atan2(2 s_ab, s_aa - s_bb) / 2) is the shoulder
 * line. A second fit without the cells more than TORSO_OFF_LINE off the first line drops a
 * forearm held in front of the chest. The fit counts when it has at least TORSO_MIN_CELLS cells
 * and its major axis is at least TORSO_ANISO times the minor one (a torso seen from the side is
 * deep, not wide: no facing then). The sign: the person faces the camera (|yaw| < 90 degrees, the
 * assumption of a Kinect: one cannot tell front from back on depth alone), so the left axis has a
 * positive +X component. The angle is smoothed over frames (exponentially, FACING_ALPHA of the
 * new one per frame) and starts at 0 (facing the camera) after a reset.
 * left = cos(theta) a + sin(theta) b. */
#include "depth_internal.h"

#include <math.h>
#include <string.h>

#define TORSO_LOW 0.0f       /* metres above the centroid (the belly) ... */
#define TORSO_HIGH 0.35f     /* ... to the chest */
#define TORSO_HALF 0.22f     /* half a torso's width */
#define TORSO_OFF_LINE 0.07f /* metres off the first line: in front of the chest */
#define TORSO_MIN_CELLS 24
#define TORSO_ANISO 2.0f
#define FACING_ALPHA 0.3f
#define FACING_MAX 1.4f /* radians: beyond this the fit is taken for a person seen from the side */

void drv__body_frame_reset(drv__body_frame *bf)
{
    bf->theta = 0;
    bf->init = 0;
}

static float dot3(const float *a, const float *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Principal axis of the torso sample: fills the angle, returns the cells used (0: none). With
 * line != NULL, leaves out cells farther than TORSO_OFF_LINE from that line through the mean. */
static int fit(const drv__grid *g, const float up[3], const float a[3], const float b[3],
               float cos_l, float sin_l, const float *line, float *theta, float *aniso,
               float mean[2])
{
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    int n = 0;
    const float lc = line ? cosf(line[0]) : 0, ls = line ? sinf(line[0]) : 0;
    for (int k = 0; k < g->ncells; k++) {
        const float *p = g->P + 3 * g->cells[k];
        float r[3] = {p[0] - g->centroid[0], p[1] - g->centroid[1], p[2] - g->centroid[2]};
        float h = dot3(r, up);
        if (h < TORSO_LOW || h > TORSO_HIGH)
            continue;
        float x = dot3(r, a), z = dot3(r, b);
        if (fabsf(cos_l * x + sin_l * z) > TORSO_HALF)
            continue;
        if (line && fabsf(-ls * (x - line[1]) + lc * (z - line[2])) > TORSO_OFF_LINE)
            continue;
        sa += x;
        sb += z;
        saa += (double)x * x;
        sbb += (double)z * z;
        sab += (double)x * z;
        n++;
    }
    if (n < TORSO_MIN_CELLS)
        return 0;
    double ma = sa / n, mb = sb / n;
    double caa = saa / n - ma * ma, cbb = sbb / n - mb * mb, cab = sab / n - ma * mb;
    double tr = caa + cbb, det = caa * cbb - cab * cab, disc = sqrt(fmax(0, tr * tr / 4 - det));
    double l1 = tr / 2 + disc, l2 = tr / 2 - disc;
    *theta = (float)(0.5 * atan2(2 * cab, caa - cbb));
    *aniso = l2 > 1e-12 ? (float)sqrt(l1 / l2) : 1e6f;
    mean[0] = (float)ma;
    mean[1] = (float)mb;
    return n;
}

int drv__body_frame_update(drv__body_frame *bf, const drv__grid *g, const float up[3],
                           float left[3])
{
    /* a: the camera's +X orthogonal to up; b = a x up (towards the camera) */
    float a[3] = {1, 0, 0};
    float d = dot3(a, up);
    for (int i = 0; i < 3; i++)
        a[i] -= d * up[i];
    float an = sqrtf(dot3(a, a));
    for (int i = 0; i < 3; i++)
        a[i] /= an;
    float b[3] = {a[1] * up[2] - a[2] * up[1], a[2] * up[0] - a[0] * up[2],
                  a[0] * up[1] - a[1] * up[0]};
    float theta = 0, aniso = 0, mean[2];
    int ok = fit(g, up, a, b, cosf(bf->theta), sinf(bf->theta), NULL, &theta, &aniso, mean) > 0;
    if (ok) {
        const float line[3] = {theta, mean[0], mean[1]};
        ok = fit(g, up, a, b, cosf(bf->theta), sinf(bf->theta), line, &theta, &aniso, mean) > 0;
    }
    /* the shoulder line's direction is theta or theta + pi: the one with +X, i.e. |theta| < pi/2,
       which atan2 / 2 gives */
    ok = ok && aniso >= TORSO_ANISO && fabsf(theta) <= FACING_MAX;
    if (ok) {
        bf->theta = bf->init ? bf->theta + FACING_ALPHA * (theta - bf->theta) : theta;
        bf->init = 1;
    }
    const float c = cosf(bf->theta), s = sinf(bf->theta);
    for (int i = 0; i < 3; i++)
        left[i] = c * a[i] + s * b[i];
    return ok;
}
