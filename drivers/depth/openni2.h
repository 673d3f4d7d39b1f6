/* openni2.h - depth cameras and .oni recordings through OpenNI2's C API (OniCAPI.h), and the
 * `openni2[:URI][#options]` marker source (openni2.c).
 *
 * URI: any OpenNI2 device URI (as oniGetDeviceList lists them), a .oni recording (OpenNI2's own
 * OniFile driver plays it), or empty for the first device found. Options follow a '#' (URIs may
 * contain '?' and ':'): width=, height=, fps= choose the depth mode (nearest supported, preferring
 * 1 mm depth pixels; default 640x480 at 30), record=PATH.oni (OpenNI2's recorder writes the depth
 * stream to PATH, losslessly, from start on; refused with -ENOTSUP when the device's driver does
 * not report ONI_STREAM_PROPERTY_CROPPING, because OpenNI2's player drops every frame of a stream
 * whose cropping the file does not record).
 * Recordings only: loop=0|1 (repeat, default 1; with 0 read returns DRV_EEOF after the last
 * frame, when OniFile reports ONI_DEVICE_STATE_EOF), speed=S (0 .. 100, default 1 = the recorded
 * rate, paced by the file's timestamps; 0 = every frame as fast as it is read, OpenNI2's manual
 * mode, playback speed -1); speed= on a live device is -EINVAL.
 * Controls (drv_source_control), recordings only: "pause" 1/0 (the player is held in OpenNI2's
 * manual mode and read returns DRV_ETIMEOUT without asking it for frames, so playback resumes
 * where it paused) and "speed" (as the option). No "seek": OpenNI2's seek can hang when the
 * stream is not running. A live camera takes no controls (s->controls is 0).
 * OpenNI2's player restarts its clock at each loop: no pause between the last and first frame.
 * An existing file is never overwritten: when PATH exists, the recording goes to PATH-1.oni,
 * PATH-2.oni, ... (the first free name), so a reopen after a loss starts the next file.
 *
 * Per stream: mirroring off (ONI_STREAM_PROPERTY_MIRRORING), intrinsics from the stream's fields
 * of view (fx = (w/2) / tan(hfov/2), fy = (h/2) / tan(vfov/2), centre at the image middle), depth
 * pixels in 1 mm or 100 um (converted to mm). Frame timestamps (the device's microsecond clock)
 * are mapped to CLOCK_MONOTONIC by the smallest offset host - device seen so far (the least
 * delayed frame), re-anchored when the device clock jumps back or drifts by more than 100 ms.
 *
 * Loss: OpenNI2's device callbacks (disconnected, or the error state) and read errors make
 * read return DRV_ELOST; the daemon closes and reopens the source later.
 * Threads: OpenNI2 runs threads of its own (its drivers deliver frames on them); the callbacks
 * only set an atomic flag. */
#ifndef MESHSTEER_DRIVERS_DEPTH_OPENNI2_H
#define MESHSTEER_DRIVERS_DEPTH_OPENNI2_H

#include "../depth.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The source kind "openni2" for the registry of drivers.h. */
extern const drv_source_ops drv_openni2_ops;

/* Maps device timestamps (us) to CLOCK_MONOTONIC (us): exposed for tests. */
typedef struct drv_clock_map {
    int init;
    int64_t offset;       /* host - device, microseconds */
    uint64_t last_dev;
} drv_clock_map;
uint64_t drv_clock_map_apply(drv_clock_map *m, uint64_t dev_us, uint64_t host_us);

#ifdef __cplusplus
}
#endif
#endif
