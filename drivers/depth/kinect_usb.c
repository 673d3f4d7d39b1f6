/* kinect_usb.c - depth sensors on USB (libusb 1.0): the device table, the arrival/departure
 * watcher (hotplug callbacks where libusb supports them, else enumeration diffs), and the Kinect
 * v1 motor's vendor control requests. Encodings as documented in ../depth.h. */
#include "../drv_err.h"
#include "../depth.h"

#include <errno.h>
#include <libusb.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const struct {
    uint16_t vid, pid;
    const char *kind;
} known[] = {
    {0x045e, 0x02ae, "kinect1-camera"}, {0x045e, 0x02b0, "kinect1-motor"},
    {0x045e, 0x02c2, "kinect1-windows"}, {0x1d27, 0x0600, "primesense"},
    {0x1d27, 0x0601, "primesense"},     {0x1d27, 0x0609, "primesense"},
};

const char *drv_usb_depth_kind(uint16_t vid, uint16_t pid)
{
    for (size_t i = 0; i < sizeof known / sizeof *known; i++)
        if (known[i].vid == vid && known[i].pid == pid)
            return known[i].kind;
    return NULL;
}

/* ------------------------------------------------------------------ request encoding */

int drv_kinect_led_parse(const char *name, int *led, char *err)
{
    static const struct { const char *n; int v; } t[] = {
        {"off", DRV_KINECT_LED_OFF}, {"green", DRV_KINECT_LED_GREEN}, {"red", DRV_KINECT_LED_RED},
        {"yellow", DRV_KINECT_LED_YELLOW}, {"blink-green", DRV_KINECT_LED_BLINK_GREEN},
        {"blink-red-yellow", DRV_KINECT_LED_BLINK_RED_YELLOW}};
    for (size_t i = 0; name && i < sizeof t / sizeof *t; i++)
        if (!strcmp(name, t[i].n)) {
            *led = t[i].v;
            return 0;
        }
    return drv__err(err, -EINVAL,
                "kinect: LED '%s': expected off, green, red, yellow, blink-green or blink-red-yellow",
                name ? name : "");
}

int drv_kinect_led_request(int led, drv_usb_request *rq, char *err)
{
    if (led < 0 || led > 6 || led == 5)
        return drv__err(err, -EINVAL, "kinect: LED mode %d unknown", led);
    *rq = (drv_usb_request){0x40, 0x06, (uint16_t)led, 0, 0};
    return 0;
}

int drv_kinect_tilt_request(double degrees, drv_usb_request *rq, char *err)
{
    if (!(degrees >= -31.0 && degrees <= 31.0))
        return drv__err(err, -EINVAL, "kinect: tilt %g degrees: the motor moves within -31..31", degrees);
    long half = lround(degrees * 2.0);
    *rq = (drv_usb_request){0x40, 0x31, (uint16_t)(int16_t)half, 0, 0};
    return 0;
}

void drv_kinect_state_request(drv_usb_request *rq)
{
    *rq = (drv_usb_request){0xC0, 0x32, 0, 0, 10};
}

int drv_kinect_state_parse(const uint8_t *buf, size_t len, drv_kinect_state *st, char *err)
{
    if (len < 10)
        return drv__err(err, -EPROTO, "kinect: motor state has %zu bytes, expected 10", len);
    for (int a = 0; a < 3; a++)
        st->accel[a] = (int16_t)(uint16_t)(buf[2 + 2 * a] << 8 | buf[3 + 2 * a]);
    st->tilt_deg = buf[8] == 0x80 ? NAN : (int8_t)buf[8] * 0.5;
    st->status = buf[9];
    return 0;
}

/* ------------------------------------------------------------------ the watcher */

#define WATCH_MAX 32

struct drv_usb_watch {
    libusb_context *ctx;
    drv_usb_event_fn fn;
    void *user;
    int hotplug;
    libusb_hotplug_callback_handle cb;
    drv_usb_dev seen[WATCH_MAX]; /* polling: the known devices present at the last scan */
    int nseen;
};

static void dev_of(libusb_device *d, const struct libusb_device_descriptor *desc, drv_usb_dev *o)
{
    o->vid = desc->idVendor;
    o->pid = desc->idProduct;
    o->bus = libusb_get_bus_number(d);
    o->addr = libusb_get_device_address(d);
    o->kind = drv_usb_depth_kind(o->vid, o->pid);
}

static int LIBUSB_CALL on_hotplug(libusb_context *ctx, libusb_device *d, libusb_hotplug_event ev,
                                  void *user)
{
    (void)ctx;
    drv_usb_watch *w = user;
    struct libusb_device_descriptor desc;
    if (libusb_get_device_descriptor(d, &desc) != 0)
        return 0;
    drv_usb_dev o;
    dev_of(d, &desc, &o);
    if (o.kind)
        w->fn(w->user, ev == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED, &o);
    return 0;
}

/* polling: enumerate, report the difference to the last scan */
static int scan(drv_usb_watch *w, char *err)
{
    libusb_device **list;
    ssize_t n = libusb_get_device_list(w->ctx, &list);
    if (n < 0)
        return drv__err(err, -EIO, "usb: listing devices: %s", libusb_strerror((int)n));
    drv_usb_dev now[WATCH_MAX];
    int nnow = 0;
    for (ssize_t i = 0; i < n && nnow < WATCH_MAX; i++) {
        struct libusb_device_descriptor desc;
        if (libusb_get_device_descriptor(list[i], &desc) != 0)
            continue;
        dev_of(list[i], &desc, &now[nnow]);
        if (now[nnow].kind)
            nnow++;
    }
    libusb_free_device_list(list, 1);
    for (int i = 0; i < w->nseen; i++) {
        int still = 0;
        for (int j = 0; j < nnow && !still; j++)
            still = !memcmp(&w->seen[i], &now[j], sizeof now[j]);
        if (!still)
            w->fn(w->user, 0, &w->seen[i]);
    }
    for (int j = 0; j < nnow; j++) {
        int had = 0;
        for (int i = 0; i < w->nseen && !had; i++)
            had = !memcmp(&w->seen[i], &now[j], sizeof now[j]);
        if (!had)
            w->fn(w->user, 1, &now[j]);
    }
    memcpy(w->seen, now, (size_t)nnow * sizeof *now);
    w->nseen = nnow;
    return 0;
}

int drv_usb_watch_create(drv_usb_event_fn fn, void *user, drv_usb_watch **out, char *err)
{
    *out = NULL;
    drv_usb_watch *w = calloc(1, sizeof *w);
    if (!w)
        return drv__err(err, -ENOMEM, "usb: out of memory");
    w->fn = fn;
    w->user = user;
    int r = libusb_init(&w->ctx);
    if (r != 0) {
        free(w);
        return drv__err(err, -ENODEV, "usb: libusb_init: %s", libusb_strerror(r));
    }
    if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) &&
        libusb_hotplug_register_callback(
            w->ctx, LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT,
            LIBUSB_HOTPLUG_ENUMERATE, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
            LIBUSB_HOTPLUG_MATCH_ANY, on_hotplug, w, &w->cb) == LIBUSB_SUCCESS) {
        w->hotplug = 1;
    } else if ((r = scan(w, err))) {
        libusb_exit(w->ctx);
        free(w);
        return r;
    }
    *out = w;
    return 0;
}

int drv_usb_watch_hotplug(const drv_usb_watch *w)
{
    return w->hotplug;
}

int drv_usb_watch_poll(drv_usb_watch *w, int timeout_ms, char *err)
{
    if (timeout_ms < 0)
        timeout_ms = 1000;
    if (w->hotplug) {
        struct timeval tv = {timeout_ms / 1000, (timeout_ms % 1000) * 1000};
        int r = libusb_handle_events_timeout_completed(w->ctx, &tv, NULL);
        if (r != 0 && r != LIBUSB_ERROR_INTERRUPTED)
            return drv__err(err, -EIO, "usb: handling events: %s", libusb_strerror(r));
        return 0;
    }
    struct timespec ts = {timeout_ms / 1000, (long)(timeout_ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
    return scan(w, err);
}

void drv_usb_watch_destroy(drv_usb_watch *w)
{
    if (!w)
        return;
    if (w->hotplug)
        libusb_hotplug_deregister_callback(w->ctx, w->cb);
    libusb_exit(w->ctx);
    free(w);
}

/* ------------------------------------------------------------------ the motor */

struct drv_kinect_motor {
    libusb_context *ctx;
    libusb_device_handle *h;
};

int drv_kinect_motor_open(drv_kinect_motor **out, char *err)
{
    *out = NULL;
    drv_kinect_motor *m = calloc(1, sizeof *m);
    if (!m)
        return drv__err(err, -ENOMEM, "kinect: out of memory");
    int r = libusb_init(&m->ctx);
    if (r != 0) {
        free(m);
        return drv__err(err, -ENODEV, "kinect: USB not available: %s", libusb_strerror(r));
    }
    libusb_device **list;
    ssize_t n = libusb_get_device_list(m->ctx, &list);
    libusb_device *found = NULL;
    for (ssize_t i = 0; i < n && !found; i++) {
        struct libusb_device_descriptor d;
        if (libusb_get_device_descriptor(list[i], &d) == 0 && d.idVendor == 0x045e &&
            d.idProduct == 0x02b0)
            found = list[i];
    }
    r = found ? libusb_open(found, &m->h) : LIBUSB_ERROR_NO_DEVICE;
    if (n >= 0)
        libusb_free_device_list(list, 1);
    if (r != 0) {
        libusb_exit(m->ctx);
        free(m);
        if (r == LIBUSB_ERROR_NO_DEVICE)
            return drv__err(err, -ENODEV, "kinect: no Kinect v1 motor (045e:02b0) attached");
        return drv__err(err, r == LIBUSB_ERROR_ACCESS ? -EACCES : -EIO,
                    "kinect: opening the motor (045e:02b0): %s%s", libusb_strerror(r),
                    r == LIBUSB_ERROR_ACCESS ? " (a udev rule must give you access)" : "");
    }
    *out = m;
    return 0;
}

void drv_kinect_motor_close(drv_kinect_motor *m)
{
    if (!m)
        return;
    libusb_close(m->h);
    libusb_exit(m->ctx);
    free(m);
}

static int transfer(drv_kinect_motor *m, const drv_usb_request *rq, uint8_t *data, const char *what,
                    char *err)
{
    int r = libusb_control_transfer(m->h, rq->bm_request_type, rq->b_request, rq->w_value,
                                    rq->w_index, data, rq->w_length, 1000);
    if (r < 0)
        return drv__err(err, r == LIBUSB_ERROR_NO_DEVICE ? DRV_ELOST : -EIO, "kinect: %s: %s", what,
                    libusb_strerror(r));
    return r;
}

int drv_kinect_motor_led(drv_kinect_motor *m, int led, char *err)
{
    drv_usb_request rq;
    int r = drv_kinect_led_request(led, &rq, err);
    if (r)
        return r;
    r = transfer(m, &rq, NULL, "set LED", err);
    return r < 0 ? r : 0;
}

int drv_kinect_motor_tilt(drv_kinect_motor *m, double degrees, char *err)
{
    drv_usb_request rq;
    int r = drv_kinect_tilt_request(degrees, &rq, err);
    if (r)
        return r;
    r = transfer(m, &rq, NULL, "set tilt", err);
    return r < 0 ? r : 0;
}

int drv_kinect_motor_state(drv_kinect_motor *m, drv_kinect_state *st, char *err)
{
    drv_usb_request rq;
    uint8_t buf[10];
    drv_kinect_state_request(&rq);
    int r = transfer(m, &rq, buf, "read state", err);
    if (r < 0)
        return r;
    return drv_kinect_state_parse(buf, (size_t)r, st, err);
}

/* ------------------------------------------------------------------ drivers.h's device watch */

struct drv_device_watch {
    drv_usb_watch *w;
    drv_device_fn fn;
    void *user;
};

static void device_event(void *user, int arrived, const drv_usb_dev *d)
{
    drv_device_watch *dw = user;
    char what[128];
    snprintf(what, sizeof what, "%s %04x:%04x at bus %u address %u", d->kind ? d->kind : "device",
             d->vid, d->pid, d->bus, d->addr);
    dw->fn(dw->user, arrived, what);
}

int drv_device_watch_create(drv_device_fn fn, void *user, drv_device_watch **out, char *err)
{
    *out = NULL;
    drv_device_watch *dw = calloc(1, sizeof *dw);
    if (!dw)
        return drv__err(err, -ENOMEM, "usb: out of memory");
    dw->fn = fn;
    dw->user = user;
    int r = drv_usb_watch_create(device_event, dw, &dw->w, err);
    if (r) {
        free(dw);
        return r;
    }
    *out = dw;
    return 0;
}

int drv_device_watch_poll(drv_device_watch *w, int timeout_ms, char *err)
{
    return drv_usb_watch_poll(w->w, timeout_ms, err);
}

int drv_device_watch_hotplug(const drv_device_watch *w)
{
    return drv_usb_watch_hotplug(w->w);
}

void drv_device_watch_destroy(drv_device_watch *w)
{
    if (!w)
        return;
    drv_usb_watch_destroy(w->w);
    free(w);
}
