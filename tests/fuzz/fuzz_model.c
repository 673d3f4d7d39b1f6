/* fuzz_model.c - fuzz target for the model file loader (model/formats/modelfile.c, versions 1 and 2,
 * and every kind's chunk). Whatever loads must be safe to synthesise from: every kind of a loaded
 * model is driven through one frame of synthesis (marker kinds with their rig vertices' rest
 * positions as markers, clock kinds at t = 0.5 s). */
#include "model.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[MDL_ERR_LEN] = "";
    mdl_model *m = NULL;
    if (mdl_model_parse(data, size, "fuzz", &m, err) != 0) {
        if (m || !err[0])
            abort(); /* a refusal must say why and leave nothing behind */
        return 0;
    }
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    float *mk = calloc((size_t)info.nmarkers * 3 + 3, sizeof *mk);
    float *V = calloc((size_t)info.nv * 3, sizeof *V);
    for (int j = 0; mk && j < info.nmarkers; j++)
        memcpy(mk + 3 * j, info.rest + 3 * info.markers[j].vertex, 3 * sizeof(float));
    for (int k = 0; k < info.nkinds; k++) {
        mdl_synth *s = NULL;
        if (mk && V && mdl_synth_create(m, info.kinds[k], &s, err) == 0) {
            mdl_synth_input in = {.markers = mk, .t = 0.5};
            mdl_synth_frame(s, &in, V, NULL);
        }
        mdl_synth_destroy(s);
    }
    free(mk);
    free(V);
    char *js = mdl_model_report_json(m);
    free(js);
    char buf[4096];
    mdl_model_describe(m, buf, sizeof buf);
    mdl_model_destroy(m);
    return 0;
}
