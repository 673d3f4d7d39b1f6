/* publish_nats.c - the daemon's stream published to NATS subjects (see publish_nats.h). */
#include "publish_nats.h"
#include "control.h"
#include "daemon_config.h"
#include "encode.h"
#include "log.h"
#include "srv_err.h"

#include <errno.h>
#include <nats/nats.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SUBJECT_LEN 160
#define URLS_MAX 16

struct srv_publisher {
    srv_pipeline *pipe;
    srv_metrics *m;
    natsOptions *opts;
    natsConnection *nc;
    natsSubscription *get_hello, *get_topology, *get_params, *get_ping;
    char subj_hello[SUBJECT_LEN], subj_topology[SUBJECT_LEN], subj_params[SUBJECT_LEN];
    char subj_get_hello[SUBJECT_LEN], subj_get_topology[SUBJECT_LEN], subj_get_params[SUBJECT_LEN];
    char subj_get_ping[SUBJECT_LEN];
    char subj_frames[SRV_ENC_COUNT][SUBJECT_LEN];

    pthread_t thread;
    int started;
    pthread_mutex_t lock; /* kick, stop */
    pthread_cond_t cond;
    int kick, stop;
    atomic_int announce; /* (re)connected: publish hello and topology again */
    atomic_int closing;  /* srv_publisher_destroy: the disconnection is ours */

    /* the publisher thread's own */
    uint32_t announced_gen; /* generation whose hello and topology went out (0: none) */
    uint64_t last_seq;      /* newest frame published */
    uint32_t skipped;       /* frames superseded since the last frame published */
    unsigned char *copy;    /* every encoding of one frame, back to back */
    size_t copy_cap;
};

static void on_connected(natsConnection *nc, void *closure)
{
    srv_publisher *p = closure;
    char url[256] = "";
    natsConnection_GetConnectedUrl(nc, url, sizeof url);
    srv_log(SRV_LOG_NOTICE, "nats: connected to %s", url);
    atomic_store(&p->m->nats_connected, 1);
    atomic_store(&p->announce, 1);
    srv_publisher_notify(p);
}

static void on_disconnected(natsConnection *nc, void *closure)
{
    srv_publisher *p = closure;
    (void)nc;
    if (atomic_exchange(&p->m->nats_connected, 0) && !atomic_load(&p->closing))
        srv_log(SRV_LOG_WARN, "nats: disconnected; frames are dropped until libnats reconnects");
}

static void on_reconnected(natsConnection *nc, void *closure)
{
    srv_publisher *p = closure;
    srv_metrics_count(&p->m->nats_reconnects, 1);
    on_connected(nc, closure);
}

static void on_error(natsConnection *nc, natsSubscription *sub, natsStatus s, void *closure)
{
    (void)nc, (void)sub, (void)closure;
    srv_log(SRV_LOG_WARN, "nats: %s", natsStatus_GetText(s));
}

/* P.get.hello / P.get.topology: the current generation's message; P.get.ping: the daemon's clock
 * as /stream's pong gives it (the viewer's clock offset). To the request's reply subject, from
 * libnats' delivery thread. */
static void on_get(natsConnection *nc, natsSubscription *sub, natsMsg *msg, void *closure)
{
    srv_publisher *p = closure;
    (void)sub;
    const char *reply = natsMsg_GetReply(msg), *subject = natsMsg_GetSubject(msg);
    if (reply && *reply) {
        natsStatus s;
        if (!strcmp(subject, p->subj_get_ping)) {
            char pong[SRV_REPLY_LEN];
            size_t n = srv_reply_pong(pong, NULL, srv_now_us());
            s = natsConnection_Publish(nc, reply, pong, (int)n);
        } else {
            srv_gen *g = srv_pipeline_current(p->pipe);
            const unsigned char *data = g->topo;
            size_t len = g->topo_len;
            if (!strcmp(subject, p->subj_get_hello))
                data = g->hello, len = g->hello_len;
            else if (!strcmp(subject, p->subj_get_params)) /* MSPM; 0 layouts: the kind has none */
                data = g->params, len = g->params_len;
            s = natsConnection_Publish(nc, reply, data, (int)len);
            srv_gen_unref(g);
        }
        if (s == NATS_OK) {
            srv_metrics_count(&p->m->nats_requests, 1);
        } else {
            srv_metrics_count(&p->m->nats_drops[SRV_NATS_DROP_ERROR], 1);
            srv_log(SRV_LOG_WARN, "nats: cannot answer %s: %s", subject, natsStatus_GetText(s));
        }
    }
    natsMsg_Destroy(msg);
}

/* One message out, counted; a drop reason when it cannot go now. */
static int publish_one(srv_publisher *p, const char *subject, const unsigned char *data,
                       size_t len)
{
    if (natsConnection_Status(p->nc) != NATS_CONN_STATUS_CONNECTED) {
        srv_metrics_count(&p->m->nats_drops[SRV_NATS_DROP_DISCONNECTED], 1);
        return -ENOTCONN;
    }
    int buffered = natsConnection_Buffered(p->nc);
    if (buffered < 0 || (size_t)buffered + len > SRV_NATS_PENDING_MAX) {
        srv_metrics_count(&p->m->nats_drops[SRV_NATS_DROP_PENDING], 1);
        return -EAGAIN;
    }
    natsStatus s = natsConnection_Publish(p->nc, subject, data, (int)len);
    if (s != NATS_OK) {
        srv_metrics_count(&p->m->nats_drops[SRV_NATS_DROP_ERROR], 1);
        srv_log(SRV_LOG_DEBUG, "nats: publish %s (%zu bytes): %s", subject, len,
                natsStatus_GetText(s));
        return -EIO;
    }
    srv_metrics_count(&p->m->nats_msgs, 1);
    srv_metrics_count(&p->m->nats_bytes, len);
    return 0;
}

/* Copies frame f's messages into p->copy, leaving out the two fields the lws thread writes while
 * the frame is shared (skipped, send time), which get this publisher's own values. Returns the
 * total length, or 0 when the buffer cannot be grown (the frame is dropped). Sized once per
 * generation in practice: a frame's size is fixed by its model. */
static size_t copy_frame(srv_publisher *p, const srv_frame *f, size_t off[SRV_ENC_COUNT])
{
    size_t total = 0;
    for (int e = 0; e < SRV_ENC_COUNT; e++)
        total += f->msg[e] ? f->len[e] : 0;
    if (total > p->copy_cap) {
        unsigned char *c = realloc(p->copy, total);
        if (!c)
            return 0;
        p->copy = c;
        p->copy_cap = total;
    }
    size_t at = 0;
    for (int e = 0; e < SRV_ENC_COUNT; e++) {
        off[e] = at;
        if (!f->msg[e] || !f->len[e])
            continue;
        const unsigned char *src = f->msg[e];
        unsigned char *dst = p->copy + at;
        size_t len = f->len[e];
        if (len >= SRV_FRAME_HEADER) {
            memcpy(dst, src, SRV_FRAME_OFF_SKIPPED);
            memcpy(dst + SRV_FRAME_OFF_SEQ, src + SRV_FRAME_OFF_SEQ,
                   SRV_FRAME_OFF_SEND - SRV_FRAME_OFF_SEQ);
            memcpy(dst + SRV_FRAME_HEADER, src + SRV_FRAME_HEADER, len - SRV_FRAME_HEADER);
        } else {
            memcpy(dst, src, len);
        }
        at += len;
    }
    return at;
}

/* A new model: its hello, topology and params model (MSPM, for params subscribers). */
static void announce(srv_publisher *p, srv_gen *g)
{
    if (publish_one(p, p->subj_hello, g->hello, g->hello_len) == 0 &&
        publish_one(p, p->subj_topology, g->topo, g->topo_len) == 0 &&
        (!g->params_len || publish_one(p, p->subj_params, g->params, g->params_len) == 0))
        p->announced_gen = g->id;
}

/* The newest frame, if newer than the last one published. */
static void publish_latest(srv_publisher *p)
{
    srv_frame *f = srv_pipeline_latest(p->pipe);
    if (!f)
        return;
    if (f->seq <= p->last_seq) {
        srv_frame_unref(f);
        return;
    }
    /* a new model's hello and topology before its first frame (not while disconnected: the
     * connection's callback asks for them again) */
    if (natsConnection_Status(p->nc) == NATS_CONN_STATUS_CONNECTED &&
        (atomic_exchange(&p->announce, 0) || f->gen->id != p->announced_gen))
        announce(p, f->gen);
    uint64_t superseded = p->last_seq ? f->seq - p->last_seq - 1 : 0;
    int nenc = 0;
    size_t off[SRV_ENC_COUNT], len[SRV_ENC_COUNT];
    for (int e = 0; e < SRV_ENC_COUNT; e++) {
        len[e] = f->msg[e] ? f->len[e] : 0;
        nenc += len[e] > 0;
    }
    size_t total = copy_frame(p, f, off);
    p->last_seq = f->seq;
    srv_frame_unref(f);
    srv_metrics_count(&p->m->nats_drops[SRV_NATS_DROP_SUPERSEDED], superseded * (uint64_t)nenc);
    p->skipped += (uint32_t)superseded;
    if (!total) {
        srv_metrics_count(&p->m->nats_drops[SRV_NATS_DROP_ERROR], (uint64_t)nenc);
        p->skipped++;
        return;
    }
    int any = 0;
    for (int e = 0; e < SRV_ENC_COUNT; e++) {
        /* a frame with no params form goes to params subscribers as int16, as on /stream */
        int src = e == SRV_ENC_PARAMS && !len[e] ? SRV_ENC_INT16 : e;
        if (!len[src])
            continue;
        unsigned char *msg = p->copy + off[src];
        if (src == e && len[e] >= SRV_FRAME_HEADER) {
            srv_put_u32(msg + SRV_FRAME_OFF_SKIPPED, p->skipped);
            srv_put_u64(msg + SRV_FRAME_OFF_SEND, srv_now_us());
        }
        any |= publish_one(p, p->subj_frames[e], msg, len[src]) == 0;
    }
    p->skipped = any ? 0 : p->skipped + 1;
}

static void *publisher_main(void *arg)
{
    srv_publisher *p = arg;
    pthread_mutex_lock(&p->lock);
    while (!p->stop) {
        if (!p->kick) {
            /* a timed wait so a (re)connect announcement goes out without a frame too */
            struct timespec ts;
            clock_gettime(CLOCK_REALTIME, &ts);
            ts.tv_nsec += 100 * 1000000L;
            if (ts.tv_nsec >= 1000000000L) {
                ts.tv_sec++;
                ts.tv_nsec -= 1000000000L;
            }
            pthread_cond_timedwait(&p->cond, &p->lock, &ts);
        }
        if (p->stop)
            break;
        p->kick = 0;
        pthread_mutex_unlock(&p->lock);
        if (atomic_load(&p->announce) && atomic_load(&p->m->nats_connected)) {
            srv_gen *g = srv_pipeline_current(p->pipe);
            atomic_store(&p->announce, 0);
            announce(p, g);
            srv_gen_unref(g);
        }
        publish_latest(p);
        pthread_mutex_lock(&p->lock);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

void srv_publisher_notify(srv_publisher *p)
{
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    p->kick = 1;
    pthread_cond_signal(&p->cond);
    pthread_mutex_unlock(&p->lock);
}

/* The comma list as libnats wants it: an array of URL strings (in `store`). */
static int split_urls(const char *urls, char *store, size_t cap, const char **out, int *n,
                      char *err)
{
    if (strlen(urls) >= cap)
        return srv_err(err, -ENAMETOOLONG, "publish: URL list too long");
    strcpy(store, urls);
    *n = 0;
    for (char *save = NULL, *u = strtok_r(store, ",", &save); u; u = strtok_r(NULL, ",", &save)) {
        while (*u == ' ')
            u++;
        if (*n == URLS_MAX)
            return srv_err(err, -E2BIG, "publish: more than %d servers", URLS_MAX);
        out[(*n)++] = u;
    }
    return *n ? 0 : srv_err(err, -EINVAL, "publish: no server URL");
}

/* Every option of the connection: the servers, reconnecting forever, the buffers, the callbacks. */
static natsStatus set_options(srv_publisher *p, const char **list, int n)
{
    natsOptions *o = p->opts;
    natsStatus s = natsOptions_SetServers(o, list, n);
    if (s == NATS_OK) /* the first URL is the preferred node */
        s = natsOptions_SetNoRandomize(o, true);
    if (s == NATS_OK)
        s = natsOptions_SetName(o, "meshsteerd");
    if (s == NATS_OK)
        s = natsOptions_SetAllowReconnect(o, true);
    if (s == NATS_OK)
        s = natsOptions_SetMaxReconnect(o, -1); /* forever */
    if (s == NATS_OK)
        s = natsOptions_SetReconnectWait(o, SRV_NATS_RECONNECT_MS);
    if (s == NATS_OK)
        s = natsOptions_SetRetryOnFailedConnect(o, true, on_connected, p);
    if (s == NATS_OK) /* room for a few frames of every encoding; beyond it frames drop */
        s = natsOptions_SetIOBufSize(o, SRV_NATS_PENDING_MAX);
    if (s == NATS_OK)
        s = natsOptions_SetReconnectBufSize(o, SRV_NATS_PENDING_MAX);
    if (s == NATS_OK) /* a server that stops reading: the connection is dropped and remade */
        s = natsOptions_SetWriteDeadline(o, 2000);
    if (s == NATS_OK)
        s = natsOptions_SetDisconnectedCB(o, on_disconnected, p);
    if (s == NATS_OK)
        s = natsOptions_SetReconnectedCB(o, on_reconnected, p);
    if (s == NATS_OK)
        s = natsOptions_SetErrorHandler(o, on_error, p);
    return s;
}

int srv_publisher_create(const char *urls, const char *prefix, srv_pipeline *pipe,
                         srv_metrics *m, srv_publisher **out, char *err)
{
    *out = NULL;
    srv_publisher *p = calloc(1, sizeof *p);
    if (!p)
        return srv_err(err, -ENOMEM, "nats: out of memory");
    p->pipe = pipe;
    p->m = m;
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->cond, NULL);
    snprintf(p->subj_hello, SUBJECT_LEN, "%s.hello", prefix);
    snprintf(p->subj_topology, SUBJECT_LEN, "%s.topology", prefix);
    snprintf(p->subj_get_hello, SUBJECT_LEN, "%s.get.hello", prefix);
    snprintf(p->subj_get_topology, SUBJECT_LEN, "%s.get.topology", prefix);
    snprintf(p->subj_params, SUBJECT_LEN, "%s.params", prefix);
    snprintf(p->subj_get_params, SUBJECT_LEN, "%s.get.params", prefix);
    snprintf(p->subj_get_ping, SUBJECT_LEN, "%s.get.ping", prefix);
    for (int e = 0; e < SRV_ENC_COUNT; e++)
        snprintf(p->subj_frames[e], SUBJECT_LEN, "%s.frames.%s", prefix, srv_encoding_name(e));

    int r = 0;
    char store[SRV_PATH_LEN];
    const char *list[URLS_MAX];
    int n = 0;
    if ((r = split_urls(urls, store, sizeof store, list, &n, err)))
        goto fail;
    natsStatus s = natsOptions_Create(&p->opts);
    if (s == NATS_OK)
        s = set_options(p, list, n);
    if (s != NATS_OK) {
        r = srv_err(err, -EINVAL, "nats: options: %s", natsStatus_GetText(s));
        goto fail;
    }
    atomic_store(&m->nats_enabled, 1);
    s = natsConnection_Connect(&p->nc, p->opts);
    if (s == NATS_NOT_YET_CONNECTED) {
        srv_log(SRV_LOG_WARN, "nats: no server of %s answers yet; retrying every %d ms", urls,
                SRV_NATS_RECONNECT_MS);
    } else if (s != NATS_OK) {
        r = srv_err(err, -ECONNREFUSED, "nats: connect to %s: %s", urls, natsStatus_GetText(s));
        goto fail;
    } else {
        on_connected(p->nc, p);
    }
    /* subscriptions made while not yet connected are sent once libnats connects */
    s = natsConnection_Subscribe(&p->get_hello, p->nc, p->subj_get_hello, on_get, p);
    if (s == NATS_OK)
        s = natsConnection_Subscribe(&p->get_topology, p->nc, p->subj_get_topology, on_get, p);
    if (s == NATS_OK)
        s = natsConnection_Subscribe(&p->get_params, p->nc, p->subj_get_params, on_get, p);
    if (s == NATS_OK)
        s = natsConnection_Subscribe(&p->get_ping, p->nc, p->subj_get_ping, on_get, p);
    if (s != NATS_OK) {
        r = srv_err(err, -EIO, "nats: subscribe to %s.get.*: %s", prefix, natsStatus_GetText(s));
        goto fail;
    }
    if (pthread_create(&p->thread, NULL, publisher_main, p)) {
        r = srv_err(err, -EAGAIN, "nats: cannot start the publisher thread");
        goto fail;
    }
    p->started = 1;
    srv_log(SRV_LOG_NOTICE, "nats: publishing to %s under %s.{hello,topology,params,frames.*}", urls,
            prefix);
    *out = p;
    return 0;
fail:
    srv_publisher_destroy(p);
    return r;
}

void srv_publisher_destroy(srv_publisher *p)
{
    if (!p)
        return;
    if (p->started) {
        pthread_mutex_lock(&p->lock);
        p->stop = 1;
        pthread_cond_signal(&p->cond);
        pthread_mutex_unlock(&p->lock);
        pthread_join(p->thread, NULL);
    }
    atomic_store(&p->closing, 1);
    natsSubscription_Destroy(p->get_hello);
    natsSubscription_Destroy(p->get_topology);
    natsSubscription_Destroy(p->get_params);
    natsSubscription_Destroy(p->get_ping);
    if (p->nc) {
        natsConnection_Close(p->nc);
        natsConnection_Destroy(p->nc);
    }
    natsOptions_Destroy(p->opts);
    /* libnats delivers the connection's callbacks (disconnected, closed) and the requests' on
     * threads of its own, possibly after the calls above returned: p lives until they are gone */
    natsStatus s = nats_CloseAndWait(5000);
    atomic_store(&p->m->nats_connected, 0);
    if (s != NATS_OK) {
        srv_log(SRV_LOG_WARN, "nats: the library's threads did not stop in 5 s (%s); its "
                "state is left in place", natsStatus_GetText(s));
        return;
    }
    pthread_cond_destroy(&p->cond);
    pthread_mutex_destroy(&p->lock);
    free(p->copy);
    free(p);
}
