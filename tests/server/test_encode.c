/* test_encode.c - the binary messages of protocol 1 decoded exactly as docs/PROTOCOL.md says:
 * topology offsets, float32 frames bit-exact, int16 frames within the stated bound, clamping,
 * padding for odd vertex counts, markers and validity, and the frame pool's reference counts. */
#include "control.h"
#include "encode.h"
#include "test.h"

#include <errno.h>
#include <stdint.h>
#include <string.h>

static float get_f32(const unsigned char *p)
{
    uint32_t u = srv_get_u32(p);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

/* A decoder written from the document: returns the vertex positions of a frame message. */
static void decode_frame(const unsigned char *m, size_t len, const float qmin[3], const float qmax[3],
                         float *V, float *mk, uint8_t *valid, int *enc)
{
    ASSERT(len >= 56);
    ASSERT(!memcmp(m, "MSFR", 4));
    *enc = m[4];
    int nv = (int)srv_get_u32(m + 12), nm = (int)srv_get_u32(m + 16);
    const unsigned char *p = m + 56;
    if (*enc == 0) {
        for (int i = 0; i < nv * 3; i++, p += 4)
            V[i] = get_f32(p);
    } else {
        for (int i = 0; i < nv * 3; i++, p += 2) {
            int a = i % 3;
            int16_t q = (int16_t)srv_get_u16(p);
            V[i] = qmin[a] + (float)(q + 32768) * (qmax[a] - qmin[a]) / 65535.0f;
        }
        if ((nv * 3) % 2)
            p += 2;
    }
    for (int i = 0; i < nm * 3; i++, p += 4)
        mk[i] = get_f32(p);
    for (int i = 0; i < nm; i++)
        valid[i] = p[i];
    p += (nm + 3) / 4 * 4;
    ASSERT_INT_EQ(p - m, (long long)len);
}

int main(void)
{
    /* a small mesh: 5 vertices (odd, to exercise the int16 padding), 2 triangles, 3 parts */
    float rest[15] = {0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 1, 2, 3};
    uint32_t F[6] = {0, 1, 2, 2, 3, 4};
    int part[5] = {0, 0, 1, 2, 2};
    mdl_rig_marker markers[3] = {{"a", "A", 0}, {"b", "", 1}, {"c", "C", 4}};
    mdl_model_info info = {.name = "tiny", .nv = 5, .nf = 2, .rest = rest, .F = F,
                           .topology = 0x1234abcdULL, .nmarkers = 3, .markers = markers,
                           .nclusters = 3, .part = part, .fps = 30,
                           .bbox_min = {0, 0, 0}, .bbox_max = {1, 2, 3}};
    const uint8_t bound[3] = {1, 0, 1}; /* a -> source 2, b unbound, c -> source 0 */
    const char *names[3] = {"C", "X", "A"};
    const char *lookup[3] = {"A", "cam_b", "C"}; /* b looks up cam_b, which the source lacks */
    srv_source_desc src = {"replay:x.csv", "replay", 60, 240, 3, names,
                           SRV_CTL_BIT(SRV_CTL_PAUSE) | SRV_CTL_BIT(SRV_CTL_RESUME) |
                               SRV_CTL_BIT(SRV_CTL_SPEED),
                           lookup, bound, 0};
    char err[512];
    srv_gen *g = NULL;
    ASSERT_OK(srv_gen_create(&info, &src, 7, &g, err), err);

    /* hello: JSON text with the documented fields */
    ASSERT(strstr((char *)g->hello, "\"type\":\"hello\""));
    ASSERT(strstr((char *)g->hello, "\"protocol\":1"));
    ASSERT(strstr((char *)g->hello, "\"generation\":7"));
    ASSERT(strstr((char *)g->hello, "\"topology\":\"000000001234abcd\""));
    ASSERT(strstr((char *)g->hello, "{\"name\":\"b\",\"source\":\"b\",\"live\":\"cam_b\",\"bound\":false}"));
    ASSERT(strstr((char *)g->hello, "{\"name\":\"a\",\"source\":\"A\",\"live\":\"A\",\"bound\":true}"));
    /* exactly the controls the source takes, in the documented order */
    ASSERT(strstr((char *)g->hello, "\"controls\":[\"pause\",\"resume\",\"speed\"]"));
    ASSERT(strstr((char *)g->hello, "\"frames\":240"));
    ASSERT_INT_EQ(strlen((char *)g->hello), g->hello_len);
    {
        /* a file's label that is not UTF-8 (Latin-1 "Kn\xe9") reaches the hello, a text frame,
         * as valid UTF-8 ("Kn?") */
        srv_source_desc latin = {"replay:\xe9.c3d", "replay", 60, 0, 3, names, 0, NULL, bound, 0};
        mdl_rig_marker m2[3] = {{"Kn\xe9", "", 0}, {"b", "", 1}, {"c", "C", 4}};
        mdl_model_info i2 = info;
        i2.markers = m2;
        srv_gen *g3 = NULL;
        ASSERT_OK(srv_gen_create(&i2, &latin, 9, &g3, err), err);
        ASSERT(srv__utf8_valid((char *)g3->hello, g3->hello_len));
        ASSERT(strstr((char *)g3->hello, "\"name\":\"Kn?\""));
        ASSERT(strstr((char *)g3->hello, "\"spec\":\"replay:?.c3d\""));
        srv_gen_unref(g3);
    }
    {
        /* no label map (live = the marker's own label) and a source without controls */
        srv_source_desc plain = {"openni2:", "openni2", 30, 0, 3, names, 0, NULL, bound, 0};
        srv_gen *g2 = NULL;
        ASSERT_OK(srv_gen_create(&info, &plain, 8, &g2, err), err);
        ASSERT(strstr((char *)g2->hello, "{\"name\":\"b\",\"source\":\"b\",\"live\":\"b\",\"bound\":false}"));
        ASSERT(strstr((char *)g2->hello, "{\"name\":\"c\",\"source\":\"C\",\"live\":\"C\",\"bound\":true}"));
        ASSERT(strstr((char *)g2->hello, "\"controls\":[]"));
        srv_gen_unref(g2);
    }

    /* the quantisation box: bbox grown by half the largest extent (3) on every side */
    for (int a = 0; a < 3; a++) {
        ASSERT_NEAR_I(g->qmin[a], info.bbox_min[a] - 1.5f, 1e-6, a);
        ASSERT_NEAR_I(g->qmax[a], info.bbox_max[a] + 1.5f, 1e-6, a);
    }

    /* topology */
    const unsigned char *t = g->topo;
    ASSERT_INT_EQ(g->topo_len, 56 + 5 * 12 + 2 * 12 + 5 * 4);
    ASSERT(!memcmp(t, "MSTO", 4));
    ASSERT_INT_EQ(srv_get_u16(t + 4), 1);
    ASSERT_INT_EQ(srv_get_u32(t + 8), 7);
    ASSERT_INT_EQ(srv_get_u32(t + 12), 5);
    ASSERT_INT_EQ(srv_get_u32(t + 16), 2);
    ASSERT_INT_EQ(srv_get_u32(t + 20), 3);
    ASSERT_INT_EQ(srv_get_u32(t + 24), 3);
    for (int a = 0; a < 3; a++) {
        ASSERT_NEAR_I(get_f32(t + 32 + 4 * a), g->qmin[a], 0, a);
        ASSERT_NEAR_I(get_f32(t + 44 + 4 * a), g->qmax[a], 0, a);
    }
    for (int i = 0; i < 15; i++)
        ASSERT_NEAR_I(get_f32(t + 56 + 4 * i), rest[i], 0, i);
    for (int i = 0; i < 6; i++)
        ASSERT_INT_EQ(srv_get_u32(t + 56 + 60 + 4 * i), F[i]);
    for (int i = 0; i < 5; i++)
        ASSERT_INT_EQ(srv_get_u32(t + 56 + 60 + 24 + 4 * i), part[i]);

    /* a frame: vertices spread over the box, markers with one invalid */
    float V[15], mk[9] = {0.1f, 0.2f, 0.3f, 9, 9, 9, 0.7f, 0.8f, 0.9f};
    uint8_t valid[3] = {1, 0, 1};
    uint32_t s = 12345;
    for (int i = 0; i < 15; i++) {
        s = s * 1103515245u + 12345u;
        int a = i % 3;
        V[i] = g->qmin[a] + (g->qmax[a] - g->qmin[a]) * (float)(s >> 8) / (float)(1u << 24);
    }
    srv_frame *f = srv_gen_free_frame(g);
    ASSERT(f);
    srv_frame_encode(f, 42, 1000, 1500, V, mk, valid, SRV_FLAG_HELD, 1);
    /* the vertex encodings; a generation without a compact form has no params message
     * (test_encode_params covers it) */
    ASSERT_INT_EQ(f->len[SRV_ENC_PARAMS], 0);
    for (int e = 0; e < SRV_ENC_PARAMS; e++) {
        const unsigned char *m = f->msg[e];
        ASSERT_INT_EQ(f->len[e], srv_frame_size(e, 5, 3));
        ASSERT_INT_EQ(m[5] & SRV_FLAG_HELD, SRV_FLAG_HELD);
        ASSERT_INT_EQ(m[5] & SRV_FLAG_CLAMPED, 0);
        ASSERT_INT_EQ(srv_get_u16(m + 6), 1);
        ASSERT_INT_EQ(srv_get_u32(m + 8), 7);
        ASSERT_INT_EQ(srv_get_u64(m + 24), 42);
        ASSERT_INT_EQ(srv_get_u64(m + 32), 1000);
        ASSERT_INT_EQ(srv_get_u64(m + 40), 1500);
        float D[15], dm[9];
        uint8_t dv[3];
        int enc;
        decode_frame(m, f->len[e], g->qmin, g->qmax, D, dm, dv, &enc);
        ASSERT_INT_EQ(enc, e);
        for (int i = 0; i < 15; i++) {
            int a = i % 3;
            double bound = e == 0 ? 0 : (g->qmax[a] - g->qmin[a]) / 131070.0 * 1.0001 + 1e-6;
            ASSERT_NEAR_I(D[i], V[i], bound, i);
        }
        ASSERT_NEAR(dm[0], 0.1f, 0);
        ASSERT_NEAR(dm[3], 0, 0); /* invalid markers are sent as zeros */
        ASSERT_NEAR(dm[8], 0.9f, 0);
        ASSERT_INT_EQ(dv[0], 1);
        ASSERT_INT_EQ(dv[1], 0);
        ASSERT_INT_EQ(dv[2], 1);
    }
    /* the int16 bound is tight: some vertex comes within half a step of it */
    /* outside the box: clamped and flagged */
    V[0] = g->qmax[0] + 10;
    V[4] = g->qmin[1] - 10;
    srv_frame_encode(f, 43, 1, 2, V, mk, NULL, 0, 0);
    ASSERT_INT_EQ(f->msg[SRV_ENC_INT16][5] & SRV_FLAG_CLAMPED, SRV_FLAG_CLAMPED);
    ASSERT_INT_EQ(f->msg[SRV_ENC_FLOAT32][5] & SRV_FLAG_CLAMPED, 0);
    ASSERT_INT_EQ((int16_t)srv_get_u16(f->msg[SRV_ENC_INT16] + 56), 32767);
    ASSERT_INT_EQ((int16_t)srv_get_u16(f->msg[SRV_ENC_INT16] + 56 + 8), -32768);

    /* the pool: referenced frames are not handed out again; a frame keeps its generation */
    srv_frame *held[SRV_POOL];
    for (int k = 0; k < SRV_POOL; k++) {
        held[k] = srv_gen_free_frame(g);
        ASSERT(held[k]);
        srv_frame_ref(held[k]);
    }
    ASSERT(srv_gen_free_frame(g) == NULL);
    ASSERT_INT_EQ(atomic_load(&g->refs), 1 + SRV_POOL);
    srv_gen_unref(g); /* the creator's reference; the frames still hold it */
    for (int k = 0; k < SRV_POOL; k++)
        srv_frame_unref(held[k]); /* the last one frees the generation (ASan checks) */

    /* invalid input is refused */
    int badpart[5] = {0, 0, 1, 3, 0};
    info.part = badpart;
    ASSERT(srv_gen_create(&info, &src, 8, &g, err) == -EINVAL);
    ASSERT(strstr(err, "vertex 3"));
    info.nv = 0;
    ASSERT(srv_gen_create(&info, &src, 8, &g, err) < 0);

    ASSERT_INT_EQ(srv_encoding_parse("int16"), SRV_ENC_INT16);
    ASSERT_INT_EQ(srv_encoding_parse("params"), SRV_ENC_PARAMS);
    ASSERT_INT_EQ(srv_encoding_parse("float64"), -1);
    printf("ok\n");
    return 0;
}
