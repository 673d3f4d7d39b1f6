/* variations.h - the transition graph of Zheng 2013 ("One-to-Many: Example-Based Mesh Animation
 * Synthesis", SCA 2013) over a skin (model.h "variations"), shared by the files of variations/:
 *   so3.c          Phi (axis-angle, the matrix logarithm of Sec. 3.2) and its inverse
 *   transitions.c  Sec. 3.2: reference bone, local-frame bone positions (eq. 2), reduced
 *                  coordinates (eq. 3-4), transition cost D(i, j) (eq. 5-6), candidates below T_c
 *   blend.c        Sec. 3.3: the reference bone matched rigidly (eq. 7; or on the ground plane,
 *                  Sec. 5), the other bones blended over a window, back to the world frame
 *                  (eq. 10): the linear blend of the local bone coordinates (the comparison of
 *                  Fig. 6) or, by default, the gradient-domain blend of gblend.c
 *   keys.c         Sec. 3.3: the key vertices (max w_ib per bone, max w_ib w_jb per bone pair)
 *   weight_grad.c  Appendix A: the weight gradients at the key vertices (eq. 15-17)
 *   defgrad.c      Sec. 3.3: the key vertices' deformation gradients in b_r's frame (eq. 8) and
 *                  their rotation-strain coordinates d_i(t), for every input frame
 *   gblend.c       Sec. 3.3: the 1-D Poisson blend of d_i over the window (Fig. 7) and the bones
 *                  from the blended gradients (eq. 9)
 *   walk.c         Sec. 3.4: random walks on the motion graph, one output frame per step
 *   bone_graph.c   Sec. 4.1: the bone graph (eq. 11), T_e, cut nodes, the blocks between them
 *   components.c   Sec. 4: the components synthesised apart and the order they are merged in
 *   merge.c        Sec. 4.2: Algorithm 1, D_C (eq. 12), the cut node (eq. 13) and the merged
 *                  component's bones (eq. 14)
 *   target.c       Sec. 3.4: targeted frames (backward reachability, the walk restricted)
 *   overlap.c      Sec. 3.4: how much two walks overlap
 *   avoid.c        Sec. 3.4: collision avoidance against a static obstacle (its AABB tree,
 *                  core/aabb_tree.c; the triangle test, core/tri_tri.c)
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

struct mdl__bone_graph;

/* A component of Sec. 4 (components.c): its own transition graph over its bones. */
typedef struct mdl__vcomp {
    struct mdl_variations *g; /* over nb bones, in the order of bones[] */
    int nb;
    int *bones;      /* nb global bone ids, ascending */
    int parent;      /* the component it is merged into (-1: the anchor, component 0) */
    int cut;         /* global id of the cut node shared with the parent (-1 for the anchor) */
    int cut_local;   /* its index in bones[] */
} mdl__vcomp;

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
    double *wsum;    /* nb: sum_i w_ib */
    /* Sec. 3.3's gradient-domain blend (keys.c, weight_grad.c, defgrad.c, gblend.c); read-only
     * after the build, so walks on several threads share it */
    int nkey;
    int *key_v;      /* nkey: the mesh vertex of key vertex i */
    double *key_x;   /* nkey x 3: its rest position v_bar_i */
    int *kb_off;     /* nkey + 1: key i's bones are [kb_off[i], kb_off[i + 1]) */
    int *kb_bone;    /* bone (this graph's numbering) */
    double *kb_w;    /* w_ib (normalised over this graph's bones) */
    double *kb_g;    /* x 3: dw_ib / dv_bar_i (Appendix A; sum over b exactly 0) */
    double *kD;      /* nframes x nkey x 9: D_i(t) of eq. 8, row-major */
    double *kd;      /* nframes x nkey x 9: d_i(t) = [Phi(U); S00 S01 S02 S11 S12 S22], D = U S */
    int nu;          /* unknowns of eq. 9 per row of F: 4 (nb - 1) */
    int *ucol;       /* nb: bone b's first unknown (F_b row, then t_b entry); -1 for b_r */
    double *gN;      /* nu x nu: upper Cholesky factor of A^T A + Lambda (column-major) */
    double *glam;    /* nu: Lambda, the pull toward the linear blend */
    double *hramp;   /* o.blend + 1: the Poisson window's shape, h_0 = 1 .. h_blend = 0 */
    /* Sec. 4 (components.c): ncomp > 1 when walks are synthesised per component */
    int ncomp;
    mdl__vcomp *comp;              /* ncomp, parents before children */
    struct mdl__bone_graph *bg;    /* the bone graph (NULL with components 1) */
};

/* transitions.c: the reference bone, eq. 2-6 and the transitions of v (nb, nframes, T, wsum,
 * centre and o set). */
int mdl__variations_analyse(struct mdl_variations *v, char *err);
/* The skin key vertices are chosen on: the whole model's, also for a component's graph. */
typedef struct mdl__vskin {
    int nv, K, nf;
    const float *rest;     /* nv x 3 */
    const int *bone;       /* nv x K */
    const double *w;       /* nv x K */
    const uint32_t *F;     /* nf x 3 */
} mdl__vskin;

/* keys.c: vertex v's weights over g's bones, map[global bone] -> g's bone or -1 (NULL: the same),
 * normalised to sum 1; their count (0 when none of g's bones moves v), at most s->K. */
int mdl__vskin_vertex(const mdl__vskin *s, const int *map, int v, int *lb, double *w);
/* keys.c: g->key_v, g->nkey (Sec. 3.3's selection); nb of g's bones. */
int mdl__keys_select(struct mdl_variations *g, const mdl__vskin *s, const int *map, char *err);
/* weight_grad.c: g->key_x and the kb_* arrays (Appendix A). */
int mdl__weight_grads(struct mdl_variations *g, const mdl__vskin *s, const int *map, char *err);
/* defgrad.c: eq. 8 at key vertex i from local bone frames LR (nb x 9), Lt (nb x 3): D (3x3
 * row-major); and g->kD, g->kd for every input frame. */
void mdl__defgrad(const struct mdl_variations *g, int i, const double *LR, const double *Lt,
                  double D[9]);
int mdl__defgrads(struct mdl_variations *g, char *err);
/* gblend.c: all of the above and eq. 9's factor and the window's shape, after
 * mdl__variations_analyse (g->ref, LR, Lt set). */
int mdl__gblend_build(struct mdl_variations *g, const mdl__vskin *s, const int *map, char *err);
void mdl__gblend_fini(struct mdl_variations *g);
/* eq. 9: the least-squares bone offsets X (nu x 3, column r the unknowns of row r of every F_b
 * and t_b) for R (nkey x 9, the gradients' wanted change, row-major) with the pull Lambda toward
 * X0 (nu x 3, may be NULL: 0); X is overwritten. No allocation. */
int mdl__gblend_solve(const struct mdl_variations *g, const double *R, const double *X0,
                      double *X);

/* transitions.c: alive and nalive of v's graph, frames with blocked[n] (nframes; NULL: none)
 * left out (avoid.c keeps walks off colliding frames). */
void mdl__variations_alive(struct mdl_variations *v, const uint8_t *blocked);
/* components.c: v->comp from the bone graph of the skin (bone, w: nv x K). */
int mdl__components_build(struct mdl_variations *v, const int *bone, const double *w,
                          const mdl__vskin *s, char *err);
void mdl__components_fini(struct mdl_variations *v);

/* merge.c (Sec. 4.2): polar decomposition F = U S (F row-major 3x3); D_C of eq. 12 between the
 * cut node's series Fa, Fb (frames, a stride of `stride` doubles between frames, 3x3 row-major at
 * the start of each), and its threshold 0.05 max_t {|S_a(t)|_F^2, |S_b(t)|_F^2}. */
void mdl__polar(const double F[9], double U[9], double S[9]);
double mdl__merge_cost(const double *Fa, size_t sa, const double *Fb, size_t sb, int frames,
                       double *threshold);
/* eq. 13-14 for one frame: T (all bones x 12) holds the anchor's bones, among them c->cut; Tc
 * (c->nb x 12, the order of c->bones) the component's; writes the cut node and c's other bones. */
void mdl__merge_frame(const mdl__vcomp *c, const double *Tc, double *T);

/* bone_graph.c: the bone graph of a skin and its blocks (Sec. 4.1). */
typedef struct mdl__bone_graph {
    int nb;
    double *d;          /* nb x nb: d_ij of eq. 11 (0: no edge) */
    uint8_t *kept;      /* nb x nb: 1 where the edge survives T_e (or connectivity needs it) */
    double dmax, te;    /* max d_ij, T_e */
    int nedges_all, nedges, nrescued; /* edges before T_e, kept, kept below T_e for connectivity */
    uint8_t *cut;       /* nb: 1 for a cut node */
    int nblocks;
    int *block_off;     /* nblocks + 1 */
    int *block_bone;    /* the bones of block k: [block_off[k], block_off[k + 1]), ascending */
} mdl__bone_graph;

/* bone (nv x K) and w (nv x K) as mdl_skin_get; te_factor in [0, 1]. Fills g (fini frees). */
int mdl__bone_graph_build(mdl__bone_graph *g, int nb, int nv, int K, const int *bone,
                          const double *w, double te_factor, char *err);
void mdl__bone_graph_fini(mdl__bone_graph *g);

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
    double rom[3], rdt[3]; /* o.ground: the reference bone's offset rotation (Phi, about its
                              centre) and translation at the last splice, let go over the window */
    /* the gradient blend (v->nkey > 0, not o.blend_linear) */
    double *kom;     /* nkey x 3: Phi(U~_i(i) U_i(j)^T) at the last splice */
    double *kdS;     /* nkey x 6: S~_i(i) - S_i(j) (upper triangles) */
    double *R;       /* nkey x 9 scratch: the wanted change of D_i */
    double *X, *X0;  /* nu x 3 scratch: eq. 9's offsets, the linear blend's */
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
/* gblend.c: at a splice (i, j), the key vertices' offsets from what frame i showed (the old
 * offsets at window weight h) to frame j; and the local bone frames L (nb x 12, the linear
 * blend's on entry) of input frame c replaced by eq. 9's from the gradients blended at weight h. */
void mdl__gblend_splice(mdl__vblend *b, const struct mdl_variations *v, int i, int j, double h);
void mdl__gblend_local(const mdl__vblend *b, const struct mdl_variations *v, int c, double h,
                       double *L);

/* walk.c: an endless random walk, one output frame per step (no allocation after init). */
typedef struct mdl__vwalk {
    const struct mdl_variations *v;
    mdl__vblend b;
    uint64_t rng;
    int cur;         /* the input frame of the next output frame */
    int seg;         /* output frames since the last transition */
    /* several components (v->ncomp > 1): one walker each, merged per frame (merge.c) */
    int ncomp;
    struct mdl__vwalk *sub;
    double *Tc;      /* sum of the components' nb x 12: their frames before the merge */
    int *src;        /* ncomp: each component's input frame of the last step */
} mdl__vwalk;

int mdl__vwalk_init(mdl__vwalk *w, const struct mdl_variations *v, uint64_t seed, char *err);
void mdl__vwalk_fini(mdl__vwalk *w);
/* Back to the start of the walk of `seed` (no allocation). */
void mdl__vwalk_reset(mdl__vwalk *w, uint64_t seed);
/* The seed of component c's walk in the walk of `seed`, and the common start frame. */
uint64_t mdl__vwalk_comp_seed(uint64_t seed, int c);
int mdl__vwalk_start(const struct mdl_variations *v, uint64_t seed);
/* A single-component walker from input frame `start` (alive) with its own seed. */
void mdl__vwalk_reset_at(mdl__vwalk *w, uint64_t seed, int start);
/* Writes the next output frame's bone transforms (nb x 12) and returns its input frame. */
int mdl__vwalk_step(mdl__vwalk *w, double *T);
/* The same for a single-component walker whose next input frame must have ok[n] != 0 (nframes;
 * NULL: any). The caller guarantees that some successor is allowed (target.c). */
int mdl__vwalk_step_to(mdl__vwalk *w, double *T, const uint8_t *ok);
/* The batch walk of frames output frames (walk.c), per component, next input frames restricted
 * by masks[c] (frames x the component's nframes, 1 = allowed at that output frame; masks or a
 * mask NULL: free) from input frame start (-1: the seed's); src frames x components. */
int mdl__variations_walk_masked(const struct mdl_variations *v, uint64_t seed, int frames,
                                uint8_t *const *masks, int start, double *T, int *src, char *err);
/* Skins one frame: V (nv x 3) from bone transforms T (nb x 12). */
void mdl__variations_skin(const struct mdl_variations *v, const double *T, float *V);

#endif
