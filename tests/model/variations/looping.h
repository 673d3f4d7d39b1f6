/* looping.h - a synthetic looping example for the variations tests: a tube along x (0..3) bent by
 * a 3-bone chain whose joint angles repeat every `period` frames, while the whole tube drifts
 * (translation along x and a turn about y, both growing with time), so only a rigid-invariant
 * metric finds the loop. Frames t and t + period differ by a rigid motion alone. */
#ifndef MESHSTEER_TEST_LOOPING_H
#define MESHSTEER_TEST_LOOPING_H

#include "model.h"
#include "core/rigid.h"
#include "tube_mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static inline void lp_rot_about(double ang, double px, double R[9], double t[3])
{
    /* rotation about z through (px, 0, 0) */
    double c = cos(ang), s = sin(ang);
    double M[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
    memcpy(R, M, sizeof M);
    t[0] = px - c * px;
    t[1] = -s * px;
    t[2] = 0;
}

/* A = A * B (rigid transforms as R row-major + t) */
static inline void lp_compose(double RA[9], double tA[3], const double RB[9], const double tB[3])
{
    double R[9], t[3];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++)
            R[3 * r + c] = RA[3 * r] * RB[c] + RA[3 * r + 1] * RB[3 + c] + RA[3 * r + 2] * RB[6 + c];
        t[r] = RA[3 * r] * tB[0] + RA[3 * r + 1] * tB[1] + RA[3 * r + 2] * tB[2] + tA[r];
    }
    memcpy(RA, R, sizeof R);
    memcpy(tA, t, sizeof t);
}

static inline mdl_meshseq *lp_sequence(int frames, int period)
{
    const int rings = 31, around = 10;
    mdl_meshseq *s = test_tube_mesh(rings, around, frames);
    if (!s)
        return NULL;
    for (int t = 0; t < frames; t++) {
        double ph = 2 * M_PI * t / period;
        double R[3][9], tr[3][3];
        /* the drift: turn about y by 0.02 t, move along x by 0.05 t */
        double a = 0.02 * t, c = cos(a), sn = sin(a);
        double R0[9] = {c, 0, sn, 0, 1, 0, -sn, 0, c}, t0[3] = {0.05 * t, 0, 0};
        memcpy(R[0], R0, sizeof R0);
        memcpy(tr[0], t0, sizeof t0);
        double Rj[9], tj[3];
        memcpy(R[1], R[0], sizeof R0);
        memcpy(tr[1], tr[0], sizeof t0);
        lp_rot_about(0.6 * sin(ph), 1, Rj, tj);
        lp_compose(R[1], tr[1], Rj, tj);
        memcpy(R[2], R[1], sizeof R0);
        memcpy(tr[2], tr[1], sizeof t0);
        lp_rot_about(0.5 * sin(ph + 1), 2, Rj, tj);
        lp_compose(R[2], tr[2], Rj, tj);
        for (int r = 0; r < rings; r++)
            for (int k = 0; k < around; k++) {
                double th = 2 * M_PI * k / around, x = 3.0 * r / (rings - 1);
                double p[3] = {x, 0.15 * cos(th), 0.15 * sin(th)}, w[3] = {0, 0, 0};
                /* bone floor(x), blended over 0.4 at the joints */
                int b = x < 1 ? 0 : x < 2 ? 1 : 2;
                w[b] = 1;
                for (int j = 1; j < 3; j++)
                    if (fabs(x - j) < 0.2) {
                        double al = (x - j + 0.2) / 0.4;
                        w[0] = w[1] = w[2] = 0;
                        w[j - 1] = 1 - al;
                        w[j] = al;
                    }
                float *o = s->V + 3 * ((size_t)t * s->nv + (size_t)r * around + k);
                for (int cc = 0; cc < 3; cc++) {
                    double acc = 0;
                    for (int j = 0; j < 3; j++)
                        acc += w[j] * (R[j][3 * cc] * p[0] + R[j][3 * cc + 1] * p[1] +
                                       R[j][3 * cc + 2] * p[2] + tr[j][cc]);
                    o[cc] = (float)acc;
                }
            }
    }
    return s;
}

/* the largest vertex displacement between consecutive frames of V (frames x nv x 3) */
static inline double lp_max_jump(const float *V, int nv, int frames)
{
    double mx = 0;
    for (int f = 1; f < frames; f++)
        for (int i = 0; i < nv; i++) {
            const float *a = V + 3 * ((size_t)(f - 1) * nv + i), *b = V + 3 * ((size_t)f * nv + i);
            double d = 0;
            for (int c = 0; c < 3; c++)
                d += ((double)a[c] - b[c]) * ((double)a[c] - b[c]);
            if (d > mx)
                mx = d;
        }
    return sqrt(mx);
}

/* the skin's own fitted frames, skinned (nframes x nv x 3, malloc'd) */
static inline float *lp_skin_frames(const mdl_model *m, int *nframes)
{
    int nb, K, N;
    const int *bone;
    const double *w, *T;
    if (mdl_skin_get(m, &nb, &K, &N, &bone, &w, &T))
        return NULL;
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    float *V = calloc((size_t)N * info.nv * 3, sizeof *V);
    for (int f = 0; V && f < N; f++)
        mdl_skin_lbs(info.nv, K, bone, w, info.rest, T + 12 * (size_t)f * nb,
                     V + 3 * (size_t)f * info.nv);
    *nframes = N;
    return V;
}

/* the tube of lp_sequence(frames, period) (*seq, caller frees) and a skin of `bones` bones fitted
 * to all of its frames (NULL on failure, the reason in err) */
static inline mdl_model *lp_fit(int frames, int period, int bones, mdl_meshseq **seq, char *err)
{
    *seq = lp_sequence(frames, period);
    int *idx = calloc(frames, sizeof *idx);
    for (int i = 0; i < frames; i++)
        idx[i] = i;
    mdl_skin_opts so;
    mdl_skin_opts_default(&so);
    so.bones = bones;
    mdl_model *m = NULL;
    int rc = mdl_skin_fit(*seq, idx, frames, &so, &m, err);
    free(idx);
    return rc ? NULL : m;
}

#endif
