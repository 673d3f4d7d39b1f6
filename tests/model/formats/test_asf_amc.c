/* test_asf_amc.c - ASF/AMC forward kinematics against hand-computed positions (tests/data/markers/
 * tiny.asf, tiny.amc: CRLF, Latin-1 in a comment and in the documentation), LF the same as CRLF,
 * the rest pose, the skeleton found by name prefix (HDM05), the CMU files, and malformed inputs. */
#include "model.h"
#include "test.h"
#include "segrot.h"

#include <errno.h>

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    ASSERT(f != NULL);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)n + 1);
    ASSERT(b && fread(b, 1, (size_t)n, f) == (size_t)n);
    fclose(f);
    b[n] = 0;
    *len = (size_t)n;
    return b;
}

/* CRLF -> LF in place */
static size_t to_lf(char *b, size_t n)
{
    size_t o = 0;
    for (size_t i = 0; i < n; i++)
        if (b[i] != '\r')
            b[o++] = b[i];
    return o;
}

static void expect_pos(const mdl_markers *m, int f, const char *name, double x, double y, double z)
{
    const double s = 0.0254 / 0.45;
    int j = mdl_markers_find(m, name);
    ASSERT_INT_GE(j, 0);
    const float *p = m->P + 3 * ((size_t)f * m->count + j);
    ASSERT_NEAR_I(p[0], s * x, 1e-5, 3 * j);
    ASSERT_NEAR_I(p[1], s * y, 1e-5, 3 * j + 1);
    ASSERT_NEAR_I(p[2], s * z, 1e-5, 3 * j + 2);
}

static void expect_fail(const char *asf, const char *amc, const char *msg)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    int r = mdl_markers_parse_asf_amc(asf, strlen(asf), amc, amc ? strlen(amc) : 0, "bad", NULL, &m,
                                      err);
    if (r == 0 || m != NULL || !strstr(err, msg)) {
        fprintf(stderr, "expected failure '%s', got %d '%s'\n", msg, r, err);
        exit(1);
    }
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    size_t sl, ml;
    char *asf = slurp(test_src("tests/data/markers/tiny.asf"), &sl);
    char *amc = slurp(test_src("tests/data/markers/tiny.amc"), &ml);
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_parse_asf_amc(asf, sl, amc, ml, "tiny", NULL, &m, err), err);
    ASSERT_INT_EQ(m->frames, 2);
    ASSERT_INT_EQ(m->count, 3);
    ASSERT(strcmp(m->names[0], "root") == 0 && strcmp(m->names[2], "lower") == 0);
    /* frame 1: root at (0, 20, 0), upper straight up by 10, lower along x by 5 */
    expect_pos(m, 0, "root", 0, 20, 0);
    expect_pos(m, 0, "upper", 0, 30, 0);
    expect_pos(m, 0, "lower", 5, 30, 0);
    /* frame 2: the root turned 90 deg about z carries upper to -x; lower: R_upper C Rx(90) C^T with
     * C = Rz(90) sends (1, 0, 0) to (0, 0, -1) */
    expect_pos(m, 1, "upper", -10, 20, 0);
    expect_pos(m, 1, "lower", -10, 20, -5);
    mdl_markers_destroy(m);

    /* LF reads the same */
    char *asf2 = malloc(sl), *amc2 = malloc(ml);
    memcpy(asf2, asf, sl), memcpy(amc2, amc, ml);
    size_t sl2 = to_lf(asf2, sl), ml2 = to_lf(amc2, ml);
    ASSERT_OK(mdl_markers_parse_asf_amc(asf2, sl2, amc2, ml2, "tiny-lf", NULL, &m, err), err);
    expect_pos(m, 1, "lower", -10, 20, -5);
    mdl_markers_destroy(m);

    /* the rest pose: without an AMC, or with opts.rest */
    ASSERT_OK(mdl_markers_parse_asf_amc(asf, sl, NULL, 0, "tiny-rest", NULL, &m, err), err);
    ASSERT_INT_EQ(m->frames, 1);
    expect_pos(m, 0, "root", 0, 0, 0);
    expect_pos(m, 0, "lower", 5, 10, 0);
    mdl_markers_destroy(m);
    mdl_marker_opts ro = {.rest = 1};
    ASSERT_OK(mdl_markers_parse_asf_amc(asf, sl, amc, ml, "tiny-rest", &ro, &m, err), err);
    ASSERT_INT_EQ(m->frames, 1);
    expect_pos(m, 0, "upper", 0, 10, 0);
    mdl_markers_destroy(m);

    /* malformed: every rejection names the problem */
    asf2[sl2 - 1] = 0; /* a NUL-terminated copy for the string edits below */
    const char *hier = strstr(asf2, ":hierarchy");
    ASSERT(hier != NULL);
    char *nohier = strndup(asf2, (size_t)(hier - asf2));
    expect_fail(nohier, NULL, "no :hierarchy");
    char *cut = strndup(asf2, (size_t)(strstr(asf2, "  end\n  begin") - asf2));
    expect_fail(cut, NULL, "has no end");
    expect_fail(asf2, "1\nroot 0 0 0 0 0 0\nelbow 1\n", "unknown bone 'elbow'");
    expect_fail(asf2, "1\nroot 0 0 0 0 0\n", "needs 6 numbers");
    expect_fail(asf2, "1\nlower 1 2\n", "more than 1 numbers");
    expect_fail(asf2, "root 0 0 0 0 0 0\n1\n", "before the first frame number");
    expect_fail(asf2, ":DEGREES\n", "no frame");
    expect_fail(asf2, "1\nlower x\n", "needs 1 numbers");
    expect_fail(asf2, "1\nlower 1 # f\xfcr\n", "above 127");
    free(nohier), free(cut);

    /* mdl_markers_read: the skeleton by name prefix (HDM05), and the CMU files */
    ASSERT_OK(mdl_markers_read(test_data("mocap/asf_amc/hdm05/HDM_dg_06-03_03_120.amc"), NULL, &m,
                               err), err);
    ASSERT_INT_EQ(m->count, 31);
    ASSERT_INT_GE(m->frames, 100);
    float lo = INFINITY, hi = -INFINITY;
    for (size_t k = 0; k < (size_t)m->frames * m->count; k++) {
        ASSERT(isfinite(m->P[3 * k]) && isfinite(m->P[3 * k + 1]) && isfinite(m->P[3 * k + 2]));
        lo = fminf(lo, m->P[3 * k + 1]);
        hi = fmaxf(hi, m->P[3 * k + 1]);
    }
    printf("HDM05 dg: %d frames, height range %.3f .. %.3f m\n", m->frames, lo, hi);
    ASSERT_NEAR(lo, 0, 0.08); /* the feet on the floor */
    ASSERT_NEAR(hi - lo, 1.75, 0.15);
    {
        /* the joint rotations reproduce every bone of every frame */
        mdl_markers *r = NULL;
        mdl_marker_opts ro = {.rest = 1};
        ASSERT_OK(mdl_markers_read(test_data("mocap/asf_amc/hdm05/HDM_dg_06-03_03_120.amc"), &ro,
                                   &r, err), err);
        ASSERT_INT_EQ(m->parent[mdl_markers_find(m, "lhipjoint")], 0);
        ASSERT_INT_EQ(m->parent[mdl_markers_find(m, "lradius")], mdl_markers_find(m, "lhumerus"));
        printf("HDM05 dg joint rotations: largest segment error %.2e m\n", segrot_check(m, r, 1e-4));
        mdl_markers_destroy(r);
    }
    mdl_markers_destroy(m);
    ASSERT_OK(mdl_markers_read(test_data("mocap/asf_amc/cmu_via_gsimchoni/lambada.amc"), NULL, &m,
                               err), err);
    ASSERT_INT_EQ(m->count, 31);
    printf("CMU lambada: %d frames\n", m->frames);
    mdl_markers_destroy(m);
    ASSERT(mdl_markers_read("/nonexistent/x.amc", NULL, &m, err) != 0 && m == NULL);
    free(asf), free(amc), free(asf2), free(amc2);
    puts("asf_amc: ok");
    return 0;
}
