/* htube.h - a straight open tube along +X (rings x around vertices, radius 0.1 m, length 2 m), the
 * test subject of the harmonic tests: a forearm stand-in. */
#ifndef MESHSTEER_TEST_HTUBE_H
#define MESHSTEER_TEST_HTUBE_H

#include "model.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

static inline mdl_mesh *htube_create(int rings, int around)
{
    mdl_mesh *m = calloc(1, sizeof *m);
    m->nv = rings * around;
    m->nf = 2 * (rings - 1) * around;
    m->V = calloc(3 * (size_t)m->nv, sizeof(float));
    m->F = calloc(3 * (size_t)m->nf, sizeof(uint32_t));
    for (int r = 0; r < rings; r++)
        for (int a = 0; a < around; a++) {
            double phi = 2 * M_PI * a / around;
            float *p = m->V + 3 * (r * around + a);
            p[0] = (float)(2.0 * r / (rings - 1));
            p[1] = (float)(1.0 + 0.1 * cos(phi));
            p[2] = (float)(0.1 * sin(phi));
        }
    int k = 0;
    for (int r = 0; r + 1 < rings; r++)
        for (int a = 0; a < around; a++) {
            uint32_t v00 = (uint32_t)(r * around + a), v01 = (uint32_t)(r * around + (a + 1) % around);
            uint32_t v10 = v00 + (uint32_t)around, v11 = v01 + (uint32_t)around;
            uint32_t t[6] = {v00, v10, v11, v00, v11, v01};
            for (int j = 0; j < 6; j++)
                m->F[3 * k + j] = t[j];
            k += 2;
        }
    return m;
}

#endif
