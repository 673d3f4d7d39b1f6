/* fuzz_model.c - fuzz target for the model file loader (model/modelfile.c). Whatever loads must be
 * safe to synthesise from: a loaded model is driven through one frame of synthesis with its rig
 * vertices' rest positions as markers, and every output coordinate must be finite. */
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
    mdl_synth *s = NULL;
    float *mk = calloc((size_t)info.nmarkers * 3, sizeof *mk);
    float *V = calloc((size_t)info.nv * 3, sizeof *V);
    if (mk && V && mdl_synth_create(m, &s, err) == 0) {
        for (int j = 0; j < info.nmarkers; j++)
            memcpy(mk + 3 * j, info.rest + 3 * info.markers[j].vertex, 3 * sizeof(float));
        mdl_synth_frame(s, mk, NULL, V, NULL);
    }
    mdl_synth_destroy(s);
    free(mk);
    free(V);
    char *js = mdl_model_report_json(m);
    free(js);
    char buf[4096];
    mdl_model_describe(m, buf, sizeof buf);
    mdl_model_destroy(m);
    return 0;
}
