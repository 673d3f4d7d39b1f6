/* http.c - meshsteerd's HTTP side: /healthz (JSON), /metrics (Prometheus text) and the viewer's
 * static files under web_root. Each request puts its body into a per-request buffer, sends the
 * headers, then the body in WRITEABLE callbacks (64 KiB per callback). The files are served here
 * rather than by an lws file mount because lws 4.1.6's file mount answers the second request on a
 * kept-alive connection with the first one's headers and no body. Paths are confined to web_root
 * (realpath). GET and HEAD (the same headers, no body); with --token, /healthz and /metrics
 * (which name the model path and source spec) need the token as /stream does.
 *
 * Request heads over SRV_HTTP_MAX_HEADERS bytes (431), over-long request-targets (414) and "%00"
 * (400) are refused by the wire guard (wire_guard_io.h) before lws parses them; a response
 * finished here tells it (srv_guard_io_answered), so that it answers a refused request pipelined
 * behind this one in order. */
#include "daemon.h"
#include "log.h"
#include "wire_guard_io.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

#include <limits.h>
#include <stdio.h>
#include <sys/stat.h>

#define HTTP_CHUNK 65536
#define HTTP_MAX_FILE (16u << 20)

#define HTTP_MAX_URI 255       /* no path of ours is longer */
#define HTTP_MAX_QUERY 1024    /* ?token=... is the only query we read (256 bytes at most) */

typedef struct http_req {
    char *body; /* LWS_PRE headroom before it */
    size_t len, sent;
    int head;   /* HEAD: headers only */
} http_req;

static char *healthz(srv_daemon *d)
{
    cJSON *h = cJSON_CreateObject();
    if (!h)
        return NULL;
    drv_state st = srv_pipeline_source_state(d->pipe);
    srv_gen *g = srv_pipeline_current(d->pipe);
    int ok = st == DRV_STATE_STREAMING || st == DRV_STATE_OPEN || st == DRV_STATE_ENDED;
    char why[200];
    int synth_bad = srv_pipeline_degraded(d->pipe, why, sizeof why);
    cJSON_AddStringToObject(h, "status", ok && !synth_bad ? "ok" : "degraded");
    if (synth_bad)
        cJSON_AddStringToObject(h, "reason", why);
    else if (!ok)
        cJSON_AddStringToObject(h, "reason", st == DRV_STATE_LOST ? "the source is lost"
                                                                  : "the source is not open");
    cJSON_AddNumberToObject(h, "protocol", SRV_PROTOCOL);
    cJSON_AddStringToObject(h, "version", MESHSTEER_VERSION);
    cJSON *m = cJSON_AddObjectToObject(h, "model");
    cJSON_AddStringToObject(m, "name", g->name);
    cJSON_AddStringToObject(m, "path", d->cfg.model);
    cJSON_AddNumberToObject(m, "generation", g->id);
    cJSON_AddNumberToObject(m, "vertices", g->nv);
    cJSON_AddNumberToObject(m, "faces", g->nf);
    cJSON_AddNumberToObject(m, "markers", g->nm);
    srv_gen_unref(g);
    cJSON_AddStringToObject(m, "kind", g->kind);
    cJSON_AddStringToObject(h, "driver", srv_pipeline_idle(d->pipe) ? "idle" : "tracked");
    cJSON *s = cJSON_AddObjectToObject(h, "source");
    cJSON_AddStringToObject(s, "spec", d->cfg.source);
    cJSON_AddStringToObject(s, "state", drv_state_name(st));
    cJSON_AddNumberToObject(h, "clients", d->nsessions);
    cJSON_AddNumberToObject(h, "frames_in", (double)atomic_load(&d->metrics.frames_in));
    cJSON_AddNumberToObject(h, "frames_synthesized", (double)atomic_load(&d->metrics.frames_synth));
    cJSON_AddNumberToObject(h, "frames_served", (double)atomic_load(&d->metrics.frames_out));
    cJSON_AddNumberToObject(h, "uptime_s", (double)(srv_now_us() - d->t_start_us) * 1e-6);
    char *txt = cJSON_PrintUnformatted(h);
    cJSON_Delete(h);
    return txt;
}

static int respond(struct lws *wsi, http_req *r, unsigned int status, const char *type,
                   const char *body, size_t len)
{
    r->body = malloc(LWS_PRE + len + 1);
    if (!r->body)
        return -1;
    memcpy(r->body + LWS_PRE, body, len);
    r->len = r->head ? 0 : len; /* HEAD: Content-Length of the GET, no body */
    unsigned char hdr[LWS_PRE + 1024], *start = hdr + LWS_PRE, *p = start,
                                       *end = hdr + sizeof hdr - 1;
    if (lws_add_http_common_headers(wsi, status, type, (lws_filepos_t)len, &p, end) ||
        lws_add_http_header_by_token(wsi, WSI_TOKEN_HTTP_CACHE_CONTROL,
                                     (const unsigned char *)"no-store", 8, &p, end) ||
        (status == HTTP_STATUS_METHOD_NOT_ALLOWED &&
         lws_add_http_header_by_name(wsi, (const unsigned char *)"allow:",
                                     (const unsigned char *)"GET, HEAD", 9, &p, end)) ||
        (status == HTTP_STATUS_UNAUTHORIZED &&
         lws_add_http_header_by_token(wsi, WSI_TOKEN_HTTP_WWW_AUTHENTICATE,
                                      (const unsigned char *)"Bearer", 6, &p, end)) ||
        lws_finalize_write_http_header(wsi, start, &p, end))
        return -1;
    lws_callback_on_writable(wsi);
    return 0;
}

static const char *mime_of(const char *path)
{
    static const struct { const char *ext, *type; } types[] = {
        {".html", "text/html; charset=utf-8"}, {".js", "text/javascript"},
        {".mjs", "text/javascript"}, {".css", "text/css"}, {".json", "application/json"},
        {".png", "image/png"}, {".svg", "image/svg+xml"}, {".ico", "image/x-icon"},
        {".txt", "text/plain; charset=utf-8"},
    };
    const char *dot = strrchr(path, '.');
    for (size_t i = 0; dot && i < sizeof types / sizeof types[0]; i++)
        if (!strcmp(dot, types[i].ext))
            return types[i].type;
    return "application/octet-stream";
}

/* Reads web_root/uri (index.html for directories) into *body; returns an HTTP status. */
static unsigned int read_static(const srv_daemon *d, const char *uri, char **body, size_t *len,
                                const char **type)
{
    char want[PATH_MAX * 2], real[PATH_MAX], root[PATH_MAX];
    if (!d->cfg.web_root[0] || !realpath(d->cfg.web_root, root))
        return HTTP_STATUS_NOT_FOUND;
    if (strstr(uri, "..") || strlen(uri) > PATH_MAX / 2)
        return HTTP_STATUS_FORBIDDEN;
    snprintf(want, sizeof want, "%s%s", root, uri);
    struct stat st;
    if (stat(want, &st) == 0 && S_ISDIR(st.st_mode))
        strncat(want, uri[strlen(uri) - 1] == '/' ? "index.html" : "/index.html",
                sizeof want - strlen(want) - 1);
    if (!realpath(want, real) || strncmp(real, root, strlen(root)) ||
        (real[strlen(root)] != '/' && real[strlen(root)] != '\0'))
        return HTTP_STATUS_NOT_FOUND;
    FILE *f = fopen(real, "rb");
    if (!f || fstat(fileno(f), &st) || !S_ISREG(st.st_mode) || (size_t)st.st_size > HTTP_MAX_FILE) {
        if (f)
            fclose(f);
        return HTTP_STATUS_NOT_FOUND;
    }
    *body = malloc((size_t)st.st_size + 1);
    size_t n = *body ? fread(*body, 1, (size_t)st.st_size, f) : 0;
    fclose(f);
    if (!*body || n != (size_t)st.st_size) {
        free(*body);
        *body = NULL;
        return HTTP_STATUS_INTERNAL_SERVER_ERROR;
    }
    *len = n;
    *type = mime_of(real);
    return HTTP_STATUS_OK;
}

/* A response is out: the next request on the connection, or its close when the wire guard refused
 * the next one (it has answered it then, when it could). */
static int transaction_done(struct lws *wsi)
{
    if (srv_guard_io_answered(wsi))
        return -1;
    return lws_http_transaction_completed(wsi) ? -1 : 0;
}

int srv_accept_guard(struct lws *wsi)
{
    if (!srv_guard_io_open(wsi))
        return 0;
    srv_log(SRV_LOG_WARN, "refused a connection: its socket number is beyond the wire guard's "
                          "table (RLIMIT_NOFILE)");
    return -1;
}

int srv_http_accept_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user,
                             void *in, size_t len)
{
    if (reason == LWS_CALLBACK_SERVER_NEW_CLIENT_INSTANTIATED)
        return srv_accept_guard(wsi);
    return lws_callback_http_dummy(wsi, reason, user, in, len);
}

static int callback_http(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in,
                         size_t len)
{
    srv_daemon *d = lws_context_user(lws_get_context(wsi));
    http_req *r = user;
    (void)in;
    switch (reason) {
    case LWS_CALLBACK_SERVER_NEW_CLIENT_INSTANTIATED:
        return srv_accept_guard(wsi);
    case LWS_CALLBACK_HTTP: {
        memset(r, 0, sizeof *r);
        if (srv_guard_io_http(wsi)) /* an Upgrade lws did not take, with frames behind it */
            return -1;
        char uri[HTTP_MAX_URI + 1];
        int ulen = lws_hdr_total_length(wsi, WSI_TOKEN_GET_URI);
        if (ulen <= 0) {
            ulen = lws_hdr_total_length(wsi, WSI_TOKEN_HEAD_URI);
            r->head = ulen > 0;
            if (!r->head) {
                static const char msg[] = "only GET and HEAD\n";
                return respond(wsi, r, HTTP_STATUS_METHOD_NOT_ALLOWED, "text/plain", msg,
                               sizeof msg - 1);
            }
        }
        if (ulen > HTTP_MAX_URI ||
            lws_hdr_total_length(wsi, WSI_TOKEN_HTTP_URI_ARGS) > HTTP_MAX_QUERY) {
            static const char msg[] = "URI too long\n";
            return respond(wsi, r, HTTP_STATUS_REQ_URI_TOO_LONG, "text/plain", msg,
                           sizeof msg - 1);
        }
        if (lws_hdr_copy(wsi, uri, sizeof uri, r->head ? WSI_TOKEN_HEAD_URI : WSI_TOKEN_GET_URI) !=
                ulen ||
            strlen(uri) != (size_t)ulen) { /* a NUL in the path (the wire guard refuses them) */
            static const char msg[] = "bad request\n";
            return respond(wsi, r, HTTP_STATUS_BAD_REQUEST, "text/plain", msg, sizeof msg - 1);
        }
        if ((!strcmp(uri, "/healthz") || !strcmp(uri, "/metrics")) && d->cfg.token[0] &&
            !srv_request_has_token(wsi, d->cfg.token)) {
            static const char msg[] = "token required (?token= or Authorization: Bearer)\n";
            return respond(wsi, r, HTTP_STATUS_UNAUTHORIZED, "text/plain", msg, sizeof msg - 1);
        }
        if (!strcmp(uri, "/healthz")) {
            char *b = healthz(d);
            if (!b)
                return -1;
            int rc = respond(wsi, r, HTTP_STATUS_OK, "application/json", b, strlen(b));
            cJSON_free(b);
            return rc;
        }
        if (!strcmp(uri, "/metrics")) {
            double up = (double)(srv_now_us() - d->t_start_us) * 1e-6;
            size_t base = srv_metrics_render(&d->metrics, up, NULL, 0);
            size_t need = base + srv_stream_render_clients(d, NULL, 0);
            char *b = malloc(need + 1);
            if (!b)
                return -1;
            srv_metrics_render(&d->metrics, up, b, base + 1);
            srv_stream_render_clients(d, b + base, need - base + 1);
            int rc = respond(wsi, r, HTTP_STATUS_OK, "text/plain; version=0.0.4; charset=utf-8", b,
                             need);
            free(b);
            return rc;
        }
        char *b = NULL;
        size_t n = 0;
        const char *type = "text/plain";
        unsigned int st = read_static(d, uri, &b, &n, &type);
        if (st != HTTP_STATUS_OK) {
            static const char msg[] = "not found\n";
            return respond(wsi, r, st, "text/plain", msg, sizeof msg - 1);
        }
        int rc = respond(wsi, r, st, type, b, n);
        free(b);
        return rc;
    }
    case LWS_CALLBACK_HTTP_WRITEABLE:
        if (!r->body)
            return -1;
        if (r->head) {
            free(r->body);
            r->body = NULL;
            return transaction_done(wsi);
        }
    {
        size_t n = r->len - r->sent > HTTP_CHUNK ? HTTP_CHUNK : r->len - r->sent;
        int final = r->sent + n == r->len;
        /* lws_write wants LWS_PRE writable bytes before the data: the previous chunk's tail, or
         * the buffer's own headroom for the first chunk */
        if (lws_write(wsi, (unsigned char *)r->body + LWS_PRE + r->sent, n,
                      final ? LWS_WRITE_HTTP_FINAL : LWS_WRITE_HTTP) != (int)n)
            return -1;
        r->sent += n;
        if (!final) {
            lws_callback_on_writable(wsi);
            return 0;
        }
    }
        free(r->body);
        r->body = NULL;
        return transaction_done(wsi);
    case LWS_CALLBACK_HTTP_DROP_PROTOCOL:
    case LWS_CALLBACK_CLOSED_HTTP:
        if (r) {
            free(r->body);
            r->body = NULL;
        }
        return 0;
    default:
        return lws_callback_http_dummy(wsi, reason, user, in, len);
    }
}

const struct lws_protocols srv_proto_http = {
    .name = "meshsteer-http",
    .callback = callback_http,
    .per_session_data_size = sizeof(http_req),
};
