/* modelfile.c - the versioned binary model file, and read-only views of a model.
 *
 * Layout (little-endian, docs/FORMATS.md): "MSTRMODL", u32 version, u32 reserved, then the fields
 * of struct mdl_model in a fixed order; every array is preceded by its u32 element count. Loading
 * recomputes every count from dimensions read before it and refuses any mismatch, checks every
 * index against what it indexes, every offset table for monotonicity, every float for finiteness,
 * and the face list against the stored topology fingerprint: a corrupt or hostile file gives a
 * clear error, never an out-of-bounds access (tests/fuzz/fuzz_model.c).
 */
#include "steer/posefeat.h"
#include "steer/steer_internal.h"
#include "core/util.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_COUNT (1u << 28)

void mdl__model_free(struct mdl_model *m)
{
    if (!m)
        return;
    free(m->rest);
    free(m->F);
    free(m->train_frames);
    free(m->markers);
    free(m->limb_off);
    free(m->limb_idx);
    free(m->part);
    free(m->part_rms);
    free(m->pv_off);
    free(m->pv_idx);
    free(m->pmodes);
    free(m->pm_off);
    free(m->part_mean);
    free(m->part_modes);
    free(m->part_sigma2);
    free(m->ps_off);
    free(m->part_explained);
    free(m->inst_part);
    free(m->inst_limb);
    free(m->inst_out);
    free(m->inst_shared);
    free(m->lpath_off);
    free(m->lpath);
    free(m->lctrl);
    if (m->reg)
        for (int l = 0; l < m->nlimbs; l++) {
            free(m->reg[l].feat_scale);
            free(m->reg[l].feat_shift);
            free(m->reg[l].zmean);
            free(m->reg[l].zsd);
            free(m->reg[l].cent);
            free(m->reg[l].in_mean);
            free(m->reg[l].in_sd);
            free(m->reg[l].coef);
        }
    free(m->reg);
    free(m->order);
    free(m->order_ov_off);
    free(m->order_ov);
    free(m->sov_off);
    free(m->sov);
    free(m->chol_off);
    free(m->chol);
    free(m->blend_off);
    free(m->blend_inst);
    free(m->blend_local);
    free(m->blend_w);
    free(m);
}

void mdl_model_destroy(mdl_model *m)
{
    mdl__model_free(m);
}

/* ------------------------------------------------------------------ writing */

typedef struct wbuf {
    uint8_t *p;
    size_t n, cap;
    int oom;
} wbuf;

static void put(wbuf *b, const void *src, size_t n)
{
    if (b->oom)
        return;
    if (b->n + n > b->cap) {
        size_t cap = (b->cap ? b->cap * 2 : 1 << 16);
        while (cap < b->n + n)
            cap *= 2;
        uint8_t *q = realloc(b->p, cap);
        if (!q) {
            b->oom = 1;
            return;
        }
        b->p = q;
        b->cap = cap;
    }
    memcpy(b->p + b->n, src, n);
    b->n += n;
}

static void put_u32(wbuf *b, uint32_t v)
{
    uint8_t x[4] = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24)};
    put(b, x, 4);
}

static void put_u64(wbuf *b, uint64_t v)
{
    put_u32(b, (uint32_t)v);
    put_u32(b, (uint32_t)(v >> 32));
}

static void put_f64(wbuf *b, double d)
{
    uint64_t v;
    memcpy(&v, &d, 8);
    put_u64(b, v);
}

static void put_i32s(wbuf *b, const int *a, size_t n)
{
    put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++)
        put_u32(b, (uint32_t)a[i]);
}

static void put_u32s(wbuf *b, const uint32_t *a, size_t n)
{
    put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++)
        put_u32(b, a[i]);
}

static void put_f32s(wbuf *b, const float *a, size_t n)
{
    put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++) {
        uint32_t v;
        memcpy(&v, &a[i], 4);
        put_u32(b, v);
    }
}

static void put_f64s(wbuf *b, const double *a, size_t n)
{
    put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++)
        put_f64(b, a[i]);
}

int mdl_model_save(const mdl_model *m, const char *path, char *err)
{
    wbuf b = {0};
    put(&b, MDL_MODEL_MAGIC, 8);
    put_u32(&b, MDL_MODEL_VERSION);
    put_u32(&b, 0);
    put(&b, m->name, MDL_NAME_LEN);
    put_u32(&b, (uint32_t)m->nv);
    put_u32(&b, (uint32_t)m->nf);
    put_u64(&b, m->topology);
    put_f64(&b, m->fps);
    put_f32s(&b, m->bbox_min, 3);
    put_f32s(&b, m->bbox_max, 3);
    put_u32(&b, (uint32_t)m->virtual_markers);
    put_f64(&b, m->train_seconds);
    put_f64(&b, m->beta);
    put_u32(&b, (uint32_t)m->iterations);
    put_u32(&b, (uint32_t)m->use_motion_dir);
    put_f64(&b, m->prior_weight);
    put_f64(&b, m->marker_weight);
    put_u32(&b, (uint32_t)m->relax);
    put_u32(&b, (uint32_t)m->place_mode);
    put_u32(&b, (uint32_t)m->axis_mesh);
    put_u32(&b, (uint32_t)m->axis_rec);
    put_f64s(&b, m->place_R, 9);
    put_f64s(&b, m->place_o, 3);
    put_f64(&b, m->rec_heading);
    put_f64s(&b, m->rec_origin, 3);
    put_f32s(&b, m->rest, 3 * (size_t)m->nv);
    put_u32s(&b, m->F, 3 * (size_t)m->nf);
    put_i32s(&b, m->train_frames, (size_t)m->ntrain);
    /* rig */
    put_u32(&b, (uint32_t)m->nmarkers);
    for (int i = 0; i < m->nmarkers; i++) {
        put(&b, m->markers[i].name, MDL_NAME_LEN);
        put(&b, m->markers[i].source, MDL_NAME_LEN);
        put_u32(&b, (uint32_t)m->markers[i].vertex);
    }
    put_u32(&b, (uint32_t)m->nref);
    put_i32s(&b, m->ref, 3);
    put_u32(&b, (uint32_t)m->nlimbs);
    put_i32s(&b, m->limb_off, (size_t)m->nlimbs + 1);
    put_i32s(&b, m->limb_idx, (size_t)m->limb_off[m->nlimbs]);
    /* parts */
    int P = m->nparts, NI = m->ninst, L = m->nlimbs;
    put_u32(&b, (uint32_t)P);
    put_i32s(&b, m->part, (size_t)m->nv);
    put_f64s(&b, m->part_rms, (size_t)P);
    put_i32s(&b, m->pv_off, (size_t)P + 1);
    put_i32s(&b, m->pv_idx, (size_t)m->pv_off[P]);
    put_i32s(&b, m->pmodes, (size_t)P);
    put_i32s(&b, m->pm_off, (size_t)P + 1);
    put_i32s(&b, m->ps_off, (size_t)P + 1);
    put_f32s(&b, m->part_mean, 3 * (size_t)m->pv_off[P]);
    put_f32s(&b, m->part_modes, (size_t)m->pm_off[P]);
    put_f64s(&b, m->part_sigma2, (size_t)m->ps_off[P]);
    put_f64s(&b, m->part_explained, (size_t)P);
    /* instances and limbs */
    put_u32(&b, (uint32_t)NI);
    put_i32s(&b, m->inst_part, (size_t)NI);
    put_i32s(&b, m->inst_limb, (size_t)NI);
    put_i32s(&b, m->inst_out, (size_t)NI);
    put_i32s(&b, m->inst_shared, (size_t)NI);
    put_i32s(&b, m->lpath_off, (size_t)L + 1);
    put_i32s(&b, m->lpath, (size_t)m->lpath_off[L]);
    put_f64s(&b, m->lctrl, 3 * ((size_t)m->lpath_off[L] + L));
    for (int l = 0; l < L; l++) {
        const mdl_limb_reg *r = &m->reg[l];
        put_u32(&b, (uint32_t)r->nin);
        put_u32(&b, (uint32_t)r->nout);
        put_f64s(&b, r->feat_scale, (size_t)r->nin);
        put_f64s(&b, r->feat_shift, (size_t)r->nin);
        put_f64s(&b, r->zmean, (size_t)r->nin);
        put_f64s(&b, r->zsd, (size_t)r->nin);
        put_u32(&b, (uint32_t)r->ncent);
        put_f64s(&b, r->cent, (size_t)r->ncent * r->nin);
        put_f64(&b, r->width);
        put_f64s(&b, r->in_mean, (size_t)(r->nin + r->ncent));
        put_f64s(&b, r->in_sd, (size_t)(r->nin + r->ncent));
        put_f64s(&b, r->coef, (size_t)(r->nin + r->ncent + 1) * r->nout);
        put_f64(&b, r->ridge);
        put_f64(&b, r->rms_train);
        put_f64(&b, r->rms_loo);
    }
    /* synthesis precomputations */
    put_i32s(&b, m->order, (size_t)NI);
    put_i32s(&b, m->order_ov_off, (size_t)NI + 1);
    put_i32s(&b, m->order_ov, (size_t)m->order_ov_off[NI]);
    put_i32s(&b, m->sov_off, (size_t)NI + 1);
    put_i32s(&b, m->sov, (size_t)m->sov_off[NI]);
    put_i32s(&b, m->chol_off, (size_t)NI + 1);
    put_f64s(&b, m->chol, (size_t)m->chol_off[NI]);
    put_i32s(&b, m->blend_off, (size_t)m->nv + 1);
    put_i32s(&b, m->blend_inst, (size_t)m->blend_off[m->nv]);
    put_i32s(&b, m->blend_local, (size_t)m->blend_off[m->nv]);
    put_f32s(&b, m->blend_w, (size_t)m->blend_off[m->nv]);
    put(&b, "END!", 4);
    if (b.oom) {
        free(b.p);
        return mdl__err(err, -ENOMEM, "%s: out of memory while encoding the model", path);
    }
    FILE *f = fopen(path, "wb");
    if (!f) {
        int e = errno;
        free(b.p);
        return mdl__err(err, -e, "%s: cannot create: %s", path, strerror(e));
    }
    size_t w = fwrite(b.p, 1, b.n, f);
    int e = ferror(f);
    if (fclose(f) != 0 || w != b.n || e) {
        free(b.p);
        return mdl__err(err, -EIO, "%s: write failed", path);
    }
    free(b.p);
    return 0;
}

/* ------------------------------------------------------------------ reading */

typedef struct rbuf {
    const uint8_t *p;
    size_t n, at;
    const char *name;
    char *err;
    int rc;
} rbuf;

static int fail(rbuf *b, const char *what)
{
    if (!b->rc)
        b->rc = mdl__err(b->err, MDL_EFORMAT, "%s: byte %zu: %s", b->name, b->at, what);
    return b->rc;
}

static int get(rbuf *b, void *dst, size_t n)
{
    if (b->rc)
        return b->rc;
    if (n > b->n - b->at)
        return fail(b, "unexpected end of file");
    memcpy(dst, b->p + b->at, n);
    b->at += n;
    return 0;
}

static uint32_t get_u32(rbuf *b)
{
    uint8_t x[4] = {0};
    get(b, x, 4);
    return (uint32_t)x[0] | (uint32_t)x[1] << 8 | (uint32_t)x[2] << 16 | (uint32_t)x[3] << 24;
}

static int get_int(rbuf *b, const char *what, int lo, int hi)
{
    uint32_t v = get_u32(b);
    if (b->rc)
        return lo;
    int iv = (int)v;
    if (v > 0x7fffffffu || iv < lo || iv > hi) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s = %u is outside %d..%d", what, v, lo, hi);
        fail(b, msg);
        return lo;
    }
    return iv;
}

static uint64_t get_u64(rbuf *b)
{
    uint64_t lo = get_u32(b);
    return lo | (uint64_t)get_u32(b) << 32;
}

static double get_f64(rbuf *b, const char *what)
{
    uint64_t v = get_u64(b);
    double d;
    memcpy(&d, &v, 8);
    if (!b->rc && !isfinite(d)) {
        char msg[120];
        snprintf(msg, sizeof msg, "%s is not a finite number", what);
        fail(b, msg);
    }
    return d;
}

static int count(rbuf *b, size_t expect, const char *what)
{
    uint32_t n = get_u32(b);
    if (b->rc)
        return b->rc;
    if (n != expect || n > MAX_COUNT) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s has %u entries, expected %zu", what, n, expect);
        return fail(b, msg);
    }
    if ((size_t)n * 4 > b->n - b->at)
        return fail(b, "unexpected end of file");
    return 0;
}

static void *get_ints(rbuf *b, size_t n, const char *what, int lo, int hi)
{
    if (count(b, n, what))
        return NULL;
    int *a = mdl__calloc(n ? n : 1, sizeof *a);
    if (!a) {
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
        return NULL;
    }
    for (size_t i = 0; i < n && !b->rc; i++) {
        uint32_t v = get_u32(b);
        if (v > 0x7fffffffu || (int)v < lo || (int)v > hi) {
            char msg[200];
            snprintf(msg, sizeof msg, "%s[%zu] = %u is outside %d..%d", what, i, v, lo, hi);
            fail(b, msg);
        }
        a[i] = (int)v;
    }
    if (b->rc) {
        free(a);
        return NULL;
    }
    return a;
}

static float *get_f32s(rbuf *b, size_t n, const char *what)
{
    if (count(b, n, what))
        return NULL;
    float *a = mdl__calloc(n ? n : 1, sizeof *a);
    if (!a) {
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
        return NULL;
    }
    for (size_t i = 0; i < n && !b->rc; i++) {
        uint32_t v = get_u32(b);
        memcpy(&a[i], &v, 4);
        if (!isfinite(a[i])) {
            char msg[160];
            snprintf(msg, sizeof msg, "%s[%zu] is not a finite number", what, i);
            fail(b, msg);
        }
    }
    if (b->rc) {
        free(a);
        return NULL;
    }
    return a;
}

static double *get_f64s(rbuf *b, size_t n, const char *what)
{
    uint32_t c = get_u32(b);
    if (b->rc)
        return NULL;
    if (c != n || n > MAX_COUNT || n * 8 > b->n - b->at) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s has %u entries, expected %zu (or the file is short)", what, c, n);
        fail(b, msg);
        return NULL;
    }
    double *a = mdl__calloc(n ? n : 1, sizeof *a);
    if (!a) {
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
        return NULL;
    }
    for (size_t i = 0; i < n && !b->rc; i++)
        a[i] = get_f64(b, what);
    if (b->rc) {
        free(a);
        return NULL;
    }
    return a;
}

/* offsets: off[0] == 0, non-decreasing, off[n] <= limit */
static int check_offsets(rbuf *b, const int *off, int n, const char *what)
{
    if (b->rc)
        return b->rc;
    if (off[0] != 0)
        return fail(b, what);
    for (int i = 0; i < n; i++)
        if (off[i + 1] < off[i]) {
            char msg[160];
            snprintf(msg, sizeof msg, "%s decreases at %d", what, i);
            return fail(b, msg);
        }
    return 0;
}

static void get_name(rbuf *b, char *dst)
{
    get(b, dst, MDL_NAME_LEN);
    dst[MDL_NAME_LEN - 1] = 0;
}

int mdl_model_parse(const uint8_t *buf, size_t len, const char *name, mdl_model **out, char *err)
{
    *out = NULL;
    rbuf b = {buf, len, 0, name, err, 0};
    char magic[8];
    if (get(&b, magic, 8) || memcmp(magic, MDL_MODEL_MAGIC, 8) != 0)
        return mdl__err(err, MDL_EFORMAT, "%s: not a meshsteer model file (bad magic)", name);
    uint32_t version = get_u32(&b);
    if (b.rc)
        return b.rc;
    if (version != MDL_MODEL_VERSION)
        return mdl__err(err, MDL_EVERSION,
                        "%s: model file version %u; this build reads version %d (retrain the model)",
                        name, version, MDL_MODEL_VERSION);
    get_u32(&b);
    struct mdl_model *m = mdl__calloc(1, sizeof *m);
    if (!m)
        return mdl__err(err, -ENOMEM, "%s: out of memory", name);
    get_name(&b, m->name);
    m->nv = get_int(&b, "vertex count", 1, 1 << 24);
    m->nf = get_int(&b, "triangle count", 1, 1 << 25);
    m->topology = get_u64(&b);
    m->fps = get_f64(&b, "fps");
    float *bb = get_f32s(&b, 3, "bbox_min");
    if (bb) {
        memcpy(m->bbox_min, bb, sizeof m->bbox_min);
        free(bb);
    }
    bb = get_f32s(&b, 3, "bbox_max");
    if (bb) {
        memcpy(m->bbox_max, bb, sizeof m->bbox_max);
        free(bb);
    }
    m->virtual_markers = get_int(&b, "virtual_markers", 0, 1);
    m->train_seconds = get_f64(&b, "train_seconds");
    m->beta = get_f64(&b, "beta");
    m->iterations = get_int(&b, "iterations", 0, 100);
    m->use_motion_dir = get_int(&b, "use_motion_dir", 0, 1);
    m->prior_weight = get_f64(&b, "prior_weight");
    m->marker_weight = get_f64(&b, "marker_weight");
    m->relax = get_int(&b, "relax", 0, 100);
    m->place_mode = get_int(&b, "placement", 0, 1);
    m->axis_mesh = get_int(&b, "mesh frame axis", 0, 1);
    m->axis_rec = get_int(&b, "recording frame axis", 0, 1);
    {
        double *pr = get_f64s(&b, 9, "place_R"), *po = get_f64s(&b, 3, "place_o");
        m->rec_heading = get_f64(&b, "rec_heading");
        double *ro = get_f64s(&b, 3, "rec_origin");
        if (pr && po && ro) {
            memcpy(m->place_R, pr, sizeof m->place_R);
            memcpy(m->place_o, po, sizeof m->place_o);
            memcpy(m->rec_origin, ro, sizeof m->rec_origin);
        }
        free(pr);
        free(po);
        free(ro);
    }
    if (b.rc)
        goto bad;
    int nv = m->nv;
    m->rest = get_f32s(&b, 3 * (size_t)nv, "rest");
    if (count(&b, 3 * (size_t)m->nf, "faces"))
        goto bad;
    m->F = mdl__calloc(3 * (size_t)m->nf, sizeof *m->F);
    if (!m->F)
        goto oom;
    for (size_t i = 0; i < 3 * (size_t)m->nf && !b.rc; i++) {
        m->F[i] = get_u32(&b);
        if (m->F[i] >= (uint32_t)nv)
            fail(&b, "a face index is out of range");
    }
    if (b.rc)
        goto bad;
    if (mdl_topology_fingerprint(m->F, m->nf, nv) != m->topology) {
        fail(&b, "the face list does not match its fingerprint");
        goto bad;
    }
    uint32_t nt = get_u32(&b);
    b.at -= 4;
    if (nt > MAX_COUNT) {
        fail(&b, "training frame count is too large");
        goto bad;
    }
    m->ntrain = (int)nt;
    m->train_frames = get_ints(&b, nt, "train_frames", 0, 0x7fffffff);
    m->nmarkers = get_int(&b, "marker count", 1, 4096);
    if (b.rc)
        goto bad;
    m->markers = mdl__calloc((size_t)m->nmarkers, sizeof *m->markers);
    if (!m->markers)
        goto oom;
    for (int i = 0; i < m->nmarkers && !b.rc; i++) {
        get_name(&b, m->markers[i].name);
        get_name(&b, m->markers[i].source);
        m->markers[i].vertex = get_int(&b, "marker vertex", 0, nv - 1);
    }
    m->nref = get_int(&b, "reference marker count", 2, 3);
    int *ref = get_ints(&b, 3, "reference", 0, m->nmarkers - 1);
    if (ref) {
        memcpy(m->ref, ref, sizeof m->ref);
        free(ref);
    }
    m->nlimbs = get_int(&b, "limb count", 1, 4096);
    if (b.rc)
        goto bad;
    int L = m->nlimbs;
    m->limb_off = get_ints(&b, (size_t)L + 1, "limb_off", 0, MAX_COUNT);
    if (check_offsets(&b, m->limb_off, L, "limb_off"))
        goto bad;
    for (int l = 0; l < L; l++)
        if (m->limb_off[l + 1] - m->limb_off[l] < 2) {
            fail(&b, "a limb has fewer than two markers");
            goto bad;
        }
    m->limb_idx = get_ints(&b, (size_t)m->limb_off[L], "limb_idx", 0, m->nmarkers - 1);
    int P = m->nparts = get_int(&b, "part count", 1, 1 << 16);
    if (b.rc)
        goto bad;
    m->part = get_ints(&b, (size_t)nv, "part", 0, P - 1);
    m->part_rms = get_f64s(&b, (size_t)P, "part_rms");
    m->pv_off = get_ints(&b, (size_t)P + 1, "pv_off", 0, MAX_COUNT);
    if (check_offsets(&b, m->pv_off, P, "pv_off"))
        goto bad;
    m->pv_idx = get_ints(&b, (size_t)m->pv_off[P], "pv_idx", 0, nv - 1);
    m->pmodes = get_ints(&b, (size_t)P, "pmodes", 0, 64);
    m->pm_off = get_ints(&b, (size_t)P + 1, "pm_off", 0, MAX_COUNT);
    m->ps_off = get_ints(&b, (size_t)P + 1, "ps_off", 0, MAX_COUNT);
    if (b.rc)
        goto bad;
    for (int p = 0; p < P; p++) {
        size_t n = (size_t)(m->pv_off[p + 1] - m->pv_off[p]);
        if (n == 0 || (size_t)m->pm_off[p + 1] - (size_t)m->pm_off[p] != 3 * n * (size_t)m->pmodes[p] ||
            m->ps_off[p + 1] - m->ps_off[p] != m->pmodes[p] || m->pm_off[p + 1] < m->pm_off[p]) {
            fail(&b, "part mode tables are inconsistent");
            goto bad;
        }
    }
    if (m->pm_off[0] != 0 || m->ps_off[0] != 0) {
        fail(&b, "part mode tables do not start at 0");
        goto bad;
    }
    m->part_mean = get_f32s(&b, 3 * (size_t)m->pv_off[P], "part_mean");
    m->part_modes = get_f32s(&b, (size_t)m->pm_off[P], "part_modes");
    m->part_sigma2 = get_f64s(&b, (size_t)m->ps_off[P], "part_sigma2");
    m->part_explained = get_f64s(&b, (size_t)P, "part_explained");
    if (b.rc)
        goto bad;
    for (int i = 0; i < m->ps_off[P]; i++)
        if (!(m->part_sigma2[i] > 0)) {
            fail(&b, "a shape variance is not positive");
            goto bad;
        }
    int NI = m->ninst = get_int(&b, "instance count", 1, 1 << 20);
    if (b.rc)
        goto bad;
    m->inst_part = get_ints(&b, (size_t)NI, "inst_part", 0, P - 1);
    m->inst_limb = get_ints(&b, (size_t)NI, "inst_limb", 0, L - 1);
    m->inst_out = get_ints(&b, (size_t)NI, "inst_out", 0, MAX_COUNT);
    m->inst_shared = get_ints(&b, (size_t)NI, "inst_shared", 0, 1);
    m->lpath_off = get_ints(&b, (size_t)L + 1, "lpath_off", 0, MAX_COUNT);
    if (check_offsets(&b, m->lpath_off, L, "lpath_off"))
        goto bad;
    m->lpath = get_ints(&b, (size_t)m->lpath_off[L], "lpath", 0, P - 1);
    m->lctrl = get_f64s(&b, 3 * ((size_t)m->lpath_off[L] + L), "control points");
    m->reg = mdl__calloc((size_t)L, sizeof *m->reg);
    if (!m->reg)
        goto oom;
    for (int l = 0; l < L && !b.rc; l++) {
        mdl_limb_reg *r = &m->reg[l];
        int plen = m->limb_off[l + 1] - m->limb_off[l];
        r->nin = get_int(&b, "regression inputs", 0, 4096);
        r->nout = get_int(&b, "regression outputs", 1, 1 << 20);
        if (b.rc)
            break;
        if (r->nin != mdl__limb_nfeat(plen, m->use_motion_dir)) {
            fail(&b, "a regression's input count does not match its limb");
            break;
        }
        r->feat_scale = get_f64s(&b, (size_t)r->nin, "feat_scale");
        r->feat_shift = get_f64s(&b, (size_t)r->nin, "feat_shift");
        r->zmean = get_f64s(&b, (size_t)r->nin, "zmean");
        r->zsd = get_f64s(&b, (size_t)r->nin, "zsd");
        r->ncent = get_int(&b, "kernel centres", 0, 1 << 16);
        r->cent = get_f64s(&b, (size_t)r->ncent * r->nin, "cent");
        r->width = get_f64(&b, "kernel width");
        r->in_mean = get_f64s(&b, (size_t)(r->nin + r->ncent), "in_mean");
        r->in_sd = get_f64s(&b, (size_t)(r->nin + r->ncent), "in_sd");
        r->coef = get_f64s(&b, (size_t)(r->nin + r->ncent + 1) * r->nout, "coef");
        r->ridge = get_f64(&b, "ridge");
        r->rms_train = get_f64(&b, "rms_train");
        r->rms_loo = get_f64(&b, "rms_loo");
        for (int j = 0; j < r->nin + r->ncent && !b.rc; j++)
            if (!(r->in_sd[j] > 0))
                fail(&b, "a feature scale is not positive");
        for (int j = 0; j < r->nin && !b.rc; j++)
            if (!(r->zsd[j] > 0))
                fail(&b, "a feature scale is not positive");
        if (!b.rc && r->ncent > 0 && !(r->width > 0))
            fail(&b, "a kernel width is not positive");
    }
    if (b.rc)
        goto bad;
    for (int i = 0; i < NI; i++) {
        const mdl_limb_reg *r = &m->reg[m->inst_limb[i]];
        if (m->inst_out[i] + 7 + m->pmodes[m->inst_part[i]] > r->nout) {
            fail(&b, "an instance's outputs exceed its regression");
            goto bad;
        }
    }
    m->order = get_ints(&b, (size_t)NI, "order", 0, NI - 1);
    m->order_ov_off = get_ints(&b, (size_t)NI + 1, "order_ov_off", 0, MAX_COUNT);
    if (check_offsets(&b, m->order_ov_off, NI, "order_ov_off"))
        goto bad;
    m->order_ov = get_ints(&b, (size_t)m->order_ov_off[NI], "order_ov", 0, MAX_COUNT);
    m->sov_off = get_ints(&b, (size_t)NI + 1, "sov_off", 0, MAX_COUNT);
    if (check_offsets(&b, m->sov_off, NI, "sov_off"))
        goto bad;
    m->sov = get_ints(&b, (size_t)m->sov_off[NI], "sov", 0, MAX_COUNT);
    m->chol_off = get_ints(&b, (size_t)NI + 1, "chol_off", 0, MAX_COUNT);
    if (check_offsets(&b, m->chol_off, NI, "chol_off"))
        goto bad;
    m->chol = get_f64s(&b, (size_t)m->chol_off[NI], "chol");
    m->blend_off = get_ints(&b, (size_t)nv + 1, "blend_off", 0, MAX_COUNT);
    if (check_offsets(&b, m->blend_off, nv, "blend_off"))
        goto bad;
    m->blend_inst = get_ints(&b, (size_t)m->blend_off[nv], "blend_inst", 0, NI - 1);
    m->blend_local = get_ints(&b, (size_t)m->blend_off[nv], "blend_local", 0, MAX_COUNT);
    m->blend_w = get_f32s(&b, (size_t)m->blend_off[nv], "blend_w");
    char end[4];
    if (b.rc || get(&b, end, 4) || memcmp(end, "END!", 4) != 0 || b.at != b.n) {
        fail(&b, "missing end marker or trailing bytes");
        goto bad;
    }
    /* cross-checks of local indices against part sizes */
    {
        uint8_t *seen = mdl__calloc((size_t)NI, 1);
        if (!seen)
            goto oom;
        for (int s = 0; s < NI; s++) {
            int i = m->order[s];
            if (seen[i]++)
                fail(&b, "the alignment order repeats an instance");
        }
        free(seen);
        for (int i = 0; i < NI && !b.rc; i++) {
            int p = m->inst_part[i], n = m->pv_off[p + 1] - m->pv_off[p], k = m->pmodes[p];
            if (m->chol_off[i + 1] - m->chol_off[i] != k * k)
                fail(&b, "a Cholesky factor has the wrong size");
            for (int o = m->sov_off[i]; o < m->sov_off[i + 1] && !b.rc; o++)
                if (m->sov[o] >= n)
                    fail(&b, "a shape-optimisation vertex is outside its part");
        }
        for (int s = 0; s < NI && !b.rc; s++) {
            int i = m->order[s], p = m->inst_part[i], n = m->pv_off[p + 1] - m->pv_off[p];
            for (int o = m->order_ov_off[s]; o < m->order_ov_off[s + 1] && !b.rc; o++)
                if (m->order_ov[o] >= n)
                    fail(&b, "an alignment overlap vertex is outside its part");
        }
        for (int j = 0; j < m->blend_off[nv] && !b.rc; j++) {
            int p = m->inst_part[m->blend_inst[j]];
            if (m->blend_local[j] >= m->pv_off[p + 1] - m->pv_off[p])
                fail(&b, "a blend entry is outside its part");
        }
        for (int i = 0; i < NI && !b.rc; i++) {
            int k = m->pmodes[m->inst_part[i]];
            const double *A = m->chol + m->chol_off[i];
            for (int a = 0; a < k; a++)
                if (!(A[a * k + a] > 0))
                    fail(&b, "a Cholesky factor has a non-positive diagonal");
        }
    }
    if (b.rc)
        goto bad;
    *out = m;
    return 0;
oom:
    if (!b.rc)
        b.rc = mdl__err(err, -ENOMEM, "%s: out of memory", name);
bad:
    mdl__model_free(m);
    return b.rc ? b.rc : MDL_EFORMAT;
}

int mdl_model_load(const char *path, mdl_model **out, char *err)
{
    char *buf;
    size_t len;
    *out = NULL;
    int r = mdl__read_file(path, (size_t)1 << 31, &buf, &len, err);
    if (r)
        return r;
    r = mdl_model_parse((const uint8_t *)buf, len, path, out, err);
    free(buf);
    return r;
}

/* ------------------------------------------------------------------ views */

void mdl_model_get_info(const mdl_model *m, mdl_model_info *info)
{
    memset(info, 0, sizeof *info);
    info->name = m->name;
    info->nv = m->nv;
    info->nf = m->nf;
    info->rest = m->rest;
    info->F = m->F;
    info->topology = m->topology;
    info->nmarkers = m->nmarkers;
    info->markers = m->markers;
    info->nclusters = m->nparts;
    info->part = m->part;
    info->ntrain = m->ntrain;
    info->train_frames = m->train_frames;
    info->fps = m->fps;
    memcpy(info->bbox_min, m->bbox_min, sizeof info->bbox_min);
    memcpy(info->bbox_max, m->bbox_max, sizeof info->bbox_max);
    info->virtual_markers = m->virtual_markers;
}

int mdl_model_bind_markers(const mdl_model *m, const char *const *names, int count, int *map)
{
    int missing = 0;
    for (int i = 0; i < m->nmarkers; i++) {
        map[i] = -1;
        for (int j = 0; j < count; j++)
            if (names[j] && strcmp(names[j], m->markers[i].source) == 0) {
                map[i] = j;
                break;
            }
        missing += map[i] < 0;
    }
    return missing;
}

#define APPEND(...)                                                                                \
    do {                                                                                           \
        if (at < len) {                                                                            \
            int w_ = snprintf(buf + at, len - at, __VA_ARGS__);                                    \
            if (w_ > 0)                                                                            \
                at += (size_t)w_;                                                                  \
        }                                                                                          \
    } while (0)

int mdl_model_describe(const mdl_model *m, char *buf, size_t len)
{
    size_t at = 0;
    if (len)
        buf[0] = 0;
    APPEND("model      %s (file version %d)\n", m->name, MDL_MODEL_VERSION);
    APPEND("mesh       %d vertices, %d triangles, topology %016llx\n", m->nv, m->nf,
           (unsigned long long)m->topology);
    APPEND("training   %d frames (", m->ntrain);
    for (int i = 0; i < m->ntrain && i < 12; i++)
        APPEND("%s%d", i ? " " : "", m->train_frames[i]);
    APPEND("%s), %s markers, %.2f s\n", m->ntrain > 12 ? " ..." : "",
           m->virtual_markers ? "virtual" : "recorded", m->train_seconds);
    APPEND("bbox       [%.3f %.3f %.3f] .. [%.3f %.3f %.3f] m\n", m->bbox_min[0], m->bbox_min[1],
           m->bbox_min[2], m->bbox_max[0], m->bbox_max[1], m->bbox_max[2]);
    APPEND("markers    %d:", m->nmarkers);
    for (int i = 0; i < m->nmarkers; i++) {
        APPEND(" %s@%d", m->markers[i].name, m->markers[i].vertex);
        if (strcmp(m->markers[i].name, m->markers[i].source))
            APPEND("<-%s", m->markers[i].source);
    }
    APPEND("\nreference  %s -> %s%s%s\n", m->markers[m->ref[0]].name, m->markers[m->ref[1]].name,
           m->nref > 2 ? ", side " : "", m->nref > 2 ? m->markers[m->ref[2]].name : "");
    int modes = 0;
    for (int p = 0; p < m->nparts; p++)
        modes += m->pmodes[p];
    long ivert = 0;
    for (int i = 0; i < m->ninst; i++)
        ivert += m->pv_off[m->inst_part[i] + 1] - m->pv_off[m->inst_part[i]];
    APPEND("parts      %d near-rigid clusters, %d shape modes, %d instances holding %ld vertices "
           "(%d shared between instances)\n",
           m->nparts, modes, m->ninst, ivert, m->sov_off[m->ninst]);
    for (int p = 0; p < m->nparts; p++) {
        int core = 0;
        for (int v = 0; v < m->nv; v++)
            core += m->part[v] == p;
        APPEND("  part %-3d %5d vertices (+%d overlap), %d modes, %5.1f%% explained, rigid rms %.4f\n",
               p, core, m->pv_off[p + 1] - m->pv_off[p] - core, m->pmodes[p],
               100 * m->part_explained[p], m->part_rms[p]);
    }
    APPEND("limbs      %d\n", m->nlimbs);
    for (int l = 0; l < m->nlimbs; l++) {
        APPEND("  limb %-2d ", l);
        for (int j = m->limb_off[l]; j < m->limb_off[l + 1]; j++)
            APPEND("%s%s", j > m->limb_off[l] ? "-" : "", m->markers[m->limb_idx[j]].name);
        APPEND("  path in H:");
        for (int j = m->lpath_off[l]; j < m->lpath_off[l + 1]; j++)
            APPEND(" %d", m->lpath[j]);
        APPEND(", %d control points", m->lpath_off[l + 1] - m->lpath_off[l] + 1);
        APPEND("  regression: %d (+%d rbf) -> %d, ridge %g, residual %.3f (leave-one-out %.3f)\n",
               m->reg[l].nin, m->reg[l].ncent, m->reg[l].nout, m->reg[l].ridge, m->reg[l].rms_train,
               m->reg[l].rms_loo);
    }
    APPEND("synthesis  beta %g, %d iterations, %d relaxation sweeps, marker weight %g, motion "
           "directions %s\n",
           m->beta, m->iterations, m->relax, m->marker_weight, m->use_motion_dir ? "on" : "off");
    return at < len ? 0 : -ENOSPC;
}

char *mdl_model_report_json(const mdl_model *m)
{
    cJSON *o = cJSON_CreateObject();
    if (!o)
        return NULL;
    cJSON_AddStringToObject(o, "model", m->name);
    cJSON_AddNumberToObject(o, "vertices", m->nv);
    cJSON_AddNumberToObject(o, "triangles", m->nf);
    cJSON_AddNumberToObject(o, "training_frames", m->ntrain);
    cJSON_AddNumberToObject(o, "training_seconds", m->train_seconds);
    cJSON_AddBoolToObject(o, "virtual_markers", m->virtual_markers);
    cJSON_AddNumberToObject(o, "clusters", m->nparts);
    cJSON_AddNumberToObject(o, "instances", m->ninst);
    cJSON *parts = cJSON_AddArrayToObject(o, "parts");
    for (int p = 0; p < m->nparts; p++) {
        int core = 0;
        for (int v = 0; v < m->nv; v++)
            core += m->part[v] == p;
        cJSON *e = cJSON_CreateObject();
        cJSON_AddNumberToObject(e, "part", p);
        cJSON_AddNumberToObject(e, "vertices", core);
        cJSON_AddNumberToObject(e, "with_overlap", m->pv_off[p + 1] - m->pv_off[p]);
        cJSON_AddNumberToObject(e, "modes", m->pmodes[p]);
        cJSON_AddNumberToObject(e, "explained_variance", m->part_explained[p]);
        cJSON_AddNumberToObject(e, "rigid_rms", m->part_rms[p]);
        cJSON_AddItemToArray(parts, e);
    }
    cJSON *limbs = cJSON_AddArrayToObject(o, "limbs");
    for (int l = 0; l < m->nlimbs; l++) {
        cJSON *e = cJSON_CreateObject(), *mk = cJSON_AddArrayToObject(e, "markers");
        for (int j = m->limb_off[l]; j < m->limb_off[l + 1]; j++)
            cJSON_AddItemToArray(mk, cJSON_CreateString(m->markers[m->limb_idx[j]].name));
        cJSON *path = cJSON_AddArrayToObject(e, "path_parts");
        for (int j = m->lpath_off[l]; j < m->lpath_off[l + 1]; j++)
            cJSON_AddItemToArray(path, cJSON_CreateNumber(m->lpath[j]));
        cJSON *cp = cJSON_AddArrayToObject(e, "control_points");
        const double *c = m->lctrl + 3 * ((size_t)m->lpath_off[l] + l);
        for (int j = 0; j <= m->lpath_off[l + 1] - m->lpath_off[l]; j++)
            cJSON_AddItemToArray(cp, cJSON_CreateDoubleArray(c + 3 * j, 3));
        cJSON_AddNumberToObject(e, "inputs", m->reg[l].nin);
        cJSON_AddNumberToObject(e, "rbf_centres", m->reg[l].ncent);
        cJSON_AddNumberToObject(e, "outputs", m->reg[l].nout);
        cJSON_AddNumberToObject(e, "ridge", m->reg[l].ridge);
        cJSON_AddNumberToObject(e, "residual", m->reg[l].rms_train);
        cJSON_AddNumberToObject(e, "residual_loo", m->reg[l].rms_loo);
        cJSON_AddItemToArray(limbs, e);
    }
    char *js = cJSON_Print(o);
    cJSON_Delete(o);
    return js;
}
