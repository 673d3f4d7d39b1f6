/* bench_daemon.c - the daemon benchmark of docs/PERFORMANCE.md (meson test --benchmark): the horse
 * model (shared/data/meshes/horse-gallop, 8,431 vertices) driven by its own rig markers replayed
 * at 60 Hz, meshsteer-load on the same host, per row:
 *   end-to-end latency (capture -> receipt) p50/p99, frames received vs sent, frames/s per client,
 *   the daemon's capture -> send latency, from the frames' stamps and from /metrics (the
 *   histogram's change over the row, as bucket bounds);
 * then the largest client count at which every client still gets 60 fps (>= 95 % of the
 * source's frames), searched upwards, for int16 and for the params encoding (the compact
 * parameter stream: docs/PROTOCOL.md 2b) in the same run; every row gives the bytes per frame.
 * Then, in the same run, the same through NATS (issue 14 §2): a three-node nats-server cluster on
 * loopback (nats_cluster.h), the daemon started again with --publish to node 1, and
 * meshsteer-load --nats subscribers spread over nodes 2 and 3: the same rows, and the largest
 * subscriber count at which every subscriber gets >= 57 frames/s, for int16 and for params when
 * the daemon publishes that encoding (said when it does not). Skipped (said so) without
 * nats-server. The cluster shares the 2 cores with the daemon and the load client.
 * Usage: bench_daemon MESHSTEERD MESHSTEER MESHSTEER_LOAD [SECONDS_PER_ROW] [MAX_CLIENTS_TRIED]
 *                     [fifo]
 * With "fifo" the daemon and the load client run under SCHED_FIFO priority 10 (both inherit it
 * from this process; needs CAP_SYS_NICE), as `chrt -f 10` or systemd's CPUSchedulingPolicy=fifo
 * would run them: on a machine busy with other work, that removes the scheduling tail.
 * Skips (77) without the shared data. Prints a Markdown table. */
#include "daemon_harness.h"
#include "nats_cluster.h"
#include "test.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#define NB 32

static harness H;

typedef struct hist {
    double le[NB];
    double count[NB];
    int n;
} hist;

static void read_hist(const char *name, hist *h)
{
    char *body;
    ASSERT_INT_EQ(harness_get(&H, "/metrics", &body), 200);
    h->n = 0;
    size_t nl = strlen(name);
    for (char *line = strtok(body, "\n"); line; line = strtok(NULL, "\n")) {
        if (strncmp(line, name, nl) || strncmp(line + nl, "_bucket{le=\"", 12))
            continue;
        const char *v = line + nl + 12;
        double le = !strncmp(v, "+Inf", 4) ? 1e9 : atof(v);
        const char *sp = strrchr(line, ' ');
        if (sp && h->n < NB) {
            h->le[h->n] = le;
            h->count[h->n++] = atof(sp + 1);
        }
    }
    free(body);
}

/* The bucket bound (ms) under which the q-quantile of the observations between a and b lies. */
static double hist_quant(const hist *a, const hist *b, double q)
{
    double total = b->count[b->n - 1] - a->count[a->n - 1];
    if (total <= 0)
        return 0;
    for (int i = 0; i < b->n; i++)
        if (b->count[i] - a->count[i] >= q * total)
            return b->le[i] * 1e3;
    return 1e12;
}

typedef struct row {
    int clients;
    const char *enc;
    const char *nats; /* subscribe through these NATS servers (NULL: WebSocket to the daemon) */
    cJSON *j;
    double m50, m99; /* /metrics capture -> send, bucket bounds in ms */
    double synth_busy;
} row;

static double num(const cJSON *j, const char *k)
{
    const cJSON *v = cJSON_GetObjectItem(j, k);
    return cJSON_IsNumber(v) ? v->valuedouble : -1;
}

static void run_row(const char *load, row *r, double secs)
{
    hist a, b;
    read_hist("meshsteer_latency_seconds", &a);
    double busy0 = harness_metric(&H, "meshsteer_drops_total{reason=\"synth_busy\"}");
    char n[16], t[32], port[16], out[1200];
    snprintf(n, sizeof n, "%d", r->clients);
    snprintf(t, sizeof t, "%g", secs);
    snprintf(port, sizeof port, "%d", H.port);
    snprintf(out, sizeof out, "%s/load-%d-%s%s.json", H.dir, r->clients, r->enc,
             r->nats ? "-nats" : "");
    const char *argv[] = {load, "-n", n, "-t", t, "-w", "1.5", "-e", r->enc, "-j",
                          r->nats ? "--nats" : "-p", r->nats ? r->nats : port, NULL};
    int st = harness_run(argv, out);
    read_hist("meshsteer_latency_seconds", &b);
    r->synth_busy = harness_metric(&H, "meshsteer_drops_total{reason=\"synth_busy\"}") - busy0;
    r->m50 = hist_quant(&a, &b, 0.5);
    r->m99 = hist_quant(&a, &b, 0.99);
    FILE *f = fopen(out, "r");
    ASSERT(f);
    char buf[4096];
    size_t got = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[got] = '\0';
    const char *js = strchr(buf, '{');
    r->j = js ? cJSON_Parse(js) : NULL;
    if (!r->j || st > 1) {
        fprintf(stderr, "meshsteer-load -n %d -e %s failed (%d): %s\n", r->clients, r->enc, st,
                buf);
        exit(1);
    }
}

static void print_row(const row *r)
{
    const cJSON *j = r->j;
    double recv = num(j, "received"), sent = num(j, "sent");
    char metrics[64] = "-"; /* the /metrics histogram is of WebSocket sends */
    if (!r->nats)
        snprintf(metrics, sizeof metrics, "<= %g / <= %g ms", r->m50, r->m99);
    printf("| %d | %s%s | %.0f | %.0f / %.0f (%.1f %%) | %.1f (slowest %.1f) | %.2f ms | %.2f ms | "
           "%.2f / %.2f ms | %s | %.0f |\n",
           r->clients, r->enc, r->nats ? " (NATS)" : "", num(j, "bytes_per_frame"), recv, sent,
           sent > 0 ? 100 * recv / sent : 0, num(j, "fps_mean"), num(j, "fps_min"),
           num(j, "e2e_p50_ms"), num(j, "e2e_p99_ms"), num(j, "server_p50_ms"),
           num(j, "server_p99_ms"), metrics, r->synth_busy);
    fflush(stdout);
}

static int holds_60(const row *r)
{
    return num(r->j, "connected") == r->clients && num(r->j, "fps_min") >= 0.95 * 60;
}

/* The largest client count (64 held) at which every client gets >= 57 frames/s, trying steps[]
 * upwards to max_tried; over NATS when nats is set. */
static int search_60(const char *load, const char *nats, const char *enc, const int *steps,
                     size_t nsteps, double secs, int max_tried)
{
    int best = 64;
    for (size_t k = 0; k < nsteps && steps[k] <= max_tried; k++) {
        row r = {steps[k], enc, nats, NULL, 0, 0, 0};
        run_row(load, &r, secs);
        print_row(&r);
        int ok = holds_60(&r);
        cJSON_Delete(r.j);
        if (!ok)
            break;
        best = steps[k];
    }
    return best;
}

static const int nats_steps[] = {96, 128, 192, 256, 320, 384, 512, 640, 768, 1024};
#define NSTEPS(a) (sizeof(a) / sizeof(a)[0])

/* The NATS rows: the daemon again, publishing to node 1 of a three-node cluster; subscribers on
 * nodes 2 and 3. */
static void bench_nats(const char *meshsteerd, const char *load, const char *const *ws_args,
                       double secs, int max_tried)
{
    if (!nats_server_path()) {
        printf("\nNATS: skipped, nats-server is not installed\n");
        return;
    }
    static nats_cluster c;
    nats_cluster_start(&c, 3, H.dir);
    const char *args[16];
    int n = 0;
    while (ws_args[n])
        args[n] = ws_args[n], n++;
    args[n++] = "--publish";
    args[n++] = c.node[0].url;
    args[n] = NULL;
    harness_start(&H, meshsteerd, args);
    nats_cluster_adopt(H.pid);
    char urls[200];
    snprintf(urls, sizeof urls, "%s,%s", c.node[1].url, c.node[2].url);
    printf("\nThrough NATS: the daemon publishes to node 1 of a 3-node nats-server %s cluster on "
           "loopback; subscribers (one NATS connection each) alternate between nodes 2 and 3\n\n",
           "2.9");
    printf("| subscribers | encoding | bytes/frame | received / sent | frames/s per subscriber | "
           "e2e p50 | e2e p99 | capture->publish p50 / p99 (frames) | - | synth_busy drops |\n"
           "|---:|---|---:|---|---|---:|---:|---|---|---:|\n");
    row rows[3] = {{1, "int16", urls, NULL, 0, 0, 0}, {64, "int16", urls, NULL, 0, 0, 0},
                   {64, "float32", urls, NULL, 0, 0, 0}};
    for (int i = 0; i < 3; i++) {
        run_row(load, &rows[i], secs);
        print_row(&rows[i]);
    }
    int best = holds_60(&rows[1])
                   ? search_60(load, urls, "int16", nats_steps, NSTEPS(nats_steps), secs, max_tried)
                   : 0;
    printf("\nNATS cluster: largest int16 subscriber count holding 60 fps (every subscriber >= 57 "
           "frames/s): %d%s; e2e (capture -> subscriber) p50 %.2f ms p99 %.2f ms at 64\n",
           best, best >= max_tried ? " (the largest tried)" : "", num(rows[1].j, "e2e_p50_ms"),
           num(rows[1].j, "e2e_p99_ms"));
    /* params: only when the daemon publishes that encoding */
    row probe = {1, "params", urls, NULL, 0, 0, 0};
    run_row(load, &probe, 1);
    if (num(probe.j, "received") > 0) {
        row p64 = {64, "params", urls, NULL, 0, 0, 0};
        run_row(load, &p64, secs);
        print_row(&p64);
        int bp = holds_60(&p64) ? search_60(load, urls, "params", nats_steps,
                                            NSTEPS(nats_steps), secs, max_tried)
                                : 0;
        printf("NATS cluster: largest params subscriber count holding 60 fps: %d%s; e2e p50 %.2f "
               "ms p99 %.2f ms at 64\n", bp, bp >= max_tried ? " (the largest tried)" : "",
               num(p64.j, "e2e_p50_ms"), num(p64.j, "e2e_p99_ms"));
        cJSON_Delete(p64.j);
    } else {
        printf("NATS cluster, params: not measured, this daemon publishes no params frames "
               "(no %s.frames.params messages)\n", "meshsteer");
    }
    cJSON_Delete(probe.j);
    for (int i = 0; i < 3; i++)
        cJSON_Delete(rows[i].j);
    pid_t pid = H.pid;
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 10000), 0);
    nats_cluster_disown(pid);
    nats_cluster_stop(&c);
}

int main(int argc, char **argv)
{
    if (argc < 4 || argc > 7 || (argc == 7 && strcmp(argv[6], "fifo"))) {
        fprintf(stderr, "usage: bench_daemon MESHSTEERD MESHSTEER MESHSTEER_LOAD [SECONDS] "
                        "[MAX_CLIENTS_TRIED] [fifo]\n");
        return 2;
    }
    int fifo = argc == 7;
    signal(SIGPIPE, SIG_IGN);
    const char *meshsteerd = argv[1], *meshsteer = argv[2], *load = argv[3];
    double secs = argc > 4 ? atof(argv[4]) : 5;
    int max_tried = argc > 5 ? atoi(argv[5]) : 512;
    const char *mesh = test_data("meshes/horse-gallop");
    const char *rig = test_src("rigs/horse.json");
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
        rl.rlim_cur = rl.rlim_max; /* a few hundred sockets on each side */
        setrlimit(RLIMIT_NOFILE, &rl);
    }
    harness_dir(&H);
    char model[1200], csv[1200], source[1300], log[1200];
    snprintf(model, sizeof model, "%s/horse.msm", H.dir);
    snprintf(csv, sizeof csv, "%s/horse.csv", H.dir);
    snprintf(log, sizeof log, "%s/cli.log", H.dir);
    const char *train[] = {meshsteer, "train", "--mesh", mesh, "--rig", rig, "--frames", "0:24:2",
                           "-o", model, NULL};
    const char *markers[] = {meshsteer, "markers", "--mesh", mesh, "--rig", rig, "--fps", "60",
                             "-o", csv, NULL};
    if (harness_run(train, log) || harness_run(markers, log)) {
        fprintf(stderr, "meshsteer train/markers failed; see %s\n", log);
        return 1;
    }
    if (fifo) { /* after training: only the daemon and the load clients inherit it */
        struct sched_param sp = {.sched_priority = 10};
        if (sched_setscheduler(0, SCHED_FIFO, &sp)) {
            fprintf(stderr, "skip: SCHED_FIFO: %s\n", strerror(errno));
            return 77;
        }
    }
    snprintf(source, sizeof source, "replay:%s?loop=1", csv);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0",
                          "--max-clients", "10000", NULL};
    harness_start(&H, meshsteerd, args);

    double load1 = test_load_average();
    printf("horse model (8,431 vertices), replay at 60 Hz, %g s per row after 1.5 s warm-up; "
           "%ld CPUs, load average %.2f at start; scheduling %s\n\n",
           secs, sysconf(_SC_NPROCESSORS_ONLN), load1,
           fifo ? "SCHED_FIFO 10 (daemon and load client)" : "default (SCHED_OTHER)");
    printf("| clients | encoding | bytes/frame | received / sent | frames/s per client | e2e p50 | "
           "e2e p99 | capture->send p50 / p99 (frames) | capture->send p50 / p99 (/metrics) | "
           "synth_busy drops |\n|---:|---|---:|---|---|---:|---:|---|---|---:|\n");
    enum { NROWS = 6 };
    row rows[NROWS] = {{1, "int16", NULL, NULL, 0, 0, 0},   {1, "float32", NULL, NULL, 0, 0, 0},
                       {1, "params", NULL, NULL, 0, 0, 0},  {64, "int16", NULL, NULL, 0, 0, 0},
                       {64, "float32", NULL, NULL, 0, 0, 0}, {64, "params", NULL, NULL, 0, 0, 0}};
    for (int i = 0; i < NROWS; i++) {
        run_row(load, &rows[i], secs);
        print_row(&rows[i]);
    }
    /* the largest client counts that hold 60 fps, int16 then params */
    static const int steps[] = {96, 128, 160, 192, 256, 320, 384, 448, 512, 640, 768, 1024,
                                1280, 1536, 2048};
    int best = holds_60(&rows[3])
                   ? search_60(load, NULL, "int16", steps, NSTEPS(steps), secs, max_tried)
                   : 0;
    int best_p = holds_60(&rows[5])
                     ? search_60(load, NULL, "params", steps, NSTEPS(steps), secs, max_tried)
                     : 0;
    printf("\nlargest int16 client count holding 60 fps (every client >= 57 frames/s): %d%s\n",
           best, best >= max_tried ? " (the largest tried)" : "");
    printf("largest params client count holding 60 fps (every client >= 57 frames/s): %d%s\n",
           best_p, best_p >= max_tried ? " (the largest tried)" : "");
    double bi = num(rows[0].j, "bytes_per_frame"), bp = num(rows[2].j, "bytes_per_frame");
    printf("bytes per frame: int16 %.0f, params %.0f: %.1fx smaller (goal >= 20x: %s)\n", bi, bp,
           bp > 0 ? bi / bp : 0, bp > 0 && bi / bp >= 20 ? "met" : "not met");
    double p99_1 = num(rows[0].j, "e2e_p99_ms"), p99_64 = num(rows[3].j, "e2e_p99_ms");
    printf("goal p99 < 5 ms with 1 client (int16): %.2f ms, %s\n", p99_1,
           p99_1 < 5 ? "met" : "not met");
    printf("goal p99 < 20 ms with 64 clients (int16): %.2f ms, %s\n", p99_64,
           p99_64 < 20 ? "met" : "not met");
    for (int i = 0; i < NROWS; i++)
        cJSON_Delete(rows[i].j);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 10000), 0);
    bench_nats(meshsteerd, load, args, secs, max_tried);
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", H.dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", H.dir);
    return 0;
}
