/* packet.h - an allocation-free reader of OSC 1.0 packets (messages and nested bundles).
 *
 * OSC 1.0 (opensoundcontrol.org/spec-1_0): a packet is a message or a bundle. A message is an
 * address ("/..."), a type tag string (",iifs..."), then the arguments, every field padded with
 * NULs to a multiple of 4 bytes, big-endian. A bundle is "#bundle\0", a 64-bit NTP time tag, then
 * elements, each a big-endian int32 size (a multiple of 4) followed by a message or a bundle.
 *
 * drv_osc_packet_walk checks the whole packet first and calls nothing when any part is malformed
 * (so a bad packet is dropped whole, never half applied); only then does it visit each message in
 * order, with bundle begin/end around the elements of each bundle. Time tags are read and passed
 * on but never used for scheduling (latest wins: everything is applied on arrival).
 * Argument types: i f s S b h t d c r m T F N I (and array brackets [ ]); any other tag is
 * malformed, because its size is unknown. Bundles nest at most DRV_OSC_MAX_DEPTH deep. */
#ifndef MESHSTEER_DRIVERS_OSC_PACKET_H
#define MESHSTEER_DRIVERS_OSC_PACKET_H

#include <stddef.h>
#include <stdint.h>

#define DRV_OSC_MAX_DEPTH 8
#define DRV_OSC_MAX_ARGS 64 /* arguments addressable by index; a message may have more */

typedef struct drv_osc_msg {
    const char *address; /* NUL-terminated, starts with '/' (points into the packet) */
    const char *types;   /* the type tags without the leading ',' (NUL-terminated) */
    int argc;            /* number of type tags (brackets included) */
    const uint8_t *arg[DRV_OSC_MAX_ARGS]; /* start of argument i (i < argc, i < DRV_OSC_MAX_ARGS) */
} drv_osc_msg;

typedef struct drv_osc_visitor {
    void (*message)(void *user, const drv_osc_msg *m);
    void (*bundle)(void *user, int begin, int depth, uint64_t timetag); /* may be NULL */
    void *user;
} drv_osc_visitor;

/* 0 after visiting a well-formed packet; -EINVAL (err says where and why) for a malformed one,
 * with no callback made. v may be NULL (check only). */
int drv_osc_packet_walk(const uint8_t *buf, size_t len, const drv_osc_visitor *v, char *err);

/* Argument i as a number (types i, h, f, d; T = 1, F = 0): 0, or -EINVAL for another type. */
int drv_osc_arg_number(const drv_osc_msg *m, int i, double *out);
/* Argument i as a string (types s, S): 0, or -EINVAL. */
int drv_osc_arg_string(const drv_osc_msg *m, int i, const char **out);

#endif
