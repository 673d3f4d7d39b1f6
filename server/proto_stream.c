/* proto_stream.c - the /stream WebSocket protocol of meshsteerd (docs/PROTOCOL.md).
 *
 * Per session: hello (JSON) -> topology (binary) -> [params model, once per generation, for a
 * session in the params encoding] -> frames, newest first: when the session is
 * writable it gets the latest published frame if it has not had it, so a slow client skips frames
 * (counted per session and in /metrics) instead of queueing them, and costs at most one frame in
 * lws's send buffer. One lws_write per WRITEABLE callback, from buffers with LWS_PRE headroom.
 * The pipeline wakes this thread with lws_cancel_service (EVENT_WAIT_CANCELLED).
 * Control messages are validated (control.c); replies queue per session (SRV_REPLY_QUEUE); a
 * message larger than max_message closes that connection with 1009, a client that leaves a frame
 * unaccepted for idle_timeout seconds is closed by an lws timeout.
 * Writes: a frame goes out in one send() (tx_packet_size) into a socket buffer sized to take it
 * whole (size_send_buffer), so lws never has to keep a remainder (/metrics partial_writes). */
#include "control.h"
#include "daemon.h"
#include "log.h"
#include "wire_guard.h"
#include "wire_guard_io.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#define SRV_SNDBUF_MIN (128 * 1024)
#define SRV_SNDBUF_MAX (4 * 1024 * 1024) /* Linux caps it at net.core.wmem_max anyway */

static srv_daemon *daemon_of(struct lws *wsi)
{
    return lws_context_user(lws_get_context(wsi));
}

static int same_secret(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    unsigned char diff = (unsigned char)(la != lb);
    for (size_t i = 0; i < la; i++)
        diff |= (unsigned char)(a[i] ^ b[i % (lb ? lb : 1)]);
    return diff == 0;
}

int srv_request_has_token(struct lws *wsi, const char *token)
{
    char buf[1024];
    const char *t = lws_get_urlarg_by_name(wsi, "token=", buf, sizeof buf);
    if (t && same_secret(t, token))
        return 1;
    return lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_HTTP_AUTHORIZATION) > 0 &&
           !strncmp(buf, "Bearer ", 7) && same_secret(buf + 7, token);
}

/* 0 to accept the upgrade, 1 to refuse (logged with the reason). */
static int filter(srv_daemon *d, struct lws *wsi)
{
    char buf[1024], host[512];
    const char *why = NULL;
    if (lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_GET_URI) <= 0 || strcmp(buf, "/stream"))
        why = "path is not /stream";
    else if (d->draining)
        why = "shutting down";
    else if (d->nsessions >= d->cfg.max_clients)
        why = "too many clients";
    if (!why && d->cfg.token[0] && !srv_request_has_token(wsi, d->cfg.token))
        why = "missing or wrong token";
    if (!why && strcmp(d->cfg.origin, "any")) {
        int n = lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_ORIGIN);
        if (n <= 0) {
            why = "no Origin header";
        } else if (!strcmp(d->cfg.origin, "same")) {
            int hn = lws_hdr_copy(wsi, host, sizeof host, WSI_TOKEN_HOST);
            /* the daemon speaks plain HTTP: its own pages' origin is http://HOST, and an https://
             * page is another origin (RFC 6454 Sec. 4: the scheme is part of it) */
            const char *o = !strncmp(buf, "http://", 7) ? buf + 7 : NULL;
            if (hn <= 0 || !o || strcmp(o, host))
                why = "Origin does not match Host";
        } else {
            int ok = 0;
            char list[sizeof d->cfg.origin];
            snprintf(list, sizeof list, "%s", d->cfg.origin);
            for (char *save = NULL, *o = strtok_r(list, ",", &save); o && !ok;
                 o = strtok_r(NULL, ",", &save)) {
                while (*o == ' ')
                    o++;
                ok = !strcmp(o, buf);
            }
            if (!ok)
                why = "Origin not allowed";
        }
    }
    if (!why)
        return 0;
    char peer[128] = "?";
    lws_get_peer_simple(wsi, peer, sizeof peer);
    if (lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_ORIGIN) <= 0)
        buf[0] = '\0';
    if (lws_hdr_copy(wsi, host, sizeof host, WSI_TOKEN_HOST) <= 0)
        host[0] = '\0';
    for (char *p = buf; *p; p++) /* the log shows what the client sent, printable only */
        *p = *p < 0x20 || *p > 0x7e ? '?' : *p;
    for (char *p = host; *p; p++)
        *p = *p < 0x20 || *p > 0x7e ? '?' : *p;
    srv_log(SRV_LOG_INFO, "refused /stream connection from %s (Origin '%s', Host '%s'): %s", peer,
            buf, host, why);
    srv_metrics_count(&d->metrics.clients_rejected, 1);
    return 1;
}

static unsigned char *reply_slot(srv_session *s, int k)
{
    return (unsigned char *)s->replies + (size_t)k * (LWS_PRE + SRV_REPLY_LEN) + LWS_PRE;
}

/* Queues a reply; returns -1 when the queue is full (the client sends without reading). */
static int queue_reply(srv_session *s, const char *txt, size_t len)
{
    if (s->nreplies == SRV_REPLY_QUEUE)
        return -1;
    int k = (s->reply_head + s->nreplies) % SRV_REPLY_QUEUE;
    if (len > SRV_REPLY_LEN)
        len = SRV_REPLY_LEN;
    memcpy(reply_slot(s, k), txt, len);
    s->reply_len[k] = len;
    s->nreplies++;
    lws_callback_on_writable(s->wsi);
    return 0;
}

/* The socket's send buffer, sized so that one whole frame (of either encoding) always fits: with
 * Linux's default (16 KB, autotuned from there) nearly every frame write of a mesh was partial,
 * and lws then copies the rest into a fresh heap buffer and sends it from a later POLLOUT, an
 * allocation, a copy and a poll round per frame and client. About two frames' worth (Linux
 * doubles the value) also bounds what a slow client has queued in the kernel on our side
 * (latest-frame-wins applies above that). */
static void size_send_buffer(srv_daemon *d, struct lws *wsi)
{
    srv_gen *g = srv_pipeline_current(d->pipe);
    size_t frame = srv_frame_size(SRV_ENC_FLOAT32, g->nv, g->nm);
    srv_gen_unref(g);
    size_t want = frame + 65536; /* Linux doubles it for its bookkeeping */
    if (want < SRV_SNDBUF_MIN)
        want = SRV_SNDBUF_MIN;
    if (want > SRV_SNDBUF_MAX)
        want = SRV_SNDBUF_MAX;
    int v = (int)want, fd = lws_get_socket_fd(wsi);
    if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &v, sizeof v))
        srv_log(SRV_LOG_DEBUG, "SO_SNDBUF %d: %s", v, strerror(errno));
}

static int reply_error(srv_daemon *d, srv_session *s, const char *code, const char *msg,
                       const srv_control *c)
{
    char buf[SRV_REPLY_LEN];
    size_t n = srv_reply_error(buf, code, msg, c);
    srv_metrics_count(&d->metrics.control_errors, 1);
    return queue_reply(s, buf, n);
}

static int handle_message(srv_daemon *d, srv_session *s)
{
    if (s->rx_binary)
        return reply_error(d, s, "binary_not_accepted",
                           "control messages are JSON text frames; binary frames are not accepted",
                           NULL);
    srv_control c;
    const char *code;
    char msg[256], buf[SRV_REPLY_LEN];
    if (srv_control_parse((const char *)s->rx, s->rx_len, &c, &code, msg, sizeof msg))
        return reply_error(d, s, code, msg, &c);
    size_t n;
    switch (c.kind) {
    case SRV_CTL_ENCODING:
        s->encoding = c.encoding;
        srv_metrics_count(&d->metrics.control_ok, 1);
        n = srv_reply_ack(buf, &c, -1);
        return queue_reply(s, buf, n);
    case SRV_CTL_PING:
        srv_metrics_count(&d->metrics.control_ok, 1);
        n = srv_reply_pong(buf, &c, srv_now_us());
        return queue_reply(s, buf, n);
    default: {
        /* what the source takes now, from the pipeline's snapshot: the source itself belongs to
         * the source thread, which rewrites it when it reopens a lost device */
        unsigned accepted = srv_pipeline_controls(d->pipe);
        const char *scheme = srv_pipeline_source_info(d->pipe)->scheme;
        if (!(accepted & SRV_CTL_BIT(c.kind))) {
            char why[160], list[64];
            srv_controls_text(accepted, list, sizeof list);
            if (list[0])
                snprintf(why, sizeof why, "the %s source takes no '%s' (it takes: %s)", scheme,
                         c.type, list);
            else
                snprintf(why, sizeof why, "the %s source takes no controls", scheme);
            return reply_error(d, s, "unsupported", why, &c);
        }
        if (srv_pipeline_control(d->pipe, s->tag, &c))
            return reply_error(d, s, "busy", "too many controls pending; try again", &c);
        return 0; /* the reply comes back from the source thread */
    }
    }
}

/* A client that is streaming and has not been written frames up to seq - 1 skipped them: they are
 * superseded by frame seq (latest-frame-wins). Counted as soon as a newer frame exists, so that a
 * client that never becomes writable (a stalled socket) is counted too, not only at its next
 * write. */
static void account_skips(srv_daemon *d, srv_session *s, uint64_t seq)
{
    if (s->stage != 2 || seq == 0 || s->accounted_seq == 0 || seq - 1 <= s->accounted_seq) {
        if (s->stage == 2 && s->accounted_seq == 0)
            s->accounted_seq = seq ? seq - 1 : 0; /* a new client owes nothing for earlier frames */
        return;
    }
    uint64_t n = seq - 1 - s->accounted_seq;
    s->accounted_seq = seq - 1;
    s->skipped += n;
    s->skip_pending = (uint32_t)(s->skip_pending + n > UINT32_MAX ? UINT32_MAX : s->skip_pending + n);
    srv_metrics_count(&d->metrics.drops[SRV_DROP_CLIENT_SLOW], n);
}

size_t srv_stream_render_clients(const srv_daemon *d, char *buf, size_t cap)
{
    size_t at = 0;
    char line[160];
    static const char head[] =
        "# HELP meshsteer_client_frames_total Frames written to each connected client.\n"
        "# TYPE meshsteer_client_frames_total counter\n"
        "# HELP meshsteer_client_skipped_frames_total Frames each connected client skipped because "
        "a newer one replaced them before it could take them.\n"
        "# TYPE meshsteer_client_skipped_frames_total counter\n";
    if (buf && at + sizeof head - 1 < cap)
        memcpy(buf + at, head, sizeof head - 1);
    at += sizeof head - 1;
    for (const srv_session *s = d->sessions; s; s = s->next) {
        int w = snprintf(line, sizeof line,
                         "meshsteer_client_frames_total{client=\"%llu\"} %llu\n"
                         "meshsteer_client_skipped_frames_total{client=\"%llu\"} %llu\n",
                         (unsigned long long)s->tag, (unsigned long long)s->frames,
                         (unsigned long long)s->tag, (unsigned long long)s->skipped);
        if (w <= 0)
            continue;
        if (buf && at + (size_t)w < cap)
            memcpy(buf + at, line, (size_t)w);
        at += (size_t)w;
    }
    if (buf && at < cap)
        buf[at] = '\0';
    return at;
}

static int write_frame_or_nothing(srv_daemon *d, srv_session *s, struct lws *wsi)
{
    srv_frame *f = srv_pipeline_latest(d->pipe);
    srv_gen *target = f ? f->gen : NULL;
    if (!target) { /* nothing synthesised yet: greet with the current generation */
        srv_gen *cur = srv_pipeline_current(d->pipe);
        if (s->gen != cur) {
            srv_gen_unref(s->gen);
            s->gen = cur;
            s->stage = 0;
        } else {
            srv_gen_unref(cur);
        }
    } else if (s->gen != target) {
        srv_gen_unref(s->gen);
        srv_gen_ref(target);
        s->gen = target;
        s->stage = 0;
    }

    int r = 0, more = 0;
    if (s->stage == 0) {
        r = lws_write(wsi, s->gen->hello, s->gen->hello_len, LWS_WRITE_TEXT);
        srv_metrics_count(&d->metrics.bytes_out, s->gen->hello_len);
        s->stage = 1;
        more = 1;
    } else if (s->stage == 1) {
        r = lws_write(wsi, s->gen->topo, s->gen->topo_len, LWS_WRITE_BINARY);
        srv_metrics_count(&d->metrics.bytes_out, s->gen->topo_len);
        s->stage = 2;
        more = 1;
    } else if (s->nreplies) {
        int k = s->reply_head;
        r = lws_write(wsi, reply_slot(s, k), s->reply_len[k], LWS_WRITE_TEXT);
        srv_metrics_count(&d->metrics.bytes_out, s->reply_len[k]);
        s->reply_head = (k + 1) % SRV_REPLY_QUEUE;
        s->nreplies--;
        more = 1;
    } else if (s->encoding == SRV_ENC_PARAMS && s->params_sent != s->gen->id) {
        /* a params client gets the generation's compact form once, before its first frame */
        r = lws_write(wsi, s->gen->params, s->gen->params_len, LWS_WRITE_BINARY);
        srv_metrics_count(&d->metrics.bytes_out, s->gen->params_len);
        s->params_sent = s->gen->id;
        more = 1;
    } else if (f && f->seq > s->last_seq) {
        int enc = s->encoding;
        if (enc == SRV_ENC_PARAMS && f->len[enc] == 0)
            enc = SRV_ENC_INT16; /* a frame of a kind without a compact form */
        unsigned char *m = f->msg[enc];
        size_t len = f->len[enc];
        account_skips(d, s, f->seq);
        uint64_t now = srv_now_us();
        srv_put_u32(m + SRV_FRAME_OFF_SKIPPED, s->skip_pending);
        s->skip_pending = 0;
        srv_put_u64(m + SRV_FRAME_OFF_SEND, now);
        r = lws_write(wsi, m, len, LWS_WRITE_BINARY);
        if (r >= 0 && lws_partial_buffered(wsi))
            srv_metrics_count(&d->metrics.partial_writes, 1);
        s->last_seq = f->seq;
        s->accounted_seq = f->seq;
        s->frames++;
        srv_metrics_count(&d->metrics.frames_out, 1);
        srv_metrics_count(&d->metrics.bytes_out, len);
        srv_hist_observe(&d->metrics.latency, now > f->t_capture_us ? now - f->t_capture_us : 0);
        if (s->timeout_armed) {
            lws_set_timeout(wsi, NO_PENDING_TIMEOUT, 0);
            s->timeout_armed = 0;
        }
    }
    if (f && f->seq > s->last_seq)
        more = 1;
    srv_frame_unref(f);
    if (r < 0)
        return -1;
    if (more || s->nreplies)
        lws_callback_on_writable(wsi);
    return 0;
}

static void wake_sessions(srv_daemon *d)
{
    srv_ctl_result res;
    while (srv_pipeline_result(d->pipe, &res))
        for (srv_session *s = d->sessions; s; s = s->next)
            if (s->tag == res.tag && queue_reply(s, res.reply, res.len))
                lws_set_timeout(s->wsi, PENDING_TIMEOUT_USER_OK, LWS_TO_KILL_ASYNC);
    srv_frame *f = srv_pipeline_latest(d->pipe);
    uint64_t now = srv_now_us();
    for (srv_session *s = d->sessions; s; s = s->next) {
        if (srv_guard_io_verdict(s->wsi)) /* closed in its WRITEABLE callback */
            lws_callback_on_writable(s->wsi);
        if (f && f->gen == s->gen)
            account_skips(d, s, f->seq);
        if (d->draining || (f && (f->seq > s->last_seq || f->gen != s->gen))) {
            lws_callback_on_writable(s->wsi);
            if (!s->timeout_armed && !d->draining) {
                lws_set_timeout(s->wsi, PENDING_TIMEOUT_USER_OK, d->cfg.idle_timeout);
                s->timeout_armed = 1;
                s->armed_at_us = now;
            }
        }
    }
    srv_frame_unref(f);
}

void srv_stream_kick_all(srv_daemon *d)
{
    wake_sessions(d);
}

static int callback_stream(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in,
                           size_t len)
{
    srv_daemon *d = daemon_of(wsi);
    srv_session *s = user;
    switch (reason) {
    case LWS_CALLBACK_SERVER_NEW_CLIENT_INSTANTIATED: /* lws 4.1 gives it the default protocol */
        return srv_accept_guard(wsi);

    case LWS_CALLBACK_FILTER_PROTOCOL_CONNECTION:
        return filter(d, wsi);

    case LWS_CALLBACK_ESTABLISHED: {
        memset(s, 0, sizeof *s);
        s->wsi = wsi;
        s->tag = ++d->next_tag;
        s->encoding = d->cfg.encoding;
        s->rx = malloc((size_t)d->cfg.max_message);
        s->replies = malloc((size_t)SRV_REPLY_QUEUE * (LWS_PRE + SRV_REPLY_LEN));
        if (!s->rx || !s->replies) {
            free(s->rx);
            free(s->replies);
            s->rx = NULL;
            s->replies = NULL;
            return -1;
        }
        size_send_buffer(d, wsi);
        s->next = d->sessions;
        d->sessions = s;
        d->nsessions++;
        atomic_fetch_add(&d->metrics.clients, 1);
        srv_metrics_count(&d->metrics.clients_total, 1);
        char peer[128] = "?";
        lws_get_peer_simple(wsi, peer, sizeof peer);
        srv_log(SRV_LOG_INFO, "client %llu connected from %s (%d clients)",
                (unsigned long long)s->tag, peer, d->nsessions);
        lws_callback_on_writable(wsi);
        return 0;
    }

    case LWS_CALLBACK_CLOSED: {
        if (!s->wsi)
            return 0;
        for (srv_session **pp = &d->sessions; *pp; pp = &(*pp)->next)
            if (*pp == s) {
                *pp = s->next;
                d->nsessions--;
                atomic_fetch_sub(&d->metrics.clients, 1);
                break;
            }
        if (s->timeout_armed &&
            srv_now_us() - s->armed_at_us >= (uint64_t)d->cfg.idle_timeout * 1000000u - 500000u) {
            srv_metrics_count(&d->metrics.closed_idle, 1);
            srv_log(SRV_LOG_INFO, "client %llu closed: accepted no frame for %d s",
                    (unsigned long long)s->tag, d->cfg.idle_timeout);
        }
        srv_log(SRV_LOG_INFO, "client %llu disconnected after %llu frames (%llu skipped)",
                (unsigned long long)s->tag, (unsigned long long)s->frames,
                (unsigned long long)s->skipped);
        srv_gen_unref(s->gen);
        free(s->rx);
        free(s->replies);
        memset(s, 0, sizeof *s);
        return 0;
    }

    case LWS_CALLBACK_RECEIVE: {
        if (!s->rx)
            return -1;
        if (lws_is_first_fragment(wsi)) {
            s->rx_len = 0;
            s->rx_binary = lws_frame_is_binary(wsi);
        }
        /* what the frame header still announces counts too: a header claiming 2^40 bytes is
         * closed at its first bytes, not after the client has sent max_message of them */
        if (s->rx_len + len + lws_remaining_packet_payload(wsi) > (size_t)d->cfg.max_message) {
            srv_metrics_count(&d->metrics.closed_oversize, 1);
            srv_log(SRV_LOG_INFO, "client %llu closed: message larger than %d bytes",
                    (unsigned long long)s->tag, d->cfg.max_message);
            static const char why[] = "message too large";
            lws_close_reason(wsi, LWS_CLOSE_STATUS_MESSAGE_TOO_LARGE, (unsigned char *)why,
                             sizeof why - 1);
            return -1;
        }
        memcpy(s->rx + s->rx_len, in, len);
        s->rx_len += len;
        if (lws_is_final_fragment(wsi) && lws_remaining_packet_payload(wsi) == 0) {
            int r = handle_message(d, s);
            s->rx_len = 0;
            if (r) {
                static const char why[] = "replies not read";
                lws_close_reason(wsi, LWS_CLOSE_STATUS_POLICY_VIOLATION, (unsigned char *)why,
                                 sizeof why - 1);
                return -1;
            }
        }
        return 0;
    }

    case LWS_CALLBACK_SERVER_WRITEABLE:
        if (!s->wsi)
            return 0;
        if (srv_guard_io_verdict(wsi) == SRV_GUARD_UNMASKED) {
            /* RFC 6455 Sec. 5.1: a server MUST close on an unmasked client frame; Sec. 7.4.1:
             * 1002, protocol error */
            static const char why[] = "client frame not masked";
            srv_log(SRV_LOG_INFO, "client %llu closed: a frame without the mask bit",
                    (unsigned long long)s->tag);
            srv_guard_io_closing(wsi);
            lws_close_reason(wsi, LWS_CLOSE_STATUS_PROTOCOL_ERR, (unsigned char *)why,
                             sizeof why - 1);
            return -1;
        }
        if (d->draining) {
            static const char why[] = "server shutting down";
            lws_close_reason(wsi, LWS_CLOSE_STATUS_GOINGAWAY, (unsigned char *)why, sizeof why - 1);
            return -1;
        }
        return write_frame_or_nothing(d, s, wsi);

    case LWS_CALLBACK_EVENT_WAIT_CANCELLED:
        if (d && d->pipe)
            wake_sessions(d);
        return 0;

    default:
        return 0;
    }
}

const struct lws_protocols srv_proto_stream = {
    .name = SRV_WS_PROTOCOL,
    .callback = callback_stream,
    .per_session_data_size = sizeof(srv_session),
    .rx_buffer_size = 4096,
    /* lws 4.1 otherwise limits one send() to rx_buffer_size (+ 20): a 50-100 KB frame went out in
     * 4116-byte pieces, one poll round each, the rest copied into a heap buffer meanwhile. */
    .tx_packet_size = SRV_SNDBUF_MAX,
};
