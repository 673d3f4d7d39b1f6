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
    mdl_eval_opts o = {noise, drop, 7, 0};
    mdl_eval_result r;
    ASSERT_OK(mdl_eval_run(m, s, idx, n, &o, &r, err), err);
    free(idx);
    return r;
}

/* Synthesises two frames of the tube from m: its markers at their rig vertices in frames 1 and 3
 * (at the rest pose when m's vertex count is not the tube's). Returns 0 when m's synthesis can be
 * created, runs and gives finite vertices; prints what failed otherwise. */
static int check_finite(mdl_model *m, const mdl_meshseq *s, char *err)
{
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    mdl_synth *syn = NULL;
    if (mdl_synth_create(m, 0, &syn, err) != 0) {
        fprintf(stderr, "loaded, but synthesis refused: %s\n", err);
        return -1;
    }
    float *mk = calloc((size_t)info.nmarkers * 3 + 3, sizeof *mk);
    float *V = calloc((size_t)info.nv * 3, sizeof *V);
    ASSERT(mk && V);
    int rc = 0;
    for (int f = 1; f <= 3 && !rc; f += 2) {
        const float *P = info.nv == s->nv ? s->V + (size_t)f * s->nv * 3 : info.rest;
        for (int j = 0; j < info.nmarkers; j++)
            memcpy(mk + 3 * j, P + 3 * (size_t)info.markers[j].vertex, 3 * sizeof(float));
        int r = mdl_synth_markers(syn, mk, NULL, V, NULL);
        if (r != 0) {
            fprintf(stderr, "loaded, but frame %d returned %d\n", f, r);
            rc = -1;
        }
        for (int v = 0; v < 3 * info.nv && !rc; v++)
            if (!isfinite(V[v])) {
                fprintf(stderr, "loaded, but frame %d has vertex coordinate %d = %g\n", f, v, V[v]);
                rc = -1;
            }
    }
    free(mk);
    free(V);
    mdl_synth_destroy(syn);
    return rc;
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
    ASSERT_INT_GE(info.nclusters, 2);

    /* held-out frames: clearly better than the nearest training frame */
    mdl_eval_result r = eval(m, s, "2:60:4", 0, 0);
    printf("tube held-out: mean %.5f (baseline %.5f), max %.5f, marker %.5f, %d parts\n", r.mean_err,
           r.baseline_nn_mean_err, r.max_err, r.marker_err, info.nclusters);
    ASSERT_INT_EQ(r.frames, 15);
    ASSERT_INT_EQ(r.nan_count, 0);
    ASSERT_LT(r.mean_err, 0.6 * r.baseline_nn_mean_err);
    ASSERT_LT(r.mean_err, 0.01);
    double clean = r.mean_err;
    mdl_eval_result_fini(&r);

    /* 5 mm noise: worse, but gracefully; 30 % of markers dropped: no NaN, nothing flies off */
    r = eval(m, s, "2:60:4", 0.005, 0);
    printf("tube 5 mm noise: mean %.5f\n", r.mean_err);
    ASSERT_GE(r.mean_err, clean * 0.9);
    ASSERT_LT(r.mean_err, 0.05);
    mdl_eval_result_fini(&r);
    r = eval(m, s, "2:60:4", 0, 0.3);
    printf("tube 30%% dropped: mean %.5f, box excess %.4f, %d dropped\n", r.mean_err,
           r.max_bbox_excess, r.markers_dropped);
    ASSERT_INT_GT(r.markers_dropped, 0);
    ASSERT_INT_EQ(r.nan_count, 0);
    /* observed (seed 7): mean 0.0367, box excess 0.427 of the diagonal (the tube has three
     * markers, so each one dropped is a third of its input). Deterministic; the bounds sit 1.35x
     * and 1.3x above, room for other BLAS kernels' rounding, not for a part flying off */
    ASSERT_LE(r.mean_err, 0.05);
    ASSERT_LE(r.max_bbox_excess, 0.55);
    mdl_eval_result_fini(&r);

    /* file round trip: identical synthesis */
    char path[] = "/tmp/meshsteer-test-XXXXXX";
    int fd = mkstemp(path);
    ASSERT_INT_GE(fd, 0);
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
        /* byte changes: every byte in turn, inverted (and, for every 4th, its lowest bit flipped,
         * which keeps most floats finite and nearby, so that they load): each version either
         * is refused with a message and nothing left behind, or loads a model whose synthesis
         * from the tube's own markers is finite */
        int loaded = 0, changed = 0;
        for (long at = 0; at < len; at++) {
            for (int flip = 0; flip < 2; flip++) {
                if (flip == 1 && at % 4 != 0)
                    continue;
                uint8_t keep = buf[at];
                buf[at] ^= flip ? 0x01 : 0xff;
                changed++;
                err[0] = 0;
                mdl_model *bad = NULL;
                if (mdl_model_parse(buf, (size_t)len, "flip", &bad, err) != 0) {
                    ASSERT(bad == NULL);
                    ASSERT(err[0] != 0);
                } else {
                    ASSERT_INT_EQ_I(check_finite(bad, s, err), 0, at); /* index: the byte */
                    mdl_model_destroy(bad);
                    loaded++;
                }
                buf[at] = keep;
            }
        }
        printf("model file: %d byte changes, %d refused with a message, %d load and synthesise "
               "finite frames\n", changed, changed - loaded, loaded);
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
        mdl_eval_opts eo = {0, 0, 1, 0};
        int one = 1;
        ASSERT_INT_EQ(mdl_eval_run(m, s, &one, 1, &eo, &rr, err), MDL_ETOPOLOGY);
        ASSERT(strstr(err, "different faces") != NULL);
        s->F[1] = s->F[0];
        s->F[0] = t;
    }

    /* the kernel blend (kblend.h) of the same frames, the synthesis meshsteerd runs per frame
     * for such a model: no compact form (-ENOTSUP, as for the harmonic kind), finite frames, a
     * missing marker held, and no allocation per frame (mallinfo2, as for the part model above) */
    {
        mdl_train_opts ko = o;
        ko.kblend = 0.7;
        mdl_model *km;
        ASSERT_OK(mdl_steer_train(s, idx, n, rig, NULL, &ko, &km, err), err);
        mdl_synth *ks;
        ASSERT_OK(mdl_synth_create(km, 0, &ks, err), err);
        mdl_params_layout lay;
        ASSERT_INT_EQ(mdl_synth_params_layout(ks, &lay), -ENOTSUP);
        uint8_t valid[3] = {1, 1, 1};
        struct mallinfo2 kb0 = mallinfo2();
        for (int f = 0; f < 6; f++) {
            for (int j = 0; j < 3; j++)
                memcpy(mk + 3 * j, s->V + ((size_t)(2 * f + 1) * s->nv + rig->markers[j].vertex) * 3, 12);
            valid[2] = f != 5; /* the last frame: one marker held */
            ASSERT_OK(mdl_synth_markers(ks, mk, valid, Va, NULL), "kernel blend synth");
            for (int v = 0; v < 3 * s->nv; v++)
                ASSERT(isfinite(Va[v]));
        }
        struct mallinfo2 kb1 = mallinfo2();
        ASSERT_INT_EQ(kb1.uordblks, kb0.uordblks);
        ASSERT_INT_EQ(kb1.hblkhd, kb0.hblkhd);
        printf("tube kernel blend: 6 frames, no params layout, no allocation\n");
        mdl_synth_destroy(ks);
        mdl_model_destroy(km);
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
