/* harmonic_internal.h - the harmonic model kind (de Aguiar, Zayer, Theobalt, Magnor, Seidel 2007,
 * "A Simple Framework for Natural Animation of Digitized Models"), shared inside model/harmonic/.
 *
 * paper -> code:
 *   target mesh M (nV vertices, nT triangles)     -> nv, nf, rest (nv x 3 float), F
 *   correspondence triangles (Sec. 4.2)           -> corr_tri[ncorr], each in group corr_group[]
 *   a template part whose triangles share one
 *     rotation (a bone; or one triangle for auto:K) -> group; ngroups of them
 *   Q = [w q1 q2 q3] (eq. 1), per group            -> qg (ngroups x 4 double, w first)
 *   S with nabla^2 S = 0 (eq. 2)                  -> mdl__hfield (harmonic_field.c): Dirichlet
 *                                                    values at the correspondences' vertices
 *   fragmented mesh M', U_reduced (eq. 3-4)       -> mdl__poisson (poisson.c)
 *   candy-wrapper handling (Sec. 4.3)             -> candy.c: sign alignment along a tree of groups
 * The template (Sec. 5) is a set of bones, each a pair of markers (joint positions) with an optional
 * third (twist) marker: bone_a, bone_b, bone_c (-1: none) index the model rig's markers.
 * Per frame everything is preallocated at create; doubles throughout (the field values go into
 * and out of factorised systems; the output is converted to float at the end). */
#ifndef MESHSTEER_HARMONIC_INTERNAL_H
#define MESHSTEER_HARMONIC_INTERNAL_H

#include "model.h"
#include "core/sparse.h"
#include "formats/chunkio.h"

#include <stdint.h>

/* ------------------------------------------------------------------ eq. 2 (harmonic_field.c) */

typedef struct mdl__hfield {
    int nv, nfree, ncv;
    int ncomp;    /* columns the factor is prepared for: 4, or 10 with the stretch (eval --stretch) */
    int *row;     /* nv: free row r >= 0, or -(c + 1) for constrained vertex c */
    int *cv;      /* ncv constrained vertices */
    /* coupling of free rows to constrained vertices: rhs[r] += cw * S[c] (cw = -L_rc) */
    int ncoup;
    int *coup_r, *coup_c;
    double *coup_w;
    mdl_spd *spd; /* L_ff, the Laplacian restricted to free vertices */
    double *B;    /* nfree x ncomp column-major, right-hand sides then solutions */
} mdl__hfield;

/* The quaternion (4) and a symmetric 3 x 3 stretch's six components (xx xy xz yy yz zz). */
#define MDL_HFIELD_NCOMP_STRETCH 10

/* w: cotangent weights (laplacian.h). cv: the constrained vertices (distinct). ncomp: 4 (the
 * paper), or MDL_HFIELD_NCOMP_STRETCH to also carry the stretch. MDL_ENUMERIC when a connected part
 * of the mesh has no constrained vertex (the field is undetermined there). */
int mdl__hfield_precompute(mdl__hfield *h, const uint32_t *F, int nf, int nv, const double *w,
                           const int *cv, int ncv, int ncomp, char *err);
void mdl__hfield_fini(mdl__hfield *h);
/* Sc: ncv x 4 (interleaved) values at the constrained vertices; S: nv x 4 interleaved output, each
 * vertex's quaternion normalised (Sec. 4.1: "fields normalised after"). Allocates nothing. */
int mdl__hfield_solve(mdl__hfield *h, const double *Sc, double *S);
/* The same with ncomp (4 or h->ncomp) values per vertex, interleaved; the first four (the
 * quaternion) normalised, the rest (the stretch) as solved. Allocates nothing. */
int mdl__hfield_solve_n(mdl__hfield *h, const double *Sc, double *S, int ncomp);

/* ------------------------------------------------------------------ eq. 3-4 (poisson.c) */

typedef struct mdl__poisson {
    int nv, nf, nfree, nanchor;
    const uint32_t *F;  /* borrowed: the model's faces */
    int *row;     /* nv: free row, or -(a + 1) for anchor a */
    int *anchor;  /* nanchor vertices (one per connected part), held at R_t x_rest */
    int *anchor_tri; /* a triangle of each anchor, whose rotation places it */
    double *anchor_rest; /* nanchor x 3 */
    int ncoup;
    int *coup_r, *coup_a;
    double *coup_w;
    double *e;    /* nf x 9: e[9t + 3k + c], the rest differential coordinate of corner k (eq. 3) */
    mdl_spd *spd;
    double *B;    /* nfree x 3 column-major */
    double *xa;   /* nanchor x 3 */
} mdl__poisson;

int mdl__poisson_precompute(mdl__poisson *p, const float *rest, const uint32_t *F, int nf, int nv,
                            const double *w, char *err);
void mdl__poisson_fini(mdl__poisson *p);
/* Rt: nf x 9 row-major per-triangle rotations (the fragmented mesh M'); X: nv x 3 interleaved
 * output, in the frame where each part's anchor vertex sits at R_t x_rest. Allocates nothing. */
int mdl__poisson_solve(mdl__poisson *p, const double *Rt, double *X);

/* ------------------------------------------------------------------ the model kind's state */

struct mdl_harmonic {
    int nv, nf;
    int ncorr;
    int *corr_tri;     /* ncorr */
    int *corr_group;   /* ncorr, in 0..ngroups */
    int ngroups;
    int *group_parent; /* ngroups: sign-alignment tree (candy.c), -1 for the root */
    int *group_order;  /* ngroups: a parent before its children */
    /* the template: bones over the rig's markers (0 bones for a model measured on its own sequence) */
    int nbones;        /* == ngroups when > 0 */
    int *bone_a, *bone_b, *bone_c;
    int nmk;           /* the rig's markers */
    float *mk_rest;    /* nmk x 3: template rest pose, aligned to the target (Sec. 4.1 "roughly aligned") */
    double align_scale, align_t[3]; /* marker frames -> target: p' = s p + t (the mocap's floor
                                       on the target's floor; mk_rest has its own t) */
    int root_marker, root_bone, anchor_vertex;
    int auto_k;        /* the K of auto:K (0 for a rig's correspondences) */
    /* joint rotations (MDL_INPUT_JOINTS, harmonic_synth.c), per bone: */
    int *bone_j;       /* the rig marker whose segment rotation (mdl_markers.rot) drives the bone:
                          b when b hangs below a in the template's skeleton (the last segment of
                          the chain a -> b), a when a hangs below b; -1: none (direction path) */
    double *bone_jrest;/* nbones x 4: that rotation in the template's rest pose, R_j(rest) */
    double *bone_fit;  /* nbones x 4: C_g, the rest fit's turn of the bone from the template's rest
                          direction to the target's limb (rest_fit.c; identity without it) */
};

void mdl__harmonic_free(struct mdl_harmonic *h);

/* ------------------------------------------------------------------ the deformer (deform.c) */

typedef struct mdl__hdeform {
    const struct mdl_harmonic *h;
    const uint32_t *F;
    mdl__hfield field;
    mdl__poisson pois;
    int *cv_group;   /* field.ncv: the group of each constrained vertex */
    double *qg;      /* ngroups x 4, aligned */
    double *qprev;   /* ngroups x 4, last frame's aligned (candy.c) */
    int have_prev;
    int ncomp;       /* 4, or MDL_HFIELD_NCOMP_STRETCH when made with the stretch */
    double *Sc, *S;  /* ncv x ncomp, nv x ncomp */
    double *Rt;      /* nf x 9: R_t, or R_t U_t with the stretch */
    double *X;       /* nv x 3 */
    int near_180;    /* groups whose relative rotation to their parent was ambiguous, last frame */
} mdl__hdeform;

int mdl__hdeform_init(mdl__hdeform *d, const struct mdl_harmonic *h, const float *rest,
                      const uint32_t *F, char *err);
/* The same; stretch != 0 also prepares the stretch fields (mdl__hdeform_run_stretch). */
int mdl__hdeform_init_mode(mdl__hdeform *d, const struct mdl_harmonic *h, const float *rest,
                           const uint32_t *F, int stretch, char *err);
void mdl__hdeform_fini(mdl__hdeform *d);
/* Per frame: group rotations qg_in (ngroups x 4, any sign) -> X (d->X, nv x 3). Allocates nothing. */
int mdl__hdeform_run(mdl__hdeform *d, const double *qg_in);
/* Per frame, beyond the paper: group rotations and group stretches ug_in (ngroups x 6, symmetric
 * U in rest coordinates, xx xy xz yy yz zz; F = R U) -> X. -EINVAL unless made with stretch.
 * Allocates nothing. */
int mdl__hdeform_run_stretch(mdl__hdeform *d, const double *qg_in, const double *ug_in);
/* Per-triangle rotations from the field (steps 2-3 of Sec. 4.1) without the Poisson glue. */
int mdl__hdeform_tri_rotations(mdl__hdeform *d, const double *qg_in);
void mdl__hdeform_reset(mdl__hdeform *d);

/* ------------------------------------------------------------------ candy.c (Sec. 4.3) */

/* Builds the tree over groups (parent, order) from a position per group (ngroups x 3: a bone's
 * midpoint, or a correspondence triangle's centroid): a
 * minimum spanning tree by Euclidean distance (Prim), root group 0. Allocates. */
int mdl__candy_tree(struct mdl_harmonic *h, const double *pos, char *err);
/* Aligns q (ngroups x 4) in place to one hemisphere per tree edge: each child's sign agrees with
 * its parent's, and where their relative rotation is near 180 deg (|<q_c, q_p>| < MDL_CANDY_EPS,
 * the "w ~ 0" of Sec. 4.3) with its own previous frame instead (prev may be NULL); with prev, a
 * group near its previous value (|<q, q_prev>| >= MDL_CANDY_PREV) always keeps its sign. Returns how
 * many such ambiguous groups there were. */
#define MDL_CANDY_EPS 0.1
#define MDL_CANDY_PREV 0.5 /* |<q, q_prev>| from which a group keeps its own last sign */
int mdl__candy_align(const int *parent, const int *order, int ngroups, double *q,
                     const double *prev);

/* ------------------------------------------------------------------ correspondences.c (Sec. 4.2) */

/* auto:K on a mesh alone: K triangles by farthest-point sampling of triangle centroids (each
 * connected part gets at least one), each grown to its own group: a patch around it, or with
 * `rings` (rings:K) a cross-section ring across the local principal axis. */
int mdl__corr_auto_k(struct mdl_harmonic *h, const float *rest, const uint32_t *F, int nf, int nv,
                     int k, int rings, char *err);
/* The bone-driven proposal: every target triangle goes to its nearest bone segment (aligned rest
 * poses); up to per_bone of a bone's triangles with segment parameter in [0.2, 0.8] are chosen by
 * farthest-point sampling. given (may be NULL): per bone a list of user triangles (off/idx as in a
 * rig's limbs), each completed by the triangles of its cross-section (the slab through its centroid
 * normal to the bone, same nearest bone). */
int mdl__corr_bones(struct mdl_harmonic *h, const float *rest, const uint32_t *F, int nf,
                    int per_bone, const int *given_off, const int *given_idx, char *err);
/* rest_fit.c: poses h->mk_rest (the aligned template rest) to the target's rest pose V: each bone
 * below the root turned onto the axis of the target's limb it lies in. kept: the bones that found no
 * limb and kept their direction. h->bone_fit (when allocated) gets each bone's C_g: the
 * rotations the fit applied to its end, then the shortest arc that takes the result onto the bone's
 * fitted direction (the end's shift onto its section's centre). Allocates. */
int mdl__rest_fit(struct mdl_harmonic *h, const float *V, const uint32_t *F, int nv, int nf,
                  int *kept, char *err);
/* For each triangle the correspondence geodesically nearest to it (Dijkstra on the edge graph from
 * the correspondences' vertices): near (nf), an index into corr_tri. */
int mdl__corr_nearest(const struct mdl_harmonic *h, const float *rest, const uint32_t *F, int nf,
                      int nv, int *near, char *err);

/* ------------------------------------------------------------------ small quaternion helpers */

/* a symmetric 3 x 3 (row-major) from its six components xx xy xz yy yz zz, and back */
static inline void mdl__sym_from6(const double u[6], double U[9])
{
    U[0] = u[0], U[1] = u[1], U[2] = u[2];
    U[3] = u[1], U[4] = u[3], U[5] = u[4];
    U[6] = u[2], U[7] = u[4], U[8] = u[5];
}
static inline void mdl__sym_to6(const double U[9], double u[6])
{
    u[0] = U[0], u[1] = 0.5 * (U[1] + U[3]), u[2] = 0.5 * (U[2] + U[6]);
    u[3] = U[4], u[4] = 0.5 * (U[5] + U[7]), u[5] = U[8];
}

static inline void mdl__qnorm(double *q)
{
    double n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    if (n > 0) {
        n = 1.0 / __builtin_sqrt(n);
        q[0] *= n, q[1] *= n, q[2] *= n, q[3] *= n;
    } else {
        q[0] = 1, q[1] = q[2] = q[3] = 0;
    }
}

/* the kind's eval (its table is in kind.h) */

int mdl__harmonic_eval(const mdl_model *m, const mdl_meshseq *seq, const int *frames, int n,
                       const mdl_eval_opts *o, mdl_eval_result *r, char *err);
/* The rotation of a triangle from rest (A) to deformed (B) vertices: the orthogonal polar factor of
 * its deformation gradient [Sumner & Popovic 2004, Sec. 3: the fourth vertex along the normal]. */
void mdl__tri_rotation(const float *A, const float *B, const uint32_t *f, double q[4]);
/* The same triangle's whole deformation gradient split F = R U (Fg: the 3 x 3 F, row-major,
 * mapping the rest edges and scaled normal onto the deformed ones; q: R; u: U's six components). */
void mdl__tri_gradient(const float *A, const float *B, const uint32_t *f, double Fg[9], double q[4],
                       double u[6]);

/* harmonic_synth.c: the kind's synthesis (markers -> bone rotations -> deformer) */
int mdl__harmonic_synth_create(const mdl_model *m, const void *impl, void **state, char *err);
int mdl__harmonic_synth_frame(void *state, const mdl_synth_input *in, float *V, mdl_synth_info *info);
void mdl__harmonic_synth_reset(void *state);
void mdl__harmonic_synth_marker_placement(const void *state, double *scale, double t[3]);
void mdl__harmonic_synth_destroy(void *state);
/* The rotation of a bone driven by its joint (MDL_INPUT_JOINTS): Q = q_t q_rest^* (the template's
 * rotation since its rest pose), composed with the rest fit, Q C^*; then, when both markers are
 * known (d0 the fitted rest direction, d the current one, unit; NULL otherwise), the shortest arc
 * from Q C^* d0 onto d in front (the identity for a one-segment bone; a chain's bend for a bone over
 * several segments). Returns that arc's angle (radians). */
double mdl__harmonic_joint_quat(const double q_t[4], const double q_rest[4], const double C[4],
                                const double *d0, const double *d, double q[4]);
/* A bone's rotation from its rest markers (a0, b0, twist c0 or NULL) to its current ones. */
void mdl__harmonic_bone_quat(const float *a0, const float *b0, const float *c0, const float *a,
                             const float *b, const float *c, double q[4]);

#endif
