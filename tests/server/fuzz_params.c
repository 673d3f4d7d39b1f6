/* fuzz_params.c - fuzz target for the client side of the params encoding (clients/params.c): the
 * input is a params model message (MSPM) whose last bytes, read from the end, are also tried as a
 * params frame's vertex block against it. */
#include "params.h"

#include <stdint.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ws_params p;
    char err[256];
    if (ws_params_parse(data, size, &p, err, sizeof err))
        return 0;
    float *V = malloc(sizeof(float) * 3 * (size_t)p.nv);
    size_t tail = size > 4096 ? 4096 : size;
    if (V)
        (void)ws_params_decode(&p, data + size - tail, tail, V, err, sizeof err);
    free(V);
    ws_params_free(&p);
    return 0;
}
