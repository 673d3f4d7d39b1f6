/* test_csv.c - the plain CSV marker format (write/read round trip, empty cells, malformed input)
 * and the Kinect v2 joints CSV of microsoft/LabanotationSuite. */
#include "model.h"
#include "test.h"

#include <errno.h>
#include <unistd.h>

static void test_round_trip(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *a = NULL, *b = NULL;
    ASSERT_OK(mdl_markers_read(test_data("mocap/trc/opensim/subject01_walk1.trc"), NULL, &a, err),
              err);
    a->valid[5] = 0;
    char path[] = "/tmp/meshsteer_csv_XXXXXX.CSV"; /* extension match is case-insensitive */
    int fd = mkstemps(path, 4);
    ASSERT(fd >= 0);
    close(fd);
    ASSERT_OK(mdl_markers_write_csv(path, a, err), err);
    ASSERT_OK(mdl_markers_read(path, NULL, &b, err), err);
    ASSERT_INT_EQ(b->frames, a->frames);
    ASSERT_INT_EQ(b->count, a->count);
    ASSERT_NEAR(b->fps, 60, 1e-6);
    for (int i = 0; i < a->count; i++)
        ASSERT(strcmp(a->names[i], b->names[i]) == 0);
    for (size_t i = 0; i < (size_t)a->frames * (size_t)a->count; i++) {
        ASSERT_INT_EQ(b->valid[i], a->valid[i]);
        if (a->valid[i])
            for (int k = 0; k < 3; k++)
            ASSERT_NEAR_I(b->P[3 * i + k], a->P[3 * i + k], 0, i); /* %.9g is exact for float */
    }
    ASSERT_INT_EQ(b->valid[5], 0);
    mdl_markers_destroy(b);
    mdl_markers_destroy(a);
    unlink(path);
}

static const char small[] = "frame,time,a_x,a_y,a_z,B_X,B_Y,B_Z\r\n"
                            "0,0,1,2,3,,,\r\n"
                            "1,0.5,1.5,2.5,3.5,4,5,6\r\n";

static void test_small(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_parse_csv(small, strlen(small), "small", NULL, &m, err), err);
    ASSERT_INT_EQ(m->frames, 2);
    ASSERT_INT_EQ(m->count, 2);
    ASSERT_NEAR(m->fps, 2, 1e-12);
    ASSERT(strcmp(m->names[0], "a") == 0 && strcmp(m->names[1], "B") == 0);
    ASSERT_INT_EQ(m->valid[1], 0);
    ASSERT_INT_EQ(m->valid[3], 1);
    ASSERT_NEAR(m->P[3 * 3 + 2], 6, 0);
    mdl_markers_destroy(m);
    /* scale and up: mm with Z up */
    mdl_marker_opts o = {.scale = 0.001, .up = MDL_UP_Z};
    ASSERT_OK(mdl_markers_parse_csv(small, strlen(small), "small", &o, &m, err), err);
    ASSERT_NEAR(m->P[0], 0.001, 1e-9);
    ASSERT_NEAR(m->P[1], 0.003, 1e-9);
    ASSERT_NEAR(m->P[2], -0.002, 1e-9);
    mdl_markers_destroy(m);
}

static void expect_bad(const char *text, const char *what)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = (mdl_markers *)1;
    int r = mdl_markers_parse_csv(text, strlen(text), "bad", NULL, &m, err);
    printf("%s: %d %s\n", what, r, err);
    ASSERT(r == MDL_EFORMAT);
    ASSERT(m == NULL);
    ASSERT(strncmp(err, "bad:", 4) == 0);
}

static void test_bad(void)
{
    expect_bad("", "empty");
    expect_bad("0,0,1,2,3\n", "no header");
    expect_bad("frame,time,a_x,a_y\n", "column count");
    expect_bad("frame,time,a_x,b_y,a_z\n", "mismatched names");
    expect_bad("frame,time,a_x,a_y,a_z\n0,0,1,2\n", "short row (truncated)");
    expect_bad("frame,time,a_x,a_y,a_z\n0,0,1,2,3,4\n", "long row");
    expect_bad("frame,time,a_x,a_y,a_z\n0,0,1,zz,3\n", "bad number");
    expect_bad("frame,time,a_x,a_y,a_z\n0,0,1,nan,3\n", "nan");
}

static void test_kinect(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_read(test_data("skeleton/kinect2-labanotation/Ges01_wavehand.csv"), NULL,
                               &m, err),
              err);
    ASSERT_INT_EQ(m->frames, 154);
    ASSERT_INT_EQ(m->count, 25);
    /* mean frame interval 33.8 ms (data README); (rows - 1) / timestamp span = 29.611 Hz */
    ASSERT_NEAR(m->fps, 29.6114, 1e-3);
    ASSERT(strcmp(m->names[0], "SpineBase") == 0);
    ASSERT(strcmp(m->names[24], "ThumbR") == 0);
    /* first row: SpineBase 0.0111604,-0.367822,2.69467 (state 2) */
    ASSERT_INT_EQ(m->valid[0], 1);
    ASSERT_NEAR(m->P[0], 0.0111604, 1e-7);
    ASSERT_NEAR(m->P[1], -0.367822, 1e-7);
    ASSERT_NEAR(m->P[2], 2.69467, 1e-6);
    /* last row, Head: -0.00329091, 0.38495, 2.65372 */
    size_t k = 153 * 25 + 3;
    ASSERT_NEAR(m->P[3 * k], -0.00329091, 1e-7);
    ASSERT_NEAR(m->P[3 * k + 1], 0.38495, 1e-7);
    ASSERT_NEAR(m->P[3 * k + 2], 2.65372, 1e-6);
    mdl_markers_destroy(m);
    ASSERT_OK(mdl_markers_read(test_data("skeleton/kinect2-labanotation/KinectReader_joints.csv"),
                               NULL, &m, err),
              err);
    ASSERT_INT_EQ(m->frames, 371);
    ASSERT_NEAR(m->fps, 29.8387, 1e-3);
    mdl_markers_destroy(m);

    /* tracking state 0 -> invalid; a bad state and a short row are errors */
    char row[2048];
    int n = snprintf(row, sizeof row, "100");
    for (int j = 0; j < 25; j++)
        n += snprintf(row + n, sizeof row - (size_t)n, ",%d.5,1,2,%d", j, j == 3 ? 0 : 2);
    snprintf(row + n, sizeof row - (size_t)n, ",\n");
    ASSERT_OK(mdl_markers_parse_csv(row, strlen(row), "k", NULL, &m, err), err);
    ASSERT_INT_EQ(m->frames, 1);
    ASSERT_INT_EQ(m->valid[3], 0);
    ASSERT_INT_EQ(m->valid[4], 1);
    ASSERT_NEAR(m->P[3 * 4], 4.5, 0);
    mdl_markers_destroy(m);
    char bad[4096];
    snprintf(bad, sizeof bad, "%s%s", row, row);
    char *p = strrchr(bad, ',');
    p[-1] = '7'; /* state 7 in the second row */
    expect_bad(bad, "kinect state");
    snprintf(bad, sizeof bad, "%s%.200s\n", row, row);
    expect_bad(bad, "kinect short row");
}

int main(void)
{
    test_small();
    test_round_trip();
    test_bad();
    test_kinect();
    printf("ok\n");
    return 0;
}
