/* fuzz_obj.c - fuzz target for the OBJ parser (model/obj.c). The input is handed over without a
 * terminating NUL, as a file's bytes would be. */
#include "model.h"

#include <stdint.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[MDL_ERR_LEN];
    mdl_mesh *m = NULL;
    if (mdl_mesh_parse_obj((const char *)data, size, "fuzz.obj", &m, err) == 0) {
        /* what the parser promises: every index inside the vertex array */
        for (long i = 0; i < 3L * m->nf; i++)
            if (m->F[i] >= (uint32_t)m->nv)
                abort();
        mdl_mesh_destroy(m);
    } else if (m) {
        abort();
    }
    return 0;
}
