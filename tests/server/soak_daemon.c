/* soak_daemon.c - the daemon's soak test (issue 13, "Keep it so"): meshsteerd serving for a long
 * time under everything at once, watched for memory growth and for clients falling behind.
 *
 * The model is the built-in example's steering model with its skin beside it (make_model's
 * two-kinds.msm: the skin is the idle animation). The source is OSC on loopback, fed by this
 * program at 60 Hz (one bundle of /marker messages per frame, the example's trot markers) from a
 * thread of its own with an absolute clock. At the same time:
 *   - LIVE clients (meshsteer-load, int16) read every frame; -i 60 gives their rates per minute;
 *   - 4 stalled clients complete the handshake and never read; when the daemon has closed them
 *     for idleness (--idle-timeout, 30 s) four new ones take their place;
 *   - 2 noise clients (wsc, lws) send a control message every 100 ms, cycling through good ones
 *     (ping, encoding) and bad ones (pause/seek/speed, which a live source refuses as
 *     unsupported; out-of-range and mistyped fields; unknown types; not JSON; a binary message),
 *     and once per cycle one larger than --max-message, which closes that client (1009): it
 *     reconnects;
 *   - every 30 s a SIGHUP, alternately after a corrupt model (cut in half: the reload fails, the
 *     old model keeps serving) and a good one (the new generation is swapped in); every 5 s
 *     during the warm-up;
 *   - the source vanishes: the sender goes quiet for 3 s at 45 s and then every 300 s. After 1 s
 *     without frames (--idle-after 1) the daemon's idle animation takes over, and tracking resumes
 *     (with the default 0.5 s cross-fade) when the
 *     markers return (both are checked in its log).
 * Every minute one line: daemon RSS, the live clients' frames/s (slowest and mean) over that
 * minute, noise replies (pongs, acks, errors), reloads, stalled clients replaced, errors.
 *
 * PASS when the daemon's RSS at the end exceeds its RSS at the end of the warm-up by less than
 * 2 MB (warm-up: the first 300 s, or half of a shorter run: the first reloads and client
 * sessions grow glibc's arenas), every live client received at least 57 frames/s over the whole
 * measured time (from 5 s on, source absences included), no live client was disconnected, every
 * reload ended as expected, the noise clients got their replies and were closed only as asked,
 * and the daemon exits cleanly on SIGTERM.
 *
 * Usage: soak_daemon MESHSTEERD MAKE_MODEL MESHSTEER_LOAD SECONDS LIVE_CLIENTS [fifo]
 * With "fifo" this program, the daemon and meshsteer-load run under SCHED_FIFO priority 10 (they
 * inherit it; needs CAP_SYS_NICE, otherwise the run says so and goes on with default scheduling),
 * as bench_daemon's fifo does: on a machine that other work keeps busy, the frame rates are then
 * the daemon's and not the machine's. None of them spins: together they take a fraction of a core.
 * The documented run (meson test --benchmark daemon_soak_30min) is 1800 s with 64 live clients;
 * CI runs 120 s with 16 (tests/server/meson.build). */
#include "daemon_harness.h"
#include "model.h"
#include "test.h"
#include "wsclient.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <errno.h>
#include <libwebsockets.h>
#include <lo/lo.h>
#include <math.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define SOURCE_HZ 60
#define STALLED 4
#define NOISE 2
#define NOISE_EVERY_US 100000u
#define RELOAD_EVERY_S 30
#define WARM_RELOAD_EVERY_S 5
#define VANISH_FIRST_S 45
#define VANISH_EVERY_S 300
#define VANISH_FOR_S 3
#define LOAD_WARMUP_S 5
#define MAX_MESSAGE 4096
#define RSS_GROWTH_MAX_KB 2048
#define FPS_MIN 57.0

static harness H;

/* ------------------------------------------------------------------ the OSC sender */

typedef struct sender {
    const mdl_markers *mk;
    int port;
    uint64_t t0;            /* the run's start, wsc_now_us */
    atomic_int stop;
    atomic_int quiet;       /* 1 while the source is away */
    atomic_ullong bundles;  /* sent */
    atomic_int vanishes;    /* absences begun */
} sender;

static int quiet_at(double t)
{
    return t >= VANISH_FIRST_S && fmod(t - VANISH_FIRST_S, VANISH_EVERY_S) < VANISH_FOR_S;
}

static void *sender_main(void *arg)
{
    sender *s = arg;
    char ps[16];
    snprintf(ps, sizeof ps, "%d", s->port);
    lo_address to = lo_address_new("127.0.0.1", ps);
    struct timespec next;
    clock_gettime(CLOCK_MONOTONIC, &next);
    for (long k = 0; !atomic_load(&s->stop); k++) {
        double t = (double)(wsc_now_us() - s->t0) * 1e-6;
        int q = quiet_at(t);
        if (q && !atomic_exchange(&s->quiet, 1))
            atomic_fetch_add(&s->vanishes, 1);
        if (!q) {
            atomic_store(&s->quiet, 0);
            const mdl_markers *mk = s->mk;
            const float *P = mk->P + (size_t)(k % mk->frames) * (size_t)mk->count * 3;
            lo_bundle b = lo_bundle_new(LO_TT_IMMEDIATE);
            for (int i = 0; i < mk->count; i++) {
                lo_message m = lo_message_new();
                lo_message_add_string(m, mk->names[i]);
                lo_message_add_float(m, P[3 * i]);
                lo_message_add_float(m, P[3 * i + 1]);
                lo_message_add_float(m, P[3 * i + 2]);
                lo_bundle_add_message(b, "/marker", m);
            }
            if (lo_send_bundle(to, b) > 0)
                atomic_fetch_add(&s->bundles, 1);
            lo_bundle_free_recursive(b);
        }
        next.tv_nsec += 1000000000L / SOURCE_HZ;
        if (next.tv_nsec >= 1000000000L) {
            next.tv_nsec -= 1000000000L;
            next.tv_sec++;
        }
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
    }
    lo_address_free(to);
    return NULL;
}

/* A UDP port on loopback that is free now (the daemon binds it a moment later). */
static int free_udp_port(void)
{
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof sa;
    ASSERT(bind(fd, (struct sockaddr *)&sa, sizeof sa) == 0);
    ASSERT(getsockname(fd, (struct sockaddr *)&sa, &len) == 0);
    close(fd);
    return ntohs(sa.sin_port);
}

/* ------------------------------------------------------------------ the noise clients */

typedef struct noise_stats {
    long sent, pongs, acks, errors, too_big_closes, unexpected_closes, protocol_errors;
    long codes[8]; /* errors by code, in the order of codes[] below */
} noise_stats;

static const char *const error_codes[8] = {"malformed", "unknown_type", "bad_field", "unsupported",
                                           "source_error", "busy", "binary_not_accepted", "other"};

/* The cycle; NULL marks the binary message, "" the oversized one (last: it closes the client). */
static const char *const noise_msgs[] = {
    "{\"type\":\"ping\",\"id\":1}",
    "{\"type\":\"pause\"}",
    "{\"type\":\"resume\",\"id\":\"r\"}",
    "{\"type\":\"seek\",\"frame\":10}",
    "{\"type\":\"speed\",\"speed\":1e-300}",
    "{\"type\":\"speed\",\"speed\":\"fast\"}",
    "{\"type\":\"speed\",\"speed\":1}",
    "{\"type\":\"seek\",\"frame\":-1}",
    "{\"type\":\"encoding\",\"encoding\":\"float32\"}",
    "{\"type\":\"encoding\",\"encoding\":\"bogus\"}",
    "{\"type\":\"encoding\",\"encoding\":\"int16\"}",
    "{\"type\":\"nope\"}",
    "{\"type\":\"ping\",\"extra\":[1,2,{\"a\":null}]}",
    "not json at all",
    "{\"type\":\"ping\"",
    "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]",
    "{\"type\":\"ping\",\"id\":\"\xc3\xa9t\xc3\xa9\"}",
    "{\"type\":\"ping\",\"id\":1e999}",
    NULL,
    "{\"type\":\"ping\",\"id\":2}",
    "",
};
#define NOISE_MSGS (sizeof noise_msgs / sizeof noise_msgs[0])

typedef struct noise {
    wsc *c;
    size_t next;      /* index into noise_msgs */
    int asked_close;  /* the oversized message went out */
} noise;

static void noise_connect(struct lws_context *ctx, noise *n)
{
    n->c = wsc_connect(ctx, H.port, NULL, 0);
    n->next = 0;
    n->asked_close = 0;
}

static void noise_replies(noise *n, noise_stats *st)
{
    wsc *c = n->c;
    for (int i = 0; i < c->ntexts; i++) {
        cJSON *j = cJSON_Parse(c->texts[i]);
        const cJSON *type = j ? cJSON_GetObjectItem(j, "type") : NULL;
        const char *t = cJSON_IsString(type) ? type->valuestring : "";
        if (!strcmp(t, "pong")) {
            st->pongs++;
        } else if (!strcmp(t, "ack")) {
            st->acks++;
        } else if (!strcmp(t, "error")) {
            st->errors++;
            const cJSON *code = cJSON_GetObjectItem(j, "code");
            int k = 0;
            while (k < 7 && !(cJSON_IsString(code) && !strcmp(code->valuestring, error_codes[k])))
                k++;
            st->codes[k]++;
        } else {
            st->protocol_errors++;
            fprintf(stderr, "soak: unexpected reply: %s\n", c->texts[i]);
        }
        cJSON_Delete(j);
        free(c->texts[i]);
    }
    c->ntexts = 0;
    st->protocol_errors += c->protocol_errors;
    c->protocol_errors = 0;
}

static void noise_step(struct lws_context *ctx, noise *n, noise_stats *st, int send)
{
    noise_replies(n, st);
    if (n->c->closed) {
        if (n->asked_close && n->c->close_code == 1009) {
            st->too_big_closes++;
        } else {
            st->unexpected_closes++;
            fprintf(stderr, "soak: a noise client was closed (code %d, %s)\n", n->c->close_code,
                    n->c->error);
        }
        wsc_free(n->c);
        noise_connect(ctx, n);
        return;
    }
    if (!send || !n->c->connected || n->asked_close)
        return;
    const char *m = noise_msgs[n->next];
    if (!m) {
        static const unsigned char bin[8] = {1, 2, 3, 4, 5, 6, 7, 8};
        wsc_send_binary(n->c, bin, sizeof bin);
    } else if (!*m) {
        static char big[MAX_MESSAGE + 2];
        memset(big, ' ', sizeof big - 1);
        memcpy(big, "{\"type\":\"ping\"}", 15);
        wsc_send(n->c, big);
        n->asked_close = 1;
    } else {
        wsc_send(n->c, m);
    }
    st->sent++;
    n->next = (n->next + 1) % NOISE_MSGS;
}

/* ------------------------------------------------------------------ the run */

/* The last "-i" line meshsteer-load has printed so far: its interval number, or 0. */
static int last_interval(const char *path, double *fps_min, double *fps_mean, int *connected)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char line[512];
    int k = 0;
    while (fgets(line, sizeof line, f)) {
        cJSON *j = strstr(line, "\"interval\"") ? cJSON_Parse(line) : NULL;
        if (j) {
            k = cJSON_GetObjectItem(j, "interval")->valueint;
            *fps_min = cJSON_GetObjectItem(j, "fps_min")->valuedouble;
            *fps_mean = cJSON_GetObjectItem(j, "fps_mean")->valuedouble;
            *connected = cJSON_GetObjectItem(j, "connected")->valueint;
            cJSON_Delete(j);
        }
    }
    fclose(f);
    return k;
}

/* meshsteer-load's closing summary (the JSON object without "interval"). */
static cJSON *load_summary(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return NULL;
    char line[2048];
    cJSON *last = NULL;
    while (fgets(line, sizeof line, f))
        if (line[0] == '{' && !strstr(line, "\"interval\"")) {
            cJSON_Delete(last);
            last = cJSON_Parse(line);
        }
    fclose(f);
    return last;
}

static int daemon_alive(void)
{
    int st;
    if (waitpid(H.pid, &st, WNOHANG) != H.pid)
        return 1;
    fprintf(stderr, "soak: meshsteerd died (status %d); its log: %s\n", st, H.log);
    H.pid = -1;
    return 0;
}

static void kill_children(void)
{
    if (H.pid > 0 && kill(H.pid, 0) == 0)
        harness_stop(&H, SIGKILL, 1000);
}

int main(int argc, char **argv)
{
    if ((argc != 6 && argc != 7) || (argc == 7 && strcmp(argv[6], "fifo"))) {
        fprintf(stderr, "usage: soak_daemon MESHSTEERD MAKE_MODEL MESHSTEER_LOAD SECONDS "
                        "LIVE_CLIENTS [fifo]\n");
        return 2;
    }
    const char *meshsteerd = argv[1], *load = argv[3];
    double secs = atof(argv[4]);
    int live = atoi(argv[5]);
    if (!(secs >= 60) || live < 1 || live > 1000) {
        fprintf(stderr, "soak_daemon: SECONDS >= 60, LIVE_CLIENTS 1..1000\n");
        return 2;
    }
    double warm = secs >= 600 ? 300 : secs / 2;
    signal(SIGPIPE, SIG_IGN);
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
        rl.rlim_cur = rl.rlim_max;
        setrlimit(RLIMIT_NOFILE, &rl);
    }
    harness_fixtures(&H, argv[2]);
    atexit(kill_children);
    char good[1200], corrupt[1200], model[1200], csv[1200], loadout[1200], source[2048];
    snprintf(good, sizeof good, "%s/two-kinds.msm", H.dir);
    snprintf(corrupt, sizeof corrupt, "%s/corrupt.msm", H.dir);
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    snprintf(csv, sizeof csv, "%s/trot.csv", H.dir);
    snprintf(loadout, sizeof loadout, "%s/load.out", H.dir);
    harness_copy(good, model);
    const char *sched = "default (SCHED_OTHER)";
    if (argc == 7) { /* after make_model: the daemon, the load client and this program inherit it */
        struct sched_param sp = {.sched_priority = 10};
        sched = sched_setscheduler(0, SCHED_FIFO, &sp) ? "default (SCHED_FIFO refused)"
                                                       : "SCHED_FIFO 10 (every process of the run)";
    }
    char err[MDL_ERR_LEN];
    mdl_markers *mk = NULL;
    ASSERT_OK(mdl_markers_read(csv, NULL, &mk, err), err);
    sender snd = {.mk = mk, .port = free_udp_port()};
    int at = snprintf(source, sizeof source, "osc:127.0.0.1:%d?markers=", snd.port);
    for (int i = 0; i < mk->count; i++)
        at += snprintf(source + at, sizeof source - (size_t)at, "%s%s", i ? "," : "", mk->names[i]);
    char maxm[16];
    snprintf(maxm, sizeof maxm, "%d", MAX_MESSAGE);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--encoding", "int16", "--max-message", maxm, "--idle-after", "1", NULL};
    harness_start(&H, meshsteerd, args);
    uint64_t t0 = wsc_now_us();
    snd.t0 = t0;
    pthread_t th;
    ASSERT(pthread_create(&th, NULL, sender_main, &snd) == 0);

    char n_s[16], t_s[32], w_s[16], port_s[16];
    snprintf(n_s, sizeof n_s, "%d", live);
    snprintf(t_s, sizeof t_s, "%g", secs - LOAD_WARMUP_S - 2);
    snprintf(w_s, sizeof w_s, "%d", LOAD_WARMUP_S);
    snprintf(port_s, sizeof port_s, "%d", H.port);
    const char *largv[] = {load, "-n", n_s, "-t", t_s, "-w", w_s, "-e", "int16", "-p", port_s,
                           "-i", "60", "-j", NULL};
    pid_t load_pid = harness_spawn(largv, loadout);

    int stalled[STALLED];
    for (int i = 0; i < STALLED; i++)
        stalled[i] = harness_stalled_client(&H);
    double idle_closed_at_open = 0;
    int stalled_replaced = 0;
    struct lws_context *ctx = wsc_context();
    ASSERT(ctx);
    noise nz[NOISE];
    noise_stats ns = {0};
    for (int i = 0; i < NOISE; i++)
        noise_connect(ctx, &nz[i]);

    printf("soak: %g s, %d live clients (meshsteer-load, int16), %d stalled, %d noise; OSC source "
           "at %d Hz (gone for %d s at %d s and every %d s after); SIGHUP every %d s (corrupt, "
           "good, ...; every %d s in the warm-up of %g s); %ld CPUs, load average %.2f at start; "
           "scheduling %s\n\n",
           secs, live, STALLED, NOISE, SOURCE_HZ, VANISH_FOR_S, VANISH_FIRST_S, VANISH_EVERY_S,
           RELOAD_EVERY_S, WARM_RELOAD_EVERY_S, warm, sysconf(_SC_NPROCESSORS_ONLN), test_load_average(),
           sched);
    printf("| minute | RSS kB | live frames/s slowest / mean (connected) | noise sent / pongs / "
           "acks / errors | reloads ok / failed | stalled replaced | source gone | errors |\n"
           "|---:|---:|---|---|---|---:|---:|---:|\n");
    fflush(stdout);

    int failures = 0, reloads = 0, good_reloads = 0, bad_reloads = 0, minute = 0;
    long rss_warm = -1, rss_last = -1, rss_max = 0;
    uint64_t next_noise = t0, next_check = t0 + 5000000u;
    uint64_t end = t0 + (uint64_t)(secs * 1e6);
    while (wsc_now_us() < end) {
        wsc_run(ctx, 10, NULL, NULL);
        uint64_t now = wsc_now_us();
        double t = (double)(now - t0) * 1e-6;
        int send = now >= next_noise;
        if (send)
            next_noise += NOISE_EVERY_US;
        for (int i = 0; i < NOISE; i++)
            noise_step(ctx, &nz[i], &ns, send);
        if (now < next_check)
            continue;
        next_check += 1000000u; /* the slower duties, once a second */
        if (!daemon_alive()) {
            failures++;
            break;
        }
        /* the stalled clients: once the daemon has closed all four, four new ones */
        double idle = harness_metric(&H, "meshsteer_closed_idle_total");
        if (idle >= idle_closed_at_open + STALLED) {
            for (int i = 0; i < STALLED; i++) {
                close(stalled[i]);
                stalled[i] = harness_stalled_client(&H);
            }
            idle_closed_at_open = idle;
            stalled_replaced += STALLED;
        }
        /* SIGHUPs: every WARM_RELOAD_EVERY_S during the warm-up (so that the one-time growth of
         * the first reloads is behind it), then every RELOAD_EVERY_S; none in the last 10 s */
        int due = t < warm ? (int)t / WARM_RELOAD_EVERY_S
                           : (int)warm / WARM_RELOAD_EVERY_S +
                                 ((int)t / RELOAD_EVERY_S - (int)warm / RELOAD_EVERY_S);
        if (due > reloads && t < secs - 10) {
            reloads = due;
            int is_good = (good_reloads + bad_reloads) % 2 == 1;
            harness_copy(is_good ? good : corrupt, model);
            good_reloads += is_good;
            bad_reloads += !is_good;
            kill(H.pid, SIGHUP);
        }
        if (rss_warm < 0 && t >= warm)
            rss_warm = harness_rss_kb(&H);
        /* a line per minute, 1 s after meshsteer-load's line of that minute */
        if (t >= LOAD_WARMUP_S + 60.0 * (minute + 1) + 1) {
            minute++;
            rss_last = harness_rss_kb(&H);
            if (t >= warm && rss_last > rss_max)
                rss_max = rss_last;
            double fmin = 0, fmean = 0;
            int conn = 0;
            int k = last_interval(loadout, &fmin, &fmean, &conn);
            char *body;
            int hz = harness_get(&H, "/healthz", &body);
            free(body);
            if (hz != 200) {
                fprintf(stderr, "soak: /healthz answered %d\n", hz);
                failures++;
            }
            double ok = harness_metric(&H, "meshsteer_reloads_total");
            double bad = harness_metric(&H, "meshsteer_reloads_failed_total");
            char fps[96] = "(not yet)";
            if (k)
                snprintf(fps, sizeof fps, "%.1f / %.1f (%d), minute %d", fmin, fmean, conn, k);
            printf("| %d | %ld | %s | %ld / %ld / %ld / %ld | %.0f / %.0f | %d | %d | %ld |\n",
                   minute, rss_last, fps, ns.sent, ns.pongs, ns.acks, ns.errors, ok, bad,
                   stalled_replaced, atomic_load(&snd.vanishes),
                   failures + ns.unexpected_closes + ns.protocol_errors);
            fflush(stdout);
        }
    }
    rss_last = daemon_alive() ? harness_rss_kb(&H) : -1;
    if (rss_last > rss_max)
        rss_max = rss_last;
    int load_st = harness_wait(load_pid);
    cJSON *sum = load_summary(loadout);
    double load_fps_min = -1, load_fps_mean = -1, lat[4] = {-1, -1, -1, -1};
    int load_connected = -1;
    if (sum) {
        static const char *const lat_keys[4] = {"e2e_p50_ms", "e2e_p99_ms", "server_p50_ms",
                                                "server_p99_ms"};
        load_fps_min = cJSON_GetObjectItem(sum, "fps_min")->valuedouble;
        load_fps_mean = cJSON_GetObjectItem(sum, "fps_mean")->valuedouble;
        load_connected = cJSON_GetObjectItem(sum, "connected")->valueint;
        for (int k = 0; k < 4; k++)
            lat[k] = cJSON_GetObjectItem(sum, lat_keys[k])->valuedouble;
        cJSON_Delete(sum);
    }
    atomic_store(&snd.stop, 1);
    pthread_join(th, NULL);
    for (int i = 0; i < NOISE; i++)
        noise_replies(&nz[i], &ns);

    double ok = harness_metric(&H, "meshsteer_reloads_total");
    double bad = harness_metric(&H, "meshsteer_reloads_failed_total");
    int went_idle = harness_log_has(&H, "the idle animation takes over");
    int came_back = harness_log_has(&H, "tracking again");
    printf("\nnoise: %ld messages sent; replies: %ld pongs, %ld acks, %ld errors (", ns.sent,
           ns.pongs, ns.acks, ns.errors);
    for (int k = 0; k < 8; k++)
        printf("%s%s %ld", k ? ", " : "", error_codes[k], ns.codes[k]);
    printf("); closed for an oversized message %ld times, otherwise %ld; %ld malformed replies\n",
           ns.too_big_closes, ns.unexpected_closes, ns.protocol_errors);
    printf("source: %llu bundles sent, gone %d times; the daemon's idle animation took over: %s, "
           "tracking resumed: %s\n",
           (unsigned long long)atomic_load(&snd.bundles), atomic_load(&snd.vanishes),
           went_idle ? "yes" : "no", came_back ? "yes" : "no");
    printf("reloads: %.0f succeeded (of %d good), %.0f failed (of %d corrupt)\n", ok, good_reloads,
           bad, bad_reloads);
    printf("stalled clients: %d replaced after the daemon closed them for idleness\n",
           stalled_replaced);
    printf("live clients: %d of %d connected at the end, frames/s per client over %s s: slowest "
           "%.2f, mean %.2f (meshsteer-load exit %d)\n",
           load_connected, live, t_s, load_fps_min, load_fps_mean, load_st);
    printf("live clients' latency over the run: end to end p50 %.2f ms, p99 %.2f ms; the daemon's "
           "capture -> send p50 %.2f ms, p99 %.2f ms\n", lat[0], lat[1], lat[2], lat[3]);
    printf("load average at the end: %.2f\n", test_load_average());
    long growth = rss_last - rss_warm;
    printf("RSS: %ld kB after the warm-up (%g s), %ld kB at the end (largest after the warm-up "
           "%ld kB): growth %ld kB\n",
           rss_warm, warm, rss_last, rss_max, growth);

    int pass = 1;
#define CHECK(cond, what)                                                                          \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            printf("FAIL: %s\n", what);                                                            \
            pass = 0;                                                                              \
        }                                                                                          \
    } while (0)
    CHECK(failures == 0 && rss_last > 0, "the daemon stayed up and answered /healthz");
    CHECK(rss_warm > 0 && growth < RSS_GROWTH_MAX_KB, "RSS growth after the warm-up < 2 MB");
    CHECK(load_st == 0 && load_connected == live, "every live client stayed connected");
    CHECK(load_fps_min >= FPS_MIN, "every live client >= 57 frames/s");
    CHECK(ok == good_reloads && bad == bad_reloads, "every reload ended as expected");
    CHECK(ns.pongs > 0 && ns.errors > 0 && ns.unexpected_closes == 0 && ns.protocol_errors == 0 &&
              ns.too_big_closes > 0,
          "the noise clients got valid replies and were closed only for oversized messages");
    CHECK(stalled_replaced >= (secs >= 120 ? STALLED : 0),
          "the daemon closed the stalled clients for idleness");
    CHECK(atomic_load(&snd.vanishes) == 0 || (went_idle && came_back),
          "the idle animation took over while the source was gone, and tracking resumed");
    for (int i = 0; i < STALLED; i++)
        close(stalled[i]);
    if (H.pid > 0)
        CHECK(harness_stop(&H, SIGTERM, 10000) == 0, "meshsteerd exits cleanly on SIGTERM");
    lws_context_destroy(ctx);
    for (int i = 0; i < NOISE; i++)
        wsc_free(nz[i].c);
    mdl_markers_destroy(mk);
    printf("%s\n", pass ? "PASS" : "FAIL");
    if (pass) {
        char cmd[1200];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", H.dir);
        if (system(cmd) != 0)
            fprintf(stderr, "could not remove %s\n", H.dir);
    } else {
        printf("(the daemon's log and meshsteer-load's output are kept in %s)\n", H.dir);
    }
    return pass ? 0 : 1;
}
