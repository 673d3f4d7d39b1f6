/* select.h - the steering model's options chosen by the data (issue 12): leave-a-block-out
 * cross-validation in time over the training frames, with clean and noisy markers.
 *
 * Procedure (with virtual markers only; a recording of another performer has no ground truth to
 * validate against, and keeps the defaults):
 *   1. The T training frames, in the order given, are cut into K contiguous blocks
 *      (K = opts->select_folds, fewer when a fold would keep under 3 frames or hold out under 2).
 *      Fold k trains on the other K - 1 blocks and validates on block k, so that the validation
 *      frames' temporal neighbours are not in its training set (only the two frames at each
 *      block boundary neighbour a training frame).
 *   2. Validation of one candidate on one fold: the fold's model is driven by the rig vertices of
 *      the held-out frames in order (a fresh synthesis per block, as `meshsteer eval`), once clean
 *      and once with Gaussian marker noise of opts->select_noise metres per axis (a fixed seed per
 *      fold: deterministic); the error is eval.c's, the mean vertex distance after rigid alignment
 *      over the rest box diagonal, beside eval.c's nearest-frame baseline among the fold's own
 *      training frames fed the same (noisy) markers.
 *   3. Score of a candidate = max(E_clean / B_clean, E_noisy / B_noisy), E and B summed over all
 *      held-out frames of all folds: the worse of the two ratios to the baseline, so that an
 *      option that wins clean but breaks under noise (motion directions) is not preferred.
 *   4. Search, coordinate-wise from the defaults (each option left at -1 in opts; a value given
 *      is fixed and not searched), in this order, keeping the best score so far:
 *        motion directions off / on; radial basis / linear; ridge by leave-one-out / 1 (these
 *        three refit only the regressions of the fold's model, train.c mdl__steer_fit_regress);
 *        overlap rings 2 / 1 / 3; modes at most 6 / 3; parts at most 24 / 12 (these refit the
 *        fold's whole model).
 *      A candidate replaces the best only when its score is lower by more than 1 % (ties keep
 *      the default, the simpler and already documented model).
 *   5. The chosen options are applied to a final fit on all training frames.
 * Cost: per fold one structural fit per structural candidate plus one regression refit per
 * regression candidate, and 2 x (held-out frames) synthesised frames per candidate.
 */
#ifndef MESHSTEER_STEER_SELECT_H
#define MESHSTEER_STEER_SELECT_H

#include "model.h"

#define MDL_SELECT_FOLDS 3      /* folds */
#define MDL_SELECT_BLOCK 2      /* training frames per time block */
#define MDL_SELECT_NOISE 0.010  /* metres: the validation's marker noise (a depth sensor's scale) */
#define MDL_SELECT_FEW_PARTS 12 /* the alternative bound on the number of parts */
#define MDL_SELECT_MAX_CAND 16

typedef struct mdl_select_cand {
    int use_motion_dir, linear, overlap_rings, max_modes, max_clusters;
    double ridge;
    double filter_noise, train_noise;
    double err_clean, base_clean, err_noisy, base_noisy; /* means over held-out frames, / diagonal */
    double score;
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
