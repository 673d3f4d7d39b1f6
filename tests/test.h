/* test.h - assertions that print both sides (libuv ASSERT_EQ style), and the data path.
 * A failed assertion prints file:line, the expression and both values, and exits 1. Tests that
 * need ../shared/data and do not find it exit 77 (skip). */
#ifndef MESHSTEER_TEST_H
#define MESHSTEER_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define ASSERT(c)                                                                                  \
    do {                                                                                           \
        if (!(c)) {                                                                                \
            fprintf(stderr, "%s:%d: assertion failed: %s\n", __FILE__, __LINE__, #c);             \
            exit(1);                                                                               \
        }                                                                                          \
    } while (0)

#define ASSERT_INT_EQ(a, b)                                                                        \
    do {                                                                                           \
        long long _a = (long long)(a), _b = (long long)(b);                                        \
        if (_a != _b) {                                                                            \
            fprintf(stderr, "%s:%d: %s == %s failed: %lld != %lld\n", __FILE__, __LINE__, #a, #b, \
                    _a, _b);                                                                       \
            exit(1);                                                                               \
        }                                                                                          \
    } while (0)

/* Ordered comparisons that print both sides: ASSERT_LT(a, b) checks a < b as doubles (a NaN on
 * either side fails), ASSERT_INT_LT as long long; LE, GT and GE likewise. The _I forms also print
 * an index the caller names (a loop variable, a frame). */
#define ASSERT_CMP_(a, op, b, idx)                                                                 \
    do {                                                                                           \
        double _a = (double)(a), _b = (double)(b);                                                 \
        if (!(_a op _b)) {                                                                         \
            if ((long)(idx) >= 0)                                                                  \
                fprintf(stderr, "%s:%d: %s %s %s failed at index %ld: %.9g vs %.9g\n", __FILE__,   \
                        __LINE__, #a, #op, #b, (long)(idx), _a, _b);                               \
            else                                                                                   \
                fprintf(stderr, "%s:%d: %s %s %s failed: %.9g vs %.9g\n", __FILE__, __LINE__, #a,  \
                        #op, #b, _a, _b);                                                          \
            exit(1);                                                                               \
        }                                                                                          \
    } while (0)
#define ASSERT_LT_I(a, b, idx) ASSERT_CMP_(a, <, b, idx)
#define ASSERT_LE_I(a, b, idx) ASSERT_CMP_(a, <=, b, idx)
#define ASSERT_GT_I(a, b, idx) ASSERT_CMP_(a, >, b, idx)
#define ASSERT_GE_I(a, b, idx) ASSERT_CMP_(a, >=, b, idx)
#define ASSERT_LT(a, b) ASSERT_CMP_(a, <, b, -1)
#define ASSERT_LE(a, b) ASSERT_CMP_(a, <=, b, -1)
#define ASSERT_GT(a, b) ASSERT_CMP_(a, >, b, -1)
#define ASSERT_GE(a, b) ASSERT_CMP_(a, >=, b, -1)

#define ASSERT_INT_CMP_(a, op, b, idx)                                                             \
    do {                                                                                           \
        long long _a = (long long)(a), _b = (long long)(b);                                        \
        if (!(_a op _b)) {                                                                         \
            if ((long)(idx) >= 0)                                                                  \
                fprintf(stderr, "%s:%d: %s %s %s failed at index %ld: %lld vs %lld\n", __FILE__,   \
                        __LINE__, #a, #op, #b, (long)(idx), _a, _b);                               \
            else                                                                                   \
                fprintf(stderr, "%s:%d: %s %s %s failed: %lld vs %lld\n", __FILE__, __LINE__, #a,  \
                        #op, #b, _a, _b);                                                          \
            exit(1);                                                                               \
        }                                                                                          \
    } while (0)
#define ASSERT_INT_LT_I(a, b, idx) ASSERT_INT_CMP_(a, <, b, idx)
#define ASSERT_INT_LE_I(a, b, idx) ASSERT_INT_CMP_(a, <=, b, idx)
#define ASSERT_INT_GT_I(a, b, idx) ASSERT_INT_CMP_(a, >, b, idx)
#define ASSERT_INT_GE_I(a, b, idx) ASSERT_INT_CMP_(a, >=, b, idx)
#define ASSERT_INT_LT(a, b) ASSERT_INT_CMP_(a, <, b, -1)
#define ASSERT_INT_LE(a, b) ASSERT_INT_CMP_(a, <=, b, -1)
#define ASSERT_INT_GT(a, b) ASSERT_INT_CMP_(a, >, b, -1)
#define ASSERT_INT_GE(a, b) ASSERT_INT_CMP_(a, >=, b, -1)
#define ASSERT_INT_NE(a, b) ASSERT_INT_CMP_(a, !=, b, -1)
#define ASSERT_INT_EQ_I(a, b, idx) ASSERT_INT_CMP_(a, ==, b, idx)

/* |a - b| <= tol, printing both, the tolerance and an index the caller names. */
#define ASSERT_NEAR_I(a, b, tol, idx)                                                              \
    do {                                                                                           \
        double _a = (double)(a), _b = (double)(b), _t = (double)(tol);                             \
        if (!(fabs(_a - _b) <= _t)) {                                                              \
            fprintf(stderr, "%s:%d: |%s - %s| <= %g failed at index %ld: %.9g vs %.9g\n",          \
                    __FILE__, __LINE__, #a, #b, _t, (long)(idx), _a, _b);                           \
            exit(1);                                                                               \
        }                                                                                          \
    } while (0)
#define ASSERT_NEAR(a, b, tol) ASSERT_NEAR_I(a, b, tol, -1)

#define ASSERT_OK(expr, errbuf)                                                                    \
    do {                                                                                           \
        int _r = (expr);                                                                           \
        if (_r != 0) {                                                                             \
            fprintf(stderr, "%s:%d: %s returned %d: %s\n", __FILE__, __LINE__, #expr, _r,          \
                    (errbuf));                                                                     \
            exit(1);                                                                               \
        }                                                                                          \
    } while (0)

/* The 1-minute load average (/proc/loadavg; 0 where there is none): benchmarks print it beside
 * wall times on the shared machine. */
static inline double test_load_average(void)
{
    double load = 0;
    FILE *f = fopen("/proc/loadavg", "r");
    if (f) {
        if (fscanf(f, "%lf", &load) != 1)
            load = 0;
        fclose(f);
    }
    return load;
}

/* Path of a file in the shared data set; exits 77 (skip) when the data set is absent. */
static inline const char *test_data(const char *rel)
{
    static char buf[4][4096];
    static int k;
    const char *root = getenv("MESHSTEER_DATA");
    if (!root)
        root = "../shared/data";
    char *b = buf[k++ & 3];
    snprintf(b, sizeof buf[0], "%s/%s", root, rel);
    struct stat st;
    if (stat(b, &st) != 0) {
        fprintf(stderr, "skip: %s not found\n", b);
        exit(77);
    }
    return b;
}

/* Path of a file in the source tree (tests/data, rigs, recordings). */
static inline const char *test_src(const char *rel)
{
    static char buf[4][4096];
    static int k;
    const char *root = getenv("MESHSTEER_SRC");
    if (!root)
        root = ".";
    char *b = buf[k++ & 3];
    snprintf(b, sizeof buf[0], "%s/%s", root, rel);
    return b;
}

#endif
