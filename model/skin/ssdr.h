/* ssdr.h - Smooth Skinning Decomposition with Rigid bones [Le & Deng 2012, "Smooth skinning
 * decomposition with rigid bones", ACM TOG 31(6)], the solver behind the skin kind (skin/).
 * Not public: model.h has mdl_skin_fit; this header is shared by the ssdr_*.c files.
 *
 * The model (Le & Deng, the linear blend skinning model and its constraints; Zheng 2013 Sec. 3.1
 * eq. (1) is the same model and needs the unit sum exactly, Sec. 3.3):
 *   v_i^t = sum_j w_ij (R_j^t p_i + T_j^t)                                   (LBS)
 *   min  E = sum_t sum_i || v_i^t - sum_j w_ij (R_j^t p_i + T_j^t) ||^2     (fitting error)
 *   s.t. w_ij >= 0 (non-negativity), sum_j w_ij = 1 (affinity), |{j : w_ij != 0}| <= K
 *        (sparsity), R_j^t R_j^t^T = I, det R_j^t = 1 (rigid bones).
 * Solved by block coordinate descent (Le & Deng's alternation), each block exactly:
 *   ssdr_init.c        clustering of the vertices into N rigid groups (label update / transform
 *                      update, splitting the worst-fitting groups until N exist);
 *   ssdr_weights.c     the weights of one vertex with the bones fixed: a non-negative,
 *                      unit-sum least-squares problem over all bones, then re-solved on its K
 *                      largest (Le & Deng's weight update);
 *   ssdr_transforms.c  the transform of one bone in one frame with the weights and the other
 *                      bones fixed: a weighted orthogonal Procrustes problem, closed form (Le &
 *                      Deng's bone transformation update);
 *   ssdr.c             the alternation to convergence, and mdl_skin_fit.
 *
 * Paper -> code:
 *   p_i  -> U (nv x 3, interleaved, double)        v_i^t -> X (nv x 3F, column-major, ld nv:
 *   X[i + nv*(3t + a)] = coordinate a of vertex i in frame t)
 *   R_j^t, T_j^t -> T[12*(t*nb + j) ...]: R row-major (9), then T (3)
 *   w_ij -> the K slots of vertex i: bone[K*i + s], w[K*i + s] (unused slots: w = 0)
 *
 * The weight update needs, per vertex, the normal equations of min ||A_i w - v_i||^2 where column
 * j of A_i (3F) stacks the frames of [R_j^t | T_j^t] p~_i, p~_i = (p_i, 1):
 *   (A^T A)_jk = p~^T G_jk p~,  G = M^T M   (4nb x 4nb; M is 3F x 4nb, M[(3t+a), 4j+b] =
 *                                            [R_j^t | T_j^t]_ab), the same for every vertex;
 *   (A^T v)_j = sum_b (X M)_{i, 4j+b} p~_b  (one matrix product for all vertices).
 * Only the candidate bones of a vertex enter its solve: those with a non-zero weight at the
 * vertex or at one of its mesh neighbours (so a bone's influence grows by one ring per
 * iteration, from the clusters of the initialisation), which bounds the per-vertex cost by the
 * local bone count instead of nb.
 *
 * Parallelism: model/ creates no threads. The caller may pass a parallel-for (mdl_skin_opts);
 * work is split into fixed blocks (vertex blocks of SSDR_BLOCK, or single frames) whose results
 * do not depend on which worker runs them, so the output is identical for any thread count.
 * Training only: everything here allocates at create, and the sweeps allocate nothing. */
#ifndef MESHSTEER_MODEL_SSDR_H
#define MESHSTEER_MODEL_SSDR_H

#include "model.h"

#define SSDR_BLOCK 128

typedef struct mdl__ssdr {
    int nv, nf, nb, K;
    double *U;      /* nv x 3 rest pose p_i */
    double *X;      /* nv x 3nf, column-major, ld nv */
    double *vv;     /* nv: sum_t |v_i^t|^2 */
    double *T;      /* nf x nb x 12 */
    int *bone;      /* nv x K */
    double *w;      /* nv x K */
    /* the mesh graph for the smoothness term (off/nbr as core/meshgraph.h), may be NULL */
    const int *g_off, *g_nbr;
    double smooth;  /* lambda_s of the smoothness term, already scaled (ssdr.c) */
    /* parallel-for */
    int workers;
    mdl_parallel_fn par;
    void *par_ud;
    /* scratch, sized at create */
    double *M, *G;       /* 3nf x 4nb, 4nb x 4nb */
    double *Yw;          /* workers x SSDR_BLOCK x 4nb */
    double *Rw;          /* workers x nv x 3: residuals of a frame */
    double *Sw;          /* workers x per-vertex solver scratch */
    size_t sw_len;
    int *new_bone;       /* nv x K */
    double *new_w;       /* nv x K */
    int *label;          /* nv: hard labels (init), or the bone of largest weight */
    double *verr;        /* nv: per-vertex error (init: of its label) */
    double *ferr;        /* nf: per-frame squared error after a transform sweep */
    double *fmax;        /* nf: per-frame largest squared vertex error */
    /* bone supports (CSR over nb): the vertices with w_ij > 0 and their weights */
    int *sup_off, *sup_v;
    double *sup_w, *sup_ubar, *sup_w2; /* sup_ubar: nb x 3 (sum w^2 p / sum w^2), sup_w2: nb */
    int trans_sweeps;
    /* the fast transform update (ssdr_transforms.c): B = sum_i w_ij v_i p~_i^T
     * (3nf x 4nb, as M), C (nb x nb x 16, C[(j nb + k) 16 + 4b + d]) = sum_i w_ij w_ik p~_b p~_d,
     * cadj (nb x nb) the bones k != j with C_jk != 0 (cnum of them), vvt (nf) sum_i |v_i^t|^2 */
    double *B, *C, *vvt;
    double *Xt;     /* 3nf x nv, column-major (ld 3nf): the frames of one vertex contiguous */
    int *mark;      /* workers x 3nb: candidate stamps, list and local index (weight update) */
    int *cadj, *cnum;
} mdl__ssdr;

/* Allocates the solver for nb bones and K influences over the frames `frames` of seq with the
 * rest pose `rest` (nv x 3 floats). */
int mdl__ssdr_create(const mdl_meshseq *seq, const int *frames, int nf, const float *rest, int nb,
                     int K, const mdl_skin_opts *o, mdl__ssdr **out, char *err);
void mdl__ssdr_destroy(mdl__ssdr *s);

/* Runs body over [0, n) through the caller's parallel-for (serially on worker 0 without one). */
void mdl__ssdr_parallel(mdl__ssdr *s, int n, mdl_parallel_body body, void *ctx);

/* ssdr_init.c: hard labels and their rigid transforms for exactly nb bones (every bone at least
 * min_size vertices). Fills T, bone/w (one-hot). Returns -EDOM, with the reason, when the mesh
 * cannot support nb bones. */
int mdl__ssdr_init(mdl__ssdr *s, int iterations, char *err);

/* ssdr_transforms.c: `sweeps` passes of the per-bone Procrustes update over every frame with the
 * weights fixed; returns E (the squared error summed over frames and vertices) after the update,
 * and, when max_sq is not NULL, the largest squared vertex error (an extra explicit pass).
 * Rebuilds the bone supports from w first. Works on the sums B, C (Le & Deng's fast update):
 * a sweep costs O(nb^2) per frame, independent of the vertex count. */
double mdl__ssdr_transforms(mdl__ssdr *s, int sweeps, double *max_sq);
/* The same for one frame t only with residual scratch r (nv x 3); returns its E. */
double mdl__ssdr_transforms_frame(mdl__ssdr *s, int t, int sweeps, double *r, double *max_sq);
/* Rebuilds the bone supports (sup_*) from bone/w. */
void mdl__ssdr_supports(mdl__ssdr *s);

/* ssdr_weights.c: the weights of every vertex with the transforms fixed (writes bone/w). */
void mdl__ssdr_weights(mdl__ssdr *s);
/* Builds M and G from T (shared by the weight update and the label update of ssdr_init.c). */
void mdl__ssdr_normal_setup(mdl__ssdr *s);
/* For vertices [i0, i1): Y = X[i0:i1, :] M into y (ld = i1 - i0), then c_ij = sum_b Y_ij,b p~_b
 * into c (row ii = i - i0, nb per row) and d_ij = p~^T G_jj p~ into d (same layout). */
void mdl__ssdr_block_cd(mdl__ssdr *s, int i0, int i1, double *y, double *c, double *d);
/* p~^T G_jk p~ */
double mdl__ssdr_q(const mdl__ssdr *s, const double pt[4], int j, int k);

/* The solve of one vertex: min w^T Q w - 2 c^T w over the simplex with at most K non-zeros,
 * over the candidate bones cand[0..n). qf(ctx, j, k) gives Q_jk. Writes up to K (bone, weight)
 * pairs (weights sum to 1) and returns how many. scratch: mdl__ssdr_nnls_scratch(n) doubles. */
size_t mdl__ssdr_nnls_scratch(int n);
int mdl__ssdr_nnls(int n, const double *c, double (*qf)(void *ctx, int j, int k), void *ctx,
                   int K, double ridge, double *scratch, int *out_bone, double *out_w);

#endif
