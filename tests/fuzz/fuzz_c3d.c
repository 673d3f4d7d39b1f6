/* fuzz_c3d.c - libFuzzer target for the c3d marker reader (mdl_markers_parse_c3d). Every input must
 * be either accepted or rejected with a message; no crash, no out-of-bounds read, no leak. */
#include "fuzz_markers.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[MDL_ERR_LEN];
    mdl_markers *m = NULL;
    int r = mdl_markers_parse_c3d(data, size, "fuzz", NULL, &m, err);
    return fuzz_markers_check(r, m, err);
}
