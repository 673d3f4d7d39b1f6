/* osc.h - the `osc:[HOST:]PORT` marker source (osc.c): markers and VMC bones over OSC/UDP.
 * The address space and the framing rules are in docs/OSC.md; the public part (spec, counters)
 * is in drivers.h. This header adds what the tests and the fuzz target reach inside. */
#ifndef MESHSTEER_DRIVERS_OSC_OSC_H
#define MESHSTEER_DRIVERS_OSC_OSC_H

#include "../drivers.h"

/* Handles one received UDP payload as read() does, at time now_us (CLOCK_MONOTONIC): a malformed
 * packet is counted and dropped; a well-formed one updates the markers and may complete a frame.
 * s must be an open osc source. */
void drv__osc_feed(drv_source *s, const uint8_t *buf, size_t len, uint64_t now_us);
/* Completes the pending frame as a quiet gap would; 1 when a frame became ready. */
int drv__osc_flush(drv_source *s, uint64_t now_us);

extern const drv_source_ops drv_osc_ops;

#endif
