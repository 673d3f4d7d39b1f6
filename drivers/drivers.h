/* drivers.h - marker sources behind one interface.
 *
 * A source yields timestamped marker frames: a fixed, named marker set (names known after open),
 * positions in metres (Y up), a validity flag per marker, and the CLOCK_MONOTONIC capture time in
 * microseconds. Sources: replay of marker files (replay.c), depth cameras through OpenNI2, V4L2 and
 * fakenect dumps (depth/), each turning depth into markers. The daemon's source thread is the only
 * caller; a source creates no threads of its own unless its header says so.
 *
 * Lifecycle: drv_source_open (parse the spec, find the device or file, learn the marker names)
 * -> drv_source_start (begin streaming) -> drv_source_read ... -> drv_source_stop -> drv_source_close.
 * drv_source_read fills caller-provided buffers and allocates nothing.
 */
#ifndef MESHSTEER_DRIVERS_H
#define MESHSTEER_DRIVERS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define DRV_ERR_LEN 512

enum {
    DRV_EEOF = -2000,     /* a finite source (replay without loop) has ended */
    DRV_ETIMEOUT = -2001, /* no frame within the timeout; try again */
    DRV_ELOST = -2002,    /* the device went away; close and reopen later */
};

/* The source's state, as shown on /healthz. */
typedef enum drv_state {
    DRV_STATE_CLOSED = 0,
    DRV_STATE_OPEN,
    DRV_STATE_STREAMING,
    DRV_STATE_ENDED,
    DRV_STATE_LOST,
} drv_state;

typedef struct drv_frame {
    uint64_t seq;          /* frame counter of the source */
    uint64_t t_capture_us; /* CLOCK_MONOTONIC, microseconds */
    int count;             /* markers in xyz/valid (= the source's marker count) */
    float *xyz;            /* count x 3, caller-provided */
    uint8_t *valid;        /* count, caller-provided */
    /* The joints block, for a source whose drv_source.joints is set (a skeleton file): per marker
     * the rotation of the segment ending at it (mdl_markers.rot: unit quaternion w x y z, Y up,
     * relative to the skeleton's rest pose) and its validity. Caller-provided (count x 4, count)
     * or NULL when the caller does not want them; other sources leave them alone. */
    float *joint_rot;
    uint8_t *joint_valid;
} drv_frame;

typedef struct drv_source drv_source;

/* The live controls a source takes (drv_source.controls, set by its open; drv_source_control
 * refuses the others with -ENOTSUP). Each control is one bit, passed as such end to end (no
 * names): DRV_CTL_PAUSE takes 1 (pause) and 0 (resume). */
enum {
    DRV_CTL_PAUSE = 1 << 0, /* 1/0 */
    DRV_CTL_SEEK = 1 << 1,  /* frame index */
    DRV_CTL_SPEED = 1 << 2, /* factor in [DRV_SPEED_MIN, DRV_SPEED_MAX] */
    DRV_CTL_LOOP = 1 << 3,  /* 1/0 */
};

/* What a source is, for its host (drv_source.caps, set by open). */
enum {
    DRV_CAP_USB_DEVICE = 1 << 0, /* a live device on USB: it may leave and come back, and its
                                    host may watch the bus to reopen it at once */
};

typedef struct drv_source_ops {
    const char *scheme; /* "replay", "openni2", "v4l2", "fakenect", ... */
    int (*open)(drv_source *s, const char *arg, char *err);
    int (*start)(drv_source *s, char *err);
    int (*read)(drv_source *s, drv_frame *f, int timeout_ms, char *err);
    /* may be NULL (no controls); called only with one DRV_CTL_* bit that is in s->controls */
    int (*control)(drv_source *s, unsigned ctl, double value, char *err);
    void (*stop)(drv_source *s);
    void (*close)(drv_source *s);
} drv_source_ops;

struct drv_source {
    const drv_source_ops *ops;
    void *impl;
    int count;            /* markers per frame */
    const char **names;   /* count labels, owned by the implementation */
    double fps;           /* nominal rate, 0 if unknown */
    drv_state state;
    int detached;         /* the device was released by drv_source_reopen and none is open yet */
    unsigned controls;    /* DRV_CTL_* bits this source takes (0: none), set by open */
    unsigned caps;        /* DRV_CAP_* bits, set by open */
    int frames;           /* frames of a recording (what "seek" ranges over), 0 for a live source */
    int joints;           /* 1: frames carry joint rotations (drv_frame.joint_rot), set by open:
                             replay of a BVH or ASF/AMC file; 0 for every other source */
};

/* spec: "scheme:argument", e.g. "replay:walk.c3d?loop=1&speed=0.5&start=10". */
int drv_source_open(const char *spec, drv_source **out, char *err);
int drv_source_start(drv_source *s, char *err);
/* After DRV_ELOST: releases the vanished device and opens `spec` again into the same handle (so
 * that other threads keep a valid pointer), provided the new device has the same source kind and
 * marker set; then start it. On failure the handle stays LOST, with no device; try again later. */
int drv_source_reopen(drv_source *s, const char *spec, char *err);
int drv_source_read(drv_source *s, drv_frame *f, int timeout_ms, char *err);
/* A live control: ctl is one DRV_CTL_* bit. -ENOTSUP when it is not in s->controls. */
int drv_source_control(drv_source *s, unsigned ctl, double value, char *err);
void drv_source_stop(drv_source *s);
void drv_source_close(drv_source *s); /* NULL is fine */

/* Depth sensors arriving on or leaving USB (depth/kinect_usb.c: libusb hotplug, or bus polling
 * where libusb has none). fn gets a one-line description such as "kinect1-camera 045e:02ae at
 * bus 1 address 4", on the thread that calls drv_device_watch_poll. -ENODEV when this machine
 * has no USB to watch. */
typedef struct drv_device_watch drv_device_watch;
typedef void (*drv_device_fn)(void *user, int arrived, const char *what);
int drv_device_watch_create(drv_device_fn fn, void *user, drv_device_watch **out, char *err);
int drv_device_watch_poll(drv_device_watch *w, int timeout_ms, char *err);
int drv_device_watch_hotplug(const drv_device_watch *w); /* 1: events, 0: polling */
void drv_device_watch_destroy(drv_device_watch *w);

/* The registry of source kinds (source.c); each implementation file adds its ops there. */
const drv_source_ops *drv_source_find_ops(const char *scheme);
/* The one range of a playback speed factor, for a spec's speed= option and the "speed" control
 * alike (drv_source_control checks the control, before the source sees it). At 0.001 a 30 Hz file
 * plays one frame every 33 s; below it a speed is indistinguishable from a pause, and the pacing's
 * arithmetic (frame period in microseconds) would lose its meaning. */
#define DRV_SPEED_MIN 0.001
#define DRV_SPEED_MAX 100.0
/* 0 when speed is in [DRV_SPEED_MIN, DRV_SPEED_MAX]; otherwise -ERANGE and the reason in err
 * ("speed 1e-300 outside [0.001, 100]"). */
int drv_speed_check(double speed, char *err);
/* The name of one DRV_CTL_* bit ("pause", "seek", "speed", "loop"), for messages; "?" otherwise. */
const char *drv_control_name(unsigned ctl);
/* "closed", "open", "streaming", "ended", "lost". */
const char *drv_state_name(drv_state st);

/* ---- replay of marker files (replay.c) ----
 * Spec: "replay:FILE[?loop=0|1&speed=S&start=N&scale=M&up=x|y|z|-x|-y|-z&joints=0|1]".
 * FILE is anything mdl_markers_read reads (.c3d .trc .bvh .csv .amc .asf). Frames are released at the
 * file's fps divided by speed, paced on CLOCK_MONOTONIC; each frame's t_capture_us is the time it
 * was released. loop=1 wraps to frame 0 at the end (seq keeps counting); otherwise the source ends
 * (DRV_EEOF). start is the first frame; scale (metres per file unit) and up override the file's
 * conventions. Controls (all four bits): "pause" (1/0), "seek" (frame index), "speed"
 * (DRV_SPEED_MIN ... DRV_SPEED_MAX, as the option), "loop" (1/0). A frame that is more than 250 ms late re-anchors the clock rather than bursting.
 * A BVH or ASF/AMC file (.amc, .asf) also gives its joint rotations (drv_source.joints = 1)
 * unless joints=0 (then its markers alone, as from any other file). */

/* ---- markers and VMC bones over OSC (osc/osc.c; docs/OSC.md) ----
 * Spec: "osc:[HOST:]PORT[?markers=A,B,..&vmc=0|1&scale=M&stale=MS&gap=MS]". Binds a UDP socket
 * (no HOST: every IPv4 interface; an IPv6 HOST in brackets; PORT 0 picks a free one, see
 * drv_osc_port). Markers come as "/marker NAME x y z" (metres, Y up; "/marker NAME" alone: not
 * seen), VMC bones as "/VMC/Ext/Bone/Pos" (+ "/VMC/Ext/Root/Pos") through forward kinematics.
 * The marker set: markers= (default head, lhand, rhand, lfoot, rfoot, torso, the depth sources'
 * labels), or with vmc=1 the 25 VMC body bones (Hips ... RightToes). A marker named like a VMC bone
 * is fed by that bone. A top-level bundle is one frame; loose messages are framed by "/frame", by
 * a marker set twice, or by gap ms of quiet (default 10). A marker older than stale ms (default
 * 500, 0 = never) is invalid. Malformed packets are counted and dropped whole. No controls. */
typedef struct drv_osc_counts {
    uint64_t packets;       /* datagrams received */
    uint64_t malformed;     /* datagrams that are not OSC 1.0 (dropped whole) */
    uint64_t messages;      /* messages in well-formed datagrams */
    uint64_t bad_messages;  /* known addresses with wrong arguments (dropped) */
    uint64_t unknown_names; /* markers or bones not in the marker set / skeleton (ignored) */
    uint64_t ignored;       /* other addresses */
    uint64_t frames;        /* frames completed */
    uint64_t coalesced;     /* frames replaced by a newer one before read (latest wins) */
} drv_osc_counts;
/* -EINVAL when s is not an open osc source. Read from the thread that reads the source. */
int drv_osc_counts_get(const drv_source *s, drv_osc_counts *out);
/* The bound UDP port, or -EINVAL. */
int drv_osc_port(const drv_source *s);

/* ---- OSC captures (osc/capture.c; docs/FORMATS.md "OSC capture") ----
 * A file of timed OSC datagrams: "MSOSCCAP", u32 version 1, u32 count, then per datagram a u64
 * time (microseconds since the capture's start, non-decreasing), a u32 length (a multiple of 4,
 * at most DRV_OSC_CAPTURE_MAX_DGRAM) and the datagram's bytes (one OSC 1.0 packet, as sent);
 * little-endian. `meshsteer osc-play` sends one to a port; the reader checks every datagram
 * with the packet walker the osc: source uses. */
#define DRV_OSC_CAPTURE_MAX_DGRAM 65504
typedef struct drv_osc_capture {
    int count;       /* datagrams */
    uint64_t *t_us;  /* count: microseconds since the capture's start, non-decreasing */
    size_t *off;     /* count: where datagram i starts in data */
    uint32_t *len;   /* count: its length in bytes */
    uint8_t *data;   /* the datagrams, one after the other */
} drv_osc_capture;
struct mdl_markers;
/* Reads (or parses buf of len bytes, `name` for messages) a capture into *out; MDL_EFORMAT with
 * the byte and the reason for a malformed one. Free with drv_osc_capture_destroy (NULL is fine). */
int drv_osc_capture_read(const char *path, drv_osc_capture **out, char *err);
int drv_osc_capture_parse(const uint8_t *buf, size_t len, const char *name, drv_osc_capture **out,
                          char *err);
int drv_osc_capture_write(const char *path, const drv_osc_capture *c, char *err);
void drv_osc_capture_destroy(drv_osc_capture *c);
/* What a sender of the osc: source's address space sends for a marker recording: frame f is one
 * bundle (time tag 1, "immediately") of "/marker NAME x y z" (float32; metres, Y up as in m) per
 * marker, "/marker NAME" for an invalid one, at time f / fps. */
int drv_osc_capture_from_markers(const struct mdl_markers *m, drv_osc_capture **out, char *err);

#ifdef __cplusplus
}
#endif
#endif
