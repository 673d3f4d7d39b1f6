/* test_daemon.c - meshsteerd end to end: a model trained on the built-in example, a replay source,
 * the daemon on an ephemeral port, and WebSocket clients that check the protocol as documented.
 *
 * Usage: test_daemon MESHSTEERD MAKE_MODEL SCENARIO, SCENARIO one of
 *   stream   hello (a replay source offers all four controls), topology, frames (increasing seq, plausible timestamps), both encodings within
 *            the int16 bound, controls (good and bad, error replies), an oversized message closing
 *            only its connection, /healthz, /metrics, SIGHUP with a corrupt model (keeps serving),
 *            SIGHUP with a good one (new hello), SIGTERM (clients closed with 1001, exit 0)
 *   slow     a client that never reads while another receives at full rate; bounded memory
 *   record   --record writes a C3D that reads back as the replayed markers
 *   limits   max clients and token checks
 *   kblend   a kernel-blend steering model (model/steer/kblend.h) swapped in by SIGHUP and back:
 *            float32 frames equal to the library's synthesis from their markers, int16 within
 *            the bound, a params client served int16 (no params form), /healthz, /metrics; the
 *            same model with an idle skin: params frames for the idle frames only
 *   origin   --origin same and --origin LIST: matching Origins accepted, others and none refused
 *   idle     --idle-timeout 2: a client that accepts no frame is closed, a reading one is not
 *   config   -c FILE round trip through the binary: the file's settings take effect, flags
 *            override them, --check-config accepts it and names FILE:LINE for bad ones
 *   labels   a replay source whose marker labels are renamed (cam_<name>): refused without a label
 *            map (the error mentions --labels), streams with --labels <name>=cam_<name>,... (an
 *            unused entry logged as a warning; the hello's markers[].live names cam_<name>), and
 *            keeps the map over a SIGHUP reload; a map leaving one marker unbound (bound false, live
 *            the label looked for); the same map from a config file's `labels =`
 *   http     HTTP answers: HEAD (the GET's headers, no body), another method 405 with Allow, an
 *            overlong URI or query 414, request headers over 8 KiB (one 100 KB header, known or
 *            not; 300 headers; 130 KiB, past lws's buffer; 300 repeats of a header lws knows; a
 *            /stream upgrade with 9 KiB) 431, but not 20 requests of 1 KB on one kept-alive
 *            connection; "%00" in the target 400 (the wire guard, server/wire_guard_io.h);
 *            a WebSocket frame header claiming 2^40 bytes closes its
 *            connection at once (not after the client sends them); a masked ping is answered, an
 *            unmasked frame closes the connection with 1002 at once
 *   listen   --listen binds exactly the address asked (the kernel's socket table, /proc/net/tcp and
 *            tcp6): 127.0.0.1:PORT and a bare PORT (the default address) an IPv4 loopback socket
 *            and no IPv6 one; [::1]:PORT an IPv6 loopback socket and no IPv4 one
 *   invalid  real data: a source whose every marker is invalid (shared/data sample16/basketball.c3d,
 *            every residual -1) bound by a label map: frames still come, flagged reference lost,
 *            with the last good pose (the rest pose); /healthz is "degraded" with the reason; the
 *            log says so once, not per frame. Skips (77) without the data.
 *   horse    real data: a model trained on shared/data/meshes/horse-gallop (meshsteer train)
 *            replaying its own rig markers at 60 Hz (meshsteer markers); hello, topology and
 *            frames of the horse's 8,431 vertices, each frame close to the ground-truth mesh of
 *            the marker frame it was made from, both encodings within the int16 bound.
 *            Needs MESHSTEER (5th argument); skips (77) without the data. */
#include "daemon_harness.h"
#include "model.h"
#include "test.h"
#include "wsclient.h"
#include "params.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <libwebsockets.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

static const char *meshsteerd;
static harness H;

/* Under ASan or TSan (MESHSTEER_SANITIZED=1, scripts/run.sh) the daemon runs several times
 * slower: the timing checks then only ask that frames keep coming (a third of the rate, latency
 * under 5 s), while every functional check stays as it is. */
static int sanitized;

/* rate must be within tol of want; sanitized, at least a third of want */
#define ASSERT_RATE(rate, want, tol)                                                               \
    do {                                                                                           \
        if (sanitized)                                                                             \
            ASSERT((rate) >= (want) / 3.0);                                                        \
        else                                                                                       \
            ASSERT_NEAR(rate, want, tol);                                                          \
    } while (0)

static double latency_bound_us(void)
{
    return sanitized ? 5e6 : 5e5;
}

/* a wait of ms, four times as long sanitized (as run_until's) */
static int wait_ms(int ms)
{
    return sanitized ? 4 * ms : ms;
}

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
    if (!wsc_run(ctx, sanitized ? 4 * ms : ms, enough, &w)) {
        fprintf(stderr, "timeout: %llu/%llu frames, %d/%d texts, closed %d (%s)\n",
                (unsigned long long)c->total_frames, (unsigned long long)frames, c->ntexts, texts,
                c->closed, c->error);
        harness_stop(&H, SIGKILL, 1000);
        exit(1);
    }
}

/* Frames received by A (float32) and B (int16) with the same sequence number decode to the same
 * mesh within the int16 bound of PROTOCOL.md; returns how many were compared, *worst the largest
 * error as a fraction of the bound. */
static int compare_encodings_as(const wsc *A, const wsc *B, int enc, double *worst)
{
    int compared = 0;
    for (int i = 0; i < B->nframes; i++) {
        const wsc_frame *q = &B->frames[i];
        if (q->encoding != enc)
            continue;
        for (int j = 0; j < A->nframes; j++) {
            const wsc_frame *p = &A->frames[j];
            if (p->seq != q->seq)
                continue;
            ASSERT(!(q->flags & 2)); /* nothing clamped on these motions */
            for (int k = 0; k < A->nv * 3; k++) {
                int a = k % 3;
                double bound = (B->qmax[a] - B->qmin[a]) / 131070.0 * 1.0001 + 1e-6;
                double d = fabs((double)p->V[k] - (double)q->V[k]);
                *worst = d / bound > *worst ? d / bound : *worst;
                ASSERT_NEAR_I(q->V[k], p->V[k], bound, k);
            }
            compared++;
        }
    }
    return compared;
}

static int compare_encodings(const wsc *A, const wsc *B, double *worst)
{
    return compare_encodings_as(A, B, 1, worst);
}

static void expect_str(const char *got, const char *want)
{
    if (strcmp(got, want)) {
        fprintf(stderr, "expected \"%s\", got \"%s\"\n", want, got);
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

/* The seq of the last reply, an ack of a source control (a whole number >= 0). */
static uint64_t ack_seq_of(const wsc *c)
{
    cJSON *j = cJSON_Parse(last_text(c));
    const cJSON *q = cJSON_GetObjectItem(j, "seq");
    if (!cJSON_IsNumber(q) || q->valuedouble < 0 || q->valuedouble != floor(q->valuedouble)) {
        fprintf(stderr, "expected an ack with a seq, got %s\n", last_text(c));
        exit(1);
    }
    uint64_t seq = (uint64_t)q->valuedouble;
    cJSON_Delete(j);
    return seq;
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
    /* the committed take itself (make_model's trot.csv is the same frames in CSV) */
    snprintf(source, sizeof source, "replay:%s?loop=1", test_src("recordings/example-trot.c3d"));
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
    /* a replay source takes all four controls, listed in this order */
    char *ctl = cJSON_PrintUnformatted(cJSON_GetObjectItem(cJSON_GetObjectItem(h, "source"), "controls"));
    ASSERT(ctl);
    expect_str(ctl, "[\"pause\",\"resume\",\"seek\",\"speed\"]");
    cJSON_free(ctl);
    cJSON_Delete(h);
    /* the topology: faces index vertices, the rest pose lies in the quantisation box */
    ASSERT_INT_EQ(A->topos, 1);
    const unsigned char *t = A->topo + 56;
    for (int i = 0; i < A->nf * 3; i++) {
        uint32_t f = (uint32_t)t[A->nv * 12 + 4 * i] | (uint32_t)t[A->nv * 12 + 4 * i + 1] << 8 |
                     (uint32_t)t[A->nv * 12 + 4 * i + 2] << 16 | (uint32_t)t[A->nv * 12 + 4 * i + 3] << 24;
        ASSERT_INT_LT_I(f, A->nv, i); /* unsigned: 0 <= f < nv */
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
        ASSERT_NEAR_I((double)(f->t_recv - f->t_capture), 0, latency_bound_us(), i); /* under 0.5 s */
    }
    double span = (double)(A->frames[A->nframes - 1].t_capture - A->frames[0].t_capture) * 1e-6;
    double rate = (double)(A->frames[A->nframes - 1].seq - A->frames[0].seq) / span;
    printf("stream: %d frames at %.1f Hz (source 30 Hz), %d vertices\n", A->nframes, rate, A->nv);
    ASSERT_RATE(rate, 30, 3);

    /* both encodings decode to the same mesh within the stated bound */
    double worst = 0;
    int compared = compare_encodings(A, B, &worst);
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
    /* the ack names the newest frame made before the pause: none made after it comes, to the
     * client that paused or to another */
    uint64_t ack_seq = ack_seq_of(B);
    wsc_run(ctx, 300, NULL, NULL); /* frames already in flight */
    uint64_t paused = A->total_frames;
    wsc_run(ctx, 600, NULL, NULL);
    ASSERT(A->total_frames <= paused + 1);
    if (A->last_seq > ack_seq || B->last_seq > ack_seq) {
        fprintf(stderr, "pause: the ack named frame %llu, frames %llu and %llu came after it\n",
                (unsigned long long)ack_seq, (unsigned long long)A->last_seq,
                (unsigned long long)B->last_seq);
        exit(1);
    }
    printf("pause: the ack named frame %llu; none newer came in 0.9 s\n",
           (unsigned long long)ack_seq);
    send_and_expect(ctx, B, "{\"type\":\"resume\"}", "ack", NULL);
    run_until(ctx, A, A->total_frames + 10, 0, 5000);
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":2}", "ack", NULL);
    send_and_expect(ctx, B, "{\"type\":\"seek\",\"frame\":10}", "ack", NULL);
    run_until(ctx, A, A->total_frames + 20, 0, 5000);
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":1}", "ack", NULL);

    /* speed: one range, [0.001, 100], for the message as for the URL option; and no speed stalls
     * the source: from 0.001 (a frame every 33 s) back to 1, frames come at once (they did
     * after 33 s; after 1e-300, never) */
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":0}", "error", "source_error");
    ASSERT(strstr(last_text(B), "outside [0.001, 100]"));
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":1e-300}", "error", "source_error");
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":101}", "error", "source_error");
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":0.001}", "ack", NULL);
    wsc_run(ctx, 500, NULL, NULL);
    send_and_expect(ctx, B, "{\"type\":\"speed\",\"speed\":1}", "ack", NULL);
    uint64_t t_resume = wsc_now_us();
    run_until(ctx, A, A->total_frames + 10, 0, 3000);
    printf("speed 0.001 then 1: 10 frames %.3f s after the ack\n",
           (double)(wsc_now_us() - t_resume) * 1e-6);
    ASSERT(wsc_now_us() - t_resume < 2000000);

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

    /* SIGHUP while paused: swapped in at once, not at the resume */
    send_and_expect(ctx, B, "{\"type\":\"pause\"}", "ack", NULL);
    wsc_run(ctx, 300, NULL, NULL); /* frames already in flight */
    ASSERT_INT_EQ(A->hellos, 2);
    kill(H.pid, SIGHUP);
    want wp = {A, 0, 0, 3, 0, -1};
    uint64_t t_hup = wsc_now_us();
    if (!wsc_run(ctx, 5000, enough, &wp)) {
        fprintf(stderr, "reload while paused: %d hellos, %llu frames\n", A->hellos,
                (unsigned long long)A->total_frames);
        exit(1);
    }
    printf("reload while paused: new hello after %.2f s\n", (double)(wsc_now_us() - t_hup) * 1e-6);
    send_and_expect(ctx, B, "{\"type\":\"resume\"}", "ack", NULL);
    run_until(ctx, A, A->total_frames + 5, 0, 5000);

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

/* ------------------------------------------------------------------ kinds */

/* Frames of A from index `from` on that have (or lack) the idle flag. */
static int count_flag(const wsc *A, int from, int flag, int set)
{
    int n = 0;
    for (int i = from; i < A->nframes; i++)
        n += ((A->frames[i].flags & flag) != 0) == set;
    return n;
}

/* A model file with two kinds over one mesh (the steering model + the skin of the same example):
 * the hello names both; while the replay plays, frames are tracked; once it ends, the skin's
 * clock-driven animation takes over (idle flag, /healthz driver idle) with no new hello; a seek
 * brings tracking back. The same with the skin walking its example's transition graph (Zheng
 * 2013's variations): idle frames at 30 fps that move. A model whose only kind is the skin streams
 * on its own clock. */
static void scenario_kinds(void)
{
    char model[1200], source[1200], *body = NULL;
    snprintf(model, sizeof model, "%s/two-kinds.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?start=150", H.dir); /* 90 frames left */
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0", "-v", NULL};
    harness_start(&H, meshsteerd, args);
    struct lws_context *ctx = wsc_context();
    wsc *A = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, A, 20, 0, 15000);
    cJSON *h = cJSON_Parse(A->hello);
    cJSON *m = cJSON_GetObjectItem(h, "model");
    ASSERT(!strcmp(cJSON_GetObjectItem(m, "kind")->valuestring, "steer"));
    ASSERT_INT_EQ(cJSON_GetArraySize(cJSON_GetObjectItem(m, "kinds")), 2);
    ASSERT(!strcmp(cJSON_GetArrayItem(cJSON_GetObjectItem(m, "kinds"), 1)->valuestring, "skin"));
    ASSERT(cJSON_IsTrue(cJSON_GetObjectItem(m, "idle")));
    cJSON_Delete(h);
    ASSERT(count_flag(A, 0, 8, 0) >= 10); /* tracked frames while the replay plays */
    /* a paused replay holds its pose: someone is there, so no idle animation for 2 s */
    wsc_send(A, "{\"type\":\"pause\"}");
    run_until(ctx, A, 0, 1, 5000);
    int paused_at = A->nframes;
    wsc_run(ctx, 2000, NULL, NULL);
    ASSERT_INT_EQ(count_flag(A, paused_at, 8, 1), 0);
    printf("kinds: paused 2 s: %d frames, none idle\n", A->nframes - paused_at);
    wsc_send(A, "{\"type\":\"resume\"}");
    run_until(ctx, A, 0, 2, 5000);
    /* the replay ends: the idle animation takes over, at the model's 30 fps */
    run_until(ctx, A, A->total_frames + 140, 0, 15000); /* the last ~80 tracked, then idle */
    int from = A->nframes - 50;
    int idle = count_flag(A, from, 8, 1);
    printf("kinds: %d of the last 50 frames are idle; hellos %d\n", idle, A->hellos);
    ASSERT_INT_EQ(idle, 50);
    ASSERT_INT_EQ(A->hellos, 1); /* same mesh: no new hello */
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200);
    ASSERT(strstr(body, "\"driver\":\"idle\""));
    free(body);
    ASSERT(harness_log_has(&H, "the idle animation takes over"));
    /* the idle frames move: the skin plays the example's walk */
    double span = (double)(A->frames[A->nframes - 1].t_capture - A->frames[from + 5].t_capture) * 1e-6;
    double rate = (A->nframes - from - 6) / span;
    printf("kinds: idle frames at %.1f Hz (model 30 Hz)\n", rate);
    ASSERT_RATE(rate, 30, 4);
    /* a seek back revives the replay: tracked again */
    wsc_send(A, "{\"type\":\"seek\",\"frame\":0}");
    run_until(ctx, A, A->total_frames + 40, 3, 15000);
    from = A->nframes - 20;
    ASSERT(count_flag(A, from, 8, 0) >= 18);
    ASSERT(harness_log_has(&H, "tracking again"));
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);

    /* the same with the skin walking its example's transition graph (Zheng 2013): idle frames at
     * 30 fps that keep changing */
    snprintf(model, sizeof model, "%s/two-kinds-walk.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?start=200", H.dir);
    harness_start(&H, meshsteerd, args);
    wsc *W = wsc_connect(ctx, H.port, NULL, 1);
    run_until(ctx, W, 20, 0, 15000);
    run_until(ctx, W, W->total_frames + 80, 0, 15000);
    from = W->nframes - 50;
    idle = count_flag(W, from, 8, 1);
    span = (double)(W->frames[W->nframes - 1].t_capture - W->frames[from + 5].t_capture) * 1e-6;
    rate = (W->nframes - from - 6) / span;
    int moved = 0;
    for (int f = from + 1; f < W->nframes; f++) {
        const float *a = W->frames[f - 1].V, *b = W->frames[f].V;
        float d = 0;
        for (int i = 0; a && b && i < 3 * W->nv; i++)
            d = fmaxf(d, fabsf(a[i] - b[i]));
        moved += d > 1e-5f;
    }
    printf("kinds: walking skin: %d of the last 50 frames are idle, at %.1f Hz, %d of 49 moved\n",
           idle, rate, moved);
    ASSERT_INT_EQ(idle, 50);
    ASSERT_INT_GE(moved, 45);
    ASSERT_RATE(rate, 30, 4);
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200);
    ASSERT(strstr(body, "\"driver\":\"idle\""));
    free(body);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);

    /* the skin alone: a clock-driven primary kind, no markers, frames at its own 30 fps */
    snprintf(model, sizeof model, "%s/skin.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?loop=1", H.dir);
    harness_start(&H, meshsteerd, args);
    wsc *B = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, B, 60, 0, 15000);
    h = cJSON_Parse(B->hello);
    ASSERT(!strcmp(cJSON_GetObjectItem(cJSON_GetObjectItem(h, "model"), "kind")->valuestring, "skin"));
    ASSERT_INT_EQ(cJSON_GetArraySize(cJSON_GetObjectItem(h, "markers")), 0);
    cJSON_Delete(h);
    ASSERT_INT_EQ(B->nm, 0);
    ASSERT_INT_EQ(count_flag(B, 0, 8, 1), 0); /* its own frames, not idle ones */
    span = (double)(B->frames[B->nframes - 1].t_capture - B->frames[10].t_capture) * 1e-6;
    rate = (B->nframes - 11) / span;
    printf("kinds: a skin alone streams at %.1f Hz with %d markers\n", rate, B->nm);
    ASSERT_RATE(rate, 30, 4);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx); /* A's connection lives in the context until here */
    wsc_free(A);
    wsc_free(W);
    wsc_free(B);
}

/* ------------------------------------------------------------------ kblend */

/* Generation of c's last hello. */
static int hello_generation(const wsc *c)
{
    cJSON *h = cJSON_Parse(c->hello);
    ASSERT(h);
    int g = cJSON_GetObjectItem(h, "generation")->valueint;
    cJSON_Delete(h);
    return g;
}

/* The float32 frames of A of generation gen against the library: each is what the model of
 * model_path synthesises from the markers the frame carries (the kernel blend keeps no state but
 * the last position of a missing marker, and the replay misses none). Every vertex finite; returns
 * the frames compared, *worst the largest difference (m), *moved the largest step of a vertex
 * between the first and the last of them (m). */
static int kblend_against_library(const wsc *A, uint32_t gen, const char *model_path, double *worst,
                                  double *moved)
{
    char err[MDL_ERR_LEN];
    mdl_model *m = NULL;
    mdl_synth *s = NULL;
    ASSERT_OK(mdl_model_load(model_path, &m, err), err);
    ASSERT_OK(mdl_synth_create(m, 0, &s, err), err);
    float *V = calloc(3 * (size_t)A->nv, sizeof *V);
    ASSERT(V);
    int n = 0, first = -1, last = -1;
    *worst = *moved = 0;
    for (int i = 0; i < A->nframes; i++) {
        const wsc_frame *f = &A->frames[i];
        if (f->generation != gen || f->encoding != 0 || !f->V || !f->M)
            continue;
        ASSERT_INT_EQ(f->flags & 1, 0); /* tracked, the reference never lost */
        ASSERT_INT_EQ(f->flags & 8, 0); /* not idle */
        for (int k = 0; k < 3 * A->nv; k++)
            ASSERT(isfinite(f->V[k]));
        ASSERT_OK(mdl_synth_markers(s, f->M, NULL, V, NULL), "synth");
        for (int k = 0; k < 3 * A->nv; k++) {
            double d = fabs((double)V[k] - (double)f->V[k]);
            *worst = d > *worst ? d : *worst;
            ASSERT_NEAR_I(f->V[k], V[k], 1e-5, k);
        }
        first = first < 0 ? i : first;
        last = i;
        n++;
    }
    for (int k = 0; n && k < 3 * A->nv; k++) {
        double d = fabs((double)A->frames[first].V[k] - (double)A->frames[last].V[k]);
        *moved = d > *moved ? d : *moved;
    }
    free(V);
    mdl_synth_destroy(s);
    mdl_model_destroy(m);
    return n;
}

/* A steering model synthesising by the kernel blend of its training meshes (model/steer/kblend.h:
 * no params layout, the meshes in its file), served as a SIGHUP reload of a part model and back:
 * float32 frames are, vertex for vertex, what the library makes of the markers they carry (finite,
 * moving with the trot); int16 frames agree with them within the int16 bound; the hello lists no
 * params form, and a params client gets the kernel blend's frames as int16 (docs/PROTOCOL.md 1, as
 * for the harmonic kind), then params frames again after the reload back; /healthz and /metrics
 * as for any model. */
static void scenario_kblend(void)
{
    char live[1200], part[1200], kb[1200], source[1200], *body = NULL;
    snprintf(live, sizeof live, "%s/live.msm", H.dir);
    snprintf(part, sizeof part, "%s/example.msm", H.dir);
    snprintf(kb, sizeof kb, "%s/kblend.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?loop=1", H.dir);
    harness_copy(part, live);
    const char *args[] = {"--model", live, "--source", source, "--listen", "127.0.0.1:0", "-v", NULL};
    harness_start(&H, meshsteerd, args);
    struct lws_context *ctx = wsc_context();
    ASSERT(ctx);
    wsc *A = wsc_connect(ctx, H.port, NULL, 1);
    wsc *B = wsc_connect(ctx, H.port, NULL, 1);
    wsc *Q = wsc_connect(ctx, H.port, NULL, 1);
    run_until(ctx, A, 5, 0, 15000);
    send_and_expect(ctx, A, "{\"type\":\"encoding\",\"encoding\":\"float32\"}", "ack", NULL);
    send_and_expect(ctx, B, "{\"type\":\"encoding\",\"encoding\":\"int16\"}", "ack", NULL);
    send_and_expect(ctx, Q, "{\"type\":\"encoding\",\"encoding\":\"params\"}", "ack", NULL);
    want wq = {Q, 10, 0, 0, 0, 2};
    ASSERT(wsc_run(ctx, wait_ms(15000), enough, &wq)); /* the part model: params frames */
    ASSERT_INT_EQ(Q->params->nlayouts, 1);

    /* SIGHUP: the part model's file replaced by the kernel blend's */
    harness_copy(kb, live);
    ASSERT_INT_EQ(kill(H.pid, SIGHUP), 0);
    want wh = {A, 0, 0, 2, 0, -1};
    ASSERT(wsc_run(ctx, wait_ms(20000), enough, &wh));
    uint32_t gen = (uint32_t)hello_generation(A);
    cJSON *h = cJSON_Parse(A->hello);
    ASSERT(h);
    const cJSON *hm = cJSON_GetObjectItem(h, "model");
    expect_str(cJSON_GetObjectItem(hm, "name")->valuestring, "example-kblend");
    expect_str(cJSON_GetObjectItem(hm, "kind")->valuestring, "steer");
    ASSERT_INT_EQ(cJSON_GetArraySize(cJSON_GetObjectItem(hm, "params")), 0);
    cJSON_Delete(h);
    uint64_t t0 = A->total_frames;
    run_until(ctx, A, t0 + 90, 0, 15000); /* 3 s of the trot */
    want wb = {B, 0, 0, 2, 0, -1};
    ASSERT(wsc_run(ctx, wait_ms(5000), enough, &wb));
    want wq2 = {Q, 0, 0, 2, 0, -1};
    ASSERT(wsc_run(ctx, wait_ms(5000), enough, &wq2));
    ASSERT_INT_EQ(A->protocol_errors + B->protocol_errors + Q->protocol_errors, 0);
    ASSERT_INT_EQ(A->topos, 2); /* a topology after each hello, the same mesh */
    ASSERT_INT_EQ(Q->topos, 2);
    ASSERT_INT_EQ(A->nv, 4794);
    double worst = 0, moved = 0;
    int n = kblend_against_library(A, gen, kb, &worst, &moved);
    double wb16 = 0;
    int n16 = compare_encodings_as(A, B, 1, &wb16);
    int q16 = 0, q2 = 0, qcmp = 0;
    double wq16 = 0;
    for (int i = 0; i < Q->nframes; i++)
        if (Q->frames[i].generation == gen) {
            q16 += Q->frames[i].encoding == 1;
            q2 += Q->frames[i].encoding == 2;
        }
    qcmp = compare_encodings_as(A, Q, 1, &wq16);
    printf("kblend: %d float32 frames as the library makes them (worst %.2g m), vertices moved up "
           "to %.3f m; int16 %d frames within %.3f of the bound; the params client: %d int16 "
           "frames, %d params frames, %d params models\n",
           n, worst, moved, n16, wb16, q16, q2, Q->params_msgs);
    ASSERT_INT_GE(n, 60);
    ASSERT(moved > 0.01); /* the blend follows the trot, not a still pose */
    ASSERT_INT_GE(n16, 30);
    ASSERT_INT_GE(q16, 30);
    ASSERT_INT_EQ(q2, 0);
    ASSERT_INT_GE(qcmp, 30);
    ASSERT_INT_EQ(Q->params_msgs, 2);
    ASSERT_INT_EQ(Q->params->nlayouts, 0);
    /* asking for params again under the kernel blend: acknowledged, frames keep coming as int16 */
    send_and_expect(ctx, Q, "{\"type\":\"encoding\",\"encoding\":\"params\"}", "ack", NULL);
    run_until(ctx, Q, Q->total_frames + 10, 0, 5000);
    ASSERT_INT_EQ(Q->frames[Q->nframes - 1].encoding, 1);
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200);
    cJSON *hz = cJSON_Parse(body);
    ASSERT(hz);
    expect_str(cJSON_GetObjectItem(hz, "status")->valuestring, "ok");
    cJSON_Delete(hz);
    free(body);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_total"), 1);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_failed_total"), 0);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_drops_total{reason=\"synth_failed\"}"), 0);
    ASSERT(harness_metric(&H, "meshsteer_frames_out_total") > 200);

    /* and back: the part model, params frames again */
    harness_copy(part, live);
    ASSERT_INT_EQ(kill(H.pid, SIGHUP), 0);
    want wq3 = {Q, 0, 0, 3, 0, -1};
    ASSERT(wsc_run(ctx, wait_ms(20000), enough, &wq3));
    uint32_t gen3 = (uint32_t)hello_generation(Q);
    run_until(ctx, Q, Q->total_frames + 20, 0, 15000);
    int back = 0;
    for (int i = 0; i < Q->nframes; i++)
        back += Q->frames[i].generation == gen3 && Q->frames[i].encoding == 2;
    printf("kblend: back to the part model: %d params frames, %d params models\n", back,
           Q->params_msgs);
    ASSERT_INT_GE(back, 15);
    ASSERT_INT_EQ(Q->params_msgs, 3);
    ASSERT_INT_EQ(Q->params->nlayouts, 1);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_total"), 2);
    ASSERT_INT_EQ(A->protocol_errors + B->protocol_errors + Q->protocol_errors, 0);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);

    /* the kernel blend with the example's skin as its idle kind: the only params layout is the
     * skin's (layout 0), so a params client gets the blend's tracked frames as int16 and the
     * idle frames as params frames, each matching the float32 frame of the same number */
    snprintf(live, sizeof live, "%s/kblend-skin.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?start=140", H.dir); /* 100 frames, then idle */
    harness_start(&H, meshsteerd, args);
    wsc *F = wsc_connect(ctx, H.port, NULL, 1);
    wsc *P = wsc_connect(ctx, H.port, NULL, 1);
    wsc_send(P, "{\"type\":\"encoding\",\"encoding\":\"params\"}");
    want wp = {P, 30, 0, 0, 0, 2}; /* 30 idle params frames */
    ASSERT(wsc_run(ctx, wait_ms(20000), enough, &wp));
    run_until(ctx, F, F->total_frames + 5, 0, 5000);
    ASSERT_INT_EQ(F->protocol_errors + P->protocol_errors, 0);
    h = cJSON_Parse(P->hello);
    ASSERT(h);
    hm = cJSON_GetObjectItem(h, "model");
    ASSERT(cJSON_IsTrue(cJSON_GetObjectItem(hm, "idle")));
    ASSERT_INT_EQ(cJSON_GetArraySize(cJSON_GetObjectItem(hm, "params")), 1);
    expect_str(cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(hm, "params"), 0), "kind")->valuestring,
               "skin");
    cJSON_Delete(h);
    ASSERT_INT_EQ(P->params_msgs, 1);
    ASSERT_INT_EQ(P->params->nlayouts, 1);
    ASSERT_INT_EQ(P->params->layout[0].kind, 3);
    int tracked16 = 0, idle2 = 0, wrong = 0;
    for (int i = 0; i < P->nframes; i++) {
        const wsc_frame *f = &P->frames[i];
        tracked16 += !(f->flags & 8) && f->encoding == 1;
        idle2 += (f->flags & 8) && f->encoding == 2;
        wrong += !(f->flags & 8) && f->encoding == 2; /* a blend frame claiming a params form */
    }
    double w1 = 0, w2 = 0;
    int c1 = compare_encodings_as(F, P, 1, &w1), c2 = compare_encodings_as(F, P, 2, &w2);
    printf("kblend + skin: a params client got %d tracked int16 frames, %d idle params frames; "
           "%d and %d compared with float32 (worst %.3f, %.3f of the int16 bound)\n",
           tracked16, idle2, c1, c2, w1, w2);
    ASSERT_INT_GE(tracked16, 20);
    ASSERT_INT_GE(idle2, 30);
    ASSERT_INT_EQ(wrong, 0);
    ASSERT_INT_GE(c1, 20);
    ASSERT_INT_GE(c2, 20);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(A);
    wsc_free(B);
    wsc_free(Q);
    wsc_free(F);
    wsc_free(P);
}

/* ------------------------------------------------------------------ fade */

/* The largest vertex displacement between frames k-1 and k of A. */
static double frame_step(const wsc *A, int k)
{
    const float *a = A->frames[k - 1].V, *b = A->frames[k].V;
    double d = 0;
    for (int i = 0; i < A->nv && a && b; i++) {
        double dx = a[3 * i] - b[3 * i], dy = a[3 * i + 1] - b[3 * i + 1], dz = a[3 * i + 2] - b[3 * i + 2];
        d = fmax(d, sqrt(dx * dx + dy * dy + dz * dz));
    }
    return d;
}

typedef struct fade_run {
    int idle_before;   /* idle frames before the first tracked one */
    int first_tracked; /* its index (-1: none) */
    double cut;        /* largest step over the first 3 tracked frames */
    double across;     /* largest step over the first 1.2 s of tracked frames */
    double motion;     /* median step of tracked frames after that */
    int switches_idle, switches_tracked; /* /metrics */
} fade_run;

/* The first blank + keep frames of trot.csv, the first `blank` with every marker invalid (empty
 * cells): the tracked kind cannot pose them, and then it can. */
static void write_blanked(const char *from, const char *to, int blank, int keep)
{
    FILE *in = fopen(from, "r"), *out = fopen(to, "w");
    ASSERT(in && out);
    char line[16384];
    for (int row = -1; row < blank + keep && fgets(line, sizeof line, in); row++) {
        if (row >= 0 && row < blank) { /* keep frame,time; empty the rest */
            char *c = strchr(line, ',');
            c = c ? strchr(c + 1, ',') : NULL;
            ASSERT(c);
            for (char *q = c; *q && *q != '\n'; q++)
                if (*q != ',')
                    *q = ' ';
            char *w = c, *r = c; /* drop the blanks */
            for (; *r; r++)
                if (*r != ' ')
                    *w++ = *r;
            *w = 0;
        }
        fputs(line, out);
    }
    fclose(in);
    ASSERT_INT_EQ(fclose(out), 0);
}

static void run_fade(struct lws_context *ctx, const char *source, const char *idle_after,
                     const char *fade, fade_run *r)
{
    char model[1200], *body = NULL;
    snprintf(model, sizeof model, "%s/two-kinds.msm", H.dir);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--idle-after", idle_after, "--fade", fade, "-v", NULL};
    harness_start(&H, meshsteerd, args);
    wsc *A = wsc_connect(ctx, H.port, NULL, 1);
    /* 60 blank frames (2 s at the example's 30 Hz) then 75 tracked (2.5 s), then the replay ends:
     * idle again */
    want w = {A, 0, 0, 0, 0, -1};
    uint64_t t0 = wsc_now_us();
    int seen_tracked_then_idle = 0;
    while (!seen_tracked_then_idle && wsc_now_us() - t0 < (sanitized ? 60000000u : 20000000u)) {
        w.frames = A->total_frames + 1;
        wsc_run(ctx, 1000, enough, &w);
        int tracked = 0;
        for (int i = 0; i < A->nframes; i++) {
            tracked |= !(A->frames[i].flags & 8);
            if (tracked && (A->frames[i].flags & 8) && i >= 10)
                seen_tracked_then_idle = 1;
        }
    }
    memset(r, 0, sizeof *r);
    r->first_tracked = -1;
    for (int i = 0; i < A->nframes && r->first_tracked < 0; i++) {
        if (A->frames[i].flags & 8)
            r->idle_before++;
        else
            r->first_tracked = i;
    }
    ASSERT(r->first_tracked >= 0);
    int k0 = r->first_tracked, end = k0;
    while (end < A->nframes && !(A->frames[end].flags & 8))
        end++;
    double steps[512];
    int ns = 0;
    for (int k = k0 > 0 ? k0 : 1; k < end; k++) {
        double d = frame_step(A, k);
        double since = (double)(A->frames[k].t_capture - A->frames[k0].t_capture) * 1e-6;
        if (k < k0 + 3)
            r->cut = fmax(r->cut, d);
        if (since <= 1.2)
            r->across = fmax(r->across, d);
        else if (ns < 512)
            steps[ns++] = d;
    }
    for (int i = 1; i < ns; i++) /* insertion sort: a median of a few dozen */
        for (int j = i; j > 0 && steps[j - 1] > steps[j]; j--) {
            double t = steps[j];
            steps[j] = steps[j - 1];
            steps[j - 1] = t;
        }
    r->motion = ns ? steps[ns / 2] : 0;
    ASSERT_INT_EQ(harness_get(&H, "/metrics", &body), 200);
    const char *a = strstr(body, "meshsteer_driver_switches_total{to=\"idle\"} ");
    const char *b = strstr(body, "meshsteer_driver_switches_total{to=\"tracked\"} ");
    ASSERT(a && b);
    r->switches_idle = atoi(a + strlen("meshsteer_driver_switches_total{to=\"idle\"} "));
    r->switches_tracked = atoi(b + strlen("meshsteer_driver_switches_total{to=\"tracked\"} "));
    free(body);
    printf("fade: --idle-after %s --fade %s: %d idle frames before the first tracked one; largest "
           "step %.4f over its first 3 frames, %.4f over its first 1.2 s, median step after %.4f; "
           "switches to idle %d, to tracked %d\n",
           idle_after, fade, r->idle_before, r->cut, r->across, r->motion, r->switches_idle,
           r->switches_tracked);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(A);
}

/* --idle-after and --fade (Zheng 2013's idle source, issue 11): a replay whose first 2 s of
 * markers are all invalid. With --idle-after 1 the idle animation takes over after 1 s of
 * refused frames, until the markers allow a pose; with --fade 0 the tracked pose then comes as a
 * cut (a jump), with --fade 1 the output blends from the still-running idle animation, so no step
 * in that second comes near the cut. With --idle-after 4 the 2 s of invalid markers are too
 * short for the idle animation: nothing idle before the first tracked frame. */
static void scenario_fade(void)
{
    char from[1200], csv[1200], source[1300];
    snprintf(from, sizeof from, "%s/trot.csv", H.dir);
    snprintf(csv, sizeof csv, "%s/trot-blank.csv", H.dir);
    write_blanked(from, csv, 60, 75);
    snprintf(source, sizeof source, "replay:%s", csv);
    fade_run cut, fade, late;
    run_fade(wsc_context(), source, "1", "0", &cut);
    run_fade(wsc_context(), source, "1", "1", &fade);
    run_fade(wsc_context(), source, "4", "0.5", &late);
    /* idle after 1 s of the 2 s: about 30 idle frames at the skin's 30 fps */
    ASSERT_INT_GE(cut.idle_before, sanitized ? 8 : 20);
    ASSERT_INT_LE(cut.idle_before, 45);
    ASSERT_INT_GE(fade.idle_before, sanitized ? 8 : 20);
    ASSERT(cut.switches_idle >= 1 && cut.switches_tracked >= 1);
    /* the cut is a jump well above the motion's own steps, or this test could not tell */
    ASSERT(cut.cut > 4 * cut.motion);
    /* the fade spreads it: every step of that second well under the cut */
    ASSERT(fade.across < 0.5 * cut.cut);
    /* --idle-after 4: tracked from the first frame on */
    ASSERT_INT_EQ(late.idle_before, 0);
    ASSERT_INT_EQ(late.first_tracked, 0);
}

/* ------------------------------------------------------------------ params */

static size_t frame_bytes(const wsc *c, int enc, int nparams)
{
    size_t vb = enc == 0 ? 12 * (size_t)c->nv : enc == 1 ? 6 * (size_t)c->nv : 8 + 4 * (size_t)nparams;
    return 56 + ((vb + 3) & ~(size_t)3) + 12 * (size_t)c->nm + (((size_t)c->nm + 3) & ~(size_t)3);
}

/* The params encoding (docs/PROTOCOL.md 2b): a client that asks for it gets the params model
 * (MSPM) once, then encoding-2 frames which, rebuilt by clients/params.c, match the float32
 * frames of the same sequence number within the int16 bound, for the steering model's tracked
 * frames (layout 0) and its skin's idle frames (layout 1); a reload sends a new MSPM. */
static void scenario_params(const char *load)
{
    char model[1200], source[1200];
    snprintf(model, sizeof model, "%s/two-kinds.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?start=170", H.dir); /* 70 frames, then idle */
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0", "-v", NULL};
    harness_start(&H, meshsteerd, args);
    struct lws_context *ctx = wsc_context();
    wsc *A = wsc_connect(ctx, H.port, NULL, 1);
    wsc *P = wsc_connect(ctx, H.port, NULL, 1);
    wsc_send(P, "{\"type\":\"encoding\",\"encoding\":\"params\",\"id\":3}");
    want wp = {P, 150, 0, 0, 0, 2};
    ASSERT(wsc_run(ctx, 20000, enough, &wp));
    ASSERT_INT_EQ(P->protocol_errors, 0);
    ASSERT_INT_EQ(A->protocol_errors, 0);
    ASSERT_INT_EQ(P->params_msgs, 1);
    ASSERT(P->params);
    ASSERT_INT_EQ(P->params->nlayouts, 2);
    ASSERT_INT_EQ(P->params->layout[0].kind, 1); /* steer, then its idle skin */
    ASSERT_INT_EQ(P->params->layout[1].kind, 3);
    cJSON *h = cJSON_Parse(P->hello);
    ASSERT(h);
    const cJSON *pk = cJSON_GetObjectItem(cJSON_GetObjectItem(h, "model"), "params");
    ASSERT_INT_EQ(cJSON_GetArraySize(pk), 2);
    ASSERT_INT_EQ(cJSON_GetObjectItem(cJSON_GetArrayItem(pk, 0), "floats")->valueint,
                  P->params->layout[0].nparams);
    cJSON_Delete(h);
    int tracked = 0, idle = 0;
    for (int i = 0; i < P->nframes; i++)
        if (P->frames[i].encoding == 2)
            *(P->frames[i].flags & 8 ? &idle : &tracked) += 1;
    double worst = 0;
    int compared = compare_encodings_as(A, P, 2, &worst);
    size_t b0 = frame_bytes(P, 0, 0), b1 = frame_bytes(P, 1, 0);
    size_t bs = frame_bytes(P, 2, P->params->layout[0].nparams);
    size_t bk = frame_bytes(P, 2, P->params->layout[1].nparams);
    printf("params: %d tracked + %d idle params frames, %d compared with float32, worst %.3f of "
           "the int16 bound; MSPM %zu bytes; bytes/frame float32 %zu, int16 %zu, params %zu (steer, "
           "%.1fx smaller than int16), %zu (skin, %.1fx)\n",
           tracked, idle, compared, worst, P->params_len, b0, b1, bs, (double)b1 / bs, bk,
           (double)b1 / bk);
    ASSERT_INT_GE(tracked, 20);
    ASSERT_INT_GE(idle, 20);
    ASSERT_INT_GE(compared, 40);
    ASSERT(bs * 10 < b1);
    /* meshsteer-load -e params: every connection gets its params model before params frames,
     * and the bytes per frame are the params frame's (the steering model's, while it tracks) */
    if (load) {
        char port[16], out[1200];
        snprintf(port, sizeof port, "%d", H.port);
        snprintf(out, sizeof out, "%s/load-params.json", H.dir);
        const char *argv[] = {load, "-n", "3", "-t", "1", "-w", "0.3", "-e", "params", "-p", port,
                              "-j", NULL};
        ASSERT_INT_EQ(harness_run(argv, out), 0);
        char buf[2048];
        harness_read(out, buf, sizeof buf);
        cJSON *j = cJSON_Parse(strchr(buf, '{') ? strchr(buf, '{') : buf);
        ASSERT(j);
        double bpf = cJSON_GetObjectItem(j, "bytes_per_frame")->valuedouble;
        printf("params: meshsteer-load -e params: %g bytes/frame, %g frames\n", bpf,
               cJSON_GetObjectItem(j, "received")->valuedouble);
        ASSERT(cJSON_GetObjectItem(j, "received")->valuedouble > 30);
        ASSERT(bpf == (double)bs || bpf == (double)bk); /* steer, or the skin once idle */
        cJSON_Delete(j);
    }
    /* a reload: a new hello, topology and params model, then params frames of the new generation */
    ASSERT_INT_EQ(kill(H.pid, SIGHUP), 0);
    want wh = {P, 0, 0, 2, 0, -1};
    ASSERT(wsc_run(ctx, 20000, enough, &wh));
    run_until(ctx, P, P->total_frames + 10, 0, 15000);
    ASSERT_INT_EQ(P->params_msgs, 2);
    ASSERT_INT_EQ(P->params->generation, P->frames[P->nframes - 1].generation);
    ASSERT_INT_EQ(P->frames[P->nframes - 1].encoding, 2);
    ASSERT_INT_EQ(P->protocol_errors, 0);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(A);
    wsc_free(P);
}

/* ------------------------------------------------------------------ slow */

static void scenario_slow(void)
{
    start_default("--encoding", "float32");
    struct lws_context *ctx = wsc_context();
    wsc *A = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, A, 10, 0, 15000);
    /* one client that keeps up: the daemon's count of what it skipped is what its frames say */
    {
        run_until(ctx, A, A->total_frames + 60, 0, 5000);
        uint64_t seen = 0;
        for (int i = 0; i < A->nframes; i++)
            seen += (uint64_t)A->frames[i].skipped;
        double per[8];
        ASSERT_INT_EQ(harness_metric_family(&H, "meshsteer_client_skipped_frames_total", per, 8), 1);
        printf("slow: one client keeping up skipped %llu frames by its headers, %.0f by /metrics\n",
               (unsigned long long)seen, per[0]);
        ASSERT(seen <= (sanitized ? 30u : 2u));
        ASSERT(per[0] >= (double)seen);
        ASSERT(per[0] <= (double)seen + 1); /* at most the one superseded since its last write */
    }
    int fds[4];
    for (int i = 0; i < 4; i++)
        fds[i] = harness_stalled_client(&H);
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
    ASSERT(240 / secs > (sanitized ? 10 : 27)); /* the fast client keeps the source's 30 Hz */
    ASSERT(skipped <= (sanitized ? 30u : 2u)); /* and misses (nearly) nothing */
    ASSERT(rss1 - rss0 < (sanitized ? 32 : 8) * 1024); /* bounded: < 8 MB growth over 240 frames of 4 stalled clients (ASan keeps freed memory in quarantine) */
    /* each stalled client is counted as skipping (nearly) every frame of the 8 s: >= 200 of 240 */
    double per[8];
    int nper = harness_metric_family(&H, "meshsteer_client_skipped_frames_total", per, 8);
    ASSERT_INT_EQ(nper, 5);
    int stalled_counted = 0;
    for (int i = 0; i < nper; i++)
        stalled_counted += per[i] >= 200;
    printf("slow: per-client skipped frames:");
    for (int i = 0; i < nper; i++)
        printf(" %.0f", per[i]);
    printf("\n");
    ASSERT_INT_EQ(stalled_counted, 4);
    ASSERT(drops >= 4 * 200.0);
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
    /* /healthz and /metrics name the model path and the source spec: the token guards them too */
    char *body;
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 401);
    free(body);
    ASSERT_INT_EQ(harness_get(&H, "/metrics", &body), 401);
    free(body);
    ASSERT_INT_EQ(harness_get(&H, "/metrics?token=wrong", &body), 401);
    free(body);
    ASSERT_INT_EQ(harness_get(&H, "/healthz?token=sesame", &body), 200);
    free(body);
    snprintf(H.token, sizeof H.token, "sesame"); /* Authorization: Bearer sesame */
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients_rejected_total"), 3);
    H.token[0] = '\0';
    ASSERT_INT_EQ(harness_stop(&H, SIGINT, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(no);
    wsc_free(wrong);
    wsc_free(a);
    wsc_free(b);
    wsc_free(c);
    printf("limits: token and client limit enforced\n");
}

/* ------------------------------------------------------------------ origin */

/* Sends a WebSocket upgrade for /stream with the given Origin header (NULL: none) on a raw
 * socket (lws's client would prefix "http://" to any origin); returns 1 when the daemon answers
 * 101 Switching Protocols, 0 when it refuses. */
static int origin_accepted(const char *origin)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)H.port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT(connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0);
    char req[1024], hdr[300] = "";
    if (origin)
        snprintf(hdr, sizeof hdr, "Origin: %s\r\n", origin);
    int n = snprintf(req, sizeof req,
                     "GET /stream HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\n"
                     "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                     "Sec-WebSocket-Version: 13\r\n%s\r\n",
                     H.port, hdr);
    ASSERT(write(fd, req, (size_t)n) == n);
    char resp[256] = "";
    size_t got = 0;
    ssize_t r;
    while (got < 12 && (r = read(fd, resp + got, sizeof resp - 1 - got)) > 0)
        got += (size_t)r;
    close(fd);
    resp[got] = '\0';
    int ok = !strncmp(resp, "HTTP/1.1 101", 12);
    char *eol = strstr(resp, "\r\n");
    if (eol)
        *eol = '\0';
    printf("origin %s: %s (%s)\n", origin ? origin : "(none)", ok ? "accepted" : "refused",
           got ? resp : "connection closed");
    return ok;
}

static void scenario_origin(void)
{
    char model[1200], source[1200], same_http[64], same_https[64];
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?loop=1", H.dir);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--origin", "same", "-v", NULL};
    harness_start(&H, meshsteerd, args);
    snprintf(same_http, sizeof same_http, "http://127.0.0.1:%d", H.port);
    snprintf(same_https, sizeof same_https, "https://127.0.0.1:%d", H.port);
    ASSERT(origin_accepted(same_http));
    /* the daemon serves http://: an https:// page is another origin (behind a TLS proxy, list it) */
    ASSERT(!origin_accepted(same_https));
    ASSERT(!origin_accepted("http://evil.example"));
    ASSERT(!origin_accepted("http://127.0.0.1:1")); /* same host, other port */
    ASSERT(!origin_accepted(NULL));
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients_rejected_total"), 4);
    ASSERT(harness_log_has(&H, "Origin does not match Host"));
    ASSERT(harness_log_has(&H, "no Origin header"));
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);

    /* an explicit list: exact matches only */
    const char *args2[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                           "--origin", "http://a.example, http://b.example:8080", "-v", NULL};
    harness_start(&H, meshsteerd, args2);
    ASSERT(origin_accepted("http://a.example"));
    ASSERT(origin_accepted("http://b.example:8080"));
    ASSERT(!origin_accepted("http://b.example"));
    ASSERT(!origin_accepted("http://a.example.evil.example"));
    ASSERT(!origin_accepted(same_http));
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients_rejected_total"), 3);
    ASSERT(harness_log_has(&H, "Origin not allowed"));
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    printf("origin: same and list checks enforced\n");
}

/* ------------------------------------------------------------------ idle */

static void scenario_idle(void)
{
    start_default("--idle-timeout", "2");
    struct lws_context *ctx = wsc_context();
    wsc *A = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, A, 10, 0, 15000);
    int fd = harness_stalled_client(&H);
    uint64_t t0 = wsc_now_us();
    /* the stalled socket fills within a few frames; 2 s later the daemon closes it */
    while (harness_metric(&H, "meshsteer_closed_idle_total") < 1 && wsc_now_us() - t0 < 10000000)
        wsc_run(ctx, 100, NULL, NULL);
    double secs = (double)(wsc_now_us() - t0) * 1e-6;
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_closed_idle_total"), 1);
    printf("idle: stalled client closed after %.1f s (timeout 2 s)\n", secs);
    ASSERT(secs >= 2.0 && secs < (sanitized ? 20.0 : 6.0));
    ASSERT(harness_log_has(&H, "accepted no frame for 2 s"));
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients"), 1);
    /* the reading client was never idle and keeps streaming */
    uint64_t n0 = A->total_frames;
    run_until(ctx, A, n0 + 60, 0, 5000);
    ASSERT(!A->closed);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_closed_idle_total"), 1);
    /* the daemon's side is gone: reading the stalled socket ends in EOF or a reset */
    char buf[65536];
    ssize_t got = 1;
    for (int i = 0; i < 100000 && got > 0; i++)
        got = read(fd, buf, sizeof buf);
    ASSERT(got <= 0);
    close(fd);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(A);
}

/* ------------------------------------------------------------------ config */

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    ASSERT(f);
    ASSERT(fputs(text, f) >= 0);
    ASSERT(fclose(f) == 0);
}

/* Runs meshsteerd with args and --check-config; returns its status, its output in out. */
static int check_config(const char *const *args, char *out, size_t cap)
{
    const char *argv[32];
    int n = 0;
    argv[n++] = meshsteerd;
    for (int i = 0; args[i]; i++)
        argv[n++] = args[i];
    argv[n++] = "--check-config";
    argv[n] = NULL;
    char log[1200];
    snprintf(log, sizeof log, "%s/check.log", H.dir);
    int st = harness_run(argv, log);
    FILE *f = fopen(log, "r");
    ASSERT(f);
    size_t got = fread(out, 1, cap - 1, f);
    out[got] = '\0';
    fclose(f);
    return st;
}

static void expect_config_error(const char *name, const char *text, const char *const *flags,
                                const char *message)
{
    char path[1200], out[4096];
    snprintf(path, sizeof path, "%s/%s", H.dir, name);
    write_file(path, text);
    const char *args[16] = {"-c", path};
    int n = 2;
    for (int i = 0; flags && flags[i]; i++)
        args[n++] = flags[i];
    args[n] = NULL;
    int st = check_config(args, out, sizeof out);
    if (st != 2 || !strstr(out, message)) {
        fprintf(stderr, "%s: expected status 2 and '%s', got %d: %s\n", name, message, st, out);
        exit(1);
    }
    printf("config %s: %s", name, out);
}

static void scenario_config(void)
{
    char conf[1200], text[4096], out[4096];
    snprintf(conf, sizeof conf, "%s/meshsteerd.conf", H.dir);
    snprintf(text, sizeof text,
             "# meshsteerd settings for the test\n"
             "model = %s/model.msm\n"
             "source = \"replay:%s/trot.csv?loop=1\"\n"
             "\n"
             "listen = 127.0.0.1:0\n"
             "max_clients = 1      # the flag below raises it to 2\n"
             "token = sesame\n"
             "encoding = int16\n",
             H.dir, H.dir);
    write_file(conf, text);
    const char *only_file[] = {"-c", conf, NULL};
    ASSERT_INT_EQ(check_config(only_file, out, sizeof out), 0);
    ASSERT(strstr(out, "settings are valid"));

    /* the file's settings take effect; --max-clients overrides the file's max_clients */
    const char *args[] = {"-c", conf, "--max-clients", "2", NULL};
    harness_start(&H, meshsteerd, args);
    struct lws_context *ctx = wsc_context();
    wsc *a = wsc_connect(ctx, H.port, "token=sesame", 0);
    wsc *b = wsc_connect(ctx, H.port, "token=sesame", 0);
    run_until(ctx, a, 5, 0, 15000);
    run_until(ctx, b, 5, 0, 15000);
    for (int i = 0; i < a->nframes; i++) /* int16 from the file, without asking */
        ASSERT_INT_EQ(a->frames[i].encoding, 1);
    wsc *c = wsc_connect(ctx, H.port, "token=sesame", 0); /* third: over the flag's limit */
    wsc *no = wsc_connect(ctx, H.port, NULL, 0);          /* no token: the file's token holds */
    want wc = {c, 0, 0, 0, 1, -1}, wn = {no, 0, 0, 0, 1, -1};
    ASSERT(wsc_run(ctx, 5000, enough, &wc));
    ASSERT(wsc_run(ctx, 5000, enough, &wn));
    ASSERT(!c->connected && !no->connected);
    snprintf(H.token, sizeof H.token, "sesame"); /* /metrics needs the token too */
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_clients_rejected_total"), 2);
    printf("config: file settings in effect (int16, token), --max-clients overrode the file\n");

    /* SIGHUP re-reads the file: a new token takes effect; a broken file keeps the old settings */
    wsc_free(c);
    wsc_free(no);
    wsc_close(a);
    wsc_close(b);
    want wa0 = {a, 0, 0, 0, 1, -1}, wb0 = {b, 0, 0, 0, 1, -1};
    wsc_run(ctx, 3000, enough, &wa0);
    wsc_run(ctx, 3000, enough, &wb0);
    snprintf(text, sizeof text,
             "model = %s/model.msm\nsource = \"replay:%s/trot.csv?loop=1\"\nlisten = 127.0.0.1:0\n"
             "token = open-sesame\nencoding = int16\n", H.dir, H.dir);
    write_file(conf, text);
    snprintf(H.token, sizeof H.token, "open-sesame"); /* /metrics answers it once reloaded */
    kill(H.pid, SIGHUP);
    for (int t = 0; t < 500 && harness_metric(&H, "meshsteer_reloads_total") < 1; t++)
        usleep(10000);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_total"), 1);
    wsc *newtok = wsc_connect(ctx, H.port, "token=open-sesame", 0);
    run_until(ctx, newtok, 3, 0, 10000);
    wsc *oldtok = wsc_connect(ctx, H.port, "token=sesame", 0);
    want wo = {oldtok, 0, 0, 0, 1, -1};
    ASSERT(wsc_run(ctx, 5000, enough, &wo));
    ASSERT(!oldtok->connected);
    write_file(conf, "model = m.msm\nmax_clients = lots\n");
    kill(H.pid, SIGHUP);
    for (int t = 0; t < 500 && harness_metric(&H, "meshsteer_reloads_total") < 2; t++)
        usleep(10000);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_total"), 2); /* the model reloads still */
    wsc *again = wsc_connect(ctx, H.port, "token=open-sesame", 0);
    run_until(ctx, again, 3, 0, 10000);
    printf("config: SIGHUP took the file's new token; a broken file left the settings as they were\n");
    H.token[0] = '\0';
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(a);
    wsc_free(b);
    wsc_free(newtok);
    wsc_free(oldtok);
    wsc_free(again);

    /* flags override: a file without model is completed by --model */
    char partial[1200], tmp[1300];
    snprintf(partial, sizeof partial, "%s/partial.conf", H.dir);
    snprintf(tmp, sizeof tmp, "source = replay:%s/trot.csv\n", H.dir);
    write_file(partial, tmp);
    const char *with_flag[] = {"-c", partial, "--model", "x.msm", NULL};
    ASSERT_INT_EQ(check_config(with_flag, out, sizeof out), 0);
    const char *without[] = {"-c", partial, NULL};
    ASSERT_INT_EQ(check_config(without, out, sizeof out), 2);
    ASSERT(strstr(out, "no model"));

    /* errors name the file and the line */
    expect_config_error("bad_number.conf", "model = m.msm\n\nmax_clients = lots\n", NULL,
                        "bad_number.conf:3: max_clients: 'lots' is not a whole number");
    expect_config_error("unknown.conf", "model = m.msm\nsource = replay:x.csv\ncolour = blue\n",
                        NULL, "unknown.conf:3: unknown key 'colour'");
    expect_config_error("twice.conf", "# twice\nlisten = 1\nlisten = 2\n", NULL,
                        "twice.conf:3: 'listen' set twice (first on line 2)");
    expect_config_error("no_equals.conf", "model m.msm\n", NULL,
                        "no_equals.conf:1: expected 'key = value'");
    expect_config_error("quote.conf", "model = m.msm\ntoken = \"abc\n", NULL,
                        "quote.conf:2: unbalanced quote");
    expect_config_error("range.conf", "model = m.msm\nsource = replay:x.csv\nidle_timeout = 0\n",
                        NULL, "range.conf:3: idle_timeout: 0 outside [1, 86400]");
    expect_config_error("origin.conf", "origin = ftp://x\n", NULL,
                        "origin.conf:1: origin: 'ftp://x' is not any, same or an http(s):// origin");
    /* a bad flag on a good file names the flag */
    const char *bad_flag[] = {"--max-clients", "0", NULL};
    expect_config_error("good.conf", "model = m.msm\nsource = replay:x.csv\n", bad_flag,
                        "--max_clients: max_clients: 0 outside [1, 10000]");
    /* a missing file */
    char missing[1200];
    snprintf(missing, sizeof missing, "%s/absent.conf", H.dir);
    const char *absent[] = {"-c", missing, NULL};
    ASSERT_INT_EQ(check_config(absent, out, sizeof out), 2);
    ASSERT(strstr(out, "absent.conf: No such file"));
}

/* ------------------------------------------------------------------ labels */

/* dir/cam.csv: trot.csv with every marker column renamed cam_<name>_<axis>; the map
 * "<source>=cam_<source>,..." of the model's markers (plus an entry the model does not use). */
static void write_renamed(char *map, size_t cap)
{
    char from[1200], to[1200], line[8192], model[1200], err[MDL_ERR_LEN];
    snprintf(from, sizeof from, "%s/trot.csv", H.dir);
    snprintf(to, sizeof to, "%s/cam.csv", H.dir);
    FILE *in = fopen(from, "r"), *out = fopen(to, "w");
    ASSERT(in && out);
    ASSERT(fgets(line, sizeof line, in));
    int col = 0;
    for (char *save = NULL, *t = strtok_r(line, ",\n", &save); t; t = strtok_r(NULL, ",\n", &save))
    {
        fprintf(out, "%s%s%s", col ? "," : "", col >= 2 ? "cam_" : "", t);
        col++;
    }
    fputc('\n', out);
    ASSERT(col > 2);
    size_t n;
    char buf[65536];
    while ((n = fread(buf, 1, sizeof buf, in)) > 0)
        ASSERT(fwrite(buf, 1, n, out) == n);
    fclose(in);
    ASSERT(fclose(out) == 0);

    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    mdl_model *m;
    ASSERT_OK(mdl_model_load(model, &m, err), err);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    size_t at = (size_t)snprintf(map, cap, "nosuch=cam_x");
    for (int i = 0; i < info.nmarkers; i++) {
        int dup = 0;
        for (int j = 0; j < i; j++)
            dup |= !strcmp(info.markers[j].source, info.markers[i].source);
        if (!dup)
            at += (size_t)snprintf(map + at, cap - at, ",%s=cam_%s", info.markers[i].source,
                                   info.markers[i].source);
        ASSERT(at < cap);
    }
    mdl_model_destroy(m);
}

/* Checks the hello's markers: each bound one's live label is prefix + its source label; each
 * unbound one is allowed only when !all_bound and must name a label the source lacks. Returns the
 * number of unbound markers. */
static int expect_live_labels(const char *hello, const char *prefix, int all_bound)
{
    cJSON *h = cJSON_Parse(hello);
    ASSERT(h);
    const cJSON *mk = cJSON_GetObjectItem(h, "markers");
    ASSERT(cJSON_GetArraySize(mk) > 0);
    int unbound = 0;
    for (const cJSON *m = mk->child; m; m = m->next) {
        const cJSON *src = cJSON_GetObjectItem(m, "source"), *live = cJSON_GetObjectItem(m, "live"),
                    *bound = cJSON_GetObjectItem(m, "bound");
        ASSERT(cJSON_IsString(src) && cJSON_IsString(live) && cJSON_IsBool(bound));
        char want[300];
        snprintf(want, sizeof want, "%s%s", prefix, src->valuestring);
        if (cJSON_IsTrue(bound)) {
            expect_str(live->valuestring, want);
        } else {
            ASSERT(!all_bound);
            ASSERT(strcmp(live->valuestring, want) != 0);
            unbound++;
        }
    }
    cJSON_Delete(h);
    return unbound;
}

static void scenario_labels(void)
{
    char map[2048], model[1200], source[1200], log[1200], out[4096];
    write_renamed(map, sizeof map);
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/cam.csv?loop=1", H.dir);

    /* without a map nothing binds: the daemon refuses to start and points to --labels */
    const char *plain[] = {meshsteerd, "--model", model, "--source", source, "--listen",
                           "127.0.0.1:0", NULL};
    snprintf(log, sizeof log, "%s/plain.log", H.dir);
    ASSERT_INT_EQ(harness_run(plain, log), 1);
    FILE *f = fopen(log, "r");
    ASSERT(f);
    size_t got = fread(out, 1, sizeof out - 1, f);
    out[got] = '\0';
    fclose(f);
    if (!strstr(out, "none of its") || !strstr(out, "--labels")) {
        fprintf(stderr, "expected the unbound error to mention --labels: %s\n", out);
        exit(1);
    }
    printf("labels: without a map the renamed source is refused with a hint to --labels\n");

    /* a bad map is a usage error naming the entry */
    const char *bad[] = {"--model", model, "--source", source, "--labels", "a=b,c", NULL};
    ASSERT_INT_EQ(check_config(bad, out, sizeof out), 2);
    ASSERT(strstr(out, "entry 2 'c': expected MODEL=LABEL"));

    /* with the map: streams, warns about the unused entry, keeps the map over SIGHUP */
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--labels", map, NULL};
    harness_start(&H, meshsteerd, args);
    char *body = NULL;
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200);
    free(body);
    ASSERT(harness_log_has(&H, "label map entry 1 'nosuch=cam_x': no marker of the model"));
    ASSERT(!harness_log_has(&H, "count as missing"));
    struct lws_context *ctx = wsc_context();
    wsc *a = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, a, 10, 0, 15000);
    /* the hello names the live label each marker is bound to: cam_<its own label> */
    expect_live_labels(a->hello, "cam_", 1);
    kill(H.pid, SIGHUP);
    want wh = {a, 0, 0, 2, 0, -1};
    ASSERT(wsc_run(ctx, 20000, enough, &wh));
    run_until(ctx, a, a->total_frames + 5, 0, 5000);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_reloads_total"), 1);
    expect_live_labels(a->hello, "cam_", 1); /* the reloaded generation's hello */
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(a);
    printf("labels: --labels binds the renamed source (the hello names the live labels); the map "
           "holds over a SIGHUP reload\n");

    /* a map that leaves one label unbound: its marker says so and names the label it looked for */
    char partial[2048];
    snprintf(partial, sizeof partial, "%s", map);
    char *last = strrchr(partial, '=');
    ASSERT(last);
    char missing_label[256];
    snprintf(missing_label, sizeof missing_label, "gone_%s", last + 1);
    snprintf(last + 1, sizeof partial - (size_t)(last + 1 - partial), "%s", missing_label);
    const char *pargs[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                           "--labels", partial, NULL};
    harness_start(&H, meshsteerd, pargs);
    ctx = wsc_context();
    a = wsc_connect(ctx, H.port, NULL, 0);
    want wp = {a, 0, 0, 1, 0, -1}; /* the hello (frames may wait for the unbound marker) */
    ASSERT(wsc_run(ctx, 15000, enough, &wp));
    int unbound = expect_live_labels(a->hello, "cam_", 0);
    ASSERT(unbound >= 1);
    ASSERT(strstr(a->hello, missing_label));
    ASSERT(harness_log_has(&H, "count as missing"));
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(a);
    printf("labels: %d marker(s) left unbound by the map are reported with bound=false and the "
           "label looked for\n", unbound);

    /* the same map from the config file */
    char conf[1200], ctext[8192];
    snprintf(conf, sizeof conf, "%s/labels.conf", H.dir);
    snprintf(ctext, sizeof ctext, "model = %s\nsource = %s\nlisten = 127.0.0.1:0\nlabels = %s\n",
             model, source, map);
    write_file(conf, ctext);
    const char *cargs[] = {"-c", conf, NULL};
    harness_start(&H, meshsteerd, cargs);
    ctx = wsc_context();
    a = wsc_connect(ctx, H.port, NULL, 0);
    run_until(ctx, a, 10, 0, 15000);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(a);
    expect_config_error("labels_bad.conf", "model = m.msm\nsource = replay:x.csv\nlabels = Hips=torso,Hips=head\n",
                        NULL, "labels_bad.conf:3: labels: entry 2 'Hips=head': model label 'Hips' is "
                              "already mapped by entry 1");
    printf("labels: 'labels =' in the config file works the same\n");
}

/* ------------------------------------------------------------------ horse (real data) */

static int run_cli(const char *const *argv)
{
    char log[1200];
    snprintf(log, sizeof log, "%s/cli.log", H.dir);
    int st = harness_run(argv, log);
    if (st) {
        fprintf(stderr, "%s %s failed with status %d; its output is in %s\n", argv[0], argv[1],
                st, log);
        exit(1);
    }
    return st;
}

static void scenario_horse(const char *meshsteer)
{
    const char *mesh = test_data("meshes/horse-gallop");
    const char *rig = test_src("rigs/horse.json");
    char model[1200], csv[1200], source[1300];
    snprintf(model, sizeof model, "%s/horse.msm", H.dir);
    snprintf(csv, sizeof csv, "%s/horse.csv", H.dir);
    const char *train[] = {meshsteer, "train", "--mesh", mesh, "--rig", rig, "--frames", "0:24:2",
                           "-o", model, NULL};
    const char *markers[] = {meshsteer, "markers", "--mesh", mesh, "--rig", rig, "--fps", "60",
                             "-o", csv, NULL};
    uint64_t t0 = wsc_now_us();
    run_cli(train);
    run_cli(markers);
    printf("horse: trained and exported markers in %.1f s\n", (double)(wsc_now_us() - t0) * 1e-6);

    snprintf(source, sizeof source, "replay:%s?loop=1", csv);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0", "-v",
                          NULL};
    harness_start(&H, meshsteerd, args);
    struct lws_context *ctx = wsc_context();
    ASSERT(ctx);
    wsc *A = wsc_connect(ctx, H.port, NULL, 1);
    wsc *B = wsc_connect(ctx, H.port, NULL, 1);
    wsc *C = wsc_connect(ctx, H.port, NULL, 1);
    wsc_send(B, "{\"type\":\"encoding\",\"encoding\":\"int16\"}");
    wsc_send(C, "{\"type\":\"encoding\",\"encoding\":\"params\"}");
    run_until(ctx, A, 120, 0, 20000);
    want wb = {B, 120, 0, 0, 0, 1}, wc = {C, 120, 0, 0, 0, 2};
    ASSERT(wsc_run(ctx, 20000, enough, &wb));
    ASSERT(wsc_run(ctx, 20000, enough, &wc));
    ASSERT_INT_EQ(C->protocol_errors, 0);
    ASSERT_INT_EQ(A->protocol_errors, 0);
    ASSERT_INT_EQ(B->protocol_errors, 0);

    /* the hello: the horse, 8 markers, all bound; the source at 60 Hz */
    char err[MDL_ERR_LEN];
    mdl_meshseq *gt = NULL;
    mdl_markers *mk = NULL;
    ASSERT_OK(mdl_meshseq_read(mesh, NULL, &gt, err), err);
    ASSERT_OK(mdl_markers_read(csv, NULL, &mk, err), err);
    ASSERT_INT_EQ(gt->nv, 8431);
    cJSON *h = cJSON_Parse(A->hello);
    ASSERT(h);
    ASSERT_INT_EQ(cJSON_GetObjectItem(h, "protocol")->valueint, 1);
    const cJSON *m = cJSON_GetObjectItem(h, "model");
    ASSERT_INT_EQ(cJSON_GetObjectItem(m, "vertices")->valueint, 8431);
    ASSERT_INT_EQ(cJSON_GetObjectItem(m, "faces")->valueint, gt->nf);
    ASSERT(cJSON_GetObjectItem(m, "parts")->valueint > 1);
    ASSERT_NEAR(cJSON_GetObjectItem(cJSON_GetObjectItem(h, "source"), "fps")->valuedouble, 60, 1e-3);
    const cJSON *hm = cJSON_GetObjectItem(h, "markers");
    ASSERT_INT_EQ(cJSON_GetArraySize(hm), 8);
    int col[8]; /* model marker -> CSV column */
    for (int i = 0; i < 8; i++) {
        const cJSON *o = cJSON_GetArrayItem(hm, i);
        ASSERT(cJSON_IsTrue(cJSON_GetObjectItem(o, "bound")));
        const char *src = cJSON_GetObjectItem(o, "source")->valuestring;
        col[i] = -1;
        for (int j = 0; j < mk->count; j++)
            if (!strcmp(mk->names[j], src))
                col[i] = j;
        ASSERT(col[i] >= 0);
    }
    cJSON_Delete(h);

    /* the topology: the horse's faces and rest pose */
    ASSERT_INT_EQ(A->nv, 8431);
    ASSERT_INT_EQ(A->nf, gt->nf);
    ASSERT_INT_EQ(A->nm, 8);
    const unsigned char *fa = A->topo + 56 + (size_t)A->nv * 12;
    for (int i = 0; i < A->nf * 3; i++) {
        uint32_t f = (uint32_t)fa[4 * i] | (uint32_t)fa[4 * i + 1] << 8 |
                     (uint32_t)fa[4 * i + 2] << 16 | (uint32_t)fa[4 * i + 3] << 24;
        ASSERT_INT_EQ(f, gt->F[i]);
    }

    /* frames: increasing sequence, plausible stamps, 60 Hz */
    for (int i = 0; i < A->nframes; i++) {
        const wsc_frame *f = &A->frames[i];
        ASSERT_INT_EQ(f->encoding, 0);
        if (i > 0) {
            ASSERT(f->seq > A->frames[i - 1].seq);
            ASSERT(f->t_capture > A->frames[i - 1].t_capture);
        }
        ASSERT(f->t_capture <= f->t_synth && f->t_synth <= f->t_send && f->t_send <= f->t_recv);
        ASSERT_NEAR_I((double)(f->t_recv - f->t_capture), 0, latency_bound_us(), i);
    }
    const wsc_frame *first = &A->frames[0], *last = &A->frames[A->nframes - 1];
    double span = (double)(last->t_capture - first->t_capture) * 1e-6;
    double rate = (double)(last->seq - first->seq) / span;
    printf("horse: %d frames at %.1f Hz (source 60 Hz), %d vertices, %d faces\n", A->nframes, rate,
           A->nv, A->nf);
    ASSERT_RATE(rate, 60, 6);

    /* each frame against the ground truth of the marker frame it came from (found by its
     * markers, which the daemon passes through unchanged) */
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (int i = 0; i < gt->nv * 3; i++) {
        lo[i % 3] = gt->V[i] < lo[i % 3] ? gt->V[i] : lo[i % 3];
        hi[i % 3] = gt->V[i] > hi[i % 3] ? gt->V[i] : hi[i % 3];
    }
    double diag = sqrt((double)(hi[0] - lo[0]) * (hi[0] - lo[0]) +
                       (double)(hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (double)(hi[2] - lo[2]) * (hi[2] - lo[2]));
    double worst_mean = 0, sum_mean = 0;
    int checked = 0, seen[64] = {0};
    for (int i = 0; i < A->nframes; i++) {
        const wsc_frame *f = &A->frames[i];
        int best = -1;
        double bestd = 1e30;
        for (int k = 0; k < mk->frames; k++) {
            double dd = 0;
            for (int j = 0; j < 8; j++)
                for (int a = 0; a < 3; a++) {
                    double e = (double)f->M[j * 3 + a] -
                               (double)mk->P[((size_t)k * (size_t)mk->count + (size_t)col[j]) * 3 + (size_t)a];
                    dd += e * e;
                }
            if (dd < bestd) {
                bestd = dd;
                best = k;
            }
        }
        ASSERT_NEAR_I(sqrt(bestd), 0, 1e-6, i); /* the markers are a row of the CSV, exactly */
        ASSERT(best < gt->frames && best < 64);
        seen[best] = 1;
        double mean = 0;
        const float *g = gt->V + (size_t)best * (size_t)gt->nv * 3;
        for (int v = 0; v < gt->nv; v++) {
            double dx = f->V[v * 3] - g[v * 3], dy = f->V[v * 3 + 1] - g[v * 3 + 1],
                   dz = f->V[v * 3 + 2] - g[v * 3 + 2];
            mean += sqrt(dx * dx + dy * dy + dz * dz);
        }
        mean /= gt->nv;
        worst_mean = mean > worst_mean ? mean : worst_mean;
        sum_mean += mean;
        checked++;
    }
    int distinct = 0;
    for (int k = 0; k < 64; k++)
        distinct += seen[k];
    printf("horse: %d frames against ground truth (%d distinct poses of %d): mean vertex error "
           "%.2f%% of the bounding-box diagonal on average, %.2f%% in the worst frame\n",
           checked, distinct, gt->frames, 100 * sum_mean / checked / diag, 100 * worst_mean / diag);
    ASSERT(distinct >= 24);                   /* most of the gallop went by */
    ASSERT(worst_mean < 0.03 * diag);         /* every frame is the right pose of the horse */

    /* both encodings decode to the same mesh within the stated bound */
    double worst = 0;
    int compared = compare_encodings(A, B, &worst);
    printf("horse: encodings agree on %d frames, worst error %.3f of the bound\n", compared, worst);
    ASSERT(compared >= 60);
    /* the params encoding too (docs/PROTOCOL.md 2b), at a twentieth of int16's bytes at most */
    worst = 0;
    compared = compare_encodings_as(A, C, 2, &worst);
    size_t b16 = frame_bytes(B, 1, 0), bp = frame_bytes(C, 2, C->params->layout[0].nparams);
    printf("horse: params frames agree with float32 on %d frames, worst error %.3f of the int16 "
           "bound; %zu bytes per frame against int16's %zu (%.1fx); params model %zu bytes\n",
           compared, worst, bp, b16, (double)b16 / bp, C->params_len);
    ASSERT(compared >= 60);
    ASSERT(bp * 20 <= b16);

    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_drops_total{reason=\"synth_failed\"}"), 0);
    ASSERT_INT_EQ(harness_metric(&H, "meshsteer_partial_writes_total"), 0);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(A);
    wsc_free(B);
    wsc_free(C);
    mdl_meshseq_destroy(gt);
    mdl_markers_destroy(mk);
}

/* ------------------------------------------------------------------ invalid */

/* The harmonic kind fed by a skeleton file (issue 9): the static human built with --fit-rest from
 * 131_03.bvh, streamed from replay:131_03.bvh; the pipeline hands the file's joint rotations to the
 * synthesis (its log says so) and finite frames come; with joints=0 the same model turns its bones
 * by the markers alone. Skips without ../shared/data. */
static void scenario_human(const char *meshsteer)
{
    const char *mesh = test_data("meshes/static-human/human_man.obj");
    const char *bvh = test_data("mocap/bvh/cmu/131_03.bvh");
    const char *rig = test_src("rigs/human-cmu-harmonic.json");
    char model[1200], source[1300];
    snprintf(model, sizeof model, "%s/human.msm", H.dir);
    const char *train[] = {meshsteer, "train", "--kind", "harmonic", "--mesh", mesh, "--rig", rig,
                           "--template", bvh, "--fit-rest", "-o", model, NULL};
    run_cli(train);
    for (int joints = 1; joints >= 0; joints--) {
        snprintf(source, sizeof source, "replay:%s?loop=1&joints=%d", bvh, joints);
        const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0", NULL};
        harness_start(&H, meshsteerd, args);
        struct lws_context *ctx = wsc_context();
        ASSERT(ctx);
        wsc *A = wsc_connect(ctx, H.port, NULL, 1);
        run_until(ctx, A, 30, 0, 20000);
        ASSERT_INT_EQ(A->protocol_errors, 0);
        ASSERT_INT_EQ(A->nv, 6890);
        int bad = 0;
        for (int f = 0; f < A->nframes; f++)
            for (int i = 0; A->frames[f].V && i < 3 * A->nv; i++)
                bad += !isfinite(A->frames[f].V[i]);
        ASSERT_INT_EQ(bad, 0);
        ASSERT(harness_log_has(&H, joints ? "turn with the source's joint rotations"
                                          : "the source gives no joint rotations"));
        printf("human: joints=%d: %d frames, the log says %s\n", joints, A->nframes,
               joints ? "the bones turn with the joints" : "markers alone");
        ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
        lws_context_destroy(ctx);
        wsc_free(A);
    }
}

static void scenario_invalid(void)
{
    const char *c3d = test_data("mocap/c3d/c3d.org/sample16/basketball.c3d");
    char model[1200], source[1300];
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s?loop=1", c3d);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--labels", "lf_foot=2000,rf_foot=2001,lh_foot=2002,rh_foot=2003,"
                          "head=2004,tail=2005,withers=2006,croup=2007", "-v", NULL};
    harness_start(&H, meshsteerd, args);
    struct lws_context *ctx = wsc_context();
    ASSERT(ctx);
    wsc *A = wsc_connect(ctx, H.port, NULL, 1);
    wsc *Q = wsc_connect(ctx, H.port, NULL, 1); /* a params client */
    wsc_send(Q, "{\"type\":\"encoding\",\"encoding\":\"params\"}");
    run_until(ctx, A, 25, 0, 5000); /* 25 fps: a second of frames */
    ASSERT_INT_EQ(A->protocol_errors, 0);
    const float *rest = (const float *)(A->topo + 56);
    /* synthesis never made a frame, so there are no parameters: the params client gets the
     * rest pose as int16 frames (docs/PROTOCOL.md 3), after its params model */
    want wq = {Q, 10, 0, 0, 0, 1};
    ASSERT(wsc_run(ctx, 5000, enough, &wq));
    ASSERT_INT_EQ(Q->protocol_errors, 0);
    ASSERT_INT_EQ(Q->params_msgs, 1);
    for (int i = 0; i < Q->nframes; i++) {
        ASSERT_INT_NE(Q->frames[i].encoding, 2);
        for (int k = 0; Q->frames[i].encoding == 1 && k < Q->nv * 3; k++)
            ASSERT_NEAR_I(Q->frames[i].V[k], rest[k], (Q->qmax[k % 3] - Q->qmin[k % 3]) / 131070.0 + 1e-6, k);
    }
    for (int i = 0; i < A->nframes; i++) {
        ASSERT(A->frames[i].flags & 1); /* reference lost */
        for (int k = 0; k < A->nv * 3; k++)
            ASSERT_NEAR_I(A->frames[i].V[k], rest[k], 1e-6, k);
    }
    char *body;
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200);
    cJSON *hz = cJSON_Parse(body);
    ASSERT(hz);
    const char *status = cJSON_GetObjectItem(hz, "status")->valuestring;
    const cJSON *reason = cJSON_GetObjectItem(hz, "reason");
    printf("invalid: %d frames, /healthz %s: %s\n", A->nframes, status,
           cJSON_IsString(reason) ? reason->valuestring : "(no reason)");
    expect_str(status, "degraded");
    ASSERT(cJSON_IsString(reason) && strstr(reason->valuestring, "reference markers"));
    cJSON_Delete(hz);
    free(body);
    ASSERT(harness_metric(&H, "meshsteer_drops_total{reason=\"synth_failed\"}") >= 25);
    ASSERT(harness_log_has(&H, "3 frames in a row: synthesis refuses every frame"));
    ASSERT(!harness_log_has(&H, "4 frames in a row")); /* not per frame */
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    lws_context_destroy(ctx);
    wsc_free(A);
    wsc_free(Q);
}

/* ------------------------------------------------------------------ http */

/* A raw /stream connection, upgraded (the 101 read); returns the socket. */
static int raw_stream(void)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)H.port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT(connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0);
    char req[512];
    int n = snprintf(req, sizeof req,
                     "GET /stream HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\n"
                     "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                     "Sec-WebSocket-Version: 13\r\n\r\n", H.port);
    ASSERT(write(fd, req, (size_t)n) == n);
    char resp[2048];
    size_t got = 0; /* byte by byte up to the blank line: the frames follow it */
    while (got < sizeof resp - 1 && (got < 4 || memcmp(resp + got - 4, "\r\n\r\n", 4)))
        ASSERT(read(fd, resp + got++, 1) == 1);
    resp[got] = '\0';
    ASSERT(!strncmp(resp, "HTTP/1.1 101", 12));
    return fd;
}

/* Seconds until the daemon closes fd: a close frame (the server's frames are unmasked: opcode,
 * 7/16/64-bit length, payload; its status code into *code when given, else -1) or the end of the
 * stream; at most 5. With `text`, returns as soon as a text frame containing it arrives (*code
 * 0). */
static double seconds_to_close_or(int fd, const char *text, int *code)
{
    struct timeval tv = {0, 200000};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    uint64_t t0 = wsc_now_us();
    size_t cap = 1 << 20, len = 0, at = 0; /* at: the next frame's header */
    unsigned char *b = malloc(cap);
    ASSERT(b);
    /* what followed the text frame a previous call returned at, on the same connection */
    static unsigned char *rest;
    static size_t rest_len;
    static int rest_fd = -1;
    if (rest_fd == fd && rest_len <= cap) {
        memcpy(b, rest, rest_len);
        len = rest_len;
    }
    free(rest);
    rest = NULL;
    rest_len = 0;
    rest_fd = -1;
    while (wsc_now_us() - t0 < 5000000) {
        for (;;) { /* the complete frames so far */
            size_t avail = len - at;
            if (avail < 2)
                break;
            unsigned l7 = b[at + 1] & 0x7f;
            size_t h = l7 == 126 ? 4 : l7 == 127 ? 10 : 2;
            if (avail < h)
                break;
            uint64_t n = l7;
            if (l7 == 126)
                n = (uint64_t)b[at + 2] << 8 | b[at + 3];
            else if (l7 == 127)
                for (int i = (int)(n = 0); i < 8; i++)
                    n = n << 8 | b[at + 2 + (size_t)i];
            if ((b[at] & 0x0f) == 8) {
                if (code)
                    *code = n >= 2 && avail >= h + 2 ? b[at + h] << 8 | b[at + h + 1] : -1;
                free(b);
                return (double)(wsc_now_us() - t0) * 1e-6;
            }
            if (avail < h + n)
                break;
            if (text && (b[at] & 0x0f) == 1 && memmem(b + at + h, (size_t)n, text, strlen(text))) {
                if (code)
                    *code = 0;
                rest_len = len - (at + h + (size_t)n);
                rest = malloc(rest_len + 1);
                ASSERT(rest);
                memcpy(rest, b + at + h + n, rest_len);
                rest_fd = fd;
                free(b);
                return (double)(wsc_now_us() - t0) * 1e-6;
            }
            at += h + (size_t)n;
        }
        if (len == cap) { /* keep only the unfinished frame */
            memmove(b, b + at, len - at);
            len -= at;
            at = 0;
        }
        ssize_t r = read(fd, b + len, cap - len);
        if (r == 0 || (r < 0 && errno != EAGAIN && errno != EWOULDBLOCK))
            break;
        if (r > 0)
            len += (size_t)r;
    }
    if (code)
        *code = -1;
    free(b);
    return (double)(wsc_now_us() - t0) * 1e-6;
}

static double seconds_to_close(int fd)
{
    return seconds_to_close_or(fd, NULL, NULL);
}

/* A client frame of opcode op (masked with a fixed key, or not) into fd. */
static void send_frame(int fd, int op, const char *payload, int masked)
{
    unsigned char f[256];
    size_t n = strlen(payload), h = 0;
    ASSERT(n < 126);
    f[h++] = (unsigned char)(0x80 | op);
    f[h++] = (unsigned char)((masked ? 0x80 : 0) | n);
    static const unsigned char key[4] = {0x37, 0xfa, 0x21, 0x3d};
    if (masked)
        for (int i = 0; i < 4; i++)
            f[h++] = key[i];
    for (size_t i = 0; i < n; i++)
        f[h + i] = (unsigned char)(payload[i] ^ (masked ? key[i % 4] : 0));
    ASSERT(write(fd, f, h + n) == (ssize_t)(h + n));
}

static void scenario_http(void)
{
    start_default(NULL, NULL);
    char *a;
    const char head[] = "HEAD /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
    ASSERT_INT_EQ(harness_raw(&H, head, sizeof head - 1, &a), 200);
    const char *sep = strstr(a, "\r\n\r\n");
    ASSERT(sep && sep[4] == '\0'); /* no body */
    ASSERT(strstr(a, "content-length: ") && atoi(strstr(a, "content-length: ") + 16) > 100);
    free(a);
    const char post[] = "POST /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 0\r\n"
                        "Connection: close\r\n\r\n";
    ASSERT_INT_EQ(harness_raw(&H, post, sizeof post - 1, &a), 405);
    ASSERT(strstr(a, "allow: GET, HEAD"));
    free(a);
    for (int n = 300; n <= 1000; n += 700) {
        char req[1200];
        int len = snprintf(req, sizeof req, "GET /%0*d HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                           "Connection: close\r\n\r\n", n, 7);
        int st = harness_raw(&H, req, (size_t)len, &a);
        printf("http: GET of a %d-character URI: %d\n", n + 1, st);
        ASSERT_INT_EQ(st, 414);
        free(a);
    }
    /* a 5,000-character query: 414 (it was a silent close) */
    {
        static char req[6000];
        int len = snprintf(req, sizeof req, "GET /healthz?q=%05000d HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                           "Connection: close\r\n\r\n", 7);
        int st = harness_raw(&H, req, (size_t)len, &a);
        printf("http: GET with a 5,000-character query: %d\n", st);
        ASSERT_INT_EQ(st, 414);
        free(a);
    }
    /* request headers beyond 8 KiB: 431 (lws closed them unanswered); under it, 200 */
    {
        static const char *const shapes[] = {"X-Big", "Cookie", "300", "under"};
        size_t cap = 120 * 1024;
        char *req = malloc(cap);
        ASSERT(req);
        for (int k = 0; k < 4; k++) {
            int len = snprintf(req, cap, "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                               "Connection: close\r\n");
            if (k < 2) { /* one header of 100 KB: unknown to lws, then one it knows */
                len += snprintf(req + len, cap - (size_t)len, "%s: ", shapes[k]);
                memset(req + len, 'a', 100000);
                len += 100000;
                len += snprintf(req + len, cap - (size_t)len, "\r\n");
            } else { /* 300 headers of 40 bytes; 150 of 20 bytes stay under the limit */
                for (int i = 0; i < (k == 2 ? 300 : 150); i++)
                    len += snprintf(req + len, cap - (size_t)len, "X-Header-%03d: %0*d\r\n", i,
                                    k == 2 ? 24 : 4, i);
            }
            len += snprintf(req + len, cap - (size_t)len, "\r\n");
            int st = harness_raw(&H, req, (size_t)len, &a);
            printf("http: request headers of %d bytes (%s): %d\n", len, shapes[k], st);
            ASSERT_INT_EQ(st, k < 3 ? 431 : 200);
            free(a);
        }
        free(req);
    }
    /* past lws's 128 KiB header buffer, 300 repeats of a header lws knows (3.3 KB, beyond its 95
     * fragments), and a /stream upgrade with 9 KiB of headers: 431 (lws closed the first two
     * unanswered; the upgrade was not checked); "%00" in the target: 400 (lws cut the path or
     * closed) */
    {
        size_t cap = 140 * 1024;
        char *req = malloc(cap);
        ASSERT(req);
        for (int k = 0; k < 3; k++) {
            int len = snprintf(req, cap, "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\n%s",
                               k == 2 ? "/stream" : "/healthz",
                               k == 2 ? "Upgrade: websocket\r\nConnection: Upgrade\r\n"
                                        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                                        "Sec-WebSocket-Version: 13\r\n"
                                      : "Connection: close\r\n");
            if (k == 1) {
                for (int i = 0; i < 300; i++)
                    len += snprintf(req + len, cap - (size_t)len, "Accept: */*\r\n");
            } else {
                size_t pad = k == 0 ? 130 * 1024 : 9 * 1024;
                len += snprintf(req + len, cap - (size_t)len, "X-Pad: ");
                memset(req + len, 'a', pad);
                len += (int)pad;
                len += snprintf(req + len, cap - (size_t)len, "\r\n");
            }
            len += snprintf(req + len, cap - (size_t)len, "\r\n");
            int st = harness_raw(&H, req, (size_t)len, &a);
            static const char *const what[] = {"130 KiB of headers", "300 Accept headers",
                                               "a /stream upgrade with 9 KiB of headers"};
            printf("http: %s (%d bytes): %d\n", what[k], len, st);
            ASSERT_INT_EQ(st, 431);
            free(a);
        }
        free(req);
        static const char *const nul[] = {"/%00", "/healthz%00", "/a%00b", "/healthz?x=%00"};
        for (int k = 0; k < 4; k++) {
            char req2[256];
            int len = snprintf(req2, sizeof req2, "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                               "Connection: close\r\n\r\n", nul[k]);
            int st = harness_raw(&H, req2, (size_t)len, &a);
            printf("http: GET %s: %d\n", nul[k], st);
            ASSERT_INT_EQ(st, 400);
            free(a);
        }
    }
    /* one kept-alive connection, 20 requests of 1 KB headers one after the other: each is its own
     * size (20 KB in all is no reason for a 431) */
    {
        int fd = socket(AF_INET, SOCK_STREAM, 0);
        struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)H.port)};
        sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        struct timeval tv = {5, 0};
        setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        ASSERT(connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0);
        char req[1200], resp[8192];
        for (int i = 0; i < 20; i++) {
            int len = snprintf(req, sizeof req, "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                               "X-Pad: %01000d\r\n\r\n", i);
            ASSERT(write(fd, req, (size_t)len) == len);
            size_t got = 0; /* the headers, then Content-Length bytes of body */
            char *sep = NULL;
            while (!sep && got < sizeof resp - 1) {
                ssize_t r = read(fd, resp + got, sizeof resp - 1 - got);
                ASSERT(r > 0);
                got += (size_t)r;
                resp[got] = '\0';
                sep = strstr(resp, "\r\n\r\n");
            }
            ASSERT(sep && !strncmp(resp, "HTTP/1.1 200", 12));
            const char *cl = strstr(resp, "content-length: ");
            ASSERT(cl);
            size_t want = (size_t)(sep + 4 - resp) + (size_t)atoi(cl + 16);
            while (got < want) {
                ssize_t r = read(fd, resp + got, sizeof resp - 1 - got);
                ASSERT(r > 0);
                got += (size_t)r;
            }
            ASSERT(got == want);
        }
        close(fd);
        printf("http: 20 requests of 1 KB headers on one connection: 200 each\n");
    }
    /* a text frame whose header claims 2^40 bytes (masked, as a client's must be), then 16 of
     * them: closed at once (a close frame, 1009), beyond --max-message, not when the rest has
     * come (never, before) */
    int fd = raw_stream();
    unsigned char frame[2 + 8 + 4 + 16] = {0x81, 0x80 | 127, 0, 0, 1, 0, 0, 0, 0, 0, 1, 2, 3, 4};
    ASSERT(write(fd, frame, sizeof frame) == (ssize_t)sizeof frame);
    double dt = seconds_to_close(fd);
    close(fd);
    printf("http: a frame header claiming 2^40 bytes closed in %.3f s\n", dt);
    ASSERT(dt < 1.0);
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &a), 200); /* and still serving */
    free(a);
    /* a masked text frame is answered; an unmasked one closes the connection with 1002 (RFC 6455
     * Sec. 5.1: a server MUST close on it; lws 4.1 took it as if masked) */
    fd = raw_stream();
    int code = -2;
    send_frame(fd, 1, "{\"type\":\"ping\",\"id\":7}", 1);
    dt = seconds_to_close_or(fd, "pong", &code);
    printf("http: a masked ping answered in %.3f s (code %d)\n", dt, code);
    ASSERT_INT_EQ(code, 0);
    send_frame(fd, 1, "{\"type\":\"ping\",\"id\":8}", 0);
    dt = seconds_to_close_or(fd, "pong", &code);
    close(fd);
    printf("http: an unmasked text frame closed in %.3f s with %d\n", dt, code);
    ASSERT_INT_EQ(code, 1002);
    ASSERT(dt < 1.0);
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &a), 200); /* and still serving */
    free(a);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
    printf("http: HEAD answered, other methods 405, long URIs and queries 414, large headers 431, "
           "%%00 400, unmasked frames closed 1002\n");
}

/* ------------------------------------------------------------------ listen */

/* The local addresses (hex, as /proc/net/tcp prints them) of the LISTEN sockets on port in table
 * ("tcp" or "tcp6"), space-separated, into out. */
static void listening(const char *table, int port, char *out, size_t n)
{
    char path[64], line[512];
    snprintf(path, sizeof path, "/proc/net/%s", table);
    out[0] = '\0';
    FILE *f = fopen(path, "r");
    if (!f)
        return; /* no IPv6 in this kernel: nothing listens there */
    while (fgets(line, sizeof line, f)) {
        char local[128], remote[128], st[8];
        if (sscanf(line, " %*[0-9]: %127s %127s %7s", local, remote, st) != 3 || strcmp(st, "0A"))
            continue;
        char *colon = strrchr(local, ':');
        if (!colon || (int)strtol(colon + 1, NULL, 16) != port)
            continue;
        *colon = '\0';
        size_t len = strlen(out);
        snprintf(out + len, n - len, "%s%s", len ? " " : "", local);
    }
    fclose(f);
}

static void expect_listening(const char *listen, const char *want4, const char *want6)
{
    char model[1200], source[1200], got4[512], got6[512];
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(source, sizeof source, "replay:%s/trot.csv?loop=1", H.dir);
    const char *args[] = {"--model", model, "--source", source, "--listen", listen, NULL};
    harness_start(&H, meshsteerd, args);
    listening("tcp", H.port, got4, sizeof got4);
    listening("tcp6", H.port, got6, sizeof got6);
    printf("listen %s: port %d, tcp [%s], tcp6 [%s]\n", listen, H.port, got4, got6);
    expect_str(got4, want4);
    expect_str(got6, want6);
    if (*want4) { /* and it answers there */
        char *body;
        ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200);
        free(body);
    }
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 5000), 0);
}

static void scenario_listen(void)
{
    expect_listening("127.0.0.1:0", "0100007F", "");
    expect_listening("0", "0100007F", ""); /* the default address */
    /* IPv6 only where the machine has ::1 */
    int fd = socket(AF_INET6, SOCK_STREAM, 0);
    struct sockaddr_in6 sa = {.sin6_family = AF_INET6, .sin6_addr = IN6ADDR_LOOPBACK_INIT};
    int v6 = fd >= 0 && bind(fd, (struct sockaddr *)&sa, sizeof sa) == 0;
    if (fd >= 0)
        close(fd);
    if (v6)
        expect_listening("[::1]:0", "", "00000000000000000000000001000000");
    else
        printf("listen: no IPv6 loopback here, [::1] not tried\n");
}

static void kill_daemon(void)
{
    if (H.pid > 0 && kill(H.pid, 0) == 0)
        harness_stop(&H, SIGKILL, 1000);
}

int main(int argc, char **argv)
{
    sanitized = getenv("MESHSTEER_SANITIZED") && getenv("MESHSTEER_SANITIZED")[0] == '1';
    if (argc != 4 && argc != 5) {
        fprintf(stderr, "usage: test_daemon MESHSTEERD MAKE_MODEL "
                        "stream|slow|record|limits|origin|idle|kinds|kblend|config|labels|listen|invalid|"
                        "http|horse|human|params [MESHSTEER | MESHSTEER_LOAD]\n");
        return 2;
    }
    signal(SIGPIPE, SIG_IGN);
    meshsteerd = argv[1];
    if (!strcmp(argv[3], "horse") || !strcmp(argv[3], "human")) {
        if (argc != 5)
            return 2;
        /* skip before training anything */
        test_data(!strcmp(argv[3], "horse") ? "meshes/horse-gallop" : "meshes/static-human/human_man.obj");
        harness_dir(&H);
    } else {
        harness_fixtures(&H, argv[2]);
    }
    atexit(kill_daemon); /* a failed assertion must not leave the daemon running */
    if (!strcmp(argv[3], "stream"))
        scenario_stream();
    else if (!strcmp(argv[3], "slow"))
        scenario_slow();
    else if (!strcmp(argv[3], "record"))
        scenario_record();
    else if (!strcmp(argv[3], "limits"))
        scenario_limits();
    else if (!strcmp(argv[3], "origin"))
        scenario_origin();
    else if (!strcmp(argv[3], "idle"))
        scenario_idle();
    else if (!strcmp(argv[3], "kinds"))
        scenario_kinds();
    else if (!strcmp(argv[3], "fade"))
        scenario_fade();
    else if (!strcmp(argv[3], "kblend"))
        scenario_kblend();
    else if (!strcmp(argv[3], "params"))
        scenario_params(argc == 5 ? argv[4] : NULL);
    else if (!strcmp(argv[3], "config"))
        scenario_config();
    else if (!strcmp(argv[3], "labels"))
        scenario_labels();
    else if (!strcmp(argv[3], "invalid"))
        scenario_invalid();
    else if (!strcmp(argv[3], "http"))
        scenario_http();
    else if (!strcmp(argv[3], "listen"))
        scenario_listen();
    else if (!strcmp(argv[3], "horse"))
        scenario_horse(argv[4]);
    else if (!strcmp(argv[3], "human"))
        scenario_human(argv[4]);
    else
        return 2;
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", H.dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", H.dir);
    printf("ok\n");
    return 0;
}
