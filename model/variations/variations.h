/* variations.h - the transition graph of Zheng 2013 ("One-to-Many: Example-Based Mesh Animation
 * Synthesis", SCA 2013) over a skin (model.h "variations"), shared by the files of variations/:
 *   so3.c          Phi (axis-angle, the matrix logarithm of Sec. 3.2) and its inverse
 *   transitions.c  Sec. 3.2: reference bone, local-frame bone positions (eq. 2), reduced
 *                  coordinates (eq. 3-4), transition cost D(i, j) (eq. 5-6), candidates below T_c
 *   blend.c        Sec. 3.3: the reference bone matched rigidly (eq. 7) and the linear blend of
 *                  the local bone coordinates over a window (the comparison of Fig. 6), back to the
 *                  world frame (eq. 10)
 *   walk.c         Sec. 3.4: random walks on the motion graph, one output frame per step
 *
 * paper -> code:
 *   N frames, |B| bones   nframes, nb (the skin's fitted frames, in order, and its bones)
 *   b_r                   ref
 *   {R_b(t), t_b(t)}      T + 12 (t nb + b): R row-major 3x3, then t (the skin's own layout)
 *   {R_b->r, t_b->r}(t)   LR + 9 (t nb + b), Lt + 3 (t nb + b)   (eq. 2)
 *   p_b^t = [t; Phi(R)]   column t of A_r, rows 6 b' .. 6 b' + 5 over the non-reference bones b'
 *   q_t (eq. 4)           Q + rank t
 *   r_t (eq. 6)           rvec + 6 t
 *   (i, j) a transition   after output frame i the walk continues with frame j + 1 (frames i and
 *                         j are the one spliced frame: S_a->i then S_j->b)
 * Doubles throughout (analysis, and bone transforms of the output); vertices are float. */
#ifndef MESHSTEER_MODEL_VARIATIONS_H
#define MESHSTEER_MODEL_VARIATIONS_H

#include "model.h"

#include <stdint.h>

struct mdl_variations {
    mdl_variations_opts o;
    int nb, nframes, ref, rank;
    double alpha, beta, tc, max_adjacent;
    double *T;       /* nframes x nb x 12, world */
    double *LR;      /* nframes x nb x 9 */
    double *Lt;      /* nframes x nb x 3 */
    double *Q;       /* nframes x rank */
    double *rvec;    /* nframes x 6 */
    int ntrans;
    int *off;        /* nframes + 1: transitions from frame i are [off[i], off[i + 1]) */
    int *to;         /* ntrans, ascending within a source frame */
    double *cost;    /* ntrans: D(i, j) */
    uint8_t *alive;  /* nframes: 1 when a walk through this frame can go on for ever */
    int nalive;
    /* the skin, for vertices */
    int nv, K;
    float *rest;     /* nv x 3 */
    int *bone;       /* nv x K */
    float *w;        /* nv x K */
    double *centre;  /* nb x 3: each bone's weighted centroid of the rest pose (blend.c) */
};

/* so3.c: Phi(R) (row-major R, a rotation) as an axis-angle vector of angle in [0, pi], and back. */
void mdl__so3_log(const double R[9], double w[3]);
void mdl__so3_exp(const double w[3], double R[9]);
/* C = A B and C = A B^T, 3x3 row-major (C may not alias). */
void mdl__mat3_mul(const double A[9], const double B[9], double C[9]);
void mdl__mat3_mul_t(const double A[9], const double B[9], double C[9]);

/* transitions.c: D(i, j) of eq. 5, for 1 <= i, j < nframes. */
double mdl__variations_cost(const struct mdl_variations *v, int i, int j);

/* blend.c: the state of a walk's splicing. Sized at init, nothing allocated per step. */
typedef struct mdl__vblend {
    double G[12];    /* the rigid transform applied to the current segment (eq. 7): R, t */
    double *om;      /* nb x 3: offset rotations Phi at the last transition */
    double *dt;      /* nb x 3: offset translations of the bone's centre */
    int since;       /* output frames since the last transition (>= blend: no offset) */
} mdl__vblend;

int mdl__vblend_init(mdl__vblend *b, const struct mdl_variations *v);
void mdl__vblend_fini(mdl__vblend *b);
void mdl__vblend_reset(mdl__vblend *b, const struct mdl_variations *v);
/* The world bone transforms (nb x 12) of input frame c in the current segment. */
void mdl__vblend_pose(const mdl__vblend *b, const struct mdl_variations *v, int c, double *T);
/* Splices: the output continues after input frame i with frame j + 1. */
void mdl__vblend_splice(mdl__vblend *b, const struct mdl_variations *v, int i, int j);
/* Advances the window by one output frame. */
void mdl__vblend_advance(mdl__vblend *b);

/* walk.c: an endless random walk, one output frame per step (no allocation after init). */
typedef struct mdl__vwalk {
    const struct mdl_variations *v;
    mdl__vblend b;
    uint64_t rng;
    int cur;         /* the input frame of the next output frame */
    int seg;         /* output frames since the last transition */
} mdl__vwalk;

int mdl__vwalk_init(mdl__vwalk *w, const struct mdl_variations *v, uint64_t seed, char *err);
void mdl__vwalk_fini(mdl__vwalk *w);
/* Back to the start of the walk of `seed` (no allocation). */
void mdl__vwalk_reset(mdl__vwalk *w, uint64_t seed);
/* Writes the next output frame's bone transforms (nb x 12) and returns its input frame. */
int mdl__vwalk_step(mdl__vwalk *w, double *T);
/* Skins one frame: V (nv x 3) from bone transforms T (nb x 12). */
void mdl__variations_skin(const struct mdl_variations *v, const double *T, float *V);

#endif
