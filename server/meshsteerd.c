/* meshsteerd.c - the real-time daemon: a marker source drives the model, and every connected
 * browser receives the synthesised mesh over WebSocket (DESIGN.md, "Threads of the daemon").
 *
 * This file wires the parts together and owns the main thread, which runs the libwebsockets
 * service loop: settings (daemon_config.c), logging (log.c), the pipeline threads (pipeline.c),
 * the /stream protocol (proto_stream.c), /healthz and /metrics (http.c), the NATS publisher
 * (publish_nats.c, --publish), the viewer as a file mount, signals and systemd notification.
 * Signal handlers only set flags (STYLE.md Sec. 7); a 100 ms lws timer guarantees the loop looks
 * at them. */
#include "daemon.h"
#include "wire_guard_io.h"
#include "log.h"
#include "srv_err.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stddef.h>
#include <getopt.h>
#include <netdb.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

void openblas_set_num_threads(int num_threads); /* OpenBLAS; the daemon owns its threads */

static volatile sig_atomic_t sig_stop, sig_reload;

static void on_signal(int sig)
{
    if (sig == SIGHUP)
        sig_reload = 1;
    else
        sig_stop = 1;
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: meshsteerd --model MODEL --source SPEC [OPTIONS]\n\n"
            "Streams meshes synthesised from a marker source to WebSocket clients.\n\n"
            "  -m, --model FILE        trained model (meshsteer train)\n"
            "  -s, --source SPEC       replay:FILE[?loop=1&speed=1&start=0&joints=1] (.c3d .trc .bvh .amc\n"
            "                          .csv; a .bvh/.amc also gives joint rotations, joints=0 not)\n"
            "  -l, --listen ADDR:PORT  default 127.0.0.1:8080, exactly that address ([::1]:PORT for IPv6;\n"
            "                          port 0: any free port)\n"
            "  -c, --config FILE       'key = value' settings; flags override them\n"
            "      --record OUT.c3d    also write the incoming markers to a C3D file\n"
            "      --max-clients N     default 256\n"
            "      --max-message BYTES largest control message, default 4096\n"
            "      --idle-timeout S    close clients that accept no frame for S seconds (30)\n"
            "      --idle-after S      a model with an idle animation (meshsteer skin --add-to) plays\n"
            "                          it after S seconds without source frames or without a pose\n"
            "                          from the markers (2; a lost or ended source: at once)\n"
            "      --fade S            cross-fade from the idle animation back to the tracked pose\n"
            "                          over S seconds when tracking returns (0.5; 0: a cut)\n"
            "      --token SECRET      require ?token=SECRET or 'Authorization: Bearer SECRET'\n"
            "      --origin any|same|LIST  Origin check for /stream (default any)\n"
            "      --web-root DIR      directory served at / (default: the built viewer)\n"
            "      --encoding float32|int16|params  default frame encoding\n"
            "      --labels MAP        drive the model with other marker labels:\n"
            "                          MODEL=LABEL[,MODEL=LABEL...], the rig's 'source' label\n"
            "                          MODEL fed by the source's LABEL (one LABEL may feed\n"
            "                          several); unmapped labels match by name. E.g. a model of\n"
            "                          rigs/horse-human.json on a depth camera: see README\n"
            "      --publish nats://HOST:PORT[,nats://HOST:PORT...]\n"
            "                          also publish hello, topology and frames to these NATS\n"
            "                          servers (one cluster); a server that is down is retried\n"
            "      --subject PREFIX    NATS subject prefix (default meshsteer): PREFIX.hello,\n"
            "                          PREFIX.topology, PREFIX.frames.ENCODING, requests on\n"
            "                          PREFIX.get.hello and PREFIX.get.topology\n"
            "      --log-level LEVEL   error, warn, notice (default), info, debug\n"
            "  -v, --verbose           --log-level info (twice: debug)\n"
            "      --check-config      validate the settings and exit\n"
            "  -h, --help, --version\n\n"
            "Signals: SIGINT/SIGTERM stop cleanly; SIGHUP reloads the model.\n"
            "HTTP: / viewer, /healthz, /metrics, /stream (WebSocket, docs/PROTOCOL.md).\n");
}

static int is_dir_with_index(const char *dir)
{
    char p[SRV_PATH_LEN + 16];
    struct stat st;
    snprintf(p, sizeof p, "%s/index.html", dir);
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

/* --web-root, else the installed viewer, else the source tree's (running from the build dir). */
static void resolve_web_root(srv_config *c)
{
    if (c->web_root[0])
        return;
    const char *cands[] = {MESHSTEER_WEB_INSTALLED, MESHSTEER_WEB_SOURCE};
    for (int i = 0; i < 2; i++)
        if (is_dir_with_index(cands[i])) {
            snprintf(c->web_root, sizeof c->web_root, "%s", cands[i]);
            return;
        }
}

static void wake(void *ud)
{
    srv_daemon *d = ud;
    if (d->ctx)
        lws_cancel_service(d->ctx);
    srv_publisher_notify(d->pub);
}

/* the wire guard found a session to close (an unmasked frame): proto_stream.c closes it */
static void guard_wake(void *ud)
{
    srv_daemon *d = ud;
    if (d->ctx)
        lws_cancel_service(d->ctx);
}

static void tick(lws_sorted_usec_list_t *sul);
static lws_sorted_usec_list_t tick_sul;
static struct lws_context *tick_ctx;

static void tick(lws_sorted_usec_list_t *sul)
{
    lws_sul_schedule(tick_ctx, 0, sul, tick, 100 * LWS_US_PER_MS);
}

/* The listen address as lws 4.1 must be given it to bind exactly that address: info.iface takes
 * the numeric address, and the socket's family follows the options. Unless IPv6 is disabled lws
 * makes an IPv6 socket and, for an IPv4 iface, binds [::] (every interface, both families); so
 * an IPv4 address disables IPv6, and an IPv6 address sets V6ONLY (no IPv4 on it). A host name
 * binds its first address. numeric gets the address, *v6 whether it is IPv6. */
static int listen_address(const char *host, char *numeric, size_t n, uint64_t *options, int *v6,
                          char *err)
{
    struct in_addr a4;
    struct in6_addr a6;
    char buf[INET6_ADDRSTRLEN];
    const char *addr = host;
    if (inet_pton(AF_INET, host, &a4) != 1 && inet_pton(AF_INET6, host, &a6) != 1) {
        struct addrinfo hints = {.ai_socktype = SOCK_STREAM, .ai_flags = AI_ADDRCONFIG}, *res;
        int r = getaddrinfo(host, NULL, &hints, &res);
        if (r)
            return srv_err(err, -EINVAL, "listen: cannot resolve '%s': %s", host, gai_strerror(r));
        const void *src = res->ai_family == AF_INET
                              ? (const void *)&((struct sockaddr_in *)res->ai_addr)->sin_addr
                              : (const void *)&((struct sockaddr_in6 *)res->ai_addr)->sin6_addr;
        const char *ok = inet_ntop(res->ai_family, src, buf, sizeof buf);
        freeaddrinfo(res);
        if (!ok)
            return srv_err(err, -EINVAL, "listen: cannot resolve '%s'", host);
        addr = buf;
    }
    *v6 = inet_pton(AF_INET, addr, &a4) != 1;
    *options |= *v6 ? LWS_SERVER_OPTION_IPV6_V6ONLY_MODIFY | LWS_SERVER_OPTION_IPV6_V6ONLY_VALUE
                    : LWS_SERVER_OPTION_DISABLE_IPV6;
    size_t len = strlen(addr);
    if (len >= n)
        return srv_err(err, -EINVAL, "listen: bad address '%s'", host);
    memcpy(numeric, addr, len + 1);
    return 0;
}

/* What the command line said, kept so that SIGHUP can build the settings again: the config file
 * re-read, then the same flags on top (flags override the file). */
typedef struct srv_args {
    const char *config;
    const char *keys[64], *vals[64];
    int nflags, verbose;
} srv_args;

/* Defaults, then the config file, then the flags; validated. Fills a fresh struct: the caller
 * swaps it in only when this succeeds (STYLE §7). */
static int build_config(const srv_args *a, srv_config *c, char *err)
{
    char e[SRV_ERR_LEN];
    srv_config_defaults(c);
    if (a->config && srv_config_read(c, a->config, e))
        return snprintf(err, SRV_ERR_LEN, "%s", e), -EINVAL;
    for (int i = 0; i < a->nflags; i++)
        if (srv_config_set(c, a->keys[i], a->vals[i], e))
            return snprintf(err, SRV_ERR_LEN, "--%s: %.400s", a->keys[i], e), -EINVAL;
    if (a->verbose)
        c->log_level = a->verbose > 1 ? SRV_LOG_DEBUG
                                      : (c->log_level > SRV_LOG_INFO ? c->log_level : SRV_LOG_INFO);
    if (srv_config_validate(c, e))
        return snprintf(err, SRV_ERR_LEN, "%s", e), -EINVAL;
    return 0;
}

static int parse_args(int argc, char **argv, srv_args *a, srv_config *c, int *check_only)
{
    enum { O_RECORD = 256, O_MAXC, O_MAXM, O_IDLE, O_TOKEN, O_ORIGIN, O_WEB, O_ENC, O_LOG, O_CHECK,
           O_VERSION, O_LABELS, O_PUBLISH, O_SUBJECT, O_IDLE_AFTER, O_FADE };
    static const struct option opts[] = {
        {"model", required_argument, 0, 'm'},     {"source", required_argument, 0, 's'},
        {"listen", required_argument, 0, 'l'},    {"config", required_argument, 0, 'c'},
        {"record", required_argument, 0, O_RECORD}, {"max-clients", required_argument, 0, O_MAXC},
        {"max-message", required_argument, 0, O_MAXM}, {"idle-timeout", required_argument, 0, O_IDLE},
        {"token", required_argument, 0, O_TOKEN}, {"origin", required_argument, 0, O_ORIGIN},
        {"web-root", required_argument, 0, O_WEB}, {"encoding", required_argument, 0, O_ENC},
        {"log-level", required_argument, 0, O_LOG}, {"verbose", no_argument, 0, 'v'},
        {"check-config", no_argument, 0, O_CHECK}, {"help", no_argument, 0, 'h'},
        {"version", no_argument, 0, O_VERSION},   {"labels", required_argument, 0, O_LABELS},
        {"publish", required_argument, 0, O_PUBLISH}, {"subject", required_argument, 0, O_SUBJECT},
        {"idle-after", required_argument, 0, O_IDLE_AFTER}, {"fade", required_argument, 0, O_FADE},
        {0, 0, 0, 0},
    };
    /* flags override the file: collect them first, read the file, then apply them */
    memset(a, 0, sizeof *a);
    int o;
    while ((o = getopt_long(argc, argv, "m:s:l:c:vh", opts, NULL)) != -1) {
        const char *key = NULL;
        switch (o) {
        case 'm': key = "model"; break;
        case 's': key = "source"; break;
        case 'l': key = "listen"; break;
        case 'c': a->config = optarg; break;
        case O_RECORD: key = "record"; break;
        case O_MAXC: key = "max_clients"; break;
        case O_MAXM: key = "max_message"; break;
        case O_IDLE: key = "idle_timeout"; break;
        case O_TOKEN: key = "token"; break;
        case O_ORIGIN: key = "origin"; break;
        case O_WEB: key = "web_root"; break;
        case O_ENC: key = "encoding"; break;
        case O_LOG: key = "log_level"; break;
        case O_LABELS: key = "labels"; break;
        case O_PUBLISH: key = "publish"; break;
        case O_SUBJECT: key = "subject"; break;
        case O_IDLE_AFTER: key = "idle_after"; break;
        case O_FADE: key = "fade"; break;
        case 'v': a->verbose++; break;
        case O_CHECK: *check_only = 1; break;
        case 'h': usage(stdout); exit(0);
        case O_VERSION: printf("meshsteerd %s\n", MESHSTEER_VERSION); exit(0);
        default: usage(stderr); return 2;
        }
        if (key && a->nflags < 64) {
            a->keys[a->nflags] = key;
            a->vals[a->nflags++] = optarg;
        }
    }
    if (optind < argc) {
        fprintf(stderr, "meshsteerd: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    char err[SRV_ERR_LEN];
    if (build_config(a, c, err)) {
        fprintf(stderr, "meshsteerd: %s\n", err);
        return 2;
    }
    return 0;
}

/* SIGHUP: the settings are built again from the file and the flags; when valid, those that can
 * change while serving take effect (model, labels, log level, client limits, token, origin,
 * default encoding) and the others are reported as needing a restart. */
static int reload_config(srv_daemon *d, const srv_args *a)
{
    static srv_config fresh; /* large; the main thread only */
    char err[SRV_ERR_LEN];
    if (build_config(a, &fresh, err)) {
        srv_log(SRV_LOG_ERROR, "SIGHUP: the settings are not valid, keeping the current ones: %s",
                err);
        return -EINVAL;
    }
    static const struct {
        const char *name;
        size_t off, len;
    } fixed[] = {
        {"source", offsetof(srv_config, source), sizeof fresh.source},
        {"listen", offsetof(srv_config, listen_host), sizeof fresh.listen_host},
        {"listen port", offsetof(srv_config, port), sizeof fresh.port},
        {"record", offsetof(srv_config, record), sizeof fresh.record},
        {"max_message", offsetof(srv_config, max_message), sizeof fresh.max_message},
        {"web_root", offsetof(srv_config, web_root), sizeof fresh.web_root},
        {"publish", offsetof(srv_config, publish), sizeof fresh.publish},
        {"subject", offsetof(srv_config, subject), sizeof fresh.subject},
    };
    resolve_web_root(&fresh);
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        if (memcmp((const char *)&fresh + fixed[i].off, (const char *)&d->cfg + fixed[i].off,
                   fixed[i].len))
            srv_log(SRV_LOG_WARN, "SIGHUP: '%s' changed; it takes effect at the next start",
                    fixed[i].name);
    srv_config keep = d->cfg;
    d->cfg = fresh;
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        memcpy((char *)&d->cfg + fixed[i].off, (const char *)&keep + fixed[i].off, fixed[i].len);
    srv_log_set_level(d->cfg.log_level);
    return 0;
}

int main(int argc, char **argv)
{
    static srv_daemon d; /* large; and the lws context points at it for its lifetime */
    static srv_args args;
    int check_only = 0;
    int rc = parse_args(argc, argv, &args, &d.cfg, &check_only);
    if (rc)
        return rc;
    if (check_only) {
        printf("meshsteerd: settings are valid\n");
        return 0;
    }
    openblas_set_num_threads(1);
    srv_log_set_level(d.cfg.log_level);
    srv_log_hook_lws();
    srv_metrics_init(&d.metrics);
    d.t_start_us = srv_now_us();
    resolve_web_root(&d.cfg);
    if (!d.cfg.web_root[0])
        srv_log(SRV_LOG_WARN, "no viewer found (set --web-root); / will answer 404");

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    char err[SRV_ERR_LEN];
    drv_source *src = NULL;
    if (drv_source_open(d.cfg.source, &src, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        return 1;
    }
    srv_log(SRV_LOG_NOTICE, "source %s: %d markers at %g fps", d.cfg.source, src->count, src->fps);
    srv_source_info si;
    if (srv_source_info_init(&si, src, d.cfg.source, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        drv_source_close(src);
        return 1;
    }
    srv_bundle b;
    if (d.cfg.labels[0])
        srv_log(SRV_LOG_NOTICE, "labels: %s", d.cfg.labels);
    if (srv_pipeline_load(d.cfg.model, d.cfg.labels, &si, 1, &b, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        srv_source_info_fini(&si);
        drv_source_close(src);
        return 1;
    }
    srv_log(SRV_LOG_NOTICE, "model %s: '%s', %d vertices, %d faces, %d parts, %d markers%s",
            d.cfg.model, b.gen->name, b.gen->nv, b.gen->nf, b.gen->nparts, b.gen->nm,
            b.inputs & MDL_INPUT_MARKERS ? "" : ", driven by its own clock");
    if (srv_pipeline_create(src, &si, &b, &d.metrics, d.cfg.record, wake, &d, &d.pipe, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        srv_bundle_fini(&b);
        srv_source_info_fini(&si);
        drv_source_close(src);
        return 1;
    }
    srv_pipeline_set_idle(d.pipe, d.cfg.idle_after, d.cfg.fade);

    static const struct lws_protocol_vhost_options pvo_default = {NULL, NULL, "default", "1"};
    static const struct lws_protocol_vhost_options pvo = {NULL, &pvo_default, SRV_WS_PROTOCOL, ""};
    /* every HTTP path is a callback mount bound to srv_proto_http by name (http.c) */
    const struct lws_protocols protocols[] = {
        {"http", srv_http_accept_callback, 0, 0, 0, NULL, 0}, srv_proto_http, srv_proto_stream,
        {0}};
    struct lws_http_mount m_metrics = {
        .mountpoint = "/metrics", .origin = "meshsteer-http", .origin_protocol = LWSMPRO_CALLBACK,
        .mountpoint_len = 8};
    struct lws_http_mount m_health = {
        .mount_next = &m_metrics, .mountpoint = "/healthz", .origin = "meshsteer-http",
        .origin_protocol = LWSMPRO_CALLBACK, .mountpoint_len = 8};
    struct lws_http_mount m_root = {
        .mount_next = &m_health, .mountpoint = "/", .origin = "meshsteer-http",
        .origin_protocol = LWSMPRO_CALLBACK, .mountpoint_len = 1};
    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.port = d.cfg.port; /* 0: any free port, reported below */
    char listen_addr[INET6_ADDRSTRLEN];
    int listen_v6 = 0;
    info.options = LWS_SERVER_OPTION_VALIDATE_UTF8 |
                   LWS_SERVER_OPTION_HTTP_HEADERS_SECURITY_BEST_PRACTICES_ENFORCE;
    if (listen_address(d.cfg.listen_host, listen_addr, sizeof listen_addr, &info.options,
                       &listen_v6, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        srv_pipeline_destroy(d.pipe);
        return 1;
    }
    info.iface = listen_addr;
    info.protocols = protocols;
    info.pvo = &pvo;
    info.mounts = &m_root;
    info.user = &d;
    info.timeout_secs = 10;
    info.pt_serv_buf_size = 64 * 1024;
    /* lws closes a request whose headers overflow its buffer without a word; a larger buffer lets
     * http.c answer 431 up to it (SRV_HTTP_HEADER_BUFFER, daemon.h) */
    info.max_http_header_data = 0;
    info.max_http_header_data2 = SRV_HTTP_HEADER_BUFFER;
    /* every byte a client sends passes the wire guard before lws parses it (wire_guard_io.h) */
    if (srv_guard_io_start(SRV_HTTP_MAX_HEADERS, guard_wake, &d, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        srv_pipeline_destroy(d.pipe);
        return 1;
    }
    d.ctx = lws_create_context(&info);
    if (!d.ctx) {
        srv_log(SRV_LOG_ERROR, "cannot listen on %s%s%s:%d", listen_v6 ? "[" : "", listen_addr,
                listen_v6 ? "]" : "", d.cfg.port);
        srv_pipeline_destroy(d.pipe);
        return 1;
    }
    int port = lws_get_vhost_listen_port(lws_get_vhost_by_name(d.ctx, "default"));
    if (d.cfg.publish[0] &&
        srv_publisher_create(d.cfg.publish, d.cfg.subject, d.pipe, &d.metrics, &d.pub, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        lws_context_destroy(d.ctx);
        d.ctx = NULL;
        srv_pipeline_destroy(d.pipe);
        return 1;
    }
    tick_ctx = d.ctx;
    lws_sul_schedule(d.ctx, 0, &tick_sul, tick, 100 * LWS_US_PER_MS);

    if (srv_pipeline_start(d.pipe, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        srv_publisher_destroy(d.pub);
        lws_context_destroy(d.ctx);
        d.ctx = NULL;
        srv_pipeline_destroy(d.pipe);
        return 1;
    }
    srv_log(SRV_LOG_NOTICE, "listening on http://%s%s%s:%d/ (viewer at /, stream at /stream)",
            listen_v6 ? "[" : "", listen_addr, listen_v6 ? "]" : "", port);
    sd_notifyf(0, "READY=1\nSTATUS=serving %s on port %d\nMAINPID=%lu", d.cfg.model, port,
               (unsigned long)getpid());

    int status = 0;
    while (!sig_stop) {
        lws_service(d.ctx, 0);
        if (sig_reload) {
            sig_reload = 0;
            sd_notify(0, "RELOADING=1");
            reload_config(&d, &args);
            int r = srv_pipeline_reload(d.pipe, d.cfg.model, d.cfg.labels);
            if (r == -EBUSY)
                srv_log(SRV_LOG_WARN, "SIGHUP: a reload is already running");
            else if (r)
                srv_log(SRV_LOG_ERROR, "SIGHUP: cannot start reload: %s", strerror(-r));
            else
                srv_log(SRV_LOG_NOTICE, "SIGHUP: reloading %s", d.cfg.model);
            if (r && r != -EBUSY)
                sd_notify(0, "READY=1");
        }
        int ok;
        if (srv_pipeline_reload_done(d.pipe, &ok, err)) {
            if (ok) {
                srv_metrics_count(&d.metrics.reloads_ok, 1);
                srv_log(SRV_LOG_NOTICE, "reload of %s succeeded; swapping it in (within 100 ms, paused or not)",
                        d.cfg.model);
            } else {
                srv_metrics_count(&d.metrics.reloads_failed, 1);
                srv_log(SRV_LOG_ERROR, "reload failed, the old model keeps serving: %s", err);
            }
            sd_notify(0, "READY=1");
        }
    }

    srv_log(SRV_LOG_NOTICE, "stopping: closing %d clients", d.nsessions);
    sd_notify(0, "STOPPING=1");
    d.draining = 1;
    srv_stream_kick_all(&d);
    uint64_t until = srv_now_us() + 1000000u;
    while (d.nsessions > 0 && srv_now_us() < until)
        lws_service(d.ctx, 0);
    if (srv_pipeline_stop(d.pipe, err)) {
        srv_log(SRV_LOG_ERROR, "%s", err);
        status = 1;
    }
    srv_publisher_destroy(d.pub); /* after the pipeline's threads, before the pipeline */
    d.pub = NULL;
    lws_sul_cancel(&tick_sul);
    lws_context_destroy(d.ctx);
    srv_guard_io_stop();
    d.ctx = NULL;
    srv_pipeline_destroy(d.pipe);
    srv_log(SRV_LOG_NOTICE, "stopped");
    return status;
}
