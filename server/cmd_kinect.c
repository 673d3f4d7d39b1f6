/* cmd_kinect.c - `meshsteer kinect`: Kinect v1 motor tilt and LED, motor state, and the depth
 * sensors on the USB bus (listed, or watched for arrivals and departures). The USB work is in
 * drivers/depth/kinect_usb.c. */
#include "cli.h"
#include "depth.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#define CMD "kinect"

static void usage(void)
{
    printf("usage: meshsteer kinect [--tilt DEG] [--led MODE] [--state] [--list] [--watch SECONDS]\n\n"
           "Kinect v1 motor and LED, and depth sensors on USB.\n\n"
           "  --tilt DEG      tilt the Kinect v1 head to DEG degrees (-31 .. 31)\n"
           "  --led MODE      off, green, red, yellow, blink-green, blink-red-yellow\n"
           "  --state         print the motor's tilt, status and accelerometer\n"
           "  --list          list Kinect v1 and PrimeSense/Asus devices on the bus\n"
           "  --watch SECONDS print arrivals and departures of such devices for SECONDS\n"
           "exit status: 0 done, 1 failure, 2 usage, 3 no device\n");
}

static void on_event(void *user, int arrived, const drv_usb_dev *d)
{
    (void)user;
    printf("%s %04x:%04x %s bus %u address %u\n", arrived ? "arrived" : "left", d->vid, d->pid,
           d->kind, d->bus, d->addr);
    fflush(stdout);
}

int cmd_kinect(int argc, char **argv)
{
    double tilt = NAN, watch = 0;
    int led = -1, state = 0, list = 0;
    char err[DRV_ERR_LEN] = "";
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage();
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--state")) {
            state = 1;
        } else if (!strcmp(a, "--list")) {
            list = 1;
        } else if (!strcmp(a, "--tilt") || !strcmp(a, "--led") || !strcmp(a, "--watch")) {
            if (!v)
                return cli_usage_error(CMD, "%s needs a value", a);
            i++;
            if (!strcmp(a, "--tilt")) {
                if (cli_parse_double(CMD, a, v, &tilt))
                    return CLI_EXIT_USAGE;
                if (!(tilt >= -31 && tilt <= 31))
                    return cli_usage_error(CMD, "--tilt %g: the motor moves within -31..31 degrees",
                                           tilt);
            } else if (!strcmp(a, "--watch")) {
                if (cli_parse_double(CMD, a, v, &watch))
                    return CLI_EXIT_USAGE;
                if (!(watch > 0 && watch <= 86400))
                    return cli_usage_error(CMD, "--watch %g: expected 0 < SECONDS <= 86400", watch);
            } else if (drv_kinect_led_parse(v, &led, err)) {
                return cli_usage_error(CMD, "%s", err);
            }
        } else {
            return cli_usage_error(CMD, "unknown option '%s'", a);
        }
    }
    if (isnan(tilt) && led < 0 && !state && !list && watch <= 0)
        return cli_usage_error(CMD, "nothing to do (--tilt, --led, --state, --list or --watch)");
    if (list || watch > 0) {
        drv_usb_watch *w;
        if (drv_usb_watch_create(on_event, NULL, &w, err))
            return cli_fail(CMD, 3, "%s", err);
        if (watch > 0) {
            printf("watching (%s)\n", drv_usb_watch_hotplug(w) ? "hotplug" : "polling");
            struct timespec t0, t;
            clock_gettime(CLOCK_MONOTONIC, &t0);
            do {
                if (drv_usb_watch_poll(w, 250, err)) {
                    drv_usb_watch_destroy(w);
                    return cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
                }
                clock_gettime(CLOCK_MONOTONIC, &t);
            } while ((double)(t.tv_sec - t0.tv_sec) + (t.tv_nsec - t0.tv_nsec) * 1e-9 < watch);
        } else {
            drv_usb_watch_poll(w, 0, err); /* deliver the enumeration's arrivals */
        }
        drv_usb_watch_destroy(w);
    }
    if (isnan(tilt) && led < 0 && !state)
        return CLI_EXIT_OK;
    drv_kinect_motor *m;
    int r = drv_kinect_motor_open(&m, err);
    if (r)
        return cli_fail(CMD, r == -ENODEV ? 3 : CLI_EXIT_FAIL, "%s", err);
    if ((led >= 0 && (r = drv_kinect_motor_led(m, led, err))) ||
        (!isnan(tilt) && (r = drv_kinect_motor_tilt(m, tilt, err)))) {
        drv_kinect_motor_close(m);
        return cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
    }
    if (state) {
        drv_kinect_state st;
        if ((r = drv_kinect_motor_state(m, &st, err))) {
            drv_kinect_motor_close(m);
            return cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
        }
        printf("tilt %s%.1f deg, status %s, accel %d %d %d (819 = 1 g)\n",
               isnan(st.tilt_deg) ? "(moving) " : "", isnan(st.tilt_deg) ? 0.0 : st.tilt_deg,
               st.status == 0 ? "stopped" : st.status == 1 ? "at limit" : st.status == 4 ? "moving" : "?",
               st.accel[0], st.accel[1], st.accel[2]);
    }
    drv_kinect_motor_close(m);
    return CLI_EXIT_OK;
}
