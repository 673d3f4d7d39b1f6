/* tube.h - a tiny articulated test subject made by our own code: a tube of two segments that bends
 * at its middle joint, with a bulge on the inside of the bend, so that part-based models have
 * rigid parts, a joint and shape change to learn. Frame f bends by angle(f) (radians), plus a
 * small twist of the whole tube about Y so that the body frame moves. */
#ifndef MESHSTEER_TEST_TUBE_H
#define MESHSTEER_TEST_TUBE_H

#include "model.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TUBE_RINGS 24
#define TUBE_AROUND 12

static inline double tube_angle(int f)
{
    return 1.2 * sin(0.23 * f) * sin(0.23 * f) + 0.1; /* 0.1 .. 1.3 rad, back and forth */
}

/* frames of the tube; the rig: root (ring 0), base2 (ring 5), tip (last ring); reference root ->
 * base2; one limb base2 -> tip. */
static inline void tube_create(int frames, mdl_meshseq **out_seq, mdl_rig **out_rig)
{
    int nv = TUBE_RINGS * TUBE_AROUND, nf = 2 * (TUBE_RINGS - 1) * TUBE_AROUND;
    mdl_meshseq *s = calloc(1, sizeof *s);
    s->nv = nv;
    s->nf = nf;
    s->frames = frames;
    s->fps = 30;
    s->V = calloc((size_t)frames * nv * 3, sizeof(float));
    s->F = calloc((size_t)nf * 3, sizeof(uint32_t));
    int k = 0;
    for (int r = 0; r + 1 < TUBE_RINGS; r++)
        for (int a = 0; a < TUBE_AROUND; a++) {
            uint32_t v00 = (uint32_t)(r * TUBE_AROUND + a), v01 = (uint32_t)(r * TUBE_AROUND + (a + 1) % TUBE_AROUND);
            uint32_t v10 = v00 + TUBE_AROUND, v11 = v01 + TUBE_AROUND;
            uint32_t t[6] = {v00, v10, v11, v00, v11, v01};
            memcpy(s->F + 3 * k, t, sizeof t);
            k += 2;
        }
    for (int f = 0; f < frames; f++) {
        double th = tube_angle(f), yaw = 0.3 * sin(0.11 * f);
        for (int r = 0; r < TUBE_RINGS; r++) {
            double x = 2.0 * r / (TUBE_RINGS - 1); /* 0 .. 2 m along the tube */
            for (int a = 0; a < TUBE_AROUND; a++) {
                double phi = 2 * M_PI * a / TUBE_AROUND;
                double rad = 0.1, cy = cos(phi), cz = sin(phi);
                /* bulge on the inside (+y side) near the joint, growing with the bend */
                double near = exp(-(x - 1) * (x - 1) / 0.05);
                if (cy > 0)
                    rad *= 1 + 0.4 * th * near * cy;
                double p[3] = {x, 1.0 + rad * cy, rad * cz};
                if (x > 1) { /* second segment: rotate about the joint (1, 1, 0) around Z */
                    double dx = p[0] - 1, dy = p[1] - 1;
                    p[0] = 1 + cos(th) * dx - sin(th) * dy;
                    p[1] = 1 + sin(th) * dx + cos(th) * dy;
                }
                float *o = s->V + ((size_t)f * nv + r * TUBE_AROUND + a) * 3;
                o[0] = (float)(cos(yaw) * p[0] + sin(yaw) * p[2]);
                o[1] = (float)p[1];
                o[2] = (float)(-sin(yaw) * p[0] + cos(yaw) * p[2]);
            }
        }
    }
    mdl_rig *g = calloc(1, sizeof *g);
    g->nmarkers = 3;
    g->markers = calloc(3, sizeof *g->markers);
    const char *names[3] = {"root", "base2", "tip"};
    int verts[3] = {0, 5 * TUBE_AROUND, (TUBE_RINGS - 1) * TUBE_AROUND};
    for (int i = 0; i < 3; i++) {
        snprintf(g->markers[i].name, MDL_NAME_LEN, "%s", names[i]);
        snprintf(g->markers[i].source, MDL_NAME_LEN, "%s", names[i]);
        g->markers[i].vertex = verts[i];
    }
    g->nref = 2;
    g->ref[0] = 0;
    g->ref[1] = 1;
    g->nlimbs = 1;
    g->limb_off = calloc(2, sizeof(int));
    g->limb_off[1] = 2;
    g->limb_idx = calloc(2, sizeof(int));
    g->limb_idx[0] = 1;
    g->limb_idx[1] = 2;
    *out_seq = s;
    *out_rig = g;
}

#endif
