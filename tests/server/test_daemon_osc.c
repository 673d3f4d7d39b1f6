/* test_daemon_osc.c - meshsteerd with an osc: source: the committed OSC capture of the example's
 * trot (recordings/example-trot.osc) drives the example model, mixed with bad traffic (datagrams
 * that are not OSC, a message with wrong arguments, a marker not in the set, an unknown
 * address); /metrics then shows the source's counters exactly (meshsteer_osc_*), the daemon keeps
 * streaming, and a replay source shows no meshsteer_osc_* metrics at all.
 * Usage: test_daemon_osc MESHSTEERD MAKE_MODEL */
#include "daemon_harness.h"
#include "drivers.h"
#include "model.h"
#include "test.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

static int udp_fd;
static struct sockaddr_in udp_to;

static void send_dgram(const void *buf, size_t len)
{
    ASSERT_INT_EQ(sendto(udp_fd, buf, len, 0, (struct sockaddr *)&udp_to, sizeof udp_to), len);
    usleep(3000); /* the daemon reads as they come; counters do not depend on it */
}

/* A free UDP port on loopback (closed again: the daemon binds it next). */
static int free_udp_port(void)
{
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t n = sizeof a;
    ASSERT(fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof a) == 0 &&
           getsockname(fd, (struct sockaddr *)&a, &n) == 0);
    close(fd);
    return ntohs(a.sin_port);
}

/* "/marker" with the given type tags and arguments already encoded (big-endian) */
static size_t marker_msg(uint8_t *b, const char *types, const char *name, int nfloats)
{
    size_t at = 0;
    const char *parts[3] = {"/marker", types, name};
    for (int i = 0; i < 3; i++) {
        size_t l = strlen(parts[i]), p = (l + 4) & ~(size_t)3;
        memset(b + at, 0, p);
        memcpy(b + at, parts[i], l);
        at += p;
    }
    for (int k = 0; k < nfloats; k++, at += 4) { /* 0.5f = 0x3f000000 */
        b[at] = 0x3f;
        b[at + 1] = b[at + 2] = b[at + 3] = 0;
    }
    return at;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: test_daemon_osc MESHSTEERD MAKE_MODEL\n");
        return 2;
    }
    harness H;
    harness_fixtures(&H, argv[2]);
    char err[DRV_ERR_LEN] = "", model[1200], source[2400];
    drv_osc_capture *cap = NULL;
    mdl_markers *mk = NULL;
    ASSERT_OK(drv_osc_capture_read(test_src("recordings/example-trot.osc"), &cap, err), err);
    ASSERT_OK(mdl_markers_read(test_src("recordings/example-trot.c3d"), NULL, &mk, err), err);
    int port = free_udp_port();
    int at = snprintf(source, sizeof source, "osc:127.0.0.1:%d?markers=", port);
    for (int m = 0; m < mk->count; m++)
        at += snprintf(source + at, sizeof source - (size_t)at, "%s%s", m ? "," : "", mk->names[m]);
    snprintf(model, sizeof model, "%s/model.msm", H.dir);
    const char *args[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0", NULL};
    harness_start(&H, argv[1], args);

    udp_fd = socket(AF_INET, SOCK_DGRAM, 0);
    ASSERT(udp_fd >= 0);
    udp_to = (struct sockaddr_in){.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    udp_to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    /* before any traffic: the counters are there, at zero */
    ASSERT_NEAR(harness_metric(&H, "meshsteer_osc_packets_total"), 0, 0);
    ASSERT_NEAR(harness_metric(&H, "meshsteer_osc_malformed_total"), 0, 0);

    /* good frames from the recording, bad datagrams among them */
    const int good = 60;
    uint8_t b[256];
    for (int f = 0; f < good; f++) {
        send_dgram(cap->data + cap->off[f], cap->len[f]);
        if (f == 10)
            send_dgram("garbage!", 8); /* not OSC */
        if (f == 20) /* a bundle whose element runs past the end */
            send_dgram("#bundle\0\0\0\0\0\0\0\0\1\0\0\1\0", 20);
        if (f == 30) /* a known address, wrong arguments: 2 numbers */
            send_dgram(b, marker_msg(b, ",sff", mk->names[0], 2));
        if (f == 40) /* a marker not in the set */
            send_dgram(b, marker_msg(b, ",sfff", "nose", 3));
        if (f == 50) { /* another address */
            static const uint8_t other[] = "/elsewhere\0\0,\0\0\0";
            send_dgram(other, 16);
        }
    }
    const double packets = good + 5, messages = good * mk->count + 3;
    double got = -1;
    for (int t = 0; t < 100 && got < packets; t++) { /* counters are mirrored after each read */
        usleep(50000);
        got = harness_metric(&H, "meshsteer_osc_packets_total");
    }
    printf("osc: %g datagrams counted of %g sent\n", got, packets);
    ASSERT_NEAR(got, packets, 0);
    ASSERT_NEAR(harness_metric(&H, "meshsteer_osc_malformed_total"), 2, 0);
    ASSERT_NEAR(harness_metric(&H, "meshsteer_osc_messages_total"), messages, 0);
    ASSERT_NEAR(harness_metric(&H, "meshsteer_osc_bad_messages_total"), 1, 0);
    ASSERT_NEAR(harness_metric(&H, "meshsteer_osc_unknown_names_total"), 1, 0);
    ASSERT_NEAR(harness_metric(&H, "meshsteer_osc_ignored_total"), 1, 0);
    double frames = harness_metric(&H, "meshsteer_osc_frames_total");
    double coalesced = harness_metric(&H, "meshsteer_osc_coalesced_total");
    double in = harness_metric(&H, "meshsteer_frames_in_total");
    printf("osc: %g frames formed, %g coalesced, %g read by the daemon\n", frames, coalesced, in);
    ASSERT_INT_GE(frames, good); /* every bundle; loose messages may form more */
    ASSERT_INT_GE(in, 1);
    ASSERT_INT_LE(in, frames - coalesced);
    double synth = harness_metric(&H, "meshsteer_frames_synthesized_total");
    ASSERT_INT_GE(synth, 1);
    char *body = NULL;
    ASSERT_INT_EQ(harness_get(&H, "/healthz", &body), 200); /* still serving */
    free(body);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 10000), 0);

    /* a replay source has no OSC counters */
    snprintf(source, sizeof source, "replay:%s?loop=1", test_src("recordings/example-trot.c3d"));
    const char *args2[] = {"--model", model, "--source", source, "--listen", "127.0.0.1:0", NULL};
    harness_start(&H, argv[1], args2);
    ASSERT_INT_EQ(harness_get(&H, "/metrics", &body), 200);
    ASSERT(strstr(body, "meshsteer_frames_in_total") && !strstr(body, "meshsteer_osc_"));
    free(body);
    ASSERT_INT_EQ(harness_stop(&H, SIGTERM, 10000), 0);
    close(udp_fd);
    mdl_markers_destroy(mk);
    drv_osc_capture_destroy(cap);
    printf("ok\n");
    return 0;
}
