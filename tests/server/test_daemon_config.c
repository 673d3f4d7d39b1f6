/* test_daemon_config.c - meshsteerd settings: defaults, the file syntax, file:line errors, the
 * all-or-nothing replacement of the old settings, and per-key validation. */
#include "daemon_config.h"
#include "encode.h"
#include "log.h"
#include "test.h"

#include <errno.h>
#include <string.h>

static int parse(srv_config *c, const char *text, char *err)
{
    return srv_config_parse(c, text, strlen(text), "t.conf", err);
}

int main(void)
{
    srv_config c;
    char err[SRV_ERR_LEN];
    srv_config_defaults(&c);
    ASSERT(!strcmp(c.listen_host, "127.0.0.1"));
    ASSERT_INT_EQ(c.port, 8080);
    ASSERT_INT_EQ(c.max_clients, 256);
    ASSERT(srv_config_validate(&c, err) == -EINVAL); /* no model, no source */

    const char *good = "# meshsteerd settings\n"
                       "model = /var/lib/meshsteer/horse.msm\n"
                       "source = \"replay:/data/gallop.c3d?loop=1#x\"   # quoted, '#' kept inside\n"
                       "\n"
                       "   listen=0.0.0.0:9000\r\n"
                       "max_clients = 64\n"
                       "idle_timeout = 5\n"
                       "origin = http://localhost:9000, https://example.org\n"
                       "log_level = debug\n"
                       "encoding = int16\n"
                       "labels = Hips=torso, Neck=head   # the depth camera's labels\n"
                       "publish = nats://10.0.0.1:4222, nats://nats-2.local:4222,nats://[::1]\n"
                       "subject = venue-1.horse_a\n"
                       "token = s3cret";
    ASSERT_OK(parse(&c, good, err), err);
    ASSERT(!strcmp(c.model, "/var/lib/meshsteer/horse.msm"));
    ASSERT(!strcmp(c.source, "replay:/data/gallop.c3d?loop=1#x"));
    ASSERT(!strcmp(c.listen_host, "0.0.0.0"));
    ASSERT_INT_EQ(c.port, 9000);
    ASSERT_INT_EQ(c.max_clients, 64);
    ASSERT_INT_EQ(c.idle_timeout, 5);
    ASSERT_INT_EQ(c.log_level, SRV_LOG_DEBUG);
    ASSERT_INT_EQ(c.encoding, SRV_ENC_INT16);
    ASSERT(!strcmp(c.token, "s3cret"));
    ASSERT(!strcmp(c.labels, "Hips=torso, Neck=head"));
    ASSERT(!strcmp(c.publish, "nats://10.0.0.1:4222, nats://nats-2.local:4222,nats://[::1]"));
    ASSERT(!strcmp(c.subject, "venue-1.horse_a"));
    ASSERT_OK(srv_config_validate(&c, err), err);

    /* errors name file:line and leave the old settings untouched */
    srv_config before = c;
    static const struct { const char *text, *expect; } bad[] = {
        {"model = a\nmax_clients = 0\n", "t.conf:2: max_clients: 0 outside [1, 10000]"},
        {"model = a\n\nnonsense\n", "t.conf:3: expected 'key = value'"},
        {"colour = red\n", "t.conf:1: unknown key 'colour'"},
        {"model = a\nmodel = b\n", "t.conf:2: 'model' set twice (first on line 1)"},
        {"listen = host:99999\n", "t.conf:1: listen port: 99999 outside [0, 65535]"},
        {"listen = a b:80\n", "t.conf:1: listen: bad character"},
        {"max_message = 12x\n", "t.conf:1: max_message: '12x' is not a whole number"},
        {"log_level = loud\n", "t.conf:1: log_level: 'loud'"},
        {"encoding = float64\n", "t.conf:1: encoding: 'float64'"},
        {"origin = ftp://x\n", "t.conf:1: origin: 'ftp://x'"},
        {"token = a&b\n", "t.conf:1: token:"},
        {"source = \"replay:x\n", "t.conf:1: unbalanced quote"},
        {" = 3\n", "t.conf:1: missing key"},
        {"model =\n", "t.conf:1: model: empty path"},
        {"model = a\nlabels = Hips=torso,Neck=head,LeftHand\n",
         "t.conf:2: labels: entry 3 'LeftHand': expected MODEL=LABEL (column 22)"},
        {"labels = Hips=torso,Hips=head\n", "t.conf:1: labels: entry 2 'Hips=head': model label "
                                             "'Hips' is already mapped by entry 1"},
        {"labels = =torso\n", "t.conf:1: labels: entry 1 '=torso': empty model label"},
        {"publish = tcp://a:4222\n", "t.conf:1: publish: 'tcp://a:4222' is not a nats://"},
        {"publish = nats://a:0\n", "t.conf:1: publish port: 0 outside [1, 65535]"},
        {"publish = nats://:4222\n", "t.conf:1: publish: no host in 'nats://:4222'"},
        {"publish = nats://a b:4222\n", "t.conf:1: publish: bad character in host"},
        {"publish = nats://a:4222/x\n", "t.conf:1: publish port: '4222/x' is not a whole"},
        {"publish = nats://[]:4222\n", "t.conf:1: publish: bad IPv6 address"},
        {"publish = ,\n", "t.conf:1: publish: no server URL"},
        {"subject = a..b\n", "t.conf:1: subject: 'a..b' at byte 1"},
        {"subject = a.>\n", "t.conf:1: subject: 'a.>' at byte 2"},
        {"subject = .a\n", "t.conf:1: subject: '.a' at byte 0"},
        {"subject =\n", "t.conf:1: subject: empty"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err[0] = '\0';
        int r = parse(&c, bad[i].text, err);
        if (r == 0 || !strstr(err, bad[i].expect)) {
            fprintf(stderr, "case %zu: got %d '%s', expected error '%s'\n", i, r, err, bad[i].expect);
            return 1;
        }
        ASSERT(!memcmp(&c, &before, sizeof c));
    }
    /* a NUL byte inside a line */
    ASSERT(srv_config_parse(&c, "model = a\0b\n", 12, "t.conf", err) == -EINVAL);
    ASSERT(strstr(err, "t.conf:1: NUL"));

    /* flags go through the same validation */
    ASSERT_OK(srv_config_set(&c, "listen", "[::1]:0", err), err);
    ASSERT(!strcmp(c.listen_host, "::1"));
    ASSERT_INT_EQ(c.port, 0);
    ASSERT_OK(srv_config_set(&c, "listen", "7000", err), err);
    ASSERT(!strcmp(c.listen_host, "::1"));
    ASSERT_INT_EQ(c.port, 7000);
    ASSERT(srv_config_set(&c, "max_clients", "20000", err) == -ERANGE);
    /* the idle hand-over: seconds, decimals allowed, each range checked */
    ASSERT(c.idle_after == 2.0 && c.fade == 0.5);
    ASSERT_OK(srv_config_set(&c, "idle_after", "0.25", err), err);
    ASSERT_OK(srv_config_set(&c, "fade", "0", err), err);
    ASSERT(c.idle_after == 0.25 && c.fade == 0);
    ASSERT(srv_config_set(&c, "idle_after", "0.01", err) == -ERANGE);
    ASSERT(strstr(err, "idle_after: 0.01 outside [0.1, 3600] seconds"));
    ASSERT(srv_config_set(&c, "fade", "-1", err) == -ERANGE);
    ASSERT(srv_config_set(&c, "fade", "nan", err) == -EINVAL);
    ASSERT(srv_config_set(&c, "idle_after", "2s", err) == -EINVAL);
    ASSERT(strstr(err, "idle_after: '2s' is not a number of seconds"));
    ASSERT(c.idle_after == 0.25 && c.fade == 0); /* refused values change nothing */
    ASSERT_OK(srv_config_set(&c, "labels", "LeftToe_End=lfoot", err), err);
    ASSERT(!strcmp(c.labels, "LeftToe_End=lfoot"));
    ASSERT_OK(srv_config_set(&c, "labels", "", err), err); /* clears the map */
    ASSERT(!strcmp(c.labels, ""));
    static char big[5000];
    memset(big, 'x', sizeof big - 1);
    big[1] = '=';
    ASSERT(srv_config_set(&c, "labels", big, err) == -ENAMETOOLONG);
    ASSERT(strstr(err, "labels: longer than 4095 characters"));

    /* srv_config_read: a missing file names it */
    ASSERT(srv_config_read(&c, "/nonexistent/meshsteerd.conf", err) == -ENOENT);
    ASSERT(strstr(err, "/nonexistent/meshsteerd.conf"));
    printf("ok\n");
    return 0;
}
