/* encode_params.c - the params model message (MSPM) and the parameter block of params frames
 * (encode_params.h; docs/PROTOCOL.md 2b and 3). The formula they carry is model.h's
 * mdl_params_layout: paper 2012 Sec. 4.4 eq. (6) (mean + modes per part) placed rigidly and blended
 * with the weights of Sec. 5.3 eq. (8); for the skin, linear blend skinning (Le & Deng 2012). */
#include "srv_err.h"
#include "encode.h"
#include "encode_params.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static void put_f32(unsigned char *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    srv_put_u32(p, u);
}

static size_t pad4(size_t n)
{
    return (n + 3) & ~(size_t)3;
}

/* sum_p k_p and sum_p n_p k_p */
static void mode_counts(const mdl_params_layout *L, size_t *nmodes, size_t *nvals)
{
    *nmodes = *nvals = 0;
    for (int p = 0; p < L->nparts; p++) {
        *nmodes += (size_t)L->nmodes[p];
        *nvals += (size_t)L->nmodes[p] * (size_t)(L->part_off[p + 1] - L->part_off[p]);
    }
}

int srv_params_layout_check(const mdl_params_layout *L, int nv, char *err)
{
    if (L->ninst <= 0 || L->nparts <= 0 || L->slots <= 0 || L->slots > 255 ||
        L->ninst > 65535 || L->nparts > 65535)
        return srv_err(err, -EINVAL, "params layout: %d pieces, %d shapes, %d slots", L->ninst,
                       L->nparts, L->slots);
    int nent = L->part_off[L->nparts], np = 0;
    for (int p = 0; p < L->nparts; p++)
        if (L->part_off[p + 1] < L->part_off[p] || L->nmodes[p] < 0 || L->nmodes[p] > 4096)
            return srv_err(err, -EINVAL, "params layout: shape %d has bad entries or modes", p);
    for (int i = 0; i < L->ninst; i++) {
        if (L->inst_part[i] < 0 || L->inst_part[i] >= L->nparts)
            return srv_err(err, -EINVAL, "params layout: piece %d has shape %d", i, L->inst_part[i]);
        np += 7 + L->nmodes[L->inst_part[i]];
    }
    if (np != L->nparams)
        return srv_err(err, -EINVAL, "params layout: %d floats per frame, expected %d", L->nparams,
                       np);
    for (size_t k = 0; k < (size_t)nv * L->slots; k++) {
        if (L->slot_w[k] == 0)
            continue;
        int i = L->slot_inst[k], e = L->slot_entry[k];
        if (i < 0 || i >= L->ninst || e < L->part_off[L->inst_part[i]] ||
            e >= L->part_off[L->inst_part[i] + 1] || e >= nent || !isfinite(L->slot_w[k]))
            return srv_err(err, -EINVAL, "params layout: vertex %zu slot %zu: piece %d entry %d",
                           k / (size_t)L->slots, k % (size_t)L->slots, i, e);
    }
    return 0;
}

/* the slots in use (weight != 0): only those go on the wire */
static size_t used_slots(const mdl_params_layout *L, int nv)
{
    size_t n = 0;
    for (size_t k = 0; k < (size_t)nv * L->slots; k++)
        n += L->slot_w[k] != 0;
    return n;
}

static size_t layout_size(const mdl_params_layout *L, int nv)
{
    size_t nmodes, nvals, nent = (size_t)L->part_off[L->nparts], nused = used_slots(L, nv);
    mode_counts(L, &nmodes, &nvals);
    return SRV_PARAMS_LAYOUT_HEADER + 16 * (size_t)L->nparts + 4 * (size_t)L->ninst + 4 * nmodes +
           12 * nent + pad4(6 * nvals) + pad4((size_t)nv) + 8 * nused + pad4(2 * nused);
}

size_t srv_params_model_size(const mdl_params_layout *L, int nlayouts, int nv)
{
    size_t n = SRV_PARAMS_HEADER;
    for (int l = 0; l < nlayouts; l++)
        n += layout_size(&L[l], nv);
    return n;
}

static unsigned char *write_layout(unsigned char *p, const mdl_params_layout *L, int nv)
{
    size_t nmodes, nvals, nent = (size_t)L->part_off[L->nparts], len = layout_size(L, nv);
    size_t nused = used_slots(L, nv);
    mode_counts(L, &nmodes, &nvals);
    memset(p, 0, SRV_PARAMS_LAYOUT_HEADER);
    p[0] = (unsigned char)L->kind;
    srv_put_u16(p + 2, (uint16_t)L->slots);
    srv_put_u32(p + 4, (uint32_t)L->ninst);
    srv_put_u32(p + 8, (uint32_t)L->nparts);
    srv_put_u32(p + 12, (uint32_t)nent);
    srv_put_u32(p + 16, (uint32_t)nmodes);
    srv_put_u32(p + 20, (uint32_t)nvals);
    srv_put_u32(p + 24, (uint32_t)L->nparams);
    srv_put_u32(p + 28, (uint32_t)len);
    srv_put_u32(p + 32, (uint32_t)nused);
    p += SRV_PARAMS_LAYOUT_HEADER;
    uint32_t mfirst = 0;
    for (int q = 0; q < L->nparts; q++, p += 16) { /* shapes: entries, modes, first mode */
        srv_put_u32(p, (uint32_t)L->part_off[q]);
        srv_put_u32(p + 4, (uint32_t)(L->part_off[q + 1] - L->part_off[q]));
        srv_put_u32(p + 8, (uint32_t)L->nmodes[q]);
        srv_put_u32(p + 12, mfirst);
        mfirst += (uint32_t)L->nmodes[q];
    }
    for (int i = 0; i < L->ninst; i++, p += 4)
        srv_put_u32(p, (uint32_t)L->inst_part[i]);
    /* per mode its scale, then the means, then the modes as int16 of that scale */
    unsigned char *scales = p;
    for (int q = 0; q < L->nparts; q++) {
        size_t n3 = 3 * (size_t)(L->part_off[q + 1] - L->part_off[q]);
        for (int a = 0; a < L->nmodes[q]; a++, p += 4) {
            const float *v = L->modes + L->mode_off[q] + (size_t)a * n3;
            float big = 0;
            for (size_t c = 0; c < n3; c++)
                big = fabsf(v[c]) > big ? fabsf(v[c]) : big;
            put_f32(p, big > 0 ? big / 32767.0f : 1.0f);
        }
    }
    for (size_t c = 0; c < 3 * nent; c++, p += 4)
        put_f32(p, L->mean[c]);
    unsigned char *q16 = p;
    for (int q = 0, m = 0; q < L->nparts; q++) {
        size_t n3 = 3 * (size_t)(L->part_off[q + 1] - L->part_off[q]);
        for (int a = 0; a < L->nmodes[q]; a++, m++) {
            uint32_t su = srv_get_u32(scales + 4 * (size_t)m);
            float scale;
            memcpy(&scale, &su, 4);
            const float *v = L->modes + L->mode_off[q] + (size_t)a * n3;
            for (size_t c = 0; c < n3; c++, p += 2)
                srv_put_u16(p, (uint16_t)(int16_t)lrintf(v[c] / scale));
        }
    }
    for (; (size_t)(p - q16) < pad4(6 * nvals); p++)
        *p = 0;
    /* the blend slots in use: a count per vertex, then (entry, weight) and the piece of each */
    unsigned char *cnt = p;
    for (int v = 0; v < nv; v++) {
        int c = 0;
        for (int s = 0; s < L->slots; s++)
            c += L->slot_w[(size_t)v * L->slots + s] != 0;
        *p++ = (unsigned char)c;
    }
    for (; (size_t)(p - cnt) < pad4((size_t)nv); p++)
        *p = 0;
    unsigned char *pieces = p + 8 * nused;
    for (size_t k = 0; k < (size_t)nv * L->slots; k++) {
        if (L->slot_w[k] == 0)
            continue;
        srv_put_u32(p, (uint32_t)L->slot_entry[k]);
        put_f32(p + 4, L->slot_w[k]);
        srv_put_u16(pieces, (uint16_t)L->slot_inst[k]);
        p += 8;
        pieces += 2;
    }
    p = pieces;
    for (size_t k = nused; k < pad4(2 * nused) / 2; k++, p += 2)
        srv_put_u16(p, 0);
    return p;
}

void srv_params_model_write(unsigned char *p, const mdl_params_layout *L, int nlayouts, int nv,
                            uint32_t generation)
{
    memcpy(p, SRV_PARAMS_MAGIC, 4);
    srv_put_u16(p + 4, SRV_PROTOCOL);
    srv_put_u16(p + 6, (uint16_t)nlayouts);
    srv_put_u32(p + 8, generation);
    srv_put_u32(p + 12, (uint32_t)nv);
    p += SRV_PARAMS_HEADER;
    for (int l = 0; l < nlayouts; l++)
        p = write_layout(p, &L[l], nv);
}

size_t srv_params_block_size(int nparams)
{
    return 8 + 4 * (size_t)nparams;
}

void srv_params_block_write(unsigned char *p, int layout, const float *prm, int nparams)
{
    p[0] = (unsigned char)layout;
    p[1] = p[2] = p[3] = 0;
    srv_put_u32(p + 4, (uint32_t)nparams);
    p += 8;
    for (int i = 0; i < nparams; i++, p += 4)
        put_f32(p, prm[i]);
}
