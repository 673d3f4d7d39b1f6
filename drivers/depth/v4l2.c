/* v4l2.c - V4L2 depth capture (Kinect v1 through gspca_kinect) and the v4l2: marker source.
 * Formats, unpacking, streaming and loss as described in v4l2.h. Implements the V4L2 capture
 * protocol of the kernel's "Video for Linux API" (Streaming I/O, memory mapping; VIDIOC_ENUM_FMT,
 * VIDIOC_S_FMT, VIDIOC_REQBUFS, VIDIOC_QUERYBUF, VIDIOC_QBUF, VIDIOC_DQBUF, VIDIOC_STREAMON/OFF). */
#include "../drv_err.h"
#include "v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#define V4_MAX_BUFS 8

static uint64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* ------------------------------------------------------------------ system calls */

static int sys_open(void *ctx, const char *path, int flags)
{
    (void)ctx;
    return open(path, flags);
}
static int sys_close(void *ctx, int fd)
{
    (void)ctx;
    return close(fd);
}
static int sys_ioctl(void *ctx, int fd, unsigned long request, void *arg)
{
    (void)ctx;
    int r;
    do
        r = ioctl(fd, request, arg);
    while (r == -1 && errno == EINTR);
    return r;
}
static void *sys_mmap(void *ctx, size_t len, int prot, int flags, int fd, off_t offset)
{
    (void)ctx;
    return mmap(NULL, len, prot, flags, fd, offset);
}
static int sys_munmap(void *ctx, void *addr, size_t len)
{
    (void)ctx;
    return munmap(addr, len);
}
static int sys_poll(void *ctx, struct pollfd *fds, nfds_t n, int timeout_ms)
{
    (void)ctx;
    return poll(fds, n, timeout_ms);
}

void drv_v4l2_sys_default(drv_v4l2_sys *s)
{
    s->ctx = NULL;
    s->open = sys_open;
    s->close = sys_close;
    s->ioctl = sys_ioctl;
    s->mmap = sys_mmap;
    s->munmap = sys_munmap;
    s->poll = sys_poll;
}

/* ------------------------------------------------------------------ unpacking */

void drv_y10b_unpack(const uint8_t *src, size_t n, uint16_t *dst)
{
    size_t i = 0;
    /* whole groups: 4 pixels in 5 bytes */
    for (; i + 4 <= n; i += 4, src += 5) {
        dst[i] = (uint16_t)(src[0] << 2 | src[1] >> 6);
        dst[i + 1] = (uint16_t)((src[1] & 0x3f) << 4 | src[2] >> 4);
        dst[i + 2] = (uint16_t)((src[2] & 0x0f) << 6 | src[3] >> 2);
        dst[i + 3] = (uint16_t)((src[3] & 0x03) << 8 | src[4]);
    }
    /* a tail of 1..3 pixels: read the MSB-first bit stream */
    unsigned bit = 0;
    for (; i < n; i++) {
        unsigned v = 0;
        for (int b = 0; b < 10; b++, bit++)
            v = v << 1 | ((src[bit >> 3] >> (7 - (bit & 7))) & 1u);
        dst[i] = (uint16_t)v;
    }
}

/* ------------------------------------------------------------------ options */

void drv_v4l2_opts_default(drv_v4l2_opts *o)
{
    memset(o, 0, sizeof *o);
    o->buffers = 4;
}

int drv_v4l2_opts_parse(const char *query, drv_v4l2_opts *o, char *err)
{
    char buf[512];
    if (!query || !*query)
        return 0;
    if (strlen(query) >= sizeof buf)
        return drv__err(err, -EINVAL, "v4l2: options too long");
    strcpy(buf, query);
    char *save = NULL;
    for (char *kv = strtok_r(buf, "&", &save); kv; kv = strtok_r(NULL, "&", &save)) {
        char *eq = strchr(kv, '=');
        if (!eq)
            return drv__err(err, -EINVAL, "v4l2: option '%s': expected key=value", kv);
        *eq = '\0';
        const char *v = eq + 1;
        if (!strcmp(kv, "format")) {
            if (!strcmp(v, "y10b"))
                o->formats = DRV_V4L2_Y10B;
            else if (!strcmp(v, "y16"))
                o->formats = DRV_V4L2_Y16;
            else if (!strcmp(v, "z16"))
                o->formats = DRV_V4L2_Z16;
            else
                return drv__err(err, -EINVAL, "v4l2: format '%s': expected y10b, y16 or z16", v);
        } else if (!strcmp(kv, "y16")) {
            if (!strcmp(v, "mm"))
                o->y16_mm = 1;
            else if (!strcmp(v, "disparity"))
                o->y16_mm = 0;
            else
                return drv__err(err, -EINVAL, "v4l2: y16 '%s': expected disparity or mm", v);
        } else if (!strcmp(kv, "buffers")) {
            char *end;
            long n = strtol(v, &end, 10);
            if (*end || end == v || n < 2 || n > V4_MAX_BUFS)
                return drv__err(err, -EINVAL, "v4l2: buffers '%s': expected 2..%d", v, V4_MAX_BUFS);
            o->buffers = (int)n;
        } else if (!strcmp(kv, "fx") || !strcmp(kv, "fy") || !strcmp(kv, "cx") ||
                   !strcmp(kv, "cy")) {
            char *end;
            double x = strtod(v, &end);
            if (*end || end == v || !isfinite(x) || x <= 0 || x > 1e5)
                return drv__err(err, -EINVAL, "v4l2: %s '%s': expected a positive number of pixels", kv,
                            v);
            *(kv[0] == 'f' ? (kv[1] == 'x' ? &o->fx : &o->fy) : (kv[1] == 'x' ? &o->cx : &o->cy)) = x;
        } else {
            return drv__err(err, -EINVAL,
                        "v4l2: unknown option '%s' (format, y16, buffers, fx, fy, cx, cy)", kv);
        }
    }
    return 0;
}

/* ------------------------------------------------------------------ the camera */

struct drv_v4l2_cam {
    drv_v4l2_sys sys;
    char path[256];
    int fd;
    drv_v4l2_opts o;
    int format;                 /* DRV_V4L2_* */
    int width, height;
    unsigned bytesperline, sizeimage;
    drv_intrinsics k;
    int nbufs;
    void *buf[V4_MAX_BUFS];
    size_t len[V4_MAX_BUFS];
    int streaming;
    uint16_t lut[2048];         /* raw sample -> mm (Y10B: 1024 entries, Y16 disparity: 2048) */
    uint16_t *row;              /* one unpacked Y10B row */
};

static int xioctl(drv_v4l2_cam *c, unsigned long req, void *arg)
{
    return c->sys.ioctl(c->sys.ctx, c->fd, req, arg);
}

static const char *fourcc(uint32_t f, char s[5])
{
    for (int i = 0; i < 4; i++) {
        char ch = (char)((f >> (8 * i)) & 0xff);
        s[i] = ch >= 32 && ch < 127 ? ch : '?';
    }
    s[4] = '\0';
    return s;
}

static int negotiate(drv_v4l2_cam *c, char *err)
{
    int offered = 0;
    char list[256] = "";
    size_t ll = 0;
    for (uint32_t i = 0; i < 64; i++) {
        struct v4l2_fmtdesc d;
        memset(&d, 0, sizeof d);
        d.index = i;
        d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        if (xioctl(c, VIDIOC_ENUM_FMT, &d) != 0) {
            if (errno == EINVAL)
                break;
            return drv__err(err, errno == ENODEV ? DRV_ELOST : -errno, "v4l2 %s: VIDIOC_ENUM_FMT: %s",
                        c->path, strerror(errno));
        }
        char s[5];
        int w = snprintf(list + ll, sizeof list - ll, "%s%s", ll ? " " : "", fourcc(d.pixelformat, s));
        if (w > 0 && (size_t)w < sizeof list - ll)
            ll += (size_t)w;
        if (d.pixelformat == V4L2_PIX_FMT_Y10BPACK)
            offered |= DRV_V4L2_Y10B;
        else if (d.pixelformat == V4L2_PIX_FMT_Y16)
            offered |= DRV_V4L2_Y16;
        else if (d.pixelformat == V4L2_PIX_FMT_Z16)
            offered |= DRV_V4L2_Z16;
    }
    int allowed = c->o.formats ? c->o.formats : (DRV_V4L2_Y10B | DRV_V4L2_Y16 | DRV_V4L2_Z16);
    int usable = offered & allowed;
    if (!usable)
        return drv__err(err, -ENOTSUP,
                    "v4l2 %s: no depth format%s (offers: %s; wanted Y10B, Y16 or Z16; for a Kinect "
                    "load gspca_kinect with depth_mode=1)",
                    c->path, c->o.formats ? " of the chosen kind" : "", ll ? list : "none");
    static const struct { int f; uint32_t pix; } pref[] = {
        {DRV_V4L2_Y10B, V4L2_PIX_FMT_Y10BPACK}, {DRV_V4L2_Y16, V4L2_PIX_FMT_Y16},
        {DRV_V4L2_Z16, V4L2_PIX_FMT_Z16}};
    for (size_t p = 0; p < sizeof pref / sizeof *pref; p++) {
        if (!(usable & pref[p].f))
            continue;
        struct v4l2_format f;
        memset(&f, 0, sizeof f);
        f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        f.fmt.pix.width = 640;
        f.fmt.pix.height = 480;
        f.fmt.pix.pixelformat = pref[p].pix;
        f.fmt.pix.field = V4L2_FIELD_NONE;
        if (xioctl(c, VIDIOC_S_FMT, &f) != 0)
            return drv__err(err, errno == ENODEV ? DRV_ELOST : -errno, "v4l2 %s: VIDIOC_S_FMT: %s",
                        c->path, strerror(errno));
        if (f.fmt.pix.pixelformat != pref[p].pix)
            continue; /* the driver substituted another format: try the next one */
        unsigned w = f.fmt.pix.width, h = f.fmt.pix.height;
        if (w < 16 || h < 16 || w > 4096 || h > 4096)
            return drv__err(err, -EPROTO, "v4l2 %s: driver chose %ux%u", c->path, w, h);
        unsigned min_bpl = pref[p].f == DRV_V4L2_Y10B ? (w * 10 + 7) / 8 : w * 2;
        unsigned bpl = f.fmt.pix.bytesperline ? f.fmt.pix.bytesperline : min_bpl;
        if (bpl < min_bpl || bpl > 4 * min_bpl)
            return drv__err(err, -EPROTO, "v4l2 %s: bytesperline %u for width %u", c->path, bpl, w);
        c->format = pref[p].f;
        c->width = (int)w;
        c->height = (int)h;
        c->bytesperline = bpl;
        c->sizeimage = bpl * h;
        return 0;
    }
    return drv__err(err, -ENOTSUP, "v4l2 %s: the driver refused every depth format (offers: %s)",
                c->path, list);
}

static void build_lut(drv_v4l2_cam *c)
{
    memset(c->lut, 0, sizeof c->lut);
    if (c->format == DRV_V4L2_Y10B) {
        for (int d = 0; d < 1023; d++) {
            double z = drv_kinect1_disparity_to_m(2.0 * d);
            c->lut[d] = z > 0 && z < 60 ? (uint16_t)lround(z * 1000) : 0;
        }
    } else if (c->format == DRV_V4L2_Y16 && !c->o.y16_mm) {
        for (int d = 0; d < 2047; d++) {
            double z = drv_kinect1_disparity_to_m(d);
            c->lut[d] = z > 0 && z < 60 ? (uint16_t)lround(z * 1000) : 0;
        }
    }
}

int drv_v4l2_cam_open(const char *path, const drv_v4l2_opts *o, const drv_v4l2_sys *sys,
                      drv_v4l2_cam **out, char *err)
{
    *out = NULL;
    if (!path || !*path || strlen(path) >= 256)
        return drv__err(err, -EINVAL, "v4l2: bad device path");
    drv_v4l2_cam *c = calloc(1, sizeof *c);
    if (!c)
        return drv__err(err, -ENOMEM, "v4l2 %s: out of memory", path);
    c->sys = *sys;
    c->o = *o;
    if (c->o.buffers < 2 || c->o.buffers > V4_MAX_BUFS)
        c->o.buffers = 4;
    strcpy(c->path, path);
    c->fd = c->sys.open(c->sys.ctx, path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (c->fd < 0) {
        int e = errno;
        free(c);
        return drv__err(err, e == ENOENT || e == ENODEV || e == ENXIO ? -ENODEV : -e,
                    "v4l2 %s: open: %s", path, strerror(e));
    }
    int r;
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    if (xioctl(c, VIDIOC_QUERYCAP, &cap) != 0) {
        r = drv__err(err, errno == ENOTTY ? -ENOTTY : -errno, "v4l2 %s: VIDIOC_QUERYCAP: %s%s", path,
                 strerror(errno), errno == ENOTTY ? " (not a V4L2 device)" : "");
        goto bad;
    }
    uint32_t caps = cap.capabilities & V4L2_CAP_DEVICE_CAPS ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
        r = drv__err(err, -ENOTSUP, "v4l2 %s (%.32s): not a streaming capture device", path,
                 (const char *)cap.card);
        goto bad;
    }
    if ((r = negotiate(c, err)))
        goto bad;
    if (c->format == DRV_V4L2_Y10B && !(c->row = malloc((size_t)c->width * sizeof *c->row))) {
        r = drv__err(err, -ENOMEM, "v4l2 %s: out of memory", path);
        goto bad;
    }
    build_lut(c);
    drv_intrinsics_kinect1(&c->k);
    double sx = c->width / 640.0, sy = c->height / 480.0;
    c->k.fx = c->o.fx > 0 ? c->o.fx : c->k.fx * sx;
    c->k.fy = c->o.fy > 0 ? c->o.fy : c->k.fy * sy;
    c->k.cx = c->o.cx > 0 ? c->o.cx : (c->width - 1) * 0.5;
    c->k.cy = c->o.cy > 0 ? c->o.cy : (c->height - 1) * 0.5;
    c->k.width = c->width;
    c->k.height = c->height;
    *out = c;
    return 0;
bad:
    c->sys.close(c->sys.ctx, c->fd);
    free(c->row);
    free(c);
    return r;
}

int drv_v4l2_cam_format(const drv_v4l2_cam *c, drv_intrinsics *k)
{
    if (k)
        *k = c->k;
    return c->format;
}

static void unmap_all(drv_v4l2_cam *c)
{
    for (int i = 0; i < c->nbufs; i++)
        if (c->buf[i])
            c->sys.munmap(c->sys.ctx, c->buf[i], c->len[i]);
    memset(c->buf, 0, sizeof c->buf);
    c->nbufs = 0;
}

void drv_v4l2_cam_stop(drv_v4l2_cam *c)
{
    if (!c || !c->streaming)
        return;
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    xioctl(c, VIDIOC_STREAMOFF, &type); /* fails harmlessly on a lost device */
    unmap_all(c);
    struct v4l2_requestbuffers rb;
    memset(&rb, 0, sizeof rb);
    rb.count = 0;
    rb.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    rb.memory = V4L2_MEMORY_MMAP;
    xioctl(c, VIDIOC_REQBUFS, &rb);
    c->streaming = 0;
}

static int lost_or(drv_v4l2_cam *c, const char *what, char *err)
{
    int e = errno;
    if (e == ENODEV || e == ENXIO || e == EIO)
        return drv__err(err, DRV_ELOST, "v4l2 %s: %s: %s (device lost)", c->path, what, strerror(e));
    return drv__err(err, -e, "v4l2 %s: %s: %s", c->path, what, strerror(e));
}

int drv_v4l2_cam_start(drv_v4l2_cam *c, char *err)
{
    if (c->streaming)
        return 0;
    struct v4l2_requestbuffers rb;
    memset(&rb, 0, sizeof rb);
    rb.count = (uint32_t)c->o.buffers;
    rb.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    rb.memory = V4L2_MEMORY_MMAP;
    if (xioctl(c, VIDIOC_REQBUFS, &rb) != 0)
        return lost_or(c, "VIDIOC_REQBUFS", err);
    if (rb.count < 2)
        return drv__err(err, -ENOMEM, "v4l2 %s: only %u buffers granted", c->path, rb.count);
    int n = rb.count > V4_MAX_BUFS ? V4_MAX_BUFS : (int)rb.count;
    int r = 0;
    c->nbufs = 0;
    for (int i = 0; i < n; i++) {
        struct v4l2_buffer b;
        memset(&b, 0, sizeof b);
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        b.index = (uint32_t)i;
        if (xioctl(c, VIDIOC_QUERYBUF, &b) != 0) {
            r = lost_or(c, "VIDIOC_QUERYBUF", err);
            goto bad;
        }
        if (b.length < c->sizeimage) {
            r = drv__err(err, -EPROTO, "v4l2 %s: buffer %d holds %u bytes, a frame needs %u", c->path,
                     i, b.length, c->sizeimage);
            goto bad;
        }
        void *p = c->sys.mmap(c->sys.ctx, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, c->fd,
                              (off_t)b.m.offset);
        if (p == MAP_FAILED) {
            r = lost_or(c, "mmap", err);
            goto bad;
        }
        c->buf[i] = p;
        c->len[i] = b.length;
        c->nbufs = i + 1;
        if (xioctl(c, VIDIOC_QBUF, &b) != 0) {
            r = lost_or(c, "VIDIOC_QBUF", err);
            goto bad;
        }
    }
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(c, VIDIOC_STREAMON, &type) != 0) {
        r = lost_or(c, "VIDIOC_STREAMON", err);
        goto bad;
    }
    c->streaming = 1;
    return 0;
bad:
    c->streaming = 1; /* so that stop releases what was set up */
    drv_v4l2_cam_stop(c);
    return r;
}

static void convert(drv_v4l2_cam *c, const uint8_t *src, uint16_t *mm)
{
    for (int y = 0; y < c->height; y++) {
        const uint8_t *row = src + (size_t)y * c->bytesperline;
        uint16_t *out = mm + (size_t)y * c->width;
        if (c->format == DRV_V4L2_Y10B) {
            drv_y10b_unpack(row, (size_t)c->width, c->row);
            for (int x = 0; x < c->width; x++)
                out[x] = c->lut[c->row[x] & 1023];
        } else if (c->format == DRV_V4L2_Y16 && !c->o.y16_mm) {
            for (int x = 0; x < c->width; x++) {
                unsigned d = row[2 * x] | (unsigned)row[2 * x + 1] << 8;
                out[x] = d < 2048 ? c->lut[d] : 0;
            }
        } else {
            for (int x = 0; x < c->width; x++)
                out[x] = (uint16_t)(row[2 * x] | row[2 * x + 1] << 8);
        }
    }
}

int drv_v4l2_cam_read(drv_v4l2_cam *c, uint16_t *mm, uint64_t *t_us, int timeout_ms, char *err)
{
    if (!c->streaming)
        return drv__err(err, -EINVAL, "v4l2 %s: not streaming", c->path);
    for (;;) {
        struct pollfd p = {.fd = c->fd, .events = POLLIN};
        int n = c->sys.poll(c->sys.ctx, &p, 1, timeout_ms);
        if (n < 0) {
            if (errno == EINTR)
                return DRV_ETIMEOUT;
            return lost_or(c, "poll", err);
        }
        if (n == 0)
            return DRV_ETIMEOUT;
        if (p.revents & POLLNVAL)
            return drv__err(err, -EBADF, "v4l2 %s: poll: descriptor not open", c->path);
        /* POLLERR: DQBUF says why (ENODEV after an unplug) */
        struct v4l2_buffer b;
        memset(&b, 0, sizeof b);
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        if (xioctl(c, VIDIOC_DQBUF, &b) != 0) {
            if (errno == EAGAIN) {
                if (p.revents & POLLERR)
                    return drv__err(err, DRV_ELOST, "v4l2 %s: poll reports an error (device lost)",
                                c->path);
                continue;
            }
            return lost_or(c, "VIDIOC_DQBUF", err);
        }
        if (b.index >= (uint32_t)c->nbufs)
            return drv__err(err, -EPROTO, "v4l2 %s: driver returned buffer %u of %d", c->path,
                        b.index, c->nbufs);
        uint64_t t = now_us();
        int ok = !(b.flags & V4L2_BUF_FLAG_ERROR) && b.bytesused >= c->sizeimage;
        if (ok) {
            convert(c, c->buf[b.index], mm);
            if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
                (b.timestamp.tv_sec || b.timestamp.tv_usec))
                t = (uint64_t)b.timestamp.tv_sec * 1000000u + (uint64_t)b.timestamp.tv_usec;
        }
        if (xioctl(c, VIDIOC_QBUF, &b) != 0)
            return lost_or(c, "VIDIOC_QBUF", err);
        if (!ok)
            continue; /* a corrupt or short frame: skip it */
        *t_us = t;
        return 0;
    }
}

void drv_v4l2_cam_close(drv_v4l2_cam *c)
{
    if (!c)
        return;
    drv_v4l2_cam_stop(c);
    c->sys.close(c->sys.ctx, c->fd);
    free(c->row);
    free(c);
}

/* ------------------------------------------------------------------ the source */

typedef struct v4_src {
    drv_v4l2_cam *cam;
    drv_depth_tracker *trk;
    uint16_t *mm;
    uint64_t seq;
} v4_src;

static void v4_free(v4_src *v)
{
    if (!v)
        return;
    drv_v4l2_cam_close(v->cam);
    drv_depth_tracker_destroy(v->trk);
    free(v->mm);
    free(v);
}

int drv_v4l2_source_open_sys(drv_source *s, const char *arg, const drv_v4l2_sys *sys, char *err)
{
    char path[256];
    const char *q = strchr(arg, '?');
    size_t pl = q ? (size_t)(q - arg) : strlen(arg);
    if (pl == 0 || pl >= sizeof path)
        return drv__err(err, -EINVAL, "v4l2: expected v4l2:/dev/videoN[?options]");
    memcpy(path, arg, pl);
    path[pl] = '\0';
    drv_v4l2_opts o;
    drv_v4l2_opts_default(&o);
    int r = drv_v4l2_opts_parse(q ? q + 1 : NULL, &o, err);
    if (r)
        return r;
    v4_src *v = calloc(1, sizeof *v);
    if (!v)
        return drv__err(err, -ENOMEM, "v4l2: out of memory");
    if ((r = drv_v4l2_cam_open(path, &o, sys, &v->cam, err))) {
        free(v);
        return r;
    }
    drv_depth_opts d;
    drv_depth_opts_default(&d);
    drv_v4l2_cam_format(v->cam, &d.k);
    if (d.k.width != 640 || d.k.height != 480) {
        d.step = d.k.width >= 320 ? 2 : 1; /* keep the grid near 160x120 */
        d.step_min = d.step < d.step_min ? d.step : d.step_min; /* then sized by distance */
    }
    v->mm = malloc((size_t)d.k.width * d.k.height * sizeof *v->mm);
    if (!v->mm) {
        v4_free(v);
        return drv__err(err, -ENOMEM, "v4l2 %s: out of memory", path);
    }
    if ((r = drv_depth_tracker_create(&d, &v->trk, err))) {
        v4_free(v);
        return r;
    }
    s->impl = v;
    s->count = DRV_DEPTH_NLABELS;
    s->names = (const char **)drv_depth_label_names;
    s->fps = 30;
    s->caps = DRV_CAP_USB_DEVICE; /* a Kinect v1 through gspca_kinect */
    return 0;
}

static int v4_open(drv_source *s, const char *arg, char *err)
{
    drv_v4l2_sys sys;
    drv_v4l2_sys_default(&sys);
    return drv_v4l2_source_open_sys(s, arg, &sys, err);
}

static int v4_start(drv_source *s, char *err)
{
    v4_src *v = s->impl;
    drv_depth_tracker_reset(v->trk);
    return drv_v4l2_cam_start(v->cam, err);
}

static int v4_read(drv_source *s, drv_frame *fr, int timeout_ms, char *err)
{
    v4_src *v = s->impl;
    uint64_t t;
    int r = drv_v4l2_cam_read(v->cam, v->mm, &t, timeout_ms, err);
    if (r)
        return r;
    drv_depth_result res;
    drv_depth_tracker_process(v->trk, v->mm, t, &res);
    for (int l = 0; l < DRV_DEPTH_NLABELS; l++) {
        memcpy(fr->xyz + 3 * l, res.xyz[l], 3 * sizeof(float));
        fr->valid[l] = res.valid[l];
    }
    fr->seq = v->seq++;
    fr->t_capture_us = t;
    return 0;
}

static void v4_stop(drv_source *s)
{
    v4_src *v = s->impl;
    drv_v4l2_cam_stop(v->cam);
}

static void v4_close(drv_source *s)
{
    v4_free(s->impl);
    s->impl = NULL;
}

const drv_source_ops drv_v4l2_ops = {
    .scheme = "v4l2",
    .open = v4_open,
    .start = v4_start,
    .read = v4_read,
    .control = NULL,
    .stop = v4_stop,
    .close = v4_close,
};
