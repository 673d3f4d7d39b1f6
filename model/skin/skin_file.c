/* skin_file.c - the skin kind's chunk of the model file ("SKIN", docs/FORMATS.md), its summary,
 * report and table (kind.h), and the public getters of model.h.
 *
 * Chunk payload (little-endian, chunkio.h; every array preceded by its u32 count):
 *   u32 nb, K, nframes            bones, influences per vertex, fitted frames (nv is the MESH's)
 *   i32 frames[nframes]           the fitted frames of the example
 *   i32 bone[nv K]                bone of each slot, 0..nb-1
 *   f64 w[nv K]                   weights: >= 0, each vertex's sum 1 within 1e-6
 *   f64 T[nframes nb 12]          R (row-major, orthonormal within 1e-6) then t, per frame, bone
 *   u32 iterations, f64 rmse, rmse_over_diag, max_err, diag, seconds
 * and, only when the synthesis walks the example's transition graph (mdl_variations_attach):
 *   u32 version (1, 2 or 3), f64 svd_tol, tc_factor, threshold, u32 min_gap, blend, f64 jump_prob,
 *   temperature, u32 min_segment, i32 start, u64 seed          (mdl_variations_opts, model.h)
 *   version 2 also: u32 components (0 auto, 1 one), f64 te_factor, u32 ground (0 or 1)
 *   version 3 also: u32 blend_linear (0 the gradient blend, 1 the linear one)
 * (version 1, written before the components were stored, walks one component without --ground;
 * versions 1 and 2, written before the gradient blend, walk with the linear blend they had;
 * readers before the trailer refuse a chunk with it: "bytes of it were not read")
 * Loading checks every count, index, weight sum and rotation: a corrupt file gives a clear error. */
#include "skin/skin_internal.h"
#include "kind.h"
#include "core/util.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void mdl__skin_free(struct mdl_skin *k)
{
    if (!k)
        return;
    free(k->bone);
    free(k->w);
    free(k->T);
    free(k->frames);
    free(k->part);
    free(k);
}

static void skin_destroy(void *impl)
{
    mdl__skin_free(impl);
}

static void skin_save(const void *impl, const mdl_model *m, mdl__wbuf *b)
{
    const struct mdl_skin *k = impl;
    (void)m;
    size_t nk = (size_t)k->nv * k->K;
    mdl__put_u32(b, (uint32_t)k->nb);
    mdl__put_u32(b, (uint32_t)k->K);
    mdl__put_u32(b, (uint32_t)k->nframes);
    mdl__put_i32s(b, k->frames, k->nframes);
    mdl__put_i32s(b, k->bone, nk);
    mdl__put_f64s(b, k->w, nk);
    mdl__put_f64s(b, k->T, (size_t)k->nframes * k->nb * 12);
    mdl__put_u32(b, (uint32_t)k->st.iterations);
    mdl__put_f64(b, k->st.rmse);
    mdl__put_f64(b, k->st.rmse_over_diag);
    mdl__put_f64(b, k->st.max_err);
    mdl__put_f64(b, k->st.diag);
    mdl__put_f64(b, k->st.seconds);
    if (k->has_vars) {
        mdl__put_u32(b, 3);
        mdl__put_f64(b, k->vars.svd_tol);
        mdl__put_f64(b, k->vars.tc_factor);
        mdl__put_f64(b, k->vars.threshold);
        mdl__put_u32(b, (uint32_t)k->vars.min_gap);
        mdl__put_u32(b, (uint32_t)k->vars.blend);
        mdl__put_f64(b, k->vars.jump_prob);
        mdl__put_f64(b, k->vars.temperature);
        mdl__put_u32(b, (uint32_t)k->vars.min_segment);
        mdl__put_u32(b, (uint32_t)k->vars.start);
        mdl__put_u64(b, k->vars_seed);
        mdl__put_u32(b, (uint32_t)k->vars.components);
        mdl__put_f64(b, k->vars.te_factor);
        mdl__put_u32(b, (uint32_t)k->vars.ground);
        mdl__put_u32(b, (uint32_t)k->vars.blend_linear);
    }
}

static int skin_parse(mdl__rbuf *b, const mdl_model *m, void **impl)
{
    *impl = NULL;
    struct mdl_skin *k = mdl__calloc(1, sizeof *k);
    if (!k) {
        b->rc = -ENOMEM;
        return -ENOMEM;
    }
    k->nv = m->nv;
    k->nb = mdl__get_int(b, "bones", 1, 65535);
    k->K = mdl__get_int(b, "influences", 1, 64);
    k->nframes = mdl__get_int(b, "frames", 1, 1 << 24);
    if (!b->rc && (size_t)k->nframes * k->nb * 12 > MDL_CHUNK_MAX_COUNT)
        mdl__rfail(b, "too many bone transforms");
    if (!b->rc && (size_t)k->nv * k->K > MDL_CHUNK_MAX_COUNT)
        mdl__rfail(b, "too many weights");
    size_t nk = (size_t)k->nv * k->K;
    if (!b->rc)
        k->frames = mdl__get_ints(b, k->nframes, "fitted frames", 0, 0x7fffffff);
    if (!b->rc)
        k->bone = mdl__get_ints(b, nk, "weight bones", 0, k->nb - 1);
    if (!b->rc)
        k->w = mdl__get_f64s(b, nk, "weights");
    if (!b->rc)
        k->T = mdl__get_f64s(b, (size_t)k->nframes * k->nb * 12, "bone transforms");
    k->st.iterations = mdl__get_int(b, "iterations", 0, 0x7fffffff);
    k->st.rmse = mdl__get_f64(b, "rmse");
    k->st.rmse_over_diag = mdl__get_f64(b, "rmse_over_diag");
    k->st.max_err = mdl__get_f64(b, "max_err");
    k->st.diag = mdl__get_f64(b, "diag");
    k->st.seconds = mdl__get_f64(b, "seconds");
    if (!b->rc && b->at < b->n) {
        int version = mdl__get_int(b, "variations flag", 1, 3);
        k->has_vars = 1;
        mdl_variations_opts_default(&k->vars);
        k->vars.components = 1; /* version 1: one component, no ground */
        k->vars.blend_linear = 1; /* versions 1-2: the linear blend, the only one then */
        k->vars.svd_tol = mdl__get_f64(b, "variations svd_tol");
        k->vars.tc_factor = mdl__get_f64(b, "variations tc_factor");
        k->vars.threshold = mdl__get_f64(b, "variations threshold");
        k->vars.min_gap = mdl__get_int(b, "variations min_gap", 0, 1 << 24);
        k->vars.blend = mdl__get_int(b, "variations blend", 0, 1 << 24);
        k->vars.jump_prob = mdl__get_f64(b, "variations jump_prob");
        k->vars.temperature = mdl__get_f64(b, "variations temperature");
        k->vars.min_segment = mdl__get_int(b, "variations min_segment", 0, 1 << 24);
        k->vars.start = (int32_t)mdl__get_u32(b);
        k->vars_seed = mdl__get_u64(b);
        if (version >= 2) {
            k->vars.components = mdl__get_int(b, "variations components", 0, 1);
            k->vars.te_factor = mdl__get_f64(b, "variations te_factor");
            k->vars.ground = mdl__get_int(b, "variations ground", 0, 1);
            if (version >= 3)
                k->vars.blend_linear = mdl__get_int(b, "variations blend_linear", 0, 1);
            if (!b->rc && !(k->vars.te_factor >= 0 && k->vars.te_factor <= 1))
                mdl__rfail(b, "variations te_factor out of range");
        }
        if (!b->rc && (!(k->vars.svd_tol >= 0 && k->vars.svd_tol < 1) ||
                       !(k->vars.tc_factor > 0 || k->vars.threshold > 0) ||
                       !(k->vars.threshold >= 0) || !(k->vars.jump_prob >= 0 && k->vars.jump_prob <= 1) ||
                       !(k->vars.temperature >= 0) || k->vars.start < -1 ||
                       k->vars.start >= k->nframes))
            mdl__rfail(b, "variations options out of range");
    }
    for (int i = 0; !b->rc && i < k->nv; i++) {
        double sum = 0;
        for (int q = 0; q < k->K; q++) {
            double w = k->w[(size_t)k->K * i + q];
            if (!(w >= 0 && w <= 1 + 1e-6)) {
                mdl__rfail(b, "a weight outside 0..1");
                break;
            }
            sum += w;
        }
        if (!b->rc && !(fabs(sum - 1) <= 1e-6))
            mdl__rfail(b, "weights of a vertex do not sum to 1");
    }
    for (size_t f = 0; !b->rc && f < (size_t)k->nframes * k->nb; f++) {
        const double *R = k->T + 12 * f;
        for (int a = 0; a < 3 && !b->rc; a++)
            for (int c = 0; c < 3; c++) {
                double d = R[3 * a] * R[3 * c] + R[3 * a + 1] * R[3 * c + 1] + R[3 * a + 2] * R[3 * c + 2];
                if (!(fabs(d - (a == c)) <= 1e-6)) {
                    mdl__rfail(b, "a bone rotation is not orthonormal");
                    break;
                }
            }
    }
    if (!b->rc) {
        k->part = mdl__calloc(k->nv, sizeof *k->part);
        if (!k->part)
            b->rc = -ENOMEM;
        else
            for (int i = 0; i < k->nv; i++)
                k->part[i] = k->bone[(size_t)k->K * i];
    }
    if (b->rc) {
        mdl__skin_free(k);
        return b->rc;
    }
    k->st.bones = k->nb;
    k->st.max_influences = k->K;
    k->st.frames = k->nframes;
    k->st.vertices = k->nv;
    *impl = k;
    return 0;
}

static void skin_info(const void *impl, mdl_model_info *info)
{
    const struct mdl_skin *k = impl;
    info->nclusters = k->nb;
    info->part = k->part;
    info->ntrain = k->nframes;
    info->train_frames = k->frames;
}

static void skin_describe(const void *impl, const mdl_model *m, char *buf, size_t len, size_t *at)
{
    const struct mdl_skin *k = impl;
    (void)m;
    mdl__appendf(buf, len, at, "skin       %d bones, at most %d influences per vertex (Le & Deng 2012)\n",
                 k->nb, k->K);
    mdl__appendf(buf, len, at, "fitted     %d frames (", k->nframes);
    for (int i = 0; i < k->nframes && i < 12; i++)
        mdl__appendf(buf, len, at, "%s%d", i ? " " : "", k->frames[i]);
    mdl__appendf(buf, len, at, "%s), %d iterations, %.2f s\n", k->nframes > 12 ? " ..." : "",
                 k->st.iterations, k->st.seconds);
    mdl__appendf(buf, len, at, "error      rmse %.6g (%.4f %% of the diagonal %.4g), max %.6g\n",
                 k->st.rmse, 100 * k->st.rmse_over_diag, k->st.diag, k->st.max_err);
    if (k->has_vars)
        mdl__appendf(buf, len, at, "plays      an endless random walk on the transition graph (Zheng "
                     "2013), seed %llu, components %s%s, blend %s\n",
                     (unsigned long long)k->vars_seed, k->vars.components == 1 ? "1" : "auto",
                     k->vars.ground ? ", ground" : "",
                     k->vars.blend < 1 ? "none" : k->vars.blend_linear ? "linear" : "gradient");
    else
        mdl__appendf(buf, len, at, "plays      the fitted frames, looping\n");
}

static void skin_report(const void *impl, const mdl_model *m, void *obj)
{
    const struct mdl_skin *k = impl;
    cJSON *o = obj;
    (void)m;
    cJSON_AddNumberToObject(o, "bones", k->nb);
    cJSON_AddNumberToObject(o, "max_influences", k->K);
    cJSON_AddNumberToObject(o, "frames", k->nframes);
    cJSON_AddNumberToObject(o, "iterations", k->st.iterations);
    cJSON_AddNumberToObject(o, "rmse", k->st.rmse);
    cJSON_AddNumberToObject(o, "rmse_over_diag", k->st.rmse_over_diag);
    cJSON_AddNumberToObject(o, "max_err", k->st.max_err);
    cJSON_AddNumberToObject(o, "seconds", k->st.seconds);
    cJSON *bones = cJSON_AddArrayToObject(o, "bone_vertices");
    for (int j = 0; j < k->nb; j++) {
        int c = 0;
        for (int i = 0; i < k->nv; i++)
            c += k->part[i] == j;
        cJSON_AddItemToArray(bones, cJSON_CreateNumber(c));
    }
}

/* play.c */
int mdl__skin_synth_create(const mdl_model *m, const void *impl, void **state, char *err);
int mdl__skin_synth_frame(void *state, const mdl_synth_input *in, float *V, mdl_synth_info *info);
void mdl__skin_synth_reset(void *state);
void mdl__skin_synth_destroy(void *state);
int mdl__skin_synth_params_layout(const void *state, mdl_params_layout *out);
int mdl__skin_synth_params(const void *state, float *out);

const mdl_kind_ops mdl__skin_kind = {
    .id = MDL_KIND_SKIN,
    .name = "skin",
    .tag = {'S', 'K', 'I', 'N'},
    .inputs = MDL_INPUT_CLOCK,
    .destroy = skin_destroy,
    .save = skin_save,
    .parse = skin_parse,
    .info = skin_info,
    .describe = skin_describe,
    .report = skin_report,
    .synth_create = mdl__skin_synth_create,
    .synth_frame = mdl__skin_synth_frame,
    .synth_reset = mdl__skin_synth_reset,
    .synth_destroy = mdl__skin_synth_destroy,
    .synth_params_layout = mdl__skin_synth_params_layout,
    .synth_params = mdl__skin_synth_params,
    .eval = mdl__skin_eval,
};

int mdl_skin_get_stats(const mdl_model *m, mdl_skin_stats *st)
{
    const mdl_kind_slot *s = mdl__model_kind(m, MDL_KIND_SKIN);
    if (!s)
        return -ENOENT;
    *st = ((const struct mdl_skin *)s->impl)->st;
    return 0;
}

int mdl_skin_get(const mdl_model *m, int *nb, int *K, int *nframes, const int **bone,
                 const double **w, const double **T)
{
    const mdl_kind_slot *s = mdl__model_kind(m, MDL_KIND_SKIN);
    if (!s)
        return -ENOENT;
    const struct mdl_skin *k = s->impl;
    if (nb)
        *nb = k->nb;
    if (K)
        *K = k->K;
    if (nframes)
        *nframes = k->nframes;
    if (bone)
        *bone = k->bone;
    if (w)
        *w = k->w;
    if (T)
        *T = k->T;
    return 0;
}
