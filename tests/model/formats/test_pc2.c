/* test_pc2.c - model/pc2.c: the samba cache against its rest OBJ, write/read round trip, the
 * golden tests/data/tiny.pc2, and corrupt headers and sizes.
 *
 * tests/data/tiny.pc2 is made by this program: `test_pc2 --regenerate tests/data/tiny.pc2`. */
#include "model.h"
#include "test.h"

#include <errno.h>
#include <stdint.h>
#include <unistd.h>

#define TINY_NV 4
#define TINY_FRAMES 3

static uint8_t *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    ASSERT(f);
    ASSERT(fseek(f, 0, SEEK_END) == 0);
    long n = ftell(f);
    ASSERT(n >= 0);
    rewind(f);
    uint8_t *b = malloc(n ? (size_t)n : 1);
    ASSERT(fread(b, 1, (size_t)n, f) == (size_t)n);
    fclose(f);
    *len = (size_t)n;
    return b;
}

/* A unit tetrahedron moving +x by 0.5 per frame, slightly scaled each frame. */
static void tiny_frames(float *V)
{
    static const float tet[TINY_NV][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int f = 0; f < TINY_FRAMES; f++)
        for (int i = 0; i < TINY_NV; i++)
            for (int k = 0; k < 3; k++)
                V[(f * TINY_NV + i) * 3 + k] = tet[i][k] * (1.0f + 0.125f * (float)f) +
                                               (k == 0 ? 0.5f * (float)f : 0.0f);
}

static void test_samba(void)
{
    const char *pc2 = test_data("meshes/samba/samba.pc2");
    const char *rest = test_data("meshes/samba/rest.obj");
    size_t len;
    uint8_t *buf = slurp(pc2, &len);
    char err[MDL_ERR_LEN] = "";
    int nv, frames;
    float start, rate, *V;
    ASSERT_OK(mdl_pc2_parse(buf, len, pc2, &nv, &frames, &start, &rate, &V, err), err);
    ASSERT_INT_EQ(nv, 9971);
    ASSERT_INT_EQ(frames, 175);
    ASSERT(start == 0.0f && rate == 1.0f);
    ASSERT_INT_EQ(len, 32 + 12 * (size_t)nv * (size_t)frames);

    /* frame 0 is rest.obj, float for float (the converter wrote float32(OBJ text)) */
    mdl_mesh *m;
    ASSERT_OK(mdl_mesh_read_obj(rest, &m, err), err);
    ASSERT_INT_EQ(m->nv, nv);
    ASSERT_INT_EQ(m->nf, 19938);
    for (int i = 0; i < 3 * nv; i++)
        if (V[i] != m->V[i]) {
            fprintf(stderr, "frame 0 value %d: %.9g (pc2) != %.9g (rest.obj)\n", i, V[i], m->V[i]);
            exit(1);
        }
    ASSERT(V[0] == 0.49353f); /* rest.obj line 1: v 0.49353 0.0415381 0.0984336 */
    ASSERT(V[1] == 0.0415381f);
    /* and frame 1 differs: the dancer moves */
    int moved = 0;
    for (int i = 0; i < 3 * nv; i++)
        moved += V[3 * nv + i] != V[i];
    ASSERT(moved > nv);
    mdl_mesh_destroy(m);
    free(V);
    free(buf);
}

static void test_roundtrip_and_golden(void)
{
    char dir[] = "/tmp/test_pc2_XXXXXX";
    ASSERT(mkdtemp(dir));
    char path[64];
    snprintf(path, sizeof path, "%s/t.pc2", dir);
    float V[TINY_FRAMES * TINY_NV * 3];
    tiny_frames(V);
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_pc2_write(path, V, TINY_NV, TINY_FRAMES, 10.0f, 0.5f, err), err);
    size_t len;
    uint8_t *buf = slurp(path, &len);
    ASSERT_INT_EQ(len, 32 + 12 * TINY_NV * TINY_FRAMES);
    /* little-endian header, byte for byte */
    static const uint8_t head[32] = {'P', 'O', 'I', 'N', 'T', 'C', 'A', 'C', 'H', 'E', '2', 0,
                                     1, 0, 0, 0, TINY_NV, 0, 0, 0, 0, 0, 0x20, 0x41,
                                     0, 0, 0, 0x3f, TINY_FRAMES, 0, 0, 0};
    ASSERT(memcmp(buf, head, 32) == 0);
    int nv, frames;
    float start, rate, *R;
    ASSERT_OK(mdl_pc2_parse(buf, len, path, &nv, &frames, &start, &rate, &R, err), err);
    ASSERT_INT_EQ(nv, TINY_NV);
    ASSERT_INT_EQ(frames, TINY_FRAMES);
    ASSERT(start == 10.0f && rate == 0.5f);
    ASSERT(memcmp(R, V, sizeof V) == 0);
    free(R);
    free(buf);

    /* the golden file in tests/data is exactly what the writer makes with start 0, rate 1 */
    ASSERT_OK(mdl_pc2_write(path, V, TINY_NV, TINY_FRAMES, 0.0f, 1.0f, err), err);
    buf = slurp(path, &len);
    size_t glen;
    uint8_t *golden = slurp(test_src("tests/data/tiny.pc2"), &glen);
    ASSERT_INT_EQ(glen, len);
    ASSERT(memcmp(golden, buf, len) == 0);
    free(golden);
    free(buf);

    ASSERT_INT_EQ(mdl_pc2_write(path, V, 0, 1, 0, 1, err), -EINVAL);
    ASSERT(mdl_pc2_write("/nonexistent/dir/x.pc2", V, TINY_NV, 1, 0, 1, err) < 0);
    ASSERT(strstr(err, "/nonexistent/dir/x.pc2"));
    unlink(path);
    rmdir(dir);
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void expect_error(const uint8_t *buf, size_t len, int code, const char *want)
{
    uint8_t *copy = malloc(len ? len : 1); /* exact size: ASan catches over-reads */
    memcpy(copy, buf, len);
    char err[MDL_ERR_LEN] = "";
    int nv = -1, frames = -1;
    float *V = (float *)1;
    int r = mdl_pc2_parse(copy, len, "c.pc2", &nv, &frames, NULL, NULL, &V, err);
    free(copy);
    if (r != code || V != NULL || !strstr(err, want)) {
        fprintf(stderr, "returned %d (want %d), err \"%s\", expected \"%s\"\n", r, code, err, want);
        exit(1);
    }
}

static void test_corrupt(void)
{
    float V[TINY_FRAMES * TINY_NV * 3];
    tiny_frames(V);
    size_t len;
    uint8_t *good = slurp(test_src("tests/data/tiny.pc2"), &len);
    ASSERT_INT_EQ(len, 32 + sizeof V);
    uint8_t b[32 + sizeof V];

    expect_error(good, 31, MDL_EFORMAT, "c.pc2: 31 bytes is shorter than the 32-byte PC2 header");
    expect_error(good, 0, MDL_EFORMAT, "shorter than");
    memcpy(b, good, len);
    b[3] = 'X';
    expect_error(b, len, MDL_EFORMAT, "c.pc2: offset 0: bad magic");
    memcpy(b, good, len);
    put32(b + 12, 2);
    expect_error(b, len, MDL_EVERSION, "c.pc2: offset 12: version 2 is not supported");
    memcpy(b, good, len);
    put32(b + 16, 0);
    expect_error(b, len, MDL_EFORMAT, "c.pc2: offset 16: numPoints 0");
    memcpy(b, good, len);
    put32(b + 16, 0x80000000u);
    expect_error(b, len, MDL_EFORMAT, "numPoints -2147483648");
    memcpy(b, good, len);
    put32(b + 28, 0xffffffffu);
    expect_error(b, len, MDL_EFORMAT, "c.pc2: offset 28: numSamples -1");
    /* the largest counts: 32 + 12 N F must be computed without overflow */
    memcpy(b, good, len);
    put32(b + 16, 0x7fffffffu);
    put32(b + 28, 0x7fffffffu);
    expect_error(b, len, MDL_EFORMAT, "need 32 + 12*2147483647*2147483647 bytes, more than 2^64");
    put32(b + 28, 0x40000000u); /* (2^31 - 1) x 2^30: still more than 2^64 bytes */
    expect_error(b, len, MDL_EFORMAT, "more than 2^64");
    put32(b + 16, 1000);
    put32(b + 28, 1000);
    expect_error(b, len, MDL_EFORMAT, "need 32 + 12*1000*1000 = 12000032");
    expect_error(good, len - 1, MDL_EFORMAT, "c.pc2: size 175 bytes, but 4 points x 3 samples need");
    uint8_t longer[32 + sizeof V + 1];
    memcpy(longer, good, len);
    longer[len] = 0;
    expect_error(longer, len + 1, MDL_EFORMAT, "size 177 bytes");
    memcpy(b, good, len);
    put32(b + 20, 0x7fc00000u); /* NaN start frame */
    expect_error(b, len, MDL_EFORMAT, "offset 20: startFrame is not finite");
    memcpy(b, good, len);
    put32(b + 32 + 4 * 17, 0x7f800000u); /* +inf at sample 1, point 1, y */
    expect_error(b, len, MDL_EFORMAT, "c.pc2: offset 100: sample 1 point 1 z is not finite");
    free(good);
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--regenerate") == 0) {
        float V[TINY_FRAMES * TINY_NV * 3];
        tiny_frames(V);
        char err[MDL_ERR_LEN] = "";
        ASSERT_OK(mdl_pc2_write(argv[2], V, TINY_NV, TINY_FRAMES, 0.0f, 1.0f, err), err);
        return 0;
    }
    test_roundtrip_and_golden();
    test_corrupt();
    test_samba();
    return 0;
}
