/* fuzz_markers.h - what every marker-reader fuzz target checks of a result: an accepted input
 * yields readable arrays (every sample and name touched), a rejected one carries a message. */
#ifndef MESHSTEER_FUZZ_MARKERS_H
#define MESHSTEER_FUZZ_MARKERS_H

#include "model.h"

#include <stdint.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static inline int fuzz_markers_check(int r, mdl_markers *m, const char *err)
{
    if (r == 0) {
        volatile float acc = 0;
        for (size_t i = 0; i < (size_t)m->frames * (size_t)m->count; i++)
            acc += m->valid[i] ? m->P[3 * i] + m->P[3 * i + 1] + m->P[3 * i + 2] : 0;
        for (int i = 0; i < m->count; i++)
            acc += (float)strlen(m->names[i]);
        (void)acc;
    } else if (!memchr(err, 0, MDL_ERR_LEN) || !err[0]) {
        __builtin_trap(); /* every rejection carries a message */
    }
    mdl_markers_destroy(m);
    return 0;
}

#endif
