/* wsclient.c - the daemon tests' WebSocket client (see wsclient.h). */
#include "wsclient.h"
#include "params.h"

#include <libwebsockets.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

uint64_t wsc_now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static uint32_t u32(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static uint64_t u64(const unsigned char *p) { return (uint64_t)u32(p) | (uint64_t)u32(p + 4) << 32; }
static float f32(const unsigned char *p) { union { uint32_t u; float f; } b = {.u = u32(p)}; return b.f; }

static void on_binary(wsc *c, const unsigned char *m, size_t len)
{
    uint64_t now = wsc_now_us();
    if (len >= 56 && !memcmp(m, "MSTO", 4)) {
        free(c->topo);
        c->topo = malloc(len);
        memcpy(c->topo, m, len);
        c->topo_len = len;
        c->topos++;
        c->nv = (int)u32(m + 12);
        c->nf = (int)u32(m + 16);
        c->nm = (int)u32(m + 20);
        for (int a = 0; a < 3; a++) {
            c->qmin[a] = f32(m + 32 + 4 * a);
            c->qmax[a] = f32(m + 44 + 4 * a);
        }
        size_t want = 56 + (size_t)c->nv * 12 + (size_t)c->nf * 12 + (size_t)c->nv * 4;
        if (want != len) {
            c->protocol_errors++;
            snprintf(c->error, sizeof c->error, "topology: %zu bytes, expected %zu", len, want);
        }
        return;
    }
    if (len >= 16 && !memcmp(m, "MSPM", 4)) { /* the params model (params encoding) */
        ws_params_free(c->params);
        free(c->params);
        c->params = calloc(1, sizeof *c->params);
        c->params_len = len;
        c->params_msgs++;
        if (!c->params || ws_params_parse(m, len, c->params, c->error, sizeof c->error)) {
            free(c->params);
            c->params = NULL;
            c->protocol_errors++;
        }
        return;
    }
    if (len < 56 || memcmp(m, "MSFR", 4)) {
        c->protocol_errors++;
        snprintf(c->error, sizeof c->error, "unknown binary message of %zu bytes", len);
        return;
    }
    int enc = m[4];
    int nv = (int)u32(m + 12), nm = (int)u32(m + 16);
    size_t vb = enc == 1 ? (size_t)nv * 6 : (size_t)nv * 12;
    if (enc == 2) /* layout, count, the floats */
        vb = len >= 64 ? 8 + 4 * (size_t)u32(m + 60) : 0;
    size_t want = 56 + ((vb + 3) & ~(size_t)3) + (size_t)nm * 12 + (((size_t)nm + 3) & ~(size_t)3);
    if (want != len || nv != c->nv || nm != c->nm || enc > 2 || (enc == 2 && !c->params)) {
        c->protocol_errors++;
        snprintf(c->error, sizeof c->error, "frame: %zu bytes, expected %zu (enc %d nv %d/%d)", len,
                 want, enc, nv, c->nv);
        return;
    }
    c->total_frames++;
    c->last_seq = u64(m + 24);
    if (c->nframes == WSC_MAX_FRAMES)
        return;
    wsc_frame *f = &c->frames[c->nframes++];
    f->encoding = enc;
    f->flags = m[5];
    f->generation = u32(m + 8);
    f->skipped = (int)u32(m + 20);
    f->seq = u64(m + 24);
    f->t_capture = u64(m + 32);
    f->t_synth = u64(m + 40);
    f->t_send = u64(m + 48);
    f->t_recv = now;
    f->V = NULL;
    f->M = NULL;
    if (c->keep_vertices) {
        f->V = malloc(sizeof(float) * (size_t)nv * 3);
        const unsigned char *p = m + 56;
        if (enc == 2 && ws_params_decode(c->params, p, vb, f->V, c->error, sizeof c->error))
            c->protocol_errors++;
        /* float32 frames are little-endian floats: one copy where the host is too (a read per
         * float costs a call under ThreadSanitizer, which made this client the tests' bottleneck) */
        int copied = 0;
#if __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
        if (enc == 0) {
            memcpy(f->V, p, sizeof(float) * (size_t)nv * 3);
            copied = 1;
        }
#endif
        for (int i = 0; i < nv * 3 && enc < 2 && !copied; i++) {
            int a = i % 3;
            if (enc == 0) {
                f->V[i] = f32(p + 4 * (size_t)i);
            } else {
                int16_t q = (int16_t)(uint16_t)(p[2 * i] | p[2 * i + 1] << 8);
                f->V[i] = c->qmin[a] + (float)(q + 32768) * (c->qmax[a] - c->qmin[a]) / 65535.0f;
            }
        }
        f->M = malloc(sizeof(float) * (size_t)(nm > 0 ? nm : 1) * 3);
        const unsigned char *q = m + 56 + ((vb + 3) & ~(size_t)3);
        for (int i = 0; i < nm * 3; i++)
            f->M[i] = f32(q + 4 * (size_t)i);
    }
}

static int callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in,
                    size_t len)
{
    wsc *c = user;
    switch (reason) {
    case LWS_CALLBACK_CLIENT_CONNECTION_ERROR:
        if (c) {
            c->failed = 1;
            c->closed = 1;
            snprintf(c->error, sizeof c->error, "connection error: %s",
                     in ? (const char *)in : "?");
            c->wsi = NULL;
        }
        return 0;
    case LWS_CALLBACK_CLIENT_ESTABLISHED:
        c->connected = 1;
        if (c->nout)
            lws_callback_on_writable(wsi);
        return 0;
    case LWS_CALLBACK_WS_PEER_INITIATED_CLOSE:
        if (len >= 2)
            c->close_code = ((unsigned char *)in)[0] << 8 | ((unsigned char *)in)[1];
        return 0;
    case LWS_CALLBACK_CLIENT_CLOSED:
        c->closed = 1;
        c->wsi = NULL;
        return 0;
    case LWS_CALLBACK_CLIENT_RECEIVE: {
        if (lws_is_first_fragment(wsi))
            c->rx_len = 0;
        if (c->rx_len + len + 1 > c->rx_cap) {
            c->rx_cap = (c->rx_len + len + 1) * 2;
            c->rx = realloc(c->rx, c->rx_cap);
        }
        memcpy(c->rx + c->rx_len, in, len);
        c->rx_len += len;
        c->bytes += len;
        if (!lws_is_final_fragment(wsi) || lws_remaining_packet_payload(wsi))
            return 0;
        if (lws_frame_is_binary(wsi)) {
            on_binary(c, c->rx, c->rx_len);
        } else {
            c->rx[c->rx_len] = '\0';
            if (strstr((char *)c->rx, "\"type\":\"hello\"")) {
                free(c->hello);
                c->hello = strdup((char *)c->rx);
                c->hellos++;
            } else if (c->ntexts < WSC_MAX_TEXT) {
                c->texts[c->ntexts++] = strdup((char *)c->rx);
            }
        }
        return 0;
    }
    case LWS_CALLBACK_CLIENT_WRITEABLE:
        if (c->want_close) {
            lws_close_reason(wsi, LWS_CLOSE_STATUS_NORMAL, NULL, 0);
            return -1;
        }
        if (c->nout) {
            size_t n = c->out_len[0];
            int binary = c->out_bin[0];
            int r = lws_write(wsi, (unsigned char *)c->out[0] + LWS_PRE, n,
                              binary ? LWS_WRITE_BINARY : LWS_WRITE_TEXT);
            free(c->out[0]);
            memmove(c->out, c->out + 1, sizeof c->out[0] * (size_t)(c->nout - 1));
            memmove(c->out_len, c->out_len + 1, sizeof c->out_len[0] * (size_t)(c->nout - 1));
            memmove(c->out_bin, c->out_bin + 1, sizeof c->out_bin[0] * (size_t)(c->nout - 1));
            c->nout--;
            if (r < (int)n)
                return -1;
            if (c->nout)
                lws_callback_on_writable(wsi);
        }
        return 0;
    default:
        return 0;
    }
}

static const struct lws_protocols protocols[] = {
    {"meshsteer.v1", callback, 0, 65536, 0, NULL, 0},
    {NULL, NULL, 0, 0, 0, NULL, 0},
};

/* lws 4.1 polls without a timeout when no timer is pending; a 10 ms tick keeps wsc_run's own
 * deadline honest while the server sends nothing (a paused source). */
static struct lws_context *tick_ctx;
static lws_sorted_usec_list_t tick_sul;

static void tick(lws_sorted_usec_list_t *sul)
{
    lws_sul_schedule(tick_ctx, 0, sul, tick, 10 * LWS_US_PER_MS);
}

struct lws_context *wsc_context(void)
{
    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.port = CONTEXT_PORT_NO_LISTEN;
    info.protocols = protocols;
    info.pt_serv_buf_size = 65536; /* read up to 64 KB per poll round, not 4 KB */
    lws_set_log_level(LLL_ERR, NULL);
    struct lws_context *ctx = lws_create_context(&info);
    if (ctx) {
        tick_ctx = ctx;
        lws_sul_schedule(ctx, 0, &tick_sul, tick, 10 * LWS_US_PER_MS);
    }
    return ctx;
}

wsc *wsc_connect(struct lws_context *ctx, int port, const char *query, int keep_vertices)
{
    return wsc_connect_origin(ctx, port, query, "127.0.0.1", keep_vertices);
}

wsc *wsc_connect_origin(struct lws_context *ctx, int port, const char *query, const char *origin,
                        int keep_vertices)
{
    wsc *c = calloc(1, sizeof *c);
    c->keep_vertices = keep_vertices;
    static char path[512];
    snprintf(path, sizeof path, "/stream%s%s", query ? "?" : "", query ? query : "");
    struct lws_client_connect_info ci;
    memset(&ci, 0, sizeof ci);
    ci.context = ctx;
    ci.address = "127.0.0.1";
    ci.port = port;
    ci.path = path;
    static char host[64];
    snprintf(host, sizeof host, "127.0.0.1:%d", port);
    ci.host = host;
    ci.origin = origin;
    ci.protocol = "meshsteer.v1";
    ci.userdata = c;
    ci.pwsi = &c->wsi;
    if (!lws_client_connect_via_info(&ci)) {
        c->failed = 1;
        c->closed = 1;
    }
    return c;
}

static void queue(wsc *c, const void *data, size_t len, int binary)
{
    if (c->nout == 16)
        return;
    c->out[c->nout] = malloc(LWS_PRE + len + 1);
    memcpy(c->out[c->nout] + LWS_PRE, data, len);
    c->out_bin[c->nout] = binary;
    c->out_len[c->nout++] = len;
    if (c->wsi && c->connected)
        lws_callback_on_writable(c->wsi);
}

void wsc_send(wsc *c, const char *text)
{
    queue(c, text, strlen(text), 0);
}

void wsc_send_binary(wsc *c, const void *data, size_t len)
{
    queue(c, data, len, 1);
}

int wsc_run(struct lws_context *ctx, int timeout_ms, int (*pred)(void *), void *ud)
{
    uint64_t end = wsc_now_us() + (uint64_t)timeout_ms * 1000u;
    while (!(pred && pred(ud)) && wsc_now_us() < end)
        lws_service(ctx, 20);
    return pred ? pred(ud) : 1;
}

void wsc_close(wsc *c)
{
    c->want_close = 1;
    if (c->wsi && c->connected)
        lws_callback_on_writable(c->wsi);
}

void wsc_free(wsc *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->nframes; i++) {
        free(c->frames[i].V);
        free(c->frames[i].M);
    }
    for (int i = 0; i < c->ntexts; i++)
        free(c->texts[i]);
    for (int i = 0; i < c->nout; i++)
        free(c->out[i]);
    ws_params_free(c->params);
    free(c->params);
    free(c->hello);
    free(c->topo);
    free(c->rx);
    free(c);
}
