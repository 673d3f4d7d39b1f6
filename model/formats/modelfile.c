/* modelfile.c - the model file container, version 2 (docs/FORMATS.md), and version 1 read as a
 * conversion.
 *
 * Version 2, after glTF's GLB: a header, then tagged, length-prefixed chunks.
 *   header  "MSTRMODL", u32 version (2), u32 primary kind (MDL_KIND_*)
 *   chunk   char tag[4], u32 length, length bytes of payload
 *   "MESH"  first: name, vertex and triangle counts, topology fingerprint, fps, box, rest pose, faces
 *   "RIG "  optional, before any kind: markers (name, source, vertex), reference, limbs
 *   a kind  one chunk per kind (kind.h: "STER", ...), the primary kind among them
 *   "END "  last, length 0, and nothing after it
 * A chunk with a tag this build does not know is skipped; every known chunk must consume exactly
 * its length. Everything little-endian, read through chunkio.h, which validates every count, index
 * and float as it goes: a corrupt or hostile file gives a clear error naming the byte, never an
 * out-of-bounds access (tests/fuzz/fuzz_model.c).
 *
 * Version 1 (a steering model only, written until meshsteer 0.1) holds the same fields as the
 * steering chunk with the mesh and rig inline, then "END!": it is read and converted on load.
 */
#include "kind.h"
#include "formats/chunkio.h"
#include "steer/steer_internal.h"
#include "core/util.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MODEL_MAGIC "MSTRMODL"
#define MODEL_VERSION 2

/* ------------------------------------------------------------------ writing */

static void chunk_begin(mdl__wbuf *b, const char tag[4], size_t *len_at)
{
    mdl__put_bytes(b, tag, 4);
    *len_at = b->n;
    mdl__put_u32(b, 0);
}

static void chunk_end(mdl__wbuf *b, size_t len_at)
{
    if (b->oom)
        return;
    uint32_t n = (uint32_t)(b->n - len_at - 4);
    uint8_t x[4] = {(uint8_t)n, (uint8_t)(n >> 8), (uint8_t)(n >> 16), (uint8_t)(n >> 24)};
    memcpy(b->p + len_at, x, 4);
}

static void put_mesh(mdl__wbuf *b, const mdl_model *m)
{
    char name[MDL_NAME_LEN] = {0};
    snprintf(name, sizeof name, "%s", m->name);
    mdl__put_bytes(b, name, MDL_NAME_LEN);
    mdl__put_u32(b, (uint32_t)m->nv);
    mdl__put_u32(b, (uint32_t)m->nf);
    mdl__put_u64(b, m->topology);
    mdl__put_f64(b, m->fps);
    mdl__put_f32s(b, m->bbox_min, 3);
    mdl__put_f32s(b, m->bbox_max, 3);
    mdl__put_f32s(b, m->rest, 3 * (size_t)m->nv);
    mdl__put_u32s(b, m->F, 3 * (size_t)m->nf);
}

void mdl__rig_write(mdl__wbuf *b, const mdl_rig *r)
{
    mdl__put_u32(b, (uint32_t)r->nmarkers);
    for (int i = 0; i < r->nmarkers; i++) {
        mdl__put_bytes(b, r->markers[i].name, MDL_NAME_LEN);
        mdl__put_bytes(b, r->markers[i].source, MDL_NAME_LEN);
        mdl__put_u32(b, (uint32_t)r->markers[i].vertex);
    }
    mdl__put_u32(b, (uint32_t)r->nref);
    mdl__put_i32s(b, r->ref, 3);
    mdl__put_u32(b, (uint32_t)r->nlimbs);
    mdl__put_i32s(b, r->limb_off, (size_t)r->nlimbs + 1);
    mdl__put_i32s(b, r->limb_idx, (size_t)r->limb_off[r->nlimbs]);
}

int mdl_model_save(const mdl_model *m, const char *path, char *err)
{
    if (!m->nkinds)
        return mdl__err(err, -EINVAL, "%s: the model holds no kind", path);
    mdl__wbuf b = {0};
    size_t at;
    mdl__put_bytes(&b, MODEL_MAGIC, 8);
    mdl__put_u32(&b, MODEL_VERSION);
    mdl__put_u32(&b, (uint32_t)m->kinds[0].ops->id);
    chunk_begin(&b, "MESH", &at);
    put_mesh(&b, m);
    chunk_end(&b, at);
    if (m->rig) {
        chunk_begin(&b, "RIG ", &at);
        mdl__rig_write(&b, m->rig);
        chunk_end(&b, at);
    }
    for (int i = 0; i < m->nkinds; i++) {
        chunk_begin(&b, m->kinds[i].ops->tag, &at);
        m->kinds[i].ops->save(m->kinds[i].impl, m, &b);
        chunk_end(&b, at);
    }
    chunk_begin(&b, "END ", &at);
    chunk_end(&b, at);
    if (b.oom || b.n > 0xffffffffu) {
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

int mdl__rig_read(mdl__rbuf *b, int nv, mdl_rig **out)
{
    *out = NULL;
    mdl_rig *r = mdl__calloc(1, sizeof *r);
    if (!r)
        return b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
    r->nmarkers = mdl__get_int(b, "marker count", 1, 4096);
    if (!b->rc && !(r->markers = mdl__calloc((size_t)r->nmarkers, sizeof *r->markers)))
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
    for (int i = 0; i < r->nmarkers && !b->rc; i++) {
        mdl__get_name(b, r->markers[i].name);
        mdl__get_name(b, r->markers[i].source);
        r->markers[i].vertex = mdl__get_int(b, "marker vertex", 0, nv - 1);
    }
    r->nref = mdl__get_int(b, "reference marker count", 2, 3);
    int *ref = b->rc ? NULL : mdl__get_ints(b, 3, "reference", 0, r->nmarkers - 1);
    if (ref) {
        memcpy(r->ref, ref, sizeof r->ref);
        free(ref);
    }
    r->nlimbs = mdl__get_int(b, "limb count", 1, 4096);
    int L = r->nlimbs;
    if (!b->rc)
        r->limb_off = mdl__get_ints(b, (size_t)L + 1, "limb_off", 0, MDL_CHUNK_MAX_COUNT);
    if (!b->rc && !mdl__check_offsets(b, r->limb_off, L, "limb_off"))
        for (int l = 0; l < L && !b->rc; l++)
            if (r->limb_off[l + 1] - r->limb_off[l] < 2)
                mdl__rfail(b, "a limb has fewer than two markers");
    if (!b->rc)
        r->limb_idx = mdl__get_ints(b, (size_t)r->limb_off[L], "limb_idx", 0, r->nmarkers - 1);
    if (b->rc) {
        if (!r->limb_off)
            r->nlimbs = 0; /* so that mdl_rig_destroy reads nothing it does not have */
        mdl_rig_destroy(r);
        return b->rc;
    }
    *out = r;
    return 0;
}

static int parse_mesh(mdl__rbuf *b, mdl_model *m)
{
    mdl__get_name(b, m->name);
    m->nv = mdl__get_int(b, "vertex count", 1, 1 << 24);
    m->nf = mdl__get_int(b, "triangle count", 1, 1 << 25);
    m->topology = mdl__get_u64(b);
    m->fps = mdl__get_f64(b, "fps");
    if (!b->rc && !(m->fps >= 0 && m->fps <= 1e4))
        mdl__rfail(b, "fps is outside 0..10000");
    float *lo = mdl__get_f32s(b, 3, "bbox_min"), *hi = mdl__get_f32s(b, 3, "bbox_max");
    if (lo && hi) {
        memcpy(m->bbox_min, lo, sizeof m->bbox_min);
        memcpy(m->bbox_max, hi, sizeof m->bbox_max);
    }
    free(lo);
    free(hi);
    if (b->rc)
        return b->rc;
    m->rest = mdl__get_f32s(b, 3 * (size_t)m->nv, "rest");
    if (b->rc || mdl__get_count(b, 3 * (size_t)m->nf, "faces"))
        return b->rc;
    m->F = mdl__calloc(3 * (size_t)m->nf, sizeof *m->F);
    if (!m->F)
        return b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
    for (size_t i = 0; i < 3 * (size_t)m->nf && !b->rc; i++) {
        m->F[i] = mdl__get_u32(b);
        if (m->F[i] >= (uint32_t)m->nv)
            mdl__rfail(b, "a face index is out of range");
    }
    if (!b->rc && mdl_topology_fingerprint(m->F, m->nf, m->nv) != m->topology)
        mdl__rfail(b, "the face list does not match its fingerprint");
    return b->rc;
}

/* A version-1 file: a steering model with its mesh and rig inline. */
static int parse_v1(mdl__rbuf *b, mdl_model **out)
{
    struct mdl_steer *s = NULL;
    int rc = mdl__steer_parse(b, NULL, 1, &s);
    if (rc)
        return rc;
    char end[4];
    if (mdl__get_bytes(b, end, 4) || memcmp(end, "END!", 4) != 0 || b->at != b->n) {
        mdl__steer_free(s);
        return mdl__rfail(b, "missing end marker or trailing bytes");
    }
    return mdl__steer_model_from(s, out, b->err);
}

static int parse_v2(mdl__rbuf *b, int primary, mdl_model **out)
{
    mdl_model *m = mdl__calloc(1, sizeof *m);
    if (!m)
        return mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
    const size_t file_end = b->n;
    int have_mesh = 0, ended = 0;
    while (!b->rc && !ended && b->at < file_end) {
        char tag[4];
        size_t tag_at = b->at;
        mdl__get_bytes(b, tag, 4);
        uint32_t len = mdl__get_u32(b);
        if (b->rc)
            break;
        if (len > file_end - b->at) {
            mdl__rfail(b, "a chunk is longer than the rest of the file");
            break;
        }
        char what[96];
        snprintf(what, sizeof what, "chunk '%.4s' at byte %zu", tag, tag_at);
        size_t chunk_end = b->at + len;
        b->n = chunk_end; /* a chunk's reader cannot run past its chunk */
        const mdl_kind_ops *ops = NULL;
        if (memcmp(tag, "END ", 4) == 0) {
            if (len != 0 || chunk_end != file_end)
                mdl__rfail(b, "the END chunk is not empty, or bytes follow it");
            ended = 1;
        } else if (memcmp(tag, "MESH", 4) == 0) {
            if (have_mesh)
                mdl__rfail(b, "a second MESH chunk");
            else
                parse_mesh(b, m);
            have_mesh = 1;
        } else if (!have_mesh) {
            mdl__rfail(b, "the first chunk is not MESH");
        } else if (memcmp(tag, "RIG ", 4) == 0) {
            if (m->rig || m->nkinds)
                mdl__rfail(b, "a RIG chunk after the kinds, or a second one");
            else
                mdl__rig_read(b, m->nv, &m->rig);
        } else if ((ops = mdl__kind_ops_by_tag(tag))) {
            void *impl = NULL;
            if (mdl__model_kind(m, ops->id))
                mdl__rfail(b, "a kind appears twice");
            else if (ops->parse(b, m, &impl) == 0)
                mdl__model_add_kind(m, ops, impl, NULL);
        } else {
            b->at = chunk_end; /* a chunk of a later version: skipped */
        }
        if (!b->rc && b->at != chunk_end) {
            char msg[160];
            snprintf(msg, sizeof msg, "%s: %zu bytes of it were not read", what, chunk_end - b->at);
            mdl__rfail(b, msg);
        }
        b->n = file_end;
    }
    if (!b->rc && !ended)
        mdl__rfail(b, "the file ends without an END chunk");
    if (!b->rc && !m->nkinds)
        mdl__rfail(b, "the file holds no model kind this build knows");
    if (!b->rc) {
        /* the primary kind first */
        int at = -1;
        for (int i = 0; i < m->nkinds; i++)
            if (m->kinds[i].ops->id == primary)
                at = i;
        if (at < 0) {
            mdl__rfail(b, "the header's primary kind has no chunk");
        } else {
            mdl_kind_slot k = m->kinds[at];
            memmove(&m->kinds[1], &m->kinds[0], (size_t)at * sizeof k);
            m->kinds[0] = k;
        }
    }
    if (b->rc) {
        mdl_model_destroy(m);
        return b->rc;
    }
    *out = m;
    return 0;
}

int mdl_model_parse(const uint8_t *buf, size_t len, const char *name, mdl_model **out, char *err)
{
    *out = NULL;
    mdl__rbuf b = {buf, len, 0, name, err, 0};
    char magic[8];
    if (mdl__get_bytes(&b, magic, 8) || memcmp(magic, MODEL_MAGIC, 8) != 0)
        return mdl__err(err, MDL_EFORMAT, "%s: not a meshsteer model file (bad magic)", name);
    uint32_t version = mdl__get_u32(&b);
    uint32_t word = mdl__get_u32(&b);
    if (b.rc)
        return b.rc;
    if (version == 1)
        return parse_v1(&b, out);
    if (version != MODEL_VERSION)
        return mdl__err(err, MDL_EVERSION,
                        "%s: model file version %u; this build reads versions 1 and %d (a newer "
                        "meshsteer wrote it, or retrain the model with this one)",
                        name, version, MODEL_VERSION);
    if (!mdl__kind_ops((int)word))
        return mdl__err(err, MDL_EVERSION,
                        "%s: the primary model kind %u is unknown to this build of meshsteer", name,
                        word);
    return parse_v2(&b, (int)word, out);
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
