/* capture.c - OSC captures: a file of timed OSC datagrams (drivers.h "OSC captures"; the layout
 * is in docs/FORMATS.md), its reader, its writer, and the encoder that turns a marker recording
 * into the datagrams a sender of the osc: source's address space sends (docs/OSC.md: one bundle
 * of "/marker NAME x y z" messages per frame, "/marker NAME" for a marker not seen).
 *
 * File layout, all integers little-endian:
 *   header  "MSOSCCAP" (8 bytes), u32 version (1), u32 datagrams
 *   record  u64 time (microseconds since the capture's start, non-decreasing), u32 length
 *           (4 .. DRV_OSC_CAPTURE_MAX_DGRAM, a multiple of 4), then `length` bytes: one OSC 1.0
 *           packet, checked whole by the packet walker (packet.h)
 * Nothing may follow the last record. The datagram bytes are the ones on the wire (OSC is
 * big-endian), so a capture replays by sending each record's bytes as one UDP datagram. */
#include "../drivers.h"

#include "../drv_err.h"
#include "model.h"
#include "packet.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CAP_MAGIC "MSOSCCAP"
#define CAP_HEADER 16
#define CAP_RECORD 12

static uint32_t rd_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint64_t rd_u64(const uint8_t *p)
{
    return (uint64_t)rd_u32(p) | (uint64_t)rd_u32(p + 4) << 32;
}

static void wr_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> 8 * i);
}

void drv_osc_capture_destroy(drv_osc_capture *c)
{
    if (!c)
        return;
    free(c->t_us);
    free(c->off);
    free(c->len);
    free(c->data);
    free(c);
}

/* An empty capture with room for n datagrams of `bytes` bytes in all. */
static drv_osc_capture *capture_alloc(int n, size_t bytes)
{
    drv_osc_capture *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    c->t_us = malloc(sizeof *c->t_us * (size_t)(n ? n : 1));
    c->off = malloc(sizeof *c->off * (size_t)(n ? n : 1));
    c->len = malloc(sizeof *c->len * (size_t)(n ? n : 1));
    c->data = malloc(bytes ? bytes : 1);
    if (!c->t_us || !c->off || !c->len || !c->data) {
        drv_osc_capture_destroy(c);
        return NULL;
    }
    return c;
}

int drv_osc_capture_parse(const uint8_t *buf, size_t len, const char *name, drv_osc_capture **out,
                          char *err)
{
    *out = NULL;
    if (len < CAP_HEADER || memcmp(buf, CAP_MAGIC, 8))
        return drv__err(err, MDL_EFORMAT, "%s: byte 0: not an OSC capture (no \"" CAP_MAGIC
                        "\" header)", name);
    uint32_t version = rd_u32(buf + 8), n = rd_u32(buf + 12);
    if (version != 1)
        return drv__err(err, MDL_EFORMAT, "%s: byte 8: capture version %u (this build reads 1)",
                        name, version);
    /* every record takes at least CAP_RECORD + 4 bytes: a count the file cannot hold is refused
     * before anything is allocated for it */
    if (n > (len - CAP_HEADER) / (CAP_RECORD + 4))
        return drv__err(err, MDL_EFORMAT, "%s: byte 12: %u datagrams cannot fit in %zu bytes", name,
                        n, len);
    drv_osc_capture *c = capture_alloc((int)n, len - CAP_HEADER);
    if (!c)
        return drv__err(err, -ENOMEM, "%s: out of memory for %u datagrams", name, n);
    size_t at = CAP_HEADER, data = 0;
    char why[DRV_ERR_LEN];
    for (uint32_t i = 0; i < n; i++) {
        if (len - at < CAP_RECORD) {
            drv_osc_capture_destroy(c);
            return drv__err(err, MDL_EFORMAT, "%s: byte %zu: datagram %u of %u: the file ends inside "
                            "its record header", name, at, i, n);
        }
        uint64_t t = rd_u64(buf + at);
        uint32_t dlen = rd_u32(buf + at + 8);
        const char *bad = NULL;
        if (i > 0 && t < c->t_us[i - 1])
            bad = "its time is before the previous datagram's";
        else if (dlen < 4 || dlen > DRV_OSC_CAPTURE_MAX_DGRAM || dlen % 4)
            bad = "its length is not a multiple of 4 in 4 .. 65504";
        else if (len - at - CAP_RECORD < dlen)
            bad = "the file ends inside it";
        if (bad) {
            drv_osc_capture_destroy(c);
            return drv__err(err, MDL_EFORMAT, "%s: byte %zu: datagram %u (length %u): %s", name, at,
                            i, dlen, bad);
        }
        at += CAP_RECORD;
        if (drv_osc_packet_walk(buf + at, dlen, NULL, why)) {
            drv_osc_capture_destroy(c);
            return drv__err(err, MDL_EFORMAT, "%s: byte %zu: datagram %u is not OSC: %s", name, at,
                            i, why);
        }
        c->t_us[i] = t;
        c->off[i] = data;
        c->len[i] = dlen;
        memcpy(c->data + data, buf + at, dlen);
        data += dlen;
        at += dlen;
    }
    if (at != len) {
        drv_osc_capture_destroy(c);
        return drv__err(err, MDL_EFORMAT, "%s: byte %zu: %zu bytes after the last datagram", name, at,
                        len - at);
    }
    c->count = (int)n;
    *out = c;
    return 0;
}

int drv_osc_capture_read(const char *path, drv_osc_capture **out, char *err)
{
    *out = NULL;
    FILE *f = fopen(path, "rb");
    if (!f)
        return drv__err(err, -errno, "%s: %s", path, strerror(errno));
    uint8_t *buf = NULL;
    long n = -1;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0 &&
        (buf = malloc((size_t)n + 1)) != NULL && fread(buf, 1, (size_t)n, f) == (size_t)n) {
        fclose(f);
        int r = drv_osc_capture_parse(buf, (size_t)n, path, out, err);
        free(buf);
        return r;
    }
    fclose(f);
    free(buf);
    return drv__err(err, buf || n < 0 ? -EIO : -ENOMEM, "%s: cannot read the file", path);
}

int drv_osc_capture_write(const char *path, const drv_osc_capture *c, char *err)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return drv__err(err, -errno, "%s: cannot create: %s", path, strerror(errno));
    uint8_t h[CAP_HEADER];
    memcpy(h, CAP_MAGIC, 8);
    wr_u32(h + 8, 1);
    wr_u32(h + 12, (uint32_t)c->count);
    int ok = fwrite(h, 1, sizeof h, f) == sizeof h;
    for (int i = 0; ok && i < c->count; i++) {
        uint8_t r[CAP_RECORD];
        wr_u32(r, (uint32_t)c->t_us[i]);
        wr_u32(r + 4, (uint32_t)(c->t_us[i] >> 32));
        wr_u32(r + 8, c->len[i]);
        ok = fwrite(r, 1, sizeof r, f) == sizeof r &&
             fwrite(c->data + c->off[i], 1, c->len[i], f) == c->len[i];
    }
    if (fclose(f) != 0 || !ok)
        return drv__err(err, -EIO, "%s: write failed", path);
    return 0;
}

/* ------------------------------------------------------------------ the marker encoder */

/* An OSC string: the bytes, a NUL, then NULs to a multiple of 4. */
static size_t put_string(uint8_t *p, const char *s)
{
    size_t n = strlen(s), padded = (n + 4) & ~(size_t)3;
    if (p) {
        memcpy(p, s, n);
        memset(p + n, 0, padded - n);
    }
    return padded;
}

static void put_be32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (24 - 8 * i));
}

/* One "/marker NAME x y z" (or "/marker NAME" when !valid) message at p (NULL: size only). */
static size_t put_marker(uint8_t *p, const char *name, const float *xyz, int valid)
{
    size_t at = put_string(p, "/marker");
    at += put_string(p ? p + at : NULL, valid ? ",sfff" : ",s");
    at += put_string(p ? p + at : NULL, name);
    for (int k = 0; valid && k < 3; k++, at += 4)
        if (p) {
            uint32_t bits;
            memcpy(&bits, &xyz[k], 4);
            put_be32(p + at, bits);
        }
    return at;
}

/* The frame's bundle at p (NULL: size only): "#bundle", time tag 1 (immediately), elements. */
static size_t put_frame(uint8_t *p, const mdl_markers *m, int f)
{
    size_t at = put_string(p, "#bundle");
    if (p) {
        put_be32(p + at, 0);
        put_be32(p + at + 4, 1);
    }
    at += 8;
    for (int k = 0; k < m->count; k++) {
        size_t i = (size_t)f * m->count + k;
        size_t n = put_marker(p ? p + at + 4 : NULL, m->names[k], m->P + 3 * i, m->valid[i]);
        if (p)
            put_be32(p + at, (uint32_t)n);
        at += 4 + n;
    }
    return at;
}

int drv_osc_capture_from_markers(const struct mdl_markers *m, drv_osc_capture **out, char *err)
{
    *out = NULL;
    if (m->frames < 1 || m->count < 1 || !(m->fps > 0 && isfinite(m->fps)))
        return drv__err(err, -EINVAL, "osc capture: a marker recording of %d frames, %d markers at "
                        "%g fps has nothing to send", m->frames, m->count, m->fps);
    size_t total = 0;
    for (int f = 0; f < m->frames; f++) {
        size_t n = put_frame(NULL, m, f);
        if (n > DRV_OSC_CAPTURE_MAX_DGRAM)
            return drv__err(err, -E2BIG, "osc capture: frame %d needs a %zu-byte datagram (at most "
                            "%d)", f, n, DRV_OSC_CAPTURE_MAX_DGRAM);
        total += n;
    }
    drv_osc_capture *c = capture_alloc(m->frames, total);
    if (!c)
        return drv__err(err, -ENOMEM, "osc capture: out of memory for %d frames", m->frames);
    size_t at = 0;
    for (int f = 0; f < m->frames; f++) {
        c->t_us[f] = (uint64_t)llround(f * 1e6 / m->fps);
        c->off[f] = at;
        c->len[f] = (uint32_t)put_frame(c->data + at, m, f);
        at += c->len[f];
    }
    c->count = m->frames;
    *out = c;
    return 0;
}
