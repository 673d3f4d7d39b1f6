/* openni2.c - the openni2: source: OpenNI2 C API device/stream handling, depth mode choice,
 * intrinsics from the field of view, device-to-monotonic time mapping, loss detection; depth is
 * turned into markers by drv_depth_tracker (markers.c). Behaviour as described in openni2.h. */
#include "../drv_err.h"
#include "openni2.h"

#include "oni_c.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static uint64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* OpenNI2's last error without its tabs and newlines */
static const char *oni_why(char buf[256])
{
    const char *e = oniGetExtendedError();
    size_t n = 0;
    for (; e && *e && n < 255; e++)
        if (*e == '\n' || *e == '\t' || *e == '\r') {
            if (n && buf[n - 1] != ' ')
                buf[n++] = ' ';
        } else {
            buf[n++] = *e;
        }
    while (n && buf[n - 1] == ' ')
        n--;
    buf[n] = '\0';
    return buf;
}

uint64_t drv_clock_map_apply(drv_clock_map *m, uint64_t dev_us, uint64_t host_us)
{
    int64_t off = (int64_t)host_us - (int64_t)dev_us;
    if (!m->init || dev_us < m->last_dev || off < m->offset || off - m->offset > 100000) {
        m->offset = off;
        m->init = 1;
    }
    m->last_dev = dev_us;
    int64_t t = (int64_t)dev_us + m->offset;
    return t < 0 ? 0 : (uint64_t)t;
}

/* ------------------------------------------------------------------ the source */

typedef struct oni_src {
    char uri[1024];
    char dev_uri[ONI_MAX_STR];   /* the opened device's URI, for the callbacks */
    int want_w, want_h, want_fps, loop;
    double speed;                /* recordings: 1 = as recorded, 0 = as fast as read, lossless */
    int speed_set;
    int playback;                /* the device is a recording (OpenNI2's OniFile driver) */
    int paused;                  /* control "pause": the player is held in manual mode and read
                                    does not poke it, so the recording keeps its place */
    int initialized;
    OniDeviceHandle dev;
    OniStreamHandle stream;
    OniCallbackHandle cb;
    int cb_registered;
    atomic_int lost;
    atomic_int eof;              /* a recording without repeat has played its last frame */
    OniVideoMode mode;
    drv_intrinsics k;
    drv_depth_tracker *trk;
    uint16_t *mm;
    drv_clock_map clock;
    uint64_t seq;
    char record[512];            /* record=PATH.oni: OpenNI2's recorder writes the depth stream */
    OniRecorderHandle rec;
} oni_src;

static int uri_matches(const oni_src *o, const OniDeviceInfo *info)
{
    return info && !strncmp(o->dev_uri, info->uri, sizeof o->dev_uri);
}

static void ONI_CALLBACK_TYPE on_disconnected(const OniDeviceInfo *info, void *cookie)
{
    oni_src *o = cookie;
    if (uri_matches(o, info))
        atomic_store(&o->lost, 1);
}

static void ONI_CALLBACK_TYPE on_connected(const OniDeviceInfo *info, void *cookie)
{
    (void)info;
    (void)cookie;
}

static void ONI_CALLBACK_TYPE on_state(const OniDeviceInfo *info, OniDeviceState st, void *cookie)
{
    oni_src *o = cookie;
    if (!uri_matches(o, info))
        return;
    if (st == ONI_DEVICE_STATE_ERROR)
        atomic_store(&o->lost, 1);
    else if (st == ONI_DEVICE_STATE_EOF) /* OniFile, repeat off: after its last frame */
        atomic_store(&o->eof, 1);
}

/* OpenNI2's playback speed for ours: 0 (every frame, as fast as it is read) is its manual mode
 * (-1: the player releases the next frame when oniWaitForAnyStream pokes it); its own 0 would
 * let the player overrun the reader, and OpenNI2 keeps only the newest frame. */
static int set_speed(oni_src *o, double speed)
{
    float v = speed > 0 ? (float)speed : -1.0f;
    return oniDeviceSetProperty(o->dev, ONI_DEVICE_PROPERTY_PLAYBACK_SPEED, &v, sizeof v) ==
                   ONI_STATUS_OK
               ? 0
               : -EIO;
}

static void oni_free(oni_src *o)
{
    if (!o)
        return;
    if (o->rec)
        oniRecorderDestroy(&o->rec);
    if (o->stream) {
        oniStreamStop(o->stream);
        oniStreamDestroy(o->stream);
    }
    if (o->cb_registered)
        oniUnregisterDeviceCallbacks(o->cb);
    if (o->dev)
        oniDeviceClose(o->dev);
    if (o->initialized)
        oniShutdown();
    drv_depth_tracker_destroy(o->trk);
    free(o->mm);
    free(o);
}

static int parse_opts(oni_src *o, const char *q, char *err)
{
    char buf[256];
    if (strlen(q) >= sizeof buf)
        return drv__err(err, -EINVAL, "openni2: options too long");
    strcpy(buf, q);
    char *save = NULL;
    for (char *kv = strtok_r(buf, "&", &save); kv; kv = strtok_r(NULL, "&", &save)) {
        char *eq = strchr(kv, '=');
        if (!eq)
            return drv__err(err, -EINVAL, "openni2: option '%s': expected key=value", kv);
        *eq = '\0';
        if (!strcmp(kv, "record")) { /* a path, not a number */
            if (!eq[1] || strlen(eq + 1) >= sizeof o->record)
                return drv__err(err, -EINVAL, "openni2: option record: empty or too long a path");
            snprintf(o->record, sizeof o->record, "%s", eq + 1);
            continue;
        }
        if (!strcmp(kv, "speed")) { /* a factor, not an integer */
            char *end;
            double v = strtod(eq + 1, &end);
            if (*end || end == eq + 1 || (v != 0 && drv_speed_check(v, NULL)))
                return drv__err(err, -EINVAL, "openni2: option speed: '%s' is not 0 (every "
                                "frame, as fast as read) or a factor in [%g, %g]", eq + 1,
                                DRV_SPEED_MIN, DRV_SPEED_MAX);
            o->speed = v;
            o->speed_set = 1;
            continue;
        }
        char *end;
        long v = strtol(eq + 1, &end, 10);
        if (*end || end == eq + 1)
            return drv__err(err, -EINVAL, "openni2: option %s: '%s' is not a number", kv, eq + 1);
        if (!strcmp(kv, "width") && v >= 16 && v <= 4096)
            o->want_w = (int)v;
        else if (!strcmp(kv, "height") && v >= 16 && v <= 4096)
            o->want_h = (int)v;
        else if (!strcmp(kv, "fps") && v >= 1 && v <= 1000)
            o->want_fps = (int)v;
        else if (!strcmp(kv, "loop") && (v == 0 || v == 1))
            o->loop = (int)v;
        else
            return drv__err(err, -EINVAL,
                        "openni2: option %s=%ld unknown or out of range (width, height, fps, loop, "
                        "speed, record)",
                        kv, v);
    }
    return 0;
}

static int is_depth_format(OniPixelFormat f)
{
    return f == ONI_PIXEL_FORMAT_DEPTH_1_MM || f == ONI_PIXEL_FORMAT_DEPTH_100_UM;
}

/* the supported depth mode nearest to the wish (size first, then rate; 1 mm pixels preferred) */
static int choose_mode(const OniSensorInfo *si, int w, int h, int fps, OniVideoMode *out)
{
    double best = INFINITY;
    for (int i = 0; si && i < si->numSupportedVideoModes; i++) {
        const OniVideoMode *m = &si->pSupportedVideoModes[i];
        if (!is_depth_format(m->pixelFormat))
            continue;
        double c = fabs(log((double)m->resolutionX / w)) * 10 + fabs(log((double)m->resolutionY / h)) * 10 +
                   fabs((double)m->fps - fps) / fps + (m->pixelFormat == ONI_PIXEL_FORMAT_DEPTH_1_MM ? 0 : 0.01);
        if (c < best) {
            best = c;
            *out = *m;
        }
    }
    return isfinite(best) ? 0 : -1;
}

static int oni_open(drv_source *s, const char *arg, char *err)
{
    char why[256];
    oni_src *o = calloc(1, sizeof *o);
    if (!o)
        return drv__err(err, -ENOMEM, "openni2: out of memory");
    o->want_w = 640;
    o->want_h = 480;
    o->want_fps = 30;
    o->loop = 1;
    o->speed = 1;
    const char *hash = strchr(arg, '#');
    size_t ul = hash ? (size_t)(hash - arg) : strlen(arg);
    int r;
    if (ul >= sizeof o->uri) {
        free(o);
        return drv__err(err, -ENAMETOOLONG, "openni2: URI too long");
    }
    memcpy(o->uri, arg, ul);
    o->uri[ul] = '\0';
    const char *name = ul ? o->uri : "(any device)";
    if (hash && (r = parse_opts(o, hash + 1, err))) {
        free(o);
        return r;
    }
    atomic_init(&o->lost, 0);
    atomic_init(&o->eof, 0);
    if (oniInitialize(ONI_API_VERSION) != ONI_STATUS_OK) {
        r = drv__err(err, -EIO, "openni2: initialise: %s", oni_why(why));
        oni_free(o);
        return r;
    }
    o->initialized = 1;
    OniStatus st = oniDeviceOpen(ul ? o->uri : NULL, &o->dev);
    if (st != ONI_STATUS_OK) {
        o->dev = NULL;
        char wb[256];
        const char *why = oni_why(wb);
        r = drv__err(err, -ENODEV, "openni2 %s: cannot open: %s", name,
                 *why ? why : "no such device (is it plugged in, and is its driver in "
                                     "OpenNI2's driver directory?)");
        oni_free(o);
        return r;
    }
    OniDeviceInfo di;
    if (oniDeviceGetInfo(o->dev, &di) == ONI_STATUS_OK)
        memcpy(o->dev_uri, di.uri, sizeof o->dev_uri);
    o->dev_uri[sizeof o->dev_uri - 1] = '\0';
    OniDeviceCallbacks cbs = {on_connected, on_disconnected, on_state};
    if (oniRegisterDeviceCallbacks(&cbs, o, &o->cb) == ONI_STATUS_OK)
        o->cb_registered = 1;
    const OniSensorInfo *si = oniDeviceGetSensorInfo(o->dev, ONI_SENSOR_DEPTH);
    if (!si) {
        r = drv__err(err, -ENOTSUP, "openni2 %s: the device has no depth sensor", name);
        oni_free(o);
        return r;
    }
    if (oniDeviceCreateStream(o->dev, ONI_SENSOR_DEPTH, &o->stream) != ONI_STATUS_OK) {
        o->stream = NULL;
        r = drv__err(err, -EIO, "openni2 %s: cannot create the depth stream: %s", name,
                 oni_why(why));
        oni_free(o);
        return r;
    }
    OniVideoMode cur, want;
    int sz = sizeof cur;
    if (oniStreamGetProperty(o->stream, ONI_STREAM_PROPERTY_VIDEO_MODE, &cur, &sz) != ONI_STATUS_OK)
        memset(&cur, 0, sizeof cur);
    if (choose_mode(si, o->want_w, o->want_h, o->want_fps, &want) == 0 &&
        memcmp(&want, &cur, sizeof want) != 0) {
        if (oniStreamSetProperty(o->stream, ONI_STREAM_PROPERTY_VIDEO_MODE, &want, sizeof want) !=
            ONI_STATUS_OK) {
            r = drv__err(err, -ENOTSUP, "openni2 %s: cannot set depth mode %dx%d@%d: %s", name,
                     want.resolutionX, want.resolutionY, want.fps, oni_why(why));
            oni_free(o);
            return r;
        }
        cur = want;
    }
    sz = sizeof o->mode;
    if (oniStreamGetProperty(o->stream, ONI_STREAM_PROPERTY_VIDEO_MODE, &o->mode, &sz) !=
        ONI_STATUS_OK)
        o->mode = cur;
    if (!is_depth_format(o->mode.pixelFormat) || o->mode.resolutionX < 16 ||
        o->mode.resolutionY < 16 || o->mode.resolutionX > 4096 || o->mode.resolutionY > 4096) {
        r = drv__err(err, -ENOTSUP, "openni2 %s: depth mode %dx%d with pixel format %d is not usable "
                 "(want 1 mm or 100 um depth)", name, o->mode.resolutionX, o->mode.resolutionY,
                 (int)o->mode.pixelFormat);
        oni_free(o);
        return r;
    }
    OniBool mirror = 0;
    if (oniStreamIsPropertySupported(o->stream, ONI_STREAM_PROPERTY_MIRRORING))
        oniStreamSetProperty(o->stream, ONI_STREAM_PROPERTY_MIRRORING, &mirror, sizeof mirror);
    o->playback = oniDeviceIsPropertySupported(o->dev, ONI_DEVICE_PROPERTY_PLAYBACK_SPEED) &&
                  oniDeviceIsPropertySupported(o->dev, ONI_DEVICE_PROPERTY_PLAYBACK_REPEAT_ENABLED);
    if (o->playback) {
        OniBool rep = o->loop ? 1 : 0;
        if (oniDeviceSetProperty(o->dev, ONI_DEVICE_PROPERTY_PLAYBACK_REPEAT_ENABLED, &rep,
                                 sizeof rep) != ONI_STATUS_OK ||
            set_speed(o, o->speed) != 0) {
            r = drv__err(err, -EIO, "openni2 %s: cannot set the playback speed or repeat: %s",
                         name, oni_why(why));
            oni_free(o);
            return r;
        }
    } else if (o->speed_set) {
        r = drv__err(err, -EINVAL, "openni2 %s: speed= applies to recordings only", name);
        oni_free(o);
        return r;
    }
    float hfov = 0, vfov = 0;
    sz = sizeof hfov;
    oniStreamGetProperty(o->stream, ONI_STREAM_PROPERTY_HORIZONTAL_FOV, &hfov, &sz);
    sz = sizeof vfov;
    oniStreamGetProperty(o->stream, ONI_STREAM_PROPERTY_VERTICAL_FOV, &vfov, &sz);
    int w = o->mode.resolutionX, h = o->mode.resolutionY;
    drv_intrinsics_kinect1(&o->k);
    o->k.width = w;
    o->k.height = h;
    /* a device that reports no field of view: the Kinect's (58.5 x 45.6 degrees) */
    o->k.fx = hfov > 0.1f && hfov < 3.0f ? 0.5 * w / tan(0.5 * hfov) : 580.0 * w / 640.0;
    o->k.fy = vfov > 0.1f && vfov < 3.0f ? 0.5 * h / tan(0.5 * vfov) : 580.0 * h / 480.0;
    o->k.cx = (w - 1) * 0.5;
    o->k.cy = (h - 1) * 0.5;
    drv_depth_opts d;
    drv_depth_opts_default(&d);
    d.k = o->k;
    d.step = w >= 640 ? 4 : w >= 320 ? 2 : 1;
    d.step_min = d.step < d.step_min ? d.step : d.step_min; /* then sized by distance */
    if (!(o->mm = malloc((size_t)w * h * sizeof *o->mm))) {
        oni_free(o);
        return drv__err(err, -ENOMEM, "openni2 %s: out of memory", name);
    }
    if ((r = drv_depth_tracker_create(&d, &o->trk, err))) {
        oni_free(o);
        return r;
    }
    s->impl = o;
    s->count = DRV_DEPTH_NLABELS;
    s->names = (const char **)drv_depth_label_names;
    s->fps = o->mode.fps > 0 ? o->mode.fps : 30;
    /* recordings pause and change speed; no seek: OpenNI2's seek can hang when the stream is not
     * running. Live cameras take no controls. */
    s->controls = o->playback ? DRV_CTL_PAUSE | DRV_CTL_SPEED : 0;
    s->caps = o->playback ? 0 : DRV_CAP_USB_DEVICE;
    return 0;
}

/* OpenNI2's recorder writes the stream's cropping into the file only when the stream reports one
 * (ONI_STREAM_PROPERTY_CROPPING), and its player (OniFile's PlayerStream) silently drops every
 * frame of a stream whose cropping it does not know: such a recording would never play. */
/* The file a recording goes to: PATH itself when no file has that name, else the first free
 * STEM-N.EXT (N = 1, 2, ...): an earlier recording is never overwritten, also not when the daemon
 * reopens a lost camera and so starts recording again. */
static int recording_path(const char *path, char *out, size_t n)
{
    if (access(path, F_OK) != 0) {
        snprintf(out, n, "%s", path);
        return 0;
    }
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    size_t stem = dot && (!slash || dot > slash + 1) ? (size_t)(dot - path) : strlen(path);
    for (int k = 1; k < 100000; k++) {
        if ((size_t)snprintf(out, n, "%.*s-%d%s", (int)stem, path, k, path + stem) >= n)
            return -ENAMETOOLONG;
        if (access(out, F_OK) != 0)
            return 0;
    }
    return -EEXIST;
}

static int start_recorder(oni_src *o, char *err)
{
    char why[256], path[sizeof o->record + 16];
    OniCropping crop;
    int sz = sizeof crop;
    if (oniStreamGetProperty(o->stream, ONI_STREAM_PROPERTY_CROPPING, &crop, &sz) != ONI_STATUS_OK)
        return drv__err(err, -ENOTSUP, "openni2 %s: cannot record to %s: the device's driver "
                        "reports no cropping property, without which OpenNI2's player drops "
                        "every frame of the recording", o->uri, o->record);
    int r = recording_path(o->record, path, sizeof path);
    if (r)
        return drv__err(err, r, "openni2 %s: cannot record to %s: no free file name beside it",
                        o->uri, o->record);
    if (oniCreateRecorder(path, &o->rec) != ONI_STATUS_OK ||
        oniRecorderAttachStream(o->rec, o->stream, 0) != ONI_STATUS_OK ||
        oniRecorderStart(o->rec) != ONI_STATUS_OK) {
        r = drv__err(err, -EIO, "openni2 %s: cannot record to %s: %s", o->uri, path,
                     oni_why(why));
        if (o->rec)
            oniRecorderDestroy(&o->rec);
        return r;
    }
    return 0;
}

static int oni_start(drv_source *s, char *err)
{
    char why[256];
    oni_src *o = s->impl;
    int r;
    drv_depth_tracker_reset(o->trk);
    memset(&o->clock, 0, sizeof o->clock);
    atomic_store(&o->eof, 0);
    /* the recorder first (lossless: the recording must replay to the same markers): it starts
     * on its own thread and drops the frames that come before */
    if (o->record[0] && !o->rec && (r = start_recorder(o, err)))
        return r;
    if (oniStreamStart(o->stream) != ONI_STATUS_OK)
        return drv__err(err, atomic_load(&o->lost) ? DRV_ELOST : -EIO,
                    "openni2 %s: cannot start the depth stream: %s", o->uri, oni_why(why));
    return 0;
}

static int oni_read(drv_source *s, drv_frame *fr, int timeout_ms, char *err)
{
    char why[256];
    oni_src *o = s->impl;
    if (atomic_load(&o->lost))
        return drv__err(err, DRV_ELOST, "openni2 %s: device disconnected", o->uri);
    if (o->paused) { /* waiting for a stream would let the manual-mode player release a frame */
        int ms = timeout_ms < 0 || timeout_ms > 100 ? 100 : timeout_ms;
        struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
        nanosleep(&ts, NULL);
        return DRV_ETIMEOUT;
    }
    int idx = -1, left = timeout_ms; /* < 0: forever (ONI_TIMEOUT_FOREVER is -1) */
    OniStatus st;
    for (;;) { /* a recording played once may end during the wait: wait in slices to notice */
        int eof = atomic_load(&o->eof);
        int t = eof ? 0 : left;
        if (o->playback && !o->loop && (t < 0 || t > 100))
            t = 100;
        st = oniWaitForAnyStream(&o->stream, 1, &idx, t);
        if (st != ONI_STATUS_TIME_OUT || eof || atomic_load(&o->lost))
            break;
        if (atomic_load(&o->eof)) /* ended: one more look for its last frame */
            continue;
        if (left >= 0 && (left -= t) <= 0)
            break;
    }
    if (atomic_load(&o->lost))
        return drv__err(err, DRV_ELOST, "openni2 %s: device disconnected", o->uri);
    if (st == ONI_STATUS_TIME_OUT)
        return atomic_load(&o->eof) ? DRV_EEOF : DRV_ETIMEOUT;
    if (st != ONI_STATUS_OK)
        return drv__err(err, DRV_ELOST, "openni2 %s: waiting for depth: %s", o->uri,
                    oni_why(why));
    OniFrame *f = NULL;
    if (oniStreamReadFrame(o->stream, &f) != ONI_STATUS_OK || !f)
        return drv__err(err, DRV_ELOST, "openni2 %s: reading depth: %s", o->uri, oni_why(why));
    uint64_t host = now_us();
    int w = o->k.width, h = o->k.height;
    int r = 0;
    if (f->sensorType != ONI_SENSOR_DEPTH || f->width != w || f->height != h || !f->data ||
        f->stride < 2 * w || (size_t)f->dataSize < (size_t)f->stride * (size_t)(h - 1) + 2u * w ||
        !is_depth_format(f->videoMode.pixelFormat)) {
        r = drv__err(err, -EPROTO, "openni2 %s: frame %d is %dx%d (stride %d, %d bytes), expected "
                 "%dx%d depth", o->uri, f->frameIndex, f->width, f->height, f->stride, f->dataSize,
                 w, h);
        oniFrameRelease(f);
        return r;
    }
    const int um100 = f->videoMode.pixelFormat == ONI_PIXEL_FORMAT_DEPTH_100_UM;
    for (int y = 0; y < h; y++) {
        const uint16_t *row = (const uint16_t *)((const uint8_t *)f->data + (size_t)y * f->stride);
        uint16_t *out = o->mm + (size_t)y * w;
        if (um100)
            for (int x = 0; x < w; x++)
                out[x] = (uint16_t)((row[x] + 5) / 10);
        else
            memcpy(out, row, (size_t)w * sizeof *out);
    }
    uint64_t t = drv_clock_map_apply(&o->clock, f->timestamp, host);
    oniFrameRelease(f);
    drv_depth_result res;
    drv_depth_tracker_process(o->trk, o->mm, t, &res);
    for (int l = 0; l < DRV_DEPTH_NLABELS; l++) {
        memcpy(fr->xyz + 3 * l, res.xyz[l], 3 * sizeof(float));
        fr->valid[l] = res.valid[l];
    }
    fr->seq = o->seq++;
    fr->t_capture_us = t;
    return 0;
}

/* Recordings: "pause" 1 holds the player (OpenNI2's manual mode, which releases a frame only
 * when oniWaitForAnyStream asks, and read does not ask while paused), 0 restores the speed;
 * "speed" S (0 .. 100, as the option; 0 = every frame as fast as read) applies at once, or on
 * resume when paused. drv_source_control passes only these two (s->controls). */
static int oni_control(drv_source *s, unsigned ctl, double value, char *err)
{
    char why[256];
    oni_src *o = s->impl;
    if (!o->playback)
        return drv__err(err, -ENOTSUP, "openni2 %s: a live camera takes no controls", o->uri);
    if (ctl == DRV_CTL_PAUSE) {
        if (value != 0 && value != 1)
            return drv__err(err, -EINVAL, "openni2 %s: pause must be 0 or 1", o->uri);
        if ((value != 0) == o->paused)
            return 0;
        if (set_speed(o, value != 0 ? 0 : o->speed))
            return drv__err(err, -EIO, "openni2 %s: cannot %s the playback: %s", o->uri,
                            value != 0 ? "pause" : "resume", oni_why(why));
        o->paused = value != 0;
        return 0;
    }
    if (ctl == DRV_CTL_SPEED) { /* the range: drv_source_control */
        if (!o->paused && set_speed(o, value))
            return drv__err(err, -EIO, "openni2 %s: cannot set the playback speed to %g: %s",
                            o->uri, value, oni_why(why));
        o->speed = value;
        return 0;
    }
    return drv__err(err, -ENOTSUP, "openni2 %s: no control '%s' (recordings take pause, speed)",
                    o->uri, drv_control_name(ctl));
}

static void oni_stop(drv_source *s)
{
    oni_src *o = s->impl;
    oniStreamStop(o->stream);
}

static void oni_close(drv_source *s)
{
    oni_free(s->impl);
    s->impl = NULL;
}

const drv_source_ops drv_openni2_ops = {
    .scheme = "openni2",
    .open = oni_open,
    .start = oni_start,
    .read = oni_read,
    .control = oni_control, /* recordings only: s->controls */
    .stop = oni_stop,
    .close = oni_close,
};
