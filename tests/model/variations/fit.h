/* fit.h - what the variations tests share: a skin fitted to a mesh sequence of ../shared/data
 * (exits 77 when absent), and the pose of one rigid transform relative to another. */
#ifndef MESHSTEER_TEST_VARIATIONS_FIT_H
#define MESHSTEER_TEST_VARIATIONS_FIT_H

#include "model.h"
#include "test.h"
#include "variations/variations.h"

/* the skin of every frame of data set file rel (rest: its rest OBJ, or NULL), K = 4, serial */
static inline mdl_model *vt_fit_skin(const char *rel, const char *rest, int bones)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s = NULL;
    ASSERT_OK(mdl_meshseq_read(test_data(rel), rest ? test_data(rest) : NULL, &s, err), err);
    int *idx = calloc(s->frames, sizeof *idx);
    for (int i = 0; i < s->frames; i++)
        idx[i] = i;
    mdl_skin_opts so;
    mdl_skin_opts_default(&so);
    so.bones = bones;
    so.max_influences = 4;
    mdl_model *m = NULL;
    ASSERT_OK(mdl_skin_fit(s, idx, s->frames, &so, &m, err), err);
    free(idx);
    mdl_meshseq_destroy(s);
    return m;
}

/* inverse(A) B for rigid A, B (12 doubles each: R row-major, t) */
static inline void vt_relative(const double A[12], const double B[12], double out[12])
{
    double At[9] = {A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8]};
    mdl__mat3_mul(At, B, out);
    double d[3] = {B[9] - A[9], B[10] - A[10], B[11] - A[11]};
    for (int a = 0; a < 3; a++)
        out[9 + a] = At[3 * a] * d[0] + At[3 * a + 1] * d[1] + At[3 * a + 2] * d[2];
}

#endif
