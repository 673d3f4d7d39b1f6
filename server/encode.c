/* encode.c - hello, topology and frame messages of protocol 1, and the generation that owns them
 * (see encode.h and docs/PROTOCOL.md). */
#include "srv_err.h"
#include "encode.h"
#include "encode_params.h"
#include "control.h"
#include "daemon_config.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <libwebsockets.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const enc_names[SRV_ENC_COUNT] = {"float32", "int16", "params"};

int srv_encoding_parse(const char *name)
{
    for (int i = 0; i < SRV_ENC_COUNT; i++)
        if (!strcmp(name, enc_names[i]))
            return i;
    return -1;
}

const char *srv_encoding_name(int enc)
{
    return enc >= 0 && enc < SRV_ENC_COUNT ? enc_names[enc] : "?";
}

static size_t pad4(size_t n)
{
    return (n + 3) & ~(size_t)3;
}

size_t srv_frame_size(int enc, int nv, int nm)
{
    size_t vb = enc == SRV_ENC_INT16 ? (size_t)nv * 3 * 2 : (size_t)nv * 3 * 4;
    return SRV_FRAME_HEADER + pad4(vb) + (size_t)nm * 12 + pad4((size_t)nm);
}

size_t srv_frame_params_size(int nparams, int nm)
{
    return SRV_FRAME_HEADER + srv_params_block_size(nparams) + (size_t)nm * 12 + pad4((size_t)nm);
}

size_t srv_topology_size(int nv, int nf)
{
    return SRV_TOPO_HEADER + (size_t)nv * 12 + (size_t)nf * 12 + (size_t)nv * 4;
}

static void put_f32(unsigned char *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    srv_put_u32(p, u);
}

/* Adds a string from outside (a file's marker label, a path) as valid UTF-8 text: the hello is a
 * text frame, and a label in Latin-1 would fail every client's connection. */
static void add_text(cJSON *o, const char *key, const char *s)
{
    size_t n = strlen(s);
    char *t = srv__utf8_valid(s, n) ? NULL : malloc(n + 1);
    if (t)
        srv__utf8_copy(t, n + 1, s);
    cJSON_AddStringToObject(o, key, t ? t : s);
    free(t);
}

static char *build_hello(const mdl_model_info *info, const srv_gen *g, const srv_source_desc *src)
{
    cJSON *h = cJSON_CreateObject();
    if (!h)
        return NULL;
    cJSON_AddStringToObject(h, "type", "hello");
    cJSON_AddNumberToObject(h, "protocol", SRV_PROTOCOL);
    cJSON_AddStringToObject(h, "server", "meshsteerd " MESHSTEER_VERSION);
    cJSON_AddNumberToObject(h, "generation", g->id);
    cJSON *m = cJSON_AddObjectToObject(h, "model");
    add_text(m, "name", g->name);
    cJSON_AddStringToObject(m, "kind", mdl_kind_name(info->kind) ? mdl_kind_name(info->kind) : "");
    cJSON *kinds = cJSON_AddArrayToObject(m, "kinds");
    for (int i = 0; i < info->nkinds; i++)
        cJSON_AddItemToArray(kinds, cJSON_CreateString(mdl_kind_name(info->kinds[i]) ? mdl_kind_name(info->kinds[i]) : ""));
    cJSON_AddBoolToObject(m, "idle", src && src->idle);
    cJSON_AddNumberToObject(m, "vertices", g->nv);
    cJSON_AddNumberToObject(m, "faces", g->nf);
    cJSON_AddNumberToObject(m, "parts", g->nparts);
    char topo[20];
    snprintf(topo, sizeof topo, "%016llx", (unsigned long long)g->topology);
    cJSON_AddStringToObject(m, "topology", topo);
    cJSON_AddNumberToObject(m, "fps", info->fps);
    float bmin[3] = {info->bbox_min[0], info->bbox_min[1], info->bbox_min[2]};
    float bmax[3] = {info->bbox_max[0], info->bbox_max[1], info->bbox_max[2]};
    cJSON_AddItemToObject(m, "bbox_min", cJSON_CreateFloatArray(bmin, 3));
    cJSON_AddItemToObject(m, "bbox_max", cJSON_CreateFloatArray(bmax, 3));
    cJSON_AddItemToObject(m, "quant_min", cJSON_CreateFloatArray(g->qmin, 3));
    cJSON_AddItemToObject(m, "quant_max", cJSON_CreateFloatArray(g->qmax, 3));
    cJSON *pk = cJSON_AddArrayToObject(m, "params");
    for (int l = 0; l < g->nlayouts; l++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "kind", mdl_kind_name(g->layout_kind[l]) ? mdl_kind_name(g->layout_kind[l]) : "");
        cJSON_AddNumberToObject(o, "floats", g->layout_nparams[l]);
        cJSON_AddNumberToObject(o, "bytes", (double)srv_frame_params_size(g->layout_nparams[l], g->nm));
        cJSON_AddItemToArray(pk, o);
    }
    cJSON *mk = cJSON_AddArrayToObject(h, "markers");
    for (int i = 0; i < g->nm; i++) {
        cJSON *o = cJSON_CreateObject();
        add_text(o, "name", info->markers[i].name);
        const char *own = info->markers[i].source[0] ? info->markers[i].source : info->markers[i].name;
        add_text(o, "source", own);
        add_text(o, "live", src && src->lookup && src->lookup[i] ? src->lookup[i] : own);
        cJSON_AddBoolToObject(o, "bound", src && src->bound && src->bound[i]);
        cJSON_AddItemToArray(mk, o);
    }
    cJSON *s = cJSON_AddObjectToObject(h, "source");
    add_text(s, "spec", src && src->spec ? src->spec : "");
    cJSON_AddStringToObject(s, "scheme", src && src->scheme ? src->scheme : "");
    cJSON_AddNumberToObject(s, "fps", src ? src->fps : 0);
    cJSON_AddNumberToObject(s, "markers", src ? src->count : 0);
    cJSON_AddNumberToObject(s, "frames", src ? src->frames : 0);
    cJSON *ctl = cJSON_AddArrayToObject(s, "controls");
    for (int i = 0; src && i < SRV_SOURCE_CONTROLS; i++)
        if (src->controls & SRV_CTL_BIT(srv_source_controls[i]))
            cJSON_AddItemToArray(ctl, cJSON_CreateString(srv_control_name(srv_source_controls[i])));
    cJSON *e = cJSON_AddArrayToObject(h, "encodings");
    for (int i = 0; i < SRV_ENC_COUNT; i++)
        cJSON_AddItemToArray(e, cJSON_CreateString(enc_names[i]));
    char *txt = cJSON_PrintUnformatted(h);
    cJSON_Delete(h);
    return txt;
}

int srv_gen_create(const mdl_model_info *info, const srv_source_desc *src, uint32_t id,
                   srv_gen **out, char *err)
{
    return srv_gen_create_params(info, src, id, NULL, 0, out, err);
}

int srv_gen_create_params(const mdl_model_info *info, const srv_source_desc *src, uint32_t id,
                          const mdl_params_layout *layouts, int nlayouts, srv_gen **out,
                          char *err)
{
    *out = NULL;
    if (nlayouts < 0 || nlayouts > SRV_PARAMS_MAX_LAYOUTS)
        return srv_err(err, -EINVAL, "%d params layouts (at most %d)", nlayouts,
                       SRV_PARAMS_MAX_LAYOUTS);
    for (int l = 0; l < nlayouts; l++) {
        int r = srv_params_layout_check(&layouts[l], info->nv, err);
        if (r)
            return r;
    }
    if (info->nv <= 0 || info->nf < 0 || info->nmarkers < 0 || !info->rest ||
        (info->nf > 0 && !info->F))
        return srv_err(err, -EINVAL, "model has no mesh");
    if (info->nv > (1 << 24) || info->nf > (1 << 25) || info->nmarkers > 65535)
        return srv_err(err, -EFBIG, "model too large to stream (%d vertices, %d faces)", info->nv,
                       info->nf);
    srv_gen *g = calloc(1, sizeof *g);
    if (!g)
        return srv_err(err, -ENOMEM, "out of memory");
    atomic_init(&g->refs, 1);
    g->id = id;
    g->nv = info->nv;
    g->nf = info->nf;
    g->nm = info->nmarkers;
    g->topology = info->topology;
    g->nlayouts = nlayouts;
    for (int l = 0; l < nlayouts; l++) {
        g->layout_kind[l] = layouts[l].kind;
        g->layout_nparams[l] = layouts[l].nparams;
    }
    snprintf(g->name, sizeof g->name, "%s", info->name ? info->name : "");
    snprintf(g->kind, sizeof g->kind, "%s", mdl_kind_name(info->kind) ? mdl_kind_name(info->kind) : "");
    /* the parts: ids must lie in [0, nparts) */
    g->nparts = info->part ? (info->nclusters > 0 ? info->nclusters : 1) : 1;
    if (info->part)
        for (int i = 0; i < g->nv; i++)
            if (info->part[i] < 0 || info->part[i] >= g->nparts) {
                int np = g->nparts;
                free(g);
                return srv_err(err, -EINVAL, "vertex %d: part %d outside [0, %d)", i,
                               info->part[i], np);
            }
    /* the quantisation box */
    float lo[3], hi[3], ext = 0;
    for (int a = 0; a < 3; a++) {
        lo[a] = info->bbox_min[a];
        hi[a] = info->bbox_max[a];
        if (!(isfinite(lo[a]) && isfinite(hi[a]) && hi[a] >= lo[a])) { /* fall back to the rest pose */
            lo[a] = hi[a] = info->rest[a];
            for (int i = 0; i < g->nv; i++) {
                float x = info->rest[(size_t)i * 3 + (size_t)a];
                lo[a] = x < lo[a] ? x : lo[a];
                hi[a] = x > hi[a] ? x : hi[a];
            }
        }
        ext = hi[a] - lo[a] > ext ? hi[a] - lo[a] : ext;
    }
    if (!(ext > 0))
        ext = 1;
    for (int a = 0; a < 3; a++) {
        g->qmin[a] = lo[a] - SRV_QBOX_MARGIN * ext;
        g->qmax[a] = hi[a] + SRV_QBOX_MARGIN * ext;
    }

    size_t fsz[SRV_ENC_COUNT], total = 0;
    size_t tsz = srv_topology_size(g->nv, g->nf);
    for (int e = 0; e < SRV_ENC_PARAMS; e++) {
        fsz[e] = srv_frame_size(e, g->nv, g->nm);
        total += SRV_POOL * (LWS_PRE + fsz[e]);
    }
    size_t psz = 0, msz = srv_params_model_size(layouts, nlayouts, g->nv);
    for (int l = 0; l < nlayouts; l++)
        if (srv_frame_params_size(g->layout_nparams[l], g->nm) > psz)
            psz = srv_frame_params_size(g->layout_nparams[l], g->nm);
    fsz[SRV_ENC_PARAMS] = psz;
    total += SRV_POOL * (LWS_PRE + psz) + LWS_PRE + msz;
    total += LWS_PRE + tsz;
    g->storage = malloc(total);
    char *hello = g->storage ? build_hello(info, g, src) : NULL;
    if (!hello) {
        free(g->storage);
        free(g);
        return srv_err(err, -ENOMEM, "out of memory for %zu bytes of frame buffers", total);
    }
    size_t hl = strlen(hello);
    g->hello = malloc(LWS_PRE + hl + 1);
    if (!g->hello) {
        cJSON_free(hello);
        free(g->storage);
        free(g);
        return srv_err(err, -ENOMEM, "out of memory");
    }
    memcpy(g->hello + LWS_PRE, hello, hl + 1);
    cJSON_free(hello);
    g->hello += LWS_PRE;
    g->hello_len = hl;

    unsigned char *p = g->storage;
    for (int k = 0; k < SRV_POOL; k++) {
        srv_frame *f = &g->frames[k];
        atomic_init(&f->refs, 0);
        f->gen = g;
        for (int e = 0; e < SRV_ENC_COUNT; e++) {
            f->msg[e] = p + LWS_PRE;
            if (fsz[e] == 0) { /* no params form in this generation */
                f->len[e] = 0;
                continue;
            }
            f->len[e] = fsz[e];
            memset(f->msg[e], 0, fsz[e]);
            memcpy(f->msg[e], SRV_FRAME_MAGIC, 4);
            f->msg[e][SRV_FRAME_OFF_ENCODING] = (unsigned char)e;
            srv_put_u32(f->msg[e] + SRV_FRAME_OFF_GENERATION, id);
            srv_put_u32(f->msg[e] + SRV_FRAME_OFF_NV, (uint32_t)g->nv);
            srv_put_u32(f->msg[e] + SRV_FRAME_OFF_NM, (uint32_t)g->nm);
            p += LWS_PRE + fsz[e];
        }
        f->len[SRV_ENC_PARAMS] = 0; /* no params form until srv_frame_encode_params */
    }
    /* the params model message */
    g->params = p + LWS_PRE;
    g->params_len = msz;
    srv_params_model_write(g->params, layouts, nlayouts, g->nv, id);
    p += LWS_PRE + msz;
    /* the topology message */
    g->topo = p + LWS_PRE;
    g->topo_len = tsz;
    unsigned char *t = g->topo;
    memset(t, 0, SRV_TOPO_HEADER);
    memcpy(t, SRV_TOPO_MAGIC, 4);
    srv_put_u16(t + 4, SRV_PROTOCOL);
    srv_put_u32(t + 8, id);
    srv_put_u32(t + 12, (uint32_t)g->nv);
    srv_put_u32(t + 16, (uint32_t)g->nf);
    srv_put_u32(t + 20, (uint32_t)g->nm);
    srv_put_u32(t + 24, (uint32_t)g->nparts);
    for (int a = 0; a < 3; a++) {
        put_f32(t + 32 + 4 * a, g->qmin[a]);
        put_f32(t + 44 + 4 * a, g->qmax[a]);
    }
    t += SRV_TOPO_HEADER;
    for (size_t i = 0; i < (size_t)g->nv * 3; i++, t += 4)
        put_f32(t, info->rest[i]);
    for (size_t i = 0; i < (size_t)g->nf * 3; i++, t += 4)
        srv_put_u32(t, info->F[i]);
    for (int i = 0; i < g->nv; i++, t += 4)
        srv_put_u32(t, info->part ? (uint32_t)info->part[i] : 0);
    *out = g;
    return 0;
}

void srv_gen_ref(srv_gen *g)
{
    atomic_fetch_add(&g->refs, 1);
}

void srv_gen_unref(srv_gen *g)
{
    if (!g || atomic_fetch_sub(&g->refs, 1) != 1)
        return;
    free(g->hello ? g->hello - LWS_PRE : NULL);
    free(g->storage);
    free(g);
}

srv_frame *srv_gen_free_frame(srv_gen *g)
{
    for (int k = 0; k < SRV_POOL; k++)
        if (atomic_load(&g->frames[k].refs) == 0)
            return &g->frames[k];
    return NULL;
}

void srv_frame_ref(srv_frame *f)
{
    srv_gen_ref(f->gen);
    atomic_fetch_add(&f->refs, 1);
}

void srv_frame_unref(srv_frame *f)
{
    if (!f)
        return;
    srv_gen *g = f->gen;
    atomic_fetch_sub(&f->refs, 1);
    srv_gen_unref(g);
}

static void put_header(unsigned char *m, uint64_t seq, uint64_t tc, uint64_t ts, int flags,
                       int missing)
{
    m[SRV_FRAME_OFF_FLAGS] = (unsigned char)flags;
    srv_put_u16(m + SRV_FRAME_OFF_MISSING, (uint16_t)(missing > 65535 ? 65535 : missing));
    srv_put_u32(m + SRV_FRAME_OFF_SKIPPED, 0);
    srv_put_u64(m + SRV_FRAME_OFF_SEQ, seq);
    srv_put_u64(m + SRV_FRAME_OFF_CAPTURE, tc);
    srv_put_u64(m + SRV_FRAME_OFF_SYNTH, ts);
    srv_put_u64(m + SRV_FRAME_OFF_SEND, 0);
}

static void put_markers(unsigned char *p, int nm, const float *markers, const uint8_t *valid)
{
    for (int i = 0; i < nm; i++) {
        int ok = valid ? valid[i] != 0 : 1;
        for (int a = 0; a < 3; a++, p += 4)
            put_f32(p, ok ? markers[(size_t)i * 3 + (size_t)a] : 0.0f);
    }
    for (int i = 0; i < nm; i++)
        p[i] = valid ? (valid[i] != 0) : 1;
    for (size_t i = (size_t)nm; i < pad4((size_t)nm); i++)
        p[i] = 0;
}

void srv_frame_encode(srv_frame *f, uint64_t seq, uint64_t t_capture_us, uint64_t t_synth_us,
                      const float *V, const float *markers, const uint8_t *valid, int flags,
                      int missing)
{
    const srv_gen *g = f->gen;
    size_t n3 = (size_t)g->nv * 3;
    f->seq = seq;
    f->t_capture_us = t_capture_us;

    unsigned char *m = f->msg[SRV_ENC_FLOAT32];
    put_header(m, seq, t_capture_us, t_synth_us, flags, missing);
    unsigned char *p = m + SRV_FRAME_HEADER;
    for (size_t i = 0; i < n3; i++, p += 4)
        put_f32(p, V[i]);
    put_markers(p, g->nm, markers, valid);

    m = f->msg[SRV_ENC_INT16];
    p = m + SRV_FRAME_HEADER;
    float scale[3];
    for (int a = 0; a < 3; a++)
        scale[a] = 65535.0f / (g->qmax[a] - g->qmin[a]);
    int clamped = 0;
    for (size_t i = 0; i < n3; i++, p += 2) {
        int a = (int)(i % 3);
        float u = (V[i] - g->qmin[a]) * scale[a];
        long q;
        if (!(u >= 0.0f)) { /* also NaN */
            q = 0;
            clamped = 1;
        } else if (u > 65535.0f) {
            q = 65535;
            clamped = 1;
        } else {
            q = lrintf(u);
        }
        srv_put_u16(p, (uint16_t)(q - 32768)); /* two's complement int16 */
    }
    if (n3 & 1) { /* pad the vertex block to 4 bytes */
        p[0] = p[1] = 0;
        p += 2;
    }
    put_header(m, seq, t_capture_us, t_synth_us, flags | (clamped ? SRV_FLAG_CLAMPED : 0), missing);
    put_markers(p, g->nm, markers, valid);
    f->len[SRV_ENC_PARAMS] = 0;
}

void srv_frame_encode_params(srv_frame *f, int layout, const float *prm)
{
    const srv_gen *g = f->gen;
    if (layout < 0 || layout >= g->nlayouts)
        return;
    int n = g->layout_nparams[layout];
    const unsigned char *src = f->msg[SRV_ENC_FLOAT32];
    unsigned char *m = f->msg[SRV_ENC_PARAMS];
    memcpy(m, src, SRV_FRAME_HEADER); /* the same header, but for the encoding */
    m[SRV_FRAME_OFF_ENCODING] = SRV_ENC_PARAMS;
    srv_params_block_write(m + SRV_FRAME_HEADER, layout, prm, n);
    size_t mk = (size_t)g->nm * 12 + pad4((size_t)g->nm); /* the marker block, as is */
    memcpy(m + SRV_FRAME_HEADER + srv_params_block_size(n),
           src + SRV_FRAME_HEADER + (size_t)g->nv * 12, mk);
    f->len[SRV_ENC_PARAMS] = srv_frame_params_size(n, g->nm);
}
