/* kinect_usb.h - depth sensors on USB through libusb (kinect_usb.c): which devices are depth
 * sensors, a watcher for their arrival and departure (libusb hotplug, or polling where libusb has
 * no hotplug support), and the Kinect v1 motor: tilt and LED.
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
#ifndef MESHSTEER_DRIVERS_DEPTH_KINECT_USB_H
#define MESHSTEER_DRIVERS_DEPTH_KINECT_USB_H

#include <stddef.h>
#include <stdint.h>

#include "drivers.h"

#ifdef __cplusplus
extern "C" {
#endif

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
