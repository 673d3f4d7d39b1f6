/* test_encode_params.c - the params encoding (server/encode_params.c, encode.c; the client side
 * clients/params.c) against docs/PROTOCOL.md 2b and 3: a hand-made layout with a shared shape,
 * modes and two blend slots per vertex goes out as MSPM and a params frame; the client rebuilds
 * the vertices of the formula within the quantisation bound the header states; the frame's
 * header and markers equal the float32 frame's; bad layouts are refused by the server and bad
 * messages by the client (truncated, indices out of range, the wrong layout or float count).
 * With an argument, writes the MSPM message there (the fuzz target's seed). */
#include "encode.h"
#include "encode_params.h"
#include "params.h"
#include "test.h"
#include "quat.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define NV 5
#define NP 2
#define NI 3

/* the formula of model.h (mdl_params_layout), in double from the unquantised layout */
static void formula(const mdl_params_layout *L, const float *prm, double *V)
{
    int at[NI];
    for (int i = 0, o = 0; i < L->ninst; i++) {
        at[i] = o;
        o += 7 + L->nmodes[L->inst_part[i]];
    }
    for (int v = 0; v < NV; v++) {
        double x[3] = {0, 0, 0};
        for (int s = 0; s < L->slots; s++) {
            int k = v * L->slots + s;
            if (L->slot_w[k] == 0)
                continue;
            int i = L->slot_inst[k], e = L->slot_entry[k], p = L->inst_part[i];
            int n = L->part_off[p + 1] - L->part_off[p], j = e - L->part_off[p];
            const float *q = prm + at[i];
            double y[3];
            for (int c = 0; c < 3; c++) {
                y[c] = L->mean[3 * e + c];
                for (int a = 0; a < L->nmodes[p]; a++)
                    y[c] += q[7 + a] * L->modes[L->mode_off[p] + (a * n + j) * 3 + c];
            }
            double R[9];
            test_quat_matrix(q, R);
            for (int r = 0; r < 3; r++)
                x[r] += L->slot_w[k] * (R[3 * r] * y[0] + R[3 * r + 1] * y[1] + R[3 * r + 2] * y[2] + q[4 + r]);
        }
        memcpy(V + 3 * v, x, sizeof x);
    }
}

int main(int argc, char **argv)
{
    float rest[3 * NV] = {0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 1, 2, 3};
    uint32_t F[6] = {0, 1, 2, 2, 3, 4};
    mdl_rig_marker markers[2] = {{"a", "A", 0}, {"b", "B", 4}};
    mdl_model_info info = {.name = "tiny", .kind = MDL_KIND_STEER, .nv = NV, .nf = 2, .rest = rest,
                           .F = F, .nmarkers = 2, .markers = markers, .fps = 30,
                           .bbox_min = {0, 0, 0}, .bbox_max = {1, 2, 3}};
    /* shape 0: 3 entries, 2 modes; shape 1: 3 entries, none. Pieces 0 and 2 share shape 0 (a
     * shared cluster in two limbs, Sec. 5.3). */
    int part_off[NP + 1] = {0, 3, 6}, nmodes[NP] = {2, 0}, mode_off[NP] = {0, 18};
    float mean[18] = {0.1f, 0.2f, 0.3f, -0.4f, 0.5f, 0.0f, 0.7f, -0.8f, 0.9f,
                      1.0f, 1.1f, -1.2f, 0.3f, 0.3f, 0.3f, -0.5f, 0.25f, 0.125f};
    float modes[18];
    for (int c = 0; c < 18; c++)
        modes[c] = 0.01f * sinf(1.7f * (float)c + 0.3f);
    int inst_part[NI] = {0, 1, 0};
    int slot_entry[NV * 2] = {0, 3, 1, -1, 2, 5, 4, 0, 5, -1};
    int slot_inst[NV * 2] = {0, 1, 0, -1, 2, 1, 1, 2, 1, -1};
    float slot_w[NV * 2] = {0.25f, 0.75f, 1, 0, 0.5f, 0.5f, 0.9f, 0.1f, 1, 0};
    mdl_params_layout L = {.kind = MDL_KIND_STEER, .ninst = NI, .nparts = NP, .part_off = part_off,
                           .mean = mean, .nmodes = nmodes, .mode_off = mode_off, .modes = modes,
                           .inst_part = inst_part, .slots = 2, .slot_entry = slot_entry,
                           .slot_inst = slot_inst, .slot_w = slot_w, .nparams = 7 * NI + 2 + 2};
    char err[512] = "";
    srv_gen *g = NULL;
    ASSERT_OK(srv_gen_create_params(&info, NULL, 9, &L, 1, &g, err), err);
    ASSERT(strstr((char *)g->hello, "\"encodings\":[\"float32\",\"int16\",\"params\"]"));
    ASSERT(strstr((char *)g->hello, "\"params\":[{\"kind\":\"steer\",\"floats\":25,"));
    ASSERT_INT_EQ(g->params_len, srv_params_model_size(&L, 1, NV));
    if (argc > 1) {
        FILE *f = fopen(argv[1], "wb");
        ASSERT(f && fwrite(g->params, 1, g->params_len, f) == g->params_len && fclose(f) == 0);
    }

    /* the client reads it back */
    ws_params P;
    ASSERT_OK(ws_params_parse(g->params, g->params_len, &P, err, sizeof err), err);
    ASSERT_INT_EQ(P.generation, 9);
    ASSERT_INT_EQ(P.nlayouts, 1);
    ASSERT_INT_EQ(P.layout[0].kind, MDL_KIND_STEER);
    ASSERT_INT_EQ(P.layout[0].nparams, 25);

    /* a frame: rotations about different axes, translations, mode coefficients */
    float prm[25];
    int o = 0;
    for (int i = 0; i < NI; i++) {
        float th = 0.4f + 0.9f * (float)i, ax[3] = {i == 0, i == 1, i == 2};
        prm[o++] = cosf(th / 2);
        for (int c = 0; c < 3; c++)
            prm[o++] = sinf(th / 2) * ax[c];
        for (int c = 0; c < 3; c++)
            prm[o++] = 0.5f * (float)(i + 1) - 0.3f * (float)c;
        for (int a = 0; a < nmodes[inst_part[i]]; a++)
            prm[o++] = (a ? -2.5f : 1.75f) * (float)(i + 1);
    }
    ASSERT_INT_EQ(o, 25);
    double want[3 * NV];
    formula(&L, prm, want);
    float V[3 * NV], mk[6] = {1, 2, 3, 4, 5, 6};
    uint8_t valid[2] = {1, 0};
    for (int c = 0; c < 3 * NV; c++)
        V[c] = (float)want[c];
    srv_frame *f = srv_gen_free_frame(g);
    ASSERT(f);
    srv_frame_encode(f, 42, 1000, 2000, V, mk, valid, SRV_FLAG_HELD, 1);
    ASSERT_INT_EQ(f->len[SRV_ENC_PARAMS], 0); /* no params form until it is given */
    srv_frame_encode_params(f, 0, prm);
    const unsigned char *m = f->msg[SRV_ENC_PARAMS], *m0 = f->msg[SRV_ENC_FLOAT32];
    ASSERT_INT_EQ(f->len[SRV_ENC_PARAMS], srv_frame_params_size(25, 2));
    ASSERT_INT_EQ(f->len[SRV_ENC_PARAMS], 56 + 8 + 100 + 24 + 4);
    ASSERT_INT_EQ(m[4], 2);
    ASSERT(!memcmp(m + 5, m0 + 5, 51)); /* the header but for the encoding */
    ASSERT(!memcmp(m + 56 + 108, m0 + 56 + 12 * NV, 28)); /* the markers and validity */
    ASSERT_INT_EQ(m[56], 0);
    ASSERT_INT_EQ(srv_get_u32(m + 60), 25);

    float got[3 * NV];
    ASSERT_OK(ws_params_decode(&P, m + 56, f->len[SRV_ENC_PARAMS] - 56, got, err, sizeof err), err);
    /* the bound of encode_params.h: sum_a |lambda_a| scale_a / 2 sqrt(3), plus float rounding */
    double big = 0;
    for (int c = 0; c < 18; c++)
        big = fabs(modes[c]) > big ? fabs(modes[c]) : big;
    double scale = big / 32767, worst = 0;
    for (int v = 0; v < NV; v++)
        for (int c = 0; c < 3; c++) {
            double tol = 2 * (2.5 * 3 + 1.75 * 3) * scale / 2 * sqrt(3.0) + 1e-5;
            double d = fabs(got[3 * v + c] - want[3 * v + c]);
            worst = d > worst ? d : worst;
            ASSERT_NEAR_I(got[3 * v + c], want[3 * v + c], tol, 3 * v + c);
        }
    printf("params: %zu-byte model message, %zu-byte frame (float32 %zu), worst error %.3g m\n",
           g->params_len, f->len[SRV_ENC_PARAMS], f->len[SRV_ENC_FLOAT32], worst);
    /* the check can fail: another coefficient moves the vertices */
    unsigned char bad[256];
    size_t flen = f->len[SRV_ENC_PARAMS] - 56;
    memcpy(bad, m + 56, flen);
    bad[8 + 4 * 7 + 2] ^= 0x40; /* piece 0's first coefficient, a bit of its exponent */
    ASSERT_OK(ws_params_decode(&P, bad, flen, got, err, sizeof err), err);
    double moved = 0;
    for (int c = 0; c < 3 * NV; c++)
        moved = fmax(moved, fabs(got[c] - want[c]));
    ASSERT_GT(moved, 1e-4);
    /* the wrong layout, the wrong float count, too short */
    memcpy(bad, m + 56, flen);
    bad[0] = 1;
    ASSERT_INT_EQ(ws_params_decode(&P, bad, flen, got, err, sizeof err), -1);
    printf("refused: %s\n", err);
    memcpy(bad, m + 56, flen);
    bad[4] = 24;
    ASSERT_INT_EQ(ws_params_decode(&P, bad, flen, got, err, sizeof err), -1);
    ASSERT_INT_EQ(ws_params_decode(&P, m + 56, 60, got, err, sizeof err), -1);

    /* a truncated message, and one whose slot points outside its piece's shape */
    for (size_t n = 0; n < g->params_len; n++) {
        ws_params T;
        ASSERT_INT_EQ_I(ws_params_parse(g->params, n, &T, err, sizeof err), -1, (int)n);
    }
    unsigned char *copy = malloc(g->params_len);
    ASSERT(copy);
    memcpy(copy, g->params, g->params_len);
    /* the message ends with 8 slots in use: 8 x (entry, weight), then 8 pieces (16 bytes) */
    size_t slots_at = g->params_len - 16 - 8 * 8;
    ASSERT_INT_EQ(srv_get_u32(copy + slots_at), 0); /* vertex 0 slot 0: entry 0 ... */
    srv_put_u32(copy + slots_at, 4); /* ... now 4, outside piece 0's shape 0 (entries 0-2) */
    ws_params T;
    ASSERT_INT_EQ(ws_params_parse(copy, g->params_len, &T, err, sizeof err), -1);
    printf("refused: %s\n", err);
    ASSERT(strstr(err, "vertex 0 slot 0"));
    free(copy);
    ws_params_free(&P);
    srv_gen_unref(g);

    /* the server refuses a layout that does not hold together */
    slot_entry[0] = 4;
    ASSERT_INT_EQ(srv_gen_create_params(&info, NULL, 9, &L, 1, &g, err), -EINVAL);
    printf("refused: %s\n", err);
    slot_entry[0] = 0;
    L.nparams = 24;
    ASSERT_INT_EQ(srv_gen_create_params(&info, NULL, 9, &L, 1, &g, err), -EINVAL);
    L.nparams = 25;
    /* without a layout the generation still says so: an MSPM with no layouts */
    ASSERT_OK(srv_gen_create_params(&info, NULL, 9, NULL, 0, &g, err), err);
    ASSERT_OK(ws_params_parse(g->params, g->params_len, &P, err, sizeof err), err);
    ASSERT_INT_EQ(P.nlayouts, 0);
    f = srv_gen_free_frame(g);
    srv_frame_encode(f, 1, 1, 1, V, mk, valid, 0, 0);
    srv_frame_encode_params(f, 0, prm); /* no such layout: nothing */
    ASSERT_INT_EQ(f->len[SRV_ENC_PARAMS], 0);
    ws_params_free(&P);
    srv_gen_unref(g);
    printf("ok\n");
    return 0;
}
