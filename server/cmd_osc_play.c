/* cmd_osc_play.c - `meshsteer osc-play`: sends an OSC capture (drivers.h "OSC captures", e.g.
 * recordings/example-trot.osc) to a UDP port, each datagram at its recorded time (divided by
 * --speed), paced on CLOCK_MONOTONIC; the receiver is any OSC server, such as meshsteerd's osc:
 * source or liblo's oscdump. */
#include "cli.h"

#include "drivers.h"

#include <errno.h>
#include <netdb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define CMD "osc-play"

static void osc_play_usage(FILE *f)
{
    fprintf(f, "usage: meshsteer osc-play CAPTURE.osc HOST:PORT [--speed S] [--repeat N]\n\n"
               "Sends an OSC capture (recordings/README.md; `meshsteer record osc` writes one) as UDP\n"
               "datagrams to HOST:PORT ([ADDR]:PORT for IPv6), each at its recorded time.\n\n"
               "  --speed S    S times the recorded rate (default 1; 0: as fast as possible)\n"
               "  --repeat N   play it N times, one after the other (default 1)\n");
}

static uint64_t mono_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* A UDP socket connected to HOST:PORT (the last ':' splits; brackets around an IPv6 address). */
static int connect_udp(const char *hp, char *why, size_t n)
{
    char host[256];
    const char *colon = strrchr(hp, ':');
    size_t hl = colon ? (size_t)(colon - hp) : 0;
    if (!colon || hl == 0 || hl >= sizeof host || !colon[1]) {
        snprintf(why, n, "'%s': expected HOST:PORT", hp);
        return -1;
    }
    memcpy(host, hp, hl);
    host[hl] = 0;
    if (host[0] == '[' && host[hl - 1] == ']') {
        memmove(host, host + 1, hl - 2);
        host[hl - 2] = 0;
    }
    struct addrinfo hints = {.ai_socktype = SOCK_DGRAM}, *ai = NULL;
    int g = getaddrinfo(host, colon + 1, &hints, &ai);
    if (g) {
        snprintf(why, n, "%s: %s", hp, gai_strerror(g));
        return -1;
    }
    int fd = socket(ai->ai_family, SOCK_DGRAM, 0);
    if (fd < 0 || connect(fd, ai->ai_addr, ai->ai_addrlen) != 0) {
        snprintf(why, n, "%s: %s", hp, strerror(errno));
        if (fd >= 0)
            close(fd);
        fd = -1;
    }
    freeaddrinfo(ai);
    return fd;
}

int cmd_osc_play(int argc, char **argv);

int cmd_osc_play(int argc, char **argv)
{
    const char *file = NULL, *to = NULL;
    double speed = 1;
    int repeat = 1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            osc_play_usage(stdout);
            return CLI_EXIT_OK;
        }
        if (!strcmp(a, "--speed") || !strcmp(a, "--repeat")) {
            if (i + 1 >= argc)
                return cli_usage_error(CMD, "%s needs a value", a);
            if (a[2] == 's' ? cli_parse_double(CMD, a, argv[++i], &speed)
                            : cli_parse_int(CMD, a, argv[++i], &repeat))
                return CLI_EXIT_USAGE;
        } else if (a[0] == '-') {
            return cli_usage_error(CMD, "unknown option '%s' (see --help)", a);
        } else if (!file) {
            file = a;
        } else if (!to) {
            to = a;
        } else {
            return cli_usage_error(CMD, "unexpected argument '%s'", a);
        }
    }
    if (!file || !to)
        return cli_usage_error(CMD, "CAPTURE and HOST:PORT are required (see --help)");
    if (!(speed == 0 || (speed >= DRV_SPEED_MIN && speed <= DRV_SPEED_MAX)))
        return cli_usage_error(CMD, "--speed %g is outside 0 or [%g, %g]", speed, DRV_SPEED_MIN,
                               DRV_SPEED_MAX);
    if (repeat < 1 || repeat > 1000000)
        return cli_usage_error(CMD, "--repeat %d is outside 1..1000000", repeat);
    char err[DRV_ERR_LEN] = "";
    drv_osc_capture *c = NULL;
    if (drv_osc_capture_read(file, &c, err))
        return cli_fail(CMD, CLI_EXIT_USAGE, "%s", err);
    int fd = connect_udp(to, err, sizeof err);
    if (fd < 0) {
        drv_osc_capture_destroy(c);
        return cli_usage_error(CMD, "%s", err);
    }
    long sent = 0, refused = 0;
    uint64_t span = c->count ? c->t_us[c->count - 1] : 0, t0 = mono_us();
    /* each pass starts one mean datagram interval after the previous one's last datagram */
    uint64_t gap = c->count > 1 ? span / (uint64_t)(c->count - 1) : 0;
    for (int r = 0; r < repeat; r++)
        for (int i = 0; i < c->count; i++) {
            if (speed > 0) {
                uint64_t due = t0 + (uint64_t)((double)((span + gap) * (uint64_t)r + c->t_us[i]) / speed);
                uint64_t now = mono_us();
                if (due > now) {
                    struct timespec ts = {(time_t)((due - now) / 1000000u),
                                          (long)((due - now) % 1000000u) * 1000L};
                    nanosleep(&ts, NULL);
                }
            }
            /* nobody listening yet (ECONNREFUSED from an earlier datagram) is not an error for
             * UDP: the datagram is counted and the capture goes on */
            if (send(fd, c->data + c->off[i], c->len[i], 0) == (ssize_t)c->len[i])
                sent++;
            else
                refused++;
        }
    close(fd);
    printf("%s: %ld datagrams sent to %s in %.3f s%s\n", file, sent, to,
           (double)(mono_us() - t0) * 1e-6, refused ? " (some refused: nobody listening)" : "");
    drv_osc_capture_destroy(c);
    return CLI_EXIT_OK;
}
