/* gltf_fixture.c - the C half of the glTF check (issue 10; gltf_three.mjs is the reader's half):
 * fits a skin to the built-in example creature (48 frames, 8 bones, 4 influences; no shared data
 * needed), writes OUT/skin.glb with mdl_skin_write_gltf (the loop closed: a last key at N / fps
 * repeats frame 0), OUT/once.glb (the clip ends at N - 1) and OUT/expected.bin with our own
 * reconstruction of fitted frames 0, N/2 and N-1:
 *     v_i(f) = sum_s w_is (R_b^f p_i + t_b^f)     (Le & Deng's LBS model, ssdr.h)
 * in double from the skin's weights and bone transforms (mdl_skin_get), the fit's own definition
 * of frame f. The skin kind's clock synthesis (mdl_synth_frame at t = f / fps, float, quaternion
 * blend) is checked against it here too, so the reference is what the daemon plays as well.
 *
 * expected.bin, little-endian float64 throughout:
 *     nv, nsel (3), diag (rest bounding-box diagonal), fps,
 *     nsel x (frame index, time f / fps),
 *     nsel x nv x 3 positions.
 * Then the variations' glTF (`meshsteer variations --gltf`, Zheng 2013): a skin of a 90-frame take
 * of the example (one loop is 75 frames), two walks of 60 frames (seeds 1, 2) as two animations of
 * OUT/variations.glb (mdl_gltf_begin / mdl_gltf_add_clip), and OUT/variations.bin with frames 0,
 * 30, 59 of each skinned by the walk's own skinning (mdl_variations_skin_frame), the same layout
 * as expected.bin with nsel = 6 (animation-major) and a frame index a * 1000 + f.
 * Usage: gltf_fixture OUTDIR */
#include "model.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NFRAMES 48
#define NBONES 8
#define NINFL 4

#define VAR_TAKE 90
#define VAR_FRAMES 60

/* A skin of NBONES bones, NINFL influences fitted to every frame of an n-frame take of the
 * built-in example creature (*seq keeps the take). 0, or -1 with the reason in err. */
static int fit_example(int n, mdl_meshseq **seq, mdl_model **m, char *err)
{
    *seq = NULL;
    *m = NULL;
    int *frames = malloc(sizeof *frames * (size_t)n);
    if (!frames || mdl_example_create(n, seq, NULL, err)) {
        free(frames);
        return -1;
    }
    for (int f = 0; f < n; f++)
        frames[f] = f;
    mdl_skin_opts o;
    mdl_skin_opts_default(&o);
    o.bones = NBONES;
    o.max_influences = NINFL;
    o.name = "example";
    int rc = mdl_skin_fit(*seq, frames, n, &o, m, err);
    free(frames);
    return rc ? -1 : 0;
}

/* OUT/variations.glb and OUT/variations.bin (the header). */
static int variations(const char *dir, char *err)
{
    mdl_meshseq *seq = NULL;
    mdl_model *m = NULL;
    mdl_variations *v = NULL;
    mdl_gltf *g = NULL;
    if (fit_example(VAR_TAKE, &seq, &m, err) || mdl_variations_build(m, NULL, &v, err) ||
        mdl_gltf_begin(m, &g, err))
        return -1;
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    int nv = info.nv, nb = st.bones;
    double fps = info.fps > 0 ? info.fps : 30;
    double *T = calloc((size_t)VAR_FRAMES * nb * 12, sizeof *T);
    int *src = calloc((size_t)VAR_FRAMES * (st.components > 0 ? st.components : 1), sizeof *src);
    const int sel[3] = {0, VAR_FRAMES / 2, VAR_FRAMES - 1};
    size_t nd = 4 + 2 * 6 + 6 * 3 * (size_t)nv;
    double *out = calloc(nd, sizeof *out);
    float *V = calloc(3 * (size_t)nv, sizeof *V);
    if (!T || !src || !out || !V)
        return -1;
    double mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < nv; i++)
        for (int c = 0; c < 3; c++) {
            mn[c] = fmin(mn[c], info.rest[3 * i + c]);
            mx[c] = fmax(mx[c], info.rest[3 * i + c]);
        }
    out[0] = nv;
    out[1] = 6;
    out[2] = sqrt((mx[0] - mn[0]) * (mx[0] - mn[0]) + (mx[1] - mn[1]) * (mx[1] - mn[1]) +
                  (mx[2] - mn[2]) * (mx[2] - mn[2]));
    out[3] = fps;
    for (int a = 0; a < 2; a++) {
        char name[32];
        snprintf(name, sizeof name, "variation_%03d", a);
        if (mdl_variations_walk(v, (uint64_t)(1 + a), VAR_FRAMES, T, NULL, src, err) ||
            mdl_gltf_add_clip(g, name, T, VAR_FRAMES, fps, 0, err))
            return -1;
        for (int k = 0; k < 3; k++) {
            int q = 3 * a + k, f = sel[k];
            out[4 + 2 * q] = a * 1000 + f;
            out[5 + 2 * q] = f / fps;
            mdl_variations_skin_frame(v, T + (size_t)f * nb * 12, V);
            for (size_t i = 0; i < 3 * (size_t)nv; i++)
                out[16 + 3 * (size_t)nv * q + i] = V[i];
        }
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/variations.glb", dir);
    if (mdl_gltf_write(g, path, err))
        return -1;
    snprintf(path, sizeof path, "%s/variations.bin", dir);
    FILE *fp = fopen(path, "wb");
    if (!fp || fwrite(out, sizeof *out, nd, fp) != nd || fclose(fp)) {
        snprintf(err, MDL_ERR_LEN, "%.400s: write failed", path);
        return -1;
    }
    printf("variations: 2 walks of %d frames on a %d-frame skin (%d transitions) as two animations\n",
           VAR_FRAMES, VAR_TAKE, st.transitions);
    mdl_gltf_free(g);
    mdl_variations_destroy(v);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(seq);
    free(T);
    free(src);
    free(out);
    free(V);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s OUTDIR\n", argv[0]);
        return 2;
    }
    char err[MDL_ERR_LEN] = "", path[4096];
    mdl_meshseq *seq = NULL;
    mdl_model *m = NULL;
    if (fit_example(NFRAMES, &seq, &m, err)) {
        fprintf(stderr, "skin of the example: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/skin.glb", argv[1]);
    int wrc = mdl_skin_write_gltf(m, path, 1, err);
    if (!wrc) {
        snprintf(path, sizeof path, "%s/once.glb", argv[1]);
        wrc = mdl_skin_write_gltf(m, path, 0, err);
    }
    if (wrc) {
        fprintf(stderr, "gltf: %s\n", err);
        return 1;
    }

    int nb, K, nfr;
    const int *bone;
    const double *w, *T;
    if (mdl_skin_get(m, &nb, &K, &nfr, &bone, &w, &T) || nb != NBONES || K != NINFL ||
        nfr != NFRAMES) {
        fprintf(stderr, "skin: unexpected shape\n");
        return 1;
    }
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int nv = info.nv;
    double fps = info.fps > 0 ? info.fps : 30;
    double mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < nv; i++)
        for (int c = 0; c < 3; c++) {
            mn[c] = fmin(mn[c], info.rest[3 * i + c]);
            mx[c] = fmax(mx[c], info.rest[3 * i + c]);
        }
    double diag = sqrt((mx[0] - mn[0]) * (mx[0] - mn[0]) + (mx[1] - mn[1]) * (mx[1] - mn[1]) +
                       (mx[2] - mn[2]) * (mx[2] - mn[2]));

    const int sel[3] = {0, nfr / 2, nfr - 1};
    size_t nd = 4 + 2 * 3 + 3 * (size_t)nv * 3;
    double *out = calloc(nd, sizeof *out);
    float *V = calloc(3 * (size_t)nv, sizeof *V);
    mdl_synth *s = NULL;
    if (!out || !V || mdl_synth_create(m, 0, &s, err)) {
        fprintf(stderr, "synth: %s\n", err[0] ? err : "out of memory");
        return 1;
    }
    out[0] = nv;
    out[1] = 3;
    out[2] = diag;
    out[3] = fps;
    double worst_synth = 0;
    for (int k = 0; k < 3; k++) {
        int f = sel[k];
        out[4 + 2 * k] = f;
        out[5 + 2 * k] = f / fps;
        double *P = out + 10 + 3 * (size_t)nv * k;
        for (int i = 0; i < nv; i++) {
            const float *p = info.rest + 3 * (size_t)i;
            for (int q = 0; q < K; q++) {
                double x = w[(size_t)K * i + q];
                if (x == 0)
                    continue;
                const double *M = T + 12 * ((size_t)f * nb + bone[(size_t)K * i + q]);
                for (int c = 0; c < 3; c++)
                    P[3 * i + c] += x * (M[3 * c] * p[0] + M[3 * c + 1] * p[1] + M[3 * c + 2] * p[2] +
                                         M[9 + c]);
            }
        }
        mdl_synth_input in = {.t = f / fps};
        if (mdl_synth_frame(s, &in, V, NULL)) {
            fprintf(stderr, "synth frame %d failed\n", f);
            return 1;
        }
        double e = 0;
        for (size_t i = 0; i < 3 * (size_t)nv; i++)
            e = fmax(e, fabs(V[i] - P[i]));
        worst_synth = fmax(worst_synth, e);
        printf("frame %d (t = %.6f s): clock synthesis vs reconstruction, max |d| %.3g (%.3g of the "
               "diagonal)\n",
               f, f / fps, e, e / diag);
    }
    if (variations(argv[1], err)) {
        fprintf(stderr, "variations: %s\n", err);
        return 1;
    }
    mdl_skin_stats st;
    mdl_skin_get_stats(m, &st);
    printf("skin: %d vertices, %d bones, %d influences, %d frames at %g fps, rmse %.3g, diagonal %.4f\n",
           nv, nb, K, nfr, fps, st.rmse, diag);
    snprintf(path, sizeof path, "%s/expected.bin", argv[1]);
    FILE *fp = fopen(path, "wb");
    if (!fp || fwrite(out, sizeof *out, nd, fp) != nd || fclose(fp)) {
        fprintf(stderr, "%s: write failed\n", path);
        return 1;
    }
    int rc = 0;
    if (worst_synth > 1e-5 * diag) { /* float synthesis: a few ulps of the diagonal */
        fprintf(stderr, "the clock synthesis does not reproduce the fitted frames\n");
        rc = 1;
    }
    mdl_synth_destroy(s);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(seq);
    free(out);
    free(V);
    return rc;
}
