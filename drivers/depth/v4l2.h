/* v4l2.h - Kinect v1 depth through the kernel's V4L2 interface (gspca_kinect), and the
 * `v4l2:/dev/videoN[?options]` marker source (v4l2.c).
 *
 * The kernel's gspca_kinect driver (loaded with depth_mode=1) offers the depth stream as
 * V4L2_PIX_FMT_Y10B: 640x480, 10 bits per pixel, bit-packed big-endian (V4L2 spec, "Y10B"):
 * the pixels form one MSB-first bit stream, so 4 pixels fill 5 bytes:
 *   byte 0 = p0[9:2]; byte 1 = p0[1:0] p1[9:4]; byte 2 = p1[3:0] p2[9:6];
 *   byte 3 = p2[5:0] p3[9:8]; byte 4 = p3[7:0].
 * The values are the Kinect's 10-bit raw disparity (its "10-bit packed" depth mode): the 11-bit
 * disparity d11 of depth.h halved, so d11 = 2 d10; 1023 means no reading. Other devices and
 * loopback feeders offer V4L2_PIX_FMT_Y16 (16-bit little-endian; by default the Kinect's 11-bit
 * disparity with 2047 = none, as libfreenect's raw depth; `?y16=mm` for millimetres) or
 * V4L2_PIX_FMT_Z16 (uvcvideo depth cameras: millimetres). Negotiation (VIDIOC_ENUM_FMT, then
 * VIDIOC_S_FMT) prefers Y10B, then Y16, then Z16; `?format=y10b|y16|z16` insists on one.
 *
 * Streaming: mmap buffers (VIDIOC_REQBUFS/QUERYBUF/QBUF/STREAMON), poll() with the caller's
 * timeout, VIDIOC_DQBUF, unpack to millimetres, re-queue. Capture times: the buffer's timestamp
 * when the driver marks it V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC, else the time of the dequeue.
 * A device that disappears (ENODEV from poll/ioctl, POLLERR with ENODEV) gives DRV_ELOST.
 *
 * Every open/close/ioctl/mmap/munmap/poll goes through a drv_v4l2_sys table: the source fills it
 * with the system calls; tests pass a fake device. The table follows the system calls'
 * conventions (-1 and errno on failure, MAP_FAILED from mmap).
 *
 * Source spec: v4l2:/dev/videoN[?format=y10b|y16|z16&y16=disparity|mm&fx=&fy=&cx=&cy=&buffers=N]
 * Intrinsics default to drv_intrinsics_kinect1 scaled to the negotiated size; fx, fy, cx, cy
 * (pixels, at that size) override them. Markers as depth.h (head, lhand, rhand, lfoot, rfoot,
 * torso; metres, camera frame Y up). */
#ifndef MESHSTEER_DRIVERS_DEPTH_V4L2_H
#define MESHSTEER_DRIVERS_DEPTH_V4L2_H

#include <poll.h>
#include <sys/types.h>

#include "../depth.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct drv_v4l2_sys {
    void *ctx;
    int (*open)(void *ctx, const char *path, int flags);
    int (*close)(void *ctx, int fd);
    int (*ioctl)(void *ctx, int fd, unsigned long request, void *arg);
    void *(*mmap)(void *ctx, size_t len, int prot, int flags, int fd, off_t offset);
    int (*munmap)(void *ctx, void *addr, size_t len);
    int (*poll)(void *ctx, struct pollfd *fds, nfds_t n, int timeout_ms);
} drv_v4l2_sys;

/* The real system calls (ctx unused). */
void drv_v4l2_sys_default(drv_v4l2_sys *s);

/* Unpacks `n` Y10B pixels (bit-packed, MSB first) from src (at least ceil(10 n / 8) bytes). */
void drv_y10b_unpack(const uint8_t *src, size_t n, uint16_t *dst);

/* Depth formats the camera may deliver. */
enum { DRV_V4L2_Y10B = 1, DRV_V4L2_Y16 = 2, DRV_V4L2_Z16 = 4 };

typedef struct drv_v4l2_opts {
    int formats;        /* allowed DRV_V4L2_* (0 = all) */
    int y16_mm;         /* 1: Y16 samples are millimetres (default: Kinect 11-bit disparity) */
    int buffers;        /* mmap buffers to request (default 4) */
    double fx, fy, cx, cy; /* 0 = Kinect v1 default scaled to the negotiated size */
} drv_v4l2_opts;

void drv_v4l2_opts_default(drv_v4l2_opts *o);
/* Parses the query of a source spec ("format=y16&fx=590") into o; errors name the option. */
int drv_v4l2_opts_parse(const char *query, drv_v4l2_opts *o, char *err);

typedef struct drv_v4l2_cam drv_v4l2_cam;

/* Opens the device, checks it captures and streams, negotiates a depth format. sys is copied. */
int drv_v4l2_cam_open(const char *path, const drv_v4l2_opts *o, const drv_v4l2_sys *sys,
                      drv_v4l2_cam **out, char *err);
void drv_v4l2_cam_close(drv_v4l2_cam *c); /* NULL is fine; stops streaming first */
/* The negotiated format (DRV_V4L2_*) and the intrinsics at its size. */
int drv_v4l2_cam_format(const drv_v4l2_cam *c, drv_intrinsics *k);
int drv_v4l2_cam_start(drv_v4l2_cam *c, char *err);
void drv_v4l2_cam_stop(drv_v4l2_cam *c);
/* Waits up to timeout_ms (-1 = forever) for a frame; writes width x height millimetres (0 = no
 * reading) and the capture time (CLOCK_MONOTONIC, us). 0, DRV_ETIMEOUT, DRV_ELOST or -errno. */
int drv_v4l2_cam_read(drv_v4l2_cam *c, uint16_t *mm, uint64_t *t_us, int timeout_ms, char *err);

/* The source kind "v4l2" for the registry of drivers.h. */
extern const drv_source_ops drv_v4l2_ops;
/* The v4l2 source's open with a given system-call table (tests): s->ops must be &drv_v4l2_ops. */
int drv_v4l2_source_open_sys(drv_source *s, const char *arg, const drv_v4l2_sys *sys, char *err);

#ifdef __cplusplus
}
#endif
#endif
