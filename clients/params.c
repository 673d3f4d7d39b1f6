/* params.c - the params model message and params frames, client side (params.h; docs/PROTOCOL.md
 * 2b, 3). The formula is the one the daemon's synthesis evaluates (model.h, mdl_params_layout:
 * paper 2012 Sec. 4.4 eq. 6 and Sec. 5.3 eq. 8, or linear blend skinning), in float. */
#include "params.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* the float of 4 little-endian bytes (a union: no memcpy call in an unoptimised build) */
static float f32(const unsigned char *p)
{
    union {
        uint32_t u;
        float f;
    } b = {.u = u32(p)};
    return b.f;
}

static int16_t i16(const unsigned char *p)
{
    return (int16_t)(uint16_t)(p[0] | p[1] << 8);
}

static int fail(char *err, size_t n, const char *fmt, ...)
{
    if (err && n) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, n, fmt, ap);
        va_end(ap);
    }
    return -1;
}

void ws_params_free(ws_params *p)
{
    if (!p)
        return;
    for (int l = 0; l < WS_PARAMS_MAX_LAYOUTS; l++) {
        free(p->layout[l].mode_at);
        free(p->layout[l].param_at);
        free(p->layout[l].slot_at);
        free(p->layout[l].shape_of);
        free(p->layout[l].shape_info);
        free(p->layout[l].scale_v);
        free(p->layout[l].mean_v);
        free(p->layout[l].modes_v);
        free(p->layout[l].slot_entry);
        free(p->layout[l].slot_weight);
        free(p->layout[l].slot_piece);
        free(p->layout[l].frame);
    }
    free(p->msg);
    memset(p, 0, sizeof *p);
}

/* The checked tables of L as native arrays (ws_params_layout). */
static int unpack_layout(ws_params_layout *L, uint32_t nvals, char *err, size_t n)
{
    L->shape_of = malloc(sizeof *L->shape_of * (size_t)L->ninst);
    L->shape_info = malloc(sizeof *L->shape_info * 4 * (size_t)L->nparts);
    L->scale_v = malloc(sizeof *L->scale_v * ((size_t)L->nmodes + 1));
    L->mean_v = malloc(sizeof *L->mean_v * (3 * (size_t)L->nentries + 1));
    L->modes_v = malloc(sizeof *L->modes_v * (3 * (size_t)nvals + 1));
    L->slot_entry = malloc(sizeof *L->slot_entry * ((size_t)L->nused + 1));
    L->slot_weight = malloc(sizeof *L->slot_weight * ((size_t)L->nused + 1));
    L->slot_piece = malloc(sizeof *L->slot_piece * ((size_t)L->nused + 1));
    L->frame = malloc(sizeof *L->frame * ((size_t)L->nparams + 1));
    if (!L->shape_of || !L->shape_info || !L->scale_v || !L->mean_v || !L->modes_v ||
        !L->slot_entry || !L->slot_weight || !L->slot_piece || !L->frame)
        return fail(err, n, "out of memory");
    for (int i = 0; i < L->ninst; i++)
        L->shape_of[i] = u32(L->inst + 4 * (size_t)i);
    for (size_t i = 0; i < 4 * (size_t)L->nparts; i++)
        L->shape_info[i] = u32(L->part + 4 * i);
    for (int i = 0; i < L->nmodes; i++)
        L->scale_v[i] = f32(L->scale + 4 * (size_t)i);
    for (size_t i = 0; i < 3 * (size_t)L->nentries; i++)
        L->mean_v[i] = f32(L->mean + 4 * i);
    for (size_t i = 0; i < 3 * (size_t)nvals; i++)
        L->modes_v[i] = i16(L->modes + 2 * i);
    for (int k = 0; k < L->nused; k++) {
        L->slot_entry[k] = u32(L->slot + 8 * (size_t)k);
        L->slot_weight[k] = f32(L->slot + 8 * (size_t)k + 4);
        L->slot_piece[k] = (uint16_t)(L->piece[2 * k] | L->piece[2 * k + 1] << 8);
    }
    return 0;
}

/* One layout at m[0 .. len); *used gets its length. */
static int parse_layout(const unsigned char *m, size_t len, int nv, ws_params_layout *L,
                        size_t *used, char *err, size_t n)
{
    if (len < 36)
        return fail(err, n, "layout header: %zu bytes left, need 36", len);
    L->kind = m[0];
    L->slots = m[2] | m[3] << 8;
    uint32_t ninst = u32(m + 4), nparts = u32(m + 8), nent = u32(m + 12), nmodes = u32(m + 16);
    uint32_t nvals = u32(m + 20), nparams = u32(m + 24), blen = u32(m + 28), nused = u32(m + 32);
    if (blen < 36 || blen > len)
        return fail(err, n, "layout length %u: %zu bytes left", blen, len);
    if (!ninst || ninst > 65535 || !nparts || nparts > 65535 || !L->slots || L->slots > 255 ||
        nent > (1u << 26) || nmodes > (1u << 20) || nvals > (1u << 28) || nparams > (1u << 24) ||
        (uint64_t)nused > (uint64_t)nv * (uint64_t)L->slots)
        return fail(err, n, "layout: implausible counts (%u pieces, %u shapes, %u entries, %u "
                    "slots)", ninst, nparts, nent, nused);
    uint64_t need = 36 + 16ull * nparts + 4ull * ninst + 4ull * nmodes + 12ull * nent +
                    ((6ull * nvals + 3) & ~3ull) + (((uint64_t)nv + 3) & ~3ull) + 8ull * nused +
                    ((2ull * nused + 3) & ~3ull);
    if (need != blen)
        return fail(err, n, "layout length %u, its counts need %llu", blen,
                    (unsigned long long)need);
    L->ninst = (int)ninst;
    L->nparts = (int)nparts;
    L->nentries = (int)nent;
    L->nmodes = (int)nmodes;
    L->nparams = (int)nparams;
    L->nused = (int)nused;
    L->part = m + 36;
    L->inst = L->part + 16 * (size_t)nparts;
    L->scale = L->inst + 4 * (size_t)ninst;
    L->mean = L->scale + 4 * (size_t)nmodes;
    L->modes = L->mean + 12 * (size_t)nent;
    L->count = L->modes + ((6 * (size_t)nvals + 3) & ~(size_t)3);
    L->slot = L->count + (((size_t)nv + 3) & ~(size_t)3);
    L->piece = L->slot + 8 * (size_t)nused;
    L->mode_at = calloc(nparts, sizeof *L->mode_at);
    L->param_at = calloc(ninst, sizeof *L->param_at);
    L->slot_at = calloc((size_t)nv + 1, sizeof *L->slot_at);
    if (!L->mode_at || !L->param_at || !L->slot_at)
        return fail(err, n, "out of memory");
    uint64_t vals = 0, modes = 0;
    for (uint32_t p = 0; p < nparts; p++) {
        const unsigned char *q = L->part + 16 * (size_t)p;
        uint32_t first = u32(q), cnt = u32(q + 4), k = u32(q + 8), mf = u32(q + 12);
        if ((uint64_t)first + cnt > nent || mf != modes || modes + k > nmodes)
            return fail(err, n, "shape %u: entries %u+%u of %u, modes %u+%u of %u", p, first, cnt,
                        nent, mf, k, nmodes);
        L->mode_at[p] = (uint32_t)(3 * vals);
        vals += (uint64_t)cnt * k;
        modes += k;
        if (vals > nvals)
            return fail(err, n, "shape %u: more mode values than the %u announced", p, nvals);
    }
    if (vals != nvals || modes != nmodes)
        return fail(err, n, "shapes hold %llu mode values and %llu modes, announced %u and %u",
                    (unsigned long long)vals, (unsigned long long)modes, nvals, nmodes);
    uint64_t at = 0;
    for (uint32_t i = 0; i < ninst; i++) {
        uint32_t p = u32(L->inst + 4 * (size_t)i);
        if (p >= nparts)
            return fail(err, n, "piece %u: shape %u of %u", i, p, nparts);
        L->param_at[i] = (uint32_t)at;
        at += 7 + u32(L->part + 16 * (size_t)p + 8);
    }
    if (at != nparams)
        return fail(err, n, "pieces need %llu floats per frame, announced %u",
                    (unsigned long long)at, nparams);
    uint32_t k = 0;
    for (int v = 0; v < nv; v++) {
        if (L->count[v] > L->slots || k + L->count[v] > nused)
            return fail(err, n, "vertex %d: %u slots (at most %d, %u in all)", v, L->count[v],
                        L->slots, nused);
        L->slot_at[v] = k;
        for (int s = 0; s < L->count[v]; s++, k++) {
            uint32_t e = u32(L->slot + 8 * (size_t)k), i = L->piece[2 * k] | L->piece[2 * k + 1] << 8;
            uint32_t p = i < ninst ? u32(L->inst + 4 * (size_t)i) : 0;
            const unsigned char *q = L->part + 16 * (size_t)p;
            if (i >= ninst || e < u32(q) || e - u32(q) >= u32(q + 4))
                return fail(err, n, "vertex %d slot %d: piece %u, entry %u outside its shape", v,
                            s, i, e);
        }
    }
    L->slot_at[nv] = k;
    if (k != nused)
        return fail(err, n, "vertices hold %u slots, announced %u", k, nused);
    return unpack_layout(L, nvals, err, n) ? -1 : (*used = blen, 0);
}

int ws_params_parse(const unsigned char *buf, size_t len, ws_params *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (len < 16 || memcmp(buf, "MSPM", 4))
        return fail(err, errlen, "not a params model message (%zu bytes)", len);
    int proto = buf[4] | buf[5] << 8, nl = buf[6] | buf[7] << 8;
    if (proto != 1)
        return fail(err, errlen, "params model: protocol %d", proto);
    if (nl > WS_PARAMS_MAX_LAYOUTS)
        return fail(err, errlen, "params model: %d layouts (at most %d)", nl, WS_PARAMS_MAX_LAYOUTS);
    out->generation = u32(buf + 8);
    uint32_t nv = u32(buf + 12);
    if (nv == 0 || nv > (1u << 24))
        return fail(err, errlen, "params model: %u vertices", nv);
    out->nv = (int)nv;
    out->msg = malloc(len);
    if (!out->msg)
        return fail(err, errlen, "out of memory");
    memcpy(out->msg, buf, len);
    size_t at = 16;
    for (int l = 0; l < nl; l++) {
        size_t used = 0;
        if (parse_layout(out->msg + at, len - at, out->nv, &out->layout[l], &used, err, errlen)) {
            ws_params_free(out);
            return -1;
        }
        out->nlayouts = l + 1;
        at += used;
    }
    if (at != len) {
        ws_params_free(out);
        return fail(err, errlen, "params model: %zu bytes after the layouts", len - at);
    }
    return 0;
}

int ws_params_decode(const ws_params *p, const unsigned char *block, size_t len, float *V,
                     char *err, size_t errlen)
{
    if (len < 8)
        return fail(err, errlen, "params frame: %zu bytes", len);
    int l = block[0];
    if (l >= p->nlayouts)
        return fail(err, errlen, "params frame: layout %d of %d", l, p->nlayouts);
    const ws_params_layout *L = &p->layout[l];
    uint32_t np = u32(block + 4);
    if (np != (uint32_t)L->nparams || len < 8 + 4 * (size_t)np)
        return fail(err, errlen, "params frame: %u floats, the layout has %d (%zu bytes)", np,
                    L->nparams, len);
    float *prm = L->frame;
    for (uint32_t i = 0; i < np; i++)
        prm[i] = f32(block + 8 + 4 * (size_t)i);
    for (int v = 0; v < p->nv; v++) {
        float x[3] = {0, 0, 0};
        for (uint32_t k = L->slot_at[v]; k < L->slot_at[v + 1]; k++) {
            uint32_t e = L->slot_entry[k], i = L->slot_piece[k], sh = L->shape_of[i];
            const uint32_t *q = L->shape_info + 4 * (size_t)sh;
            uint32_t first = q[0], cnt = q[1], nk = q[2], mf = q[3];
            const float *pi = prm + L->param_at[i];
            float y[3];
            for (int c = 0; c < 3; c++)
                y[c] = L->mean_v[3 * (size_t)e + c];
            for (uint32_t a = 0; a < nk; a++) {
                float lam = pi[7 + a] * L->scale_v[mf + a];
                const int16_t *mv = L->modes_v + L->mode_at[sh] + 3 * ((size_t)a * cnt + (e - first));
                for (int c = 0; c < 3; c++)
                    y[c] += lam * (float)mv[c];
            }
            float qw = pi[0], qx = pi[1], qy = pi[2], qz = pi[3];
            float R[9] = {1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy),
                          2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx),
                          2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy)};
            float w = L->slot_weight[k];
            for (int r = 0; r < 3; r++)
                x[r] += w * (R[3 * r] * y[0] + R[3 * r + 1] * y[1] + R[3 * r + 2] * y[2] + pi[4 + r]);
        }
        memcpy(V + 3 * (size_t)v, x, sizeof x);
    }
    return 0;
}
