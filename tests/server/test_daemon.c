/* test_daemon.c - meshsteerd end to end: a model trained on the built-in example, a replay source,
 * the daemon on an ephemeral port, and WebSocket clients that check the protocol as documented.
 *
 * Usage: test_daemon MESHSTEERD MAKE_MODEL SCENARIO, SCENARIO one of
 *   stream   hello, topology, frames (increasing seq, plausible timestamps), both encodings within
 *            the int16 bound, controls (good and bad, error replies), an oversized message closing
 *            only its connection, /healthz, /metrics, SIGHUP with a corrupt model (keeps serving),
 *            SIGHUP with a good one (new hello), SIGTERM (clients closed with 1001, exit 0)
 *   slow     a client that never reads while another receives at full rate; bounded memory
 *   record   --record writes a C3D that reads back as the replayed markers
 *   limits   max clients, token and Origin checks */
#include "daemon_harness.h"
#include "model.h"
#include "test.h"
#include "wsclient.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <libwebsockets.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static const char *meshsteerd;
static harness H;

typedef struct want {
    wsc *c;
    uint64_t frames;
    int texts, hellos, closed;
    int enc;          /* count only frames of this encoding (-1 any) */
} want;

static int enough(void *ud)
{
    want *w = ud;
    if (w->closed)
        return w->c->closed;
    if (w->hellos && w->c->hellos < w->hellos)
        return 0;
    if (w->texts && w->c->ntexts < w->texts)
        return 0;
    if (w->enc >= 0) {
        uint64_t n = 0;
        for (int i = 0; i < w->c->nframes; i++)
            n += w->c->frames[i].encoding == w->enc;
        return n >= w->frames;
    }
    return w->c->total_frames >= w->frames;
}

static void run_until(struct lws_context *ctx, wsc *c, uint64_t frames, int texts, int ms)
{
    want w = {c, frames, texts, 0, 0, -1};
    if (!wsc_run(ctx, ms, enough, &w)) {
        fprintf(stderr, "timeout: %llu/%llu frames, %d/%d texts, closed %d (%s)\n",
                (unsigned long long)c->total_frames, (unsigned long long)frames, c->ntexts, texts,
                c->closed, c->error);
        harness_stop(&H, SIGKILL, 1000);
        exit(1);
    }
}

static const char *last_text(const wsc *c)
{
    return c->ntexts ? c->texts[c->ntexts - 1] : "";
}

/* The last reply is {"type":type, ...} with code (for errors). */
static void expect_reply(const wsc *c, const char *type, const char *code)
{
    cJSON *j = cJSON_Parse(last_text(c));
    ASSERT(j);
    const cJSON *t = cJSON_GetObjectItem(j, "type");
    if (!cJSON_IsString(t) || strcmp(t->valuestring, type) ||
        (code && strcmp(cJSON_GetObjectItem(j, "code")->valuestring, code))) {
        fprintf(stderr, "expected reply %s %s, got %s\n", type, code ? code : "", last_text(c));
        exit(1);
    }
    cJSON_Delete(j);
}

static void send_and_expect(struct lws_context *ctx, wsc *c, const char *msg, const char *type,
                            const char *code)
{
    int before = c->ntexts;
    wsc_send(c, msg);
    run_until(ctx, c, 0, before + 1, 5000);
    expect_reply(c, type, code);
}

static void start_default(const char *extra1, const char *extra2)
{
    char model[1200], source[1200];
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?loop=1", H.dir);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--max-message", "1024", "-v", extra1, extra2, NULL};
    harness_start(&H, meshsteerd, args);
}

/* ------------------------------------------------------------------ stream */

static void scenario_stream(void)
{
    start_default(NULL, NULL);
    struct lws_context *ctx = wsc_context();
    ASSERT(ctx);

    /* /healthz */
    char *body;
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200);
    cJSON *hz = cJSON_Parse(body);
    ASSERT(hz);
    ASSERT(!strcmp(cJSON_GetObjectItem(hz, "status")->valuestring, "ok"));
    ASSERT(cJSON_GetObjectItem(cJSON_GetObjectItem(hz, "model"), "vertices")->valueint > 1000);
    ASSERT(!strcmp(cJSON_GetObjectItem(cJSON_GetObjectItem(hz, "source"), "state")->valuestring,
                   "streaming"));
    ASSERT(cJSON_GetObjectItem(hz, "uptime_s")->valuedouble > 0);
    cJSON_Delete(hz);
    free(body);
    ASSERT_INT_EQ(harness_get(&H, "/nonexistent-endpoint", &body), 404);
    free(body);

    /* two clients: A stays float32, B switches to int16 */
    wsc *A = wsc_connect(ctx, H.port, NULL, 1);
    wsc *B = wsc_connect(ctx, H.port, NULL, 1);
    wsc_send(B, "{\"type\":\"encoding\",\"encoding\":\"int16\",\"id\":1}");
    run_until(ctx, A, 60, 0, 15000);
    want wb = {B, 60, 0, 0, 0, 1};
    ASSERT(wsc_run(ctx, 15000, enough, &wb));
    ASSERT_INT_EQ(A->protocol_errors, 0);
    ASSERT_INT_EQ(B->protocol_errors, 0);
    expect_reply(B, "ack", NULL);

    /* the hello */
    ASSERT_INT_EQ(A->hellos, 1);
    cJSON *h = cJSON_Parse(A->hello);
    ASSERT(h);
    ASSERT_INT_EQ(cJSON_GetObjectItem(h, "protocol")->valueint, 1);
    const cJSON *m = cJSON_GetObjectItem(h, "model");
    ASSERT_INT_EQ(cJSON_GetObjectItem(m, "vertices")->valueint, A->nv);
    ASSERT_INT_EQ(cJSON_GetObjectItem(m, "faces")->valueint, A->nf);
    ASSERT_INT_EQ(cJSON_GetArraySize(cJSON_GetObjectItem(h, "markers")), A->nm);
    ASSERT_INT_EQ(cJSON_GetObjectItem(h, "generation")->valueint, 1);
    cJSON_Delete(h);
    /* the topology: faces index vertices, the rest pose lies in the quantisation box */
    ASSERT_INT_EQ(A->topos, 1);
    const unsigned char *t = A->topo + 56;
    for (int i = 0; i < A->nf * 3; i++) {
        uint32_t f = (uint32_t)t[A->nv * 12 + 4 * i] | (uint32_t)t[A->nv * 12 + 4 * i + 1] << 8 |
                     (uint32_t)t[A->nv * 12 + 4 * i + 2] << 16 | (uint32_t)t[A->nv * 12 + 4 * i + 3] << 24;
        ASSERT_NEAR_I(f, A->nv / 2.0, A->nv / 2.0, i);
    }

    /* frames: increasing sequence numbers, plausible timestamps, the source's rate */
    for (int i = 0; i < A->nframes; i++) {
        const wsc_frame *f = &A->frames[i];
        ASSERT_INT_EQ(f->encoding, 0);
        if (i > 0) {
            ASSERT(f->seq > A->frames[i - 1].seq);
            ASSERT(f->t_capture > A->frames[i - 1].t_capture);
        }
        ASSERT(f->t_capture <= f->t_synth && f->t_synth <= f->t_send && f->t_send <= f->t_recv);
        ASSERT_NEAR_I((double)(f->t_recv - f->t_capture), 0, 500000, i); /* under 0.5 s */
    }
    double span = (double)(A->frames[A->nframes - 1].t_capture - A->frames[0].t_capture) * 1e-6;
    double rate = (double)(A->frames[A->nframes - 1].seq - A->frames[0].seq) / span;
    printf("stream: %d frames at %.1f Hz (source 30 Hz), %d vertices\n", A->nframes, rate, A->nv);
    ASSERT_NEAR(rate, 30, 3);

    /* both encodings decode to the same mesh within the stated bound */
    int compared = 0;
    double worst = 0;
    for (int i = 0; i < B->nframes; i++) {
        const wsc_frame *q = &B->frames[i];
        if (q->encoding != 1)
            continue;
        for (int j = 0; j < A->nframes; j++) {
            const wsc_frame *p = &A->frames[j];
            if (p->seq != q->seq)
                continue;
            ASSERT(!(q->flags & 2)); /* nothing clamped on this motion */
            for (int k = 0; k < A->nv * 3; k++) {
                int a = k % 3;
                double bound = (B->qmax[a] - B->qmin[a]) / 131070.0 * 1.0001 + 1e-6;
                double d = fabs((double)p->V[k] - (double)q->V[k]);
                worst = d / bound > worst ? d / bound : worst;
                ASSERT_NEAR_I(q->V[k], p->V[k], bound, k);
            }
            compared++;
        }
    }
    printf("encodings: %d frames compared, worst error %.3f of the bound\n", compared, worst);
    ASSERT(compared >= 30);

    /* controls: good ones are acknowledged, bad ones get error replies, the connection stays */
    send_and_expect(ctx, B, "{\"type\":\"ping\",\"id\":\"p\"}", "pong", NULL);
    send_and_expect(ctx, B, "not json", "error", "malformed");
    send_and_expect(ctx, B, "{\"type\":\"dance\"}", "error", "unknown_type");
    send_and_expect(ctx, B, "{\"type\":\"seek\",\"frame\":-1}", "error", "bad_field");
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":2,\"extra\":1}", "error", "bad_field");
    send_and_expect(ctx, B, "{\"type\":\"seek\",\"frame\":100000}", "error", "source_error");
    int before = B->ntexts;
    wsc_send_binary(B, "\x01\x02\x03", 3);
    run_until(ctx, B, 0, before + 1, 5000);
    expect_reply(B, "error", "binary_not_accepted");
    uint64_t n0 = B->total_frames;
    run_until(ctx, B, n0 + 10, 0, 5000); /* still streaming */

    send_and_expect(ctx, B, "{\"type\":\"pause\"}", "ack", NULL);
    wsc_run(ctx, 300, NULL, NULL); /* frames already in flight */
    uint64_t paused = A->total_frames;
    wsc_run(ctx, 600, NULL, NULL);
    ASSERT(A->total_frames <= paused + 1);
    send_and_expect(ctx, B, "{\"type\":\"resume\"}", "ack", NULL);
    run_until(ctx, A, A->total_frames + 10, 0, 5000);
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":2}", "ack", NULL);
    send_and_expect(ctx, B, "{\"type\":\"seek\",\"frame\":10}", "ack", NULL);
    run_until(ctx, A, A->total_frames + 20, 0, 5000);
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":1}", "ack", NULL);

    /* an oversized message closes only that connection, with 1009 */
    wsc *C = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, C, 1, 0, 5000);
    char big[2001];
    memset(big, ' ', sizeof big - 1);
    big[0] = '{';
    big[sizeof big - 2] = '}';
    big[sizeof big - 1] = '\0';
    wsc_send(C, big);
    want wc = {C, 0, 0, 0, 1, -1};
    ASSERT(wsc_run(ctx, 5000, enough, &wc));
    ASSERT_INT_EQ(C->close_code, 1009);
    run_until(ctx, A, A->total_frames + 10, 0, 5000);

    /* /metrics */
    ASSERT(harness_metric(&H, "meshsteer_frames_out_total") > 100);
    ASSERT(harness_metric(&H, "meshsteer_control_errors_total") >= 6);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_closed_oversize_total"), 1);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients"), 2);
    ASSERT(harness_metric(&H, "meshsteer_latency_seconds_count") > 100);

    /* SIGHUP with a corrupt model file: logged, the old model keeps serving */
    char model[1200], corrupt[1200], good[1200];
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(corrupt, sizeof corrupt, "%s/corrupt.msm", H.dir);
    snprintf(good, sizeof good, "%s/example.msm", H.dir);
    harness_copy(corrupt, model);
    kill(H.pid, SIGHUP);
    for (int i = 0; i < 100 && harness_metric(&H, "meshsteer_reloads_failed_total") < 1; i++)
        wsc_run(ctx, 100, NULL, NULL);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_failed_total"), 1);
    ASSERT(harness_log_has(&H, "reload failed, the old model keeps serving"));
    run_until(ctx, A, A->total_frames + 15, 0, 5000);
    ASSERT_INT_EQ(A->hellos, 1);
    ASSERT_INT_EQ(A->frames[A->nframes - 1].generation, 1);

    /* SIGHUP with a good model: swapped in, every client greeted again */
    harness_copy(good, model);
    kill(H.pid, SIGHUP);
    want wh = {A, 0, 0, 2, 0, -1};
    ASSERT(wsc_run(ctx, 20000, enough, &wh));
    run_until(ctx, A, A->total_frames + 5, 0, 5000);
    /* generation numbers are unique, not contiguous: the failed reload used one */
    ASSERT(A->frames[A->nframes - 1].generation > 1);
    cJSON *h2 = cJSON_Parse(A->hello);
    ASSERT_INT_EQ(cJSON_GetObjectItem(h2, "generation")->valueint, A->frames[A->nframes - 1].generation);
    cJSON_Delete(h2);
    ASSERT_INT_EQ(A->topos, 2);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_total"), 1);
    printf("reload: corrupt model refused while serving; good model swapped in (new generation, new hello)\n");

    /* SIGTERM: every client closed with 1001 (going away), exit status 0 */
    int st = harness_stop(&H, SIGTERM, 5000);
    want wa = {A, 0, 0, 0, 1, -1}, wb2 = {B, 0, 0, 0, 1, -1};
    wsc_run(ctx, 3000, enough, &wa);
    wsc_run(ctx, 3000, enough, &wb2);
    ASSERT_INT_EQ(st, 0);
    ASSERT(A->closed && B->closed);
    ASSERT_INT_EQ(A->close_code, 1001);
    lws_context_destroy(ctx);
    wsc_free(A);
    wsc_free(B);
    wsc_free(C);
}

/* ------------------------------------------------------------------ slow */

/* A WebSocket client on a raw socket that completes the handshake and then never reads. */
static int stalled_client(int port)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    int small = 4096;
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT(connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0);
    const char *req = "GET /stream HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
                      "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                      "Sec-WebSocket-Version: 13\r\n\r\n";
    ASSERT(write(fd, req, strlen(req)) == (ssize_t)strlen(req));
    return fd;
}

static void scenario_slow(void)
{
    start_default("--encoding", "float32");
    struct lws_context *ctx = wsc_context();
    wsc *A = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, A, 10, 0, 15000);
    int fds[4];
    for (int i = 0; i < 4; i++)
        fds[i] = stalled_client(H.port);
    run_until(ctx, A, A->total_frames + 30, 0, 5000); /* the stalled sockets fill up */
    long rss0 = harness_rss_kb(&H);
    uint64_t f0 = A->total_frames;
    uint64_t t0 = wsc_now_us();
    run_until(ctx, A, f0 + 240, 0, 15000); /* 8 s at 30 Hz */
    double secs = (double)(wsc_now_us() - t0) * 1e-6;
    long rss1 = harness_rss_kb(&H);
    uint64_t skipped = 0;
    for (int i = 0; i < A->nframes; i++)
        skipped += (uint64_t)A->frames[i].skipped;
    double drops = harness_metric(&H, "meshsteer_drops_total{reason=\"client_slow\"}");
    printf("slow: fast client %.1f frames/s while 4 clients never read; daemon RSS %ld -> %ld kB; "
           "fast client skipped %llu; daemon counted %.0f skipped frames in all\n",
           240 / secs, rss0, rss1, (unsigned long long)skipped, drops);
    ASSERT(240 / secs > 27);        /* the fast client keeps the source's 30 Hz */
    ASSERT(skipped <= 2);           /* and misses nothing */
    ASSERT(rss1 - rss0 < 8 * 1024); /* bounded: < 8 MB growth over 240 frames of 4 stalled clients */
    ASSERT(drops >= 0);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients"), 5);
    for (int i = 0; i < 4; i++)
        close(fds[i]);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(A);
}

/* ------------------------------------------------------------------ record */

static void scenario_record(void)
{
    char out[1200], csv[1200];
    snprintf(out, sizeof out, "%s/recorded.c3d", H.dir);
    snprintf(csv, sizeof csv, "%s/trot.csv", H.dir);
    start_default("--record", out);
    /* let it run for about 2 s of frames */
    for (int i = 0; i < 100 && harness_metric(&H, "meshsteer_frames_in_total") < 60; i++)
        usleep(50000);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    char err[MDL_ERR_LEN];
    mdl_markers *rec = NULL, *src = NULL;
    ASSERT_OK(mdl_markers_read(out, NULL, &rec, err), err);
    ASSERT_OK(mdl_markers_read(csv, NULL, &src, err), err);
    ASSERT(rec->frames >= 60);
    ASSERT_INT_EQ(rec->count, src->count);
    ASSERT_NEAR(rec->fps, src->fps, 1e-6);
    for (int i = 0; i < src->count; i++)
        ASSERT(!strcmp(rec->names[i], src->names[i]));
    /* frame k of the recording is frame k of the replay (it started at 0) */
    for (int k = 0; k < rec->frames; k++)
        for (int i = 0; i < src->count * 3; i++) {
            size_t a = (size_t)k * (size_t)src->count * 3 + (size_t)i;
            size_t b = (size_t)(k % src->frames) * (size_t)src->count * 3 + (size_t)i;
            ASSERT_NEAR_I(rec->P[a], src->P[b], 1e-5, a);
        }
    printf("record: %d frames recorded and read back equal to the replayed file\n", rec->frames);
    mdl_markers_destroy(rec);
    mdl_markers_destroy(src);
}

/* ------------------------------------------------------------------ limits */

static void scenario_limits(void)
{
    char model[1200], source[1200];
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?loop=1", H.dir);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--max-clients", "2", "--token", "sesame", NULL};
    harness_start(&H, meshsteerd, args);
    struct lws_context *ctx = wsc_context();
    wsc *no = wsc_connect(ctx, H.port, NULL, 0);
    wsc *wrong = wsc_connect(ctx, H.port, "token=wrong", 0);
    wsc *a = wsc_connect(ctx, H.port, "token=sesame", 0);
    wsc *b = wsc_connect(ctx, H.port, "token=sesame", 0);
    run_until(ctx, a, 5, 0, 15000);
    run_until(ctx, b, 5, 0, 15000);
    wsc *c = wsc_connect(ctx, H.port, "token=sesame", 0); /* the third: over the limit */
    want w = {c, 0, 0, 0, 1, -1};
    ASSERT(wsc_run(ctx, 5000, enough, &w));
    ASSERT(no->closed && !no->connected);
    ASSERT(wrong->closed && !wrong->connected);
    ASSERT(!c->connected);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients_rejected_total"), 3);
    ASSERT_INT_EQ(harness_stop(&H, SIGINT, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(no);
    wsc_free(wrong);
    wsc_free(a);
    wsc_free(b);
    wsc_free(c);
    printf("limits: token and client limit enforced\n");
}

static void kill_daemon(void)
{
    if (H.pid > 0 && kill(H.pid, 0) == 0)
        harness_stop(&H, SIGKILL, 1000);
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: test_daemon MESHSTEERD MAKE_MODEL stream|slow|record|limits\n");
        return 2;
    }
    signal(SIGPIPE, SIG_IGN);
    meshsteerd = argv[1];
    harness_fixtures(&H, argv[2]);
    atexit(kill_daemon); /* a failed assertion must not leave the daemon running */
    if (!strcmp(argv[3], "stream"))
        scenario_stream();
    else if (!strcmp(argv[3], "slow"))
        scenario_slow();
    else if (!strcmp(argv[3], "record"))
        scenario_record();
    else if (!strcmp(argv[3], "limits"))
        scenario_limits();
    else
        return 2;
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", H.dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", H.dir);
    printf("ok\n");
    return 0;
}
