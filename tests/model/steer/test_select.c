/* test_select.c - the option selection (model/steer/select.c) and the input filter
 * (model/steer/mfilter.c) of the steering model (issue 12):
 *   - the filter: a still marker is smoothed, a fast one barely; a marker moving at constant
 *     velocity is followed without lag; white noise on a still marker comes out smaller;
 *   - the selection on horse-gallop (0:24:2): the report lists the candidates with their
 *     validation errors and exactly one choice, no worse than the defaults; two runs give the
 *     same report (deterministic); options given are not searched; select_folds 0 runs none;
 *   - a model with the filter saved and loaded synthesises the same frames (the STER trailer);
 *     so does one with the kernel blend (kblend.h; trailer version 2), and the selection tries it;
 *   - on 24 frames the part model and each blend are validated at twice the spacing too, and
 *     their scores at the test's spacing follow from the reported errors (select.h, step 4). */
#include "model.h"
#include "steer/mfilter.h"
#include "core/util.h"
#include "test.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static mdl_model *train_frames(const mdl_meshseq *s, const mdl_rig *rig, const mdl_train_opts *o,
                               const char *frames)
{
    char err[MDL_ERR_LEN] = "";
    int *idx, n;
    ASSERT_OK(mdl_parse_frames(frames, s->frames, &idx, &n, err), err);
    mdl_model *m;
    ASSERT_OK(mdl_steer_train(s, idx, n, rig, NULL, o, &m, err), err);
    free(idx);
    return m;
}

static mdl_model *train(const mdl_meshseq *s, const mdl_rig *rig, const mdl_train_opts *o)
{
    return train_frames(s, rig, o, "0:24:2");
}

/* The error at half the validation's spacing (select.h, step 4), computed here independently. */
static double half(double e1, double e2)
{
    return e2 > e1 ? e1 * e1 / e2 : e1;
}

/* Candidates validated at two spacings in a selection report; each one's score is checked
 * against its four extrapolated errors. */
static int count_spaced(cJSON *cands)
{
    int n = 0;
    for (int i = 0; i < cJSON_GetArraySize(cands); i++) {
        cJSON *c = cJSON_GetArrayItem(cands, i);
        if (!cJSON_GetObjectItem(c, "val2_err_clean"))
            continue;
        double v[8];
        static const char *const keys[8] = {
            "val_err_clean",  "val_baseline_clean",  "val_err_noisy",  "val_baseline_noisy",
            "val2_err_clean", "val2_baseline_clean", "val2_err_noisy", "val2_baseline_noisy"};
        for (int k = 0; k < 8; k++) {
            v[k] = cJSON_GetNumberValue(cJSON_GetObjectItem(c, keys[k]));
            ASSERT(v[k] > 0);
        }
        double want = fmax(half(v[0], v[4]) / half(v[1], v[5]), half(v[2], v[6]) / half(v[3], v[7]));
        double got = cJSON_GetNumberValue(cJSON_GetObjectItem(c, "score_at_test_spacing"));
        ASSERT(fabs(got - want) <= 1e-9 * want);
        n++;
    }
    return n;
}

static double noisy_err(const mdl_model *m, const mdl_meshseq *s)
{
    char err[MDL_ERR_LEN] = "";
    int *idx, n;
    ASSERT_OK(mdl_parse_frames("1:24:2", s->frames, &idx, &n, err), err);
    mdl_eval_opts o = {0.010, 0, 1, 0};
    mdl_eval_result r;
    ASSERT_OK(mdl_eval_run(m, s, idx, n, &o, &r, err), err);
    double e = r.mean_err;
    mdl_eval_result_fini(&r);
    free(idx);
    return e;
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_set_blas_threads(1);

    /* the filter */
    {
        enum { T = 40 };
        float P[T * 6];
        for (int f = 0; f < T; f++) {
            for (int c = 0; c < 3; c++)
                P[6 * f + c] = 0.001f * (float)sin(0.1 * f + c);    /* marker 0: nearly still */
            for (int c = 0; c < 3; c++)
                P[6 * f + 3 + c] = 0.3f * (float)sin(0.8 * f + c);  /* marker 1: fast */
        }
        double g[4];
        mdl__mfilter_train(P, T, 6, 2, 0.010, g);
        printf("filter gains: still alpha %.3f beta %.3f, fast alpha %.3f beta %.3f\n", g[0], g[1],
               g[2], g[3]);
        ASSERT(g[0] > 0 && g[0] < 0.5);
        ASSERT(g[2] > 0.9 && g[2] <= 1);
        ASSERT(g[1] >= 0 && g[3] >= 0 && g[1] < 2 && g[3] < 2);
        float S[T * 3] = {0}; /* a marker that never moved is still followed */
        double gs[2];
        mdl__mfilter_train(S, T, 3, 1, 0.010, gs);
        ASSERT(gs[0] > 0.1 && gs[1] > 0);
        double x[3], v[3];
        uint8_t init = 0;
        float z[3];
        for (int f = 0; f < 3000; f++) { /* constant velocity: no lag once settled */
            for (int c = 0; c < 3; c++)
                z[c] = 0.001f * (float)f * (float)(c + 1);
            mdl__mfilter_step(g, 1, z, NULL, x, v, &init);
        }
        for (int c = 0; c < 3; c++)
            ASSERT(fabs(x[c] - z[c]) < 1e-4);
        init = 0;
        uint64_t rng = 7;
        double in2 = 0, out2 = 0;
        for (int f = 0; f < 2000; f++) { /* white noise on a still marker */
            for (int c = 0; c < 3; c++)
                z[c] = (float)(0.01 * mdl__gauss(&rng));
            mdl__mfilter_step(g, 1, z, NULL, x, v, &init);
            if (f >= 100)
                for (int c = 0; c < 3; c++) {
                    in2 += (double)z[c] * z[c];
                    out2 += x[c] * x[c];
                }
        }
        printf("filter on white noise: rms in %.4f out %.4f\n", sqrt(in2 / 5700), sqrt(out2 / 5700));
        ASSERT(out2 < 0.5 * in2);
    }

    mdl_meshseq *horse;
    ASSERT_OK(mdl_meshseq_read(test_data("meshes/horse-gallop"), NULL, &horse, err), err);
    mdl_rig *rig;
    ASSERT_OK(mdl_rig_read(test_src("rigs/horse.json"), horse->nv, &rig, err), err);
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    ASSERT_INT_EQ(o.select_folds, 0); /* the library's default: off */
    o.select_folds = 3;               /* `meshsteer train`'s */

    /* the selection and its report */
    mdl_model *m = train(horse, rig, &o);
    char *js = mdl_model_report_json(m);
    ASSERT(js != NULL);
    cJSON *rep = cJSON_Parse(js);
    cJSON *sel = cJSON_GetObjectItem(rep, "selection");
    ASSERT(sel != NULL);
    cJSON *cands = cJSON_GetObjectItem(sel, "candidates");
    int nc = cJSON_GetArraySize(cands), chosen = -1, nchosen = 0, md_tried = 0, kb_tried = 0;
    ASSERT_INT_GE(nc, 5);
    for (int i = 0; i < nc; i++) {
        cJSON *c = cJSON_GetArrayItem(cands, i);
        ASSERT(cJSON_GetNumberValue(cJSON_GetObjectItem(c, "val_err_clean")) > 0);
        ASSERT(cJSON_GetNumberValue(cJSON_GetObjectItem(c, "val_err_noisy")) > 0);
        ASSERT(cJSON_GetNumberValue(cJSON_GetObjectItem(c, "val_baseline_noisy")) > 0);
        md_tried |= cJSON_IsTrue(cJSON_GetObjectItem(c, "motion_dir"));
        kb_tried |= cJSON_GetNumberValue(cJSON_GetObjectItem(c, "kernel_blend")) > 0;
        if (cJSON_IsTrue(cJSON_GetObjectItem(c, "chosen"))) {
            chosen = i;
            nchosen++;
        }
    }
    ASSERT_INT_EQ(nchosen, 1);
    ASSERT_INT_EQ(md_tried, 1);
    ASSERT_INT_EQ(kb_tried, 1);
    ASSERT_INT_EQ((int)cJSON_GetNumberValue(cJSON_GetObjectItem(sel, "chosen")), chosen);
    double s0 = cJSON_GetNumberValue(cJSON_GetObjectItem(cJSON_GetArrayItem(cands, 0), "score"));
    double sc = cJSON_GetNumberValue(cJSON_GetObjectItem(cJSON_GetArrayItem(cands, chosen), "score"));
    printf("selection: %d candidates, chose %d (score %.3f, defaults %.3f)\n", nc, chosen, sc, s0);
    ASSERT_LE(sc, s0);
    ASSERT_INT_EQ(count_spaced(cands), 0); /* 12 frames: too few for folds of 3-frame blocks */
    cJSON_Delete(rep);

    /* 24 frames: the part model and each blend compared at two spacings (select.h, step 4) */
    {
        mdl_model *mw = train_frames(horse, rig, &o, "0:48:2");
        char *jw = mdl_model_report_json(mw);
        cJSON *rw = cJSON_Parse(jw);
        cJSON *cw = cJSON_GetObjectItem(cJSON_GetObjectItem(rw, "selection"), "candidates");
        int nblend = 0;
        for (int i = 0; i < cJSON_GetArraySize(cw); i++)
            nblend += cJSON_GetNumberValue(
                          cJSON_GetObjectItem(cJSON_GetArrayItem(cw, i), "kernel_blend")) > 0;
        int ns = count_spaced(cw);
        printf("selection on 24 frames: %d candidates at two spacings (%d blends)\n", ns, nblend);
        ASSERT_INT_GE(nblend, 3);
        ASSERT_INT_EQ(ns, nblend + 1); /* the blends and the part model they are compared with */
        cJSON_Delete(rw);
        free(jw);
        mdl_model_destroy(mw);
    }

    /* deterministic: the same report again (but the timings) */
    mdl_model *m2 = train(horse, rig, &o);
    char *js2 = mdl_model_report_json(m2);
    cJSON *r1 = cJSON_Parse(js), *r2 = cJSON_Parse(js2);
    cJSON_DeleteItemFromObject(r1, "training_seconds");
    cJSON_DeleteItemFromObject(r2, "training_seconds");
    cJSON_DeleteItemFromObject(cJSON_GetObjectItem(r1, "selection"), "seconds");
    cJSON_DeleteItemFromObject(cJSON_GetObjectItem(r2, "selection"), "seconds");
    ASSERT(cJSON_Compare(r1, r2, 1));
    cJSON_Delete(r1);
    cJSON_Delete(r2);
    free(js);
    free(js2);
    mdl_model_destroy(m2);

    /* the filter survives the file */
    double e1 = noisy_err(m, horse);
    char path[] = "/tmp/test_select_XXXXXX";
    int fd = mkstemp(path);
    ASSERT(fd >= 0);
    close(fd);
    ASSERT_OK(mdl_model_save(m, path, err), err);
    mdl_model *ml;
    ASSERT_OK(mdl_model_load(path, &ml, err), err);
    remove(path);
    double e2 = noisy_err(ml, horse);
    printf("10 mm noise: trained %.6f, loaded %.6f\n", e1, e2);
    ASSERT(e1 == e2);
    mdl_model_destroy(ml);
    mdl_model_destroy(m);

    /* options given are not searched */
    o.use_motion_dir = 0;
    o.filter_noise = 0.010;
    m = train(horse, rig, &o);
    js = mdl_model_report_json(m);
    rep = cJSON_Parse(js);
    cands = cJSON_GetObjectItem(cJSON_GetObjectItem(rep, "selection"), "candidates");
    for (int i = 0; i < cJSON_GetArraySize(cands); i++) {
        cJSON *c = cJSON_GetArrayItem(cands, i);
        ASSERT(!cJSON_IsTrue(cJSON_GetObjectItem(c, "motion_dir")));
        ASSERT(cJSON_GetNumberValue(cJSON_GetObjectItem(c, "filter_noise_m")) == 0.010);
    }
    cJSON_Delete(rep);
    free(js);
    mdl_model_destroy(m);

    /* no selection */
    o.select_folds = 0;
    m = train(horse, rig, &o);
    js = mdl_model_report_json(m);
    rep = cJSON_Parse(js);
    ASSERT(cJSON_GetObjectItem(rep, "selection") == NULL);
    cJSON_Delete(rep);
    free(js);
    mdl_model_destroy(m);

    /* the kernel blend (kblend.h) survives the file (trailer version 2), with and without the
     * filter */
    for (int f = 0; f < 2; f++) {
        o.kblend = 0.7;
        o.filter_noise = f ? 0.010 : 0;
        m = train(horse, rig, &o);
        e1 = noisy_err(m, horse);
        strcpy(path, "/tmp/test_select_XXXXXX");
        fd = mkstemp(path);
        ASSERT(fd >= 0);
        close(fd);
        ASSERT_OK(mdl_model_save(m, path, err), err);
        ASSERT_OK(mdl_model_load(path, &ml, err), err);
        remove(path);
        e2 = noisy_err(ml, horse);
        printf("kernel blend, filter %d, 10 mm noise: trained %.6f, loaded %.6f\n", f, e1, e2);
        ASSERT(e1 == e2 && e1 > 0);
        mdl_model_destroy(ml);
        mdl_model_destroy(m);
    }

    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(horse);
    printf("select: ok\n");
    return 0;
}
