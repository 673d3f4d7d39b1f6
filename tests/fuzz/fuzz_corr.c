/* fuzz_corr.c - fuzz target for the correspondences file parser (model/formats/corr.c) against a
 * fixed rig of three limbs and a 100-triangle target. */
#include "model.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const char rig_json[] =
    "{\"markers\": [{\"name\": \"hip\", \"vertex\": 0}, {\"name\": \"knee\", \"vertex\": 0},"
    " {\"name\": \"ankle\", \"vertex\": 0}, {\"name\": \"toe\", \"vertex\": 0}],"
    " \"reference\": [\"hip\", \"knee\"],"
    " \"limbs\": [[\"hip\", \"knee\", \"toe\"], [\"knee\", \"ankle\"], [\"ankle\", \"toe\", \"knee\"]]}";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static mdl_rig *rig;
    char err[MDL_ERR_LEN];
    if (!rig && mdl_rig_parse(rig_json, sizeof rig_json - 1, "rig", 0, &rig, err))
        abort();
    const int nf = 100;
    int *off = NULL, *idx = NULL;
    if (mdl_corr_parse((const char *)data, size, "fuzz.json", rig, nf, &off, &idx, err) == 0) {
        /* what the parser promises: offsets ascend from 0, every triangle is in range */
        if (!off || !idx || off[0] != 0)
            abort();
        for (int l = 0; l < rig->nlimbs; l++)
            if (off[l + 1] < off[l])
                abort();
        for (int k = 0; k < off[rig->nlimbs]; k++)
            if (idx[k] < 0 || idx[k] >= nf)
                abort();
    } else if (off || idx) {
        abort();
    }
    free(off);
    free(idx);
    return 0;
}
