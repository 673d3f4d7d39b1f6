/* test_modelfile.c - the model file container (model/formats/modelfile.c): a version-1 file is
 * converted on load and synthesises exactly what it did; version 2 round-trips byte for byte; an
 * unknown chunk is skipped; every structural fault of the chunk layout is refused with its reason;
 * two models over one mesh merge into one file, and a mesh that differs is refused. */
#include "model.h"
#include "test.h"

#include <errno.h>
#include <unistd.h>

static uint8_t *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    ASSERT(f != NULL);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *b = malloc((size_t)n + 64);
    ASSERT(b != NULL);
    ASSERT_INT_EQ(fread(b, 1, (size_t)n, f), n);
    fclose(f);
    *len = (size_t)n;
    return b;
}

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void wr32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

/* Offset of the chunk with this tag, or 0. */
static size_t find_chunk(const uint8_t *b, size_t len, const char *tag)
{
    for (size_t at = 16; at + 8 <= len; at += 8 + rd32(b + at + 4))
        if (memcmp(b + at, tag, 4) == 0)
            return at;
    return 0;
}

/* Parsing must fail with MDL_EFORMAT and a message containing `want`. */
static void refused(const uint8_t *b, size_t len, const char *want)
{
    char err[MDL_ERR_LEN] = "";
    mdl_model *m = NULL;
    int rc = mdl_model_parse(b, len, "t.msm", &m, err);
    printf("  refused (%d): %s\n", rc, err);
    ASSERT(rc != 0);
    ASSERT(m == NULL);
    if (!strstr(err, want)) {
        fprintf(stderr, "expected the message to contain '%s'\n", want);
        exit(1);
    }
}

/* One synthesised frame with the rig vertices' rest positions as markers. */
static void frame_of(const mdl_model *m, float *V)
{
    char err[MDL_ERR_LEN] = "";
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    float *mk = calloc((size_t)info.nmarkers * 3, sizeof *mk);
    for (int j = 0; j < info.nmarkers; j++)
        memcpy(mk + 3 * j, info.rest + 3 * info.markers[j].vertex, 3 * sizeof(float));
    mdl_synth *s;
    ASSERT_OK(mdl_synth_create(m, 0, &s, err), err);
    ASSERT_INT_EQ(mdl_synth_inputs(s), MDL_INPUT_MARKERS);
    ASSERT_OK(mdl_synth_markers(s, mk, NULL, V, NULL), "synth");
    mdl_synth_destroy(s);
    free(mk);
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    char v2path[] = "/tmp/test_modelfile_XXXXXX";
    int fd = mkstemp(v2path);
    ASSERT(fd >= 0);
    close(fd);

    /* version 1 (written by meshsteer 0.1): converted on load */
    mdl_model *m1;
    ASSERT_OK(mdl_model_load(test_src("tests/data/model_v1.msm"), &m1, err), err);
    mdl_model_info info;
    mdl_model_get_info(m1, &info);
    ASSERT_INT_EQ(info.kind, MDL_KIND_STEER);
    ASSERT_INT_EQ(info.nkinds, 1);
    ASSERT(info.nmarkers > 0);
    ASSERT(info.nclusters > 0);
    ASSERT_INT_EQ(info.topology, mdl_topology_fingerprint(info.F, info.nf, info.nv));
    float *V1 = calloc((size_t)info.nv * 3, sizeof *V1), *V2 = calloc((size_t)info.nv * 3, sizeof *V2);
    frame_of(m1, V1);

    /* saved as version 2, it loads back and synthesises the same frame, bit for bit */
    ASSERT_OK(mdl_model_save(m1, v2path, err), err);
    size_t len;
    uint8_t *b = slurp(v2path, &len);
    ASSERT(memcmp(b, "MSTRMODL", 8) == 0);
    ASSERT_INT_EQ(rd32(b + 8), 2);
    ASSERT_INT_EQ(rd32(b + 12), MDL_KIND_STEER);
    ASSERT_INT_EQ(find_chunk(b, len, "MESH"), 16);
    ASSERT(find_chunk(b, len, "RIG ") > 16);
    ASSERT(find_chunk(b, len, "STER") > find_chunk(b, len, "RIG "));
    ASSERT_INT_EQ(find_chunk(b, len, "END "), len - 8);
    mdl_model *m2;
    ASSERT_OK(mdl_model_parse(b, len, "v2", &m2, err), err);
    frame_of(m2, V2);
    for (int i = 0; i < 3 * info.nv; i++)
        ASSERT_NEAR_I(V2[i], V1[i], 0, i);
    /* and saves to the same bytes */
    char again[] = "/tmp/test_modelfile2_XXXXXX";
    fd = mkstemp(again);
    close(fd);
    ASSERT_OK(mdl_model_save(m2, again, err), err);
    size_t len2;
    uint8_t *b2 = slurp(again, &len2);
    ASSERT_INT_EQ(len2, len);
    ASSERT(memcmp(b, b2, len) == 0);
    free(b2);
    unlink(again);
    mdl_model_destroy(m2);

    /* a chunk this build does not know, before END, is skipped */
    {
        uint8_t *x = malloc(len + 20);
        size_t end = len - 8;
        memcpy(x, b, end);
        memcpy(x + end, "XTRA", 4);
        wr32(x + end + 4, 12);
        memset(x + end + 8, 0xab, 12);
        memcpy(x + end + 20, b + end, 8);
        mdl_model *mx;
        ASSERT_OK(mdl_model_parse(x, len + 20, "xtra", &mx, err), err);
        mdl_model_destroy(mx);
        /* ... but not when its length runs past the file */
        wr32(x + end + 4, 1000000);
        refused(x, len + 20, "longer than the rest of the file");
        free(x);
    }

    /* structural faults, each with its reason */
    uint8_t *c = malloc(len);
    memcpy(c, b, len);
    wr32(c + 8, 3);
    refused(c, len, "version 3");
    memcpy(c, b, len);
    wr32(c + 12, 77);
    refused(c, len, "primary model kind 77");
    refused(b, len - 8, "without an END chunk");
    memcpy(c, b, len);
    memcpy(c + find_chunk(b, len, "MESH"), "MASH", 4);
    refused(c, len, "the first chunk is not MESH");
    memcpy(c, b, len);
    memcpy(c + find_chunk(b, len, "STER"), "STEX", 4); /* unknown now: no kind is left */
    refused(c, len, "no model kind");
    {
        /* a kind chunk one byte longer than what its reader consumes */
        uint8_t *x = malloc(len + 1);
        size_t st = find_chunk(b, len, "STER"), stl = rd32(b + st + 4);
        memcpy(x, b, st + 8 + stl);
        x[st + 8 + stl] = 0;
        memcpy(x + st + 8 + stl + 1, b + st + 8 + stl, len - st - 8 - stl);
        wr32(x + st + 4, (uint32_t)stl + 1);
        refused(x, len + 1, "1 bytes of it were not read");
        free(x);
    }
    free(c);

    /* a second model over the same mesh merges into one; over another mesh it is refused */
    {
        mdl_model *other;
        ASSERT_OK(mdl_model_parse(b, len, "again", &other, err), err);
        ASSERT_INT_EQ(mdl_model_merge(m1, &other, err), -EEXIST); /* both are steering models */
        printf("  merge refused: %s\n", err);
        ASSERT(other != NULL);
        mdl_model_destroy(other);
        mdl_meshseq *s;
        mdl_rig *rig;
        ASSERT_OK(mdl_example_create(20, &s, &rig, err), err); /* not the tube of the v1 file */
        int frames[6] = {0, 3, 6, 9, 12, 15};
        mdl_train_opts o;
        mdl_train_opts_default(&o);
        ASSERT_OK(mdl_steer_train(s, frames, 6, rig, NULL, &o, &other, err), err);
        ASSERT_INT_EQ(mdl_model_merge(m1, &other, err), MDL_ETOPOLOGY);
        printf("  merge refused: %s\n", err);
        mdl_model_destroy(other);
        mdl_meshseq_destroy(s);
        mdl_rig_destroy(rig);
    }

    /* the inspect text names the kind */
    char desc[8192];
    ASSERT_OK(mdl_model_describe(m1, desc, sizeof desc), "describe");
    ASSERT(strstr(desc, "kinds      steer") != NULL);
    char *js = mdl_model_report_json(m1);
    ASSERT(js && strstr(js, "\"kind\":\t\"steer\""));
    free(js);

    free(b);
    free(V1);
    free(V2);
    mdl_model_destroy(m1);
    unlink(v2path);
    printf("model file: v1 converted, v2 round trip, unknown chunk skipped, faults refused\n");
    return 0;
}
