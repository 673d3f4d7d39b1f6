/* metrics.c - counters and histograms of meshsteerd and their Prometheus text (see metrics.h). */
#include "metrics.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* upper bounds in microseconds: fine below 20 ms, where the latency goals lie */
static const uint64_t bucket_us[SRV_HIST_BUCKETS] = {
    100, 250, 500, 750, 1000, 1500, 2000, 3000, 4000, 5000, 7500, 10000, 15000, 20000, 50000,
    100000, 250000, 1000000};

static const char *const drop_names[SRV_DROP_COUNT] = {"synth_busy", "synth_failed", "client_slow",
                                                       "source_error"};

static const char *const nats_drop_names[SRV_NATS_DROP_COUNT] = {"superseded", "disconnected",
                                                                 "pending", "error"};

void srv_metrics_init(srv_metrics *m)
{
    memset(m, 0, sizeof *m); /* all-zero is a valid state for these lock-free atomics */
}

void srv_metrics_count(atomic_uint_fast64_t *c, uint64_t n)
{
    atomic_fetch_add_explicit(c, n, memory_order_relaxed);
}

void srv_metrics_set(atomic_uint_fast64_t *c, uint64_t v)
{
    atomic_store_explicit(c, v, memory_order_relaxed);
}

void srv_hist_observe(srv_hist *h, uint64_t us)
{
    int b = 0;
    while (b < SRV_HIST_BUCKETS && us > bucket_us[b])
        b++;
    atomic_fetch_add_explicit(&h->count[b], 1, memory_order_relaxed);
    atomic_fetch_add_explicit(&h->sum_us, us, memory_order_relaxed);
    atomic_fetch_add_explicit(&h->n, 1, memory_order_relaxed);
}

typedef struct out {
    char *buf;
    size_t cap, len;
} out;

static void emit(out *o, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void emit(out *o, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(o->len < o->cap ? o->buf + o->len : NULL, o->len < o->cap ? o->cap - o->len : 0,
                      fmt, ap);
    va_end(ap);
    if (w > 0)
        o->len += (size_t)w;
}

static uint64_t ld(const atomic_uint_fast64_t *c)
{
    return atomic_load_explicit((atomic_uint_fast64_t *)c, memory_order_relaxed);
}

static void counter(out *o, const char *name, const char *help, uint64_t v)
{
    emit(o, "# HELP %s %s\n# TYPE %s counter\n%s %llu\n", name, help, name, name,
         (unsigned long long)v);
}

static void hist(out *o, const char *name, const char *help, const srv_hist *h)
{
    emit(o, "# HELP %s %s\n# TYPE %s histogram\n", name, help, name);
    uint64_t cum = 0;
    for (int b = 0; b < SRV_HIST_BUCKETS; b++) {
        cum += ld(&h->count[b]);
        emit(o, "%s_bucket{le=\"%g\"} %llu\n", name, (double)bucket_us[b] * 1e-6,
             (unsigned long long)cum);
    }
    cum += ld(&h->count[SRV_HIST_BUCKETS]);
    emit(o, "%s_bucket{le=\"+Inf\"} %llu\n", name, (unsigned long long)cum);
    emit(o, "%s_sum %.6f\n%s_count %llu\n", name, (double)ld(&h->sum_us) * 1e-6, name,
         (unsigned long long)cum);
}

size_t srv_metrics_render(const srv_metrics *m, double uptime_s, char *buf, size_t cap)
{
    out o = {buf, cap, 0};
    if (cap)
        buf[0] = '\0';
    counter(&o, "meshsteer_frames_in_total", "Marker frames read from the source.", ld(&m->frames_in));
    counter(&o, "meshsteer_frames_synthesized_total", "Mesh frames synthesised and published.",
            ld(&m->frames_synth));
    counter(&o, "meshsteer_frames_out_total", "Frame messages written to clients.",
            ld(&m->frames_out));
    counter(&o, "meshsteer_bytes_out_total", "Bytes of WebSocket messages written to clients.",
            ld(&m->bytes_out));
    counter(&o, "meshsteer_partial_writes_total",
            "Frame messages the socket did not take whole (the rest waited in lws).",
            ld(&m->partial_writes));
    emit(&o, "# HELP meshsteer_drops_total Frames dropped, by reason.\n"
             "# TYPE meshsteer_drops_total counter\n");
    for (int d = 0; d < SRV_DROP_COUNT; d++)
        emit(&o, "meshsteer_drops_total{reason=\"%s\"} %llu\n", drop_names[d],
             (unsigned long long)ld(&m->drops[d]));
    emit(&o, "# HELP meshsteer_clients WebSocket clients connected now.\n"
             "# TYPE meshsteer_clients gauge\nmeshsteer_clients %d\n",
         atomic_load(&m->clients));
    counter(&o, "meshsteer_clients_total", "WebSocket clients accepted since start.",
            ld(&m->clients_total));
    counter(&o, "meshsteer_clients_rejected_total",
            "WebSocket connections refused (limit, token, origin).", ld(&m->clients_rejected));
    counter(&o, "meshsteer_control_messages_total", "Control messages accepted.",
            ld(&m->control_ok));
    counter(&o, "meshsteer_control_errors_total", "Control messages answered with an error.",
            ld(&m->control_errors));
    counter(&o, "meshsteer_closed_oversize_total", "Connections closed for an oversized message.",
            ld(&m->closed_oversize));
    counter(&o, "meshsteer_closed_idle_total", "Connections closed for not accepting frames.",
            ld(&m->closed_idle));
    counter(&o, "meshsteer_reloads_total", "Model reloads that succeeded.", ld(&m->reloads_ok));
    counter(&o, "meshsteer_reloads_failed_total", "Model reloads that failed (old model kept).",
            ld(&m->reloads_failed));
    emit(&o, "# HELP meshsteer_driver_switches_total Switches between the tracked pose and the "
             "model's idle animation, by the driver switched to.\n"
             "# TYPE meshsteer_driver_switches_total counter\n"
             "meshsteer_driver_switches_total{to=\"idle\"} %llu\n"
             "meshsteer_driver_switches_total{to=\"tracked\"} %llu\n",
         (unsigned long long)ld(&m->to_idle), (unsigned long long)ld(&m->to_tracked));
    if (atomic_load(&m->osc.present)) {
        const srv_osc_metrics *c = &m->osc;
        counter(&o, "meshsteer_osc_packets_total", "UDP datagrams the osc: source received.",
                ld(&c->packets));
        counter(&o, "meshsteer_osc_malformed_total",
                "Datagrams that are not OSC 1.0 (dropped whole).", ld(&c->malformed));
        counter(&o, "meshsteer_osc_messages_total", "OSC messages in well-formed datagrams.",
                ld(&c->messages));
        counter(&o, "meshsteer_osc_bad_messages_total",
                "Messages to a known address with wrong arguments (dropped).", ld(&c->bad_messages));
        counter(&o, "meshsteer_osc_unknown_names_total",
                "Markers or bones not in the source's marker set (ignored).", ld(&c->unknown_names));
        counter(&o, "meshsteer_osc_ignored_total", "Messages to other addresses (ignored).",
                ld(&c->ignored));
        counter(&o, "meshsteer_osc_frames_total", "Marker frames the OSC traffic completed.",
                ld(&c->frames));
        counter(&o, "meshsteer_osc_coalesced_total",
                "OSC frames replaced by a newer one before the daemon read them (latest wins).",
                ld(&c->coalesced));
    }
    if (atomic_load(&m->nats_enabled)) {
        emit(&o, "# HELP meshsteer_nats_connected 1 while connected to a NATS server.\n"
                 "# TYPE meshsteer_nats_connected gauge\nmeshsteer_nats_connected %d\n",
             atomic_load(&m->nats_connected));
        counter(&o, "meshsteer_nats_messages_total", "Messages published to NATS.",
                ld(&m->nats_msgs));
        counter(&o, "meshsteer_nats_bytes_total", "Bytes of messages published to NATS.",
                ld(&m->nats_bytes));
        counter(&o, "meshsteer_nats_requests_total", "Hello, topology and ping requests answered.",
                ld(&m->nats_requests));
        counter(&o, "meshsteer_nats_reconnects_total", "Reconnections to a NATS server.",
                ld(&m->nats_reconnects));
        emit(&o, "# HELP meshsteer_nats_drops_total Frame messages not published to NATS, by "
                 "reason.\n# TYPE meshsteer_nats_drops_total counter\n");
        for (int d = 0; d < SRV_NATS_DROP_COUNT; d++)
            emit(&o, "meshsteer_nats_drops_total{reason=\"%s\"} %llu\n", nats_drop_names[d],
                 (unsigned long long)ld(&m->nats_drops[d]));
    }
    hist(&o, "meshsteer_synthesis_seconds", "Synthesis plus encoding time per frame.", &m->synth);
    hist(&o, "meshsteer_latency_seconds",
         "End-to-end latency from marker capture to the frame's send, per client message.",
         &m->latency);
    emit(&o, "# HELP meshsteer_uptime_seconds Seconds since start.\n"
             "# TYPE meshsteer_uptime_seconds gauge\nmeshsteer_uptime_seconds %.3f\n",
         uptime_s);
    return o.len;
}
