/* test_train.c - the whole model on a subject with known ground truth (tests/model/tube.h):
 * training, synthesis of held-out frames against the nearest-frame baseline, the model file
 * round trip and its validation, the topology check, occlusion and noise. */
#include "model.h"
#include "steer/steer_internal.h"
#include "test.h"
#include "model/tube.h"

#include <errno.h>
#include <malloc.h>
#include <unistd.h>

static mdl_eval_result eval(const mdl_model *m, const mdl_meshseq *s, const char *spec, double noise,
                            double drop)
{
    char err[MDL_ERR_LEN] = "";
    int *idx, n;
    ASSERT_OK(mdl_parse_frames(spec, s->frames, &idx, &n, err), err);
    mdl_eval_opts o = {noise, drop, 7};
    mdl_eval_result r;
    ASSERT_OK(mdl_eval_run(m, s, idx, n, &o, &r, err), err);
    free(idx);
    return r;
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    mdl_rig *rig;
    tube_create(60, &s, &rig);
    int *idx, n;
    ASSERT_OK(mdl_parse_frames("0:60:4", s->frames, &idx, &n, err), err);
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    o.name = "tube";
    mdl_model *m;
    ASSERT_OK(mdl_steer_train(s, idx, n, rig, NULL, &o, &m, err), err);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    ASSERT_INT_EQ(info.nv, s->nv);
    ASSERT(info.nclusters >= 2);

    /* held-out frames: clearly better than the nearest training frame */
    mdl_eval_result r = eval(m, s, "2:60:4", 0, 0);
    printf("tube held-out: mean %.5f (baseline %.5f), max %.5f, marker %.5f, %d parts\n", r.mean_err,
           r.baseline_nn_mean_err, r.max_err, r.marker_err, info.nclusters);
    ASSERT_INT_EQ(r.frames, 15);
    ASSERT_INT_EQ(r.nan_count, 0);
    ASSERT(r.mean_err < 0.6 * r.baseline_nn_mean_err);
    ASSERT(r.mean_err < 0.01);
    double clean = r.mean_err;
    mdl_eval_result_fini(&r);

    /* 5 mm noise: worse, but gracefully; 30 % of markers dropped: no NaN, nothing flies off */
    r = eval(m, s, "2:60:4", 0.005, 0);
    printf("tube 5 mm noise: mean %.5f\n", r.mean_err);
    ASSERT(r.mean_err >= clean * 0.9);
    ASSERT(r.mean_err < 0.05);
    mdl_eval_result_fini(&r);
    r = eval(m, s, "2:60:4", 0, 0.3);
    printf("tube 30%% dropped: mean %.5f, box excess %.4f, %d dropped\n", r.mean_err,
           r.max_bbox_excess, r.markers_dropped);
    ASSERT(r.markers_dropped > 0);
    ASSERT_INT_EQ(r.nan_count, 0);
    ASSERT(r.max_bbox_excess < 1.0);
    mdl_eval_result_fini(&r);

    /* file round trip: identical synthesis */
    char path[] = "/tmp/meshsteer-test-XXXXXX";
    int fd = mkstemp(path);
    ASSERT(fd >= 0);
    close(fd);
    ASSERT_OK(mdl_model_save(m, path, err), err);
    mdl_model *m2;
    ASSERT_OK(mdl_model_load(path, &m2, err), err);
    mdl_synth *a, *b, *c;
    ASSERT_OK(mdl_synth_create(m, 0, &a, err), err);
    ASSERT_OK(mdl_synth_create(m2, 0, &b, err), err);
    ASSERT_OK(mdl_synth_create(m, 0, &c, err), err);
    mdl__steer_synth_portable(mdl__synth_steer(c)); /* the variant without AVX2 gives the same frames */
    float *Vc = malloc(sizeof(float) * 3 * (size_t)s->nv);
    float mk[9], *Va = malloc(sizeof(float) * 3 * (size_t)s->nv), *Vb = malloc(sizeof(float) * 3 * (size_t)s->nv);
    /* the per-frame path allocates nothing: the heap in use is the same after 5 frames
     * (meaningful without ASan, whose allocator mallinfo2 does not see) */
    struct mallinfo2 before = mallinfo2();
    for (int f = 0; f < 5; f++) {
        for (int j = 0; j < 3; j++)
            memcpy(mk + 3 * j, s->V + ((size_t)(2 * f + 1) * s->nv + rig->markers[j].vertex) * 3, 12);
        ASSERT_OK(mdl_synth_markers(a, mk, NULL, Va, NULL), "synth");
        ASSERT_OK(mdl_synth_markers(b, mk, NULL, Vb, NULL), "synth");
        ASSERT(memcmp(Va, Vb, sizeof(float) * 3 * (size_t)s->nv) == 0);
        ASSERT_OK(mdl_synth_markers(c, mk, NULL, Vc, NULL), "synth");
        ASSERT(memcmp(Va, Vc, sizeof(float) * 3 * (size_t)s->nv) == 0);
    }
    struct mallinfo2 after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    ASSERT_INT_EQ(after.hblkhd, before.hblkhd);
    /* all markers missing before any was seen: -EAGAIN, no output; then held */
    mdl_synth_reset(a);
    uint8_t none[3] = {0, 0, 0}, some[3] = {1, 1, 0};
    ASSERT_INT_EQ(mdl_synth_markers(a, mk, none, Va, NULL), -EAGAIN);
    mdl_synth_info si;
    ASSERT_OK(mdl_synth_markers(a, mk, NULL, Va, &si), "synth");
    ASSERT_OK(mdl_synth_markers(a, mk, some, Va, &si), "synth");
    ASSERT_INT_EQ(si.markers_missing, 1);
    ASSERT_INT_EQ(si.markers_held, 1);
    ASSERT_OK(mdl_synth_markers(a, mk, none, Va, &si), "synth");
    ASSERT_INT_EQ(si.reference_lost, 0); /* held reference markers still define the frame */
    for (int v = 0; v < 3 * s->nv; v++)
        ASSERT(isfinite(Va[v]));
    mdl_synth_destroy(a);
    mdl_synth_destroy(b);
    mdl_synth_destroy(c);
    free(Vc);

    /* corrupted files: every truncation and a sweep of byte changes are refused or load cleanly */
    {
        FILE *f = fopen(path, "rb");
        fseek(f, 0, SEEK_END);
        long len = ftell(f);
        rewind(f);
        uint8_t *buf = malloc((size_t)len);
        ASSERT_INT_EQ(fread(buf, 1, (size_t)len, f), len);
        fclose(f);
        int refused = 0;
        for (long cut = 0; cut < len; cut += len / 97 + 1) {
            mdl_model *bad = NULL;
            int rc = mdl_model_parse(buf, (size_t)cut, "cut", &bad, err);
            ASSERT(rc != 0);
            ASSERT(bad == NULL);
            ASSERT(strstr(err, "cut") != NULL);
            refused++;
        }
        buf[8] = 99; /* version */
        mdl_model *bad = NULL;
        ASSERT_INT_EQ(mdl_model_parse(buf, (size_t)len, "v", &bad, err), MDL_EVERSION);
        ASSERT(strstr(err, "version 99") != NULL);
        buf[8] = 1;
        printf("model file: %ld bytes, %d truncations refused\n", len, refused);
        free(buf);
    }
    unlink(path);

    /* a mesh with the same counts but other faces is refused */
    {
        uint32_t t = s->F[0];
        s->F[0] = s->F[1];
        s->F[1] = t;
        mdl_eval_result rr;
        mdl_eval_opts eo = {0, 0, 1};
        int one = 1;
        ASSERT_INT_EQ(mdl_eval_run(m, s, &one, 1, &eo, &rr, err), MDL_ETOPOLOGY);
        ASSERT(strstr(err, "different faces") != NULL);
        s->F[1] = s->F[0];
        s->F[0] = t;
    }
    free(Va);
    free(Vb);
    free(idx);
    mdl_model_destroy(m);
    mdl_model_destroy(m2);
    mdl_meshseq_destroy(s);
    mdl_rig_destroy(rig);
    printf("train: ok\n");
    return 0;
}
