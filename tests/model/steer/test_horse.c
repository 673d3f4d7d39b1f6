/* test_horse.c - the acceptance checks of the model on real data (../shared/data):
 *   horse-gallop, trained on frames 0:24:2, driven by the rig vertices of 1:24:2: mean error at
 *   most 0.6 x the nearest-frame baseline and at most 1.2 % of the diagonal; 10 mm marker noise
 *   degrades gracefully; 20 % dropped markers: no NaN, mean error at most 2.5 % and no vertex
 *   beyond the training box by more than 1.5 % of its diagonal; the same subject with
 *   horse-collapse's faces is refused.
 *   horse-gallop with one more marker per leg (rigs/horse-dense.json): at most 0.5 %.
 *   samba, trained on 0:175:2, beats the baseline on 1:175:2: with elbow and knee markers
 *   (rigs/samba-dense.json) by default, with the sparse rig given motion directions. */
#include "model.h"
#include "test.h"

static mdl_eval_result eval(const mdl_model *m, const mdl_meshseq *s, const char *spec, double noise,
                            double drop)
{
    char err[MDL_ERR_LEN] = "";
    int *idx, n;
    ASSERT_OK(mdl_parse_frames(spec, s->frames, &idx, &n, err), err);
    mdl_eval_opts o = {noise, drop, 1, 0};
    mdl_eval_result r;
    ASSERT_OK(mdl_eval_run(m, s, idx, n, &o, &r, err), err);
    free(idx);
    return r;
}

static mdl_model *train(const mdl_meshseq *s, const char *rigfile, const char *spec,
                        const mdl_train_opts *o)
{
    char err[MDL_ERR_LEN] = "";
    mdl_rig *rig;
    ASSERT_OK(mdl_rig_read(test_src(rigfile), s->nv, &rig, err), err);
    int *idx, n;
    ASSERT_OK(mdl_parse_frames(spec, s->frames, &idx, &n, err), err);
    mdl_model *m;
    ASSERT_OK(mdl_steer_train(s, idx, n, rig, NULL, o, &m, err), err);
    free(idx);
    mdl_rig_destroy(rig);
    return m;
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_set_blas_threads(1);
    mdl_meshseq *horse;
    ASSERT_OK(mdl_meshseq_read(test_data("meshes/horse-gallop"), NULL, &horse, err), err);
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    o.select_folds = 3; /* `meshsteer train`'s default: the option selection (select.h) */
    mdl_model *m = train(horse, "rigs/horse.json", "0:24:2", &o);

    mdl_eval_result r = eval(m, horse, "1:24:2", 0, 0);
    printf("horse: mean %.4f p95 %.4f max %.4f marker %.4f | baseline mean %.4f p95 %.4f | "
           "ratio %.3f\n",
           r.mean_err, r.p95_err, r.max_err, r.marker_err, r.baseline_nn_mean_err,
           r.baseline_nn_p95_err, r.mean_err / r.baseline_nn_mean_err);
    ASSERT_LE(r.mean_err, 0.6 * r.baseline_nn_mean_err);
    ASSERT_LE(r.mean_err, 0.012);
    ASSERT_INT_EQ(r.nan_count, 0);
    double clean = r.mean_err;
    mdl_eval_result_fini(&r);

    r = eval(m, horse, "1:24:2", 0.010, 0);
    printf("horse, 10 mm noise: mean %.4f (baseline %.4f)\n", r.mean_err, r.baseline_nn_mean_err);
    ASSERT_LT(r.mean_err, 3 * clean);
    ASSERT_LT(r.mean_err, r.baseline_nn_mean_err);
    mdl_eval_result_fini(&r);

    r = eval(m, horse, "1:24:2", 0, 0.2);
    printf("horse, 20%% dropped (%d samples): mean %.4f, box excess %.4f of its diagonal\n",
           r.markers_dropped, r.mean_err, r.max_bbox_excess);
    ASSERT_INT_GT(r.markers_dropped, 0);
    ASSERT_INT_EQ(r.nan_count, 0);
    /* observed (seed 1): mean 0.0182, box excess 0.0101 (0.0180, 0.0084 with blocks of 2 in the
     * option selection, select.h). The run is deterministic; the margins
     * (1.4x, 1.5x) leave room for other BLAS kernels' rounding and small training changes, while
     * a limb thrown off by a lost marker moves whole parts by tenths of the diagonal */
    ASSERT_LE(r.mean_err, 0.025);
    ASSERT_LE(r.max_bbox_excess, 0.015);
    mdl_eval_result_fini(&r);

    /* same counts, different faces */
    mdl_meshseq *collapse;
    ASSERT_OK(mdl_meshseq_read(test_data("meshes/horse-collapse/horse-collapse.pc2"),
                               test_data("meshes/horse-collapse/rest.obj"), &collapse, err),
              err);
    ASSERT_INT_EQ(collapse->nv, horse->nv);
    int one = 1;
    mdl_eval_opts eo = {0, 0, 1, 0};
    ASSERT_INT_EQ(mdl_eval_run(m, collapse, &one, 1, &eo, &r, err), MDL_ETOPOLOGY);
    printf("horse-collapse refused: %s\n", err);
    mdl_meshseq_destroy(collapse);
    mdl_model_destroy(m);

    /* one more marker per leg reaches the goal of 0.5 % */
    m = train(horse, "rigs/horse-dense.json", "0:24:2", &o);
    r = eval(m, horse, "1:24:2", 0, 0);
    printf("horse, 12 markers: mean %.4f p95 %.4f | baseline %.4f | ratio %.3f\n", r.mean_err,
           r.p95_err, r.baseline_nn_mean_err, r.mean_err / r.baseline_nn_mean_err);
    ASSERT_LE(r.mean_err, 0.005);
    mdl_eval_result_fini(&r);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(horse);

    mdl_meshseq *samba;
    ASSERT_OK(mdl_meshseq_read(test_data("meshes/samba/samba.pc2"),
                               test_data("meshes/samba/rest.obj"), &samba, err),
              err);
    /* with a marker at each elbow and knee the default options beat the baseline */
    m = train(samba, "rigs/samba-dense.json", "0:175:2", &o);
    r = eval(m, samba, "1:175:2", 0, 0);
    printf("samba, 13 markers, defaults: mean %.4f p95 %.4f | baseline mean %.4f | ratio %.3f\n",
           r.mean_err, r.p95_err, r.baseline_nn_mean_err, r.mean_err / r.baseline_nn_mean_err);
    ASSERT_LT(r.mean_err, r.baseline_nn_mean_err);
    mdl_eval_result_fini(&r);
    mdl_model_destroy(m);
    /* the options of docs/MODEL.md's table, without the option selection (select.h): with it this
     * configuration chooses noise-robust options (filter, training noise) that cost it its clean
     * accuracy here (1.17 of the baseline; docs/PERFORMANCE.md) */
    o.use_motion_dir = 1;
    o.explained = 0.99;
    o.max_modes = 12;
    o.select_folds = 0;
    m = train(samba, "rigs/samba.json", "0:175:2", &o);
    r = eval(m, samba, "1:175:2", 0, 0);
    printf("samba (motion directions, 99%% variance): mean %.4f p95 %.4f | baseline mean %.4f | "
           "ratio %.3f\n",
           r.mean_err, r.p95_err, r.baseline_nn_mean_err, r.mean_err / r.baseline_nn_mean_err);
    ASSERT_LT(r.mean_err, r.baseline_nn_mean_err);
    mdl_eval_result_fini(&r);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(samba);
    printf("horse: ok\n");
    return 0;
}
