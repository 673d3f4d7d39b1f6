/* replay.c - a marker source that plays back a marker file (C3D, TRC, BVH, ASF/AMC, CSV) in real
 * time; a skeleton file's joint rotations (mdl_markers.rot) go with its frames (drv_frame.joint_rot).
 *
 * Pacing: frame n (counted since the last re-anchoring, across loops) is due at
 *     t_due(n) = t_anchor + (n - n_anchor) * 1e6 / (fps * speed)   [CLOCK_MONOTONIC, us]
 * read() sleeps (clock_nanosleep, absolute) until t_due or its own timeout, whichever is first.
 * Pause, seek, a speed change and a late frame (> REPLAY_LATE_US behind) re-anchor the clock at
 * the current time, so the stream never bursts to catch up. The frame's capture stamp is the
 * clock when it was released. Everything is read at open; read() copies and allocates nothing. */
#include "drv_err.h"
#include "drivers.h"
#include "model.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define REPLAY_LATE_US 250000
#define REPLAY_DEFAULT_FPS 30.0

typedef struct replay {
    mdl_markers *m;
    int loop;
    double speed;
    int paused;
    int idx;           /* file frame to emit next */
    uint64_t n;        /* frames emitted since start */
    uint64_t n_anchor; /* n at the anchor */
    uint64_t t_anchor; /* us */
    double fps;
} replay;

static uint64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void sleep_until_us(uint64_t t)
{
    struct timespec ts = {.tv_sec = (time_t)(t / 1000000u), .tv_nsec = (long)(t % 1000000u) * 1000};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
        ;
}

/* The frame period and the due time saturate a day ahead: no speed or file rate overflows
 * llround (speed 1e-300 once made the due time undefined). */
#define REPLAY_MAX_AHEAD_US 864e8

static double period_us(const replay *r)
{
    double p = 1e6 / (r->fps * r->speed);
    return p < REPLAY_MAX_AHEAD_US ? p : REPLAY_MAX_AHEAD_US;
}

static uint64_t due_us(const replay *r)
{
    double d = (double)(r->n - r->n_anchor) * period_us(r);
    return r->t_anchor + (uint64_t)llround(d < REPLAY_MAX_AHEAD_US ? d : REPLAY_MAX_AHEAD_US);
}

static void reanchor(replay *r, uint64_t t)
{
    r->t_anchor = t;
    r->n_anchor = r->n;
}

static int parse_num(const char *file, const char *key, const char *val, double lo, double hi,
                     double *out, char *err)
{
    char *end;
    errno = 0;
    double v = strtod(val, &end);
    if (end == val || *end || errno || !isfinite(v))
        return drv__err(err, -EINVAL, "replay %s: option %s: '%s' is not a number", file, key, val);
    if (v < lo || v > hi)
        return drv__err(err, -ERANGE, "replay %s: option %s=%g outside [%g, %g]", file, key, v, lo,
                      hi);
    *out = v;
    return 0;
}

static int parse_up(const char *file, const char *val, int *up, char *err)
{
    static const struct { const char *name; int up; } axes[] = {
        {"x", MDL_UP_X}, {"y", MDL_UP_Y}, {"z", MDL_UP_Z},
        {"-x", MDL_UP_NEG_X}, {"-y", MDL_UP_NEG_Y}, {"-z", MDL_UP_NEG_Z}, {"auto", MDL_UP_AUTO},
    };
    for (size_t i = 0; i < sizeof axes / sizeof axes[0]; i++)
        if (!strcmp(val, axes[i].name)) {
            *up = axes[i].up;
            return 0;
        }
    return drv__err(err, -EINVAL, "replay %s: option up='%s' (expected x, y, z, -x, -y, -z or auto)",
                  file, val);
}

static int replay_open(drv_source *s, const char *arg, char *err)
{
    char path[4096];
    size_t alen = strlen(arg);
    if (alen == 0)
        return drv__err(err, -EINVAL, "replay: missing file name (replay:FILE?loop=1&speed=1)");
    if (alen >= sizeof path)
        return drv__err(err, -ENAMETOOLONG, "replay: file name too long");
    memcpy(path, arg, alen + 1);
    char *q = strrchr(path, '?');
    if (q)
        *q++ = '\0';

    double loop = 0, speed = 1, start = 0, joints = 1;
    mdl_marker_opts o = {0, MDL_UP_AUTO, 0};
    for (char *save = NULL, *kv = q ? strtok_r(q, "&", &save) : NULL; kv;
         kv = strtok_r(NULL, "&", &save)) {
        char *eq = strchr(kv, '=');
        if (!eq)
            return drv__err(err, -EINVAL, "replay %s: option '%s' needs a value (key=value)", path,
                          kv);
        *eq++ = '\0';
        int r;
        if (!strcmp(kv, "loop"))
            r = parse_num(path, kv, eq, 0, 1, &loop, err);
        else if (!strcmp(kv, "speed")) {
            char why[DRV_ERR_LEN];
            r = parse_num(path, kv, eq, -INFINITY, INFINITY, &speed, err);
            if (!r && (r = drv_speed_check(speed, why)))
                drv__err(err, r, "replay %s: option %s", path, why);
        }
        else if (!strcmp(kv, "start"))
            r = parse_num(path, kv, eq, 0, 2e9, &start, err);
        else if (!strcmp(kv, "joints"))
            r = parse_num(path, kv, eq, 0, 1, &joints, err);
        else if (!strcmp(kv, "scale"))
            r = parse_num(path, kv, eq, 1e-9, 1e9, &o.scale, err);
        else if (!strcmp(kv, "up"))
            r = parse_up(path, eq, &o.up, err);
        else
            r = drv__err(err, -EINVAL,
                       "replay %s: unknown option '%s' (known: loop, speed, start, scale, up, "
                       "joints)", path,
                       kv);
        if (r)
            return r;
        if (!strcmp(kv, "loop") && loop != 0 && loop != 1)
            return drv__err(err, -EINVAL, "replay %s: option loop must be 0 or 1", path);
        if (!strcmp(kv, "joints") && joints != 0 && joints != 1)
            return drv__err(err, -EINVAL, "replay %s: option joints must be 0 or 1", path);
    }
    if (start != floor(start))
        return drv__err(err, -EINVAL, "replay %s: option start must be a whole frame number", path);

    replay *r = calloc(1, sizeof *r);
    if (!r)
        return drv__err(err, -ENOMEM, "replay %s: out of memory", path);
    char merr[MDL_ERR_LEN] = "";
    int rc = mdl_markers_read(path, &o, &r->m, merr);
    if (rc) {
        free(r);
        return drv__err(err, rc, "replay: %s", merr);
    }
    if (r->m->frames <= 0 || r->m->count <= 0) {
        mdl_markers_destroy(r->m);
        free(r);
        return drv__err(err, MDL_EFORMAT, "replay %s: no frames or no markers", path);
    }
    if (start >= r->m->frames) {
        int frames = r->m->frames;
        mdl_markers_destroy(r->m);
        free(r);
        return drv__err(err, -ERANGE, "replay %s: start=%.0f but the file has %d frames", path, start,
                      frames);
    }
    r->loop = loop != 0;
    r->speed = speed;
    r->idx = (int)start;
    r->fps = r->m->fps > 0 && isfinite(r->m->fps) ? r->m->fps : REPLAY_DEFAULT_FPS;
    s->impl = r;
    s->count = r->m->count;
    s->names = (const char **)r->m->names;
    s->fps = r->fps;
    s->controls = DRV_CTL_PAUSE | DRV_CTL_SEEK | DRV_CTL_SPEED | DRV_CTL_LOOP;
    s->frames = r->m->frames;
    s->joints = r->m->rot != NULL && joints != 0;
    return 0;
}

static int replay_start(drv_source *s, char *err)
{
    (void)err;
    replay *r = s->impl;
    reanchor(r, now_us());
    return 0;
}

static int replay_read(drv_source *s, drv_frame *f, int timeout_ms, char *err)
{
    (void)err;
    replay *r = s->impl;
    uint64_t now = now_us();
    uint64_t deadline = now + (uint64_t)(timeout_ms > 0 ? timeout_ms : 0) * 1000u;
    if (r->paused) {
        sleep_until_us(deadline);
        return DRV_ETIMEOUT;
    }
    if (r->idx >= r->m->frames) {
        if (!r->loop)
            return DRV_EEOF;
        r->idx = 0;
    }
    uint64_t due = due_us(r);
    if (now > due + REPLAY_LATE_US) {
        reanchor(r, now);
        due = now;
    }
    if (due > deadline) {
        sleep_until_us(deadline);
        return DRV_ETIMEOUT;
    }
    if (due > now)
        sleep_until_us(due);

    int c = r->m->count;
    memcpy(f->xyz, r->m->P + (size_t)r->idx * (size_t)c * 3, (size_t)c * 3 * sizeof(float));
    memcpy(f->valid, r->m->valid + (size_t)r->idx * (size_t)c, (size_t)c);
    if (s->joints && f->joint_rot && f->joint_valid) {
        memcpy(f->joint_rot, r->m->rot + (size_t)r->idx * (size_t)c * 4, (size_t)c * 4 * sizeof(float));
        memcpy(f->joint_valid, f->valid, (size_t)c);
    }
    f->seq = r->n;
    f->t_capture_us = now_us();
    r->n++;
    r->idx++;
    if (r->idx >= r->m->frames && r->loop)
        r->idx = 0;
    return 0;
}

static int replay_control(drv_source *s, unsigned ctl, double value, char *err)
{
    replay *r = s->impl;
    if (!isfinite(value))
        return drv__err(err, -EINVAL, "replay: %s: value is not finite", drv_control_name(ctl));
    if (ctl == DRV_CTL_PAUSE) {
        if (value != 0 && value != 1)
            return drv__err(err, -EINVAL, "replay: pause must be 0 or 1");
        if (r->paused && value == 0)
            reanchor(r, now_us());
        r->paused = value != 0;
        return 0;
    }
    if (ctl == DRV_CTL_SEEK) {
        if (value < 0 || value >= r->m->frames || value != floor(value))
            return drv__err(err, -ERANGE, "replay: seek to %g outside the %d frames [0, %d]", value,
                          r->m->frames, r->m->frames - 1);
        r->idx = (int)value;
        reanchor(r, now_us());
        return 0;
    }
    if (ctl == DRV_CTL_SPEED) { /* the range: drv_source_control */
        /* the next frame keeps its time if it is sooner than a period at the new speed (no
         * burst when speeding up), else comes a period from now (from speed 0.001, a frame
         * 33 s away, to 1: 1/fps, not 33 s) */
        uint64_t now = now_us(), due = due_us(r);
        r->speed = value;
        uint64_t soon = now + (uint64_t)llround(period_us(r));
        reanchor(r, due < now ? now : due < soon ? due : soon);
        return 0;
    }
    if (ctl == DRV_CTL_LOOP) {
        if (value != 0 && value != 1)
            return drv__err(err, -EINVAL, "replay: loop must be 0 or 1");
        r->loop = value != 0;
        return 0;
    }
    return drv__err(err, -ENOTSUP, "replay: no control '%s' (known: pause, seek, speed, loop)",
                  drv_control_name(ctl));
}

static void replay_stop(drv_source *s)
{
    (void)s;
}

static void replay_close(drv_source *s)
{
    replay *r = s->impl;
    if (!r)
        return;
    mdl_markers_destroy(r->m);
    free(r);
    s->impl = NULL;
}

const drv_source_ops drv_replay_ops = {
    .scheme = "replay",
    .open = replay_open,
    .start = replay_start,
    .read = replay_read,
    .control = replay_control,
    .stop = replay_stop,
    .close = replay_close,
};
