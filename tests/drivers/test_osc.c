/* test_osc.c - the osc: source (drivers/osc/): OSC packets built by liblo and read by our walker
 * (packet.c), corrupt packets dropped whole, VMC forward kinematics (vmc.c), the source over
 * real UDP on loopback, fed by liblo's lo_send (a C sender) and by liblo's own `oscsend` tool, and
 * OSC captures (capture.c): the committed recordings/example-trot.osc sent datagram by datagram
 * gives the frames of recordings/example-trot.c3d; malformed captures are refused. */
#include "osc/osc.h"
#include "osc/packet.h"
#include "osc/vmc.h"
#include "model.h"
#include "test.h"

#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <lo/lo.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

/* ---- the walker against liblo's serialiser ---- */

typedef struct seen {
    int messages, begins, ends;
    char addr[8][64];
    double num[8][8];
    char str[8][64];
} seen;

static void see_msg(void *user, const drv_osc_msg *m)
{
    seen *s = user;
    int k = s->messages++;
    if (k >= 8)
        return;
    snprintf(s->addr[k], sizeof s->addr[k], "%s", m->address);
    const char *str;
    if (drv_osc_arg_string(m, 0, &str) == 0)
        snprintf(s->str[k], sizeof s->str[k], "%s", str);
    for (int i = 0; i < m->argc && i < 8; i++)
        if (drv_osc_arg_number(m, i, &s->num[k][i]))
            s->num[k][i] = -999;
}

static void see_bundle(void *user, int begin, int depth, uint64_t tt)
{
    (void)depth, (void)tt;
    seen *s = user;
    if (begin)
        s->begins++;
    else
        s->ends++;
}

static uint8_t *marker_msg(const char *name, float x, float y, float z, size_t *len)
{
    lo_message m = lo_message_new();
    lo_message_add_string(m, name);
    lo_message_add_float(m, x);
    lo_message_add_float(m, y);
    lo_message_add_float(m, z);
    uint8_t *b = lo_message_serialise(m, "/marker", NULL, len);
    lo_message_free(m);
    return b;
}

static void test_walk(void)
{
    char err[DRV_ERR_LEN];
    size_t len;
    uint8_t *b = marker_msg("head", 0.5f, 1.75f, -2.0f, &len);
    seen s = {0};
    drv_osc_visitor v = {see_msg, see_bundle, &s};
    ASSERT_OK(drv_osc_packet_walk(b, len, &v, err), err);
    ASSERT_INT_EQ(s.messages, 1);
    ASSERT(!strcmp(s.addr[0], "/marker") && !strcmp(s.str[0], "head"));
    ASSERT_NEAR(s.num[0][1], 0.5, 0);
    ASSERT_NEAR(s.num[0][2], 1.75, 0);
    ASSERT_NEAR(s.num[0][3], -2.0, 0);
    /* every truncation and every trailing extra word is malformed, and nothing is visited */
    for (size_t n = 0; n < len; n++) {
        seen z = {0};
        drv_osc_visitor vz = {see_msg, see_bundle, &z};
        ASSERT(drv_osc_packet_walk(b, n, &vz, err) == -EINVAL);
        ASSERT_INT_EQ(z.messages, 0);
    }
    uint8_t longer[256];
    memcpy(longer, b, len);
    memset(longer + len, 0, 4);
    ASSERT(drv_osc_packet_walk(longer, len + 4, NULL, err) == -EINVAL);
    /* an unknown type tag, a broken pad */
    memcpy(longer, b, len);
    char *tags = memchr(longer, ',', len);
    tags[1] = 'x';
    ASSERT(drv_osc_packet_walk(longer, len, NULL, err) == -EINVAL);
    ASSERT(strstr(err, "unknown type tag 'x'"));
    memcpy(longer, b, len);
    longer[7] = 'A'; /* "/marker" + NUL fills 8 bytes; the address's NUL */
    ASSERT(drv_osc_packet_walk(longer, len, NULL, err) == -EINVAL);

    /* a bundle of two messages in a nested bundle: one begin/end pair each, in order */
    lo_bundle outer = lo_bundle_new(LO_TT_IMMEDIATE), inner = lo_bundle_new(LO_TT_IMMEDIATE);
    lo_message m1 = lo_message_new(), m2 = lo_message_new();
    lo_message_add_string(m1, "lhand");
    lo_message_add_double(m1, 1.0);
    lo_message_add_int32(m1, 2);
    lo_message_add_float(m1, 3.0f);
    lo_message_add_int32(m2, 7);
    lo_bundle_add_message(inner, "/marker", m1);
    lo_bundle_add_message(outer, "/frame", m2);
    lo_bundle_add_bundle(outer, inner);
    size_t blen;
    uint8_t *bb = lo_bundle_serialise(outer, NULL, &blen);
    seen t = {0};
    drv_osc_visitor vt = {see_msg, see_bundle, &t};
    ASSERT_OK(drv_osc_packet_walk(bb, blen, &vt, err), err);
    ASSERT_INT_EQ(t.messages, 2);
    ASSERT_INT_EQ(t.begins, 2);
    ASSERT_INT_EQ(t.ends, 2);
    ASSERT(!strcmp(t.addr[0], "/frame") && !strcmp(t.addr[1], "/marker"));
    ASSERT_NEAR(t.num[1][1], 1.0, 0);
    ASSERT_NEAR(t.num[1][2], 2.0, 0);
    /* every truncation is refused but two, which end at an element boundary: the empty bundle
     * (16 bytes) and the bundle of its first element */
    int whole = 0;
    for (size_t n = 0; n < blen; n++)
        whole += drv_osc_packet_walk(bb, n, NULL, err) == 0;
    ASSERT_INT_EQ(whole, 2);
    /* bundles nested deeper than DRV_OSC_MAX_DEPTH */
    uint8_t deep[16 * 20 + 64];
    size_t at = 0;
    for (int d = 0; d < DRV_OSC_MAX_DEPTH + 1; d++) {
        memcpy(deep + at, "#bundle\0\0\0\0\0\0\0\0\1", 16);
        uint32_t rest = htonl((uint32_t)(16 * (DRV_OSC_MAX_DEPTH - d) + 4 * (DRV_OSC_MAX_DEPTH - d)) + 12);
        at += 16;
        memcpy(deep + at, &rest, 4);
        at += 4;
    }
    memcpy(deep + at, "/f\0\0,\0\0\0", 8);
    at += 8;
    ASSERT(drv_osc_packet_walk(deep, at, NULL, err) == -EINVAL);
    free(b);
    free(bb);
    lo_bundle_free_recursive(outer);
    printf("walk: liblo's messages and bundles read back; truncations and corruptions refused\n");
}

/* ---- VMC forward kinematics ---- */

static void test_vmc(void)
{
    drv_vmc v;
    drv_vmc_init(&v);
    double s2 = sqrt(0.5);
    /* root at (1, 0, 0) turned 90 degrees about +Y (Unity): local +Z becomes world +X */
    ASSERT_OK(drv_vmc_set_root(&v, (double[]){1, 0, 0}, (double[]){0, s2, 0, s2}), "root");
    ASSERT_OK(drv_vmc_set_bone(&v, 0, (double[]){0, 1, 0}, (double[]){0, 0, 0, 1}), "hips");
    ASSERT_OK(drv_vmc_set_bone(&v, 1, (double[]){0, 0, 0.5}, (double[]){0, 0, 0, 1}), "spine");
    ASSERT(drv_vmc_set_bone(&v, 2, (double[]){0, 0, NAN}, (double[]){0, 0, 0, 1}) == -EINVAL);
    ASSERT(drv_vmc_set_bone(&v, 2, (double[]){0, 0, 0}, (double[]){0, 0, 0, 0}) == -EINVAL);
    drv_vmc_solve(&v);
    /* hips: (1, 1, 0); spine: hips + rot(0,0,0.5) = (1.5, 1, 0); Chest (never sent) = spine */
    ASSERT_NEAR(v.wp[0][0], 1, 1e-6);
    ASSERT_NEAR(v.wp[0][1], 1, 1e-6);
    ASSERT_NEAR(v.wp[1][0], 1.5, 1e-6);
    ASSERT_NEAR(v.wp[1][2], 0, 1e-6);
    ASSERT_NEAR(v.wp[2][0], 1.5, 1e-6);
    /* mirrored into our frame: z -> -z; a local +X offset after the turn points to Unity -Z */
    ASSERT_OK(drv_vmc_set_bone(&v, 1, (double[]){0.5, 0, 0}, (double[]){0, 0, 0, 1}), "spine");
    drv_vmc_solve(&v);
    ASSERT_NEAR(v.wp[1][0], 1, 1e-6);
    ASSERT_NEAR(v.wp[1][2], 0.5, 1e-6);
    ASSERT_INT_EQ(drv_vmc_bone_index("LeftHand"), 12);
    ASSERT_INT_EQ(drv_vmc_bone_index("lefthand"), -1);
    ASSERT(!strcmp(drv_vmc_bone_name(DRV_VMC_BODY - 1), "RightToes"));
    printf("vmc: forward kinematics through the root, missing bones as identity, z mirrored\n");
}

/* ---- the source over UDP ---- */

static int read_frame(drv_source *s, float *xyz, uint8_t *valid, int timeout_ms, char *err)
{
    drv_frame f = {.count = s->count, .xyz = xyz, .valid = valid};
    return drv_source_read(s, &f, timeout_ms, err);
}

static int raw_send(int port, const void *buf, size_t len)
{
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ssize_t n = sendto(fd, buf, len, 0, (struct sockaddr *)&a, sizeof a);
    close(fd);
    return n == (ssize_t)len ? 0 : -1;
}

static void test_source_markers(void)
{
    char err[DRV_ERR_LEN] = "";
    drv_source *s;
    ASSERT_OK(drv_source_open("osc:127.0.0.1:0?stale=0", &s, err), err);
    ASSERT_INT_EQ(s->count, 6);
    ASSERT(!strcmp(s->names[0], "head") && !strcmp(s->names[5], "torso"));
    ASSERT_INT_EQ(s->controls, 0);
    int port = drv_osc_port(s);
    ASSERT(port > 0);
    ASSERT_OK(drv_source_start(s, err), err);
    float xyz[18];
    uint8_t valid[6];
    ASSERT_INT_EQ(read_frame(s, xyz, valid, 20, err), DRV_ETIMEOUT);

    /* a C sender: liblo's lo_send_bundle, one bundle per frame */
    char ps[16];
    snprintf(ps, sizeof ps, "%d", port);
    lo_address to = lo_address_new("127.0.0.1", ps);
    for (int frame = 0; frame < 3; frame++) {
        lo_bundle b = lo_bundle_new(LO_TT_IMMEDIATE);
        for (int i = 0; i < 6; i++) {
            lo_message m = lo_message_new();
            lo_message_add_string(m, s->names[i]);
            lo_message_add_float(m, (float)frame);
            lo_message_add_float(m, (float)i);
            lo_message_add_float(m, 0.25f);
            lo_bundle_add_message(b, "/marker", m);
        }
        ASSERT(lo_send_bundle(to, b) > 0);
        lo_bundle_free_recursive(b);
        ASSERT_OK(read_frame(s, xyz, valid, 1000, err), err);
        for (int i = 0; i < 6; i++) {
            ASSERT_INT_EQ(valid[i], 1);
            ASSERT_NEAR_I(xyz[3 * i], frame, 0, i);
            ASSERT_NEAR_I(xyz[3 * i + 1], i, 0, i);
        }
    }
    /* loose messages framed by /frame: one frame, head moved, rhand occluded */
    ASSERT(lo_send(to, "/marker", "sfff", "head", 9.0f, 8.0f, 7.0f) > 0);
    ASSERT(lo_send(to, "/marker", "s", "rhand") > 0);
    ASSERT(lo_send(to, "/frame", "") > 0);
    ASSERT_OK(read_frame(s, xyz, valid, 1000, err), err);
    ASSERT_NEAR(xyz[0], 9, 0);
    ASSERT_INT_EQ(valid[2], 0);
    ASSERT_INT_EQ(valid[1], 1);

    /* garbage: counted, dropped whole, the source keeps going */
    drv_osc_counts c0, c1;
    ASSERT_OK(drv_osc_counts_get(s, &c0), "counts");
    ASSERT(raw_send(port, "garbage!", 8) == 0);
    ASSERT(raw_send(port, "#bundle\0\0\0\0\0\0\0\0\1\0\0\1\0", 20) == 0);
    ASSERT(lo_send(to, "/marker", "sff", "head", 1.0f, 2.0f) > 0);     /* wrong arguments */
    ASSERT(lo_send(to, "/marker", "sfff", "nose", 1.0f, 2.0f, 3.0f) > 0); /* not in the set */
    ASSERT(lo_send(to, "/elsewhere", "i", 1) > 0);
    ASSERT(lo_send(to, "/marker", "sfff", "lhand", 4.0f, 5.0f, 6.0f) > 0);
    ASSERT_OK(read_frame(s, xyz, valid, 1000, err), err); /* framed by the quiet gap */
    ASSERT_NEAR(xyz[3], 4, 0);
    ASSERT_OK(drv_osc_counts_get(s, &c1), "counts");
    ASSERT_INT_EQ(c1.malformed - c0.malformed, 2);
    ASSERT_INT_EQ(c1.bad_messages - c0.bad_messages, 1);
    ASSERT_INT_EQ(c1.unknown_names - c0.unknown_names, 1);
    ASSERT_INT_EQ(c1.ignored - c0.ignored, 1);

    /* liblo's own oscsend, one process per message: each a frame after the quiet gap */
    char cmd[256];
    snprintf(cmd, sizeof cmd, "oscsend 127.0.0.1 %d /marker sfff torso 0.5 1.0 -0.5", port);
    int rc = system(cmd);
    if (rc != 0) {
        fprintf(stderr, "`%s` failed (%d): liblo-tools is in scripts/run.sh's PACKAGES\n", cmd, rc);
        exit(1);
    }
    ASSERT_OK(read_frame(s, xyz, valid, 2000, err), err);
    ASSERT_NEAR(xyz[15], 0.5, 0);
    ASSERT_NEAR(xyz[16], 1.0, 0);
    ASSERT_NEAR(xyz[17], -0.5, 0);
    snprintf(cmd, sizeof cmd, "oscsend 127.0.0.1 %d /marker sddd lfoot 0.125 0 2", port);
    ASSERT_INT_EQ(system(cmd), 0);
    ASSERT_OK(read_frame(s, xyz, valid, 2000, err), err);
    ASSERT_NEAR(xyz[9], 0.125, 0);
    ASSERT_NEAR(xyz[11], 2, 0);
    lo_address_free(to);
    drv_source_close(s);
    printf("source: liblo bundles and loose messages, oscsend, garbage counted (%llu malformed)\n",
           (unsigned long long)c1.malformed);
}

static void test_source_vmc(void)
{
    char err[DRV_ERR_LEN] = "";
    drv_source *s;
    ASSERT_OK(drv_source_open("osc:127.0.0.1:0?vmc=1&stale=0", &s, err), err);
    ASSERT_INT_EQ(s->count, DRV_VMC_BODY);
    ASSERT(!strcmp(s->names[0], "Hips") && !strcmp(s->names[12], "LeftHand"));
    ASSERT_OK(drv_source_start(s, err), err);
    char ps[16];
    snprintf(ps, sizeof ps, "%d", drv_osc_port(s));
    lo_address to = lo_address_new("127.0.0.1", ps);
    lo_bundle b = lo_bundle_new(LO_TT_IMMEDIATE);
    lo_message m = lo_message_new();
    lo_message_add_string(m, "root");
    float root[7] = {0, 0, 2, 0, 0, 0, 1};
    for (int k = 0; k < 7; k++)
        lo_message_add_float(m, root[k]);
    lo_bundle_add_message(b, "/VMC/Ext/Root/Pos", m);
    /* Hips 1 m up, the left arm chain 0.2 m along +X at each bone (Unity local frames) */
    const char *chain[] = {"Hips", "Spine", "Chest", "LeftShoulder", "LeftUpperArm",
                           "LeftLowerArm", "LeftHand", "LeftThumbProximal", "Tail"};
    for (int i = 0; i < 9; i++) {
        lo_message bm = lo_message_new();
        lo_message_add_string(bm, chain[i]);
        lo_message_add_float(bm, i == 0 ? 0.0f : 0.2f);
        lo_message_add_float(bm, i == 0 ? 1.0f : 0.0f);
        lo_message_add_float(bm, 0.0f);
        for (int k = 0; k < 3; k++)
            lo_message_add_float(bm, 0.0f);
        lo_message_add_float(bm, 1.0f);
        lo_bundle_add_message(b, "/VMC/Ext/Bone/Pos", bm);
    }
    lo_message ok = lo_message_new();
    lo_message_add_int32(ok, 1);
    lo_bundle_add_message(b, "/VMC/Ext/OK", ok);
    ASSERT(lo_send_bundle(to, b) > 0);
    lo_bundle_free_recursive(b);
    float xyz[3 * DRV_VMC_BODY];
    uint8_t valid[DRV_VMC_BODY];
    ASSERT_OK(read_frame(s, xyz, valid, 1000, err), err);
    /* Hips (0, 1, -2) in our frame; LeftHand 6 x 0.2 along +X from it (Spine..LeftHand) */
    ASSERT_NEAR(xyz[0], 0, 1e-6);
    ASSERT_NEAR(xyz[1], 1, 1e-6);
    ASSERT_NEAR(xyz[2], -2, 1e-6);
    ASSERT_INT_EQ(valid[12], 1);
    ASSERT_NEAR(xyz[3 * 12], 1.2, 1e-5);
    ASSERT_NEAR(xyz[3 * 12 + 2], -2, 1e-6);
    ASSERT_INT_EQ(valid[5], 0); /* Head: never sent */
    drv_osc_counts c;
    ASSERT_OK(drv_osc_counts_get(s, &c), "counts");
    ASSERT_INT_EQ(c.unknown_names, 1); /* Tail */
    ASSERT_INT_EQ(c.ignored, 1);       /* /VMC/Ext/OK */
    ASSERT_INT_EQ(c.frames, 1);
    lo_address_free(to);
    drv_source_close(s);
    printf("source vmc: a liblo bundle of root + bones is one frame; LeftHand at x=%.3f\n",
           xyz[36]);
}

static void test_specs(void)
{
    char err[DRV_ERR_LEN];
    drv_source *s;
    const char *bad[] = {"osc:", "osc:x", "osc:70000", "osc:::1:9000", "osc:0?vmc=2",
                         "osc:0?markers=", "osc:0?markers=a,a", "osc:0?speed=1", "osc:0?gap",
                         "osc:nosuchhost.invalid:0"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        err[0] = '\0';
        ASSERT(drv_source_open(bad[i], &s, err) < 0);
        ASSERT(s == NULL && err[0]);
    }
    ASSERT_OK(drv_source_open("osc:[::1]:0?markers=a,b,LeftHand&scale=0.001", &s, err), err);
    ASSERT_INT_EQ(s->count, 3);
    ASSERT(drv_source_control(s, DRV_CTL_PAUSE, 1, err) == -ENOTSUP);
    drv_source_close(s);
    printf("specs: %zu bad specs refused with a message\n", sizeof bad / sizeof *bad);
}

/* ---- OSC captures: the committed take, sent to the source, is the committed C3D ---- */

static void test_capture(void)
{
    char err[DRV_ERR_LEN] = "";
    drv_osc_capture *c = NULL;
    mdl_markers *mk = NULL;
    ASSERT_OK(drv_osc_capture_read(test_src("recordings/example-trot.osc"), &c, err), err);
    ASSERT_OK(mdl_markers_read(test_src("recordings/example-trot.c3d"), NULL, &mk, err), err);
    ASSERT_INT_EQ(c->count, mk->frames);
    for (int f = 0; f < c->count; f++) /* 30 frames a second */
        ASSERT_INT_EQ(c->t_us[f], (uint64_t)llround(f * 1e6 / 30));
    /* every datagram is a bundle of one /marker message per marker (the walker counts) */
    seen sn = {0};
    drv_osc_visitor v = {see_msg, see_bundle, &sn};
    ASSERT_OK(drv_osc_packet_walk(c->data + c->off[0], c->len[0], &v, err), err);
    ASSERT_INT_EQ(sn.messages, mk->count);
    ASSERT_INT_EQ(sn.begins, 1);
    ASSERT(!strcmp(sn.addr[0], "/marker") && !strcmp(sn.str[0], mk->names[0]));

    char spec[2048] = "osc:127.0.0.1:0?stale=0&markers=";
    for (int m = 0; m < mk->count; m++)
        snprintf(spec + strlen(spec), sizeof spec - strlen(spec), "%s%s", m ? "," : "", mk->names[m]);
    drv_source *s;
    ASSERT_OK(drv_source_open(spec, &s, err), err);
    ASSERT_INT_EQ(s->count, mk->count);
    ASSERT_OK(drv_source_start(s, err), err);
    int port = drv_osc_port(s);
    float xyz[3 * 64];
    uint8_t valid[64];
    ASSERT(mk->count <= 64);
    double worst = 0;
    for (int f = 0; f < c->count; f++) { /* the test sender: each datagram as it is, one by one */
        ASSERT(raw_send(port, c->data + c->off[f], c->len[f]) == 0);
        ASSERT_OK(read_frame(s, xyz, valid, 1000, err), err);
        for (int m = 0; m < mk->count; m++) {
            size_t i = (size_t)f * mk->count + m;
            ASSERT_INT_EQ(valid[m], mk->valid[i]);
            for (int k = 0; k < 3; k++)
                worst = fmax(worst, fabs(xyz[3 * m + k] - mk->P[3 * i + k]));
        }
    }
    drv_osc_counts n;
    ASSERT_OK(drv_osc_counts_get(s, &n), "counts");
    drv_source_close(s);
    /* the C3D keeps float millimetres: within a float32 step of a 2 m coordinate in mm */
    ASSERT_NEAR(worst, 0, 1e-6);
    ASSERT_INT_EQ(n.frames, c->count);
    ASSERT_INT_EQ(n.malformed, 0);
    ASSERT_INT_EQ(n.messages, (uint64_t)c->count * mk->count);

    /* malformed captures: the reason and the byte */
    size_t len = 16 + 12 + c->len[0];
    uint8_t *b = malloc(len + 8);
    ASSERT(b);
    memcpy(b, "MSOSCCAP\1\0\0\0\1\0\0\0", 16);
    memset(b + 16, 0, 8);
    b[24] = (uint8_t)c->len[0], b[25] = (uint8_t)(c->len[0] >> 8), b[26] = b[27] = 0;
    memcpy(b + 28, c->data + c->off[0], c->len[0]);
    drv_osc_capture *one = NULL;
    ASSERT_OK(drv_osc_capture_parse(b, len, "one.osc", &one, err), err);
    ASSERT_INT_EQ(one->count, 1);
    drv_osc_capture_destroy(one);
    ASSERT_INT_EQ(drv_osc_capture_parse(b, len - 4, "cut.osc", &one, err), MDL_EFORMAT);
    ASSERT(strstr(err, "cut.osc: byte 16") && strstr(err, "ends inside"));
    b[28] = 'x'; /* "#bundle" -> "xbundle": not OSC */
    ASSERT_INT_EQ(drv_osc_capture_parse(b, len, "bad.osc", &one, err), MDL_EFORMAT);
    ASSERT(strstr(err, "bad.osc: byte 28: datagram 0 is not OSC"));
    b[28] = '#';
    memset(b + len, 0, 8);
    ASSERT_INT_EQ(drv_osc_capture_parse(b, len + 8, "tail.osc", &one, err), MDL_EFORMAT);
    ASSERT(strstr(err, "8 bytes after the last datagram"));
    b[12] = 200; /* 200 datagrams cannot fit */
    ASSERT_INT_EQ(drv_osc_capture_parse(b, len, "count.osc", &one, err), MDL_EFORMAT);
    ASSERT(strstr(err, "byte 12"));
    b[8] = 2;
    ASSERT_INT_EQ(drv_osc_capture_parse(b, len, "v2.osc", &one, err), MDL_EFORMAT);
    ASSERT(strstr(err, "version 2"));
    ASSERT(drv_osc_capture_read("/nonexistent.osc", &one, err) == -ENOENT && !one);
    free(b);
    printf("capture: %d datagrams of recordings/example-trot.osc are the C3D's frames (worst "
           "%.2g m); malformed captures refused\n", c->count, worst);
    mdl_markers_destroy(mk);
    drv_osc_capture_destroy(c);
}

int main(void)
{
    test_walk();
    test_vmc();
    test_specs();
    test_source_markers();
    test_source_vmc();
    test_capture();
    return 0;
}
