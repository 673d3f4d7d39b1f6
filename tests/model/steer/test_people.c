/* test_people.c - the steering model on two captured humans with plain seven-marker rigs (issue
 * 12: head, hands, feet, pelvis, neck; reference edge pelvis -> neck, the heading from all markers,
 * heading.c), default options, trained on the even frames of the first 120 and driven by the rig
 * vertices of the odd ones: samba (rigs/samba-7.json) and pjump (rigs/pjump-7.json) meet issue
 * 12's bar, at most 0.6 x the nearest-frame baseline clean and below it with 10 mm noise.
 * The default options are chosen by the option selection (select.h); on both people it chooses
 * the kernel blend of the training meshes (kblend.h) over the part model. Observed
 * (docs/PERFORMANCE.md): samba 0.473, pjump 0.387 of the baseline; with 10 mm noise 0.589 and
 * 0.508 (the part model alone: 0.90, 0.74; 1.41, 1.26). The bounds sit just above what is
 * observed, so that a regression fails, and never above the bar. A third case: pjump
 * with the rig proposed from the mesh alone (`meshsteer rig`, the medoid over every 10th frame),
 * which the bar covers too. A fourth: pcow, the elastic cow that falls, stretches and
 * rolls (no skeleton, no rig in rigs/), with the rig proposed from its frame 0 (`meshsteer rig`
 * falls back to frame 0 alone on it: most of its frames lie rolled over); the issue sets it no bar,
 * but the same bar holds (observed 0.511 / 0.541, the kernel blend 0.5). */
#include "model.h"
#include "test.h"

#include <stdlib.h>
#include <string.h>

/* rigfile: a rig in the source tree; NULL: the rig proposed from the mesh alone (rig_propose.c),
 * the medoid over every 10th frame, as `meshsteer rig --frames ::10` gives it; FRAME0: the rig
 * proposed from frame 0 alone, the body told from the mesh (`meshsteer rig --frame 0`) */
static const char FRAME0[] = "frame 0"; /* compared as a pointer */
static void run(const char *name, const char *pc2, const char *rest, const char *rigfile,
                double max_ratio, double max_noise_ratio)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    ASSERT_OK(mdl_meshseq_read(test_data(pc2), test_data(rest), &s, err), err);
    mdl_rig *rig;
    if (rigfile == FRAME0) {
        const float up[3] = {0, 1, 0};
        mdl_rig_proposal info;
        ASSERT_OK(mdl_rig_propose(s->V, s->nv, s->F, s->nf, up, MDL_BODY_AUTO, &rig, &info, err),
                  err);
        printf("%s: proposed a %s\n", name, info.body == MDL_BODY_QUADRUPED ? "quadruped" : "human");
    } else if (rigfile) {
        ASSERT_OK(mdl_rig_read(test_src(rigfile), s->nv, &rig, err), err);
    } else {
        int nk = (s->frames + 9) / 10, used;
        float *V = malloc((size_t)nk * s->nv * 3 * sizeof *V);
        ASSERT(V);
        for (int k = 0; k < nk; k++)
            memcpy(V + (size_t)k * s->nv * 3, s->V + (size_t)10 * k * s->nv * 3,
                   (size_t)s->nv * 3 * sizeof *V);
        const float up[3] = {0, 1, 0};
        ASSERT_OK(mdl_rig_propose_frames(V, s->nv, nk, NULL, s->F, s->nf, up, MDL_BODY_HUMAN,
                                         &rig, NULL, &used, err),
                  err);
        ASSERT_INT_EQ(used, nk);
        free(V);
    }
    int *tr, ntr, *te, nte;
    ASSERT_OK(mdl_parse_frames("0:120:2", s->frames, &tr, &ntr, err), err);
    ASSERT_OK(mdl_parse_frames("1:120:2", s->frames, &te, &nte, err), err);
    mdl_model *m;
    mdl_train_opts o0;
    mdl_train_opts_default(&o0);
    o0.select_folds = 3; /* `meshsteer train`'s default: the option selection (select.h) */
    ASSERT_OK(mdl_steer_train(s, tr, ntr, rig, NULL, &o0, &m, err), err);
    mdl_eval_opts o = {0, 0, 1, 0};
    mdl_eval_result r;
    ASSERT_OK(mdl_eval_run(m, s, te, nte, &o, &r, err), err);
    double ratio = r.mean_err / r.baseline_nn_mean_err;
    printf("%s: mean %.5f baseline %.5f ratio %.3f (bound %.2f)\n", name, r.mean_err,
           r.baseline_nn_mean_err, ratio, max_ratio);
    ASSERT_INT_EQ(r.nan_count, 0);
    ASSERT(ratio <= max_ratio);
    ASSERT(ratio <= 0.6); /* issue 12 */
    mdl_eval_result_fini(&r);
    o.noise_m = 0.010;
    ASSERT_OK(mdl_eval_run(m, s, te, nte, &o, &r, err), err);
    ratio = r.mean_err / r.baseline_nn_mean_err;
    printf("%s, 10 mm noise: mean %.5f baseline %.5f ratio %.3f (bound %.2f)\n", name, r.mean_err,
           r.baseline_nn_mean_err, ratio, max_noise_ratio);
    ASSERT_INT_EQ(r.nan_count, 0);
    ASSERT(ratio <= max_noise_ratio);
    ASSERT(ratio < 1); /* issue 12 */
    mdl_eval_result_fini(&r);
    free(tr);
    free(te);
    mdl_model_destroy(m);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(s);
}

int main(void)
{
    mdl_set_blas_threads(1);
    run("samba-7", "meshes/samba/samba.pc2", "meshes/samba/rest.obj", "rigs/samba-7.json", 0.49, 0.61);
    run("pjump-7", "meshes/pjump/pjump.pc2", "meshes/pjump/rest.obj", "rigs/pjump-7.json", 0.40, 0.53);
    /* the proposed rig on which the selection at one spacing kept the part model (0.748 / 1.128,
     * select.h step 4); with the comparison at the test's spacing 0.450 / 0.540 */
    run("pjump, proposed over ::10", "meshes/pjump/pjump.pc2", "meshes/pjump/rest.obj", NULL,
        0.49, 0.56);
    run("pcow, proposed from frame 0", "meshes/pcow/pcow.pc2", "meshes/pcow/rest.obj", FRAME0,
        0.53, 0.56);
    return 0;
}
