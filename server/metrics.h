/* metrics.h - the daemon's counters and histograms, updated lock-free from every thread and
 * rendered as Prometheus text for /metrics (text exposition format 0.0.4).
 * Histogram buckets are in seconds; each observation costs a few relaxed atomic adds. */
#ifndef MESHSTEER_SERVER_METRICS_H
#define MESHSTEER_SERVER_METRICS_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define SRV_HIST_BUCKETS 18

typedef struct srv_hist {
    atomic_uint_fast64_t count[SRV_HIST_BUCKETS + 1]; /* last = +Inf */
    atomic_uint_fast64_t sum_us;
    atomic_uint_fast64_t n;
} srv_hist;

/* drop reasons */
enum {
    SRV_DROP_SYNTH_BUSY = 0, /* source frames replaced before synthesis took them */
    SRV_DROP_SYNTH_FAILED,   /* synthesis refused the frame (e.g. no reference yet) */
    SRV_DROP_CLIENT_SLOW,    /* frames a client skipped (latest-frame-wins) */
    SRV_DROP_SOURCE_ERROR,   /* source read errors */
    SRV_DROP_COUNT
};

/* The counters of an osc: source (drivers.h drv_osc_counts), mirrored by the source thread after
 * each read: the source keeps them, the daemon shows them. present = 1 when the source is an
 * osc: one (the meshsteer_osc_* metrics are rendered only then). */
typedef struct srv_osc_metrics {
    atomic_int present;
    atomic_uint_fast64_t packets, malformed, messages, bad_messages, unknown_names, ignored,
        frames, coalesced;
} srv_osc_metrics;

/* NATS publication: frame messages (one per encoding per frame) not published, by reason */
enum {
    SRV_NATS_DROP_SUPERSEDED = 0, /* a newer frame came before the publisher took this one */
    SRV_NATS_DROP_DISCONNECTED,   /* no connection to a NATS server at the time */
    SRV_NATS_DROP_PENDING,        /* the connection's outgoing buffer was full */
    SRV_NATS_DROP_ERROR,          /* the publish failed (e.g. larger than the server's max_payload) */
    SRV_NATS_DROP_COUNT
};

typedef struct srv_metrics {
    atomic_uint_fast64_t frames_in;    /* marker frames from the source */
    atomic_uint_fast64_t frames_synth; /* mesh frames synthesised and published */
    atomic_uint_fast64_t frames_out;   /* frame messages written to clients */
    atomic_uint_fast64_t bytes_out;
    atomic_uint_fast64_t partial_writes; /* frames the socket did not take whole (lws kept the rest) */
    atomic_uint_fast64_t drops[SRV_DROP_COUNT];
    atomic_uint_fast64_t clients_total;
    atomic_uint_fast64_t clients_rejected;
    atomic_uint_fast64_t control_ok;
    atomic_uint_fast64_t control_errors;
    atomic_uint_fast64_t closed_oversize;
    atomic_uint_fast64_t closed_idle;
    atomic_uint_fast64_t reloads_ok;
    atomic_uint_fast64_t reloads_failed;
    atomic_uint_fast64_t to_idle, to_tracked; /* driver switches (the idle animation) */
    atomic_int clients;
    /* NATS publication (publish_nats.c); rendered only when nats_enabled */
    atomic_int nats_enabled, nats_connected;
    atomic_uint_fast64_t nats_msgs, nats_bytes, nats_requests, nats_reconnects;
    atomic_uint_fast64_t nats_drops[SRV_NATS_DROP_COUNT];
    srv_hist synth;   /* synthesis + encoding time */
    srv_hist latency; /* capture -> send, per frame message */
    srv_osc_metrics osc;
} srv_metrics;

void srv_metrics_init(srv_metrics *m);
void srv_hist_observe(srv_hist *h, uint64_t us);
void srv_metrics_count(atomic_uint_fast64_t *c, uint64_t n);
/* Sets a mirrored counter (a source's own running total). */
void srv_metrics_set(atomic_uint_fast64_t *c, uint64_t v);
/* Renders every metric; returns the length, or the needed length (>= cap) when buf is too small. */
size_t srv_metrics_render(const srv_metrics *m, double uptime_s, char *buf, size_t cap);

#endif
