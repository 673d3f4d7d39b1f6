/* loadclient.c - load and latency client for meshsteerd (knows only docs/PROTOCOL.md).
 *
 * Opens N WebSocket connections to /stream, asks for the chosen encoding, and after a warm-up
 * (connections, hellos and topologies done) measures for every frame message it receives:
 *   end to end  receipt (CLOCK_MONOTONIC, so run it on the daemon's host) - capture timestamp
 *   server      the frame's send timestamp - capture timestamp (the daemon's own share)
 *   synthesis   the frame's synthesis timestamp - capture timestamp (source -> mesh done)
 * and per connection the frames received against the server's sequence span (what it would have
 * received had it kept up). Prints p50/p99/max of both, received vs sent, frames/s per client
 * (mean and the slowest client); -j prints the same as one JSON object.
 *
 * It shares the daemon's cores when both run on one host, so its receive path must cost little
 * next to the daemon's. libwebsockets 4.1's client parses every payload byte through its state
 * machine (measured: 94 % of this client's CPU at 16 int16 clients, and the reason for seconds of
 * backlog at 64 clients). So this client speaks the client side of RFC 6455 itself, over epoll:
 * the handshake (status 101 checked; Sec-WebSocket-Accept is not verified, this is a measuring
 * tool on a known server), the server's frames parsed as a stream by wsframe.c (payload skipped
 * in bulk, only the first 56 bytes of each message kept), pings answered, close honoured, and one
 * masked text frame sent (the encoding request). With -e params it counts params frames (and the
 * int16 frames of a kind without a compact form) and checks that each connection got its params
 * model (MSPM) before its first params frame; it reports the bytes per frame. One recv of up to 1 MB
 * per readable socket, the receipt time taken once per recv. No allocation after start. With -i, every INTERVAL seconds of
 * the measured time also one line: frames/s of the slowest client and the mean over that interval,
 * and how many are still connected (for long runs, tests/server/soak_daemon.c; WebSocket only).
 * With --nats the same figures are measured over NATS instead (loadclient_nats.c).
 * Usage: meshsteer-load [-n CLIENTS] [-t SECONDS] [-w WARMUP_S] [-e float32|int16|params] [-p PORT]
 *                       [-H HOST] [-O ORIGIN] [-i INTERVAL_S] [-j]
 *                       [--nats URL[,URL...] [--subject PREFIX]] */
#include <errno.h>
#include <getopt.h>
#include <stdatomic.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "loadclient.h"
#include "wsframe.h"

#define HEADER LOAD_HEADER
#define RECV_CHUNK (1 << 20) /* one recv takes up to this much */
#define HS_MAX 2048          /* handshake response headers */

enum { C_HANDSHAKE, C_OPEN, C_CLOSED };

typedef struct conn {
    int fd, state, failed;
    char hs[HS_MAX];
    size_t hs_len;
    ws_rx rx;
    uint64_t t_recv; /* receipt time of the bytes being parsed */
    load_stats st;
    uint64_t frames_at_interval; /* frames at the start of the current -i interval */
    int have_model; /* params: the params model (MSPM) has arrived */
} conn;

static load_run R;
static int want_enc;       /* WebSocket: 0 float32, 1 int16, 2 params */
static uint64_t order_errors; /* WebSocket params: frames before their connection's params model */
static double interval_s;  /* -i: seconds per progress line, 0 for none */
static int json_out;       /* -j */

uint64_t load_now_us(void)
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

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Sends one masked client frame (FIN set); small payloads only. */
static int send_frame(conn *c, int opcode, const void *data, size_t len)
{
    unsigned char f[8 + 125];
    if (len > 125)
        return -1;
    uint32_t key = (uint32_t)rand();
    unsigned char mask[4] = {(unsigned char)key, (unsigned char)(key >> 8),
                             (unsigned char)(key >> 16), (unsigned char)(key >> 24)};
    f[0] = (unsigned char)(0x80 | opcode);
    f[1] = (unsigned char)(0x80 | len);
    memcpy(f + 2, mask, 4);
    for (size_t i = 0; i < len; i++)
        f[6 + i] = ((const unsigned char *)data)[i] ^ mask[i & 3];
    ssize_t w = send(c->fd, f, 6 + len, MSG_NOSIGNAL);
    return w == (ssize_t)(6 + len) ? 0 : -1;
}

static int fail(conn *c, const char *why)
{
    if (!c->failed)
        fprintf(stderr, "meshsteer-load: connection %d: %s\n", c->fd, why);
    c->failed = 1;
    c->state = C_CLOSED;
    return -1;
}

/* A whole message has arrived (wsframe.c callback). */
static void on_message(void *ud, int binary, const unsigned char *h, size_t head_len, uint64_t len)
{
    conn *c = ud;
    if (binary && head_len >= 4 && !memcmp(h, "MSPM", 4)) {
        c->have_model = 1; /* the params model: parsed by clients/params.c where it is used */
        return;
    }
    if (!binary || head_len < HEADER || memcmp(h, "MSFR", 4))
        return; /* hello, topology, replies */
    if (h[4] == 2 && !c->have_model)
        order_errors++;
    /* params: a frame of a kind without a compact form comes as int16 */
    if (h[4] != want_enc && !(want_enc == 2 && h[4] == 1))
        return; /* before the encoding switch took effect */
    load_frame(&R, &c->st, h, len, c->t_recv);
}

void load_frame(load_run *r, load_stats *s, const unsigned char *h, uint64_t len, uint64_t t)
{
    if (t < r->t_measure || t >= r->t_end)
        return; /* warm-up, or after the end */
    s->bytes += len;
    uint64_t seq = le64(h + 24), tc = le64(h + 32), tsy = le64(h + 40), ts = le64(h + 48);
    if (!s->frames)
        s->first_seq = seq;
    else
        s->skipped += le32(h + 20);
    s->last_seq = seq;
    s->frames++;
    size_t i = atomic_fetch_add(&r->nlat, 1);
    if (i >= r->caplat)
        return;
    r->e2e[i] = (uint32_t)(t > tc ? t - tc : 0);
    r->srv[i] = (uint32_t)(ts > tc ? ts - tc : 0);
    r->syn[i] = (uint32_t)(tsy > tc ? tsy - tc : 0);
}

/* Ping -> pong with the same payload; close -> answer and stop. */
static int on_control(void *ud, int opcode, const unsigned char *payload, size_t len)
{
    conn *c = ud;
    if (opcode == WS_OP_PING)
        return send_frame(c, WS_OP_PONG, payload, len) ? fail(c, "cannot send pong") : 0;
    if (opcode == WS_OP_CLOSE) {
        send_frame(c, WS_OP_CLOSE, payload, len >= 2 ? 2 : 0);
        return fail(c, "closed by the server");
    }
    return 0;
}

static const ws_rx_cb callbacks = {on_message, on_control, NULL};

static int ws_feed(conn *c, const unsigned char *p, size_t n, uint64_t t)
{
    ws_rx_cb cb = callbacks;
    cb.ud = c;
    c->t_recv = t;
    int r = ws_rx_feed(&c->rx, p, n, &cb);
    if (r < 0 && c->rx.error)
        return fail(c, c->rx.error);
    return r ? -1 : 0;
}

static int open_conn(conn *c, const struct addrinfo *ai, const char *host, int port,
                     const char *origin)
{
    c->fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
    if (c->fd < 0)
        return -1;
    if (connect(c->fd, ai->ai_addr, ai->ai_addrlen)) {
        close(c->fd);
        c->fd = -1;
        return -1;
    }
    int one = 1;
    setsockopt(c->fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    char req[1024];
    int n = snprintf(req, sizeof req,
                     "GET /stream HTTP/1.1\r\nHost: %s:%d\r\nUpgrade: websocket\r\n"
                     "Connection: Upgrade\r\nSec-WebSocket-Key: bWVzaHN0ZWVyLWxvYWQtMQ==\r\n"
                     "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: meshsteer.v1\r\n"
                     "Origin: %s\r\n\r\n",
                     host, port, origin);
    if (n <= 0 || (size_t)n >= sizeof req || write(c->fd, req, (size_t)n) != n) {
        close(c->fd);
        c->fd = -1;
        return -1;
    }
    fcntl(c->fd, F_SETFL, fcntl(c->fd, F_GETFL) | O_NONBLOCK);
    c->state = C_HANDSHAKE;
    ws_rx_init(&c->rx, HEADER);
    return 0;
}

/* Reads the 101 response; what follows the headers is frame data. */
static int handshake(conn *c, const unsigned char *p, size_t n, uint64_t t)
{
    size_t before = c->hs_len, room = sizeof c->hs - before, k = n < room ? n : room;
    memcpy(c->hs + before, p, k);
    c->hs_len += k;
    long end = ws_handshake_end(c->hs, c->hs_len);
    if (end < 0) {
        char line[128];
        size_t l = 0;
        while (l < c->hs_len && l < sizeof line - 1 && c->hs[l] != '\r' && c->hs[l] != '\n')
            line[l] = c->hs[l], l++;
        line[l] = '\0';
        return fail(c, l ? line : "refused");
    }
    if (end == 0)
        return c->hs_len == sizeof c->hs ? fail(c, "handshake response too long") : 0;
    c->state = C_OPEN;
    char msg[96];
    int m = snprintf(msg, sizeof msg, "{\"type\":\"encoding\",\"encoding\":\"%s\"}", R.encoding);
    if (send_frame(c, WS_OP_TEXT, msg, (size_t)m))
        return fail(c, "cannot send the encoding request");
    size_t used = (size_t)end - before; /* bytes of p that belonged to the headers */
    return ws_feed(c, p + used, n - used, t);
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* q-quantile (nearest rank) of sorted v, in ms */
static double quant(const uint32_t *v, size_t n, double q)
{
    if (!n)
        return 0;
    size_t k = (size_t)(q * (double)n);
    return (double)v[k < n ? k : n - 1] * 1e-3;
}

/* -i: one line for the interval of secs seconds that just ended; starts the next. */
static void report_interval(conn *c, int n, int k, double secs)
{
    double fmin = -1, sum = 0;
    int up = 0;
    for (int i = 0; i < n; i++) {
        double f = (double)(c[i].st.frames - c[i].frames_at_interval) / secs;
        c[i].frames_at_interval = c[i].st.frames;
        fmin = fmin < 0 || f < fmin ? f : fmin;
        sum += f;
        up += c[i].state == C_OPEN;
    }
    if (json_out)
        printf("{\"interval\":%d,\"seconds\":%g,\"fps_min\":%.2f,\"fps_mean\":%.2f,"
               "\"connected\":%d}\n", k, secs, fmin, sum / n, up);
    else
        printf("interval %d (%g s): %.1f frames/s per client (slowest %.1f), %d of %d connected\n",
               k, secs, sum / n, fmin, up, n);
    fflush(stdout);
}

/* The WebSocket run: n connections to HOST:PORT, each asking for R.encoding. */
static int ws_run(const char *host, int port, const char *origin, int n, load_stats *st, int *up)
{
    conn *c = calloc((size_t)n, sizeof *c);
    unsigned char *buf = malloc(RECV_CHUNK);
    struct epoll_event *ev = malloc(sizeof *ev * (size_t)n);
    int ep = epoll_create1(EPOLL_CLOEXEC);
    if (!c || !buf || !ev || ep < 0) {
        fprintf(stderr, "meshsteer-load: out of memory\n");
        return -1;
    }
    char portstr[16];
    snprintf(portstr, sizeof portstr, "%d", port);
    struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM}, *ai = NULL;
    int gr = getaddrinfo(host, portstr, &hints, &ai);
    if (gr) {
        fprintf(stderr, "meshsteer-load: %s: %s\n", host, gai_strerror(gr));
        return -1;
    }
    int opened = 0;
    for (int i = 0; i < n; i++) {
        c[i].fd = -1;
        if (open_conn(&c[i], ai, host, port, origin)) {
            fprintf(stderr, "meshsteer-load: connection %d to %s:%d: %s\n", i, host, port,
                    strerror(errno));
            c[i].state = C_CLOSED;
            continue;
        }
        struct epoll_event e = {.events = EPOLLIN, .data.ptr = &c[i]};
        epoll_ctl(ep, EPOLL_CTL_ADD, c[i].fd, &e);
        opened++;
    }
    freeaddrinfo(ai);

    uint64_t step = (uint64_t)(interval_s * 1e6);
    uint64_t next_report = step ? R.t_measure + step : R.t_end + 1;
    int reports = 0;
    for (uint64_t now = load_now_us(); now < R.t_end; now = load_now_us()) {
        if (now >= next_report) {
            report_interval(c, n, ++reports, interval_s);
            next_report += step;
        }
        uint64_t until = next_report < R.t_end ? next_report : R.t_end;
        int k = epoll_wait(ep, ev, n, now < until ? (int)((until - now) / 1000) + 1 : 0);
        for (int i = 0; i < k; i++) {
            conn *cc = ev[i].data.ptr;
            if (cc->state == C_CLOSED)
                continue;
            ssize_t got = recv(cc->fd, buf, RECV_CHUNK, 0);
            uint64_t t = load_now_us();
            int r = 0;
            if (got > 0)
                r = cc->state == C_HANDSHAKE ? handshake(cc, buf, (size_t)got, t)
                                             : ws_feed(cc, buf, (size_t)got, t);
            else if (got == 0 || (errno != EAGAIN && errno != EINTR))
                r = fail(cc, got == 0 ? "closed by the server" : strerror(errno));
            if (r || cc->state == C_CLOSED)
                epoll_ctl(ep, EPOLL_CTL_DEL, cc->fd, NULL);
        }
    }
    if (step && next_report <= R.t_end) /* the interval that ends with the run */
        report_interval(c, n, ++reports, interval_s);
    *up = 0;
    for (int i = 0; i < n; i++) {
        *up += c[i].state == C_OPEN;
        st[i] = c[i].st;
        if (c[i].fd >= 0)
            close(c[i].fd);
    }
    close(ep);
    free(ev);
    free(buf);
    free(c);
    return opened == n ? 0 : 1;
}

static const char usage_short[] =
    "usage: meshsteer-load [-n CLIENTS] [-t SECONDS] [-w WARMUP_S] [-e ENCODING]\n"
    "                      [-p PORT] [-H HOST] [-O ORIGIN] [-i INTERVAL_S] [-j]\n"
    "                      [--nats URL[,URL...] [--subject PREFIX]]\n";

int main(int argc, char **argv)
{
    int n = 1, port = 8080, opt, json = 0;
    double secs = 10, warm = 1;
    const char *host = "127.0.0.1", *origin = NULL, *nats = NULL, *prefix = "meshsteer";
    R.encoding = "float32";
    enum { O_NATS = 256, O_SUBJECT };
    static const struct option longopts[] = {{"help", no_argument, NULL, 'h'},
                                             {"nats", required_argument, NULL, O_NATS},
                                             {"subject", required_argument, NULL, O_SUBJECT},
                                             {NULL, 0, NULL, 0}};
    while ((opt = getopt_long(argc, argv, "n:t:w:e:p:H:O:i:jh", longopts, NULL)) != -1) {
        switch (opt) {
        case 'h':
            printf("%s\n"
                   "Opens CLIENTS WebSocket connections to meshsteerd (default 1, to 127.0.0.1:8080),\n"
                   "subscribes each to the stream in the given encoding (default float32; params:\n"
                   "the compact parameter stream, int16 frames where a kind has none), discards\n"
                   "the first WARMUP_S seconds (default 1), then counts frames for SECONDS (default\n"
                   "10) and prints frames per second and the capture-to-receive latency (median,\n"
                   "p99, max). -O sets the Origin header (default http://HOST:PORT); -i prints a\n"
                   "line every INTERVAL_S seconds of the measured time (frames/s of the slowest client\n"
                   "and the mean over it, clients still connected; WebSocket only); -j prints JSON\n"
                   "(one object, and one per -i line).\n"
                   "--nats: the same over NATS instead: CLIENTS subscribers (one NATS connection\n"
                   "each, spread round robin over the URLs, e.g. the nodes of a cluster) join as a\n"
                   "late joiner does (PREFIX.get.hello, PREFIX.get.topology) and subscribe to\n"
                   "PREFIX.frames.ENCODING (PREFIX: --subject, default meshsteer).\n"
                   "Exit status 0 when every client connected and was subscribed, 1 if not, 2 on\n"
                   "bad usage.\n", usage_short);
            return 0;
        case 'n': n = atoi(optarg); break;
        case 't': secs = atof(optarg); break;
        case 'w': warm = atof(optarg); break;
        case 'e': R.encoding = optarg; break;
        case 'p': port = atoi(optarg); break;
        case 'H': host = optarg; break;
        case 'O': origin = optarg; break;
        case 'i': interval_s = atof(optarg); break;
        case 'j': json = 1; break;
        case O_NATS: nats = optarg; break;
        case O_SUBJECT: prefix = optarg; break;
        default:
            fputs(usage_short, stderr);
            return 2;
        }
    }
    if (n < 1 || n > 10000 || !(secs > 0) || !(warm >= 0) || port < 1 || port > 65535 ||
        !(interval_s >= 0)) {
        fprintf(stderr, "meshsteer-load: bad -n, -t, -w, -p or -i\n");
        return 2;
    }
    /* over NATS the encoding is a subject name: any the daemon has */
    if (!nats && strcmp(R.encoding, "float32") && strcmp(R.encoding, "int16") &&
        strcmp(R.encoding, "params")) {
        fprintf(stderr, "meshsteer-load: -e float32, int16 or params\n");
        return 2;
    }
    json_out = json;
    char origin_buf[300];
    if (!origin) {
        snprintf(origin_buf, sizeof origin_buf, "http://%s:%d", host, port);
        origin = origin_buf;
    }
    want_enc = !strcmp(R.encoding, "int16") ? 1 : !strcmp(R.encoding, "params") ? 2 : 0;
    /* room for 240 frames/s per client over the measured time */
    R.caplat = (size_t)((double)n * secs * 240) + 1024;
    R.e2e = malloc(R.caplat * sizeof *R.e2e);
    R.srv = malloc(R.caplat * sizeof *R.srv);
    R.syn = malloc(R.caplat * sizeof *R.syn);
    load_stats *st = calloc((size_t)n, sizeof *st);
    if (!R.e2e || !R.srv || !R.syn || !st) {
        fprintf(stderr, "meshsteer-load: out of memory\n");
        return 1;
    }
    R.t_measure = load_now_us() + (uint64_t)(warm * 1e6);
    R.t_end = R.t_measure + (uint64_t)(secs * 1e6);
    int up = 0;
    int rc = nats ? load_nats_run(&R, nats, prefix, n, st, &up)
                  : ws_run(host, port, origin, n, st, &up);
    if (rc < 0)
        return nats ? 2 : 1;

    uint64_t frames = 0, sent = 0, skipped = 0, bytes = 0;
    double fps_min = -1;
    for (int i = 0; i < n; i++) {
        frames += st[i].frames;
        bytes += st[i].bytes;
        sent += st[i].frames ? st[i].last_seq - st[i].first_seq + 1 : 0;
        skipped += st[i].skipped;
        double f = (double)st[i].frames / secs;
        fps_min = fps_min < 0 || f < fps_min ? f : fps_min;
    }
    size_t nlat = atomic_load(&R.nlat), lost = 0;
    if (nlat > R.caplat) {
        lost = nlat - R.caplat;
        nlat = R.caplat;
    }
    qsort(R.e2e, nlat, sizeof *R.e2e, cmp_u32);
    qsort(R.srv, nlat, sizeof *R.srv, cmp_u32);
    qsort(R.syn, nlat, sizeof *R.syn, cmp_u32);
    double pct = sent ? 100.0 * (double)frames / (double)sent : 0, fps = (double)frames / n / secs;
    double e50 = quant(R.e2e, nlat, 0.5), e99 = quant(R.e2e, nlat, 0.99);
    double emax = quant(R.e2e, nlat, 1.0);
    double s50 = quant(R.srv, nlat, 0.5), s99 = quant(R.srv, nlat, 0.99);
    double y50 = quant(R.syn, nlat, 0.5), y99 = quant(R.syn, nlat, 0.99);
    double bpf = frames ? (double)bytes / (double)frames : 0;
    const char *via = nats ? "nats" : "websocket";
    if (json)
        printf("{\"clients\":%d,\"connected\":%d,\"transport\":\"%s\",\"encoding\":\"%s\","
               "\"seconds\":%g,\"received\":%llu,\"sent\":%llu,\"skipped\":%llu,"
               "\"fps_mean\":%.2f,\"fps_min\":%.2f,\"e2e_p50_ms\":%.3f,\"e2e_p99_ms\":%.3f,"
               "\"e2e_max_ms\":%.3f,\"server_p50_ms\":%.3f,\"server_p99_ms\":%.3f,"
               "\"synth_p50_ms\":%.3f,\"synth_p99_ms\":%.3f,\"bytes_per_frame\":%.1f}\n",
               n, up, via, R.encoding, secs, (unsigned long long)frames,
               (unsigned long long)sent, (unsigned long long)skipped, fps, fps_min, e50, e99, emax,
               s50, s99, y50, y99, bpf);
    else
        printf("clients %d (connected %d) over %s, encoding %s, %.1f s: frames received %llu of "
               "%llu sent (%.2f%%), skipped %llu, %.1f frames/s per client (slowest %.1f); "
               "end-to-end p50 %.2f ms p99 %.2f ms max %.2f ms; capture->send p50 %.2f ms p99 "
               "%.2f ms; capture->synthesised p50 %.2f ms p99 %.2f ms; %.0f bytes/frame\n",
               n, up, via, R.encoding, secs, (unsigned long long)frames,
               (unsigned long long)sent, pct, (unsigned long long)skipped, fps, fps_min, e50, e99,
               emax, s50, s99, y50, y99, bpf);
    if (lost)
        fprintf(stderr, "meshsteer-load: %zu latencies not stored (more frames than expected)\n",
                lost);
    free(st);
    free(R.e2e);
    free(R.srv);
    free(R.syn);
    if (order_errors)
        fprintf(stderr, "meshsteer-load: %llu params frames came before their params model\n",
                (unsigned long long)order_errors);
    return up == n && rc == 0 && !order_errors ? 0 : 1;
}
