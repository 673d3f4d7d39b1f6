/* c3d.c - C3D motion-capture files: reader for all processor types, float writer.
 *
 * Implements the C3D format as described in "The C3D File Format - A Technical User Guide"
 * (Motion Lab Systems, c3d.org). The file is a sequence of 512-byte blocks:
 *   block 1      header: byte 0 = first parameter block, byte 1 = key 0x50; 16-bit words
 *                2 points, 3 analog samples per 3D frame, 4/5 first/last frame, 7-8 scale (float),
 *                9 DATA_START block, 11-12 frame rate (float).
 *   param block  4-byte section header (byte 3 = processor: 84 Intel, 85 DEC/VAX, 86 SGI/MIPS),
 *                then records: signed name length, signed group id (<0 defines a group, >0 a
 *                parameter of that group), name, int16 offset to the next record, and for
 *                parameters type (-1 char, 1 byte, 2 int16, 4 float), dimensions and data.
 *   data         frames of (x, y, z, residual) per point followed by the frame's analog samples,
 *                int16 (x scale) or float32 (when the scale is negative).
 * Intel and DEC are little-endian, MIPS big-endian. DEC floats are VAX F_floating: the 16-bit
 * halves are swapped relative to IEEE little-endian and the exponent bias is 128 instead of 126,
 * so the value is IEEE(word-swapped bits) / 4.
 *
 * Reader rules (where files disagree with themselves):
 *   - points: the header count; POINT:USED must agree when present. Files without a POINT group
 *     (e.g. phasespace_sample.c3d) are read from the header alone. A count greater than both the
 *     labels and the points the data section could hold (the file holds no frame of them) is
 *     rejected.
 *   - storage: the sign of the header scale picks int16 or float; the int16 scale factor is
 *     |POINT:SCALE| (|header scale| without the parameter).
 *   - units: POINT:UNITS "mm", "cm" or "m" (also spelled out); missing means mm.
 *   - rate: POINT:RATE, else the header rate.
 *   - frames: the header announces last - first + 1 and POINT:FRAMES (read unsigned; a float is
 *     accepted for files longer than 65535 frames) may announce another count. The reader takes
 *     the larger announced count, bounded by the whole frames the data section holds up to the
 *     end of the file; a file that holds fewer frames than the smaller announced count is
 *     rejected as truncated.
 *   - validity: a sample whose residual word is negative (conventionally -1), or whose float
 *     coordinates are not finite, is invalid.
 *   - labels: POINT:LABELS, continued by LABELS2, LABELS3, ... when a file has more points than one
 *     parameter holds; entries beyond the point count are ignored; labels are trimmed of spaces;
 *     missing labels become "M<i>" (1-based); a repeated label gets a suffix: the second "RKNE"
 *     becomes "RKNE#2".
 *   - axes: C3D's default up axis is +Z; (x, y, z) becomes (x, z, -y) (markers_internal.h).
 * The writer produces Intel float storage in millimetres, Z up, with POINT:LABELS (LABELS2...
 * past 255 markers), RATE, UNITS, FRAMES, and residual -1 for invalid samples, 0 otherwise. */
#include "formats/markers_internal.h"
#include "model.h"
#include "core/util.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

enum { PROC_INTEL = 84, PROC_DEC = 85, PROC_MIPS = 86 };

typedef struct c3d_param {
    int group;          /* group id, > 0 */
    const uint8_t *nm;  /* name (not NUL-terminated) */
    int nlen;
    int type;           /* -1 char, 1 byte, 2 int16, 4 float */
    int ndims;
    int dims[7];
    size_t off, count;  /* data offset in the file, number of elements */
} c3d_param;

typedef struct c3d_group {
    int id;
    const uint8_t *nm;
    int nlen;
} c3d_group;

typedef struct c3d {
    const uint8_t *b;
    size_t len;
    int proc;
    const char *name;
    c3d_param *params;
    int nparams, cparams;
    c3d_group *groups;
    int ngroups, cgroups;
} c3d;

static unsigned rd_u16(const c3d *c, size_t off)
{
    const uint8_t *p = c->b + off;
    return c->proc == PROC_MIPS ? (unsigned)p[0] << 8 | p[1] : (unsigned)p[1] << 8 | p[0];
}

static int rd_i16(const c3d *c, size_t off)
{
    unsigned u = rd_u16(c, off);
    return u >= 32768u ? (int)u - 65536 : (int)u;
}

static float rd_f32(const c3d *c, size_t off)
{
    const uint8_t *p = c->b + off;
    uint32_t u;
    if (c->proc == PROC_MIPS)
        u = (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
    else if (c->proc == PROC_DEC)
        u = (uint32_t)p[1] << 24 | (uint32_t)p[0] << 16 | (uint32_t)p[3] << 8 | p[2];
    else
        u = (uint32_t)p[3] << 24 | (uint32_t)p[2] << 16 | (uint32_t)p[1] << 8 | p[0];
    float f;
    memcpy(&f, &u, sizeof f);
    return c->proc == PROC_DEC ? f / 4.0f : f;
}

static int name_eq(const uint8_t *nm, int nlen, const char *s)
{
    size_t n = strlen(s);
    if ((size_t)nlen != n)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (toupper(nm[i]) != toupper((unsigned char)s[i]))
            return 0;
    return 1;
}

static int grow(void **arr, int *cap, int n, size_t elem)
{
    if (n < *cap)
        return 0;
    int nc = *cap ? *cap * 2 : 32;
    void *p = realloc(*arr, (size_t)nc * elem);
    if (!p)
        return -ENOMEM;
    *arr = p;
    *cap = nc;
    return 0;
}

/* Walks the parameter records from byte `start` up to byte `end` (the end of the section). */
static int parse_params(c3d *c, size_t start, size_t end, char *err)
{
    size_t off = start;
    while (off + 2 <= end) {
        int nlen = (int8_t)c->b[off];
        int gid = (int8_t)c->b[off + 1];
        if (nlen == 0)
            break;
        int n = abs(nlen);
        size_t p = off + 2 + (size_t)n;
        if (p + 2 > end)
            return mdl__err(err, MDL_EFORMAT,
                            "%s: byte %zu: parameter record runs past the end of the parameter section",
                            c->name, off);
        int next = rd_i16(c, p);
        if (next < 0)
            return mdl__err(err, MDL_EFORMAT,
                            "%s: byte %zu: negative offset %d to the next parameter record",
                            c->name, p, next);
        if (gid < 0) {
            if (grow((void **)&c->groups, &c->cgroups, c->ngroups, sizeof *c->groups))
                return mdl__err(err, -ENOMEM, "%s: out of memory", c->name);
            c->groups[c->ngroups++] = (c3d_group){-gid, c->b + off + 2, n};
        } else if (gid > 0) {
            if (p + 4 > end)
                return mdl__err(err, MDL_EFORMAT,
                                "%s: byte %zu: parameter record runs past the end of the parameter "
                                "section", c->name, off);
            c3d_param q = {.group = gid, .nm = c->b + off + 2, .nlen = n};
            q.type = (int8_t)c->b[p + 2];
            q.ndims = c->b[p + 3];
            if (q.type != -1 && q.type != 1 && q.type != 2 && q.type != 4)
                return mdl__err(err, MDL_EFORMAT, "%s: byte %zu: parameter %.*s has type %d",
                                c->name, p + 2, n, (const char *)q.nm, q.type);
            if (q.ndims > 7)
                return mdl__err(err, MDL_EFORMAT,
                                "%s: byte %zu: parameter %.*s has %d dimensions (at most 7)",
                                c->name, p + 3, n, (const char *)q.nm, q.ndims);
            if (p + 4 + (size_t)q.ndims > end)
                return mdl__err(err, MDL_EFORMAT,
                                "%s: byte %zu: parameter record runs past the end of the parameter "
                                "section", c->name, off);
            size_t count = 1;
            for (int d = 0; d < q.ndims; d++) {
                q.dims[d] = c->b[p + 4 + d];
                count *= (size_t)q.dims[d];
            }
            q.off = p + 4 + (size_t)q.ndims;
            q.count = count;
            size_t bytes = count * (size_t)abs(q.type);
            if (q.off + bytes > end)
                return mdl__err(err, MDL_EFORMAT,
                                "%s: byte %zu: data of parameter %.*s (%zu bytes) runs past the "
                                "end of the parameter section",
                                c->name, q.off, n, (const char *)q.nm, bytes);
            if (grow((void **)&c->params, &c->cparams, c->nparams, sizeof *c->params))
                return mdl__err(err, -ENOMEM, "%s: out of memory", c->name);
            c->params[c->nparams++] = q;
        }
        if (next == 0)
            break;
        off = p + (size_t)next;
    }
    return 0;
}

static const c3d_param *find_param(const c3d *c, const char *group, const char *name)
{
    for (int g = 0; g < c->ngroups; g++) {
        if (!name_eq(c->groups[g].nm, c->groups[g].nlen, group))
            continue;
        for (int i = 0; i < c->nparams; i++)
            if (c->params[i].group == c->groups[g].id &&
                name_eq(c->params[i].nm, c->params[i].nlen, name))
                return &c->params[i];
    }
    return NULL;
}

/* Element k of a numeric parameter as a double (int16 read signed unless `unsigned16`). */
static double param_num(const c3d *c, const c3d_param *q, size_t k, int unsigned16)
{
    switch (q->type) {
    case 1:
        return c->b[q->off + k];
    case 2:
        return unsigned16 ? (double)rd_u16(c, q->off + 2 * k) : (double)rd_i16(c, q->off + 2 * k);
    case 4:
        return rd_f32(c, q->off + 4 * k);
    default:
        return NAN;
    }
}

static int c3d_units(const c3d *c, double *scale, char *err)
{
    const c3d_param *q = find_param(c, "POINT", "UNITS");
    *scale = 1e-3;
    if (!q || q->type != -1 || q->count == 0)
        return 0;
    size_t w = q->ndims >= 1 ? (size_t)q->dims[0] : 1;
    if (w > q->count)
        w = q->count;
    char u[64];
    size_t n = 0;
    for (size_t i = 0; i < w && n + 1 < sizeof u; i++) {
        char ch = (char)c->b[q->off + i];
        if (ch == 0)
            break;
        if (!isspace((unsigned char)ch))
            u[n++] = (char)tolower((unsigned char)ch);
    }
    u[n] = 0;
    if (n == 0 || !strcmp(u, "mm") || !strncmp(u, "millimet", 8))
        *scale = 1e-3;
    else if (!strcmp(u, "cm") || !strncmp(u, "centimet", 8))
        *scale = 1e-2;
    else if (!strcmp(u, "m") || !strcmp(u, "meter") || !strcmp(u, "meters") ||
             !strcmp(u, "metre") || !strcmp(u, "metres"))
        *scale = 1;
    else
        return mdl__err(err, MDL_EFORMAT,
                        "%s: byte %zu: POINT:UNITS '%s' is not mm, cm or m (set a scale to read "
                        "it anyway)",
                        c->name, q->off, u);
    return 0;
}

/* The k-th (from 1) of POINT:LABELS, LABELS2, ...: a character array of labels *w characters
 * wide; NULL where the run of them ends (missing, not characters, or of width 0). */
static const c3d_param *c3d_labels_param(const c3d *c, int k, size_t *w)
{
    char pname[32];
    if (k == 1)
        snprintf(pname, sizeof pname, "LABELS");
    else
        snprintf(pname, sizeof pname, "LABELS%d", k);
    const c3d_param *q = find_param(c, "POINT", pname);
    if (!q || q->type != -1)
        return NULL;
    *w = q->ndims >= 1 ? (size_t)q->dims[0] : 1;
    return *w ? q : NULL;
}

/* The number of labels POINT:LABELS, LABELS2, ... hold. */
static size_t c3d_label_count(const c3d *c)
{
    size_t total = 0, w;
    for (int k = 1;; k++) {
        const c3d_param *q = c3d_labels_param(c, k, &w);
        if (!q)
            break;
        total += q->count / w;
    }
    return total;
}

/* Copies labels from POINT:LABELS, LABELS2, ... into m. */
static int c3d_labels(const c3d *c, mdl_markers *m)
{
    int filled = 0;
    for (int k = 1; filled < m->count; k++) {
        size_t w;
        const c3d_param *q = c3d_labels_param(c, k, &w);
        if (!q)
            break;
        size_t n = q->count / w;
        for (size_t i = 0; i < n && filled < m->count; i++, filled++)
            if (mdl__markers_set_name(m, filled, (const char *)c->b + q->off + i * w, w))
                return -ENOMEM;
    }
    return mdl__markers_unique_names(m);
}

int mdl_markers_parse_c3d(const uint8_t *buf, size_t len, const char *name,
                          const mdl_marker_opts *o, mdl_markers **out, char *err)
{
    *out = NULL;
    if (!name)
        name = "<c3d>";
    c3d c = {.b = buf, .len = len, .name = name};
    if (len < 512)
        return mdl__err(err, MDL_EFORMAT, "%s: %zu bytes is shorter than the 512-byte C3D header",
                        name, len);
    if (buf[1] != 0x50)
        return mdl__err(err, MDL_EFORMAT, "%s: byte 1 is 0x%02x, not the C3D key 0x50", name,
                        buf[1]);
    if (buf[0] < 2)
        return mdl__err(err, MDL_EFORMAT, "%s: byte 0: parameter section at block %d (must be >= 2)",
                        name, buf[0]);
    size_t pstart = 512 * (size_t)(buf[0] - 1);
    if (pstart + 4 > len)
        return mdl__err(err, MDL_EFORMAT,
                        "%s: byte 0: parameter section at block %d starts past the end of the file",
                        name, buf[0]);
    c.proc = buf[pstart + 3];
    if (c.proc != PROC_INTEL && c.proc != PROC_DEC && c.proc != PROC_MIPS)
        return mdl__err(err, MDL_EFORMAT,
                        "%s: byte %zu: processor type %d is not 84 (Intel), 85 (DEC) or 86 (MIPS)",
                        name, pstart + 3, c.proc);

    unsigned npoints = rd_u16(&c, 2), nanalog = rd_u16(&c, 4);
    unsigned first = rd_u16(&c, 6), last = rd_u16(&c, 8);
    float hscale = rd_f32(&c, 12);
    unsigned data_start = rd_u16(&c, 16);
    float hrate = rd_f32(&c, 20);
    if (!isfinite(hscale))
        return mdl__err(err, MDL_EFORMAT, "%s: byte 12: header scale is not a finite number", name);
    if (data_start < 2)
        return mdl__err(err, MDL_EFORMAT, "%s: byte 16: DATA_START block %u (must be >= 2)", name,
                        data_start);

    /* The parameter section: byte 2 of its header counts its blocks, but files understate it
     * (Dance.c3d says 3 blocks and its LABELS run into the 4th; phasespace_sample.c3d says 0).
     * The section is taken to extend to the data section when that follows it. */
    size_t pend = pstart + 512 * (size_t)buf[pstart + 2];
    size_t doff = 512 * (size_t)(data_start - 1);
    if (doff > pstart && doff > pend)
        pend = doff;
    if (pend <= pstart)
        pend = len;
    if (pend > len)
        return mdl__err(err, MDL_EFORMAT,
                        "%s: byte %zu: truncated: the parameter section at block %d (up to byte "
                        "%zu) runs past the end of the file (%zu bytes)",
                        name, pstart + 2, buf[0], pend, len);
    int r = parse_params(&c, pstart + 4, pend, err);
    mdl_markers *m = NULL;
    if (r != 0)
        goto done;

    const c3d_param *q = find_param(&c, "POINT", "USED");
    if (q && q->type != -1 && q->count >= 1) {
        double used = param_num(&c, q, 0, 1);
        if (used != npoints) {
            r = mdl__err(err, MDL_EFORMAT,
                         "%s: byte %zu: POINT:USED %g disagrees with the header's %u points", name,
                         q->off, used, npoints);
            goto done;
        }
    }
    int is_float = hscale < 0;
    double iscale = fabs(hscale);
    q = find_param(&c, "POINT", "SCALE");
    if (q && q->type != -1 && q->count >= 1) {
        double s = param_num(&c, q, 0, 0);
        if (isfinite(s) && s != 0)
            iscale = fabs(s);
    }
    if (!is_float && iscale == 0) {
        r = mdl__err(err, MDL_EFORMAT, "%s: byte 12: integer storage with scale 0", name);
        goto done;
    }
    double rate = hrate;
    q = find_param(&c, "POINT", "RATE");
    if (q && q->type != -1 && q->count >= 1) {
        double v = param_num(&c, q, 0, 0);
        if (isfinite(v) && v > 0)
            rate = v;
    }
    if (!isfinite(rate) || rate < 0 || rate > 1e7)
        rate = 0;

    double unit;
    if (!(o && o->scale != 0)) {
        r = c3d_units(&c, &unit, err);
        if (r != 0)
            goto done;
    } else {
        unit = o->scale;
    }
    double scale;
    int up;
    r = mdl__marker_opts_resolve(o, unit, MDL_UP_Z, &scale, &up, name, err);
    if (r != 0)
        goto done;

    /* frames: the larger announced count, bounded by what the data section holds */
    size_t word = is_float ? 4 : 2;
    size_t frame_bytes = (4 * (size_t)npoints + nanalog) * word;
    size_t data_off = 512 * (size_t)(data_start - 1);
    size_t hdr_frames = last >= first ? (size_t)(last - first) + 1 : 0;
    size_t par_frames = hdr_frames;
    q = find_param(&c, "POINT", "FRAMES");
    if (q && q->type != -1 && q->count >= 1) {
        double v = param_num(&c, q, 0, 1);
        if (isfinite(v) && v >= 0 && v < 1e9)
            par_frames = (size_t)v;
    }
    size_t lo = hdr_frames < par_frames ? hdr_frames : par_frames;
    size_t hi = hdr_frames < par_frames ? par_frames : hdr_frames;
    size_t avail = hi;
    if (frame_bytes > 0)
        avail = data_off >= len ? 0 : (len - data_off) / frame_bytes;
    if (avail < lo) {
        r = mdl__err(err, MDL_EFORMAT,
                     "%s: byte %zu: truncated: the header announces %zu frames and POINT:FRAMES "
                     "%zu, but the data section (block %u, %zu bytes a frame) holds only %zu",
                     name, len, hdr_frames, par_frames, data_start, frame_bytes, avail);
        goto done;
    }
    size_t frames = hi < avail ? hi : avail;
    if (frames > (size_t)1 << 30) {
        r = mdl__err(err, -EFBIG, "%s: %zu frames is too many", name, frames);
        goto done;
    }
    /* every declared point is in the file, as a label or as data of a whole frame (a 4.8 KB file
     * declaring 65,302 points and no frame, ../shared/repro) */
    size_t data_points = data_off < len ? (len - data_off) / (4 * word) : 0;
    size_t labels = c3d_label_count(&c);
    if (npoints > data_points && npoints > labels) {
        r = mdl__err(err, MDL_EFORMAT,
                     "%s: byte 2: the header declares %u points, but the file holds data for %zu "
                     "and labels for %zu",
                     name, npoints, data_points, labels);
        goto done;
    }
    r = mdl_markers_create((int)frames, (int)npoints, rate, &m, err);
    if (r != 0) {
        /* mdl_markers_create's message does not name the file */
        char tmp[MDL_ERR_LEN];
        snprintf(tmp, sizeof tmp, "%s", err ? err : "");
        r = mdl__err(err, r, "%s: %s", name, tmp);
        goto done;
    }
    if (c3d_labels(&c, m) != 0) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    for (size_t f = 0; f < frames; f++) {
        size_t base = data_off + f * frame_bytes;
        for (unsigned i = 0; i < npoints; i++) {
            size_t at = base + (size_t)i * 4 * word;
            float *p = m->P + 3 * (f * npoints + i);
            uint8_t *v = m->valid + f * npoints + i;
            if (is_float) {
                float x = rd_f32(&c, at), y = rd_f32(&c, at + 4), z = rd_f32(&c, at + 8);
                float res = rd_f32(&c, at + 12);
                *v = res >= 0 && isfinite(x) && isfinite(y) && isfinite(z);
                p[0] = x, p[1] = y, p[2] = z;
            } else {
                int res = rd_i16(&c, at + 6);
                *v = res >= 0;
                p[0] = (float)(rd_i16(&c, at) * iscale);
                p[1] = (float)(rd_i16(&c, at + 2) * iscale);
                p[2] = (float)(rd_i16(&c, at + 4) * iscale);
            }
        }
    }
    mdl__markers_convert(m, scale, up);
    *out = m;
    m = NULL;
done:
    mdl_markers_destroy(m);
    free(c.params);
    free(c.groups);
    return r;
}

/* ------------------------------------------------------------------ writer */

typedef struct wbuf {
    uint8_t *b;
    size_t n, cap;
    int oom;
} wbuf;

static void put(wbuf *w, const void *p, size_t n)
{
    if (w->oom)
        return;
    if (w->n + n > w->cap) {
        size_t nc = w->cap ? w->cap : 4096;
        while (nc < w->n + n)
            nc *= 2;
        uint8_t *b = realloc(w->b, nc);
        if (!b) {
            w->oom = 1;
            return;
        }
        w->b = b;
        w->cap = nc;
    }
    memcpy(w->b + w->n, p, n);
    w->n += n;
}

static void put_u8(wbuf *w, int v)
{
    uint8_t b = (uint8_t)v;
    put(w, &b, 1);
}

static void put_u16(wbuf *w, unsigned v)
{
    uint8_t b[2] = {(uint8_t)(v & 0xff), (uint8_t)(v >> 8 & 0xff)};
    put(w, b, 2);
}

static void put_f32(wbuf *w, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    uint8_t b[4] = {(uint8_t)u, (uint8_t)(u >> 8), (uint8_t)(u >> 16), (uint8_t)(u >> 24)};
    put(w, b, 4);
}

static void pad_block(wbuf *w)
{
    static const uint8_t zero[512];
    if (w->n % 512)
        put(w, zero, 512 - w->n % 512);
}

static void put_group(wbuf *w, int id, const char *name)
{
    put_u8(w, (int)strlen(name));
    put_u8(w, -id);
    put(w, name, strlen(name));
    put_u16(w, 3); /* offset field, description length byte: next record follows */
    put_u8(w, 0);
}

/* A parameter record; `last` writes 0 as the offset to the next record. */
static void put_param(wbuf *w, int group, const char *name, int type, int ndims, const int *dims,
                      const void *data, int last)
{
    size_t count = 1;
    for (int d = 0; d < ndims; d++)
        count *= (size_t)dims[d];
    size_t bytes = count * (size_t)abs(type);
    put_u8(w, (int)strlen(name));
    put_u8(w, group);
    put(w, name, strlen(name));
    put_u16(w, last ? 0 : (unsigned)(2 + 1 + 1 + ndims + bytes + 1));
    put_u8(w, type);
    put_u8(w, ndims);
    for (int d = 0; d < ndims; d++)
        put_u8(w, dims[d]);
    put(w, data, bytes);
    put_u8(w, 0); /* no description */
}

static void put_param_i16(wbuf *w, int group, const char *name, int v)
{
    uint8_t b[2] = {(uint8_t)(v & 0xff), (uint8_t)((unsigned)v >> 8 & 0xff)};
    put_param(w, group, name, 2, 0, NULL, b, 0);
}

static void put_param_f32(wbuf *w, int group, const char *name, float f, int last)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    uint8_t b[4] = {(uint8_t)u, (uint8_t)(u >> 8), (uint8_t)(u >> 16), (uint8_t)(u >> 24)};
    put_param(w, group, name, 4, 0, NULL, b, last);
}

int mdl_markers_write_c3d(const char *path, const mdl_markers *m, char *err)
{
    if (!m || m->count < 0 || m->frames < 0)
        return mdl__err(err, -EINVAL, "%s: no marker set to write", path);
    if (m->count > 65535)
        return mdl__err(err, -EINVAL, "%s: C3D holds at most 65535 points, not %d", path,
                        m->count);
    /* labels: fixed width (at most 255 bytes), at most 255 per LABELS parameter */
    size_t width = 1;
    for (int i = 0; i < m->count; i++) {
        size_t n = m->names[i] ? strlen(m->names[i]) : 0;
        if (n > width)
            width = n;
    }
    if (width > 255)
        width = 255;
    const float rate = (float)(m->fps > 0 ? m->fps : 0);
    const float scale = -0.1f; /* float storage; 0.1 mm is the nominal precision */
    wbuf w = {0};

    /* parameter section, starting at block 2 */
    wbuf p = {0};
    put_u8(&p, 1);
    put_u8(&p, 0x50);
    put_u8(&p, 0); /* number of blocks, patched below */
    put_u8(&p, PROC_INTEL);
    put_group(&p, 1, "POINT");
    put_param_i16(&p, 1, "USED", m->count);
    if (m->frames <= 65535) {
        put_param_i16(&p, 1, "FRAMES", m->frames);
    } else {
        put_param_f32(&p, 1, "FRAMES", (float)m->frames, 0);
    }
    put_param_f32(&p, 1, "SCALE", scale, 0);
    put_param_f32(&p, 1, "RATE", rate, 0);
    int udims[1] = {2};
    put_param(&p, 1, "UNITS", -1, 1, udims, "mm", 0);
    int nlabel_params = (m->count + 254) / 255;
    for (int k = 0; k < nlabel_params; k++) {
        int n = m->count - k * 255 < 255 ? m->count - k * 255 : 255;
        char *lab = mdl__calloc((size_t)n * width, 1);
        if (!lab) {
            free(p.b);
            return mdl__err(err, -ENOMEM, "%s: out of memory", path);
        }
        memset(lab, ' ', (size_t)n * width);
        for (int i = 0; i < n; i++) {
            const char *s = m->names[k * 255 + i] ? m->names[k * 255 + i] : "";
            size_t l = strlen(s);
            memcpy(lab + (size_t)i * width, s, l < width ? l : width);
        }
        char pname[32];
        if (k == 0)
            snprintf(pname, sizeof pname, "LABELS");
        else
            snprintf(pname, sizeof pname, "LABELS%d", k + 1);
        int dims[2] = {(int)width, n};
        put_param(&p, 1, pname, -1, 2, dims, lab, 0);
        free(lab);
    }
    put_group(&p, 2, "ANALOG");
    put_param_i16(&p, 2, "USED", 0);
    put_param_f32(&p, 2, "RATE", 0, 1);
    put_u8(&p, 0);
    pad_block(&p);
    size_t pblocks = p.n / 512;
    if (p.oom || pblocks > 255) {
        free(p.b);
        return mdl__err(err, p.oom ? -ENOMEM : -EINVAL,
                        "%s: parameter section of %zu blocks does not fit", path, pblocks);
    }
    p.b[2] = (uint8_t)pblocks;
    unsigned data_start = (unsigned)(2 + pblocks);

    /* header block */
    put_u8(&w, 2);
    put_u8(&w, 0x50);
    put_u16(&w, (unsigned)m->count);
    put_u16(&w, 0);                                  /* analog samples per frame */
    put_u16(&w, 1);                                  /* first frame */
    put_u16(&w, m->frames <= 65535 ? (unsigned)m->frames : 65535u); /* last frame */
    put_u16(&w, 10);                                 /* max interpolation gap */
    put_f32(&w, scale);
    put_u16(&w, data_start);
    put_u16(&w, 0); /* analog samples per 3D frame */
    put_f32(&w, rate);
    pad_block(&w);
    put(&w, p.b, p.n);
    free(p.b);

    for (int f = 0; f < m->frames && !w.oom; f++) {
        for (int i = 0; i < m->count; i++) {
            size_t k = (size_t)f * (size_t)m->count + (size_t)i;
            const float *q = m->P + 3 * k;
            if (m->valid[k]) {
                /* Y up metres -> Z up millimetres: inverse of (x, y, z) -> (x, z, -y) */
                put_f32(&w, q[0] * 1000.0f);
                put_f32(&w, -q[2] * 1000.0f);
                put_f32(&w, q[1] * 1000.0f);
                put_f32(&w, 0.0f);
            } else {
                put_f32(&w, 0.0f);
                put_f32(&w, 0.0f);
                put_f32(&w, 0.0f);
                put_f32(&w, -1.0f);
            }
        }
    }
    pad_block(&w);
    if (w.oom) {
        free(w.b);
        return mdl__err(err, -ENOMEM, "%s: out of memory", path);
    }
    FILE *fp = fopen(path, "wb");
    if (!fp) {
        int e = errno;
        free(w.b);
        return mdl__err(err, -e, "%s: cannot create: %s", path, strerror(e));
    }
    size_t put_n = fwrite(w.b, 1, w.n, fp);
    int e = ferror(fp) ? errno : 0;
    if (fclose(fp) != 0 && !e)
        e = errno ? errno : EIO;
    if (put_n != w.n && !e)
        e = EIO;
    free(w.b);
    if (e)
        return mdl__err(err, -e, "%s: write failed: %s", path, strerror(e));
    return 0;
}
