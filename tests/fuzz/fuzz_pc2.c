/* fuzz_pc2.c - fuzz target for the PC2 point-cache parser (model/pc2.c). */
#include "model.h"

#include <stdint.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[MDL_ERR_LEN];
    int nv = 0, frames = 0;
    float start, rate, *V = NULL;
    if (mdl_pc2_parse(data, size, "fuzz.pc2", &nv, &frames, &start, &rate, &V, err) == 0) {
        if (nv <= 0 || frames <= 0 || size != 32 + 12 * (size_t)nv * (size_t)frames)
            abort();
        volatile float sink = V[3 * (size_t)nv * (size_t)frames - 1]; /* last value is inside */
        (void)sink;
        free(V);
    } else if (V) {
        abort();
    }
    return 0;
}
