/* model.h - the public interface of meshsteer's numerical core.
 *
 * Everything outside model/ includes only this header. model/ needs libc, OpenBLAS/LAPACKE and
 * cJSON; it creates no threads, opens no sockets or devices and never prints.
 *
 * Conventions (DESIGN.md, "Data and units"):
 *   - lengths in metres, right-handed, Y up;
 *   - vertex and marker arrays are interleaved xyz, float, n x 3;
 *   - triangles are uint32, 0-based, F x 3;
 *   - a mesh sequence is frames x V x 3, frame-contiguous.
 * Errors: functions return 0 or a negative errno / MDL_E* code; the last parameter `err` (may be
 * NULL) receives a message of at most MDL_ERR_LEN bytes naming the file, the position and the reason.
 * Ownership: x_create/x_read/x_load allocate, x_destroy frees and accepts NULL.
 */
#ifndef MESHSTEER_MODEL_H
#define MESHSTEER_MODEL_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MDL_ERR_LEN 512

/* Our own error codes (negative, below the errno range). */
enum {
    MDL_EFORMAT = -1000,  /* malformed input file */
    MDL_EVERSION = -1001, /* model file of an incompatible version */
    MDL_ETOPOLOGY = -1002,/* mesh topology differs from the one the model was trained on */
    MDL_ENUMERIC = -1003, /* a factorisation or decomposition failed */
};

/* ------------------------------------------------------------------ meshes (obj.c, pc2.c, meshseq.c) */

typedef struct mdl_mesh {
    int nv, nf;
    float *V;    /* nv x 3 */
    uint32_t *F; /* nf x 3 */
} mdl_mesh;

typedef struct mdl_meshseq {
    int nv, nf, frames;
    double fps;  /* 0 when the file does not say */
    float *V;    /* frames x nv x 3 */
    uint32_t *F; /* nf x 3, shared by all frames */
} mdl_meshseq;

/* OBJ: `v` and `f` lines (f with v, v/t, v//n, v/t/n and negative indices); polygons are
 * fan-triangulated; other lines are ignored. */
int mdl_mesh_read_obj(const char *path, mdl_mesh **out, char *err);
int mdl_mesh_parse_obj(const char *buf, size_t len, const char *name, mdl_mesh **out, char *err);
int mdl_mesh_write_obj(const char *path, const float *V, int nv, const uint32_t *F, int nf, char *err);
void mdl_mesh_destroy(mdl_mesh *m);

/* A sequence: a directory of numbered OBJ files (natural numeric order; identical faces enforced),
 * or a .pc2 point cache whose topology comes from `rest_obj` (required for .pc2, ignored otherwise). */
int mdl_meshseq_read(const char *path, const char *rest_obj, mdl_meshseq **out, char *err);
void mdl_meshseq_destroy(mdl_meshseq *s);
/* Writes every frame as DIR/0000.obj, DIR/0001.obj, ... (creating DIR if needed), so that the
 * directory reads back with mdl_meshseq_read. */
int mdl_meshseq_write_objdir(const char *dir, const mdl_meshseq *s, char *err);

/* PC2 point cache (little-endian "POINTCACHE2\0", version 1, numPoints, startFrame, sampleRate,
 * numSamples, then samples x points x 3 float32). */
int mdl_pc2_parse(const uint8_t *buf, size_t len, const char *name, int *nv, int *frames,
                  float *start, float *rate, float **V, char *err);
int mdl_pc2_write(const char *path, const float *V, int nv, int frames, float start, float rate,
                  char *err);

/* A 64-bit fingerprint of the face list (FNV-1a over nv, nf and the indices). */
uint64_t mdl_topology_fingerprint(const uint32_t *F, int nf, int nv);

/* ------------------------------------------------------------------ markers (c3d.c, trc.c, bvh.c, csv.c) */

typedef struct mdl_markers {
    int frames, count;
    double fps;
    float *P;       /* frames x count x 3, metres, Y up */
    uint8_t *valid; /* frames x count, 1 = sample present */
    char **names;   /* count NUL-terminated labels */
    /* Skeleton sources only (BVH, ASF/AMC; NULL for every other source): the joint rotations.
     * rot[(f count + i) 4 ..]: a unit quaternion (w, x, y, z) in the same Y-up frame as P, the
     * world rotation relative to the skeleton's rest pose (every rotation channel zero, where it
     * is the identity) that carries the segment from marker parent[i] to marker i: p_i(f) -
     * p_parent(f) = R (p_i - p_parent)(rest). A BVH joint's or End Site's segment turns with its
     * parent joint's frame, an ASF bone with its own; a root (parent -1) has its own frame's
     * rotation. Valid where P is. */
    float *rot;     /* frames x count x 4, or NULL */
    int *parent;    /* count: the marker each segment hangs from, -1 for a root; NULL with rot */
} mdl_markers;

/* Source axis conventions: which file axis points up. MDL_UP_AUTO picks the format's default
 * (C3D: +Z, TRC: +Y, BVH: +Y, CSV: +Y). */
enum { MDL_UP_AUTO = 0, MDL_UP_X, MDL_UP_Y, MDL_UP_Z, MDL_UP_NEG_X, MDL_UP_NEG_Y, MDL_UP_NEG_Z };

typedef struct mdl_marker_opts {
    double scale; /* metres per file unit; 0 = from the file (C3D POINT:UNITS, TRC Units) or a guess (BVH) */
    int up;       /* MDL_UP_* */
    int rest;     /* 1: one frame, the skeleton's rest pose (every rotation channel zero) instead of
                     the motion (BVH, ASF/AMC only) */
} mdl_marker_opts;

/* Reads by extension: .c3d .trc .bvh .csv .amc .asf. `o` may be NULL for defaults. */
int mdl_markers_read(const char *path, const mdl_marker_opts *o, mdl_markers **out, char *err);
int mdl_markers_parse_c3d(const uint8_t *buf, size_t len, const char *name, const mdl_marker_opts *o,
                          mdl_markers **out, char *err);
int mdl_markers_parse_trc(const char *buf, size_t len, const char *name, const mdl_marker_opts *o,
                          mdl_markers **out, char *err);
int mdl_markers_parse_bvh(const char *buf, size_t len, const char *name, const mdl_marker_opts *o,
                          mdl_markers **out, char *err);
int mdl_markers_parse_csv(const char *buf, size_t len, const char *name, const mdl_marker_opts *o,
                          mdl_markers **out, char *err);
/* ASF/AMC (asf_amc.c): joint positions by forward kinematics, "root" and every bone's far end.
 * amc may be NULL (then, as with o->rest, one frame: the skeleton's rest pose). mdl_markers_read
 * takes FILE.amc (its skeleton: FILE.asf, else the .asf in the same folder whose name is the
 * longest prefix of FILE's, e.g. HDM_dg.asf for HDM_dg_06-03_03_120.amc) or FILE.asf (rest pose). */
int mdl_markers_parse_asf_amc(const char *asf, size_t asf_len, const char *amc, size_t amc_len,
                              const char *name, const mdl_marker_opts *o, mdl_markers **out,
                              char *err);
/* Writers take metres, Y up, and write the format's own convention (C3D: mm, Z up, float storage). */
int mdl_markers_write_c3d(const char *path, const mdl_markers *m, char *err);
int mdl_markers_write_csv(const char *path, const mdl_markers *m, char *err);
/* An empty marker set of the given size (all samples invalid), for writers and tests. */
int mdl_markers_create(int frames, int count, double fps, mdl_markers **out, char *err);
int mdl_markers_find(const mdl_markers *m, const char *name); /* index or -1 */
void mdl_markers_destroy(mdl_markers *m);

/* ------------------------------------------------------------------ the rig (rig.c) */

#define MDL_NAME_LEN 64

typedef struct mdl_rig_marker {
    char name[MDL_NAME_LEN];
    char source[MDL_NAME_LEN]; /* label in the marker file or live source; defaults to name */
    int vertex;                /* 0-based mesh vertex (tau in paper 2012 Sec. 4) */
} mdl_rig_marker;

typedef struct mdl_rig {
    int nmarkers;
    mdl_rig_marker *markers;
    int nref;       /* 2 (the reference edge e_ref) or 3 (a third marker fixes the roll) */
    int ref[3];     /* marker indices */
    int nlimbs;
    int *limb_off;  /* nlimbs + 1 offsets into limb_idx */
    int *limb_idx;  /* marker indices; limb l is limb_idx[limb_off[l] .. limb_off[l+1]) */
} mdl_rig;

/* Parses the rig JSON of DESIGN.md; `nv` > 0 checks vertex indices against the mesh. */
int mdl_rig_read(const char *path, int nv, mdl_rig **out, char *err);
int mdl_rig_parse(const char *buf, size_t len, const char *name, int nv, mdl_rig **out, char *err);
void mdl_rig_destroy(mdl_rig *r);
/* Writes the rig as the JSON of DESIGN.md (markers with name, vertex and source, reference, limbs);
 * `comment` (may be NULL) goes into a "comment" member, which readers ignore. */
int mdl_rig_write(const char *path, const mdl_rig *r, const char *comment, char *err);

/* A rig proposed from one pose of a mesh (steer/rig_propose.c, issue 12): geodesic extremities of
 * the surface graph named by the up axis (unit or not, in the mesh's coordinates) and the body's
 * left-right symmetry. body MDL_BODY_HUMAN: head, lhand, rhand, lfoot, rfoot, pelvis, neck,
 * reference pelvis -> neck; MDL_BODY_QUADRUPED: withers, croup, lf/rf/lh/rh_hoof, muzzle, tail,
 * reference croup -> withers; MDL_BODY_AUTO decides (info->body says which). Errors name what is
 * missing (too few extremities, a body that is not upright along `up`). info may be NULL. */
enum { MDL_BODY_AUTO = 0, MDL_BODY_HUMAN = 1, MDL_BODY_QUADRUPED = 2 };
typedef struct mdl_rig_proposal {
    int body;             /* MDL_BODY_HUMAN or MDL_BODY_QUADRUPED */
    int centre;           /* the central vertex the extremities are measured from */
    int ntips;            /* geodesic extremities found, farthest-point order */
    int tips[8];
    float forward[3], left[3]; /* unit, perpendicular to up: where the body faces, its left */
    double height;        /* the body's extent along up */
    double fourth_lowest;  /* height of the fourth-lowest of the first six tips / height (auto) */
} mdl_rig_proposal;
int mdl_rig_propose(const float *V, int nv, const uint32_t *F, int nf, const float up[3], int body,
                    mdl_rig **out, mdl_rig_proposal *info, char *err);
/* The rig proposed from several frames (V: nframes x nv x 3, frame-contiguous, one topology):
 * each frame is proposed on its own (frames refused are skipped), the body is the one most frames
 * gave, and each marker's vertex is the medoid of that marker's vertices over those frames (least
 * summed distance to the others, measured in the first frame). info is the first used frame's,
 * with the chosen body; *nused (may be NULL) gets the number of frames that voted. -EINVAL
 * unless more than half of the frames gave that body. frame_no (may be NULL: 0, 1, ...) numbers
 * the frames in messages, as the caller's sequence does. */
int mdl_rig_propose_frames(const float *V, int nv, int nframes, const int *frame_no,
                           const uint32_t *F, int nf, const float up[3], int body, mdl_rig **out,
                           mdl_rig_proposal *info, int *nused, char *err);

/* ------------------------------------------------------------------ models and their kinds (kind.c) */

/* A model is one mesh (rest pose, faces, topology fingerprint, box, fps), optionally the rig that
 * binds markers to it, and one or more *kinds* over that mesh (DESIGN.md, "Model kinds"):
 *   MDL_KIND_STEER     Voegele et al. 2012: driven by markers, trained from an example sequence
 *   MDL_KIND_HARMONIC  de Aguiar et al. 2007: driven by bone directions / joint rotations
 *   MDL_KIND_SKIN      Le & Deng 2012 skinning + Zheng 2013 variations: driven by a clock
 * The first kind is the *primary* one: what mdl_synth_create(m, 0, ...) runs. Everything outside
 * model/ uses only the kind-neutral calls below; training is kind-specific. */
typedef struct mdl_model mdl_model;

enum { MDL_KIND_STEER = 1, MDL_KIND_HARMONIC = 2, MDL_KIND_SKIN = 3 };
#define MDL_MAX_KINDS 4

/* What a kind's synthesis reads (mdl_synth_input), as bits. */
enum {
    MDL_INPUT_MARKERS = 1u << 0, /* marker positions + validity, model marker order */
    MDL_INPUT_JOINTS = 1u << 1,  /* joint rotations (a skeleton source: BVH, ASF/AMC) */
    MDL_INPUT_CLOCK = 1u << 2,   /* time alone (the idle source): no source frames needed */
};

/* "steer", "harmonic", "skin", or NULL for an unknown id. */
const char *mdl_kind_name(int kind);
/* The id for a name, or 0. */
int mdl_kind_from_name(const char *name);

int mdl_model_save(const mdl_model *m, const char *path, char *err);
/* Reads a model file: version 2 (chunks, docs/FORMATS.md) or version 1 (a steering model,
 * converted on load). */
int mdl_model_load(const char *path, mdl_model **out, char *err);
int mdl_model_parse(const uint8_t *buf, size_t len, const char *name, mdl_model **out, char *err);
void mdl_model_destroy(mdl_model *m);

/* Moves every kind of *src into dst (they must share the mesh: MDL_ETOPOLOGY otherwise, and a kind
 * dst already has is refused with -EEXIST), then destroys *src and sets it to NULL. On error
 * nothing changes. So one file holds a steering model and the skin of the same example. */
int mdl_model_merge(mdl_model *dst, mdl_model **src, char *err);

/* Read-only views into the model (valid while the model lives). */
typedef struct mdl_model_info {
    const char *name;
    int kind;              /* the primary kind, MDL_KIND_* */
    int nkinds;
    int kinds[MDL_MAX_KINDS]; /* kinds[0] == kind */
    unsigned inputs;       /* MDL_INPUT_* bits the primary kind's synthesis reads */
    int nv, nf;
    const float *rest;     /* nv x 3, the reference frame */
    const uint32_t *F;     /* nf x 3 */
    uint64_t topology;     /* mdl_topology_fingerprint of F */
    int nmarkers;          /* the rig's markers, what marker-driven kinds read (0: no rig); a
                              primary kind whose inputs lack MDL_INPUT_MARKERS ignores them */
    const mdl_rig_marker *markers;
    int nclusters;         /* parts for colouring (steer: the disjoint clusters); 0 if none */
    const int *part;       /* nv: the part of each vertex, or NULL */
    int ntrain;            /* training frames (0 for a kind built without an example) */
    const int *train_frames;
    double fps;            /* of the example mesh sequence, 0 if unknown */
    float bbox_min[3], bbox_max[3]; /* box of all training frames (or the rest pose) */
    int virtual_markers;   /* 1 when trained without a marker recording */
} mdl_model_info;

void mdl_model_get_info(const mdl_model *m, mdl_model_info *info);

/* Writes a human-readable summary (what `meshsteer inspect` prints) into buf. */
int mdl_model_describe(const mdl_model *m, char *buf, size_t len);

/* The training report (JSON) as a newly allocated string (cJSON_Print; free() it), or NULL. */
char *mdl_model_report_json(const mdl_model *m);

/* Maps source labels to model markers: map[i] = index into `names` of model marker i, or -1.
 * Returns how many model markers stay unbound. */
int mdl_model_bind_markers(const mdl_model *m, const char *const *names, int count, int *map);

/* ------------------------------------------------------------------ the steering model (paper 2012, steer/) */

typedef void (*mdl_progress_fn)(void *ud, const char *stage, double fraction);

typedef struct mdl_train_opts {
    int clusters;          /* 0 = automatic (Sec. 4.5) */
    int max_clusters;      /* upper bound for the automatic choice; -1: chosen by the selection
                              (select.h) among 24 and 12, 24 without it. Fields marked "-1:
                              selected" below work the same way: a value given is kept, -1 leaves
                              it to the cross-validated selection (virtual markers only) */
    double rigid_tol;      /* automatic clustering stops when the RMS rigid-fit residual of every
                              cluster is below this fraction of the bounding-box diagonal */
    int overlap_rings;     /* rings of neighbours added to each cluster (Sec. 4.5 overlaps); -1:
                              selected among 2, 1 and 3 (2 without selection) */
    double explained;      /* fraction of shape variance kept per cluster (Sec. 4.4) */
    int max_modes;         /* upper bound on modes per cluster; -1: selected among 6 and 3 (6) */
    double ridge;          /* Tikhonov regularisation of Phi and Psi (eq. 5), on standardised inputs;
                              -1: chosen by leave-one-out error, and with the selection also
                              tried against a fixed 1 (stiffer where noise matters); -2: leave-one-
                              out, never searched */
    int linear;            /* 1: the purely linear regression of eq. 5; 0: with radial basis
                              features (regress.h); -1: automatic, radial basis with virtual
                              markers (interpolating the example's own poses), linear with a
                              recording of another performer (smooth where the relation is loose) */
    double beta;           /* shape prior weight of eq. 7 */
    int iterations;        /* alternating rigid/shape iterations at synthesis (Sec. 5) */
    int use_motion_dir;    /* include directions of movement d_m (Table 1) in the features; -1:
                              selected (off without selection) */
    double marker_weight;  /* markers as alignment targets at synthesis (synth.c); < 0: automatic,
                              1 with virtual markers (they live in the mesh's space), else 0 */
    int relax;             /* alignment sweeps against all neighbours after the greedy pass */
    int align_samples;     /* shared vertices per instance used by alignment and eq. 7 (0: all) */
    double train_noise;    /* with virtual markers: standard deviation (m) of the marker noise the
                              regressions are taught to ignore, by noisy copies of each frame;
                              -1: selected among 0, select_noise / 2 and select_noise (0) */
    int noise_copies;      /* how many noisy copies of each training frame */
    int select_folds;      /* with virtual markers, the options left at -1 are chosen by
                              leave-a-block-out cross-validation over this many time blocks of
                              the training frames (select.h); 0 = no selection (the defaults).
                              mdl_train_opts_default gives 0 (training of the built-in example in
                              ~0.2 s instead of ~6 s CPU); `meshsteer train` defaults to 3 */
    double select_noise;   /* marker noise (m, per axis) of the selection's noisy validation */
    double filter_noise;   /* with virtual markers: the marker noise (m) synthesis filters its
                              input markers for (steer/mfilter.h); 0 = no filter; -1: selected
                              between 0 and select_noise (0 without selection) */
    double kblend;         /* with virtual markers: > 0 synthesises by the kernel blend of the
                              training meshes with this bandwidth factor (steer/kblend.h) instead
                              of the part model; 0 = the part model; -1: selected among 0 and
                              MDL_KBLEND_H (0 without selection) */
    const char *name;      /* model name, stored in the file */
    mdl_progress_fn progress;
    void *progress_ud;
} mdl_train_opts;

void mdl_train_opts_default(mdl_train_opts *o);

/* Trains from mesh frames `frames[0..nframes)` of `seq`. With `markers` NULL the rig vertices'
 * own trajectories are the markers (virtual markers); otherwise the rig's `source` names select
 * the markers and pose adaption (Sec. 4.2) maps the recording onto the mesh frames. The result is
 * a model whose primary kind is MDL_KIND_STEER. */
int mdl_steer_train(const mdl_meshseq *seq, const int *frames, int nframes, const mdl_rig *rig,
                    const mdl_markers *markers, const mdl_train_opts *o, mdl_model **out, char *err);

/* ------------------------------------------------------------------ the harmonic model (de Aguiar 2007, harmonic/) */

/* A static mesh animated without an example (de Aguiar et al. 2007): rotations at a few
 * correspondence triangles are interpolated over the mesh as harmonic fields of quaternion
 * components (Sec. 4.1 eq. 1-2) and the rotated triangles glued back by a Poisson solve (eq. 3-4).
 * Driven by markers (MDL_INPUT_MARKERS): the template is a skeleton whose bones are pairs of
 * markers (BVH / ASF/AMC joint positions, or any marker source); a bone's rotation is the rotation
 * of its rest direction onto its current one, its twist from a third marker where the rig names one
 * (docs/MODEL.md says what is lost without it). Driven by joint rotations (MDL_INPUT_JOINTS; a
 * model whose template_rest had mdl_markers.rot): a bone over a chain of the template's skeleton
 * turns with the segment ending at its far marker, R_j(t) R_j(rest)^T composed with the rest fit,
 * twist included; per bone, an invalid joint falls back to the markers. */
typedef struct mdl_harmonic_opts {
    int auto_k;           /* > 0: K correspondences by farthest-point sampling, each its own group,
                             no template (a model measured on its own sequence: `auto:K`) */
    int rings;            /* with auto_k: each sample grown to a cross-section ring (the triangles in
                             a slab normal to the local principal axis, `rings:K`) instead of a patch */
    int per_bone;         /* with a rig: automatic correspondence triangles per bone (Sec. 4.2) */
    const int *given_off; /* with a rig, may be NULL: per bone (rig limb) user triangles, */
    const int *given_idx; /*   given_idx[given_off[b] .. given_off[b+1]), completed by cross-section */
    int fit_rest;         /* with a rig: 1 poses each bone below the root onto the target's limb
                             it lies in before correspondences are chosen (rest_fit.c: a mocap
                             rest pose is not the scan's T-pose); 0 (default) keeps the template's
                             rest directions (docs/MODEL.md: why it is not the default yet) */
    const char *name;     /* model name */
    const mdl_markers *template_motion; /* may be NULL: the template's motion (a BVH's frames, as
                             synthesis will see them); its lowest marker over all frames is the
                             floor put on the target's floor. NULL: the rest pose's lowest marker */
} mdl_harmonic_opts;

void mdl_harmonic_opts_default(mdl_harmonic_opts *o);

/* A harmonic model's correspondence triangles (n of them) and the group (template bone, or auto:K
 * patch) of each, borrowed from the model. Returns -EINVAL (and n = 0) for a model without the
 * harmonic kind. */
int mdl_harmonic_correspondences(const mdl_model *m, const int **tri, const int **group, int *n,
                                 int *ngroups);

/* The correspondences file (formats/corr.c, docs/FORMATS.md): per rig limb ([from, to] marker
 * names) target triangles in 0..nf-1. Out: off (rig->nlimbs + 1) and idx as given_off and
 * given_idx of mdl_harmonic_opts; the caller frees both. Bad input: MDL_EFORMAT naming the file and
 * the JSON path. */
int mdl_corr_parse(const char *buf, size_t len, const char *name, const mdl_rig *rig, int nf,
                   int **off, int **idx, char *err);
int mdl_corr_read(const char *path, const mdl_rig *rig, int nf, int **off, int **idx, char *err);

/* Builds a harmonic model over `target`. With o->auto_k > 0, rig and template_rest may be NULL.
 * Otherwise the rig's limbs are the template's bones ([from, to] or [from, to, twist] marker
 * names), reference[0] its root, and template_rest (frame 0) holds the rig's `source` labels in the
 * template's rest pose; it is aligned to the target by scale (height) and translation (feet on the
 * target's floor, centres over each other), both facing the same way. Marker frames at synthesis
 * are mapped with the same scale, the mocap's floor (o->template_motion) on the target's floor. The model's rig is a copy of
 * `rig` whose vertices are the target vertices nearest the aligned joints. */
int mdl_harmonic_build(const mdl_mesh *target, const mdl_rig *rig, const mdl_markers *template_rest,
                       const mdl_harmonic_opts *o, mdl_model **out, char *err);

/* ------------------------------------------------------------------ synthesis, any kind */

typedef struct mdl_synth mdl_synth;

/* One frame's input. Each kind reads the parts its info.inputs names and ignores the rest. */
typedef struct mdl_synth_input {
    const float *markers;     /* MDL_INPUT_MARKERS: nmarkers x 3 in model marker order (metres) */
    const uint8_t *valid;     /* nmarkers, 1 = present; NULL = all valid */
    int njoints;              /* MDL_INPUT_JOINTS: joints in the kind's joint order; the harmonic
                                 kind's are its markers' (model marker order, mdl_model_info):
                                 joint i is the segment ending at marker i (mdl_markers.rot) */
    const float *joint_rot;   /* njoints x 4 unit quaternions (w, x, y, z), world frame, as
                                 mdl_markers.rot (relative to the skeleton's rest pose); NULL: none */
    const uint8_t *joint_valid; /* njoints; NULL = all valid */
    double t;                 /* MDL_INPUT_CLOCK: seconds since the synthesis started */
} mdl_synth_input;

typedef struct mdl_synth_info {
    int markers_missing;  /* markers invalid in this frame */
    int markers_held;     /* of those, replaced by their last valid position */
    int reference_lost;   /* the reference edge was not available: the last body frame was kept */
    int joints_used;      /* harmonic: bones driven by their joint's rotation (MDL_INPUT_JOINTS)
                             this frame; the others took the direction path */
    double joint_arc_max; /* harmonic: the largest turn (radians) that brought a joint-driven bone
                             onto its markers' direction (0 for a one-segment bone; a chain's bend) */
} mdl_synth_info;

/* All memory for synthesis is allocated here; mdl_synth_frame allocates nothing. One mdl_synth per
 * thread; the model may be shared read-only between several. `kind` 0 is the primary kind; another
 * MDL_KIND_* picks that kind of the model (-ENOENT if it has none). */
int mdl_synth_create(const mdl_model *m, int kind, mdl_synth **out, char *err);
void mdl_synth_destroy(mdl_synth *s);
/* The MDL_INPUT_* bits this synthesis reads (of this model: a harmonic model reads
 * MDL_INPUT_JOINTS only when its template was a skeleton). */
unsigned mdl_synth_inputs(const mdl_synth *s);
/* V: nv x 3 output. info may be NULL. Returns 0, or -EAGAIN while the input does not yet allow a
 * frame (e.g. no reference was ever seen). */
int mdl_synth_frame(mdl_synth *s, const mdl_synth_input *in, float *V, mdl_synth_info *info);
/* The common case of a marker-driven kind: in = {markers, valid}. */
int mdl_synth_markers(mdl_synth *s, const float *markers, const uint8_t *valid, float *V,
                      mdl_synth_info *info);
/* Forgets held markers and motion history (seek, new performer). */
void mdl_synth_reset(mdl_synth *s);

/* The compact form of a synthesis (the "params" encoding of docs/PROTOCOL.md), for the kinds whose
 * output is exactly a weighted blend of rigidly placed shapes (paper 2012 Sec. 4.4 eq. 6 and
 * Sec. 5.3 eq. 8; linear blend skinning for the skin, Le & Deng 2012):
 *   V_v = sum_{s < slots, w_vs != 0} w_vs (R_i (mean_e + sum_a lambda_ia mode_pa[e]) + t_i),
 *   i = slot_inst[v, s], e = slot_entry[v, s], p = inst_part[i],
 * with R_i, t_i and lambda_i the per-frame parameters (mdl_synth_params) and everything else the
 * layout, fixed at mdl_synth_create. The steering kind: pieces are the instances (a part within a
 * limb), shapes the parts' means and PCA modes, slots the blend weights of eq. (8); nothing follows
 * the blend, so the formula is the synthesis itself (float, the same values). The skin: pieces are
 * the bones, one shape (the rest pose, no modes), slots the skin's K weights. */
typedef struct mdl_params_layout {
    int kind;              /* MDL_KIND_* it describes */
    int ninst;             /* pieces: one rigid transform (+ coefficients) each per frame */
    int nparts;            /* shapes: a mean and modes each */
    const int *part_off;   /* nparts + 1: entries of part p are [part_off[p], part_off[p + 1]) */
    const float *mean;     /* part_off[nparts] x 3: mean local positions (metres) */
    const int *nmodes;     /* nparts: modes k_p */
    const int *mode_off;   /* nparts: offset of part p's modes in `modes` (floats) */
    const float *modes;    /* per part, k_p blocks of n_p x 3 (mode a of entry j at
                              mode_off[p] + (a n_p + j) 3) */
    const int *inst_part;  /* ninst: the shape of each piece */
    int slots;             /* blend slots per vertex */
    const int *slot_entry; /* nv x slots: entry (into mean, global), -1 where unused */
    const int *slot_inst;  /* nv x slots: piece, -1 where unused */
    const float *slot_w;   /* nv x slots: weight, 0 where unused */
    int nparams;           /* floats of one frame's parameters: sum_i (7 + k_{inst_part[i]}) */
} mdl_params_layout;

/* The layout of s (valid while s lives); -ENOTSUP when its kind has no compact form (harmonic:
 * its Poisson solve couples every vertex). */
int mdl_synth_params_layout(const mdl_synth *s, mdl_params_layout *out);
/* The parameters of the last frame mdl_synth_frame made: per piece in order a unit quaternion
 * (w, x, y, z) of R_i, t_i (3), then lambda_i (k of its shape), layout.nparams floats into out.
 * -ENOTSUP without a compact form, -EAGAIN before the first frame. Allocates nothing. */
int mdl_synth_params(const mdl_synth *s, float *out);
/* The similarity a kind applies to the markers it reads before using them, p' = scale p + t
 * (harmonic: the template's alignment to the target, Sec. 5; others: the identity), so that a
 * viewer can draw the markers where the model sees them, beside its mesh. */
void mdl_synth_marker_placement(const mdl_synth *s, double *scale, double t[3]);

/* Limits BLAS to n threads (the daemon and the benchmarks own their threads: n = 1). */
void mdl_set_blas_threads(int n);

/* ------------------------------------------------------------------ evaluation helpers */

/* Error after best rigid alignment (Kabsch, rigid.c): per-vertex distances into `dist` (nv), may be NULL.
 * Returns the mean distance. */
double mdl_rigid_aligned_error(const float *A, const float *B, int n, float *dist);

/* Quality against ground truth (eval.c, DESIGN.md "Quality, measured"): drives the model with
 * virtual markers (the rig vertices of the given ground-truth frames, in order), optionally with
 * Gaussian noise (standard deviation noise_m per axis, metres) and each marker dropped with
 * probability drop, and compares every vertex after best rigid alignment, as a fraction of the
 * rest mesh's bounding-box diagonal. The baseline picks, per frame, the training frame whose rig
 * markers match the (noisy, surviving) markers best after rigid alignment. */
typedef struct mdl_eval_opts {
    double noise_m;
    double drop;
    uint64_t seed;
    int harmonic_stretch; /* the harmonic kind: drive with rotation and stretch (eval --stretch) */
} mdl_eval_opts;

typedef struct mdl_eval_result {
    int frames;
    double mean_err, p95_err, max_err;   /* fractions of the diagonal */
    double marker_err;                   /* mean error at the rig vertices */
    double baseline_nn_mean_err, baseline_nn_p95_err;
    double max_bbox_excess;  /* how far any output vertex left the training box, / diagonal */
    int nan_count;           /* non-finite output coordinates */
    int markers_dropped;
    int frames_skipped;      /* frames the model could not synthesise (no reference yet) */
    double rmse;             /* root mean square vertex error, mesh units (0: not computed) */
    double rmse_over_diag;   /* rmse over the rest box diagonal */
    double *synth_us;        /* per frame synthesis time, allocated (frames) */
    double *frame_err;       /* per frame mean error, allocated (frames) */
    double *baseline_frame_err;
    const char *baseline_name; /* the baseline's JSON key stem, e.g. "baseline_nearest" (the
                                  harmonic kind), or NULL for the nearest-frame "baseline_nn" */
    const char *mode;        /* the harmonic kind: "rotation" or "rotation+stretch"; else NULL */
    double oracle_mean_err;  /* the harmonic kind: every triangle its measured rotation (and
                                stretch), the same glue: the floor of the mode */
} mdl_eval_result;

/* The mesh must have the model's topology (MDL_ETOPOLOGY otherwise). Runs the primary kind's own
 * evaluation (-ENOTSUP for a kind that has none). */
int mdl_eval_run(const mdl_model *m, const mdl_meshseq *seq, const int *frames, int n,
                 const mdl_eval_opts *o, mdl_eval_result *r, char *err);
void mdl_eval_result_fini(mdl_eval_result *r);

/* ------------------------------------------------------------------ the skin (Le & Deng 2012, skin/) */

/* A parallel-for supplied by the caller (model/ creates no threads): run body(ctx, i, worker) for
 * every i in [0, n), each exactly once, with worker in [0, workers) and no two concurrent calls
 * sharing a worker index; return when all are done. */
typedef void (*mdl_parallel_body)(void *ctx, int i, int worker);
typedef void (*mdl_parallel_fn)(void *ud, int n, mdl_parallel_body body, void *ctx);

typedef struct mdl_skin_opts {
    int bones;             /* N, the number of bones (rigid transforms per frame) */
    int max_influences;    /* K, non-zero weights per vertex at most */
    int iterations;        /* alternations at most (weights, then transforms) */
    double tolerance;      /* stop when the RMSE improved by less than this fraction ... */
    int patience;          /* ... this many times in a row */
    int init_iterations;   /* label/transform iterations after each split of the initialisation */
    int transform_sweeps;  /* per-bone Procrustes passes per alternation */
    double smooth;         /* weight smoothness over the mesh edges (0: off), relative: the
                              penalty is smooth * frames * diag^2 * |w_i - mean of neighbours|^2 */
    uint64_t seed;         /* recorded; the fit makes no random choices (it is deterministic) */
    const float *rest;     /* nv x 3 rest pose, or NULL for the first fitted frame */
    const char *name;      /* model name */
    int workers;           /* the parallel-for's worker count (1 without one) */
    mdl_parallel_fn parallel; /* NULL: serial */
    void *parallel_ud;
    mdl_progress_fn progress;
    void *progress_ud;
} mdl_skin_opts;

/* bones 20, max_influences 4, iterations 100, tolerance 1e-3, patience 3, init_iterations 5,
 * transform_sweeps 2, smooth 0, seed 1, serial. */
void mdl_skin_opts_default(mdl_skin_opts *o);

typedef struct mdl_skin_stats {
    int bones, max_influences, frames, vertices, iterations;
    double rmse;           /* root mean square vertex error over the fitted frames, mesh units */
    double rmse_over_diag; /* over the rest mesh's bounding-box diagonal */
    double max_err;        /* the largest vertex error, mesh units */
    double diag;           /* the rest box diagonal */
    double seconds;        /* wall time of the fit */
} mdl_skin_stats;

/* Fits a skin to frames[0..n) of seq: a model whose primary kind is MDL_KIND_SKIN, over the rest
 * pose (o->rest or the first fitted frame) and seq's faces. Its synthesis (MDL_INPUT_CLOCK) plays
 * the fitted bone animation, looping at seq->fps (30 when unknown); its eval fits the bone
 * transforms of other frames with the weights fixed. -EDOM when the mesh cannot support
 * o->bones bones (fewer vertices than 3 per bone). */
int mdl_skin_fit(const mdl_meshseq *seq, const int *frames, int n, const mdl_skin_opts *o,
                 mdl_model **out, char *err);
/* The fit's figures; -ENOENT when m holds no skin. */
int mdl_skin_get_stats(const mdl_model *m, mdl_skin_stats *st);
/* The skin's weights as K slots per vertex (bone index, weight; unused slots weight 0) and its
 * bone transforms of fitted frame f (nb x 12: R row-major, then t); pointers valid while m lives. */
int mdl_skin_get(const mdl_model *m, int *nb, int *K, int *nframes, const int **bone,
                 const double **w, const double **T);
/* Linear blend skinning (lbs.c, Zheng 2013 eq. 1): V (nv x 3) = the rest points (nv x 3) moved by
 * the bone transforms T (nb x 12, as mdl_skin_get's, one frame) with K slots of bone and w per
 * vertex. */
void mdl_skin_lbs(int nv, int K, const int *bone, const double *w, const float *rest,
                  const double *T, float *V);
/* glTF 2.0 binary (.glb, gltf.c): the rest mesh, one joint per bone, JOINTS_0/WEIGHTS_0 and one
 * animation (translation + rotation per bone per fitted frame). close_loop: one more key at
 * N / fps equal to frame 0, so that an engine looping the clip plays the skin's loop (frame N - 1
 * to frame 0 in one frame's time) instead of jumping; 0: the clip ends at frame N - 1. K <= 4. */
int mdl_skin_write_gltf(const mdl_model *m, const char *path, int close_loop, char *err);
/* The same writer, clip by clip (several animations on one skinned mesh, e.g. the variations):
 * begin takes the skin's mesh, weights and rest (K <= 4); each clip is `frames` bone transforms
 * (frames x nb x 12, as mdl_skin_get's T) at fps, as one animation named `name` (close_loop as
 * above); write makes the .glb (the writer can take more clips after); free frees. */
typedef struct mdl_gltf mdl_gltf;
int mdl_gltf_begin(const mdl_model *m, mdl_gltf **out, char *err);
int mdl_gltf_add_clip(mdl_gltf *g, const char *name, const double *T, int frames, double fps,
                      int close_loop, char *err);
int mdl_gltf_write(mdl_gltf *g, const char *path, char *err);
void mdl_gltf_free(mdl_gltf *g);

/* ------------------------------------------------------------------ variations (Zheng 2013, variations/) */

/* Endless different animations from one example, on the bones of its skin (Zheng 2013, Sec. 3-4):
 * transitions between frames whose reduced, rigid-invariant bone coordinates are close (Sec. 3.2),
 * spliced with the reference bone matched rigidly (eq. 7) and the other bones blended over a
 * window in its frame, through the deformation gradients at key vertices (Sec. 3.3, eq. 8-9) or
 * linearly in their coordinates (the comparison of Fig. 6), walked at random on the motion graph
 * (Sec. 3.4), meeting targeted frames and avoiding static obstacles; optionally per component between the cut nodes of the
 * bone graph, merged by Algorithm 1 (Sec. 4). The output is bone transforms (compact, resolution-independent); vertices come from
 * the skin only when asked. docs/MODEL.md says where this departs from the paper. */
typedef struct mdl_variations mdl_variations;

typedef struct mdl_variations_opts {
    double svd_tol;     /* eq. 4: singular values below svd_tol x the largest are dropped */
    double tc_factor;   /* T_c = tc_factor x max_i D(i, i-1) (Sec. 3.2) ... */
    double threshold;   /* ... unless > 0: T_c itself */
    int min_gap;        /* transitions (i, j) need |i - j| > min_gap (a frame is close to its
                           neighbours; only other valleys of D(i, .) are transitions) */
    int blend;          /* output frames over which a splice is blended (0: none) */
    int blend_linear;   /* 0: Sec. 3.3's gradient-domain blend (key vertices, eq. 8-9); 1: the
                           linear blend of the bones' local coordinates (Fig. 6's comparison) */
    double jump_prob;   /* per output frame, the chance of taking a transition where one is open */
    double temperature; /* which one: chance ~ exp(-D / (temperature x max_i D(i, i-1))), as in
                           video textures (Schoedl et al. 2000); 0: uniform */
    int min_segment;    /* output frames between two transitions at least (unless at a dead end) */
    int start;          /* the input frame walks start at; -1: a random one (of the seed) */
    int components;     /* Sec. 4: 1 one component; 0 (auto) the blocks between the cut nodes of
                           the bone graph, synthesised apart and merged (Algorithm 1) */
    double te_factor;   /* Sec. 4.1: bone graph edges below te_factor x max d_ij are dropped */
    int ground;         /* Sec. 5: the reference bone moved only on the ground plane (a turn
                           about the up axis y and a horizontal shift) at a splice */
} mdl_variations_opts;

/* svd_tol 0.005, tc_factor 1/40 (the paper prints 40; docs/MODEL.md says why not), threshold 0,
 * min_gap 3, blend 8, blend_linear 1 (linear: as smooth as the gradient blend on every sequence measured, at 1/40 of its cost; docs/MODEL.md), jump_prob 0.2, temperature 0.1, min_segment 8, start -1, components 1,
 * te_factor 0.1, ground 0 (the paper's values where it gives them). */
void mdl_variations_opts_default(mdl_variations_opts *o);

typedef struct mdl_variations_stats {
    int bones, frames;  /* of the skin */
    int ref_bone;       /* b_r: the bone of the largest weight sum */
    int rank;           /* length of the reduced coordinates q_i (eq. 4) */
    int transitions;    /* directed candidate transitions (i, j) */
    int alive_frames;   /* frames from which a walk can go on for ever */
    double alpha, beta; /* the weights of eq. 5 */
    double max_adjacent;/* max_i D(i, i-1) */
    double tc;          /* T_c (of the whole skin's graph) */
    int components;     /* 1, or the components synthesised apart (Sec. 4) */
    int single_transitions; /* transitions of the whole skin's graph (= transitions with one
                           component; with several, transitions sums the components') */
    int key_vertices;   /* the gradient blend's key vertices (Sec. 3.3; the components' sum;
                           0 with the linear blend or no blend) */
} mdl_variations_stats;

/* The transition graph of the skin in m (-ENOENT when m holds none; -EDOM with fewer than 4
 * frames or more than 16384, or fewer than 2 bones). o may be NULL for defaults. Allocates *out (mdl_variations_destroy); m may be
 * destroyed afterwards (the graph keeps what it needs). */
int mdl_variations_build(const mdl_model *m, const mdl_variations_opts *o, mdl_variations **out,
                         char *err);
void mdl_variations_destroy(mdl_variations *v);
void mdl_variations_get_stats(const mdl_variations *v, mdl_variations_stats *st);
/* Transition k (0 <= k < transitions): frames (from, to) and its cost D. -ERANGE otherwise. */
int mdl_variations_transition(const mdl_variations *v, int k, int *from, int *to, double *cost);
/* Component c (0 <= c < components; 0 the anchor, parents before children): its bones (global
 * ids, ascending; valid while v lives; NULL with one component: all of them), its cut node shared with its parent component (-1 for
 * component 0), the parent, its reference bone and its transitions. -ERANGE otherwise. */
typedef struct mdl_variations_component {
    int nbones;
    const int *bones;
    int cut, parent, ref_bone, transitions, alive_frames;
    double tc;
} mdl_variations_component;
int mdl_variations_get_component(const mdl_variations *v, int c, mdl_variations_component *out);
/* Transition k of component c (as mdl_variations_transition for the whole graph). */
int mdl_variations_component_transition(const mdl_variations *v, int c, int k, int *from, int *to,
                                        double *cost);
/* D(i, j) of eq. 5 for 1 <= i, j < frames (NAN otherwise). */
double mdl_variations_cost(const mdl_variations *v, int i, int j);
/* A random walk of `frames` output frames, reproducible from `seed`: T (frames x bones x 12, R
 * row-major then t, as mdl_skin_get) gets the bone transforms; V (frames x nv x 3, may be NULL)
 * the skinned vertices; src (frames x components, may be NULL) the input frame of each output
 * frame in each component. With several components, each walks on its own graph from a common
 * start frame and they are merged by Algorithm 1 (eq. 12-14); a component whose cut node's
 * stretch does not match (D_C >= its T_c) is walked again with another seed (16 tries, then
 * -EAGAIN). -ENOENT when the graph has no frame a walk can go on for ever from (no transitions). */
int mdl_variations_walk(const mdl_variations *v, uint64_t seed, int frames, double *T, float *V,
                        int *src, char *err);
/* Skins one frame of bone transforms T (bones x 12) into V (nv x 3). */
void mdl_variations_skin_frame(const mdl_variations *v, const double *T, float *V);
/* Targeted frames (Sec. 3.4): input frame `in` must be shown at output frame `out`. */
typedef struct mdl_variations_target {
    int in, out;
} mdl_variations_target;
/* mdl_variations_walk meeting targets[0..nt) exactly (src[out] = in in every component): the
 * walk's choices restricted to input frames from which the later targets can still be met.
 * -EINVAL for a frame out of range or an output frame targeted twice, -ENOENT when no walk meets
 * them (the transitions do not connect the frames in the time given). */
int mdl_variations_walk_targets(const mdl_variations *v, uint64_t seed, int frames,
                                const mdl_variations_target *targets, int nt, double *T, float *V,
                                int *src, char *err);
/* Sec. 3.4's overlap of two walks' src (frames x components, as mdl_variations_walk gives): the
 * fraction of output frames where every component shows the same input frame (overlap.c). */
double mdl_variations_overlap(const int *src_a, const int *src_b, int frames, int components);
/* Makes the skin of m play an endless random walk (seed, o: NULL for defaults) on its example's
 * transition graph instead of looping the fitted frames: mdl_synth_create of the skin kind then
 * rebuilds the graph, and mdl_synth_frame at clock t shows the walk's frame t x fps (the
 * daemon's idle source). Stored in the model file (the SKIN chunk, docs/FORMATS.md). -ENOENT
 * without a skin; the errors of mdl_variations_build, and -ENOENT when no walk can go on. */
int mdl_variations_attach(mdl_model *m, const mdl_variations_opts *o, uint64_t seed, char *err);
/* 1 when the skin of m walks (*o, *seed filled; either may be NULL), else 0. */
int mdl_variations_attached(const mdl_model *m, mdl_variations_opts *o, uint64_t *seed);

/* Collision avoidance against static objects (Sec. 3.4, variations/avoid.c). An obstacle: the
 * triangles of meshes[0..n) together (in the skin's world frame), with an AABB tree over them
 * (core/aabb_tree.c). -EINVAL when they hold no triangle. Read-only after create: any number of
 * threads may test against one. */
typedef struct mdl_obstacle mdl_obstacle;
int mdl_obstacle_create(const mdl_mesh *const *meshes, int n, mdl_obstacle **out, char *err);
void mdl_obstacle_destroy(mdl_obstacle *o);
/* Its triangles and box (any argument may be NULL). */
void mdl_obstacle_get_info(const mdl_obstacle *o, int *triangles, float lo[3], float hi[3]);
/* 1 when the surface V (xyz) with triangles F (nf x 3) intersects the obstacle's: a triangle of
 * each share a point (Möller's test, core/tri_tri.c; touching counts); else 0. Allocates
 * nothing. */
int mdl_obstacle_hits(const mdl_obstacle *o, const float *V, const uint32_t *F, int nf);
/* flags[n] (the skin's frames) = 1 where fitted frame n, skinned, intersects o (F: the skin's
 * triangles, nf of them). */
int mdl_variations_colliding_frames(const mdl_variations *v, const mdl_obstacle *o,
                                    const uint32_t *F, int nf, uint8_t *flags, char *err);
/* Keeps every later walk of v (all components) off the frames with blocked[n] (and off frames
 * from which every walk must reach one): they leave the graph's alive frames. NULL: none
 * blocked. With components, one that could then not go on at all keeps every frame. -ENOENT
 * when no walk can go on any more (with components: in none of them). */
int mdl_variations_block_frames(mdl_variations *v, const uint8_t *blocked, char *err);
/* mdl_variations_walk_targets (V NULL) whose every output frame, skinned into V (scratch: nv x
 * 3), is tested against o (NULL: none); a walk with a colliding frame is discarded and the next
 * seed (a function of `seed` and the try) walked, max_tries walks at most, then -EAGAIN.
 * *used_seed gets the seed of the walk returned (mdl_variations_walk_targets with it gives the
 * same frames) and *redraws the walks discarded (either may be NULL). */
int mdl_variations_walk_avoiding(const mdl_variations *v, const mdl_obstacle *o,
                                 const uint32_t *F, int nf, uint64_t seed, int frames,
                                 const mdl_variations_target *targets, int nt, int max_tries,
                                 double *T, int *src, float *V, uint64_t *used_seed, int *redraws,
                                 char *err);

/* A Python-style slice (frames.c) "start:stop[:step]" (also "N" and ":"), resolved against `count`.
 * Allocates *idx. */
int mdl_parse_frames(const char *spec, int count, int **idx, int *n, char *err);

/* The built-in example (example.c): a procedurally generated four-legged creature (about 4800
 * vertices, 1.7 m long, Y up, facing +X) with bulging limbs, its rig, and a marker recording of a
 * different gait. Deterministic: equal arguments give identical bytes.
 * mdl_example_create: `frames` frames (1..100000) of a walk in place at 30 fps into *seq, and the rig
 *   into *rig (either may be NULL): markers lf_foot rf_foot lh_foot rh_foot head tail withers croup;
 *   reference withers-croup; limbs withers-lf_foot, withers-rf_foot, croup-lh_foot, croup-rh_foot,
 *   withers-head, croup-tail. Free with mdl_meshseq_destroy / mdl_rig_destroy (each array and the
 *   struct are separately malloc'd).
 * mdl_example_markers: the rig vertices' positions during a trot of the same creature, `speed` times
 *   the walk's cycle rate (1 = same rate), with other amplitudes and starting phase: names = the rig's
 *   source names, fps 30, all valid (struct, P, valid, names and each names[i] separately malloc'd;
 *   mdl_markers_destroy). *truth (may be NULL) gets the matching ground-truth mesh frames. */
int mdl_example_create(int frames, mdl_meshseq **seq, mdl_rig **rig, char *err);
int mdl_example_markers(const mdl_rig *rig, int frames, double speed, mdl_markers **out,
                        mdl_meshseq **truth, char *err);

#ifdef __cplusplus
}
#endif
#endif
