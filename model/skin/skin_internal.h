/* skin_internal.h - the skin kind's state (skin/; model.h "the skin"): a linear blend skinning
 * model fitted by SSDR (ssdr.h) and the bone animation of its fitted frames.
 *   bone, w   nv x K slots: bone index and weight (weights >= 0, sum 1, unused slots weight 0,
 *             slot 0 the largest)
 *   T         nframes x nb x 12: R (row-major 3x3, a rotation) then t, for the fitted frames in
 *             order: v_i^f = sum_s w[K i + s] (R_b p_i + t_b), b = bone[K i + s], p = the rest pose
 *   part      nv: the bone of largest weight (model info, for colouring)
 *   has_vars  1 when the synthesis plays an endless random walk on the example's transition
 *             graph (variations/, mdl_variations_attach) with vars and vars_seed, instead of
 *             looping the fitted frames
 * The rest pose, faces and fps are the model's (kind.h). */
#ifndef MESHSTEER_MODEL_SKIN_INTERNAL_H
#define MESHSTEER_MODEL_SKIN_INTERNAL_H

#include "model.h"

struct mdl_skin {
    int nv, nb, K, nframes;
    int *bone;
    double *w;
    double *T;
    int *frames;
    int *part;
    mdl_skin_stats st;
    int has_vars;
    mdl_variations_opts vars;
    uint64_t vars_seed;
};



void mdl__skin_free(struct mdl_skin *k);
int mdl__skin_eval(const mdl_model *m, const mdl_meshseq *seq, const int *frames, int n,
                   const mdl_eval_opts *o, mdl_eval_result *r, char *err);

#endif
