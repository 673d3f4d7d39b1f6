/* fuzz_rig.c - fuzz target for the rig JSON parser (model/rig.c), with and without the vertex range
 * check. */
#include "model.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(const mdl_rig *r, int nv)
{
    /* what the parser promises: every index refers to an existing marker or vertex */
    if (r->nmarkers < 2 || (r->nref != 2 && r->nref != 3) || r->nlimbs < 1)
        abort();
    for (int i = 0; i < r->nmarkers; i++)
        if (r->markers[i].vertex < 0 || (nv > 0 && r->markers[i].vertex >= nv) ||
            strlen(r->markers[i].name) >= MDL_NAME_LEN || !r->markers[i].source[0])
            abort();
    for (int i = 0; i < r->nref; i++)
        if (r->ref[i] < 0 || r->ref[i] >= r->nmarkers)
            abort();
    for (int l = 0; l < r->nlimbs; l++) {
        if (r->limb_off[l + 1] - r->limb_off[l] < 2)
            abort();
        for (int k = r->limb_off[l]; k < r->limb_off[l + 1]; k++)
            if (r->limb_idx[k] < 0 || r->limb_idx[k] >= r->nmarkers)
                abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const int nvs[2] = {0, 8431};
    for (int i = 0; i < 2; i++) {
        char err[MDL_ERR_LEN];
        mdl_rig *r = NULL;
        if (mdl_rig_parse((const char *)data, size, "fuzz.json", nvs[i], &r, err) == 0) {
            check(r, nvs[i]);
            mdl_rig_destroy(r);
        } else if (r) {
            abort();
        }
    }
    return 0;
}
