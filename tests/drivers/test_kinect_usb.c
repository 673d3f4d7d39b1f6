/* test_kinect_usb.c - the USB side without hardware: the device table, the Kinect v1 motor's
 * request encodings (LED, tilt in half degrees as two's complement, state read) and the parsing
 * of its 10-byte state, against values worked out by hand from the documented protocol. */
#include "depth.h"
#include "test.h"

#include <errno.h>

int main(void)
{
    char err[DRV_ERR_LEN] = "";
    ASSERT(!strcmp(drv_usb_depth_kind(0x045e, 0x02ae), "kinect1-camera"));
    ASSERT(!strcmp(drv_usb_depth_kind(0x045e, 0x02b0), "kinect1-motor"));
    ASSERT(!strcmp(drv_usb_depth_kind(0x045e, 0x02c2), "kinect1-windows"));
    ASSERT(!strcmp(drv_usb_depth_kind(0x1d27, 0x0600), "primesense"));
    ASSERT(!strcmp(drv_usb_depth_kind(0x1d27, 0x0601), "primesense"));
    ASSERT(!strcmp(drv_usb_depth_kind(0x1d27, 0x0609), "primesense"));
    ASSERT(drv_usb_depth_kind(0x045e, 0x02ad) == NULL); /* the Kinect's audio device */
    ASSERT(drv_usb_depth_kind(0x1d6b, 0x0002) == NULL);

    drv_usb_request rq;
    /* tilt: vendor OUT (0x40), request 0x31, half degrees as int16 */
    ASSERT_OK(drv_kinect_tilt_request(10.0, &rq, err), err);
    ASSERT_INT_EQ(rq.bm_request_type, 0x40);
    ASSERT_INT_EQ(rq.b_request, 0x31);
    ASSERT_INT_EQ(rq.w_value, 20);
    ASSERT_INT_EQ(rq.w_index, 0);
    ASSERT_INT_EQ(rq.w_length, 0);
    ASSERT_OK(drv_kinect_tilt_request(-15.0, &rq, err), err);
    ASSERT_INT_EQ(rq.w_value, 0xFFE2); /* -30 */
    ASSERT_OK(drv_kinect_tilt_request(-0.25, &rq, err), err);
    ASSERT(rq.w_value == 0 || rq.w_value == 0xFFFF); /* rounds to 0 or -1 half degree */
    ASSERT_OK(drv_kinect_tilt_request(31.0, &rq, err), err);
    ASSERT_INT_EQ(rq.w_value, 62);
    ASSERT_OK(drv_kinect_tilt_request(-31.0, &rq, err), err);
    ASSERT_INT_EQ(rq.w_value, 0xFFC2);
    ASSERT_INT_EQ(drv_kinect_tilt_request(31.5, &rq, err), -EINVAL);
    ASSERT_INT_EQ(drv_kinect_tilt_request(NAN, &rq, err), -EINVAL);

    /* LED: vendor OUT, request 0x06, mode in wValue */
    int led;
    ASSERT_OK(drv_kinect_led_parse("blink-red-yellow", &led, err), err);
    ASSERT_INT_EQ(led, 6);
    ASSERT_OK(drv_kinect_led_request(led, &rq, err), err);
    ASSERT_INT_EQ(rq.bm_request_type, 0x40);
    ASSERT_INT_EQ(rq.b_request, 0x06);
    ASSERT_INT_EQ(rq.w_value, 6);
    ASSERT_OK(drv_kinect_led_parse("off", &led, err), err);
    ASSERT_INT_EQ(led, 0);
    ASSERT_INT_EQ(drv_kinect_led_parse("purple", &led, err), -EINVAL);
    ASSERT(strstr(err, "purple"));
    ASSERT_INT_EQ(drv_kinect_led_request(5, &rq, err), -EINVAL);
    ASSERT_INT_EQ(drv_kinect_led_request(7, &rq, err), -EINVAL);

    /* state: vendor IN (0xC0), request 0x32, 10 bytes */
    drv_kinect_state_request(&rq);
    ASSERT_INT_EQ(rq.bm_request_type, 0xC0);
    ASSERT_INT_EQ(rq.b_request, 0x32);
    ASSERT_INT_EQ(rq.w_length, 10);
    /* accel x = 0x0010 (16), y = 0xFCCD (-819: 1 g down), z = 0x0102 (258); tilt 0xF6 = -10 half
     * degrees = -5 deg; status 0 */
    const uint8_t buf[10] = {0x00, 0x00, 0x00, 0x10, 0xFC, 0xCD, 0x01, 0x02, 0xF6, 0x00};
    drv_kinect_state st;
    ASSERT_OK(drv_kinect_state_parse(buf, 10, &st, err), err);
    ASSERT_INT_EQ(st.accel[0], 16);
    ASSERT_INT_EQ(st.accel[1], -819);
    ASSERT_INT_EQ(st.accel[2], 258);
    ASSERT_NEAR(st.tilt_deg, -5.0, 1e-12);
    ASSERT_INT_EQ(st.status, 0);
    const uint8_t moving[10] = {0, 0, 0, 0, 0, 0, 0, 0, 0x80, 0x04};
    ASSERT_OK(drv_kinect_state_parse(moving, 10, &st, err), err);
    ASSERT(isnan(st.tilt_deg));
    ASSERT_INT_EQ(st.status, 4);
    ASSERT_INT_EQ(drv_kinect_state_parse(buf, 9, &st, err), -EPROTO);
    printf("ok\n");
    return 0;
}
