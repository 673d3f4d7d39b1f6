/* packet.c - OSC 1.0 packets (format in packet.h): a strict, allocation-free walk. */
#include "packet.h"

#include "../drv_err.h"
#include "../drivers.h"

#include <errno.h>
#include <string.h>

static uint32_t be32(const uint8_t *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

static uint64_t be64(const uint8_t *p)
{
    return (uint64_t)be32(p) << 32 | be32(p + 4);
}

/* Length of the padded OSC string at p (within n bytes): the string, its NUL, then NULs up to a
 * multiple of 4. 0 when it is not terminated or not padded with NULs within n. */
static size_t padded_string(const uint8_t *p, size_t n)
{
    const uint8_t *nul = memchr(p, '\0', n);
    if (!nul)
        return 0;
    size_t len = (size_t)(nul - p) + 1, pad = (len + 3) & ~(size_t)3;
    if (pad > n)
        return 0;
    for (size_t i = len; i < pad; i++)
        if (p[i])
            return 0;
    return pad;
}

static int walk_message(const uint8_t *p, size_t n, size_t at, const drv_osc_visitor *v,
                        char *err)
{
    size_t a = padded_string(p, n);
    if (a == 0 || p[0] != '/')
        return drv__err(err, -EINVAL, "osc: byte %zu: address is not a padded '/...' string", at);
    if (a == n || p[a] != ',')
        return drv__err(err, -EINVAL, "osc %s: byte %zu: no type tag string", (const char *)p,
                        at + a);
    size_t t = padded_string(p + a, n - a);
    if (t == 0)
        return drv__err(err, -EINVAL, "osc %s: byte %zu: type tag string not padded",
                        (const char *)p, at + a);
    drv_osc_msg m;
    m.address = (const char *)p;
    m.types = (const char *)p + a + 1;
    m.argc = 0;
    size_t off = a + t;
    int open = 0;
    for (const char *c = m.types; *c; c++, m.argc++) {
        if (m.argc < DRV_OSC_MAX_ARGS)
            m.arg[m.argc] = p + off;
        size_t need;
        switch (*c) {
        case 'i': case 'f': case 'c': case 'r': case 'm': need = 4; break;
        case 'h': case 't': case 'd': need = 8; break;
        case 'T': case 'F': case 'N': case 'I': need = 0; break;
        case '[': open++; need = 0; break;
        case ']':
            if (--open < 0)
                return drv__err(err, -EINVAL, "osc %s: ']' without '['", m.address);
            need = 0;
            break;
        case 's': case 'S':
            need = off < n ? padded_string(p + off, n - off) : 0;
            if (need == 0)
                return drv__err(err, -EINVAL, "osc %s: argument %d: string runs past the end",
                                m.address, m.argc);
            break;
        case 'b':
            if (n - off < 4)
                return drv__err(err, -EINVAL, "osc %s: argument %d: blob size past the end",
                                m.address, m.argc);
            need = be32(p + off);
            if (need > n - off - 4)
                return drv__err(err, -EINVAL, "osc %s: argument %d: blob of %zu bytes past the end",
                                m.address, m.argc, need);
            {
                /* padded to 4 bytes with zeros, as strings are (OSC 1.0; liblo refuses others) */
                size_t len = need;
                need = 4 + ((len + 3) & ~(size_t)3);
                for (size_t i = 4 + len; i < need && off + i < n; i++)
                    if (p[off + i])
                        return drv__err(err, -EINVAL, "osc %s: argument %d: blob padding is not "
                                        "zero", m.address, m.argc);
            }
            break;
        default:
            return drv__err(err, -EINVAL, "osc %s: argument %d: unknown type tag '%c' (0x%02x)",
                            m.address, m.argc, *c >= 32 && *c < 127 ? *c : '?',
                            (unsigned)(unsigned char)*c);
        }
        if (need > n - off)
            return drv__err(err, -EINVAL, "osc %s: argument %d ('%c') runs past the end",
                            m.address, m.argc, *c);
        off += need;
    }
    if (open)
        return drv__err(err, -EINVAL, "osc %s: '[' without ']'", m.address);
    if (off != n)
        return drv__err(err, -EINVAL, "osc %s: %zu bytes after the last argument", m.address,
                        n - off);
    if (v && v->message)
        v->message(v->user, &m);
    return 0;
}

static int walk(const uint8_t *p, size_t n, size_t at, int depth, const drv_osc_visitor *v,
                char *err)
{
    if (n == 0 || n % 4)
        return drv__err(err, -EINVAL, "osc: byte %zu: element of %zu bytes (not a positive multiple of 4)",
                        at, n);
    if (n >= 8 && !memcmp(p, "#bundle", 8)) {
        if (depth >= DRV_OSC_MAX_DEPTH)
            return drv__err(err, -EINVAL, "osc: byte %zu: bundles nested deeper than %d", at,
                            DRV_OSC_MAX_DEPTH);
        if (n < 16)
            return drv__err(err, -EINVAL, "osc: byte %zu: bundle without a time tag", at);
        uint64_t tt = be64(p + 8);
        if (v && v->bundle)
            v->bundle(v->user, 1, depth, tt);
        for (size_t off = 16; off < n;) {
            if (n - off < 4)
                return drv__err(err, -EINVAL, "osc: byte %zu: bundle element size past the end",
                                at + off);
            size_t e = be32(p + off);
            off += 4;
            if (e > n - off)
                return drv__err(err, -EINVAL, "osc: byte %zu: bundle element of %zu bytes past the end",
                                at + off - 4, e);
            int r = walk(p + off, e, at + off, depth + 1, v, err);
            if (r)
                return r;
            off += e;
        }
        if (v && v->bundle)
            v->bundle(v->user, 0, depth, tt);
        return 0;
    }
    if (p[0] == '#')
        return drv__err(err, -EINVAL, "osc: byte %zu: '#' packet that is not a bundle", at);
    return walk_message(p, n, at, v, err);
}

int drv_osc_packet_walk(const uint8_t *buf, size_t len, const drv_osc_visitor *v, char *err)
{
    if (!buf)
        return drv__err(err, -EINVAL, "osc: NULL packet");
    int r = walk(buf, len, 0, 0, NULL, err); /* check all first: a bad packet is dropped whole */
    if (r || !v)
        return r;
    return walk(buf, len, 0, 0, v, err);
}

int drv_osc_arg_number(const drv_osc_msg *m, int i, double *out)
{
    if (i < 0 || i >= m->argc || i >= DRV_OSC_MAX_ARGS)
        return -EINVAL;
    const uint8_t *p = m->arg[i];
    switch (m->types[i]) {
    case 'i': *out = (double)(int32_t)be32(p); return 0;
    case 'h': *out = (double)(int64_t)be64(p); return 0;
    case 'f': {
        uint32_t u = be32(p);
        float f;
        memcpy(&f, &u, sizeof f);
        *out = f;
        return 0;
    }
    case 'd': {
        uint64_t u = be64(p);
        double d;
        memcpy(&d, &u, sizeof d);
        *out = d;
        return 0;
    }
    case 'T': *out = 1; return 0;
    case 'F': *out = 0; return 0;
    }
    return -EINVAL;
}

int drv_osc_arg_string(const drv_osc_msg *m, int i, const char **out)
{
    if (i < 0 || i >= m->argc || i >= DRV_OSC_MAX_ARGS)
        return -EINVAL;
    if (m->types[i] != 's' && m->types[i] != 'S')
        return -EINVAL;
    *out = (const char *)m->arg[i];
    return 0;
}
