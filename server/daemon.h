/* daemon.h - state shared by meshsteerd's lws protocols (proto_stream.c, http.c) and its main loop
 * (meshsteerd.c). Everything here is touched only by the lws service thread (the main thread),
 * except `metrics` (atomics) and `pipe` (its own locking). */
#ifndef MESHSTEER_SERVER_DAEMON_H
#define MESHSTEER_SERVER_DAEMON_H

#include "daemon_config.h"
#include "metrics.h"
#include "pipeline.h"
#include "publish_nats.h"

#include <libwebsockets.h>

#define SRV_WS_PROTOCOL "meshsteer.v1" /* Sec-WebSocket-Protocol; optional for clients */
#define SRV_REPLY_QUEUE 8
/* HTTP request heads: the wire guard (wire_guard_io.h) answers 431 above SRV_HTTP_MAX_HEADERS
 * bytes, before lws has them; lws parses what passes into a buffer of SRV_HTTP_HEADER_BUFFER
 * bytes. */
#define SRV_HTTP_HEADER_BUFFER (128 * 1024)
#define SRV_HTTP_MAX_HEADERS 8192

typedef struct srv_session srv_session;

typedef struct srv_daemon {
    srv_config cfg;
    srv_metrics metrics;
    srv_pipeline *pipe;
    srv_publisher *pub;    /* --publish: the NATS publisher, or NULL */
    struct lws_context *ctx;
    srv_session *sessions; /* every established /stream session */
    int nsessions;
    uint64_t next_tag;
    uint64_t t_start_us;
    int draining;          /* shutting down: close every session */
    char model_name[128];
    uint32_t generation;
} srv_daemon;

struct srv_session {
    srv_session *next;
    struct lws *wsi;
    uint64_t tag;
    srv_gen *gen;     /* the generation this client was greeted with (referenced) */
    int stage;        /* 0 hello due, 1 topology due, 2 streaming */
    int encoding;
    uint32_t params_sent; /* generation id whose params model (MSPM) this client has; 0 none */
    uint64_t last_seq;      /* the newest frame written to this client */
    uint64_t accounted_seq; /* frames up to this one were counted as written or skipped */
    uint64_t frames, skipped; /* frames written; frames superseded before this client got them */
    uint32_t skip_pending;  /* skipped since the last write: the next frame header says so */
    unsigned char *rx; /* max_message bytes */
    size_t rx_len;
    int rx_binary;
    char *replies;     /* SRV_REPLY_QUEUE x (LWS_PRE + SRV_REPLY_LEN) */
    size_t reply_len[SRV_REPLY_QUEUE];
    int reply_head, nreplies;
    int timeout_armed;
    uint64_t armed_at_us;
};

extern const struct lws_protocols srv_proto_stream;
extern const struct lws_protocols srv_proto_http;
/* lws accepted wsi's connection (LWS_CALLBACK_SERVER_NEW_CLIENT_INSTANTIATED, which lws 4.1 gives
 * the vhost's default protocol, before it reads a byte): the wire guard takes its socket. 0, or
 * -1 to refuse the connection. */
int srv_accept_guard(struct lws *wsi);
/* protocols[0]'s callback: lws's HTTP dummy, and srv_accept_guard */
int srv_http_accept_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user,
                             void *in, size_t len);

/* 1 when the request carries the token (?token=T or "Authorization: Bearer T"), compared in
 * constant time; /stream, /healthz and /metrics require it when --token is set. */
int srv_request_has_token(struct lws *wsi, const char *token);

/* Asks every session to be written to (new frame, results, shutdown). lws thread only. */
void srv_stream_kick_all(srv_daemon *d);

/* Appends per-client lines to the Prometheus text (meshsteer_client_frames_total and
 * meshsteer_client_skipped_frames_total, labelled by the session's tag); with buf NULL returns the
 * length it needs. lws thread only. */
size_t srv_stream_render_clients(const srv_daemon *d, char *buf, size_t cap);

#endif
