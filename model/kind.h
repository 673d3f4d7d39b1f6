/* kind.h - what a model kind implements, and the model that holds kinds (kind.c, formats/modelfile.c).
 * Not part of the public interface: server/ sees only model.h.
 *
 * A kind is a table of functions (like drivers/source.c's schemes). The kind-neutral calls of
 * model.h (info, describe, report, synthesis, eval) dispatch through it, so a new kind needs no
 * change outside model/: add its table to kind.c's registry, a chunk tag, and its own train call.
 *
 * The model owns the mesh (rest pose, faces, fingerprint, box, fps) and the rig; each kind's state
 * (`impl`) may keep its own copies of what it needs at synthesis and sees the model read-only.
 */
#ifndef MESHSTEER_KIND_H
#define MESHSTEER_KIND_H

#include "model.h"
#include "formats/chunkio.h"

typedef struct mdl_kind_ops {
    int id;              /* MDL_KIND_* */
    const char *name;    /* mdl_kind_name */
    char tag[4];         /* its chunk in the model file (docs/FORMATS.md) */
    unsigned inputs;     /* MDL_INPUT_* bits its synthesis reads */
    /* The bits this model's synthesis reads, when they depend on the model (a harmonic model
     * whose template has no skeleton reads no joints); NULL: `inputs`. */
    unsigned (*inputs_of)(const void *impl);

    void (*destroy)(void *impl);
    /* The chunk payload, and back. parse sees the model's mesh and rig (already read: the MESH and
     * RIG chunks come first) and validates every count and index of its own chunk. */
    void (*save)(const void *impl, const mdl_model *m, mdl__wbuf *b);
    int (*parse)(mdl__rbuf *b, const mdl_model *m, void **impl);

    /* Fills the kind-specific fields of info (parts, training frames, ...); may be NULL. */
    void (*info)(const void *impl, mdl_model_info *info);
    /* Appends its part of `meshsteer inspect` at buf + *at (len is the whole buffer). */
    void (*describe)(const void *impl, const mdl_model *m, char *buf, size_t len, size_t *at);
    /* Adds its training report fields to a cJSON object (void * to keep cJSON out of this header). */
    void (*report)(const void *impl, const mdl_model *m, void *cjson_object);

    /* Synthesis: create allocates everything, frame nothing. */
    int (*synth_create)(const mdl_model *m, const void *impl, void **state, char *err);
    int (*synth_frame)(void *state, const mdl_synth_input *in, float *V, mdl_synth_info *info);
    void (*synth_reset)(void *state);
    void (*synth_destroy)(void *state);
    /* The compact form of the synthesis (model.h, mdl_params_layout); both NULL when the kind
     * has none. params fills layout.nparams floats from the last frame, -EAGAIN before one. */
    int (*synth_params_layout)(const void *state, mdl_params_layout *out);
    int (*synth_params)(const void *state, float *out);
    /* Where the synthesis puts its input markers: p' = scale p + t (mdl_synth_marker_placement);
     * NULL for a kind that reads them as they are. */
    void (*synth_marker_placement)(const void *state, double *scale, double t[3]);

    /* Quality against ground truth (model.h, mdl_eval_run); NULL when the kind has none. */
    int (*eval)(const mdl_model *m, const mdl_meshseq *seq, const int *frames, int n,
                const mdl_eval_opts *o, mdl_eval_result *r, char *err);
} mdl_kind_ops;

typedef struct mdl_kind_slot {
    const mdl_kind_ops *ops;
    void *impl;
} mdl_kind_slot;

struct mdl_model {
    char name[MDL_NAME_LEN];
    /* the mesh chunk */
    int nv, nf;
    float *rest;            /* nv x 3 */
    uint32_t *F;            /* nf x 3 */
    uint64_t topology;
    double fps;
    float bbox_min[3], bbox_max[3];
    /* the rig chunk; NULL for a model driven by no markers */
    mdl_rig *rig;
    /* kinds[0] is the primary kind */
    int nkinds;
    mdl_kind_slot kinds[MDL_MAX_KINDS];
};

struct mdl_synth {
    const mdl_kind_ops *ops;
    void *state;
    unsigned inputs; /* ops->inputs, or inputs_of(impl) */
};

/* The registry: the table of a kind id or chunk tag, or NULL. */
const mdl_kind_ops *mdl__kind_ops(int id);
const mdl_kind_ops *mdl__kind_ops_by_tag(const char tag[4]);
/* The slot of a kind in m (0: the primary one), or NULL. */
const mdl_kind_slot *mdl__model_kind(const mdl_model *m, int id);

/* A new model over a copy of the given mesh and rig (rig may be NULL), holding no kind yet; the
 * topology fingerprint is computed here. */
int mdl__model_create(const char *name, const float *rest, int nv, const uint32_t *F, int nf,
                      double fps, const float bbox_min[3], const float bbox_max[3],
                      const mdl_rig *rig, mdl_model **out, char *err);
/* Adds a kind's state to m (which then owns it and frees it with ops->destroy, also on error). */
int mdl__model_add_kind(mdl_model *m, const mdl_kind_ops *ops, void *impl, char *err);

/* The rig as the RIG chunk holds it (formats/modelfile.c); read validates every index (vertices
 * below nv). */
void mdl__rig_write(mdl__wbuf *b, const mdl_rig *r);
int mdl__rig_read(mdl__rbuf *b, int nv, mdl_rig **out);

/* A deep copy of a rig. */
int mdl__rig_copy(const mdl_rig *src, mdl_rig **out, char *err);

/* The tables of the kinds (steer/steer_kind.c, ...). */
extern const mdl_kind_ops mdl__steer_kind;
extern const mdl_kind_ops mdl__harmonic_kind;
extern const mdl_kind_ops mdl__skin_kind;

#endif
