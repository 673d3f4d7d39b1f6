/* fuzz_csv.c - libFuzzer target for the csv marker reader (mdl_markers_parse_csv). Every input must
 * be either accepted or rejected with a message; no crash, no out-of-bounds read, no leak. */
#include "model.h"

#include <stdint.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[MDL_ERR_LEN];
    mdl_markers *m = NULL;
    int r = mdl_markers_parse_csv((const char *)data, size, "fuzz", NULL, &m, err);
    if (r == 0) {
        /* touch everything the reader produced */
        volatile float acc = 0;
        for (size_t i = 0; i < (size_t)m->frames * (size_t)m->count; i++)
            acc += m->valid[i] ? m->P[3 * i] + m->P[3 * i + 1] + m->P[3 * i + 2] : 0;
        for (int i = 0; i < m->count; i++)
            acc += (float)strlen(m->names[i]);
        (void)acc;
    } else if (!memchr(err, 0, sizeof err) || !err[0]) {
        __builtin_trap(); /* every rejection carries a message */
    }
    mdl_markers_destroy(m);
    return 0;
}
