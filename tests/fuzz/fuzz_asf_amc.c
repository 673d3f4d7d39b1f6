/* fuzz_asf_amc.c - libFuzzer target for the ASF/AMC reader (mdl_markers_parse_asf_amc). The input
 * is the ASF, a NUL byte, then the AMC (no NUL: the ASF alone, its rest pose). Every input must be
 * either accepted or rejected with a message; no crash, no out-of-bounds read, no leak. */
#include "fuzz_markers.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[MDL_ERR_LEN];
    mdl_markers *m = NULL;
    const uint8_t *nul = memchr(data, 0, size);
    size_t sl = nul ? (size_t)(nul - data) : size;
    const char *amc = nul ? (const char *)nul + 1 : NULL;
    size_t ml = nul ? size - sl - 1 : 0;
    int r = mdl_markers_parse_asf_amc((const char *)data, sl, amc, ml, "fuzz", NULL, &m, err);
    return fuzz_markers_check(r, m, err);
}
