/* test_trc.c - the TRC reader on the OpenSim example files (trailing tabs, space-padded cells,
 * inconsistent Orig* fields) and on hand-written malformed inputs. */
#include "model.h"
#include "test.h"

#include <errno.h>

#define TRC(rel) test_data("mocap/trc/opensim/" rel)

static mdl_markers *read_ok(const char *path)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_read(path, NULL, &m, err), err);
    return m;
}

static void test_walk(void)
{
    mdl_markers *m = read_ok(TRC("subject01_walk1.trc"));
    ASSERT_INT_EQ(m->frames, 151);
    ASSERT_INT_EQ(m->count, 41);
    ASSERT_NEAR(m->fps, 60, 1e-9);
    ASSERT(strcmp(m->names[0], "R.ASIS") == 0);
    ASSERT_INT_EQ(mdl_markers_find(m, "V.Sacral"), 2);
    /* row 1: R.ASIS 617.247620 1055.275020 170.781980 (mm, Y up already) */
    ASSERT_INT_EQ(m->valid[0], 1);
    ASSERT_NEAR(m->P[0], 0.61724762, 1e-7);
    ASSERT_NEAR(m->P[1], 1.05527502, 1e-7);
    ASSERT_NEAR(m->P[2], 0.17078198, 1e-7);
    /* row 151, marker 3 (V.Sacral): 411.469180 1042.821660 28.446270 */
    size_t k = 150 * 41 + 2;
    ASSERT_NEAR(m->P[3 * k], 0.41146918, 1e-7);
    ASSERT_NEAR(m->P[3 * k + 1], 1.04282166, 1e-7);
    ASSERT_NEAR(m->P[3 * k + 2], 0.02844627, 1e-7);
    for (size_t i = 0; i < 151 * 41; i++)
        ASSERT_INT_EQ(m->valid[i], 1);
    mdl_markers_destroy(m);
}

static void test_running_and_rajagopal(void)
{
    /* header lines padded with many trailing tabs */
    mdl_markers *m = read_ok(TRC("subject02_running.trc"));
    ASSERT_INT_EQ(m->frames, 600);
    ASSERT_INT_EQ(m->count, 41);
    ASSERT_NEAR(m->fps, 60, 1e-9);
    ASSERT_NEAR(m->P[0], 0.8090094, 1e-7);
    mdl_markers_destroy(m);
    /* OrigNumFrames 128 vs NumFrames 510, trailing tab on every row, Time "  0.230000" */
    m = read_ok(TRC("rajagopal_motion_capture_run.trc"));
    ASSERT_INT_EQ(m->frames, 510);
    ASSERT_INT_EQ(m->count, 42);
    ASSERT_NEAR(m->fps, 100, 1e-9);
    ASSERT(strcmp(m->names[0], "LPSI") == 0);
    ASSERT_NEAR(m->P[0], 0.878948715, 1e-7);
    ASSERT_NEAR(m->P[1], 1.067420124, 1e-7);
    ASSERT_NEAR(m->P[2], -0.433885912, 1e-7);
    mdl_markers_destroy(m);
    /* up-axis override: +Z up maps (x, y, z) to (x, z, -y) */
    mdl_marker_opts o = {.scale = 0, .up = MDL_UP_Z};
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_markers_read(TRC("rajagopal_motion_capture_run.trc"), &o, &m, err), err);
    ASSERT_NEAR(m->P[1], -0.433885912, 1e-7);
    ASSERT_NEAR(m->P[2], -1.067420124, 1e-7);
    mdl_markers_destroy(m);
}

static const char good[] =
    "PathFileType\t4\t(X/Y/Z)\tt.trc\n"
    "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n"
    "50\t50\t3\t2\tm\n"
    "Frame#\tTime\tA\t\t\tA\t\t\n"
    "\t\tX1\tY1\tZ1\tX2\tY2\tZ2\n"
    "\n"
    "1\t0\t1\t2\t3\t4\t5\t6\n"
    "2\t0.02\t\t\t\t4.5\t5.5\t6.5\n"
    "3\t0.04\t1.5\t2.5\t3.5\n";

static void test_small(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_parse_trc(good, strlen(good), "good", NULL, &m, err), err);
    ASSERT_INT_EQ(m->frames, 3);
    ASSERT_INT_EQ(m->count, 2);
    ASSERT_NEAR(m->fps, 50, 0);
    ASSERT(strcmp(m->names[1], "A#2") == 0); /* repeated name made unique */
    ASSERT_NEAR(m->P[3], 4, 0);              /* Units m */
    ASSERT_INT_EQ(m->valid[2], 0);           /* empty cells */
    ASSERT_INT_EQ(m->valid[3], 1);
    ASSERT_INT_EQ(m->valid[5], 0);           /* short row */
    ASSERT_NEAR(m->P[3 * 4 + 2], 3.5, 1e-6);
    mdl_markers_destroy(m);
}

static void expect_bad(const char *text, const char *what)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = (mdl_markers *)1;
    int r = mdl_markers_parse_trc(text, strlen(text), "bad", NULL, &m, err);
    printf("%s: %d %s\n", what, r, err);
    ASSERT(r == MDL_EFORMAT);
    ASSERT(m == NULL);
    ASSERT(strncmp(err, "bad:", 4) == 0);
}

static void test_bad(void)
{
    char buf[1024];
    /* truncated: fewer rows than NumFrames */
    snprintf(buf, sizeof buf, "%.*s", (int)(strstr(good, "3\t0.04") - good), good);
    expect_bad(buf, "truncated rows");
    expect_bad("PathFileType\t4\n", "truncated header");
    expect_bad("Hello\n1\n2\n3\n4\n", "not trc");
    /* a marker with only two of its three cells */
    snprintf(buf, sizeof buf, "%s", good);
    char *p = strstr(buf, "1.5\t2.5\t3.5");
    strcpy(p, "1.5\t2.5\n");
    expect_bad(buf, "partial marker");
    snprintf(buf, sizeof buf, "%s", good);
    p = strstr(buf, "4.5");
    p[1] = 'x';
    expect_bad(buf, "bad number");
    snprintf(buf, sizeof buf, "%s", good);
    p = strstr(buf, "\tm\n");
    p[1] = 'q';
    expect_bad(buf, "bad units");
}

int main(void)
{
    test_walk();
    test_running_and_rajagopal();
    test_small();
    test_bad();
    printf("ok\n");
    return 0;
}
