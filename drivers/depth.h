/* depth.h - the public depth side of drivers/ (beside drivers.h, the marker-source interface):
 * markers from depth images (pure C, no device), the test camera, and depth sensors on USB. The
 * sources built on them (fakenect, v4l2, openni2) are reached through drivers.h; their headers,
 * and everything else under drivers/depth/, are private to drivers/ (tests/layout.sh).
 *
 * Markers from depth images, pipeline per frame (drv_depth_tracker_process, markers.c):
 *   segment.c   foreground: depth gate, RANSAC floor plane removal, connected components on a
 *               downsampled grid, the nearest person-sized component;
 *   geodesic.c  accumulative geodesic extrema (Plagemann et al. 2010, Baak et al. 2011): Dijkstra
 *               from the body centroid, the farthest point becomes a new zero-distance source, repeat;
 *   body_frame.c  the body frame: up = the floor normal, left = across the torso's depth surface
 *               (which way the person faces), smoothed over frames;
 *   label.c     head / lhand / rhand / lfoot / rfoot by a cost assignment in that body frame that
 *               includes the previous frame's markers (temporal consistency), with a confidence
 *               per marker; a hand (foot) pair whose swap costs little has an uncertain side and is
 *               not reported valid (drv_depth_result.side_uncertain), nor is a head, hand or
 *               foot that is inferred rather than seen (.inferred, markers.c);
 *   head_axis.c, head_crown.c  the head marker: the top of the head on its axis, from its
 *               silhouette; or, when an arm before the head cuts its top off from the face, that
 *               top, an extremum of its own;
 *   one_euro.c  One Euro filter (Casiez et al. 2012) per marker coordinate.
 * Output frame: the camera's, in metres, Y up: X to the image's right, Y up, Z towards the viewer
 * (the camera looks along -Z). A person facing the camera has their left hand at +X.
 *
 * The test camera (render.c) rasterises a mesh into Kinect-v1-like depth (disparity quantisation,
 * noise, projector shadows at silhouettes, a floor) and maps world points into that same frame.
 *
 * Memory: everything is allocated at create; process/render calls allocate nothing.
 */
#ifndef MESHSTEER_DRIVERS_DEPTH_H
#define MESHSTEER_DRIVERS_DEPTH_H

#include <stddef.h>
#include <stdint.h>

#include "drivers.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------ camera intrinsics (intrinsics.c) */

/* Pinhole intrinsics in pixels; pixel (u, v) has its centre at integer coordinates. */
typedef struct drv_intrinsics {
    int width, height;
    double fx, fy, cx, cy;
} drv_intrinsics;

/* Kinect v1 depth camera at 640x480: fx = fy = 580, cx = 319.5, cy = 239.5. Published calibrations
 * of single units range over fx 580..594 (e.g. N. Burrus: fx 594.2, fy 591.0, cx 339.3, cy 242.7);
 * pass your own through drv_depth_opts.k / drv_render_opts.k to override. */
void drv_intrinsics_kinect1(drv_intrinsics *k);

/* Back-projects pixel (u, v) with depth z (metres along the optical axis) into the Y-up camera
 * frame: X = (u - cx) z / fx, Y = -(v - cy) z / fy, Z = -z. */
void drv_intrinsics_unproject(const drv_intrinsics *k, double u, double v, double z, float p[3]);
/* Projects a Y-up camera-frame point; returns 0 when it is in front of the camera. */
int drv_intrinsics_project(const drv_intrinsics *k, const float p[3], double *u, double *v);

/* Kinect v1 raw 11-bit disparity <-> metres (the widely used fit z = 1 / (3.3309495 - 0.0030711 d),
 * d in 0..2046, 2047 = no reading). */
double drv_kinect1_disparity_to_m(double d);
double drv_kinect1_m_to_disparity(double z);

/* ------------------------------------------------------------------ marker labels */

enum { DRV_DEPTH_HEAD = 0, DRV_DEPTH_LHAND, DRV_DEPTH_RHAND, DRV_DEPTH_LFOOT, DRV_DEPTH_RFOOT,
       DRV_DEPTH_TORSO, DRV_DEPTH_NLABELS };
/* "head", "lhand", "rhand", "lfoot", "rfoot", "torso" */
extern const char *const drv_depth_label_names[DRV_DEPTH_NLABELS];

/* ------------------------------------------------------------------ options */

typedef struct drv_depth_opts {
    drv_intrinsics k;      /* of the input images */
    int step;              /* grid cell size in pixels (4: 160x120 cells at 640x480); with
                              cell_m > 0, the size of the first frame's cells */
    float cell_m;          /* > 0: each frame's cell size is chosen so that a cell spans about
                              this many metres at the person (its depth in the previous frame),
                              within [step_min, step_max] pixels: the graph keeps about the same
                              number of cells near and far. 0: always `step` */
    int step_min, step_max;
    float z_min, z_max;    /* depth gate, metres */
    float max_jump;        /* geodesic graph: neighbouring cells whose depths differ by less
                              than this (metres; raised at a distance to three of the sensor's
                              depth steps there) are joined by their 3D distance. As given, not
                              raised, a step over it is an occluding edge that can close an arm
                              loop (a slit, segment.c) ... */
    float seg_jump;        /* ... those differing by less than this (and by more than max_jump)
                              belong to the same person (segmentation) and are joined with
                              jump_penalty metres added: a dress hem in front of the legs, a
                              hand in front of the body (reached through the arm when shorter) */
    float jump_penalty;
    float attach_jump;     /* a small component (at most attach_frac of the person's area) that
                              touches the person across a depth step below this (metres) is a
                              limb seen past an occluder (a leg behind the other, 0.3 m back) and
                              joins the person; the geodesic graph crosses that step with
                              jump_penalty added. 0 = off */
    float attach_frac;
    int floor;             /* 1: find and remove a floor plane (RANSAC) */
    int floor_iters;       /* RANSAC hypotheses */
    float floor_tol;       /* metres: cells this close to the floor plane (or below) are floor */
    float floor_max_tilt;  /* degrees between the floor normal and the camera's up axis */
    float min_area;        /* m^2: smallest component taken for a person */
    int max_extrema;       /* accumulative geodesic extrema per frame */
    float min_extent;      /* metres: stop adding extrema once the farthest is this close */
    float tip_radius;      /* metres: a marker is the mean of the cells this close (geodesically)
                              to its extremum */
    float head_offset;     /* metres: when the head's silhouette is not its own (an arm in
                              front of it; head_axis.c places it otherwise), the head marker is
                              pushed this far back along the viewing ray, from the visible
                              surface to the head's mid-plane (the top of the head lies there;
                              cf. Shotton et al. 2011, Sec. 3.3, who push surface proposals back
                              by a learned 39 mm) */
    int smooth;            /* 1: One Euro filter on the output */
    double oe_min_cutoff;  /* One Euro: minimum cutoff frequency (Hz) */
    double oe_beta;        /* One Euro: speed coefficient (s/m) */
    double oe_dcutoff;     /* One Euro: cutoff for the derivative (Hz) */
    double oe_head_beta;    /* the head's own speed coefficient (s/m) and derivative cutoff */
    double oe_head_dcutoff; /* (Hz): it follows motion faster than a hand (markers.c) */
    int hold_frames;       /* frames a lost marker keeps its last position (reported invalid) */
    uint64_t seed;         /* RANSAC random seed (results are deterministic per seed) */
} drv_depth_opts;

void drv_depth_opts_default(drv_depth_opts *o);

/* ------------------------------------------------------------------ the tracker (markers.c) */

#define DRV_DEPTH_MAX_EXTREMA 12

typedef struct drv_depth_result {
    float xyz[DRV_DEPTH_NLABELS][3];  /* metres, Y-up camera frame (smoothed when opts.smooth) */
    float raw[DRV_DEPTH_NLABELS][3];  /* this frame's unsmoothed measurement */
    uint8_t valid[DRV_DEPTH_NLABELS]; /* 1 when found in this frame and, for a hand or foot, its
                                         side is certain: what a marker source publishes */
    uint8_t side_uncertain[DRV_DEPTH_NLABELS]; /* 1: a hand (foot) was found at xyz, but which
                                         hand (foot) it is is not certain (label.c): valid is 0,
                                         so that no consumer takes a guess for a measurement;
                                         lhand and rhand (lfoot, rfoot) may then both be set */
    uint8_t inferred[DRV_DEPTH_NLABELS]; /* 1: a hand not seen (markers.c): its arm disappears
                                         behind a nearer surface at or above the elbow, the
                                         point labelled is not reached through an arm, or it is
                                         nearer the centroid than a shoulder and an upper arm
                                         (a person seen down to the floor), or it comes from a
                                         slit (the forearm in front of the torso, the hand on
                                         the hip: segment.c); or a foot not seen:
                                         its leg is cut by the image's bottom edge above the
                                         ankle; or a head cut by the image's top edge wider
                                         than a head is long, or whose neck lies more than 8 cm
                                         off the body's mid-plane (label.c HEAD_ASIDE). xyz
                                         is a guess, not a measurement, and valid is 0 */
    float conf[DRV_DEPTH_NLABELS];    /* 0..1 */
    int nextrema;                     /* accumulative geodesic extrema found, followed by the hands
                                         estimated from arm loops (geodesic 0), up to the max */
    float extrema[DRV_DEPTH_MAX_EXTREMA][3];
    float geodesic[DRV_DEPTH_MAX_EXTREMA]; /* metres from the sources at the time it was found */
    int extremum_label[DRV_DEPTH_MAX_EXTREMA]; /* DRV_DEPTH_* or -1 */
    int extremum_px[DRV_DEPTH_MAX_EXTREMA][2]; /* pixel (u, v) */
    float left[3];                    /* the body frame's left axis (unit, orthogonal to the
                                         floor normal): the person's left, from their torso
                                         (body_frame.c); the camera's +X when facing it */
    int person_cells;                 /* grid cells of the tracked person, 0 = nobody */
    float person_depth;               /* mean depth of the person (metres along the axis) */
    int floor_found;
    float floor[4];                   /* n.p + d = 0, n unit, Y-up camera frame, n up */
} drv_depth_result;

typedef struct drv_depth_tracker drv_depth_tracker;

int drv_depth_tracker_create(const drv_depth_opts *o, drv_depth_tracker **out, char *err);
void drv_depth_tracker_destroy(drv_depth_tracker *t);
/* One depth image, width x height of opts.k, millimetres (0 = no reading); t_us is its capture
 * time (microseconds, any epoch, increasing). Fills *r; allocates nothing. */
int drv_depth_tracker_process(drv_depth_tracker *t, const uint16_t *depth_mm, uint64_t t_us,
                              drv_depth_result *r);
/* Forgets the previous frames (new performer, seek). */
void drv_depth_tracker_reset(drv_depth_tracker *t);
/* Grid view for debugging and overlays: cell size, dimensions and the person mask (gw x gh, 1 =
 * person) of the last processed frame. */
void drv_depth_tracker_grid(const drv_depth_tracker *t, int *step, int *gw, int *gh,
                            const uint8_t **person);

/* ------------------------------------------------------------------ the test camera (render.c)
 * Rasterises a mesh into Kinect-v1-like depth.
 *
 * World: metres, Y up, the floor is y = 0. The camera stands at (0, cam_height, 0) looking along
 * world -Z, pitched down by cam_pitch degrees; its frame is the Y-up camera frame above.
 * Per frame: z-buffer rasterisation (perspective-correct depth), a floor plane and an optional back
 * wall, then the Kinect's ways of failing: shadows of the IR projector (it sits `baseline` metres
 * to the camera's +X, so surfaces it cannot see give no reading, left of foreground objects),
 * dropouts at depth edges, raw 11-bit disparity quantisation with Gaussian disparity noise
 * (about 2 cm depth steps at 2.5 m), and the valid range. Output: millimetres, 0 = no reading.
 * All buffers are allocated at create (for up to max_vertices vertices). */

typedef struct drv_render_opts {
    drv_intrinsics k;
    float cam_height;        /* metres above the floor */
    float cam_pitch;         /* degrees, positive = looking down */
    int floor;               /* 1: render the floor y = 0 */
    float wall_dist;         /* a back wall at world z = -wall_dist; 0 = none */
    float min_range, max_range; /* metres; no reading outside */
    double disparity_noise;  /* sigma of Gaussian noise on raw disparity (units of 1/8 pixel) */
    double baseline;         /* projector offset along the camera's +X (metres); 0 = no shadows */
    double edge_dropout;     /* probability that a pixel at a depth edge has no reading */
    int quantise;            /* 1: Kinect v1 raw disparity quantisation */
    uint64_t seed;           /* noise seed; frames are deterministic per seed and frame order */
} drv_render_opts;

void drv_render_opts_default(drv_render_opts *o);

typedef struct drv_render drv_render;

int drv_render_create(const drv_render_opts *o, int max_vertices, drv_render **out, char *err);
void drv_render_destroy(drv_render *r);
/* V: nv x 3 world positions; F: nf x 3 0-based triangles; out: width x height millimetres. */
int drv_render_frame(drv_render *r, const float *V, int nv, const uint32_t *F, int nf,
                     uint16_t *out, char *err);
/* World point -> the camera frame (metres, Y up, looking -Z). */
void drv_render_world_to_camera(const drv_render *r, const float w[3], float c[3]);

/* Moves a mesh into the scene: rotates it about the vertical axis by yaw (radians, around the
 * point (pivot_x, *, pivot_z)), then translates by t. V, out: nv x 3 (may be the same array). */
void drv_render_place(const float *V, int nv, float yaw, float pivot_x, float pivot_z,
                      const float t[3], float *out);

/* ------------------------------------------------------------------ fakenect dumps (fakenect.c)
 * The writer of libfreenect's fakenect dump directories (the format: depth/fakenect.h), for
 * recordings of the test camera that the fakenect: source and libfreenect's fakenect replay. */
typedef struct drv_fakenect_writer drv_fakenect_writer;

/* Creates DIR (or uses an empty existing one; refuses one that has an INDEX.txt: -EEXIST). */
int drv_fakenect_writer_open(const char *dir, drv_fakenect_writer **out, char *err);
/* Writes one 640x480 depth frame given in millimetres (0 = none) at host time `t` seconds. */
int drv_fakenect_writer_depth(drv_fakenect_writer *w, double t, uint32_t timestamp,
                              const uint16_t *mm, char *err);
int drv_fakenect_writer_close(drv_fakenect_writer *w, char *err); /* NULL is fine */

/* ------------------------------------------------------------------ USB (kinect_usb.c)
 * Depth sensors on USB through libusb: which devices are depth sensors, a watcher for their
 * arrival and departure (libusb hotplug, or polling where libusb has no hotplug support), and the
 * Kinect v1 motor: tilt and LED.
 *
 * Known devices: Kinect v1 camera 045e:02ae, motor 045e:02b0, Kinect for Windows 045e:02c2;
 * PrimeSense Carmine/Asus Xtion 1d27:0600, 1d27:0601, 1d27:0609.
 *
 * Kinect v1 motor vendor requests (OpenKinect protocol documentation, "Motor"):
 *   LED:   bmRequestType 0x40 (vendor, host-to-device), bRequest 0x06, wValue = LED mode
 *          (0 off, 1 green, 2 red, 3 yellow, 4 blink green, 6 blink red/yellow), wIndex 0, no data;
 *   tilt:  bmRequestType 0x40, bRequest 0x31, wValue = angle in half degrees as a 16-bit two's
 *          complement (the motor accepts about -31..+31 degrees), wIndex 0, no data;
 *   state: bmRequestType 0xC0 (vendor, device-to-host), bRequest 0x32, wValue 0, wIndex 0,
 *          10 bytes: [2..7] accelerometer x, y, z as big-endian int16 (819 counts = 1 g),
 *          [8] tilt angle in half degrees (int8, 0x80 = unknown, moving), [9] motor status
 *          (0 stopped, 1 at limit, 4 moving). */

/* "kinect1-camera", "kinect1-motor", "kinect1-windows", "primesense" or NULL. */
const char *drv_usb_depth_kind(uint16_t vid, uint16_t pid);

typedef struct drv_usb_request {
    uint8_t bm_request_type, b_request;
    uint16_t w_value, w_index, w_length;
} drv_usb_request;

enum { DRV_KINECT_LED_OFF = 0, DRV_KINECT_LED_GREEN = 1, DRV_KINECT_LED_RED = 2,
       DRV_KINECT_LED_YELLOW = 3, DRV_KINECT_LED_BLINK_GREEN = 4,
       DRV_KINECT_LED_BLINK_RED_YELLOW = 6 };

/* name: off, green, red, yellow, blink-green, blink-red-yellow. */
int drv_kinect_led_parse(const char *name, int *led, char *err);
int drv_kinect_led_request(int led, drv_usb_request *rq, char *err);
/* degrees in [-31, 31], rounded to half degrees. */
int drv_kinect_tilt_request(double degrees, drv_usb_request *rq, char *err);
void drv_kinect_state_request(drv_usb_request *rq);

typedef struct drv_kinect_state {
    int16_t accel[3];     /* raw counts, 819 = 1 g */
    double tilt_deg;      /* NAN while moving / unknown */
    int status;           /* 0 stopped, 1 at limit, 4 moving */
} drv_kinect_state;
int drv_kinect_state_parse(const uint8_t *buf, size_t len, drv_kinect_state *st, char *err);

/* ---- devices on the bus */

typedef struct drv_usb_dev {
    uint16_t vid, pid;
    uint8_t bus, addr;
    const char *kind;     /* drv_usb_depth_kind */
} drv_usb_dev;

typedef struct drv_usb_watch drv_usb_watch;
/* Called for each known depth device that arrives (arrived = 1, including those present at
 * create) or leaves (0); from drv_usb_watch_poll, on the caller's thread. */
typedef void (*drv_usb_event_fn)(void *user, int arrived, const drv_usb_dev *d);

/* -ENODEV when USB is not available here (no usbfs). */
int drv_usb_watch_create(drv_usb_event_fn fn, void *user, drv_usb_watch **out, char *err);
void drv_usb_watch_destroy(drv_usb_watch *w);
/* 1 when libusb's hotplug events are used, 0 when the watcher polls the bus. */
int drv_usb_watch_hotplug(const drv_usb_watch *w);
/* Waits up to timeout_ms for events (polling: re-enumerates at most once per poll_ms). */
int drv_usb_watch_poll(drv_usb_watch *w, int timeout_ms, char *err);

/* ---- the Kinect v1 motor */

typedef struct drv_kinect_motor drv_kinect_motor;
/* -ENODEV when no Kinect v1 motor (045e:02b0) is attached. */
int drv_kinect_motor_open(drv_kinect_motor **out, char *err);
void drv_kinect_motor_close(drv_kinect_motor *m);
int drv_kinect_motor_led(drv_kinect_motor *m, int led, char *err);
int drv_kinect_motor_tilt(drv_kinect_motor *m, double degrees, char *err);
int drv_kinect_motor_state(drv_kinect_motor *m, drv_kinect_state *st, char *err);

#ifdef __cplusplus
}
#endif
#endif
