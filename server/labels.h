/* labels.h - a label map: which label of a marker source drives each marker of a model.
 *
 * A model's markers each carry a `source` label (the rig's `source` field, docs/FORMATS.md): the
 * label they had in the recording the model was trained with, e.g. the CMU BVH joint names of
 * rigs/horse-human.json. A live source publishes its own labels (the depth sources: head, lhand,
 * rhand, lfoot, rfoot, torso). A label map renames between the two, so that a model trained with
 * one marker set is driven by another without retraining (issue 4):
 *
 *     MODEL_LABEL=LIVE_LABEL[,MODEL_LABEL=LIVE_LABEL...]
 *
 * e.g. "Hips=torso,Neck=head,LeftToe_End=lfoot". One live label may feed several model labels; a
 * model label may appear once. Model markers whose label is not in the map bind by their own label
 * (exact string match), as without a map. Blanks around names are ignored; names cannot hold ',' or
 * '=', and each is shorter than MDL_NAME_LEN. Used by meshsteerd (--labels, `labels =`) and by
 * `meshsteer synth --labels`.
 */
#ifndef MESHSTEER_SERVER_LABELS_H
#define MESHSTEER_SERVER_LABELS_H

#include "model.h"

#define SRV_LABELS_MAX_LEN 4096 /* longest map text, including the terminating NUL */

typedef struct srv_labels srv_labels;

/* Parses a map. An empty (or all-blank) text is the empty map. On error *out is NULL and err
 * (MDL_ERR_LEN, may be NULL) names the entry, its column and the reason, e.g.
 * "entry 3 'LeftHand' (column 21): expected MODEL=LABEL". Free with srv_labels_destroy. */
int srv_labels_create(const char *text, srv_labels **out, char *err);
void srv_labels_destroy(srv_labels *l); /* NULL is fine */

int srv_labels_count(const srv_labels *l); /* entries; 0 for NULL */
/* Entry i's model and live label (0 <= i < count). */
const char *srv_labels_model(const srv_labels *l, int i);
const char *srv_labels_live(const srv_labels *l, int i);

/* The live label that model label `model_label` binds to: the map's, or model_label itself. */
const char *srv_labels_lookup(const srv_labels *l, const char *model_label);

/* Called once per map entry that cannot take effect, with a complete sentence. */
typedef void (*srv_labels_warn_fn)(void *ud, const char *msg);

/* Binds the model's markers to the source's labels through the map (l may be NULL: exact names):
 * map[i] = the index into names[0..count) of model marker i's live label, or -1. An entry whose
 * model label no model marker carries, or whose live label is not among names, is reported through
 * warn (may be NULL). Returns the number of model markers left unbound (0..nmarkers), or -EINVAL
 * for count < 0. names[j] may be NULL (never matches). */
int srv_labels_bind(const srv_labels *l, const mdl_model_info *info, const char *const *names,
                    int count, int *map, srv_labels_warn_fn warn, void *ud);

#endif
