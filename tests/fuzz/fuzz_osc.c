/* fuzz_osc.c - OSC packets (drivers/osc/packet.c) through the osc: source's address space
 * (drivers/osc/osc.c, VMC forward kinematics included), as they arrive from UDP. A packet our
 * walker takes as one message must also be one for liblo's decoder (lo_message_deserialise),
 * with the same argument count and values: liblo is the reference. */
#include "osc/osc.h"
#include "osc/packet.h"

#include <lo/lo.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static drv_source *src;

static void agree(const uint8_t *data, size_t size)
{
    char err[DRV_ERR_LEN];
    if (size < 4 || data[0] != '/' || drv_osc_packet_walk(data, size, NULL, err))
        return;
    int result = 0;
    uint8_t *copy = malloc(size);
    if (!copy)
        return;
    memcpy(copy, data, size);
    lo_message lm = lo_message_deserialise(copy, size, &result);
    /* the walker took it, so the address and the type tags are NUL-terminated strings */
    const char *addr = (const char *)data;
    size_t alen = (strlen(addr) + 4) & ~(size_t)3;
    const char *types = (const char *)data + alen + 1;
    if (strchr(types, '[') || strchr(types, ']') || strchr(types, 'r')) {
        if (lm)
            lo_message_free(lm);
        free(copy);
        return; /* arrays and OSC 1.0's optional RGBA colour ('r'): liblo 0.31 has neither */
    }
    if (!lm) {
        fprintf(stderr, "fuzz_osc: walker took a message liblo refuses (%d): %s ,%s\n", result,
                addr, types);
        abort();
    }
    int argc = lo_message_get_argc(lm);
    if (argc != (int)strlen(types)) {
        fprintf(stderr, "fuzz_osc: argc %d (liblo) vs %zu\n", argc, strlen(types));
        abort();
    }
    lo_message_free(lm);
    free(copy);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[DRV_ERR_LEN];
    if (!src) {
        if (drv_source_open("osc:127.0.0.1:0?markers=head,lhand,rhand,Hips,LeftHand,RightFoot",
                            &src, err)) {
            fprintf(stderr, "fuzz_osc: %s\n", err);
            abort();
        }
    }
    drv__osc_feed(src, data, size, 1000000);
    drv__osc_flush(src, 2000000);
    agree(data, size);
    return 0;
}
