/* http.c - meshsteerd's dynamic HTTP endpoints: /healthz (JSON) and /metrics (Prometheus text).
 * The viewer at / is a plain lws file mount (meshsteerd.c). Each request renders its body into a
 * per-request buffer, sends the headers, then the body in the WRITEABLE callback. */
#include "daemon.h"
#include "log.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

typedef struct http_req {
    char *body; /* LWS_PRE headroom before it */
    size_t len;
} http_req;

static char *healthz(srv_daemon *d)
{
    cJSON *h = cJSON_CreateObject();
    if (!h)
        return NULL;
    drv_state st = srv_pipeline_source_state(d->pipe);
    srv_gen *g = srv_pipeline_current(d->pipe);
    int ok = st == DRV_STATE_STREAMING || st == DRV_STATE_OPEN || st == DRV_STATE_ENDED;
    cJSON_AddStringToObject(h, "status", ok ? "ok" : "degraded");
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
    r->len = len;
    unsigned char hdr[LWS_PRE + 1024], *start = hdr + LWS_PRE, *p = start,
                                       *end = hdr + sizeof hdr - 1;
    if (lws_add_http_common_headers(wsi, status, type, (lws_filepos_t)len, &p, end) ||
        lws_add_http_header_by_token(wsi, WSI_TOKEN_HTTP_CACHE_CONTROL,
                                     (const unsigned char *)"no-store", 8, &p, end) ||
        lws_finalize_write_http_header(wsi, start, &p, end))
        return -1;
    lws_callback_on_writable(wsi);
    return 0;
}

static int callback_http(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in,
                         size_t len)
{
    srv_daemon *d = lws_context_user(lws_get_context(wsi));
    http_req *r = user;
    (void)in;
    switch (reason) {
    case LWS_CALLBACK_HTTP: {
        memset(r, 0, sizeof *r);
        char uri[256];
        if (lws_hdr_copy(wsi, uri, sizeof uri, WSI_TOKEN_GET_URI) <= 0) {
            static const char msg[] = "only GET\n";
            return respond(wsi, r, HTTP_STATUS_METHOD_NOT_ALLOWED, "text/plain", msg,
                           sizeof msg - 1);
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
            size_t need = srv_metrics_render(&d->metrics, up, NULL, 0);
            char *b = malloc(need + 1);
            if (!b)
                return -1;
            srv_metrics_render(&d->metrics, up, b, need + 1);
            int rc = respond(wsi, r, HTTP_STATUS_OK, "text/plain; version=0.0.4; charset=utf-8", b,
                             need);
            free(b);
            return rc;
        }
        static const char msg[] = "not found\n";
        return respond(wsi, r, HTTP_STATUS_NOT_FOUND, "text/plain", msg, sizeof msg - 1);
    }
    case LWS_CALLBACK_HTTP_WRITEABLE:
        if (!r->body)
            return -1;
        if (lws_write(wsi, (unsigned char *)r->body + LWS_PRE, r->len, LWS_WRITE_HTTP_FINAL) !=
            (int)r->len)
            return -1;
        free(r->body);
        r->body = NULL;
        return lws_http_transaction_completed(wsi) ? -1 : 0;
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
