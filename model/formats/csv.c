/* csv.c - plain CSV marker files, and the Kinect v2 joints CSV.
 *
 * Plain CSV (read and written):
 *   frame,time,<name>_x,<name>_y,<name>_z,<name2>_x,...
 *   0,0,0.1,1.2,0.3,...
 * The header is required; each marker takes three consecutive columns whose names share a prefix
 * and end in _x, _y, _z (any case). Every row has exactly the header's column count. An empty
 * cell makes that marker's sample invalid; any other cell must be a finite number. Units are
 * metres and the default up axis is +Y. The frame rate is (rows - 1) / (last time - first time)
 * when the times increase, else 0. The writer prints time = frame / fps (0 without a rate) and
 * %.9g coordinates, so float values survive a round trip exactly.
 *
 * Kinect v2 joints CSV (microsoft/LabanotationSuite KinectReader, read only): no header; a row is
 * a timestamp in 100 ns units, then 25 joints x (x, y, z in metres in camera space, tracking state
 * 0 not tracked / 1 inferred / 2 tracked), optionally a trailing comma: 101 or 102 fields. It is
 * recognised when the first line does not start with a letter and has that field count. Joints
 * are named SpineBase, SpineMid, Neck, Head, ShoulderL, ElbowL, WristL, HandL, ShoulderR, ElbowR,
 * WristR, HandR, HipL, KneeL, AnkleL, FootL, HipR, KneeR, AnkleR, FootR, SpineShoulder, HandTipL,
 * ThumbL, HandTipR, ThumbR. State 0 is an invalid sample; inferred joints are kept as valid.
 * Kinect camera space is right-handed with +Y up, so the defaults apply unchanged. The frame rate
 * is (rows - 1) / (timestamp span in seconds). */
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

static const char *const kinect_joints[25] = {
    "SpineBase", "SpineMid",  "Neck",   "Head",   "ShoulderL", "ElbowL",        "WristL",
    "HandL",     "ShoulderR", "ElbowR", "WristR", "HandR",     "HipL",          "KneeL",
    "AnkleL",    "FootL",     "HipR",   "KneeR",  "AnkleR",    "FootR",         "SpineShoulder",
    "HandTipL",  "ThumbL",    "HandTipR", "ThumbR"};

/* Splits a line at commas in place into at most `max` cells (the last takes the rest); cells are
 * trimmed of spaces. Returns the number of cells; *more is set when the line had more. */
static int split_commas(char *s, char **cells, int max, int *more)
{
    int n = 0;
    *more = 0;
    for (;;) {
        char *c = strchr(s, ',');
        if (c)
            *c = 0;
        while (*s == ' ' || *s == '\t')
            s++;
        char *e = s + strlen(s);
        while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r'))
            *--e = 0;
        if (n == max) {
            *more = 1;
            return n;
        }
        cells[n++] = s;
        if (!c)
            return n;
        s = c + 1;
    }
}

static int count_fields(const char *s, size_t n)
{
    int k = 1;
    for (size_t i = 0; i < n; i++)
        k += s[i] == ',';
    return k;
}

static int num(const char *s, double *v)
{
    char *end;
    if (!*s)
        return -1;
    *v = strtod(s, &end);
    return (end == s || *end || !isfinite(*v)) ? -1 : 0;
}

typedef struct text {
    char *b;
    size_t len, pos;
    int no;
} text;

static char *next_line(text *t)
{
    while (t->pos < t->len) {
        char *s = t->b + t->pos;
        char *nl = memchr(s, '\n', t->len - t->pos);
        size_t n = nl ? (size_t)(nl - s) : t->len - t->pos;
        t->pos += n + (nl ? 1 : 0);
        t->no++;
        s[n] = 0;
        int blank = 1;
        for (size_t i = 0; i < n && blank; i++)
            blank = isspace((unsigned char)s[i]) != 0;
        if (!blank)
            return s;
    }
    return NULL;
}

static size_t count_rows(const text *t)
{
    size_t rows = 0;
    for (size_t pos = t->pos; pos < t->len;) {
        const char *s = t->b + pos;
        const char *nl = memchr(s, '\n', t->len - pos);
        size_t n = nl ? (size_t)(nl - s) : t->len - pos;
        int blank = 1;
        for (size_t i = 0; i < n && blank; i++)
            blank = isspace((unsigned char)s[i]) != 0;
        rows += !blank;
        pos += n + (nl ? 1 : 0);
    }
    return rows;
}

static int wrap_create(int frames, int count, const char *name, mdl_markers **m, char *err)
{
    int r = mdl_markers_create(frames, count, 0, m, err);
    if (r != 0) {
        char tmp[MDL_ERR_LEN];
        snprintf(tmp, sizeof tmp, "%s", err ? err : "");
        r = mdl__err(err, r, "%s: %s", name, tmp);
    }
    return r;
}

static int parse_kinect(text *t, const char *name, mdl_markers **out, char *err)
{
    size_t rows = count_rows(t);
    if (rows > (size_t)1 << 30)
        return mdl__err(err, -EFBIG, "%s: too many rows", name);
    mdl_markers *m;
    int r = wrap_create((int)rows, 25, name, &m, err);
    if (r)
        return r;
    for (int j = 0; j < 25; j++)
        if (mdl__markers_set_name(m, j, kinect_joints[j], strlen(kinect_joints[j]))) {
            mdl_markers_destroy(m);
            return mdl__err(err, -ENOMEM, "%s: out of memory", name);
        }
    char *cells[102];
    double t0 = 0, t1 = 0;
    char *s;
    for (size_t f = 0; (s = next_line(t)) != NULL; f++) {
        int more, n = split_commas(s, cells, 102, &more);
        if (more || n < 101 || (n == 102 && *cells[101])) {
            mdl_markers_destroy(m);
            return mdl__err(err, MDL_EFORMAT,
                            "%s:%d: a Kinect v2 row has 101 fields (102 with a trailing comma), "
                            "not %d%s", name, t->no, n, more ? "+" : "");
        }
        double ts;
        if (num(cells[0], &ts) != 0) {
            mdl_markers_destroy(m);
            return mdl__err(err, MDL_EFORMAT, "%s:%d: field 1: timestamp '%.40s' is not a number",
                            name, t->no, cells[0]);
        }
        if (f == 0)
            t0 = ts;
        t1 = ts;
        for (int j = 0; j < 25; j++) {
            double v[4];
            for (int a = 0; a < 4; a++) {
                if (num(cells[1 + 4 * j + a], &v[a]) != 0) {
                    mdl_markers_destroy(m);
                    return mdl__err(err, MDL_EFORMAT, "%s:%d: field %d: '%.40s' is not a number",
                                    name, t->no, 2 + 4 * j + a, cells[1 + 4 * j + a]);
                }
            }
            if (v[3] != 0 && v[3] != 1 && v[3] != 2) {
                mdl_markers_destroy(m);
                return mdl__err(err, MDL_EFORMAT,
                                "%s:%d: field %d: tracking state %g is not 0, 1 or 2", name, t->no,
                                5 + 4 * j, v[3]);
            }
            size_t i = f * 25 + (size_t)j;
            m->valid[i] = v[3] != 0;
            for (int a = 0; a < 3; a++)
                m->P[3 * i + (size_t)a] = (float)v[a];
        }
    }
    if (rows > 1 && t1 > t0)
        m->fps = (double)(rows - 1) / ((t1 - t0) * 1e-7);
    *out = m;
    return 0;
}

int mdl_markers_parse_csv(const char *buf, size_t len, const char *name, const mdl_marker_opts *o,
                          mdl_markers **out, char *err)
{
    *out = NULL;
    if (!name)
        name = "<csv>";
    double scale;
    int up;
    int r = mdl__marker_opts_resolve(o, 1.0, MDL_UP_Y, &scale, &up, name, err);
    if (r)
        return r;
    text t = {.len = len};
    t.b = malloc(len + 1);
    if (!t.b)
        return mdl__err(err, -ENOMEM, "%s: out of memory", name);
    memcpy(t.b, buf, len);
    t.b[len] = 0;
    mdl_markers *m = NULL;
    char **cells = NULL;
    if (memchr(t.b, 0, len)) {
        r = mdl__err(err, MDL_EFORMAT, "%s: byte %zu: NUL byte in a text file", name,
                     (size_t)((char *)memchr(t.b, 0, len) - t.b));
        goto done;
    }
    char *hdr = next_line(&t);
    if (!hdr) {
        r = mdl__err(err, MDL_EFORMAT, "%s:1: empty file (a header line is required)", name);
        goto done;
    }
    int nf = count_fields(hdr, strlen(hdr));
    {
        const char *h = hdr;
        while (*h == ' ' || *h == '\t')
            h++;
        if (!isalpha((unsigned char)*h) && (nf == 101 || nf == 102)) {
            t.pos = 0;
            t.no = 0;
            memcpy(t.b, buf, len); /* undo the NULs next_line wrote */
            r = parse_kinect(&t, name, &m, err);
            if (r)
                goto done;
            goto convert;
        }
    }
    if (nf < 2 || (nf - 2) % 3 != 0) {
        r = mdl__err(err, MDL_EFORMAT,
                     "%s:%d: header has %d columns; expected frame,time and three per marker", name,
                     t.no, nf);
        goto done;
    }
    int count = (nf - 2) / 3;
    if (count > MDL__MARKERS_MAX_COUNT) {
        r = mdl__err(err, MDL_EFORMAT, "%s:%d: %d markers is too many", name, t.no, count);
        goto done;
    }
    cells = calloc((size_t)nf, sizeof *cells);
    if (!cells) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    int more;
    split_commas(hdr, cells, nf, &more);
    if (strcasecmp(cells[0], "frame") != 0 || strcasecmp(cells[1], "time") != 0) {
        r = mdl__err(err, MDL_EFORMAT, "%s:%d: header must start with frame,time (found '%.40s,%.40s')",
                     name, t.no, cells[0], cells[1]);
        goto done;
    }
    size_t rows = count_rows(&t);
    if (rows > (size_t)1 << 30) {
        r = mdl__err(err, -EFBIG, "%s: too many rows", name);
        goto done;
    }
    if ((r = wrap_create((int)rows, count, name, &m, err)) != 0)
        goto done;
    for (int k = 0; k < count; k++) {
        static const char axes[3] = {'x', 'y', 'z'};
        size_t plen = 0;
        for (int a = 0; a < 3; a++) {
            const char *c = cells[2 + 3 * k + a];
            size_t n = strlen(c);
            if (n < 3 || c[n - 2] != '_' || tolower((unsigned char)c[n - 1]) != axes[a] ||
                (a > 0 && (n - 2 != plen || strncmp(c, cells[2 + 3 * k], plen) != 0))) {
                r = mdl__err(err, MDL_EFORMAT, "%s:%d: column %d: '%.60s' should be <name>_%c%s",
                             name, t.no, 3 + 3 * k + a, c, axes[a],
                             a ? " with the same name as the column before" : "");
                goto done;
            }
            plen = n - 2;
        }
        if (mdl__markers_set_name(m, k, cells[2 + 3 * k], plen)) {
            r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
            goto done;
        }
    }
    if (mdl__markers_unique_names(m)) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    double t0 = 0, t1 = 0;
    int increasing = 1;
    char *s;
    for (size_t f = 0; (s = next_line(&t)) != NULL; f++) {
        int n = split_commas(s, cells, nf, &more);
        if (n != nf || more) {
            r = mdl__err(err, MDL_EFORMAT, "%s:%d: %s%d fields where the header has %d", name,
                         t.no, more ? "more than " : "", n, nf);
            goto done;
        }
        double fr, tm;
        if (num(cells[0], &fr) != 0 || num(cells[1], &tm) != 0) {
            r = mdl__err(err, MDL_EFORMAT, "%s:%d: frame and time must be numbers ('%.40s', '%.40s')",
                         name, t.no, cells[0], cells[1]);
            goto done;
        }
        if (f == 0)
            t0 = tm;
        else if (!(tm > t1))
            increasing = 0;
        t1 = tm;
        for (int k = 0; k < count; k++) {
            double v[3];
            int present = 0;
            for (int a = 0; a < 3; a++) {
                const char *c = cells[2 + 3 * k + a];
                if (!*c)
                    continue;
                if (num(c, &v[a]) != 0) {
                    r = mdl__err(err, MDL_EFORMAT, "%s:%d: column %d: '%.40s' is not a number",
                                 name, t.no, 3 + 3 * k + a, c);
                    goto done;
                }
                present++;
            }
            size_t i = f * (size_t)count + (size_t)k;
            m->valid[i] = present == 3;
            if (present == 3)
                for (int a = 0; a < 3; a++)
                    m->P[3 * i + (size_t)a] = (float)v[a];
        }
    }
    if (rows > 1 && increasing && t1 > t0)
        m->fps = (double)(rows - 1) / (t1 - t0);
convert:
    mdl__markers_convert(m, scale, up);
    *out = m;
    m = NULL;
done:
    mdl_markers_destroy(m);
    free(cells);
    free(t.b);
    return r;
}

int mdl_markers_write_csv(const char *path, const mdl_markers *m, char *err)
{
    if (!m)
        return mdl__err(err, -EINVAL, "%s: no marker set to write", path);
    for (int k = 0; k < m->count; k++) {
        const char *s = m->names[k] ? m->names[k] : "";
        if (strpbrk(s, ",\r\n") || !*s)
            return mdl__err(err, -EINVAL, "%s: marker %d name '%s' cannot be a CSV column name",
                            path, k, s);
    }
    FILE *fp = fopen(path, "w");
    if (!fp) {
        int e = errno;
        return mdl__err(err, -e, "%s: cannot create: %s", path, strerror(e));
    }
    fputs("frame,time", fp);
    for (int k = 0; k < m->count; k++)
        fprintf(fp, ",%s_x,%s_y,%s_z", m->names[k], m->names[k], m->names[k]);
    fputc('\n', fp);
    for (int f = 0; f < m->frames; f++) {
        fprintf(fp, "%d,%.9g", f, m->fps > 0 ? f / m->fps : 0.0);
        for (int k = 0; k < m->count; k++) {
            size_t i = (size_t)f * (size_t)m->count + (size_t)k;
            if (m->valid[i])
                fprintf(fp, ",%.9g,%.9g,%.9g", m->P[3 * i], m->P[3 * i + 1], m->P[3 * i + 2]);
            else
                fputs(",,,", fp);
        }
        fputc('\n', fp);
    }
    int e = ferror(fp) ? (errno ? errno : EIO) : 0;
    if (fclose(fp) != 0 && !e)
        e = errno ? errno : EIO;
    if (e)
        return mdl__err(err, -e, "%s: write failed: %s", path, strerror(e));
    return 0;
}
