/* oni_testcam.c - an OpenNI2 driver plugin (libMeshsteerTestCam.so.0) that serves a fakenect dump
 * directory (fakenect.h; written from the test camera, render.c) as a depth device, so that tests
 * run OpenNI2's own driver loading, device and stream code with no hardware.
 *
 * OpenNI2 loads drivers by the C symbols that Driver/OniDriverAPI.h's ONI_EXPORT_DRIVER macro
 * defines (oniDriverCreate, oniDriverDeviceOpen, oniDriverStreamStart, ...). That header wraps
 * them around C++ classes; the ABI itself is plain C (opaque device and stream pointers, the
 * OniDriverServices / OniStreamServices tables of Driver/OniDriverTypes.h), so this plugin
 * implements the symbols directly in C. Debian's libOpenNI2 looks for drivers named *.so.0 in
 * "OpenNI2/Drivers" next to the loaded libOpenNI2.so.0 (or the Repository of the fixed
 * /etc/openni2/OpenNI.ini); tests stage such a directory (test_openni2.c).
 *
 * URI: meshsteer-testcam:DIR[?vanish=N&fps=F&delay=MS&cropping=0|1]. One depth stream, 640x480
 * 1 mm pixels, frames of DIR in a loop at F fps (default: the recorded rate), timestamps in device
 * microseconds from stream start; the first frame comes MS milliseconds after the stream starts
 * (default 0; OpenNI2's recorder, started on its own thread, misses frames that come before it
 * runs: `meshsteer record oni` waits so that a recording holds every frame). vanish=N: after N frames the device reports itself disconnected
 * (OpenNI2's deviceDisconnected callback) and delivers nothing more; opening the URI again brings
 * it back. The stream reports cropping (off) as real drivers do, since OpenNI2's recorder needs it
 * for its recordings to play; cropping=0 imitates a driver that does not.
 * The driver ABI has no handle for the driver itself, so its callbacks live in one file-scope
 * struct (the one exception to "state in the handle" that the plugin ABI forces). */
#include "fakenect.h"
#include "oni_c.h"

#include <Driver/OniDriverTypes.h>
#include <OniCProperties.h>

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define EXPORT __attribute__((visibility("default")))
typedef struct OniStreamServices OniStreamServices; /* C++ names structs without "struct" */
typedef struct OniDriverServices OniDriverServices;
#define TC_W 640
#define TC_H 480
#define TC_PREFIX "meshsteer-testcam:"

typedef void (*tc_dev_cb)(const OniDeviceInfo *, void *);
typedef void (*tc_state_cb)(const OniDeviceInfo *, int, void *);
typedef void (*tc_frame_cb)(void *stream, OniFrame *, void *);
typedef void (*tc_prop_cb)(void *sender, int id, const void *data, int size, void *cookie);

static struct {
    tc_dev_cb connected, disconnected;
    tc_state_cb state_changed;
    void *cookie;
} g_drv;

typedef struct tc_device tc_device;

typedef struct tc_stream {
    tc_device *dev;
    OniStreamServices *svc;
    tc_frame_cb on_frame;
    void *frame_cookie;
    pthread_t thread;
    int running;
    atomic_int stop;
    int mirror;
} tc_stream;

struct tc_device {
    OniDeviceInfo info;
    OniVideoMode mode;
    OniSensorInfo sensor;
    char dir[1024];
    int vanish;            /* frames before vanishing, 0 = never */
    int delay_ms;          /* before the first frame */
    int cropping;          /* 1: the cropping property is reported */
    double fps;
    int n;                 /* frames */
    char (*file)[96];
    uint16_t *mm;
    uint8_t *buf;
    tc_stream *stream;
};

static int parse_uri(const char *uri, char *dir, size_t dirlen, int *vanish, double *fps,
                     int *delay_ms, int *cropping)
{
    if (strncmp(uri, TC_PREFIX, strlen(TC_PREFIX)))
        return -1;
    const char *p = uri + strlen(TC_PREFIX);
    const char *q = strchr(p, '?');
    size_t dl = q ? (size_t)(q - p) : strlen(p);
    if (dl == 0 || dl >= dirlen)
        return -1;
    memcpy(dir, p, dl);
    dir[dl] = '\0';
    *vanish = 0;
    *fps = 0;
    *delay_ms = 0;
    *cropping = 1;
    while (q && *q) {
        q++;
        char *end;
        if (!strncmp(q, "vanish=", 7)) {
            long v = strtol(q + 7, &end, 10);
            if (end == q + 7 || v < 0)
                return -1;
            *vanish = (int)v;
        } else if (!strncmp(q, "delay=", 6)) {
            long v = strtol(q + 6, &end, 10);
            if (end == q + 6 || v < 0 || v > 60000)
                return -1;
            *delay_ms = (int)v;
        } else if (!strncmp(q, "fps=", 4)) {
            double f = strtod(q + 4, &end);
            if (end == q + 4 || !(f > 0 && f <= 1000))
                return -1;
            *fps = f;
        } else if (!strncmp(q, "cropping=", 9) && (q[9] == '0' || q[9] == '1')) {
            *cropping = q[9] == '1';
            end = (char *)q + 10;
        } else {
            return -1;
        }
        if (*end == '&')
            q = end;
        else if (*end == '\0')
            q = NULL;
        else
            return -1;
    }
    return 0;
}

/* reads DIR/INDEX.txt: depth file names and the recorded rate */
static int load_index(tc_device *d)
{
    char path[1100], line[512];
    snprintf(path, sizeof path, "%s/INDEX.txt", d->dir);
    FILE *in = fopen(path, "r");
    if (!in)
        return -1;
    int cap = 0;
    double t0 = 0, t1 = 0;
    while (fgets(line, sizeof line, in)) {
        double t;
        uint32_t ts;
        size_t len = strlen(line);
        if (len < 2)
            continue;
        if (drv_fakenect_parse_index_line(line, len, &t, &ts, NULL) != 1)
            continue;
        if (d->n == cap) {
            cap = cap ? 2 * cap : 64;
            void *nf = realloc(d->file, (size_t)cap * sizeof *d->file);
            if (!nf)
                break;
            d->file = nf;
        }
        size_t nl = strcspn(line, "\r\n");
        if (nl >= sizeof d->file[0])
            continue;
        memcpy(d->file[d->n], line, nl);
        d->file[d->n][nl] = '\0';
        if (d->n == 0)
            t0 = t;
        t1 = t;
        d->n++;
    }
    fclose(in);
    if (d->fps <= 0)
        d->fps = d->n > 1 && t1 > t0 ? (d->n - 1) / (t1 - t0) : 30;
    return d->n > 0 ? 0 : -1;
}

static void sleep_us(uint64_t us)
{
    struct timespec ts = {(time_t)(us / 1000000u), (long)(us % 1000000u) * 1000L};
    nanosleep(&ts, NULL);
}

static void *stream_thread(void *arg)
{
    tc_stream *s = arg;
    tc_device *d = s->dev;
    uint64_t period = (uint64_t)(1e6 / d->fps);
    int sent = 0;
    for (int waited = 0; waited < d->delay_ms && !atomic_load(&s->stop); waited += 10)
        sleep_us(10000);
    for (int k = 0; !atomic_load(&s->stop); k = (k + 1) % d->n) {
        if (d->vanish > 0 && sent >= d->vanish) {
            if (g_drv.disconnected)
                g_drv.disconnected(&d->info, g_drv.cookie);
            break;
        }
        char path[1200];
        snprintf(path, sizeof path, "%s/%s", d->dir, d->file[k]);
        FILE *in = fopen(path, "rb");
        size_t len = 0;
        if (in) {
            len = fread(d->buf, 1, 64 + (size_t)TC_W * TC_H * 2, in);
            fclose(in);
        }
        if (!in || drv_fakenect_parse_depth(d->buf, len, path, d->mm, NULL) != 0) {
            if (g_drv.state_changed)
                g_drv.state_changed(&d->info, ONI_DEVICE_STATE_ERROR, g_drv.cookie);
            break;
        }
        OniFrame *f = s->svc->acquireFrame(s->svc->streamServices);
        if (f) {
            uint16_t *dst = f->data;
            for (int y = 0; y < TC_H; y++)
                for (int x = 0; x < TC_W; x++)
                    dst[y * TC_W + x] = d->mm[y * TC_W + (s->mirror ? TC_W - 1 - x : x)];
            f->dataSize = TC_W * TC_H * 2;
            f->sensorType = ONI_SENSOR_DEPTH;
            f->timestamp = (uint64_t)sent * period + 1000;
            f->frameIndex = sent + 1;
            f->width = TC_W;
            f->height = TC_H;
            f->videoMode = d->mode;
            f->croppingEnabled = 0;
            f->cropOriginX = f->cropOriginY = 0;
            f->stride = TC_W * 2;
            if (s->on_frame)
                s->on_frame(s, f, s->frame_cookie);
            s->svc->releaseFrame(s->svc->streamServices, f);
        }
        sent++;
        sleep_us(period);
    }
    return NULL;
}

/* ------------------------------------------------------------------ driver */

EXPORT void oniDriverCreate(OniDriverServices *services)
{
    (void)services;
    memset(&g_drv, 0, sizeof g_drv);
}

EXPORT void oniDriverDestroy(void)
{
    memset(&g_drv, 0, sizeof g_drv);
}

EXPORT OniStatus oniDriverInitialize(tc_dev_cb connected, tc_dev_cb disconnected,
                                     tc_state_cb state_changed, void *cookie)
{
    g_drv.connected = connected;
    g_drv.disconnected = disconnected;
    g_drv.state_changed = state_changed;
    g_drv.cookie = cookie;
    return ONI_STATUS_OK;
}

EXPORT OniStatus oniDriverTryDevice(const char *uri)
{
    char dir[1024], path[1100];
    int vanish, delay, cropping;
    double fps;
    if (!uri || parse_uri(uri, dir, sizeof dir, &vanish, &fps, &delay, &cropping) != 0)
        return ONI_STATUS_ERROR;
    snprintf(path, sizeof path, "%s/INDEX.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f)
        return ONI_STATUS_ERROR;
    fclose(f);
    OniDeviceInfo info;
    memset(&info, 0, sizeof info);
    snprintf(info.uri, sizeof info.uri, "%s", uri);
    snprintf(info.vendor, sizeof info.vendor, "meshsteer");
    snprintf(info.name, sizeof info.name, "test camera");
    if (g_drv.connected)
        g_drv.connected(&info, g_drv.cookie);
    return ONI_STATUS_OK;
}

EXPORT void *oniDriverDeviceOpen(const char *uri, const char *mode)
{
    (void)mode;
    tc_device *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    if (!uri || parse_uri(uri, d->dir, sizeof d->dir, &d->vanish, &d->fps, &d->delay_ms, &d->cropping) != 0 ||
        load_index(d) != 0 || !(d->mm = malloc((size_t)TC_W * TC_H * 2)) ||
        !(d->buf = malloc(64 + (size_t)TC_W * TC_H * 2 + 1))) {
        free(d->file);
        free(d->mm);
        free(d);
        return NULL;
    }
    snprintf(d->info.uri, sizeof d->info.uri, "%s", uri);
    snprintf(d->info.vendor, sizeof d->info.vendor, "meshsteer");
    snprintf(d->info.name, sizeof d->info.name, "test camera");
    d->mode.pixelFormat = ONI_PIXEL_FORMAT_DEPTH_1_MM;
    d->mode.resolutionX = TC_W;
    d->mode.resolutionY = TC_H;
    d->mode.fps = (int)lround(d->fps);
    d->sensor.sensorType = ONI_SENSOR_DEPTH;
    d->sensor.numSupportedVideoModes = 1;
    d->sensor.pSupportedVideoModes = &d->mode;
    return d;
}

EXPORT void oniDriverDeviceClose(void *dev)
{
    tc_device *d = dev;
    if (!d)
        return;
    free(d->file);
    free(d->mm);
    free(d->buf);
    free(d);
}

EXPORT OniStatus oniDriverDeviceGetSensorInfoList(void *dev, OniSensorInfo **infos, int *n)
{
    tc_device *d = dev;
    *infos = &d->sensor;
    *n = 1;
    return ONI_STATUS_OK;
}

EXPORT void *oniDriverDeviceCreateStream(void *dev, OniSensorType type)
{
    tc_device *d = dev;
    if (type != ONI_SENSOR_DEPTH || d->stream)
        return NULL;
    tc_stream *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->dev = d;
    atomic_init(&s->stop, 0);
    d->stream = s;
    return s;
}

EXPORT void oniDriverStreamStop(void *stream);

EXPORT void oniDriverDeviceDestroyStream(void *dev, void *stream)
{
    tc_device *d = dev;
    oniDriverStreamStop(stream);
    if (d && d->stream == stream)
        d->stream = NULL;
    free(stream);
}

EXPORT OniStatus oniDriverDeviceSetProperty(void *dev, int id, const void *data, int size)
{
    (void)dev, (void)id, (void)data, (void)size;
    return ONI_STATUS_NOT_SUPPORTED;
}
EXPORT OniStatus oniDriverDeviceGetProperty(void *dev, int id, void *data, int *size)
{
    (void)dev, (void)id, (void)data, (void)size;
    return ONI_STATUS_NOT_SUPPORTED;
}
EXPORT OniBool oniDriverDeviceIsPropertySupported(void *dev, int id)
{
    (void)dev, (void)id;
    return 0;
}
EXPORT void oniDriverDeviceSetPropertyChangedCallback(void *dev, tc_prop_cb cb, void *cookie)
{
    (void)dev, (void)cb, (void)cookie;
}
EXPORT void oniDriverDeviceNotifyAllProperties(void *dev)
{
    (void)dev;
}
EXPORT OniStatus oniDriverDeviceInvoke(void *dev, int id, void *data, int size)
{
    (void)dev, (void)id, (void)data, (void)size;
    return ONI_STATUS_NOT_SUPPORTED;
}
EXPORT OniBool oniDriverDeviceIsCommandSupported(void *dev, int id)
{
    (void)dev, (void)id;
    return 0;
}
EXPORT OniStatus oniDriverDeviceTryManualTrigger(void *dev)
{
    (void)dev;
    return ONI_STATUS_OK;
}
EXPORT OniBool oniDriverDeviceIsImageRegistrationModeSupported(void *dev, OniImageRegistrationMode m)
{
    (void)dev;
    return m == ONI_IMAGE_REGISTRATION_OFF;
}

/* ------------------------------------------------------------------ stream */

EXPORT void oniDriverStreamSetServices(void *stream, OniStreamServices *svc)
{
    ((tc_stream *)stream)->svc = svc;
}

EXPORT OniStatus oniDriverStreamSetProperty(void *stream, int id, const void *data, int size)
{
    tc_stream *s = stream;
    if (id == ONI_STREAM_PROPERTY_MIRRORING && size == (int)sizeof(OniBool)) {
        s->mirror = *(const OniBool *)data != 0;
        return ONI_STATUS_OK;
    }
    if (id == ONI_STREAM_PROPERTY_CROPPING && s->dev->cropping && size == (int)sizeof(OniCropping))
        return !((const OniCropping *)data)->enabled ? ONI_STATUS_OK : ONI_STATUS_NOT_SUPPORTED;
    if (id == ONI_STREAM_PROPERTY_VIDEO_MODE && size == (int)sizeof(OniVideoMode))
        return !memcmp(data, &s->dev->mode, sizeof(OniVideoMode)) ? ONI_STATUS_OK
                                                                   : ONI_STATUS_NOT_SUPPORTED;
    return ONI_STATUS_NOT_SUPPORTED;
}

EXPORT OniStatus oniDriverStreamGetProperty(void *stream, int id, void *data, int *size)
{
    tc_stream *s = stream;
    switch (id) {
    case ONI_STREAM_PROPERTY_VIDEO_MODE:
        if (*size < (int)sizeof(OniVideoMode))
            return ONI_STATUS_BAD_PARAMETER;
        memcpy(data, &s->dev->mode, sizeof(OniVideoMode));
        *size = sizeof(OniVideoMode);
        return ONI_STATUS_OK;
    case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
    case ONI_STREAM_PROPERTY_VERTICAL_FOV:
        if (*size < (int)sizeof(float))
            return ONI_STATUS_BAD_PARAMETER;
        /* the test camera's pinhole: fx = fy = 580 px (drv_intrinsics_kinect1) */
        *(float *)data = (float)(2.0 * atan((id == ONI_STREAM_PROPERTY_HORIZONTAL_FOV ? TC_W : TC_H) /
                                            (2.0 * 580.0)));
        *size = sizeof(float);
        return ONI_STATUS_OK;
    case ONI_STREAM_PROPERTY_MIRRORING:
        if (*size < (int)sizeof(OniBool))
            return ONI_STATUS_BAD_PARAMETER;
        *(OniBool *)data = s->mirror;
        *size = sizeof(OniBool);
        return ONI_STATUS_OK;
    case ONI_STREAM_PROPERTY_CROPPING: /* never on; OpenNI2's player needs to be told so */
        if (!s->dev->cropping)
            return ONI_STATUS_NOT_SUPPORTED;
        if (*size < (int)sizeof(OniCropping))
            return ONI_STATUS_BAD_PARAMETER;
        memset(data, 0, sizeof(OniCropping));
        *size = sizeof(OniCropping);
        return ONI_STATUS_OK;
    case ONI_STREAM_PROPERTY_MAX_VALUE:
    case ONI_STREAM_PROPERTY_MIN_VALUE:
    case ONI_STREAM_PROPERTY_STRIDE:
        if (*size < (int)sizeof(int))
            return ONI_STATUS_BAD_PARAMETER;
        *(int *)data = id == ONI_STREAM_PROPERTY_MAX_VALUE ? 10000 : id == ONI_STREAM_PROPERTY_STRIDE ? TC_W * 2 : 0;
        *size = sizeof(int);
        return ONI_STATUS_OK;
    }
    return ONI_STATUS_NOT_SUPPORTED;
}

EXPORT OniBool oniDriverStreamIsPropertySupported(void *stream, int id)
{
    const tc_stream *s = stream;
    if (id == ONI_STREAM_PROPERTY_CROPPING)
        return s->dev->cropping;
    return id == ONI_STREAM_PROPERTY_VIDEO_MODE || id == ONI_STREAM_PROPERTY_HORIZONTAL_FOV ||
           id == ONI_STREAM_PROPERTY_VERTICAL_FOV || id == ONI_STREAM_PROPERTY_MIRRORING ||
           id == ONI_STREAM_PROPERTY_MAX_VALUE || id == ONI_STREAM_PROPERTY_MIN_VALUE ||
           id == ONI_STREAM_PROPERTY_STRIDE || id == ONI_STREAM_PROPERTY_CROPPING;
}
EXPORT void oniDriverStreamSetPropertyChangedCallback(void *stream, tc_prop_cb cb, void *cookie)
{
    (void)stream, (void)cb, (void)cookie;
}
EXPORT void oniDriverStreamNotifyAllProperties(void *stream)
{
    (void)stream;
}
EXPORT OniStatus oniDriverStreamInvoke(void *stream, int id, void *data, int size)
{
    (void)stream, (void)id, (void)data, (void)size;
    return ONI_STATUS_NOT_SUPPORTED;
}
EXPORT OniBool oniDriverStreamIsCommandSupported(void *stream, int id)
{
    (void)stream, (void)id;
    return 0;
}

EXPORT OniStatus oniDriverStreamStart(void *stream)
{
    tc_stream *s = stream;
    if (s->running)
        return ONI_STATUS_OK;
    if (!s->svc)
        return ONI_STATUS_ERROR;
    atomic_store(&s->stop, 0);
    if (pthread_create(&s->thread, NULL, stream_thread, s) != 0)
        return ONI_STATUS_ERROR;
    s->running = 1;
    return ONI_STATUS_OK;
}

EXPORT void oniDriverStreamStop(void *stream)
{
    tc_stream *s = stream;
    if (!s || !s->running)
        return;
    atomic_store(&s->stop, 1);
    pthread_join(s->thread, NULL);
    s->running = 0;
}

EXPORT int oniDriverStreamGetRequiredFrameSize(void *stream)
{
    (void)stream;
    return TC_W * TC_H * 2;
}

EXPORT void oniDriverStreamSetNewFrameCallback(void *stream, tc_frame_cb cb, void *cookie)
{
    tc_stream *s = stream;
    s->on_frame = cb;
    s->frame_cookie = cookie;
}

EXPORT OniStatus oniDriverStreamConvertDepthToColorCoordinates(void *depth, void *color, int x,
                                                               int y, OniDepthPixel z, int *cx,
                                                               int *cy)
{
    (void)depth, (void)color, (void)x, (void)y, (void)z, (void)cx, (void)cy;
    return ONI_STATUS_NOT_SUPPORTED;
}

EXPORT void *oniDriverEnableFrameSync(void **streams, int n)
{
    (void)streams, (void)n;
    return NULL;
}

EXPORT void oniDriverDisableFrameSync(void *group)
{
    (void)group;
}
