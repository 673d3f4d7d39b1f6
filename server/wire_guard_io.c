/* wire_guard_io.c - recv() and close() of meshsteerd, interposed before libc's so that
 * wire_guard.c sees exactly the bytes libwebsockets 4.1 reads from a client socket (why, and what
 * happens on a verdict: wire_guard_io.h). Checked against lws v4.1.6: a plain server socket is
 * read only by lws_ssl_capable_read_no_ssl (lib/core-net/output.c, recv(fd, buf, len, 0)) and
 * closed by compatible_close (close()) in __lws_close_free_wsi_final; lws's read() calls are on
 * files, pipes and CGI descriptors. With TLS (not used by meshsteerd) OpenSSL would read the
 * socket itself and bypass this. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#undef _FORTIFY_SOURCE /* its inline recv() wrapper would clash with the definition below */
#include "wire_guard_io.h"
#include "log.h"
#include "srv_err.h"
#include "wire_guard.h"

#include <dlfcn.h>
#include <errno.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#define GUARD_MAX_FDS (1 << 20)
#define GUARD_MAX_FIELDS 64 /* lws 4.1 holds 95 fragments a request; browsers send ~15 */

enum { ST_OPEN, ST_PENDING, ST_CLOSING };

typedef struct guard_slot {
    srv_guard g;
    struct lws *wsi;
    uint64_t answered; /* responses http.c finished on this connection */
    int state;         /* ST_*: a verdict waits to be acted on; the close is under way */
} guard_slot;

typedef ssize_t (*recv_fn)(int, void *, size_t, int);
typedef int (*close_fn)(int);

static _Atomic(recv_fn) next_recv;
static _Atomic(close_fn) next_close;
static atomic_int nslots;          /* 0 until started: everything passes through */
static atomic_uchar *live;         /* nslots flags: the descriptor is a guarded lws socket */
static guard_slot *slots;          /* nslots; only the service thread touches one that is live */
static srv_guard_rules rules;
static uint32_t known[WSI_TOKEN_COUNT];
static void (*wake_fn)(void *);
static void *wake_ud;

static void *next_symbol(const char *name)
{
    return dlsym(RTLD_NEXT, name);
}

static recv_fn real_recv(void)
{
    recv_fn f = atomic_load_explicit(&next_recv, memory_order_acquire);
    if (!f) { /* several threads may look it up at once: they find the same */
        void *s = next_symbol("recv");
        memcpy(&f, &s, sizeof f);
        atomic_store_explicit(&next_recv, f, memory_order_release);
    }
    return f;
}

static close_fn real_close(void)
{
    close_fn f = atomic_load_explicit(&next_close, memory_order_acquire);
    if (!f) {
        void *s = next_symbol("close");
        memcpy(&f, &s, sizeof f);
        atomic_store_explicit(&next_close, f, memory_order_release);
    }
    return f;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

int srv_guard_io_start(uint32_t max_head, void (*wake)(void *), void *ud, char *err)
{
    struct rlimit rl;
    size_t n = 1024;
    if (!getrlimit(RLIMIT_NOFILE, &rl) && rl.rlim_cur != RLIM_INFINITY && rl.rlim_cur > n)
        n = (size_t)rl.rlim_cur;
    if (n > GUARD_MAX_FDS)
        n = GUARD_MAX_FDS;
    /* kept for the process's life: another thread may be in recv() while the daemon stops */
    live = calloc(n, sizeof *live);
    slots = calloc(n, sizeof *slots);
    if (!live || !slots) {
        free(live);
        free(slots);
        live = NULL;
        slots = NULL;
        if (err)
            snprintf(err, SRV_ERR_LEN, "wire guard: no memory for %zu sockets", n);
        return -ENOMEM;
    }
    int nk = 0;
    for (int t = 0; t < WSI_TOKEN_COUNT; t++) {
        const unsigned char *s = lws_token_to_string((enum lws_token_indexes)t);
        size_t len = s ? strlen((const char *)s) : 0;
        /* header names end in ':'; the request line's tokens ("get ") and h2's pseudo-headers
         * (":path") are not header lines */
        if (len > 1 && s[len - 1] == ':' && s[0] != ':')
            known[nk++] = srv_guard_hash((const char *)s, len - 1);
    }
    qsort(known, (size_t)nk, sizeof known[0], cmp_u32);
    rules = (srv_guard_rules){max_head, GUARD_MAX_FIELDS, known, nk};
    wake_fn = wake;
    wake_ud = ud;
    real_recv();
    real_close();
    atomic_store_explicit(&nslots, (int)n, memory_order_release);
    return 0;
}

void srv_guard_io_stop(void)
{
    atomic_store_explicit(&nslots, 0, memory_order_release);
}

static guard_slot *slot_of(struct lws *wsi)
{
    int fd = lws_get_socket_fd(wsi), n = atomic_load_explicit(&nslots, memory_order_acquire);
    if (fd < 0 || fd >= n || !atomic_load_explicit(&live[fd], memory_order_acquire) ||
        slots[fd].wsi != wsi)
        return NULL;
    return &slots[fd];
}

int srv_guard_io_open(struct lws *wsi)
{
    int fd = lws_get_socket_fd(wsi), n = atomic_load_explicit(&nslots, memory_order_acquire);
    if (!n)
        return 0; /* not started (tests of http.c alone) */
    if (fd < 0 || fd >= n)
        return -EMFILE;
    guard_slot *s = &slots[fd];
    srv_guard_init(&s->g, &rules);
    s->wsi = wsi;
    s->answered = 0;
    s->state = ST_OPEN;
    atomic_store_explicit(&live[fd], 1, memory_order_release);
    return 0;
}

static const char *reason_of(int v, const char **body)
{
    switch (v) {
    case SRV_GUARD_URI_TOO_LONG:
        *body = "URI too long\n";
        return "URI Too Long";
    case SRV_GUARD_HEADERS_TOO_LARGE:
        *body = "request headers too large\n";
        return "Request Header Fields Too Large";
    case SRV_GUARD_NOT_IMPLEMENTED:
        *body = "request content is not accepted\n";
        return "Not Implemented";
    default:
        *body = "bad request\n";
        return "Bad Request";
    }
}

/* The whole response to a refused request, then the end of our side of the stream. */
static void answer(guard_slot *s, int fd)
{
    const char *body, *reason = reason_of(s->g.verdict, &body);
    char msg[320];
    int n = snprintf(msg, sizeof msg,
                     "HTTP/1.1 %d %s\r\ncontent-type: text/plain\r\ncontent-length: %zu\r\n"
                     "cache-control: no-store\r\nconnection: close\r\n\r\n%s",
                     s->g.verdict, reason, strlen(body), body);
    /* a few hundred bytes into a socket whose earlier output is all sent: one send; if the client
     * left earlier responses unread and the buffer is full, it gets less, and the close */
    if (send(fd, msg, (size_t)n, MSG_NOSIGNAL | MSG_DONTWAIT) < 0)
        srv_log(SRV_LOG_DEBUG, "wire guard: send: %s", strerror(errno));
    shutdown(fd, SHUT_WR);
    s->state = ST_CLOSING;
}

static void log_verdict(guard_slot *s, const char *what)
{
    char peer[128] = "?";
    lws_get_peer_simple(s->wsi, peer, sizeof peer);
    srv_log(SRV_LOG_INFO, "connection from %s: %s", peer, what);
}

/* recv() on a guarded socket, on the service thread. */
static ssize_t guarded_recv(guard_slot *s, recv_fn next, int fd, void *buf, size_t len,
                            int flags)
{
    if (s->state == ST_CLOSING)
        return 0; /* lws closes without waiting for more */
    ssize_t r = next(fd, buf, len, flags);
    if (r <= 0)
        return r;
    if (s->state == ST_PENDING) { /* after the verdict: dropped */
        errno = EAGAIN;
        return -1;
    }
    size_t k = srv_guard_feed(&s->g, buf, (size_t)r);
    if (k == (size_t)r)
        return r;
    int v = s->g.verdict;
    if (v == SRV_GUARD_UNMASKED) {
        log_verdict(s, "unmasked WebSocket frame (RFC 6455 5.1), closing with 1002");
        s->state = ST_PENDING;
        if (wake_fn)
            wake_fn(wake_ud);
    } else {
        char what[64];
        snprintf(what, sizeof what, "request refused with %d", v);
        log_verdict(s, what);
        if (s->g.heads == s->answered) {
            if (!lws_partial_buffered(s->wsi))
                answer(s, fd);
            else
                s->state = ST_CLOSING;
            return 0;
        }
        s->state = ST_PENDING; /* http.c answers it after the requests before it */
    }
    if (k)
        return (ssize_t)k;
    errno = EAGAIN;
    return -1;
}

int srv_guard_io_answered(struct lws *wsi)
{
    guard_slot *s = slot_of(wsi);
    if (!s)
        return 0;
    s->answered++;
    if (s->state != ST_PENDING || s->g.verdict == SRV_GUARD_UNMASKED || s->answered < s->g.heads)
        return 0;
    if (lws_partial_buffered(wsi))
        s->state = ST_CLOSING;
    else
        answer(s, lws_get_socket_fd(wsi));
    return 1;
}

int srv_guard_io_http(struct lws *wsi)
{
    guard_slot *s = slot_of(wsi);
    if (!s || !srv_guard_is_websocket(&s->g))
        return 0;
    return srv_guard_not_upgraded(&s->g);
}

int srv_guard_io_verdict(struct lws *wsi)
{
    guard_slot *s = slot_of(wsi);
    return s && s->state == ST_PENDING ? s->g.verdict : 0;
}

void srv_guard_io_closing(struct lws *wsi)
{
    guard_slot *s = slot_of(wsi);
    if (s)
        s->state = ST_CLOSING;
}

/* ---- the interposed libc calls: every thread, every descriptor ---- */

ssize_t recv(int fd, void *buf, size_t len, int flags)
{
    recv_fn next = real_recv();
    int n = atomic_load_explicit(&nslots, memory_order_acquire);
    if (fd < 0 || fd >= n || (flags & MSG_PEEK) ||
        !atomic_load_explicit(&live[fd], memory_order_acquire))
        return next(fd, buf, len, flags);
    return guarded_recv(&slots[fd], next, fd, buf, len, flags);
}

int close(int fd)
{
    int n = atomic_load_explicit(&nslots, memory_order_acquire);
    if (fd >= 0 && fd < n && atomic_load_explicit(&live[fd], memory_order_relaxed))
        atomic_store_explicit(&live[fd], 0, memory_order_seq_cst); /* before the number is free */
    return real_close()(fd);
}
