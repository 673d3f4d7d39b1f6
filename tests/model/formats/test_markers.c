/* test_markers.c - what the marker readers share (model/markers.c): repeated labels made unique
 * ("RKNE", "RKNE#2", skipping a suffix already taken) in time linear in the marker count, and
 * declared marker counts bounded by what the file can hold. The four inputs of ../shared/repro
 * (README there) hung the readers for 3 to 23 s; each must now be read or refused in well under a
 * second of CPU time. Skips (77) without ../shared. */
#include "model.h"
#include "test.h"

#include <stdint.h>
#include <time.h>

/* CPU time of this process: the machines are shared, and a busy neighbour must not fail a test
 * whose subject is the work done (quadratic or linear), not the wall clock. */
static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* Every name of m differs from every other (sorted copy, then neighbours). */
static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static void assert_unique(const mdl_markers *m)
{
    char **s = malloc((size_t)m->count * sizeof *s);
    ASSERT(s || m->count == 0);
    memcpy(s, m->names, (size_t)m->count * sizeof *s);
    qsort(s, (size_t)m->count, sizeof *s, cmp_str);
    for (int i = 1; i < m->count; i++)
        if (!strcmp(s[i], s[i - 1])) {
            fprintf(stderr, "name '%s' twice\n", s[i]);
            exit(1);
        }
    free(s);
}

/* A TRC with the given names (tab-separated cells of line 4) and one data row of n markers. */
static char *trc_text(int n, const char *const *names)
{
    size_t cap = 256 + (size_t)n * 64;
    char *t = malloc(cap);
    ASSERT(t);
    int len = snprintf(t, cap, "PathFileType\t4\t(X/Y/Z)\tt.trc\n"
                               "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n"
                               "60\t60\t1\t%d\tmm\nFrame#\tTime", n);
    for (int k = 0; k < n; k++)
        len += snprintf(t + len, cap - (size_t)len, "\t%s\t\t", names[k]);
    len += snprintf(t + len, cap - (size_t)len, "\n\n1\t0");
    for (int k = 0; k < n; k++)
        len += snprintf(t + len, cap - (size_t)len, "\t%d\t2\t3", k);
    snprintf(t + len, cap - (size_t)len, "\n");
    return t;
}

static void test_unique_names(void)
{
    char err[MDL_ERR_LEN] = "";
    /* the rule: the second RKNE becomes RKNE#2, the third RKNE#3; a suffix already taken (the
     * file's own "RKNE#2", "A#2") is skipped */
    const char *names[] = {"RKNE", "RKNE", "RKNE#2", "RKNE", "A", "A#2", "A", "B"};
    const char *want[] = {"RKNE", "RKNE#3", "RKNE#2", "RKNE#4", "A", "A#2", "A#3", "B"};
    char *t = trc_text(8, names);
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_parse_trc(t, strlen(t), "t.trc", NULL, &m, err), err);
    ASSERT_INT_EQ(m->count, 8);
    for (int k = 0; k < 8; k++)
        if (strcmp(m->names[k], want[k])) {
            fprintf(stderr, "name %d: expected %s, got %s\n", k, want[k], m->names[k]);
            exit(1);
        }
    mdl_markers_destroy(m);
    free(t);

    /* 3,000 markers of one name (was cubic: ~10 s), then 50,000 of distinct names (was quadratic:
     * ~2 s); linear now */
    enum { NSAME = 3000, N = 50000 };
    static char buf[N][16];
    static const char *many[N];
    for (int k = 0; k < NSAME; k++) {
        snprintf(buf[k], sizeof buf[k], "%s", "Same");
        many[k] = buf[k];
    }
    t = trc_text(NSAME, many);
    double t0 = now_s();
    ASSERT_OK(mdl_markers_parse_trc(t, strlen(t), "same.trc", NULL, &m, err), err);
    double dt_same = now_s() - t0;
    ASSERT_INT_EQ(m->count, NSAME);
    ASSERT(!strcmp(m->names[0], "Same") && !strcmp(m->names[1], "Same#2"));
    ASSERT(!strcmp(m->names[NSAME - 1], "Same#3000"));
    assert_unique(m);
    mdl_markers_destroy(m);
    free(t);
    for (int k = 0; k < N; k++) {
        snprintf(buf[k], sizeof buf[k], "m%d", k);
        many[k] = buf[k];
    }
    t = trc_text(N, many);
    t0 = now_s();
    ASSERT_OK(mdl_markers_parse_trc(t, strlen(t), "distinct.trc", NULL, &m, err), err);
    double dt_distinct = now_s() - t0;
    assert_unique(m);
    ASSERT(!strcmp(m->names[N - 1], "m49999"));
    mdl_markers_destroy(m);
    free(t);
    printf("unique names: %d markers of one name read in %.3f s, %d distinct in %.3f s\n", NSAME,
           dt_same, N, dt_distinct);
    ASSERT(dt_same < 1.0);
    ASSERT(dt_distinct < 1.0);
}

/* Declared counts beyond what the file holds are refused, with the count in the message. */
static void test_declared_counts(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    const char *trc = "PathFileType\t4\t(X/Y/Z)\tt.trc\n"
                      "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n"
                      "60\t60\t1\t50000\tmm\nFrame#\tTime\tA\n\n1\t0\t1\t2\t3\n";
    ASSERT(mdl_markers_parse_trc(trc, strlen(trc), "t.trc", NULL, &m, err) != 0);
    ASSERT(!m);
    printf("declared 50000 markers: %s\n", err);
    ASSERT(strstr(err, "50000"));
}

/* The repro files: each read or refused within a second. */
static void test_repro(void)
{
    const char *data = getenv("MESHSTEER_DATA");
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/../repro", data ? data : "../shared/data");
    struct stat st;
    if (stat(dir, &st) != 0) {
        fprintf(stderr, "skip: %s not found\n", dir);
        exit(77);
    }
    const char *files[] = {"trc-59210-markers.trc", "trc-99999-markers.trc",
                           "trc-4000-same-names.trc", "c3d-65302-points.c3d"};
    for (int i = 0; i < 4; i++) {
        char path[4200], err[MDL_ERR_LEN] = "";
        snprintf(path, sizeof path, "%s/%s", dir, files[i]);
        mdl_markers *m = NULL;
        double t0 = now_s();
        int r = mdl_markers_read(path, NULL, &m, err);
        double dt = now_s() - t0;
        printf("%s: %s in %.3f s%s%s\n", files[i], r ? "refused" : "read", dt, r ? ": " : "",
               r ? err : "");
        if (!r) {
            assert_unique(m);
            mdl_markers_destroy(m);
        }
        ASSERT(dt < 1.0);
    }
}

/* A directory given as a file is named as one (it "was" 9223372036854775807 bytes, ftell's
 * answer for a directory). */
static void test_directory(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/tests/model/a-directory.c3d",
             getenv("MESHSTEER_BUILD") ? getenv("MESHSTEER_BUILD") : ".");
    mkdir(dir, 0755); /* may exist from an earlier run */
    ASSERT(mdl_markers_read(dir, NULL, &m, err) != 0);
    printf("directory: %s\n", err);
    ASSERT(strstr(err, "is a directory"));
    ASSERT(!strstr(err, "9223372036854775807"));
    mdl_model *model = NULL;
    ASSERT(mdl_model_load(dir, &model, err) != 0);
    printf("directory as a model: %s\n", err);
    ASSERT(strstr(err, "is a directory"));
}

int main(void)
{
    test_directory();
    test_unique_names();
    test_declared_counts();
    test_repro();
    printf("ok\n");
    return 0;
}
