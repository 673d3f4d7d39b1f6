/* test_bvh.c - BVH forward kinematics against hand-computed positions, the unit guess, the CMU
 * walk file, and malformed inputs. */
#include "model.h"
#include "test.h"
#include "segrot.h"

#include <errno.h>

/* Hips at the root, Chest above it, Leg to the side with an X position channel; CRLF and LF
 * mixed. Rotation order of the root is Z, X, Y. */
static const char tiny[] =
    "HIERARCHY\r\n"
    "ROOT Hips\r\n"
    "{\r\n"
    "  OFFSET 0 0 0\r\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\r\n"
    "  JOINT Chest\n"
    "  {\n"
    "    OFFSET 0 10 0\n"
    "    CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "    End Site\n"
    "    {\n"
    "      OFFSET 0 5 0\n"
    "    }\n"
    "  }\n"
    "  JOINT Leg\n"
    "  {\n"
    "    OFFSET 2 0 0\n"
    "    CHANNELS 4 Xrotation Yrotation Zrotation Xposition\n"
    "    End Site\n"
    "    {\n"
    "      OFFSET 0 -8 0\n"
    "    }\n"
    "  }\n"
    "}\n"
    "MOTION\n"
    "Frames: 3\n"
    "Frame Time: 0.04\n"
    "1 2 3 0 0 0  0 0 0  0 0 0 2\r\n"
    "10 0 0 90 0 0  0 90 0  0 0 0 2\n"
    "0 0 0 90 90 0  0 0 0  0 0 0 4\n";

static void expect_pos(const mdl_markers *m, int f, const char *name, double x, double y, double z,
                       double s)
{
    int j = mdl_markers_find(m, name);
    ASSERT_INT_GE(j, 0);
    const float *p = m->P + 3 * ((size_t)f * (size_t)m->count + (size_t)j);
    printf("frame %d %-10s (%g, %g, %g)\n", f, name, p[0], p[1], p[2]);
    ASSERT_NEAR_I(p[0], x * s, 1e-5, f);
    ASSERT_NEAR_I(p[1], y * s, 1e-5, f);
    ASSERT_NEAR_I(p[2], z * s, 1e-5, f);
}

static void test_tiny(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    mdl_marker_opts o = {.scale = 1, .up = MDL_UP_AUTO};
    ASSERT_OK(mdl_markers_parse_bvh(tiny, strlen(tiny), "tiny", &o, &m, err), err);
    ASSERT_INT_EQ(m->count, 5);
    ASSERT_INT_EQ(m->frames, 3);
    ASSERT_NEAR(m->fps, 25, 1e-9);
    ASSERT(strcmp(m->names[0], "Hips") == 0);
    ASSERT(strcmp(m->names[2], "Chest_End") == 0);
    ASSERT(strcmp(m->names[4], "Leg_End") == 0);
    /* frame 0: pure translation (1, 2, 3) */
    expect_pos(m, 0, "Hips", 1, 2, 3, 1);
    expect_pos(m, 0, "Chest", 1, 12, 3, 1);
    expect_pos(m, 0, "Chest_End", 1, 17, 3, 1);
    expect_pos(m, 0, "Leg", 3, 2, 3, 1);
    expect_pos(m, 0, "Leg_End", 3, -6, 3, 1);
    /* frame 1: root at (10,0,0) turned 90 deg about Z: (x,y) -> (-y,x); Chest turned 90 about X */
    expect_pos(m, 1, "Hips", 10, 0, 0, 1);
    expect_pos(m, 1, "Chest", 0, 0, 0, 1);
    expect_pos(m, 1, "Chest_End", 0, 0, 5, 1);
    expect_pos(m, 1, "Leg", 10, 2, 0, 1);
    expect_pos(m, 1, "Leg_End", 18, 2, 0, 1);
    /* frame 2: root Rz(90) * Rx(90) (listed order); Rx * Rz would put Chest at (-10, 0, 0).
     * Leg's Xposition 4 replaces its OFFSET x of 2. */
    expect_pos(m, 2, "Chest", 0, 0, 10, 1);
    expect_pos(m, 2, "Leg", 0, 4, 0, 1);
    expect_pos(m, 2, "Leg_End", 0, 4, -8, 1);
    mdl_markers_destroy(m);

    /* unit guess: frame 0 height 17 - (-6) = 23 units; 23 * 0.056444 = 1.30 m is the closest
     * to 1.75 m among 23, 0.23, 0.023, 0.584 and 1.30 */
    ASSERT_OK(mdl_markers_parse_bvh(tiny, strlen(tiny), "tiny", NULL, &m, err), err);
    expect_pos(m, 0, "Chest", 1, 12, 3, 0.056444);
    mdl_markers_destroy(m);
    /* Z up: (x, y, z) -> (x, z, -y) */
    o.up = MDL_UP_Z;
    ASSERT_OK(mdl_markers_parse_bvh(tiny, strlen(tiny), "tiny", &o, &m, err), err);
    expect_pos(m, 0, "Chest", 1, 3, -12, 1);
    mdl_markers_destroy(m);
}

static void test_cmu(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_read(test_data("mocap/bvh/cmu/131_01.bvh"), NULL, &m, err), err);
    ASSERT_INT_EQ(m->frames, 994);
    ASSERT_INT_EQ(m->count, 31 + 7);
    ASSERT_NEAR(m->fps, 1 / 0.0083333, 1e-6);
    ASSERT(strcmp(m->names[0], "Hips") == 0);
    ASSERT_INT_GE(mdl_markers_find(m, "Head_End"), 0);
    int lt = mdl_markers_find(m, "LeftToe_End"), rt = mdl_markers_find(m, "RightToe_End");
    int head = mdl_markers_find(m, "Head_End");
    ASSERT_INT_GE(lt, 0);
    ASSERT_INT_GE(rt, 0);
    ASSERT_INT_GE(head, 0);
    float lo = 1e9f, hi = -1e9f;
    for (int j = 0; j < m->count; j++) {
        lo = m->P[3 * j + 1] < lo ? m->P[3 * j + 1] : lo;
        hi = m->P[3 * j + 1] > hi ? m->P[3 * j + 1] : hi;
    }
    printf("131_01 frame 0: height %.3f m (y %.3f .. %.3f), toes at %.3f / %.3f, head end %.3f\n",
           hi - lo, lo, hi, m->P[3 * lt + 1], m->P[3 * rt + 1], m->P[3 * head + 1]);
    /* Measured 1.427 m: toe tip (End Site) to the Head End Site of the CMU skeleton in the
     * first frame; the rest pose (all channels 0) spans 24.27 units = 1.370 m. The joint skeleton
     * is shorter than the subject's stature, hence the lower bound below 1.5 m. */
    ASSERT_GT(hi - lo, 1.35);
    ASSERT_LT(hi - lo, 1.9);
    /* the guessed unit is the CMU unit: the same as asking for scale 0.056444 */
    mdl_markers *g = NULL;
    mdl_marker_opts o = {.scale = 0.056444, .up = MDL_UP_AUTO};
    ASSERT_OK(mdl_markers_read(test_data("mocap/bvh/cmu/131_01.bvh"), &o, &g, err), err);
    for (size_t i = 0; i < 3 * (size_t)m->count * (size_t)m->frames; i += 97)
        ASSERT_NEAR_I(g->P[i], m->P[i], 1e-6, i);
    mdl_markers_destroy(g);
    /* feet near the floor over the whole walk: in every frame the lowest marker is a foot joint
     * (Toe or Toe_End) within 10 cm of y = 0 (measured: -0.023 .. 0.080 m) */
    for (int f = 0; f < m->frames; f++) {
        const float *P = m->P + 3 * (size_t)f * (size_t)m->count;
        int arg = 0;
        for (int j = 1; j < m->count; j++)
            arg = P[3 * j + 1] < P[3 * arg + 1] ? j : arg;
        ASSERT_NEAR_I(P[3 * arg + 1], 0, 0.10, f);
        ASSERT(strstr(m->names[arg], "Toe") != NULL);
    }
    /* the joint rotations reproduce every segment of every frame (float positions: 1e-4 m), also
     * read with +Z up (the rotations turn with the axes) */
    mdl_markers *r = NULL;
    mdl_marker_opts ro = {.rest = 1};
    ASSERT_OK(mdl_markers_read(test_data("mocap/bvh/cmu/131_01.bvh"), &ro, &r, err), err);
    ASSERT_INT_EQ(m->parent[0], -1);
    ASSERT_INT_EQ(m->parent[mdl_markers_find(m, "LeftWrist")], mdl_markers_find(m, "LeftElbow"));
    printf("131_01 joint rotations: largest segment error %.2e m\n", segrot_check(m, r, 1e-4));
    for (int i = 0; i < r->count; i++)
        ASSERT_NEAR_I(r->rot[4 * i], 1, 1e-6, i); /* the rest pose: the identity */
    mdl_markers_destroy(r);
    mdl_markers_destroy(m);
    ro.up = MDL_UP_Z;
    ASSERT_OK(mdl_markers_read(test_data("mocap/bvh/cmu/131_01.bvh"), &ro, &r, err), err);
    ro.rest = 0;
    ASSERT_OK(mdl_markers_read(test_data("mocap/bvh/cmu/131_01.bvh"), &ro, &m, err), err);
    printf("131_01 read with +Z up: largest segment error %.2e m\n", segrot_check(m, r, 1e-4));
    mdl_markers_destroy(r);
    mdl_markers_destroy(m);
}

static void expect_bad(const char *text, size_t len, const char *what)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = (mdl_markers *)1;
    int r = mdl_markers_parse_bvh(text, len, "bad", NULL, &m, err);
    printf("%s: %d %s\n", what, r, err);
    ASSERT(r == MDL_EFORMAT);
    ASSERT(m == NULL);
    ASSERT(strncmp(err, "bad:", 4) == 0);
}

static void test_bad(void)
{
    size_t n = strlen(tiny);
    expect_bad(tiny, n - 10, "truncated motion");
    expect_bad(tiny, 200, "truncated hierarchy");
    expect_bad("HIERARCHY\nMOTION\nFrames: 0\nFrame Time: 1\n", 40, "no root");
    char buf[2048];
    snprintf(buf, sizeof buf, "%s", tiny);
    char *p = strstr(buf, "Zrotation Xrotation Yrotation\n");
    memcpy(p, "Qrotation", 9);
    expect_bad(buf, strlen(buf), "bad channel");
    snprintf(buf, sizeof buf, "%s", tiny);
    p = strstr(buf, "Frames: 3");
    p[8] = '9';
    expect_bad(buf, strlen(buf), "frames overstated");
    snprintf(buf, sizeof buf, "%s1 2 3\n", tiny);
    expect_bad(buf, strlen(buf), "extra data");
    snprintf(buf, sizeof buf, "%s", tiny);
    p = strstr(buf, "10 0 0 90");
    p[1] = 'x';
    expect_bad(buf, strlen(buf), "bad number");
}

int main(void)
{
    test_tiny();
    test_cmu();
    test_bad();
    printf("ok\n");
    return 0;
}
