/* wsclient.h - a small libwebsockets client for the daemon tests: connects to /stream, keeps the
 * hello, the topology and the frames it receives (decoded as docs/PROTOCOL.md says), collects text
 * replies, and sends text messages. One lws context, serviced by the caller's thread. */
#ifndef MESHSTEER_TESTS_WSCLIENT_H
#define MESHSTEER_TESTS_WSCLIENT_H

#include <stddef.h>
#include <stdint.h>

#define WSC_MAX_FRAMES 4096
#define WSC_MAX_TEXT 64

typedef struct wsc_frame {
    uint64_t seq, t_capture, t_synth, t_send, t_recv;
    int encoding, flags, skipped;
    uint32_t generation;
    float *V; /* nv x 3 decoded (only when keep_vertices) */
    float *M; /* nm x 3 marker positions, model order (only when keep_vertices) */
} wsc_frame;

typedef struct wsc {
    struct lws *wsi;
    int connected, closed, close_code, failed;
    int keep_vertices;
    char *hello;           /* the last hello */
    int hellos;
    unsigned char *topo;   /* the last topology message */
    size_t topo_len;
    int topos;
    int nv, nf, nm;
    float qmin[3], qmax[3];
    wsc_frame frames[WSC_MAX_FRAMES];
    int nframes;           /* stops growing at WSC_MAX_FRAMES; total counts all */
    uint64_t total_frames, bytes;
    uint64_t last_seq;     /* of the newest frame, counted in total_frames */
    char *texts[WSC_MAX_TEXT]; /* non-hello text messages (replies) */
    int ntexts;
    char *out[16];         /* queued text to send */
    size_t out_len[16];
    int nout;
    int out_bin[16];       /* queued entry is binary */
    unsigned char *rx;
    size_t rx_len, rx_cap;
    struct ws_params *params; /* the last params model (MSPM), parsed; NULL before one */
    size_t params_len;
    int params_msgs;
    int protocol_errors;   /* malformed binary messages */
    int want_close;        /* wsc_close asked for a normal close */
    char error[256];
} wsc;

struct lws_context *wsc_context(void);
/* Opens ws://127.0.0.1:port/stream[?query]; NULL query for none. Origin: 127.0.0.1. */
wsc *wsc_connect(struct lws_context *ctx, int port, const char *query, int keep_vertices);
/* The same with a given Origin header (NULL: none); Host is 127.0.0.1:port, as a browser's. */
wsc *wsc_connect_origin(struct lws_context *ctx, int port, const char *query, const char *origin,
                        int keep_vertices);
void wsc_send(wsc *c, const char *text);
void wsc_send_binary(wsc *c, const void *data, size_t len);
/* Services the context until pred(ud) is true or timeout_ms passes; returns pred's last value. */
int wsc_run(struct lws_context *ctx, int timeout_ms, int (*pred)(void *), void *ud);
/* Closes the connection normally (1000) at the next service; closed is set once it is gone. */
void wsc_close(wsc *c);
void wsc_free(wsc *c);
uint64_t wsc_now_us(void);

#endif
