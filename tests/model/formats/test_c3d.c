/* test_c3d.c - the C3D reader on the c3d.org samples (all processor types, int and float
 * storage, odd block layouts, header/parameter disagreements) and the writer by round trip. */
#include "model.h"
#include "test.h"

#include <errno.h>
#include <stdint.h>
#include <unistd.h>

#define C3D(rel) test_data("mocap/c3d/" rel)

static mdl_markers *read_ok(const char *path, const mdl_marker_opts *o)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_read(path, o, &m, err), err);
    ASSERT(m != NULL);
    return m;
}

static long count_valid(const mdl_markers *m)
{
    long n = 0;
    for (size_t i = 0; i < (size_t)m->frames * (size_t)m->count; i++)
        n += m->valid[i];
    return n;
}

/* Max |a - b| over samples valid in both; both sets must agree on validity. */
static double max_diff(const mdl_markers *a, const mdl_markers *b)
{
    ASSERT_INT_EQ(a->frames, b->frames);
    ASSERT_INT_EQ(a->count, b->count);
    double d = 0;
    for (size_t i = 0; i < (size_t)a->frames * (size_t)a->count; i++) {
        ASSERT_INT_EQ(a->valid[i], b->valid[i]);
        if (!a->valid[i])
            continue;
        for (int k = 0; k < 3; k++) {
            double e = fabs((double)a->P[3 * i + k] - b->P[3 * i + k]);
            d = e > d ? e : d;
        }
    }
    return d;
}

static void test_sample01_variants(void)
{
    static const char *v[] = {"pi", "pr", "si", "sr", "vi", "vr"};
    char rel[128];
    mdl_markers *ref = read_ok(C3D("c3d.org/sample01/Eb015pi.c3d"), NULL);
    ASSERT_INT_EQ(ref->count, 26);
    ASSERT_INT_EQ(ref->frames, 450);
    ASSERT_NEAR(ref->fps, 50, 1e-9);
    /* POINT:LABELS has 48 entries; only the first 26 (POINT:USED) are markers */
    for (int i = 0; i < ref->count; i++)
        ASSERT(ref->names[i][0] != 0);
    /* hand-decoded from the file: data block 11 -> byte 5120, int16 (2983, 2722, 449, res 15888),
     * scale 0.0833333358 mm; Y up: (x, z, -y) */
    double s = 0.0833333358168602e-3;
    ASSERT_INT_EQ(ref->valid[0], 1);
    ASSERT_NEAR(ref->P[0], 2983 * s, 1e-6);
    ASSERT_NEAR(ref->P[1], 449 * s, 1e-6);
    ASSERT_NEAR(ref->P[2], -2722 * s, 1e-6);
    /* frame 100 (0-based 99), marker 5: int16 (-785, 5171, 420) at byte 5120 + 99*336 + 40 */
    size_t k = 99 * 26 + 5;
    ASSERT_NEAR(ref->P[3 * k], -785 * s, 1e-6);
    ASSERT_NEAR(ref->P[3 * k + 1], 420 * s, 1e-6);
    ASSERT_NEAR(ref->P[3 * k + 2], -5171 * s, 1e-6);
    for (int i = 1; i < 6; i++) {
        snprintf(rel, sizeof rel, "mocap/c3d/c3d.org/sample01/Eb015%s.c3d", v[i]);
        mdl_markers *m = read_ok(test_data(rel), NULL);
        double d = max_diff(ref, m);
        printf("Eb015%s vs Eb015pi: max diff %.3g mm\n", v[i], d * 1000);
        ASSERT_NEAR_I(d, 0, 0.2e-3, i);
        for (int j = 0; j < m->count; j++)
            ASSERT(strcmp(m->names[j], ref->names[j]) == 0);
        mdl_markers_destroy(m);
    }
    static const char *t[] = {"B", "C", "D"};
    for (int i = 0; i < 3; i++) {
        snprintf(rel, sizeof rel, "mocap/c3d/c3d.org/sample08/TEST%sPI.c3d", t[i]);
        mdl_markers *m = read_ok(test_data(rel), NULL);
        double d = max_diff(ref, m);
        printf("TEST%sPI vs Eb015pi: max diff %.3g mm\n", t[i], d * 1000);
        ASSERT_NEAR_I(d, 0, 0.2e-3, i);
        mdl_markers_destroy(m);
    }
    mdl_markers_destroy(ref);
}

static void test_sample02_procs(void)
{
    /* The same take in the three processor types. sgi_int equals pc_int exactly; dec_int differs
     * from it by one int16 step in 58 coordinates (checked on the raw words: the file itself was
     * rounded differently), and int vs float differ by at most one quantisation step (POINT:SCALE
     * 0.2812 mm). */
    static const char *v[] = {"pc", "dec", "sgi"};
    char rel[128];
    mdl_markers *ri = read_ok(C3D("c3d.org/sample02/pc_int.c3d"), NULL);
    mdl_markers *rr = read_ok(C3D("c3d.org/sample02/pc_real.c3d"), NULL);
    ASSERT_INT_EQ(rr->count, 36);
    ASSERT_INT_EQ(rr->frames, 89);
    ASSERT_NEAR(rr->fps, 50, 1e-9);
    double d = max_diff(ri, rr);
    printf("pc_int vs pc_real: max diff %.4g mm\n", d * 1000);
    ASSERT_NEAR(d, 0, 0.2812e-3 + 1e-6);
    for (int i = 0; i < 3; i++) {
        snprintf(rel, sizeof rel, "mocap/c3d/c3d.org/sample02/%s_int.c3d", v[i]);
        mdl_markers *m = read_ok(test_data(rel), NULL);
        d = max_diff(ri, m);
        printf("%s_int vs pc_int: max diff %.3g mm\n", v[i], d * 1000);
        ASSERT_NEAR_I(d, 0, i == 1 ? 0.2812e-3 + 1e-6 : 1e-6, i);
        mdl_markers_destroy(m);
        snprintf(rel, sizeof rel, "mocap/c3d/c3d.org/sample02/%s_real.c3d", v[i]);
        m = read_ok(test_data(rel), NULL);
        d = max_diff(rr, m);
        printf("%s_real vs pc_real: max diff %.3g mm\n", v[i], d * 1000);
        ASSERT_NEAR_I(d, 0, 1e-6, i);
        mdl_markers_destroy(m);
    }
    mdl_markers_destroy(ri);
    mdl_markers_destroy(rr);
}

static void test_counts(void)
{
    /* sample33: 205 markers, 323 frames, 200 Hz, DATA_START 188 (> 127) */
    mdl_markers *m = read_ok(C3D("c3d.org/sample33/bigparlove.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 205);
    ASSERT_INT_EQ(m->frames, 323);
    ASSERT_NEAR(m->fps, 200, 1e-9);
    /* float storage, hand-decoded at byte 512*187: (-1440.8168, 417.34567, 1135.3995) mm */
    ASSERT_INT_EQ(m->valid[0], 1);
    ASSERT_NEAR(m->P[0], -1.4408168, 1e-6);
    ASSERT_NEAR(m->P[1], 1.1353995, 1e-6);
    ASSERT_NEAR(m->P[2], -0.41734567, 1e-6);
    /* frame 11 marker 7 after 150 analog floats per frame: (-1341.9866, 325.24985, 487.51559) */
    size_t k = 10 * 205 + 7;
    ASSERT_NEAR(m->P[3 * k], -1.3419866, 1e-6);
    ASSERT_NEAR(m->P[3 * k + 1], 0.48751559, 1e-6);
    ASSERT_NEAR(m->P[3 * k + 2], -0.32524985, 1e-6);
    mdl_markers_destroy(m);

    /* basketball: every residual is -1; POINT:UNITS missing (mm) */
    m = read_ok(C3D("c3d.org/sample16/basketball.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 22);
    ASSERT_INT_EQ(m->frames, 34);
    ASSERT_NEAR(m->fps, 25, 1e-5);
    ASSERT_INT_EQ(count_valid(m), 0);
    mdl_markers_destroy(m);

    /* phasespace: no POINT group, header only: 40 points, 701 frames, 30 Hz, 1281 invalid */
    m = read_ok(C3D("c3d.org/sample20/phasespace_sample.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 40);
    ASSERT_INT_EQ(m->frames, 701);
    ASSERT_NEAR(m->fps, 30, 1e-9);
    ASSERT_INT_EQ(count_valid(m), 28040 - 1281);
    ASSERT(strcmp(m->names[0], "M1") == 0);
    mdl_markers_destroy(m);

    /* Dance: header 499 frames, POINT:FRAMES 500, file holds 499 */
    m = read_ok(C3D("c3d.org/sample13/Dance.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 40);
    ASSERT_INT_EQ(m->frames, 499);
    ASSERT_NEAR(m->fps, 65.0533447, 1e-6);
    mdl_markers_destroy(m);
    m = read_ok(C3D("c3d.org/sample13/Dance1.c3d"), NULL);
    ASSERT_INT_EQ(m->frames, 498);
    mdl_markers_destroy(m);

    /* duplicate labels made unique */
    m = read_ok(C3D("c3d.org/sample00/MotionAnalysis_Sample_Jump2.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 51);
    ASSERT_INT_EQ(m->frames, 264);
    ASSERT_NEAR(m->fps, 120, 1e-9);
    int a = mdl_markers_find(m, "RKNE"), b = mdl_markers_find(m, "RKNE#2");
    ASSERT(a >= 0 && b >= 0 && a != b);
    for (int i = 0; i < m->count; i++)
        for (int j = 0; j < i; j++)
            ASSERT(strcmp(m->names[i], m->names[j]) != 0);
    mdl_markers_destroy(m);

    m = read_ok(C3D("c3d.org/sample00/Vicon_pyCGM2_lower_limb_CGM24_Walking01.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 171);
    ASSERT_INT_EQ(m->frames, 493);
    ASSERT_NEAR(m->fps, 100, 1e-9);
    mdl_markers_destroy(m);

    m = read_ok(C3D("c3d.org/sample37/ART-Human_2persons_integer.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 126);
    ASSERT_INT_EQ(m->frames, 972);
    ASSERT_NEAR(m->fps, 60, 1e-9);
    mdl_markers_destroy(m);

    m = read_ok(C3D("hdm05/HDM_dg_06-03_03_120.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 44);
    ASSERT_INT_EQ(m->frames, 202);
    ASSERT_NEAR(m->fps, 120, 1e-9);
    mdl_markers_destroy(m);

    /* CMU: labels like Male:LFWT; Z up in the file, so after conversion heads are ~1.5-2 m up */
    m = read_ok(C3D("cmu/85_02.c3d"), NULL);
    ASSERT_INT_EQ(m->count, 41);
    ASSERT_INT_EQ(m->frames, 810);
    float ymax = -1e9f, ymin = 1e9f;
    for (int i = 0; i < m->count; i++) {
        if (!m->valid[i])
            continue;
        ymax = m->P[3 * i + 1] > ymax ? m->P[3 * i + 1] : ymax;
        ymin = m->P[3 * i + 1] < ymin ? m->P[3 * i + 1] : ymin;
    }
    printf("85_02 frame 1: marker height range %.3f .. %.3f m\n", ymin, ymax);
    ASSERT(ymax - ymin > 1.3 && ymax - ymin < 2.2);
    mdl_markers_destroy(m);
}

static void test_opts(void)
{
    /* scale and up overrides: up = +Y keeps the file axes, scale 1 keeps millimetres */
    mdl_marker_opts o = {.scale = 1.0, .up = MDL_UP_Y};
    mdl_markers *m = read_ok(C3D("c3d.org/sample01/Eb015pi.c3d"), &o);
    double s = 0.0833333358168602;
    ASSERT_NEAR(m->P[0], 2983 * s, 1e-3);
    ASSERT_NEAR(m->P[1], 2722 * s, 1e-3);
    ASSERT_NEAR(m->P[2], 449 * s, 1e-3);
    mdl_markers_destroy(m);
    o.up = 99;
    char err[MDL_ERR_LEN] = "";
    ASSERT(mdl_markers_read(C3D("c3d.org/sample01/Eb015pi.c3d"), &o, &m, err) == -EINVAL);
    ASSERT(m == NULL);
    printf("bad up axis: %s\n", err);
}

static void test_round_trip(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *a = read_ok(C3D("c3d.org/sample00/MotionAnalysis_Sample_Jump2.c3d"), NULL);
    /* make some samples invalid so the residual -1 path is exercised */
    a->valid[3] = 0;
    a->valid[(size_t)a->count * 10 + 7] = 0;
    char path[] = "/tmp/meshsteer_c3d_XXXXXX.c3d";
    int fd = mkstemps(path, 4);
    ASSERT(fd >= 0);
    close(fd);
    ASSERT_OK(mdl_markers_write_c3d(path, a, err), err);
    mdl_markers *b = NULL;
    b = read_ok(path, NULL);
    ASSERT_INT_EQ(b->frames, a->frames);
    ASSERT_INT_EQ(b->count, a->count);
    ASSERT_NEAR(b->fps, a->fps, 1e-4);
    for (int i = 0; i < a->count; i++)
        ASSERT(strcmp(a->names[i], b->names[i]) == 0);
    double d = max_diff(a, b);
    printf("C3D round trip: %ld valid samples, max diff %.3g mm\n", count_valid(b), d * 1000);
    ASSERT_NEAR(d, 0, 1e-6);
    ASSERT_INT_EQ(b->valid[3], 0);
    mdl_markers_destroy(b);

    /* an empty set and one with more than 255 markers (LABELS2) */
    mdl_markers *c;
    ASSERT_OK(mdl_markers_create(3, 300, 90, &c, err), err);
    for (size_t i = 0; i < 3 * 300; i++) {
        c->valid[i] = i % 7 != 0;
        c->P[3 * i] = (float)i * 1e-3f;
        c->P[3 * i + 1] = 1.0f;
        c->P[3 * i + 2] = -(float)i * 1e-4f;
    }
    ASSERT_OK(mdl_markers_write_c3d(path, c, err), err);
    b = read_ok(path, NULL);
    ASSERT_INT_EQ(b->count, 300);
    ASSERT(strcmp(b->names[299], "M300") == 0);
    ASSERT_NEAR(max_diff(c, b), 0, 1e-6);
    mdl_markers_destroy(b);
    mdl_markers_destroy(c);
    mdl_markers_destroy(a);
    unlink(path);
}

static void test_corrupt(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = (mdl_markers *)1;
    /* too short */
    uint8_t tiny[100] = {2, 0x50};
    ASSERT_INT_EQ(mdl_markers_parse_c3d(tiny, sizeof tiny, "tiny", NULL, &m, err), MDL_EFORMAT);
    ASSERT(m == NULL);
    printf("short: %s\n", err);
    FILE *f = fopen(C3D("c3d.org/sample01/Eb015pr.c3d"), "rb");
    ASSERT(f);
    static uint8_t buf[400000];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    ASSERT_INT_EQ(n, 307712);
    /* truncated inside the data: the header announces 450 frames */
    ASSERT_INT_EQ(mdl_markers_parse_c3d(buf, 200000, "cut", NULL, &m, err), MDL_EFORMAT);
    printf("truncated: %s\n", err);
    ASSERT(strstr(err, "truncated") != NULL);
    /* truncated inside the parameter section */
    ASSERT_INT_EQ(mdl_markers_parse_c3d(buf, 600, "cutparam", NULL, &m, err), MDL_EFORMAT);
    printf("truncated params: %s\n", err);
    /* bad key and bad processor type */
    uint8_t save = buf[1];
    buf[1] = 0x51;
    ASSERT_INT_EQ(mdl_markers_parse_c3d(buf, n, "key", NULL, &m, err), MDL_EFORMAT);
    buf[1] = save;
    save = buf[512 + 3];
    buf[512 + 3] = 90;
    ASSERT_INT_EQ(mdl_markers_parse_c3d(buf, n, "proc", NULL, &m, err), MDL_EFORMAT);
    printf("processor: %s\n", err);
    buf[512 + 3] = save;
    /* the intact buffer still parses */
    ASSERT_OK(mdl_markers_parse_c3d(buf, n, "ok", NULL, &m, err), err);
    mdl_markers_destroy(m);
    /* unknown extension, missing file */
    ASSERT(mdl_markers_read("/nonexistent/x.c3d", NULL, &m, err) < 0);
    ASSERT(mdl_markers_read("x.obj", NULL, &m, err) == -EINVAL);
    printf("extension: %s\n", err);
}

int main(void)
{
    test_sample01_variants();
    test_sample02_procs();
    test_counts();
    test_opts();
    test_round_trip();
    test_corrupt();
    printf("ok\n");
    return 0;
}
