/* osc.c - the `osc:[HOST:]PORT` marker source: markers and VMC bones as OSC over UDP.
 *
 * One UDP socket, bound at open (getaddrinfo; no HOST = every IPv4 interface, as liblo's servers
 * do). read() waits on it with ppoll, drains what arrived into one buffer of the handle and walks
 * each datagram (packet.h) against the marker set fixed at open. Framing (docs/OSC.md):
 *   - a top-level bundle is one frame, complete at its end;
 *   - outside bundles, "/frame" completes one; so does a marker (or bone) set a second time (the
 *     frame before it completes first), and a quiet gap of `gap` ms after the last update.
 * A marker is valid in a frame when it was received at most `stale` ms before (0: forever).
 * When frames complete faster than they are read, the newest wins (counted as coalesced).
 * Nothing is allocated after open. */
#include "osc.h"

#include "../drv_err.h"
#include "packet.h"
#include "vmc.h"

#include <errno.h>
#include <math.h>
#include <netdb.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define OSC_MAX_MARKERS 128
#define OSC_NAME_LEN 64
#define OSC_DRAIN 256 /* datagrams handled per wake-up at most */

static const char *const depth_labels[] = {"head", "lhand", "rhand", "lfoot", "rfoot", "torso"};

typedef struct osc_src {
    int fd;
    int port;
    int count;
    char (*name)[OSC_NAME_LEN];
    const char **names;
    int *bone;          /* count: VMC bone feeding marker i, -1 for none */
    float *cur;         /* count x 3: latest positions */
    uint8_t *have;      /* count: received at least once */
    uint8_t *dirty;     /* count: set since the last completed frame */
    uint64_t *t_upd;    /* count: when last set (us) */
    float *out;         /* count x 3: the completed frame */
    uint8_t *out_valid; /* count */
    uint64_t out_t;     /* its capture time */
    int ready;          /* a completed frame waits for read() */
    drv_vmc vmc;
    uint8_t bone_dirty[DRV_VMC_BONES];
    uint64_t bone_t[DRV_VMC_BONES];
    int vmc_pending;    /* a bone or the root changed since the last frame */
    int pending;        /* updates since the last completed frame */
    int bundle;         /* top-level bundle open */
    uint64_t t_last;    /* last update (us) */
    uint64_t now;       /* time of the packet being handled */
    uint64_t seq;
    double scale;
    uint64_t stale_us, gap_us;
    drv_osc_counts n;
    uint8_t buf[65536];
} osc_src;

static uint64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* ---- frames ---- */

static void complete(osc_src *o)
{
    if (!o->pending)
        return;
    if (o->vmc_pending) {
        /* a bone below a moved one moves too: every received bone's marker is refreshed, and
         * marks the time only of bones set in this frame */
        drv_vmc_solve(&o->vmc);
        for (int i = 0; i < o->count; i++) {
            int b = o->bone[i];
            if (b < 0 || !o->vmc.have[b])
                continue;
            for (int k = 0; k < 3; k++)
                o->cur[3 * i + k] = (float)(o->vmc.wp[b][k] * o->scale);
            o->have[i] = 1;
            if (o->bone_dirty[b])
                o->t_upd[i] = o->bone_t[b];
        }
    }
    for (int i = 0; i < o->count; i++) {
        memcpy(o->out + 3 * i, o->cur + 3 * i, 3 * sizeof(float));
        o->out_valid[i] = o->have[i] && (o->stale_us == 0 || o->now - o->t_upd[i] <= o->stale_us);
        if (!o->out_valid[i])
            o->out[3 * i] = o->out[3 * i + 1] = o->out[3 * i + 2] = 0;
    }
    if (o->ready)
        o->n.coalesced++;
    o->ready = 1;
    o->out_t = o->now;
    o->n.frames++;
    o->pending = 0;
    o->vmc_pending = 0;
    memset(o->dirty, 0, (size_t)o->count);
    memset(o->bone_dirty, 0, sizeof o->bone_dirty);
}

static int marker_index(const osc_src *o, const char *name)
{
    for (int i = 0; i < o->count; i++)
        if (!strcmp(o->name[i], name))
            return i;
    return -1;
}

/* ---- the address space ---- */

static void on_marker(osc_src *o, const drv_osc_msg *m)
{
    const char *name;
    double x[3];
    if (drv_osc_arg_string(m, 0, &name) || (m->argc != 1 && m->argc != 4)) {
        o->n.bad_messages++;
        return;
    }
    for (int k = 0; k + 1 < m->argc; k++)
        if (drv_osc_arg_number(m, k + 1, &x[k]) || !isfinite(x[k]) || fabs(x[k]) > 1e6) {
            o->n.bad_messages++;
            return;
        }
    int i = marker_index(o, name);
    if (i < 0) {
        o->n.unknown_names++;
        return;
    }
    if (!o->bundle && o->dirty[i])
        complete(o); /* the same marker again: the frame before it is whole */
    if (m->argc == 4) {
        for (int k = 0; k < 3; k++)
            o->cur[3 * i + k] = (float)(x[k] * o->scale);
        o->have[i] = 1;
        o->t_upd[i] = o->now;
    } else {
        o->have[i] = 0; /* "/marker NAME": occluded */
    }
    o->dirty[i] = 1;
    o->pending = 1;
    o->t_last = o->now;
}

/* /VMC/Ext/Bone/Pos s fff ffff, /VMC/Ext/Root/Pos s fff ffff [ffffff] */
static void on_vmc(osc_src *o, const drv_osc_msg *m, int root)
{
    const char *name;
    double v[7];
    if (drv_osc_arg_string(m, 0, &name) || !(m->argc == 8 || (root && m->argc == 14))) {
        o->n.bad_messages++;
        return;
    }
    for (int k = 0; k < 7; k++)
        if (drv_osc_arg_number(m, k + 1, &v[k]) || fabs(v[k]) > 1e6) {
            o->n.bad_messages++;
            return;
        }
    int b = root ? -1 : drv_vmc_bone_index(name);
    if (!root && b < 0) {
        o->n.unknown_names++;
        return;
    }
    if (!o->bundle && (root ? 0 : o->bone_dirty[b]))
        complete(o);
    int r = root ? drv_vmc_set_root(&o->vmc, v, v + 3) : drv_vmc_set_bone(&o->vmc, b, v, v + 3);
    if (r) {
        o->n.bad_messages++;
        return;
    }
    if (!root) {
        o->bone_dirty[b] = 1;
        o->bone_t[b] = o->now;
    }
    o->vmc_pending = 1;
    o->pending = 1;
    o->t_last = o->now;
}

static void on_message(void *user, const drv_osc_msg *m)
{
    osc_src *o = user;
    o->n.messages++;
    if (!strcmp(m->address, "/marker"))
        on_marker(o, m);
    else if (!strcmp(m->address, "/frame")) {
        if (!o->bundle)
            complete(o);
    } else if (!strcmp(m->address, "/VMC/Ext/Bone/Pos"))
        on_vmc(o, m, 0);
    else if (!strcmp(m->address, "/VMC/Ext/Root/Pos"))
        on_vmc(o, m, 1);
    else
        o->n.ignored++; /* other VMC messages (/VMC/Ext/Blend/Val, /VMC/Ext/OK, ...) and the rest */
}

static void on_bundle(void *user, int begin, int depth, uint64_t timetag)
{
    (void)timetag;
    osc_src *o = user;
    if (depth != 0)
        return;
    if (begin) {
        complete(o); /* loose messages before the bundle form their own frame */
        o->bundle = 1;
    } else {
        o->bundle = 0;
        complete(o);
    }
}

void drv__osc_feed(drv_source *s, const uint8_t *buf, size_t len, uint64_t t)
{
    osc_src *o = s->impl;
    drv_osc_visitor v = {on_message, on_bundle, o};
    o->now = t;
    o->n.packets++;
    o->bundle = 0;
    if (drv_osc_packet_walk(buf, len, &v, NULL))
        o->n.malformed++;
}

int drv__osc_flush(drv_source *s, uint64_t t)
{
    osc_src *o = s->impl;
    o->now = t;
    int before = o->ready;
    complete(o);
    return !before && o->ready;
}

/* ---- the spec ---- */

static int parse_num(const char *spec, const char *key, const char *val, double lo, double hi,
                     double *out, char *err)
{
    char *end;
    errno = 0;
    double v = strtod(val, &end);
    if (end == val || *end || errno || !isfinite(v))
        return drv__err(err, -EINVAL, "osc %s: option %s: '%s' is not a number", spec, key, val);
    if (v < lo || v > hi)
        return drv__err(err, -ERANGE, "osc %s: option %s=%g outside [%g, %g]", spec, key, v, lo, hi);
    *out = v;
    return 0;
}

static int add_marker(osc_src *o, const char *spec, const char *name, char *err)
{
    size_t n = strlen(name);
    if (n == 0 || n >= OSC_NAME_LEN)
        return drv__err(err, -EINVAL, "osc %s: marker name '%s' is empty or longer than %d bytes",
                        spec, name, OSC_NAME_LEN - 1);
    if (o->count >= OSC_MAX_MARKERS)
        return drv__err(err, -EINVAL, "osc %s: more than %d markers", spec, OSC_MAX_MARKERS);
    if (marker_index(o, name) >= 0)
        return drv__err(err, -EINVAL, "osc %s: marker '%s' named twice", spec, name);
    memcpy(o->name[o->count++], name, n + 1);
    return 0;
}

static void osc_free(osc_src *o)
{
    if (!o)
        return;
    if (o->fd >= 0)
        close(o->fd);
    free(o->name);
    free(o->names);
    free(o->bone);
    free(o->cur);
    free(o->have);
    free(o->dirty);
    free(o->t_upd);
    free(o->out);
    free(o->out_valid);
    free(o);
}

static int bind_udp(osc_src *o, const char *spec, const char *host, const char *port, char *err)
{
    struct addrinfo hints = {0}, *ai = NULL;
    hints.ai_family = host ? AF_UNSPEC : AF_INET;
    hints.ai_socktype = SOCK_DGRAM;
    hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
    int r = getaddrinfo(host, port, &hints, &ai);
    if (r)
        return drv__err(err, -EINVAL, "osc %s: %s:%s: %s", spec, host ? host : "*", port,
                        gai_strerror(r));
    int e = 0;
    for (struct addrinfo *a = ai; a; a = a->ai_next) {
        int fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, a->ai_protocol);
        if (fd < 0) {
            e = errno;
            continue;
        }
        int big = 1 << 20;
        (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
        if (bind(fd, a->ai_addr, a->ai_addrlen) == 0) {
            struct sockaddr_storage ss;
            socklen_t sl = sizeof ss;
            if (getsockname(fd, (struct sockaddr *)&ss, &sl) == 0) {
                char hb[NI_MAXHOST], pb[NI_MAXSERV];
                if (getnameinfo((struct sockaddr *)&ss, sl, hb, sizeof hb, pb, sizeof pb,
                                NI_NUMERICHOST | NI_NUMERICSERV) == 0)
                    o->port = atoi(pb);
            }
            o->fd = fd;
            freeaddrinfo(ai);
            return 0;
        }
        e = errno;
        close(fd);
    }
    freeaddrinfo(ai);
    return drv__err(err, -(e ? e : EADDRNOTAVAIL), "osc %s: bind %s:%s: %s", spec,
                    host ? host : "*", port, strerror(e ? e : EADDRNOTAVAIL));
}

static int osc_open(drv_source *s, const char *arg, char *err)
{
    char buf[1024];
    size_t alen = strlen(arg);
    if (alen == 0)
        return drv__err(err, -EINVAL, "osc: missing port (osc:[HOST:]PORT[?markers=a,b&vmc=1])");
    if (alen >= sizeof buf)
        return drv__err(err, -ENAMETOOLONG, "osc: spec too long");
    memcpy(buf, arg, alen + 1);
    char *q = strchr(buf, '?');
    if (q)
        *q++ = '\0';
    /* [HOST:]PORT, HOST in brackets for IPv6 */
    char *host = NULL, *port = buf;
    if (buf[0] == '[') {
        char *rb = strchr(buf, ']');
        if (!rb || rb[1] != ':')
            return drv__err(err, -EINVAL, "osc %s: expected [IPV6]:PORT", arg);
        *rb = '\0';
        host = buf + 1;
        port = rb + 2;
    } else {
        char *c = strchr(buf, ':');
        if (c && strchr(c + 1, ':'))
            return drv__err(err, -EINVAL, "osc %s: an IPv6 host goes in brackets: [::1]:PORT", arg);
        if (c) {
            *c = '\0';
            host = buf;
            port = c + 1;
        }
    }
    char *end;
    errno = 0;
    long pn = strtol(port, &end, 10);
    if (!*port || *end || errno || pn < 0 || pn > 65535)
        return drv__err(err, -EINVAL, "osc %s: port '%s' is not a number in [0, 65535]", arg, port);
    if (host && !*host)
        host = NULL;

    osc_src *o = calloc(1, sizeof *o);
    if (!o)
        return drv__err(err, -ENOMEM, "osc: out of memory");
    o->fd = -1;
    o->name = calloc(OSC_MAX_MARKERS, sizeof *o->name);
    if (!o->name) {
        osc_free(o);
        return drv__err(err, -ENOMEM, "osc: out of memory");
    }
    double vmc = 0, scale = 1, stale = 500, gap = 10;
    char *markers = NULL;
    int r = 0;
    for (char *save = NULL, *kv = q ? strtok_r(q, "&", &save) : NULL; kv && !r;
         kv = strtok_r(NULL, "&", &save)) {
        char *eq = strchr(kv, '=');
        if (!eq) {
            r = drv__err(err, -EINVAL, "osc %s: option '%s' needs a value (key=value)", arg, kv);
            break;
        }
        *eq++ = '\0';
        if (!strcmp(kv, "markers"))
            markers = eq;
        else if (!strcmp(kv, "vmc")) {
            r = parse_num(arg, kv, eq, 0, 1, &vmc, err);
            if (!r && vmc != 0 && vmc != 1)
                r = drv__err(err, -EINVAL, "osc %s: option vmc must be 0 or 1", arg);
        } else if (!strcmp(kv, "scale"))
            r = parse_num(arg, kv, eq, 1e-9, 1e9, &scale, err);
        else if (!strcmp(kv, "stale"))
            r = parse_num(arg, kv, eq, 0, 3600e3, &stale, err);
        else if (!strcmp(kv, "gap"))
            r = parse_num(arg, kv, eq, 1, 10e3, &gap, err);
        else
            r = drv__err(err, -EINVAL,
                         "osc %s: unknown option '%s' (known: markers, vmc, scale, stale, gap)", arg,
                         kv);
    }
    if (!r && markers) {
        for (char *save = NULL, *n = strtok_r(markers, ",", &save); n && !r;
             n = strtok_r(NULL, ",", &save))
            r = add_marker(o, arg, n, err);
        if (!r && o->count == 0)
            r = drv__err(err, -EINVAL, "osc %s: markers= names none", arg);
    } else if (!r && vmc) {
        for (int b = 0; b < DRV_VMC_BODY && !r; b++)
            r = add_marker(o, arg, drv_vmc_bone_name(b), err);
    } else if (!r) {
        for (size_t i = 0; i < sizeof depth_labels / sizeof *depth_labels && !r; i++)
            r = add_marker(o, arg, depth_labels[i], err);
    }
    if (r) {
        osc_free(o);
        return r;
    }
    int c = o->count;
    o->names = calloc((size_t)c, sizeof *o->names);
    o->bone = calloc((size_t)c, sizeof *o->bone);
    o->cur = calloc((size_t)c * 3, sizeof *o->cur);
    o->out = calloc((size_t)c * 3, sizeof *o->out);
    o->have = calloc((size_t)c, 1);
    o->dirty = calloc((size_t)c, 1);
    o->out_valid = calloc((size_t)c, 1);
    o->t_upd = calloc((size_t)c, sizeof *o->t_upd);
    if (!o->names || !o->bone || !o->cur || !o->out || !o->have || !o->dirty || !o->out_valid ||
        !o->t_upd) {
        osc_free(o);
        return drv__err(err, -ENOMEM, "osc: out of memory");
    }
    for (int i = 0; i < c; i++) {
        o->names[i] = o->name[i];
        o->bone[i] = drv_vmc_bone_index(o->name[i]);
    }
    drv_vmc_init(&o->vmc);
    o->scale = scale;
    o->stale_us = (uint64_t)(stale * 1000);
    o->gap_us = (uint64_t)(gap * 1000);
    r = bind_udp(o, arg, host, port, err);
    if (r) {
        osc_free(o);
        return r;
    }
    s->impl = o;
    s->count = c;
    s->names = o->names;
    s->fps = 0; /* the sender decides */
    s->controls = 0;
    return 0;
}

static int osc_start(drv_source *s, char *err)
{
    (void)s;
    (void)err;
    return 0;
}

static void drain(osc_src *o, drv_source *s)
{
    for (int k = 0; k < OSC_DRAIN; k++) {
        ssize_t n = recv(o->fd, o->buf, sizeof o->buf, MSG_DONTWAIT | MSG_TRUNC);
        if (n < 0)
            return; /* EAGAIN, or an ICMP error from an earlier send: nothing to read */
        if ((size_t)n > sizeof o->buf) {
            o->n.packets++;
            o->n.malformed++; /* larger than any UDP payload we take: truncated */
            continue;
        }
        drv__osc_feed(s, o->buf, (size_t)n, now_us());
    }
}

static int osc_read(drv_source *s, drv_frame *f, int timeout_ms, char *err)
{
    osc_src *o = s->impl;
    uint64_t deadline = now_us() + (uint64_t)(timeout_ms > 0 ? timeout_ms : 0) * 1000u;
    for (;;) {
        uint64_t now = now_us();
        if (!o->ready && o->pending && now >= o->t_last + o->gap_us) {
            o->now = now;
            complete(o);
        }
        if (o->ready) {
            memcpy(f->xyz, o->out, (size_t)o->count * 3 * sizeof(float));
            memcpy(f->valid, o->out_valid, (size_t)o->count);
            f->seq = o->seq++;
            f->t_capture_us = o->out_t;
            o->ready = 0;
            return 0;
        }
        uint64_t until = deadline;
        if (o->pending && o->t_last + o->gap_us < until)
            until = o->t_last + o->gap_us;
        if (now >= until && now >= deadline)
            return DRV_ETIMEOUT;
        uint64_t wait = until > now ? until - now : 0;
        struct timespec ts = {.tv_sec = (time_t)(wait / 1000000u),
                              .tv_nsec = (long)(wait % 1000000u) * 1000};
        struct pollfd p = {.fd = o->fd, .events = POLLIN};
        int r = ppoll(&p, 1, &ts, NULL);
        if (r < 0 && errno != EINTR)
            return drv__err(err, -errno, "osc: poll: %s", strerror(errno));
        if (r > 0)
            drain(o, s);
    }
}

static void osc_stop(drv_source *s)
{
    (void)s;
}

static void osc_close(drv_source *s)
{
    osc_free(s->impl);
    s->impl = NULL;
}

int drv_osc_counts_get(const drv_source *s, drv_osc_counts *out)
{
    if (!s || !out || s->ops != &drv_osc_ops || !s->impl)
        return -EINVAL;
    *out = ((const osc_src *)s->impl)->n;
    return 0;
}

int drv_osc_port(const drv_source *s)
{
    if (!s || s->ops != &drv_osc_ops || !s->impl)
        return -EINVAL;
    return ((const osc_src *)s->impl)->port;
}

const drv_source_ops drv_osc_ops = {
    .scheme = "osc",
    .open = osc_open,
    .start = osc_start,
    .read = osc_read,
    .control = NULL,
    .stop = osc_stop,
    .close = osc_close,
};
