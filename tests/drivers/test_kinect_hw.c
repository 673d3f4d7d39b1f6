/* test_kinect_hw.c - suite hw: with a Kinect v1 attached, reads the motor state, sets the LED and
 * lists the device through the USB watcher. Exits 77 (skip) when USB or the motor is absent. */
#include "depth.h"
#include "test.h"

#include <errno.h>

static int seen;

static void on_event(void *user, int arrived, const drv_usb_dev *d)
{
    (void)user;
    printf("%s %04x:%04x %s\n", arrived ? "arrived" : "left", d->vid, d->pid, d->kind);
    if (arrived && d->vid == 0x045e && d->pid == 0x02b0)
        seen = 1;
}

int main(void)
{
    char err[DRV_ERR_LEN] = "";
    drv_kinect_motor *m;
    int r = drv_kinect_motor_open(&m, err);
    if (r == -ENODEV) {
        fprintf(stderr, "skip: %s\n", err);
        return 77;
    }
    ASSERT_OK(r, err);
    drv_kinect_state st;
    ASSERT_OK(drv_kinect_motor_state(m, &st, err), err);
    printf("tilt %.1f status %d accel %d %d %d\n", st.tilt_deg, st.status, st.accel[0], st.accel[1],
           st.accel[2]);
    /* a Kinect at rest feels about 1 g */
    double g = sqrt((double)st.accel[0] * st.accel[0] + (double)st.accel[1] * st.accel[1] +
                    (double)st.accel[2] * st.accel[2]) / 819.0;
    ASSERT_GT(g, 0.7);
    ASSERT_LT(g, 1.3);
    ASSERT_OK(drv_kinect_motor_led(m, DRV_KINECT_LED_GREEN, err), err);
    drv_kinect_motor_close(m);
    drv_usb_watch *w;
    ASSERT_OK(drv_usb_watch_create(on_event, NULL, &w, err), err);
    ASSERT_OK(drv_usb_watch_poll(w, 100, err), err);
    drv_usb_watch_destroy(w);
    ASSERT(seen);
    return 0;
}
