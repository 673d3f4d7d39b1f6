/* fuzz_csv.c - libFuzzer target for the csv marker reader (mdl_markers_parse_csv). Every input must
 * be either accepted or rejected with a message; no crash, no out-of-bounds read, no leak. */
#include "fuzz_markers.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[MDL_ERR_LEN];
    mdl_markers *m = NULL;
    int r = mdl_markers_parse_csv((const char *)data, size, "fuzz", NULL, &m, err);
    return fuzz_markers_check(r, m, err);
}
