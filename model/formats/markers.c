/* markers.c - marker sequences: creation, lookup, reading by file extension, and the shared axis
 * and unit conversion of markers_internal.h.
 *
 * mdl_markers_create names the markers "M1" ... "M<count>" (1-based) and marks every sample
 * invalid; readers replace the names with the file's labels. */
#include "formats/markers_internal.h"
#include "model.h"
#include "core/util.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <sys/stat.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

int mdl_markers_create(int frames, int count, double fps, mdl_markers **out, char *err)
{
    *out = NULL;
    if (frames < 0 || count < 0 || count > MDL__MARKERS_MAX_COUNT || !(fps >= 0) || !isfinite(fps))
        return mdl__err(err, -EINVAL, "markers: invalid size %d frames x %d markers at %g fps",
                        frames, count, fps);
    size_t samples = (size_t)frames * (size_t)count;
    if (samples > MDL__MARKERS_MAX_SAMPLES)
        return mdl__err(err, -EFBIG, "markers: %d frames x %d markers exceeds the limit of %zu samples",
                        frames, count, MDL__MARKERS_MAX_SAMPLES);
    mdl_markers *m = mdl__calloc(1, sizeof *m);
    if (!m)
        return mdl__err(err, -ENOMEM, "markers: out of memory");
    m->frames = frames;
    m->count = count;
    m->fps = fps;
    m->P = mdl__calloc(samples * 3, sizeof *m->P);
    m->valid = mdl__calloc(samples, 1);
    m->names = mdl__calloc((size_t)count, sizeof *m->names);
    if (!m->P || !m->valid || !m->names) {
        mdl_markers_destroy(m);
        return mdl__err(err, -ENOMEM, "markers: out of memory for %zu samples", samples);
    }
    for (int i = 0; i < count; i++) {
        if (mdl__markers_set_name(m, i, "", 0) != 0) {
            mdl_markers_destroy(m);
            return mdl__err(err, -ENOMEM, "markers: out of memory");
        }
    }
    *out = m;
    return 0;
}

void mdl_markers_destroy(mdl_markers *m)
{
    if (!m)
        return;
    if (m->names)
        for (int i = 0; i < m->count; i++)
            free(m->names[i]);
    free(m->names);
    free(m->P);
    free(m->valid);
    free(m->rot);
    free(m->parent);
    free(m);
}

int mdl_markers_find(const mdl_markers *m, const char *name)
{
    if (!m || !name)
        return -1;
    for (int i = 0; i < m->count; i++)
        if (m->names[i] && strcmp(m->names[i], name) == 0)
            return i;
    return -1;
}

/* FILE.amc: its skeleton is FILE.asf, else the .asf in its folder whose stem is the longest prefix
 * of FILE's stem (model.h); FILE.asf alone: the rest pose */
static int read_asf_amc(const char *path, const char *dot, const mdl_marker_opts *o,
                        mdl_markers **out, char *err)
{
    int is_amc = strcasecmp(dot, ".amc") == 0;
    char asf[4096 + 512];
    size_t stem = (size_t)(dot - path);
    if (stem + 5 > sizeof asf)
        return mdl__err(err, -ENAMETOOLONG, "%s: path too long", path);
    if (!is_amc) {
        snprintf(asf, sizeof asf, "%s", path);
    } else {
        memcpy(asf, path, stem);
        memcpy(asf + stem, ".asf", 5);
        struct stat st;
        if (stat(asf, &st) != 0) {
            const char *slash = strrchr(path, '/');
            size_t dlen = slash ? (size_t)(slash - path) : 0;
            const char *base = slash ? slash + 1 : path;
            size_t blen = (size_t)(dot - base), best = 0;
            char dir[4096];
            snprintf(dir, sizeof dir, "%.*s", dlen ? (int)dlen : 1, dlen ? path : ".");
            DIR *d = opendir(dir);
            if (!d)
                return mdl__err(err, -errno, "%s: no skeleton %s, and its folder: %s", path, asf,
                                strerror(errno));
            for (struct dirent *e; (e = readdir(d));) {
                size_t n = strlen(e->d_name);
                if (n < 5 || strcasecmp(e->d_name + n - 4, ".asf") != 0 || n - 4 > blen ||
                    strncmp(e->d_name, base, n - 4) != 0 || n - 4 <= best)
                    continue;
                best = n - 4;
                snprintf(asf, sizeof asf, "%s/%s", dir, e->d_name);
            }
            closedir(d);
            if (best == 0)
                return mdl__err(err, -ENOENT, "%s: no skeleton: neither %.*s.asf nor an .asf whose "
                                "name begins %s", path, (int)stem, path, base);
        }
    }
    char *sb = NULL, *mb = NULL;
    size_t sl = 0, ml = 0;
    int r = mdl__read_file(asf, MDL__MARKERS_MAX_FILE, &sb, &sl, err);
    if (!r && is_amc)
        r = mdl__read_file(path, MDL__MARKERS_MAX_FILE, &mb, &ml, err);
    if (!r)
        r = mdl_markers_parse_asf_amc(sb, sl, mb, ml, is_amc ? path : asf, o, out, err);
    free(sb);
    free(mb);
    return r;
}

int mdl_markers_read(const char *path, const mdl_marker_opts *o, mdl_markers **out, char *err)
{
    *out = NULL;
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash))
        return mdl__err(err, -EINVAL, "%s: no file extension (expected .c3d, .trc, .bvh, .csv, "
                        ".amc or .asf)", path);
    int kind;
    if (strcasecmp(dot, ".c3d") == 0)
        kind = 0;
    else if (strcasecmp(dot, ".trc") == 0)
        kind = 1;
    else if (strcasecmp(dot, ".bvh") == 0)
        kind = 2;
    else if (strcasecmp(dot, ".csv") == 0)
        kind = 3;
    else if (strcasecmp(dot, ".amc") == 0 || strcasecmp(dot, ".asf") == 0)
        return read_asf_amc(path, dot, o, out, err);
    else
        return mdl__err(err, -EINVAL,
                        "%s: unknown marker file extension '%s' (expected .c3d, .trc, .bvh, .csv, "
                        ".amc or .asf)", path, dot);
    char *buf;
    size_t len;
    int r = mdl__read_file(path, MDL__MARKERS_MAX_FILE, &buf, &len, err);
    if (r != 0)
        return r;
    switch (kind) {
    case 0:
        r = mdl_markers_parse_c3d((const uint8_t *)buf, len, path, o, out, err);
        break;
    case 1:
        r = mdl_markers_parse_trc(buf, len, path, o, out, err);
        break;
    case 2:
        r = mdl_markers_parse_bvh(buf, len, path, o, out, err);
        break;
    default:
        r = mdl_markers_parse_csv(buf, len, path, o, out, err);
        break;
    }
    free(buf);
    return r;
}

int mdl__marker_opts_resolve(const mdl_marker_opts *o, double file_scale, int default_up,
                             double *scale, int *up, const char *name, char *err)
{
    double s = (o && o->scale != 0) ? o->scale : file_scale;
    int u = (o && o->up != MDL_UP_AUTO) ? o->up : default_up;
    if (!isfinite(s) || s < 0)
        return mdl__err(err, -EINVAL, "%s: invalid scale %g (metres per file unit must be > 0)",
                        name, s);
    if (u < MDL_UP_X || u > MDL_UP_NEG_Z)
        return mdl__err(err, -EINVAL, "%s: invalid up axis %d (expected an MDL_UP_* value)", name,
                        u);
    *scale = s;
    *up = u;
    return 0;
}

/* the file axes (x, y, z) of an `up` file to Y-up axes (markers_internal.h's table) */
static void axes(int up, double x, double y, double z, double *X, double *Y, double *Z)
{
    switch (up) {
    case MDL_UP_X:
        *X = -y, *Y = x, *Z = z;
        break;
    case MDL_UP_NEG_X:
        *X = y, *Y = -x, *Z = z;
        break;
    case MDL_UP_NEG_Y:
        *X = x, *Y = -y, *Z = -z;
        break;
    case MDL_UP_Z:
        *X = x, *Y = z, *Z = -y;
        break;
    case MDL_UP_NEG_Z:
        *X = x, *Y = -z, *Z = y;
        break;
    default: /* MDL_UP_Y */
        *X = x, *Y = y, *Z = z;
        break;
    }
}

void mdl__markers_convert(mdl_markers *m, double scale, int up)
{
    size_t n = (size_t)m->frames * (size_t)m->count;
    for (size_t k = 0; k < n; k++) {
        float *p = m->P + 3 * k;
        if (!m->valid[k]) {
            p[0] = p[1] = p[2] = 0;
            if (m->rot)
                m->rot[4 * k] = 1, m->rot[4 * k + 1] = m->rot[4 * k + 2] = m->rot[4 * k + 3] = 0;
            continue;
        }
        double X, Y, Z;
        axes(up, p[0], p[1], p[2], &X, &Y, &Z);
        p[0] = (float)(X * scale);
        p[1] = (float)(Y * scale);
        p[2] = (float)(Z * scale);
        if (m->rot) {
            /* P R P^T for the proper rotation P above is the rotation by the same angle about the
             * axis P a: the quaternion's vector part maps like a point (without the scale) */
            float *q = m->rot + 4 * k;
            axes(up, q[1], q[2], q[3], &X, &Y, &Z);
            q[1] = (float)X, q[2] = (float)Y, q[3] = (float)Z;
        }
    }
}

int mdl__markers_alloc_rot(mdl_markers *m)
{
    size_t n = (size_t)m->frames * (size_t)m->count;
    m->rot = mdl__calloc(4 * n + 4, sizeof *m->rot);
    m->parent = mdl__calloc((size_t)m->count + 1, sizeof *m->parent);
    if (!m->rot || !m->parent) {
        free(m->rot), free(m->parent);
        m->rot = NULL, m->parent = NULL;
        return -ENOMEM;
    }
    for (size_t k = 0; k < n; k++)
        m->rot[4 * k] = 1;
    for (int i = 0; i < m->count; i++)
        m->parent[i] = -1;
    return 0;
}

int mdl__markers_set_name(mdl_markers *m, int i, const char *s, size_t n)
{
    while (n > 0 && (isspace((unsigned char)*s) || iscntrl((unsigned char)*s)))
        s++, n--;
    while (n > 0 && (isspace((unsigned char)s[n - 1]) || iscntrl((unsigned char)s[n - 1])))
        n--;
    /* a NUL inside the field ends the label */
    const char *nul = memchr(s, 0, n);
    if (nul)
        n = (size_t)(nul - s);
    char *c;
    if (n == 0) {
        c = malloc(16);
        if (c)
            snprintf(c, 16, "M%d", i + 1);
    } else {
        c = malloc(n + 1);
        if (c) {
            memcpy(c, s, n);
            c[n] = 0;
        }
    }
    if (!c)
        return -ENOMEM;
    free(m->names[i]);
    m->names[i] = c;
    return 0;
}

/* The names of a marker set in an open-addressing hash table (FNV-1a, linear probing), for
 * mdl__markers_unique_names. The keys are borrowed from m->names; an entry is never removed. */
typedef struct name_slot {
    const char *key; /* NULL: empty */
    int seen;        /* held by a marker already visited */
    int next;        /* the next "#k" suffix to try for this name */
} name_slot;

static size_t name_hash(const char *s)
{
    uint64_t h = 1469598103934665603ull;
    for (; *s; s++)
        h = (h ^ (unsigned char)*s) * 1099511628211ull;
    return (size_t)h;
}

/* The slot of key, or the empty slot where it goes; the table is never full. */
static name_slot *name_slot_find(name_slot *t, size_t mask, const char *key)
{
    for (size_t i = name_hash(key) & mask;; i = (i + 1) & mask)
        if (!t[i].key || !strcmp(t[i].key, key))
            return &t[i];
}

/* Visits the markers in order: a name held by an earlier marker gets the smallest suffix "#k"
 * (k >= 2) that no marker holds. The set of held names only grows (a renamed marker's old name is
 * still held by the earlier one), so the smallest free k for a name only grows, and each name
 * remembers where its search stopped: linear in the count (the quadratic search took 20 s on 4000
 * copies of one name, ../shared/repro). */
int mdl__markers_unique_names(mdl_markers *m)
{
    if (m->count < 2)
        return 0;
    size_t cap = 4;
    while (cap < 4 * (size_t)m->count) /* at most 2 x count keys: a load of at most 1/2 */
        cap <<= 1;
    name_slot *t = calloc(cap, sizeof *t);
    if (!t)
        return -ENOMEM;
    size_t mask = cap - 1;
    for (int i = 0; i < m->count; i++) {
        name_slot *e = name_slot_find(t, mask, m->names[i]);
        if (!e->key)
            *e = (name_slot){m->names[i], 0, 2};
    }
    int r = 0;
    for (int i = 0; i < m->count; i++) {
        name_slot *e = name_slot_find(t, mask, m->names[i]);
        if (!e->seen) {
            e->seen = 1;
            continue;
        }
        size_t n = strlen(m->names[i]);
        char *c = malloc(n + 16);
        if (!c) {
            r = -ENOMEM;
            break;
        }
        name_slot *f;
        for (;; e->next++) {
            snprintf(c, n + 16, "%s#%d", m->names[i], e->next);
            f = name_slot_find(t, mask, c);
            if (!f->key)
                break;
        }
        e->next++;
        /* e's key is an earlier marker's copy of this name, so freeing this one is safe */
        free(m->names[i]);
        m->names[i] = c;
        *f = (name_slot){c, 1, 2};
    }
    free(t);
    return r;
}
