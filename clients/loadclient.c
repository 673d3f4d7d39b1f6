/* loadclient.c - load and latency client for meshsteerd (knows only docs/PROTOCOL.md).
 * Opens N WebSocket connections to /stream, optionally asks for int16 frames, and for every frame
 * records the end-to-end latency: receipt (CLOCK_MONOTONIC, so run it on the daemon's host) minus
 * the frame's capture timestamp. Prints p50/p99 latency, frames received vs the server's sequence
 * span (sent), and skipped frames, per run.
 * Usage: meshsteer-load [-n CLIENTS] [-t SECONDS] [-e float32|int16] [-p PORT] [-H HOST] */
#include <libwebsockets.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

typedef struct conn {
    int established, closed;
    uint64_t first_seq, last_seq, frames, skipped;
    size_t rx;
    unsigned char head[56]; /* first bytes of the message being received */
} conn;

static double *lat;
static size_t nlat, caplat;
static const char *encoding = "float32";
static lws_sorted_usec_list_t tick_sul;
static struct lws_context *ctx;

static uint64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static uint64_t le64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}

static int callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in,
                    size_t len)
{
    conn *c = user;
    switch (reason) {
    case LWS_CALLBACK_CLIENT_ESTABLISHED:
        c->established = 1;
        lws_callback_on_writable(wsi);
        return 0;
    case LWS_CALLBACK_CLIENT_WRITEABLE: {
        unsigned char buf[LWS_PRE + 128];
        int n = snprintf((char *)buf + LWS_PRE, 128, "{\"type\":\"encoding\",\"encoding\":\"%s\"}",
                         encoding);
        return lws_write(wsi, buf + LWS_PRE, (size_t)n, LWS_WRITE_TEXT) < n ? -1 : 0;
    }
    case LWS_CALLBACK_CLIENT_RECEIVE: {
        unsigned char *h = c->head;
        if (lws_is_first_fragment(wsi))
            c->rx = 0;
        if (c->rx < 56) {
            size_t k = len < 56 - c->rx ? len : 56 - c->rx;
            memcpy(h + c->rx, in, k);
        }
        c->rx += len;
        if (!lws_is_final_fragment(wsi) || lws_remaining_packet_payload(wsi))
            return 0;
        if (lws_frame_is_binary(wsi) && c->rx >= 56 && !memcmp(h, "MSFR", 4)) {
            uint64_t t = now_us(), seq = le64(h + 24), tc = le64(h + 32);
            if (!c->frames)
                c->first_seq = seq;
            c->last_seq = seq;
            c->frames++;
            c->skipped += (uint64_t)(h[20] | h[21] << 8 | h[22] << 16 | (uint64_t)h[23] << 24);
            if (nlat == caplat) {
                caplat = caplat ? caplat * 2 : 1 << 16;
                lat = realloc(lat, caplat * sizeof *lat);
            }
            lat[nlat++] = (double)(t - tc) * 1e-3;
        }
        return 0;
    }
    case LWS_CALLBACK_CLIENT_CONNECTION_ERROR:
    case LWS_CALLBACK_CLIENT_CLOSED:
        if (c)
            c->closed = 1;
        return 0;
    default:
        return 0;
    }
}

static void tick(lws_sorted_usec_list_t *s)
{
    lws_sul_schedule(ctx, 0, s, tick, 10 * LWS_US_PER_MS);
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv)
{
    int n = 1, port = 8080, opt;
    double secs = 10;
    const char *host = "127.0.0.1";
    while ((opt = getopt(argc, argv, "n:t:e:p:H:h")) != -1) {
        switch (opt) {
        case 'n': n = atoi(optarg); break;
        case 't': secs = atof(optarg); break;
        case 'e': encoding = optarg; break;
        case 'p': port = atoi(optarg); break;
        case 'H': host = optarg; break;
        default:
            fprintf(stderr, "usage: meshsteer-load [-n CLIENTS] [-t SECONDS] [-e float32|int16] "
                            "[-p PORT] [-H HOST]\n");
            return 2;
        }
    }
    if (n < 1 || n > 10000 || !(secs > 0)) {
        fprintf(stderr, "meshsteer-load: bad -n or -t\n");
        return 2;
    }
    static const struct lws_protocols protocols[] = {
        {"meshsteer.v1", callback, 0, 1 << 16, 0, NULL, 0}, {NULL, NULL, 0, 0, 0, NULL, 0}};
    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.port = CONTEXT_PORT_NO_LISTEN;
    info.protocols = protocols;
    info.fd_limit_per_thread = (unsigned int)(n + 16);
    lws_set_log_level(LLL_ERR, NULL);
    ctx = lws_create_context(&info);
    if (!ctx)
        return 1;
    lws_sul_schedule(ctx, 0, &tick_sul, tick, 10 * LWS_US_PER_MS);
    conn *c = calloc((size_t)n, sizeof *c);
    for (int i = 0; i < n; i++) {
        struct lws_client_connect_info ci;
        memset(&ci, 0, sizeof ci);
        ci.context = ctx;
        ci.address = host;
        ci.port = port;
        ci.path = "/stream";
        ci.host = host;
        ci.origin = host;
        ci.protocol = "meshsteer.v1";
        ci.userdata = &c[i];
        lws_client_connect_via_info(&ci);
    }
    uint64_t t0 = now_us(), end = t0 + (uint64_t)(secs * 1e6);
    while (now_us() < end)
        lws_service(ctx, 0);
    int up = 0;
    uint64_t frames = 0, sent = 0, skipped = 0;
    for (int i = 0; i < n; i++) {
        up += c[i].established && !c[i].closed;
        frames += c[i].frames;
        sent += c[i].frames ? c[i].last_seq - c[i].first_seq + 1 : 0;
        skipped += c[i].skipped;
    }
    qsort(lat, nlat, sizeof *lat, cmp);
    double p50 = nlat ? lat[nlat / 2] : 0, p99 = nlat ? lat[(size_t)((double)nlat * 0.99)] : 0;
    printf("clients %d (connected %d) encoding %s: frames received %llu of %llu sent (%.2f%%), "
           "skipped %llu, %.1f frames/s per client; latency p50 %.2f ms p99 %.2f ms\n",
           n, up, encoding, (unsigned long long)frames, (unsigned long long)sent,
           sent ? 100.0 * (double)frames / (double)sent : 0, (unsigned long long)skipped,
           (double)frames / n / secs, p50, p99);
    lws_context_destroy(ctx);
    free(c);
    free(lat);
    return 0;
}
