/* source.c - the registry of marker sources and the drv_source_* dispatch of drivers.h.
 *
 * A spec is "scheme:argument" (or a bare "scheme" when the source takes no argument). The scheme
 * selects an entry of `registry`; the argument is handed to that source's open(). This file owns
 * the drv_source handle and the state machine CLOSED -> OPEN -> STREAMING -> (ENDED | LOST) that
 * /healthz shows; the implementations only fill in count, names and fps at open. */
#include "drv_err.h"
#include "drivers.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the registry: each source kind declares its ops here and adds a line to the table ---- */

/* replay of marker files (replay.c) */
extern const drv_source_ops drv_replay_ops;

/* depth cameras and depth->markers (depth/) */
extern const drv_source_ops drv_fakenect_ops;
extern const drv_source_ops drv_v4l2_ops;
extern const drv_source_ops drv_openni2_ops;

/* markers and VMC bones over OSC (osc/) */
extern const drv_source_ops drv_osc_ops;

static const drv_source_ops *const registry[] = {
    /* replay of marker files */
    &drv_replay_ops,
    /* depth cameras and depth->markers */
    &drv_fakenect_ops,
    &drv_v4l2_ops,
    &drv_openni2_ops,
    /* markers and VMC bones over OSC */
    &drv_osc_ops,
    NULL,
};

const drv_source_ops *drv_source_find_ops(const char *scheme)
{
    if (!scheme)
        return NULL;
    for (const drv_source_ops *const *o = registry; *o; o++)
        if (!strcmp((*o)->scheme, scheme))
            return *o;
    return NULL;
}

int drv_source_open(const char *spec, drv_source **out, char *err)
{
    *out = NULL;
    if (!spec || !*spec)
        return drv__err(err, -EINVAL, "source: empty spec");
    char scheme[32];
    const char *colon = strchr(spec, ':');
    size_t n = colon ? (size_t)(colon - spec) : strlen(spec);
    if (n == 0 || n >= sizeof scheme)
        return drv__err(err, -EINVAL, "source '%s': expected scheme:argument", spec);
    memcpy(scheme, spec, n);
    scheme[n] = '\0';
    const drv_source_ops *ops = drv_source_find_ops(scheme);
    if (!ops) {
        char known[256] = "";
        size_t k = 0;
        for (const drv_source_ops *const *o = registry; *o && k < sizeof known - 1; o++) {
            int w = snprintf(known + k, sizeof known - k, "%s%s", k ? ", " : "", (*o)->scheme);
            if (w < 0)
                break;
            k += (size_t)w;
        }
        return drv__err(err, -ENOENT, "source '%s': unknown scheme '%s' (known: %s)", spec, scheme,
                       known);
    }
    drv_source *s = calloc(1, sizeof *s);
    if (!s)
        return drv__err(err, -ENOMEM, "source '%s': out of memory", spec);
    s->ops = ops;
    s->state = DRV_STATE_CLOSED;
    int r = ops->open(s, colon ? colon + 1 : "", err);
    if (r != 0) {
        free(s);
        return r;
    }
    if (s->count <= 0 || !s->names) {
        ops->close(s);
        free(s);
        return drv__err(err, -EINVAL, "source '%s': no markers", spec);
    }
    s->state = DRV_STATE_OPEN;
    *out = s;
    return 0;
}

int drv_source_reopen(drv_source *s, const char *spec, char *err)
{
    if (!s || !spec)
        return drv__err(err, -EINVAL, "source: NULL");
    /* release the vanished device first: a driver may refuse to open a device twice */
    if (!s->detached) {
        if (s->state == DRV_STATE_STREAMING || s->state == DRV_STATE_LOST ||
            s->state == DRV_STATE_ENDED)
            s->ops->stop(s);
        s->ops->close(s);
        s->impl = NULL;
        s->detached = 1;
        s->state = DRV_STATE_LOST;
    }
    drv_source *t;
    int r = drv_source_open(spec, &t, err);
    if (r)
        return r;
    int same = t->ops == s->ops && t->count == s->count;
    for (int i = 0; same && i < s->count; i++)
        same = !strcmp(t->names[i], s->names[i]);
    if (!same) {
        drv_source_close(t);
        return drv__err(err, -EINVAL, "source '%s': reopened with another marker set", spec);
    }
    s->impl = t->impl;
    s->names = t->names;
    s->fps = t->fps;
    s->controls = t->controls;
    s->caps = t->caps;
    s->frames = t->frames;
    s->detached = 0;
    s->state = DRV_STATE_OPEN;
    free(t);
    return 0;
}

int drv_source_start(drv_source *s, char *err)
{
    if (!s)
        return drv__err(err, -EINVAL, "source: NULL");
    if (s->detached)
        return drv__err(err, -ENODEV, "source %s: the device is gone", s->ops->scheme);
    if (s->state == DRV_STATE_STREAMING)
        return 0;
    int r = s->ops->start(s, err);
    if (r == 0)
        s->state = DRV_STATE_STREAMING;
    return r;
}

int drv_source_read(drv_source *s, drv_frame *f, int timeout_ms, char *err)
{
    if (!s || !f)
        return drv__err(err, -EINVAL, "source: NULL");
    if (s->state != DRV_STATE_STREAMING)
        return s->state == DRV_STATE_ENDED ? DRV_EEOF
             : s->state == DRV_STATE_LOST  ? DRV_ELOST
                                           : drv__err(err, -EINVAL, "source %s: not started",
                                                     s->ops->scheme);
    if (f->count < s->count || !f->xyz || !f->valid)
        return drv__err(err, -EINVAL, "source %s: frame buffers hold %d markers, need %d",
                       s->ops->scheme, f->count, s->count);
    int r = s->ops->read(s, f, timeout_ms, err);
    if (r == 0)
        f->count = s->count;
    else if (r == DRV_EEOF)
        s->state = DRV_STATE_ENDED;
    else if (r == DRV_ELOST)
        s->state = DRV_STATE_LOST;
    return r;
}

const char *drv_control_name(unsigned ctl)
{
    switch (ctl) {
    case DRV_CTL_PAUSE: return "pause";
    case DRV_CTL_SEEK: return "seek";
    case DRV_CTL_SPEED: return "speed";
    case DRV_CTL_LOOP: return "loop";
    }
    return "?";
}

int drv_speed_check(double speed, char *err)
{
    if (!(speed >= DRV_SPEED_MIN && speed <= DRV_SPEED_MAX))
        return drv__err(err, -ERANGE, "speed %g outside [%g, %g]", speed, DRV_SPEED_MIN,
                        DRV_SPEED_MAX);
    return 0;
}

int drv_source_control(drv_source *s, unsigned ctl, double value, char *err)
{
    if (!s)
        return drv__err(err, -EINVAL, "source: NULL");
    if (!s->ops->control || (ctl & (ctl - 1)) || !(s->controls & ctl))
        return drv__err(err, -ENOTSUP, "source %s: no control '%s'%s", s->ops->scheme,
                        drv_control_name(ctl), s->controls ? "" : " (it takes no controls)");
    if (s->detached)
        return drv__err(err, -ENODEV, "source %s: the device is gone", s->ops->scheme);
    if (ctl == DRV_CTL_SPEED) {
        char why[DRV_ERR_LEN];
        if (drv_speed_check(value, why))
            return drv__err(err, -ERANGE, "source %s: %s", s->ops->scheme, why);
    }
    int r = s->ops->control(s, ctl, value, err);
    /* a seek may revive a replay that had ended */
    if (r == 0 && s->state == DRV_STATE_ENDED && ctl == DRV_CTL_SEEK)
        s->state = DRV_STATE_STREAMING;
    return r;
}

void drv_source_stop(drv_source *s)
{
    if (!s || s->detached || (s->state != DRV_STATE_STREAMING && s->state != DRV_STATE_ENDED &&
               s->state != DRV_STATE_LOST))
        return;
    s->ops->stop(s);
    s->state = DRV_STATE_OPEN;
}

void drv_source_close(drv_source *s)
{
    if (!s)
        return;
    drv_source_stop(s);
    if (!s->detached)
        s->ops->close(s);
    free(s);
}

const char *drv_state_name(drv_state st)
{
    switch (st) {
    case DRV_STATE_CLOSED: return "closed";
    case DRV_STATE_OPEN: return "open";
    case DRV_STATE_STREAMING: return "streaming";
    case DRV_STATE_ENDED: return "ended";
    case DRV_STATE_LOST: return "lost";
    }
    return "unknown";
}
