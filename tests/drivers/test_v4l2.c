/* test_v4l2.c - the V4L2 depth source against a fake device behind drv_v4l2_sys: Y10B unpacking
 * against hand-computed bit patterns, option parsing, format negotiation (a device offering only
 * Y10B, only Y16, neither, and one that substitutes another format), a streamed real Kinect frame
 * from the fake device through depth -> markers (same markers as the direct path), timeouts, and
 * device loss (ENODEV) -> DRV_ELOST. */
#include "depth/v4l2.h"
#include "kinect_frames.h"
#include "test.h"

#include <errno.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

/* ------------------------------------------------------------------ the fake device */

#define FK_BUFS 4

typedef struct fake {
    uint32_t offered[4];
    int noffered;
    int substitute;          /* S_FMT answers with offered[0] whatever was asked */
    uint32_t pix;            /* chosen format */
    unsigned bpl, size;
    int open_fds, streaming;
    uint8_t *mem[FK_BUFS];
    int queued[FK_BUFS];
    int nbufs, mapped;
    const uint8_t *frame;    /* payload copied into each dequeued buffer */
    int frames_left;         /* frames until the device "disappears" (-1 = never) */
    int lost;
    int delivered;
    int vanish;              /* 1: after the last frame, poll reports POLLERR, ioctls ENODEV */
    uint32_t seq;
} fake;

static int fk_open(void *ctx, const char *path, int flags)
{
    fake *f = ctx;
    (void)flags;
    if (strcmp(path, "/dev/video7")) {
        errno = ENOENT;
        return -1;
    }
    f->open_fds++;
    return 42;
}

static int fk_close(void *ctx, int fd)
{
    fake *f = ctx;
    ASSERT_INT_EQ(fd, 42);
    f->open_fds--;
    return 0;
}

static int fk_ioctl(void *ctx, int fd, unsigned long req, void *arg)
{
    fake *f = ctx;
    ASSERT_INT_EQ(fd, 42);
    if (f->lost && req != VIDIOC_STREAMOFF && req != VIDIOC_REQBUFS) {
        errno = ENODEV;
        return -1;
    }
    switch (req) {
    case VIDIOC_QUERYCAP: {
        struct v4l2_capability *c = arg;
        strcpy((char *)c->card, "fake Kinect");
        c->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
        return 0;
    }
    case VIDIOC_ENUM_FMT: {
        struct v4l2_fmtdesc *d = arg;
        if (d->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || d->index >= (uint32_t)f->noffered) {
            errno = EINVAL;
            return -1;
        }
        d->pixelformat = f->offered[d->index];
        return 0;
    }
    case VIDIOC_S_FMT: {
        struct v4l2_format *fm = arg;
        uint32_t want = fm->fmt.pix.pixelformat;
        int ok = 0;
        for (int i = 0; i < f->noffered; i++)
            ok |= f->offered[i] == want;
        f->pix = ok && !f->substitute ? want : f->offered[0];
        fm->fmt.pix.pixelformat = f->pix;
        fm->fmt.pix.width = 640;
        fm->fmt.pix.height = 480;
        f->bpl = f->pix == V4L2_PIX_FMT_Y10BPACK ? 800 : 1280;
        fm->fmt.pix.bytesperline = f->bpl;
        f->size = f->bpl * 480;
        fm->fmt.pix.sizeimage = f->size;
        return 0;
    }
    case VIDIOC_REQBUFS: {
        struct v4l2_requestbuffers *rb = arg;
        if (rb->count == 0) {
            ASSERT_INT_EQ(f->mapped, 0); /* unmapped before release */
            f->nbufs = 0;
            return 0;
        }
        rb->count = rb->count > FK_BUFS ? FK_BUFS : rb->count;
        f->nbufs = (int)rb->count;
        return 0;
    }
    case VIDIOC_QUERYBUF: {
        struct v4l2_buffer *b = arg;
        ASSERT_INT_LT(b->index, (uint32_t)f->nbufs);
        b->length = f->size;
        b->m.offset = b->index * 0x100000u;
        return 0;
    }
    case VIDIOC_QBUF: {
        struct v4l2_buffer *b = arg;
        ASSERT_INT_LT(b->index, (uint32_t)f->nbufs);
        ASSERT_INT_EQ(f->queued[b->index], 0);
        f->queued[b->index] = 1;
        return 0;
    }
    case VIDIOC_DQBUF: {
        struct v4l2_buffer *b = arg;
        if (!f->streaming || f->frames_left == 0) {
            errno = EAGAIN;
            return -1;
        }
        for (int i = 0; i < f->nbufs; i++)
            if (f->queued[i]) {
                f->queued[i] = 0;
                memcpy(f->mem[i], f->frame, f->size);
                b->index = (uint32_t)i;
                b->bytesused = f->size;
                b->flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
                b->timestamp.tv_sec = 1000 + f->seq;
                b->timestamp.tv_usec = 0;
                b->sequence = f->seq++;
                if (f->frames_left > 0)
                    f->frames_left--;
                f->delivered++;
                return 0;
            }
        errno = EAGAIN;
        return -1;
    }
    case VIDIOC_STREAMON:
        f->streaming = 1;
        return 0;
    case VIDIOC_STREAMOFF:
        f->streaming = 0;
        for (int i = 0; i < FK_BUFS; i++)
            f->queued[i] = 0;
        return 0;
    }
    errno = ENOTTY;
    return -1;
}

static void *fk_mmap(void *ctx, size_t len, int prot, int flags, int fd, off_t off)
{
    fake *f = ctx;
    (void)prot;
    (void)flags;
    ASSERT_INT_EQ(fd, 42);
    ASSERT_INT_EQ(len, f->size);
    int i = (int)(off / 0x100000);
    ASSERT_INT_GE(i, 0);
    ASSERT_INT_LT(i, f->nbufs);
    f->mapped++;
    return f->mem[i];
}

static int fk_munmap(void *ctx, void *addr, size_t len)
{
    fake *f = ctx;
    (void)addr;
    (void)len;
    f->mapped--;
    return 0;
}

static int fk_poll(void *ctx, struct pollfd *p, nfds_t n, int timeout_ms)
{
    fake *f = ctx;
    (void)timeout_ms;
    ASSERT_INT_EQ(n, 1);
    p->revents = 0;
    if (f->lost) {
        p->revents = POLLERR;
        return 1;
    }
    if (f->frames_left == 0) {
        if (f->vanish) {
            /* the device vanishes after its last frame */
            f->lost = 1;
            p->revents = POLLERR;
            return 1;
        }
        return 0;
    }
    p->revents = POLLIN;
    return 1;
}

static void fake_init(fake *f, drv_v4l2_sys *s)
{
    memset(f, 0, sizeof *f);
    for (int i = 0; i < FK_BUFS; i++)
        f->mem[i] = calloc(1, 1280 * 480);
    f->frames_left = -1;
    s->ctx = f;
    s->open = fk_open;
    s->close = fk_close;
    s->ioctl = fk_ioctl;
    s->mmap = fk_mmap;
    s->munmap = fk_munmap;
    s->poll = fk_poll;
}

static void fake_fini(fake *f)
{
    ASSERT_INT_EQ(f->open_fds, 0);
    ASSERT_INT_EQ(f->mapped, 0);
    for (int i = 0; i < FK_BUFS; i++)
        free(f->mem[i]);
}

/* packs 10-bit values MSB first (the reference for the writer side; independent of the unpacker) */
static void pack_y10b(const uint16_t *v, size_t n, uint8_t *out)
{
    memset(out, 0, (n * 10 + 7) / 8);
    size_t bit = 0;
    for (size_t i = 0; i < n; i++)
        for (int b = 9; b >= 0; b--, bit++)
            if (v[i] >> b & 1)
                out[bit / 8] |= (uint8_t)(0x80 >> (bit % 8));
}

int main(void)
{
    char err[DRV_ERR_LEN] = "";

    /* ---- Y10B by hand: 4 pixels in 5 bytes, MSB first */
    {
        /* p0 = 0x3FF (all ones), p1 = 0x000, p2 = 0x2AA (1010101010), p3 = 0x155 (0101010101):
         * bits 1111111111 0000000000 1010101010 0101010101 ->
         * 11111111 11000000 00001010 10101001 01010101 */
        const uint8_t a[5] = {0xFF, 0xC0, 0x0A, 0xA9, 0x55};
        uint16_t v[4];
        drv_y10b_unpack(a, 4, v);
        ASSERT_INT_EQ(v[0], 0x3FF);
        ASSERT_INT_EQ(v[1], 0x000);
        ASSERT_INT_EQ(v[2], 0x2AA);
        ASSERT_INT_EQ(v[3], 0x155);
        /* p0 = 1 (0000000001), p1 = 512 (1000000000), p2 = 3, p3 = 768 (1100000000):
         * 00000000 01100000 00000000 00001111 00000000 */
        const uint8_t b[5] = {0x00, 0x60, 0x00, 0x0F, 0x00};
        drv_y10b_unpack(b, 4, v);
        ASSERT_INT_EQ(v[0], 1);
        ASSERT_INT_EQ(v[1], 512);
        ASSERT_INT_EQ(v[2], 3);
        ASSERT_INT_EQ(v[3], 768);
        /* tail: 6 pixels (a group and 2 more): 0x3FF 0 0x2AA 0x155 | 0x201 0x0F0 ->
         * ... 10000000 01001111 0000(pad) */
        const uint8_t c[8] = {0xFF, 0xC0, 0x0A, 0xA9, 0x55, 0x80, 0x4F, 0x00};
        uint16_t w[6];
        drv_y10b_unpack(c, 6, w);
        ASSERT_INT_EQ(w[4], 0x201);
        ASSERT_INT_EQ(w[5], 0x0F0);
        /* round trip of every value against the bitwise packer */
        uint16_t all[1024], back[1024];
        uint8_t packed[1280];
        for (int i = 0; i < 1024; i++)
            all[i] = (uint16_t)((i * 617) & 1023);
        pack_y10b(all, 1024, packed);
        drv_y10b_unpack(packed, 1024, back);
        for (int i = 0; i < 1024; i++)
            ASSERT_INT_EQ(back[i], all[i]);
        for (int n = 1; n < 9; n++) { /* every tail length */
            pack_y10b(all + 3, (size_t)n, packed);
            drv_y10b_unpack(packed, (size_t)n, back);
            for (int i = 0; i < n; i++)
                ASSERT_INT_EQ(back[i], all[3 + i]);
        }
    }

    /* ---- options */
    {
        drv_v4l2_opts o;
        drv_v4l2_opts_default(&o);
        ASSERT_OK(drv_v4l2_opts_parse("format=y16&y16=mm&fx=590.5&cy=240&buffers=3", &o, err), err);
        ASSERT_INT_EQ(o.formats, DRV_V4L2_Y16);
        ASSERT_INT_EQ(o.y16_mm, 1);
        ASSERT_NEAR(o.fx, 590.5, 1e-9);
        ASSERT_NEAR(o.cy, 240, 1e-9);
        ASSERT_INT_EQ(o.buffers, 3);
        const char *bad[] = {"format=rgb", "fx=-1", "fx=abc", "buffers=99", "colour=1", "fx"};
        for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
            err[0] = '\0';
            ASSERT_INT_EQ(drv_v4l2_opts_parse(bad[i], &o, err), -EINVAL);
            ASSERT_INT_GT(strlen(err), 0);
        }
    }

    fake f;
    drv_v4l2_sys sys;
    drv_v4l2_opts o;
    drv_v4l2_opts_default(&o);
    drv_v4l2_cam *cam;
    drv_intrinsics k;

    /* ---- negotiation: only Y10B (among colour formats), only Y16, neither, a substituting
     * driver, a missing device */
    {
        fake_init(&f, &sys);
        f.offered[0] = V4L2_PIX_FMT_YUYV;
        f.offered[1] = V4L2_PIX_FMT_Y10BPACK;
        f.noffered = 2;
        ASSERT_OK(drv_v4l2_cam_open("/dev/video7", &o, &sys, &cam, err), err);
        ASSERT_INT_EQ(drv_v4l2_cam_format(cam, &k), DRV_V4L2_Y10B);
        ASSERT_INT_EQ(f.pix, V4L2_PIX_FMT_Y10BPACK);
        ASSERT_INT_EQ(k.width, 640);
        ASSERT_NEAR(k.fx, 580, 1e-9);
        drv_v4l2_cam_close(cam);
        fake_fini(&f);

        fake_init(&f, &sys);
        f.offered[0] = V4L2_PIX_FMT_Y16;
        f.noffered = 1;
        drv_v4l2_opts o2 = o;
        o2.fx = 594.2;
        ASSERT_OK(drv_v4l2_cam_open("/dev/video7", &o2, &sys, &cam, err), err);
        ASSERT_INT_EQ(drv_v4l2_cam_format(cam, &k), DRV_V4L2_Y16);
        ASSERT_NEAR(k.fx, 594.2, 1e-9); /* overridden */
        ASSERT_NEAR(k.fy, 580, 1e-9);
        drv_v4l2_cam_close(cam);
        fake_fini(&f);

        fake_init(&f, &sys);
        f.offered[0] = V4L2_PIX_FMT_YUYV;
        f.offered[1] = V4L2_PIX_FMT_SGRBG8;
        f.noffered = 2;
        ASSERT_INT_EQ(drv_v4l2_cam_open("/dev/video7", &o, &sys, &cam, err), -ENOTSUP);
        printf("neither: %s\n", err);
        ASSERT(strstr(err, "YUYV") && strstr(err, "depth_mode=1"));
        fake_fini(&f);

        /* both offered but the driver always substitutes YUYV: refused with a message */
        fake_init(&f, &sys);
        f.offered[0] = V4L2_PIX_FMT_YUYV;
        f.offered[1] = V4L2_PIX_FMT_Y10BPACK;
        f.noffered = 2;
        f.substitute = 1;
        ASSERT_INT_EQ(drv_v4l2_cam_open("/dev/video7", &o, &sys, &cam, err), -ENOTSUP);
        fake_fini(&f);

        /* format=y16 on a Y10B-only device */
        fake_init(&f, &sys);
        f.offered[0] = V4L2_PIX_FMT_Y10BPACK;
        f.noffered = 1;
        drv_v4l2_opts o3 = o;
        o3.formats = DRV_V4L2_Y16;
        ASSERT_INT_EQ(drv_v4l2_cam_open("/dev/video7", &o3, &sys, &cam, err), -ENOTSUP);
        ASSERT_INT_EQ(drv_v4l2_cam_open("/dev/video3", &o, &sys, &cam, err), -ENODEV);
        ASSERT(strstr(err, "/dev/video3"));
        fake_fini(&f);
    }

    /* ---- streaming a real Kinect frame as Y10B and as Y16 through to markers */
    uint16_t *mm = malloc(640 * 480 * sizeof *mm), *got = malloc(640 * 480 * sizeof *got);
    uint16_t *d10 = malloc(640 * 480 * sizeof *d10), *expect = malloc(640 * 480 * sizeof *expect);
    uint8_t *payload = calloc(1, 1280 * 480);
    kinect_frame_load("depth-data-1045879925", mm);
    for (int i = 0; i < 640 * 480; i++) {
        /* the camera's 10-bit disparity of this depth, and what it decodes to */
        long d = mm[i] ? lround(drv_kinect1_m_to_disparity(mm[i] * 0.001) / 2) : 1023;
        d10[i] = (uint16_t)(d < 0 || d > 1022 ? 1023 : d);
        double z = d10[i] < 1023 ? drv_kinect1_disparity_to_m(2.0 * d10[i]) : 0;
        expect[i] = z > 0 ? (uint16_t)lround(z * 1000) : 0;
    }
    for (int y = 0; y < 480; y++)
        pack_y10b(d10 + 640 * y, 640, payload + 800 * y);

    for (int pass = 0; pass < 2; pass++) {
        fake_init(&f, &sys);
        f.offered[0] = pass == 0 ? V4L2_PIX_FMT_Y10BPACK : V4L2_PIX_FMT_Y16;
        f.noffered = 1;
        if (pass == 1) /* Y16 carrying the 11-bit disparity */
            for (int i = 0; i < 640 * 480; i++) {
                unsigned d = d10[i] < 1023 ? 2u * d10[i] : 2047u;
                payload[2 * i] = (uint8_t)(d & 0xff);
                payload[2 * i + 1] = (uint8_t)(d >> 8);
            }
        f.frame = payload;
        f.frames_left = 3;
        f.vanish = 1;
        drv_source src;
        memset(&src, 0, sizeof src);
        src.ops = &drv_v4l2_ops;
        ASSERT_OK(drv_v4l2_source_open_sys(&src, "/dev/video7?buffers=3", &sys, err), err);
        ASSERT_INT_EQ(src.count, DRV_DEPTH_NLABELS);
        ASSERT_OK(drv_v4l2_ops.start(&src, err), err);
        ASSERT_INT_EQ(f.mapped, 3);
        ASSERT_INT_EQ(f.streaming, 1);
        float xyz[DRV_DEPTH_NLABELS * 3];
        uint8_t valid[DRV_DEPTH_NLABELS];
        drv_frame fr = {.count = DRV_DEPTH_NLABELS, .xyz = xyz, .valid = valid};
        for (int n = 0; n < 3; n++) {
            ASSERT_OK(drv_v4l2_ops.read(&src, &fr, 100, err), err);
            ASSERT_INT_EQ(fr.seq, n);
            ASSERT_INT_EQ(fr.t_capture_us, (uint64_t)(1000 + n) * 1000000u); /* driver's time */
        }
        /* markers: the same as processing the decoded depth directly */
        drv_depth_opts dopt;
        drv_depth_opts_default(&dopt);
        drv_depth_tracker *t;
        ASSERT_OK(drv_depth_tracker_create(&dopt, &t, err), err);
        drv_depth_result r;
        for (int n = 0; n < 3; n++)
            drv_depth_tracker_process(t, expect, (uint64_t)(1000 + n) * 1000000u, &r);
        for (int l = 0; l < DRV_DEPTH_NLABELS; l++) {
            ASSERT_INT_EQ(valid[l], r.valid[l]);
            for (int c = 0; c < 3; c++)
                ASSERT_NEAR_I(xyz[3 * l + c], r.xyz[l][c], 1e-6, l);
        }
        ASSERT(valid[DRV_DEPTH_HEAD] && valid[DRV_DEPTH_LHAND] && valid[DRV_DEPTH_RHAND]);
        printf("%s: head (%.2f %.2f %.2f)\n", pass ? "Y16" : "Y10B", xyz[0], xyz[1], xyz[2]);
        drv_depth_tracker_destroy(t);
        /* the device vanishes after its frames: lost, and the source stops and closes cleanly */
        ASSERT_INT_EQ(drv_v4l2_ops.read(&src, &fr, 100, err), DRV_ELOST);
        printf("loss: %s\n", err);
        ASSERT(strstr(err, "lost"));
        drv_v4l2_ops.stop(&src);
        ASSERT_INT_EQ(f.mapped, 0);
        drv_v4l2_ops.close(&src);
        fake_fini(&f);
    }

    /* ---- the unpacked depth itself (camera layer) and a timeout */
    {
        fake_init(&f, &sys);
        f.offered[0] = V4L2_PIX_FMT_Y10BPACK;
        f.noffered = 1;
        for (int y = 0; y < 480; y++)
            pack_y10b(d10 + 640 * y, 640, payload + 800 * y);
        f.frame = payload;
        f.frames_left = 1;
        ASSERT_OK(drv_v4l2_cam_open("/dev/video7", &o, &sys, &cam, err), err);
        ASSERT_OK(drv_v4l2_cam_start(cam, err), err);
        uint64_t ts;
        ASSERT_OK(drv_v4l2_cam_read(cam, got, &ts, 10, err), err);
        for (int i = 0; i < 640 * 480; i++)
            ASSERT_NEAR_I(got[i], expect[i], 0, i);
        f.frames_left = 0; /* nothing arrives */
        ASSERT_INT_EQ(drv_v4l2_cam_read(cam, got, &ts, 10, err), DRV_ETIMEOUT);
        /* ENODEV from DQBUF */
        f.frames_left = 1;
        f.lost = 1;
        ASSERT_INT_EQ(drv_v4l2_cam_read(cam, got, &ts, 10, err), DRV_ELOST);
        drv_v4l2_cam_close(cam);
        fake_fini(&f);
    }

    /* ---- through the registry: v4l2 is known, a missing device is a clear error */
    {
        drv_source *s;
        ASSERT(drv_source_find_ops("v4l2") == &drv_v4l2_ops);
        int r = drv_source_open("v4l2:/dev/nonexistent-video", &s, err);
        ASSERT_INT_LT(r, 0);
        printf("missing: %s\n", err);
        ASSERT(strstr(err, "/dev/nonexistent-video"));
    }
    free(mm);
    free(got);
    free(d10);
    free(expect);
    free(payload);
    printf("ok\n");
    return 0;
}
