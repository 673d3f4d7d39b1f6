/* loadclient.h - what meshsteer-load's two transports share: per-subscriber frame statistics and
 * the latency samples of a run (loadclient.c: WebSocket to the daemon; loadclient_nats.c: NATS
 * subjects the daemon publishes to). Knows only docs/PROTOCOL.md. */
#ifndef MESHSTEER_CLIENTS_LOADCLIENT_H
#define MESHSTEER_CLIENTS_LOADCLIENT_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define LOAD_HEADER 56 /* frame message header (docs/PROTOCOL.md) */

/* One subscriber's frames over the measured time. */
typedef struct load_stats {
    uint64_t first_seq, last_seq, frames, skipped;
    uint64_t bytes; /* frame message bytes counted */
} load_stats;

typedef struct load_run {
    const char *encoding;
    uint64_t t_measure, t_end;  /* frames received outside [t_measure, t_end) are not counted */
    uint32_t *e2e, *srv, *syn; /* microseconds, caplat each */
    size_t caplat;
    atomic_size_t nlat;        /* samples taken (may pass caplat: the rest are lost) */
} load_run;

uint64_t load_now_us(void);
/* Counts a frame message of len bytes (h: its first LOAD_HEADER bytes, checked by the caller)
 * received at t into s and r. Thread-safe across different s. */
void load_frame(load_run *r, load_stats *s, const unsigned char *h, uint64_t len, uint64_t t);

/* NATS: n subscribers, subscriber i connected to the i-th URL of the comma list (round robin; the
 * others are its fail-over list), each subscribed to PREFIX.frames.ENCODING after joining as a late
 * joiner does (PREFIX.get.hello, PREFIX.get.topology). Runs for warm + secs seconds from now
 * (r->t_measure and r->t_end set by the caller). Fills st[n] and *up (subscribers that joined and
 * were still connected at the end). 0, or -1 with a message on stderr for bad usage. */
int load_nats_run(load_run *r, const char *urls, const char *prefix, int n, load_stats *st,
                  int *up);

#endif
