/* steer_internal.h - the trained part-based model (Voegele et al. 2012), shared by train.c,
 * synth.c and modelfile.c. Not part of the public interface.
 *
 * paper -> code:
 *   marker graph G, e_ref, limb paths p_G (Sec. 4.1)  -> rig (markers, ref, limb_off/limb_idx)
 *   clusters C, virtual skeleton H (Sec. 4.1, 4.5)    -> parts (part[], part_adj)
 *   cluster overlaps (Sec. 4.5)                        -> inst_vidx (core + overlap rings)
 *   shared clusters, duplicated per limb (Sec. 5.3)    -> instances: one per (part, limb)
 *   eigenshapes V, sigma^2, mean x_bar (Sec. 4.4 eq. 6) -> part_mean, part_modes, part_sigma2
 *   Phi^l, Psi^l (Sec. 4.3 eq. 5)                      -> limb regression coef (one matrix, both)
 *   pose adaption (Sec. 4.2)                           -> feat_scale, feat_shift per limb
 *   blend weights w_l (Sec. 5.3 eq. 8)                 -> blend_off/blend_inst/blend_w
 *   greedy alignment order (Sec. 5.1)                  -> order[], order_ov_off/order_ov
 *
 * Coordinates: every per-part quantity lives in the *body frame*, the orthonormal frame spanned by
 * the reference edge e_ref and the up axis (posefeat.h), so that the model is invariant to where
 * the performer stands and which way they face.
 * Precision: training in double; everything the per-frame synthesis reads is stored as float
 * (positions and modes) or double (small regression matrices and Cholesky factors).
 */
#ifndef MESHSTEER_STEER_INTERNAL_H
#define MESHSTEER_STEER_INTERNAL_H

#include "model.h"


typedef struct mdl_limb_reg {
    int nin;        /* features d_l (Table 1), computed by mdl__limb_features */
    int nout;       /* outputs: sum over the limb's instances of 7 + modes */
    double *feat_scale, *feat_shift; /* pose adaption (Sec. 4.2): f' = scale * f + shift; nin */
    double *zmean, *zsd;             /* standardisation of adapted features for the kernel; nin */
    int ncent;                       /* radial basis centres (regress.h), 0 = purely linear */
    double *cent;                    /* ncent x nin, standardised feature space, row-major */
    double width;                    /* kernel width in standardised units */
    double *in_mean, *in_sd;         /* standardisation of the design row; nin + ncent */
    double *coef;   /* (nin + ncent + 1) x nout, column-major; row 0 is the intercept */
    double ridge;   /* the regularisation that was chosen */
    double rms_train, rms_loo; /* regression residuals (report) */
} mdl_limb_reg;

struct mdl_steer {
    char name[MDL_NAME_LEN];
    int nv, nf;
    float *rest;            /* nv x 3 */
    uint32_t *F;            /* nf x 3 */
    uint64_t topology;
    double fps;
    float bbox_min[3], bbox_max[3];
    int virtual_markers;
    int ntrain;
    int *train_frames;
    double train_seconds;

    /* the rig (copied) */
    int nmarkers;
    mdl_rig_marker *markers;
    int nref, ref[3];
    int nlimbs;
    int *limb_off, *limb_idx;

    /* options used at synthesis */
    double beta;
    int iterations;
    int use_motion_dir;
    double prior_weight;    /* weight of the predicted rotation in the greedy alignment */
    double marker_weight;   /* weight of a marker as an alignment target, relative to the overlap
                               points of the same instance (0: markers only drive the regressions) */
    int relax;              /* extra alignment sweeps against all neighbours (synth.c) */
    /* placement of the result (synth.c): 0 = in the markers' body frame (markers in the mesh's
     * space); 1 = ground-locked, for a performer of another build: the mesh keeps the body frame
     * of its first training frame (place_R, place_o) and follows only the performer's heading about
     * +Y and horizontal travel, both relative to the recording's first frame (rec_heading,
     * rec_origin) */
    int place_mode;
    int axis_mesh, axis_rec;  /* secondary body-frame axis of the mesh's and the recording's
                                 reference edge (posefeat.h), or MDL_AXIS_FIT (heading.h) */
    double *hd_mesh, *hd_rec; /* with MDL_AXIS_FIT: the heading fit's canonical configuration and
                                 weights, nmarkers x 4 (heading.h); else NULL */
    double *mfilt;            /* nmarkers x 2: the input filter's gains (mfilter.h), or NULL (off;
                                 files before it) */
    double filter_noise;      /* the sigma_n they were made for (m; report) */
    double kb_h;              /* > 0: synthesis is the kernel blend of the training meshes
                                 (kblend.h) with this bandwidth factor, not the part model */
    float *kb_V;              /* with kb_h: ntrain x nv x 3, the training meshes */
    float *kb_mk;             /* with kb_h: ntrain x nmarkers x 3, their rig vertices */
    double place_R[9], place_o[3];
    double rec_heading, rec_origin[3];

    /* disjoint parts (clusters) */
    int nparts;
    int *part;              /* nv */
    double *part_rms;       /* nparts: RMS rigid-fit residual of each part over training (report) */

    /* shape model per part over core + overlap vertices */
    int *pv_off;            /* nparts + 1 */
    int *pv_idx;            /* mesh vertex indices */
    int *pmodes;            /* nparts: kept modes k_p */
    int *pm_off;            /* nparts + 1: offsets into part_modes (3 n_p k_p floats each) */
    float *part_mean;       /* 3 * pv_off[nparts] floats, local (aligned) coordinates */
    float *part_modes;      /* per part 3n_p x k_p column-major, ld 3n_p */
    double *part_sigma2;    /* per part k_p eigenvalues (offsets: ps_off) */
    int *ps_off;            /* nparts + 1 */
    double *part_explained; /* nparts: variance explained by the kept modes */

    /* instances: a part within one limb (shared parts appear once per limb that uses them) */
    int ninst;
    int *inst_part;         /* ninst */
    int *inst_limb;         /* ninst */
    int *inst_out;          /* ninst: offset of this instance's outputs in its limb's nout */
    int *inst_shared;       /* ninst: 1 when the part has instances in several limbs */

    /* per limb: control-point path (eq. 2) as parts along the path, and the regression */
    int *lpath_off, *lpath;  /* parts on the path from the first to the last marker of each limb */
    double *lctrl;           /* control points of eq. (2) per limb, rest pose: the first marker's
                                vertex, the virtual joints gamma(e) at the barycentres of the
                                intersections of successive parts, the last marker's vertex;
                                limb l has lpath_off[l+1] - lpath_off[l] + 1 points at
                                3 * (lpath_off[l] + l) */
    mdl_limb_reg *reg;       /* nlimbs */

    /* greedy rigid alignment order (Sec. 5.1) and the overlap of each step with what is placed */
    int *order;              /* ninst */
    int *order_ov_off;       /* ninst + 1 */
    int *order_ov;           /* local vertex indices (into the instance's part vertex list) */

    /* shape optimisation (eq. 7): vertices of each instance shared with any other instance */
    int *sov_off;            /* ninst + 1 */
    int *sov;                /* local vertex indices */
    int *chol_off;           /* ninst + 1: offsets of k x k Cholesky factors */
    double *chol;            /* upper factor of V_O^T V_O + beta diag(1/sigma^2) */

    /* blending (eq. 8): for every vertex, the instances that hold it and their weights */
    int *blend_off;          /* nv + 1 */
    int *blend_inst;         /* instance index */
    int *blend_local;        /* local index of the vertex in that instance's part list */
    float *blend_w;

    /* the option selection of this training (select.h), for the report; not saved (NULL after
     * loading, or when no selection ran) */
    struct mdl_select_result *sel;
};

/* Frees everything a model holds; NULL is fine. */
void mdl__steer_free(struct mdl_steer *m);

/* train.c: the whole training (model.h, mdl_steer_train). */
int mdl__steer_train(const mdl_meshseq *seq, const int *frames, int nframes, const mdl_rig *rig,
                     const mdl_markers *markers, const mdl_train_opts *opts, struct mdl_steer **out,
                     char *err);

/* train.c: training in two steps, for the option selection (select.c): mdl__steer_fit_begin runs
 * every stage but the regressions (stages 1-6 and 8) with opts (resolved: no -1 left but ridge and
 * linear); mdl__steer_fit_regress fits (again) the regressions (stage 7) with o's use_motion_dir,
 * linear, ridge, train_noise and noise_copies, after which mdl__steer_fit_model is a complete
 * model; mdl__steer_fit_end frees the fit and, with out, hands over the model. */
typedef struct mdl__steer_fit mdl__steer_fit;
/* A partition into near-rigid parts (cluster.h): n parts, part (nv ids), rms (n residuals). */
typedef struct mdl__steer_parts {
    int n;
    int *part;
    double *rms;
} mdl__steer_parts;
/* given: a partition of the same frames to use instead of clustering (NULL: cluster); snap_k > 0:
 * also keep the partition a run with max_clusters = snap_k would give (mdl__steer_fit_snap). */
int mdl__steer_fit_begin(const mdl_meshseq *seq, const int *frames, int nframes, const mdl_rig *rig,
                         const mdl_markers *markers, const mdl_train_opts *opts,
                         const mdl__steer_parts *given, int snap_k, mdl__steer_fit **out,
                         char *err);
/* The fit's partition, and the snapshot (n = 0 without snap_k); both borrowed. */
mdl__steer_parts mdl__steer_fit_parts(const mdl__steer_fit *f);
mdl__steer_parts mdl__steer_fit_snap(const mdl__steer_fit *f);
int mdl__steer_fit_regress(mdl__steer_fit *f, const mdl_train_opts *o, char *err);
const struct mdl_steer *mdl__steer_fit_model(const mdl__steer_fit *f);
void mdl__steer_fit_end(mdl__steer_fit *f, struct mdl_steer **out);

/* synth.c: synthesis (Sec. 5), behind the kind table of steer_kind.c. */
typedef struct mdl_steer_synth mdl_steer_synth;
int mdl__steer_synth_create(const struct mdl_steer *m, mdl_steer_synth **out, char *err);
void mdl__steer_synth_destroy(mdl_steer_synth *s);
int mdl__steer_synth_frame(mdl_steer_synth *s, const float *markers, const uint8_t *valid,
                           float *Vout, mdl_synth_info *info);
void mdl__steer_synth_reset(mdl_steer_synth *s);
/* The compact form of the synthesis (model.h, mdl_params_layout / mdl_synth_params). */
int mdl__steer_synth_params_layout(const mdl_steer_synth *s, mdl_params_layout *out);
int mdl__steer_synth_params(const mdl_steer_synth *s, float *out);
/* Makes s use the plain x86-64 variant of synthesis even on an AVX2 machine (tests: both
 * variants must give identical frames). */
void mdl__steer_synth_portable(mdl_steer_synth *s);

/* steer_file.c: the steering chunk of the model file (docs/FORMATS.md). v1 = 1 reads the body of
 * a version-1 file, which also holds the mesh and the rig (converted on load); otherwise the mesh
 * and rig come from m. */
struct mdl__wbuf;
struct mdl__rbuf;
void mdl__steer_save(const struct mdl_steer *s, struct mdl__wbuf *b);
int mdl__steer_parse(struct mdl__rbuf *b, const mdl_model *m, int v1, struct mdl_steer **out);

/* eval.c: mdl_eval_run for the steering kind. */
int mdl__steer_eval(const mdl_model *model, const mdl_meshseq *seq, const int *frames, int n,
                    const mdl_eval_opts *o, mdl_eval_result *r, char *err);

/* steer_file.c: a model holding s as its primary kind, over s's mesh and rig (takes s, also on
 * error). */
int mdl__steer_model_from(struct mdl_steer *s, mdl_model **out, char *err);

/* The steering model inside a model (NULL if it has none). */
const struct mdl_steer *mdl__model_steer(const mdl_model *m);
/* Same, for a synthesis of the steering kind (tests of internals). */
mdl_steer_synth *mdl__synth_steer(mdl_synth *s);

#endif
