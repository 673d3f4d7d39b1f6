/* trc.c - TRC marker files (OpenSim / Motion Analysis "Track Row Column", PathFileType 4).
 *
 * Layout (tab-separated; cells may be space-padded; rows may end in extra tabs):
 *   line 1  PathFileType <tab> 4 <tab> (X/Y/Z) <tab> file name
 *   line 2  header keys: DataRate CameraRate NumFrames NumMarkers Units OrigDataRate
 *           OrigDataStartFrame OrigNumFrames (any order; unknown keys ignored)
 *   line 3  the values of those keys, column by column
 *   line 4  Frame# <tab> Time <tab> name1 <tab><tab> name2 ...  (marker k's name in column 2 + 3k)
 *   line 5  <tab><tab> X1 Y1 Z1 X2 ...                           (skipped)
 *   then    optional blank lines and one row per frame: Frame#, Time, x y z per marker.
 * Rules: NumMarkers sets the marker count (names missing from line 4 become "M<k>", repeated
 * names get "#2" suffixes), at most as many markers as the widest line from line 4 on has
 * columns for; a marker whose three cells are empty or absent (a short row) is an
 * invalid sample, while one with only some of its cells is an error; every present cell must be
 * a finite number. Rows are read until the end of the file; fewer rows than NumFrames is
 * rejected as truncated. Units mm, cm or m (metres per unit 0.001, 0.01, 1). The frame rate is
 * DataRate (else CameraRate). The Orig* fields describe the capture the file was cut from and are
 * often inconsistent with the file itself (e.g. OrigNumFrames 128 beside NumFrames 510); they are
 * not used. Default up axis +Y. */
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

typedef struct line {
    char *s;  /* NUL-terminated, without the line ending */
    int no;   /* 1-based line number */
} line;

/* Splits `s` at tabs in place; returns the number of cells (at most `max`, the last one taking
 * the rest). Cells are trimmed of spaces. */
static int split_tabs(char *s, char **cells, int max)
{
    int n = 0;
    while (n < max) {
        char *t = strchr(s, '\t');
        if (t && n + 1 < max)
            *t = 0;
        char *a = s;
        while (*a == ' ')
            a++;
        char *e = a + strlen(a);
        while (e > a && (e[-1] == ' ' || e[-1] == '\r'))
            *--e = 0;
        cells[n++] = a;
        if (!t || n == max)
            break;
        s = t + 1;
    }
    return n;
}

static int count_tabs(const char *s)
{
    int n = 0;
    for (; *s; s++)
        n += *s == '\t';
    return n;
}

static int parse_num(const char *s, double *v)
{
    char *end;
    if (!*s)
        return -1;
    *v = strtod(s, &end);
    if (end == s || *end || !isfinite(*v))
        return -1;
    return 0;
}

/* Next line of text at *pos; returns 0 at the end of the buffer. */
static int next_line(char *buf, size_t len, size_t *pos, int *no, line *out)
{
    if (*pos >= len)
        return 0;
    char *s = buf + *pos;
    char *nl = memchr(s, '\n', len - *pos);
    size_t n = nl ? (size_t)(nl - s) : len - *pos;
    *pos += n + (nl ? 1 : 0);
    if (n > 0 && s[n - 1] == '\r')
        n--;
    s[n] = 0;
    out->s = s;
    out->no = ++*no;
    return 1;
}

static int is_blank(const char *s)
{
    for (; *s; s++)
        if (!isspace((unsigned char)*s))
            return 0;
    return 1;
}

int mdl_markers_parse_trc(const char *buf, size_t len, const char *name, const mdl_marker_opts *o,
                          mdl_markers **out, char *err)
{
    *out = NULL;
    if (!name)
        name = "<trc>";
    char *b = malloc(len + 1);
    if (!b)
        return mdl__err(err, -ENOMEM, "%s: out of memory", name);
    memcpy(b, buf, len);
    b[len] = 0;
    /* an embedded NUL would silently cut a line short */
    if (memchr(b, 0, len)) {
        size_t at = (size_t)((char *)memchr(b, 0, len) - b);
        free(b);
        return mdl__err(err, MDL_EFORMAT, "%s: byte %zu: NUL byte in a text file", name, at);
    }
    size_t pos = 0;
    int no = 0, r = 0;
    line L[5];
    char **cells = NULL, **keys = NULL;
    mdl_markers *m = NULL;
    for (int i = 0; i < 5; i++) {
        if (!next_line(b, len, &pos, &no, &L[i])) {
            r = mdl__err(err, MDL_EFORMAT, "%s:%d: file ends inside the 5-line TRC header", name,
                         no + 1);
            goto done;
        }
    }
    if (strncmp(L[0].s, "PathFileType", 12) != 0) {
        r = mdl__err(err, MDL_EFORMAT, "%s:1: not a TRC file (does not start with PathFileType)",
                     name);
        goto done;
    }
    int nk = count_tabs(L[1].s) + 1, nv = count_tabs(L[2].s) + 1;
    keys = calloc((size_t)nk + (size_t)nv, sizeof *keys);
    if (!keys) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    char **vals = keys + nk;
    nk = split_tabs(L[1].s, keys, nk);
    nv = split_tabs(L[2].s, vals, nv);
    double rate = 0, camrate = 0, nframes = -1, nmarkers = -1, unit = 0;
    const char *units = NULL;
    for (int k = 0; k < nk; k++) {
        if (!*keys[k])
            continue;
        const char *v = k < nv ? vals[k] : "";
        double *dst = NULL;
        if (!strcasecmp(keys[k], "DataRate"))
            dst = &rate;
        else if (!strcasecmp(keys[k], "CameraRate"))
            dst = &camrate;
        else if (!strcasecmp(keys[k], "NumFrames"))
            dst = &nframes;
        else if (!strcasecmp(keys[k], "NumMarkers"))
            dst = &nmarkers;
        else if (!strcasecmp(keys[k], "Units"))
            units = v;
        if (dst && parse_num(v, dst) != 0) {
            r = mdl__err(err, MDL_EFORMAT, "%s:3: column %d: %s '%s' is not a number", name, k + 1,
                         keys[k], v);
            goto done;
        }
    }
    if (nmarkers < 0 || nframes < 0) {
        r = mdl__err(err, MDL_EFORMAT, "%s:2: header lacks %s", name,
                     nmarkers < 0 ? "NumMarkers" : "NumFrames");
        goto done;
    }
    if (nmarkers != floor(nmarkers) || nmarkers > MDL__MARKERS_MAX_COUNT ||
        nframes != floor(nframes) || nframes > 1e9) {
        r = mdl__err(err, MDL_EFORMAT, "%s:3: NumMarkers %g / NumFrames %g out of range", name,
                     nmarkers, nframes);
        goto done;
    }
    if (!units || !*units || !strcasecmp(units, "mm"))
        unit = 1e-3;
    else if (!strcasecmp(units, "cm"))
        unit = 1e-2;
    else if (!strcasecmp(units, "m"))
        unit = 1;
    else if (!(o && o->scale != 0)) {
        r = mdl__err(err, MDL_EFORMAT, "%s:3: Units '%s' is not mm, cm or m (set a scale to read it "
                     "anyway)", name, units);
        goto done;
    }
    if (!(rate > 0))
        rate = camrate > 0 ? camrate : 0;
    if (rate > 1e7)
        rate = 0;
    double scale;
    int up;
    r = mdl__marker_opts_resolve(o, unit, MDL_UP_Y, &scale, &up, name, err);
    if (r != 0)
        goto done;

    int count = (int)nmarkers;
    int maxcells = 2 + 3 * count + 1;
    cells = calloc((size_t)maxcells, sizeof *cells);
    if (!cells) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    /* count the data rows first, so that the set is allocated once; and the widest line from
     * line 4 on (names, axes, data), in tabs */
    size_t rows = 0, scan = pos;
    int tabs = count_tabs(L[3].s) > count_tabs(L[4].s) ? count_tabs(L[3].s) : count_tabs(L[4].s);
    while (scan < len) {
        const char *s = b + scan;
        const char *nl = memchr(s, '\n', len - scan);
        size_t n = nl ? (size_t)(nl - s) : len - scan;
        int blank = 1, t = 0;
        for (size_t i = 0; i < n; i++) {
            blank = blank && isspace((unsigned char)s[i]);
            t += s[i] == '\t';
        }
        rows += !blank;
        tabs = t > tabs ? t : tabs;
        scan += n + (nl ? 1 : 0);
    }
    /* marker k has column 2 + 3k: a marker no line gives a column to is not in the file (a
     * 520-byte file declaring 59,210 markers, ../shared/repro) */
    int held = tabs >= 2 ? (tabs - 2) / 3 + 1 : 0;
    if (count > held) {
        r = mdl__err(err, MDL_EFORMAT, "%s:3: NumMarkers %d, but no line of the file has columns "
                     "for more than %d markers", name, count, held);
        goto done;
    }
    if (rows < (size_t)nframes) {
        r = mdl__err(err, MDL_EFORMAT, "%s:%d: truncated: NumFrames is %g but the file has %zu "
                     "data rows", name, no + 1, nframes, rows);
        goto done;
    }
    if (rows > (size_t)1 << 30) {
        r = mdl__err(err, -EFBIG, "%s: too many rows", name);
        goto done;
    }
    r = mdl_markers_create((int)rows, count, rate, &m, err);
    if (r != 0) {
        char tmp[MDL_ERR_LEN];
        snprintf(tmp, sizeof tmp, "%s", err ? err : "");
        r = mdl__err(err, r, "%s: %s", name, tmp);
        goto done;
    }
    /* names from line 4: column 2 + 3k */
    int nn = split_tabs(L[3].s, cells, maxcells);
    for (int k = 0; k < count; k++) {
        const char *s = 2 + 3 * k < nn ? cells[2 + 3 * k] : "";
        if (mdl__markers_set_name(m, k, s, strlen(s))) {
            r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
            goto done;
        }
    }
    for (int c = 2 + 3 * count; c < nn; c++) {
        if (*cells[c]) {
            r = mdl__err(err, MDL_EFORMAT, "%s:4: column %d: marker name '%s' beyond NumMarkers %d",
                         name, c + 1, cells[c], count);
            goto done;
        }
    }
    if (mdl__markers_unique_names(m)) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    line l;
    size_t f = 0;
    while (next_line(b, len, &pos, &no, &l)) {
        if (is_blank(l.s))
            continue;
        int nc = split_tabs(l.s, cells, maxcells);
        double v;
        if (nc < 2 || parse_num(cells[0], &v) != 0 || parse_num(cells[1], &v) != 0) {
            r = mdl__err(err, MDL_EFORMAT, "%s:%d: a data row must start with Frame# and Time",
                         name, l.no);
            goto done;
        }
        if (nc == maxcells && *cells[maxcells - 1] && !is_blank(cells[maxcells - 1])) {
            /* the last cell holds the rest of the row: it may only be empty tabs */
            for (const char *s = cells[maxcells - 1]; *s; s++)
                if (!isspace((unsigned char)*s)) {
                    r = mdl__err(err, MDL_EFORMAT, "%s:%d: more than %d columns", name, l.no,
                                 maxcells - 1);
                    goto done;
                }
        }
        for (int k = 0; k < count; k++) {
            int present = 0;
            double xyz[3];
            for (int a = 0; a < 3; a++) {
                int c = 2 + 3 * k + a;
                const char *s = c < nc ? cells[c] : "";
                if (!*s)
                    continue;
                if (parse_num(s, &xyz[a]) != 0) {
                    r = mdl__err(err, MDL_EFORMAT, "%s:%d: column %d: '%.40s' is not a number",
                                 name, l.no, c + 1, s);
                    goto done;
                }
                present++;
            }
            if (present != 0 && present != 3) {
                r = mdl__err(err, MDL_EFORMAT, "%s:%d: column %d: marker %s has %d of 3 "
                             "coordinates", name, l.no, 3 + 3 * k, m->names[k], present);
                goto done;
            }
            if (present == 3) {
                size_t i = f * (size_t)count + (size_t)k;
                m->valid[i] = 1;
                for (int a = 0; a < 3; a++)
                    m->P[3 * i + (size_t)a] = (float)xyz[a];
            }
        }
        f++;
    }
    mdl__markers_convert(m, scale, up);
    *out = m;
    m = NULL;
done:
    mdl_markers_destroy(m);
    free(cells);
    free(keys);
    free(b);
    return r;
}
