/* test_frames.c - model/frames.c: slices against the index lists Python gives for
 * list(range(count))[spec], and the error cases. Expected lists were written from Python's
 * slice.indices rules and checked with python3. */
#include "model.h"
#include "test.h"

#include <errno.h>

#define END -999 /* terminates an expected list */

static const struct {
    const char *spec;
    int count;
    int want[32];
} ok[] = {
    {"0:24:2", 48, {0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, END}},
    {"1:24:2", 48, {1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, END}},
    {"::-1", 5, {4, 3, 2, 1, 0, END}},
    {"-5:", 48, {43, 44, 45, 46, 47, END}},
    {":", 4, {0, 1, 2, 3, END}},
    {"::", 3, {0, 1, 2, END}},
    {"3", 10, {3, END}},
    {"-1", 10, {9, END}},
    {"-10", 10, {0, END}},
    {"+2", 10, {2, END}},
    {" 2 : 5 ", 10, {2, 3, 4, END}},
    {"2:100", 5, {2, 3, 4, END}},
    {"-100:2", 5, {0, 1, END}},
    {"::3", 10, {0, 3, 6, 9, END}},
    {"1::3", 10, {1, 4, 7, END}},
    {"8:2:-2", 10, {8, 6, 4, END}},
    {"-1:-4:-1", 10, {9, 8, 7, END}},
    {"100::-3", 10, {9, 6, 3, 0, END}},
    {":-100:-1", 3, {2, 1, 0, END}},
    {":2:-1", 5, {4, 3, END}},
    {"0:1", 1, {0, END}},
    {"5:0:-100", 10, {5, END}},
    {"0:99999999999999999999999", 3, {0, 1, 2, END}},
    {"::99999999999999999999999", 3, {0, END}},
};

static const struct {
    const char *spec;
    int count;
    const char *want;
} bad[] = {
    {"", 10, "not a frame number"},
    {"abc", 10, "not a frame number"},
    {"1.5", 10, "not a frame number"},
    {"10", 10, "frame 10 is out of range (10 frames)"},
    {"-11", 10, "frame -11 is out of range"},
    {"0", 0, "frame 0 is out of range (0 frames)"},
    {"::0", 10, "step must not be zero"},
    {"1:2:3:4", 10, "too many ':'"},
    {"a:2", 10, "bad start \"a\""},
    {"1:b", 10, "bad stop \"b\""},
    {"1:2:c", 10, "bad step \"c\""},
    {"1:2:-", 10, "bad step"},
    {"5:2", 10, "selects no frames"},
    {"2:5:-1", 10, "selects no frames"},
    {"-1:0:1", 10, "selects no frames"},
    {"10:", 10, "selects no frames"},
    {":", 0, "selects no frames"},
};

int main(void)
{
    char err[MDL_ERR_LEN];
    for (size_t c = 0; c < sizeof ok / sizeof ok[0]; c++) {
        int *idx = NULL, n = -1;
        err[0] = 0;
        int r = mdl_parse_frames(ok[c].spec, ok[c].count, &idx, &n, err);
        if (r != 0) {
            fprintf(stderr, "\"%s\" (count %d): returned %d: %s\n", ok[c].spec, ok[c].count, r, err);
            return 1;
        }
        int m = 0;
        while (ok[c].want[m] != END)
            m++;
        if (n != m) {
            fprintf(stderr, "\"%s\" (count %d): %d frames, expected %d\n", ok[c].spec, ok[c].count,
                    n, m);
            return 1;
        }
        for (int i = 0; i < n; i++)
            if (idx[i] != ok[c].want[i]) {
                fprintf(stderr, "\"%s\" (count %d): index %d is %d, expected %d\n", ok[c].spec,
                        ok[c].count, i, idx[i], ok[c].want[i]);
                return 1;
            }
        free(idx);
    }
    for (size_t c = 0; c < sizeof bad / sizeof bad[0]; c++) {
        int *idx = (int *)1, n = -1;
        err[0] = 0;
        int r = mdl_parse_frames(bad[c].spec, bad[c].count, &idx, &n, err);
        if (r != -EINVAL || idx != NULL || n != 0 || !strstr(err, bad[c].want) ||
            !strstr(err, bad[c].spec)) {
            fprintf(stderr, "\"%s\" (count %d): returned %d, err \"%s\", expected \"%s\"\n",
                    bad[c].spec, bad[c].count, r, err, bad[c].want);
            return 1;
        }
    }
    /* the full range of a long sequence, as `train --frames :` would ask */
    int *idx, n;
    ASSERT_OK(mdl_parse_frames(":", 100000, &idx, &n, err), err);
    ASSERT_INT_EQ(n, 100000);
    ASSERT_INT_EQ(idx[99999], 99999);
    free(idx);
    return 0;
}
