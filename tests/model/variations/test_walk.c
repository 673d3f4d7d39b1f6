/* test_walk.c - Zheng 2013 Sec. 3.4 random walks (model/variations/walk.c, blend.c): on the
 * looping example (looping.h) a walk is the same for the same seed and differs across seeds,
 * follows only the graph's edges (t -> t + 1, or (i, j) -> j + 1), takes transitions, has any
 * length, and no output frame-to-frame vertex jump exceeds 3x the example's own largest; the
 * bone transforms stay rigid. Then horse-gallop (48 frames, a 22-bone skin; skip 77 if absent):
 * the cheapest transition from every frame joins corresponding frames of the two cycles and with
 * T_c between the two groups those are all (as the paper says, a single component finds no
 * variation); walks of 336 frames under the paper's T_c keep the same jump bound. And the skin's
 * clock synthesis with variations attached (model/skin/play.c): through a model file round trip
 * it plays the walk of its seed frame by frame, past the example's end, and again from the start
 * when the clock goes back. */
#include "model.h"
#include "test.h"
#include "looping.h"

#include <errno.h>
#include <malloc.h>
#include <time.h>

static int graph_edge(const mdl_variations *v, int a, int b)
{
    if (b == a + 1)
        return 1;
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    for (int k = 0; k < st.transitions; k++) {
        int i, j;
        mdl_variations_transition(v, k, &i, &j, NULL);
        if (i == a && j + 1 == b)
            return 1;
    }
    return 0;
}

/* walks of `frames` frames for `seeds` seeds: determinism, edges, rigidity, jumps; returns the
 * largest jump ratio and the number of transitions taken */
static double check_walks(const mdl_variations *v, const mdl_model *m, int frames, int seeds,
                          double example_jump, int *taken)
{
    char err[MDL_ERR_LEN] = "";
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    size_t nt = (size_t)frames * st.bones * 12, nvv = (size_t)frames * info.nv * 3;
    double *T = calloc(nt, sizeof *T), *T2 = calloc(nt, sizeof *T2);
    float *V = calloc(nvv, sizeof *V), *V2 = calloc(nvv, sizeof *V2);
    int *src = calloc(frames, sizeof *src), *src0 = calloc(frames, sizeof *src0);
    double worst = 0;
    *taken = 0;
    for (int seed = 1; seed <= seeds; seed++) {
        ASSERT_OK(mdl_variations_walk(v, (uint64_t)seed, frames, T, V, src, err), err);
        ASSERT_OK(mdl_variations_walk(v, (uint64_t)seed, frames, T2, V2, NULL, err), err);
        ASSERT(memcmp(T, T2, nt * sizeof *T) == 0);
        ASSERT(memcmp(V, V2, nvv * sizeof *V) == 0);
        if (seed == 1)
            memcpy(src0, src, frames * sizeof *src);
        else
            ASSERT(memcmp(src0, src, frames * sizeof *src) != 0);
        for (int f = 0; f + 1 < frames; f++) {
            if (!graph_edge(v, src[f], src[f + 1]))
                fprintf(stderr, "seed %d frame %d: %d -> %d is no edge\n", seed, f, src[f], src[f + 1]);
            ASSERT(graph_edge(v, src[f], src[f + 1]));
            *taken += src[f + 1] != src[f] + 1;
        }
        for (size_t b = 0; b < (size_t)frames * st.bones; b++) {
            const double *R = T + 12 * b;
            double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                         R[2] * (R[3] * R[7] - R[4] * R[6]);
            ASSERT_NEAR_I(det, 1, 1e-9, (int)b);
        }
        double j = lp_max_jump(V, info.nv, frames);
        if (j / example_jump > worst)
            worst = j / example_jump;
    }
    free(T);
    free(T2);
    free(V);
    free(V2);
    free(src);
    free(src0);
    return worst;
}

static void test_looping(void)
{
    char err[MDL_ERR_LEN] = "";
    const int N = 60, P = 20;
    mdl_meshseq *s = NULL;
    mdl_model *m = lp_fit(N, P, 3, &s, err);
    ASSERT_OK(m ? 0 : -1, err);
    int nf = 0;
    float *E = lp_skin_frames(m, &nf);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    double ej = lp_max_jump(E, info.nv, nf);
    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m, NULL, &v, err), err);
    int taken = 0;
    double worst = check_walks(v, m, 500, 6, ej, &taken);
    printf("looping: example max jump %.4f, walks of 500 frames x 6 seeds: %d transitions taken, "
           "worst jump %.2f x the example's\n", ej, taken, worst);
    ASSERT_INT_GT(taken, 6 * 5);
    ASSERT_LE(worst, 3.0);
    /* zero frames is fine; a fixed start is respected */
    double T0[12 * 3];
    ASSERT_OK(mdl_variations_walk(v, 1, 0, T0, NULL, NULL, err), err);
    mdl_variations_destroy(v);
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    o.start = 5;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
    int src[3];
    double T3[3 * 12 * 3];
    ASSERT_OK(mdl_variations_walk(v, 99, 3, T3, NULL, src, err), err);
    ASSERT_INT_EQ(src[0], 5);
    mdl_variations_destroy(v);
    free(E);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
}

static void test_play(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s = NULL;
    mdl_model *m = lp_fit(60, 20, 3, &s, err);
    ASSERT_OK(m ? 0 : -1, err);
    ASSERT_INT_EQ(mdl_variations_attached(m, NULL, NULL), 0);
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    o.jump_prob = 0.5;
    o.components = 0; /* auto, and --ground: kept in the file (the trailer's version 2) */
    o.ground = 1;
    o.te_factor = 0.2;
    o.blend_linear = 0; /* the gradient blend, not the default: kept (version 3) */
    ASSERT_OK(mdl_variations_attach(m, &o, 42, err), err);
    const char *path = "test_walk_vars.msm";
    ASSERT_OK(mdl_model_save(m, path, err), err);
    mdl_model *m2 = NULL;
    ASSERT_OK(mdl_model_load(path, &m2, err), err);
    /* the trailer (88 bytes, last in the SKIN chunk before the 8-byte END chunk) is checked: a
     * version other than 1, 2 or 3, a jump_prob above 1, a ground or blend_linear flag of 2 is
     * refused with a message; a version-2 trailer (no blend_linear) reads as the linear blend */
    FILE *fp = fopen(path, "rb");
    ASSERT(fp != NULL);
    fseek(fp, 0, SEEK_END);
    long len = ftell(fp);
    uint8_t *buf = malloc((size_t)len);
    fseek(fp, 0, SEEK_SET);
    ASSERT(fread(buf, 1, (size_t)len, fp) == (size_t)len);
    fclose(fp);
    remove(path);
    size_t tr = (size_t)len - 8 - 88;
    ASSERT_INT_EQ(buf[tr], 3);
    ASSERT_INT_EQ(buf[tr + 84], 0); /* the gradient blend */
    mdl_model *bad = NULL;
    buf[tr] = 4;
    ASSERT_INT_NE(mdl_model_parse(buf, (size_t)len, "flag", &bad, err), 0);
    printf("trailer version 4: %s\n", err);
    ASSERT(strstr(err, "variations flag") != NULL);
    buf[tr] = 3;
    buf[tr + 80] = 2; /* ground */
    ASSERT_INT_NE(mdl_model_parse(buf, (size_t)len, "ground", &bad, err), 0);
    printf("ground 2: %s\n", err);
    ASSERT(strstr(err, "variations ground") != NULL);
    buf[tr + 80] = 1;
    buf[tr + 84] = 2; /* blend_linear */
    ASSERT_INT_NE(mdl_model_parse(buf, (size_t)len, "blend", &bad, err), 0);
    printf("blend_linear 2: %s\n", err);
    ASSERT(strstr(err, "variations blend_linear") != NULL);
    buf[tr + 84] = 0;
    { /* version 2: the same file without the last u32, the SKIN chunk 4 bytes shorter */
        uint8_t *b2 = malloc((size_t)len - 4);
        memcpy(b2, buf, tr + 84);
        memcpy(b2 + tr + 84, buf + tr + 88, 8);
        b2[tr] = 2;
        size_t at = tr;
        while (at > 0 && memcmp(b2 + at, "SKIN", 4) != 0)
            at--;
        ASSERT(at > 0);
        uint32_t clen;
        memcpy(&clen, b2 + at + 4, 4);
        clen -= 4;
        memcpy(b2 + at + 4, &clen, 4);
        mdl_model *m3 = NULL;
        ASSERT_OK(mdl_model_parse(b2, (size_t)len - 4, "v2", &m3, err), err);
        mdl_variations_opts o3;
        ASSERT_INT_EQ(mdl_variations_attached(m3, &o3, NULL), 1);
        ASSERT_INT_EQ(o3.blend_linear, 1);
        ASSERT_INT_EQ(o3.ground, 1);
        printf("a version-2 trailer reads as the linear blend\n");
        mdl_model_destroy(m3);
        free(b2);
    }
    double big = 2;
    memcpy(buf + tr + 4 + 3 * 8 + 2 * 4, &big, sizeof big); /* jump_prob */
    ASSERT_INT_NE(mdl_model_parse(buf, (size_t)len, "jump", &bad, err), 0);
    printf("jump_prob 2: %s\n", err);
    ASSERT(strstr(err, "variations options out of range") != NULL);
    ASSERT(bad == NULL);
    free(buf);
    mdl_variations_opts o2;
    uint64_t seed = 0;
    ASSERT_INT_EQ(mdl_variations_attached(m2, &o2, &seed), 1);
    ASSERT(seed == 42);
    ASSERT_NEAR(o2.jump_prob, 0.5, 0);
    ASSERT_INT_EQ(o2.blend, o.blend);
    ASSERT_INT_EQ(o2.blend_linear, 0); /* the gradient blend, kept (version 3) */
    ASSERT_INT_EQ(o2.components, 0);
    ASSERT_INT_EQ(o2.ground, 1);
    ASSERT_NEAR(o2.te_factor, 0.2, 0);

    const int F = 200;
    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m2, &o2, &v, err), err);
    mdl_model_info info;
    mdl_model_get_info(m2, &info);
    double *T = calloc((size_t)F * 3 * 12, sizeof *T);
    float *W = calloc((size_t)F * info.nv * 3, sizeof *W), *V = calloc(3 * (size_t)info.nv, sizeof *V);
    int src[200];
    ASSERT_OK(mdl_variations_walk(v, 42, F, T, W, src, err), err);
    int taken = 0;
    for (int f = 1; f < F; f++)
        taken += src[f] != src[f - 1] + 1;
    ASSERT_INT_GT(taken, 3);
    mdl_synth *sy = NULL;
    ASSERT_OK(mdl_synth_create(m2, MDL_KIND_SKIN, &sy, err), err);
    /* the walk's per-frame path allocates nothing (meaningful without ASan, whose allocator
     * mallinfo2 does not see), whatever the number of components */
    mdl_variations_stats vst;
    mdl_variations_get_stats(v, &vst);
    struct mallinfo2 before = mallinfo2();
    for (int f = 0; f < 2 * F; f++) {
        mdl_synth_input in = {.t = (f + 1e-9) / info.fps};
        ASSERT_INT_EQ(mdl_synth_frame(sy, &in, V, NULL), 0);
    }
    struct mallinfo2 after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    printf("play: %d frames of a %d-component walk allocated nothing\n", 2 * F, vst.components);
    double worst = 0;
    for (int pass = 0; pass < 2; pass++) /* the second pass: the clock went back */
        for (int f = 0; f < F; f += pass ? 7 : 1) {
            mdl_synth_input in = {.t = (f + 1e-9) / info.fps};
            ASSERT_INT_EQ(mdl_synth_frame(sy, &in, V, NULL), 0);
            for (int i = 0; i < 3 * info.nv; i++) {
                double d = fabs(V[i] - W[3 * (size_t)f * info.nv + i]);
                worst = d > worst ? d : worst;
                ASSERT_NEAR_I(V[i], W[3 * (size_t)f * info.nv + i], 1e-4, f);
            }
        }
    printf("play: the clock synthesis follows the walk of seed 42 over %d frames (%d transitions, "
           "60 fitted frames) within %.2g\n", F, taken, worst);
    mdl_synth_destroy(sy);
    mdl_variations_destroy(v);
    free(T);
    free(W);
    free(V);
    mdl_model_destroy(m2);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
}

static void test_horse(void)
{
    char err[MDL_ERR_LEN] = "";
    const char *p = test_data("meshes/horse-gallop");
    mdl_meshseq *s = NULL;
    ASSERT_OK(mdl_meshseq_read(p, NULL, &s, err), err);
    int *idx = NULL, n = 0;
    ASSERT_OK(mdl_parse_frames(":", s->frames, &idx, &n, err), err);
    mdl_skin_opts so;
    mdl_skin_opts_default(&so);
    so.bones = 22;
    mdl_model *m = NULL;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    ASSERT_OK(mdl_skin_fit(s, idx, n, &so, &m, err), err);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    mdl_skin_stats sst;
    mdl_skin_get_stats(m, &sst);
    printf("horse: %d frames, 22 bones: rmse %.4f %% of the diagonal, %.1f s\n", n,
           100 * sst.rmse_over_diag, (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec));
    int nf = 0;
    float *E = lp_skin_frames(m, &nf);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    double ej = lp_max_jump(E, info.nv, nf), gj = lp_max_jump(s->V, s->nv, s->frames);
    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m, NULL, &v, err), err);
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    printf("horse: ref bone %d, rank %d, alpha %.3g, beta %.3g, T_c %.4g, %d transitions, %d alive\n",
           st.ref_bone, st.rank, st.alpha, st.beta, st.tc, st.transitions, st.alive_frames);
    /* the paper's T_c admits other valleys of D too; the cheapest from every frame joins it to
     * the corresponding frame of the other cycle, and those are all far cheaper than the rest */
    int half = n / 2, corresponding = 0;
    double worst_corr = 0, cheapest_other = INFINITY;
    for (int k = 0; k < st.transitions; k++) {
        int i, j;
        double c;
        mdl_variations_transition(v, k, &i, &j, &c);
        if (abs(i - j) == half) {
            corresponding++;
            worst_corr = fmax(worst_corr, c);
        } else
            cheapest_other = fmin(cheapest_other, c);
    }
    printf("horse: %d of %d transitions join corresponding frames of the two cycles (costliest "
           "%.3g; the cheapest other %.3g = %.3g x max D(i, i-1))\n", corresponding,
           st.transitions, worst_corr, cheapest_other, cheapest_other / st.max_adjacent);
    int expected = 0;
    for (int i = 1; i < n; i++)
        expected += (i + half <= n - 2) + (i - half >= 2);
    ASSERT_INT_EQ(corresponding, expected);
    ASSERT_GT(cheapest_other, 1000 * worst_corr);
    /* single component, T_c between the two groups: only corresponding frames, no variation */
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    o.tc_factor = 0.02;
    mdl_variations *v1 = NULL;
    ASSERT_OK(mdl_variations_build(m, &o, &v1, err), err);
    mdl_variations_stats st1;
    mdl_variations_get_stats(v1, &st1);
    printf("horse, T_c = 0.02 x max D(i, i-1) = %.3g: %d transitions\n", st1.tc, st1.transitions);
    ASSERT_INT_EQ(st1.transitions, expected);
    mdl_variations_destroy(v1);
    int taken = 0;
    double worst = check_walks(v, m, 336, 4, ej, &taken);
    printf("horse: example max jump %.4f (skin) / %.4f (mesh), walks of 336 frames x 4 seeds: "
           "%d transitions taken, worst jump %.2f x the skin's\n", ej, gj, taken, worst);
    ASSERT_INT_GT(taken, 0);
    ASSERT_LE(worst, 3.0);
    /* the idle source on the horse with its components (the tail walks apart): kept by attach,
     * played by the skin's clock synthesis without allocating per frame */
    mdl_variations_opts oc;
    mdl_variations_opts_default(&oc);
    oc.components = 0;
    ASSERT_OK(mdl_variations_attach(m, &oc, 3, err), err);
    mdl_synth *sy = NULL;
    ASSERT_OK(mdl_synth_create(m, MDL_KIND_SKIN, &sy, err), err);
    mdl_model_info hinfo;
    mdl_model_get_info(m, &hinfo);
    float *HV = calloc(3 * (size_t)hinfo.nv, sizeof *HV);
    ASSERT(HV);
    mdl_synth_input in0 = {.t = 0};
    ASSERT_INT_EQ(mdl_synth_frame(sy, &in0, HV, NULL), 0);
    struct mallinfo2 before = mallinfo2();
    for (int f = 1; f < 400; f++) {
        mdl_synth_input in = {.t = (f + 1e-9) / (hinfo.fps > 0 ? hinfo.fps : 30)};
        ASSERT_INT_EQ(mdl_synth_frame(sy, &in, HV, NULL), 0);
    }
    struct mallinfo2 after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    mdl_variations *vc = NULL;
    ASSERT_OK(mdl_variations_build(m, &oc, &vc, err), err);
    mdl_variations_stats stc;
    mdl_variations_get_stats(vc, &stc);
    printf("horse idle walk: %d components, 400 frames allocated nothing\n", stc.components);
    ASSERT_INT_GT(stc.components, 1);
    mdl_variations_destroy(vc);
    mdl_synth_destroy(sy);
    free(HV);
    mdl_variations_destroy(v);
    free(E);
    free(idx);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
}

int main(void)
{
    mdl_set_blas_threads(1);
    test_looping();
    test_play();
    test_horse();
    printf("walk: ok\n");
    return 0;
}
