/* tube_mesh.h - tests: a tube mesh sequence to fill in: `rings` rings of `around` vertices (ring r's
 * vertex a is r * around + a), each quad of neighbouring rings two triangles, `frames` frames
 * of zeroed vertices at 30 fps. The caller places the vertices; NULL when out of memory. */
#ifndef MESHSTEER_TESTS_TUBE_MESH_H
#define MESHSTEER_TESTS_TUBE_MESH_H

#include "model.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static inline mdl_meshseq *test_tube_mesh(int rings, int around, int frames)
{
    mdl_meshseq *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->nv = rings * around;
    s->nf = 2 * (rings - 1) * around;
    s->frames = frames;
    s->fps = 30;
    s->V = calloc((size_t)frames * s->nv * 3, sizeof *s->V);
    s->F = calloc(3 * (size_t)s->nf, sizeof *s->F);
    if (!s->V || !s->F) {
        free(s->V);
        free(s->F);
        free(s);
        return NULL;
    }
    int f = 0;
    for (int r = 0; r + 1 < rings; r++)
        for (int a = 0; a < around; a++) {
            uint32_t v0 = r * around + a, v1 = r * around + (a + 1) % around, v2 = v0 + around,
                     v3 = v1 + around;
            uint32_t t[6] = {v0, v1, v2, v1, v3, v2};
            memcpy(s->F + 3 * (size_t)f, t, sizeof t);
            f += 2;
        }
    return s;
}

#endif
