/* fakenect.c - fakenect dump directories (format in fakenect.h): writer, parsers, and the
 * `fakenect:DIR[?loop=1]` source. Every file read is checked (header fields, sizes, names); a
 * malformed index line or PGM is reported with the file, the line or byte offset and the reason. */
#include "../drv_err.h"
#include "fakenect.h"

#include "model.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#define FN_W 640
#define FN_H 480
#define FN_PIX (FN_W * FN_H)

/* ------------------------------------------------------------------ writer */

struct drv_fakenect_writer {
    char dir[4096];
    FILE *index;
    uint8_t *buf; /* one frame of raw disparities */
};

int drv_fakenect_writer_open(const char *dir, drv_fakenect_writer **out, char *err)
{
    *out = NULL;
    if (strlen(dir) > 4000)
        return drv__err(err, -ENAMETOOLONG, "fakenect %s: path too long", dir);
    if (mkdir(dir, 0777) != 0 && errno != EEXIST)
        return drv__err(err, -errno, "fakenect %s: mkdir: %s", dir, strerror(errno));
    char path[4200];
    snprintf(path, sizeof path, "%s/INDEX.txt", dir);
    struct stat st;
    if (stat(path, &st) == 0)
        return drv__err(err, -EEXIST, "fakenect %s: INDEX.txt exists; use an empty directory", dir);
    drv_fakenect_writer *w = calloc(1, sizeof *w);
    if (!w || !(w->buf = malloc(FN_PIX * 2))) {
        free(w);
        return drv__err(err, -ENOMEM, "fakenect %s: out of memory", dir);
    }
    snprintf(w->dir, sizeof w->dir, "%s", dir);
    if (!(w->index = fopen(path, "w"))) {
        int e = errno;
        free(w->buf);
        free(w);
        return drv__err(err, -e, "fakenect %s: %s", path, strerror(e));
    }
    *out = w;
    return 0;
}

int drv_fakenect_writer_depth(drv_fakenect_writer *w, double t, uint32_t timestamp,
                              const uint16_t *mm, char *err)
{
    char name[128], path[4300];
    snprintf(name, sizeof name, "d-%f-%u.pgm", t, timestamp);
    snprintf(path, sizeof path, "%s/%s", w->dir, name);
    for (int i = 0; i < FN_PIX; i++) {
        long d = 2047;
        if (mm[i]) {
            d = lround(drv_kinect1_m_to_disparity(mm[i] * 0.001));
            if (d < 0 || d > 2046)
                d = 2047;
        }
        w->buf[2 * i] = (uint8_t)(d & 0xff);
        w->buf[2 * i + 1] = (uint8_t)(d >> 8);
    }
    FILE *f = fopen(path, "wb");
    if (!f)
        return drv__err(err, -errno, "fakenect %s: %s", path, strerror(errno));
    int ok = fprintf(f, "P5 %d %d 65535\n", FN_W, FN_H) > 0 &&
             fwrite(w->buf, 1, FN_PIX * 2, f) == FN_PIX * 2;
    ok = (fclose(f) == 0) && ok;
    if (!ok || fprintf(w->index, "%s\n", name) < 0)
        return drv__err(err, -EIO, "fakenect %s: write failed", path);
    return 0;
}

int drv_fakenect_writer_close(drv_fakenect_writer *w, char *err)
{
    if (!w)
        return 0;
    int r = 0;
    if (fclose(w->index) != 0)
        r = drv__err(err, -EIO, "fakenect %s: writing INDEX.txt failed", w->dir);
    free(w->buf);
    free(w);
    return r;
}

/* ------------------------------------------------------------------ parsers */

int drv_fakenect_parse_index_line(const char *line, size_t len, double *t, uint32_t *timestamp,
                                  char *err)
{
    char tmp[256];
    while (len && (line[len - 1] == '\n' || line[len - 1] == '\r'))
        len--;
    if (len < 3 || len >= sizeof tmp)
        return drv__err(err, MDL_EFORMAT, "bad entry (length %zu)", len);
    memcpy(tmp, line, len);
    tmp[len] = '\0';
    if (tmp[1] != '-' || (tmp[0] != 'd' && tmp[0] != 'r' && tmp[0] != 'a'))
        return drv__err(err, MDL_EFORMAT, "bad entry '%s': expected d-, r- or a-", tmp);
    char *end;
    errno = 0;
    double tv = strtod(tmp + 2, &end);
    if (end == tmp + 2 || *end != '-' || errno || !isfinite(tv) || tv < 0)
        return drv__err(err, MDL_EFORMAT, "bad entry '%s': expected a time after '%c-'", tmp, tmp[0]);
    const char *q = end + 1;
    if (*q < '0' || *q > '9')
        return drv__err(err, MDL_EFORMAT, "bad entry '%s': expected a timestamp", tmp);
    errno = 0;
    unsigned long long ts = strtoull(q, &end, 10);
    if (errno || ts > UINT32_MAX || *end != '.')
        return drv__err(err, MDL_EFORMAT, "bad entry '%s': bad timestamp", tmp);
    const char *ext = tmp[0] == 'd' ? "pgm" : tmp[0] == 'r' ? "ppm" : "dump";
    if (strcmp(end + 1, ext))
        return drv__err(err, MDL_EFORMAT, "bad entry '%s': expected extension .%s", tmp, ext);
    if (tmp[0] != 'd')
        return 0;
    *t = tv;
    *timestamp = (uint32_t)ts;
    return 1;
}

/* reads a decimal header field after whitespace; returns the offset after it or 0 */
static size_t field(const uint8_t *b, size_t len, size_t i, long *v)
{
    while (i < len && (b[i] == ' ' || b[i] == '\t' || b[i] == '\n' || b[i] == '\r'))
        i++;
    size_t s = i;
    long x = 0;
    while (i < len && b[i] >= '0' && b[i] <= '9' && i - s < 7)
        x = x * 10 + (b[i++] - '0');
    if (i == s || (i < len && b[i] >= '0' && b[i] <= '9'))
        return 0;
    *v = x;
    return i;
}

int drv_fakenect_parse_depth(const uint8_t *buf, size_t len, const char *name, uint16_t *mm,
                             char *err)
{
    if (len < 2 || buf[0] != 'P' || buf[1] != '5')
        return drv__err(err, MDL_EFORMAT, "%s: offset 0: not a binary PGM (P5)", name);
    long w, h, maxval;
    size_t i = 2;
    if (!(i = field(buf, len, i, &w)) || !(i = field(buf, len, i, &h)) ||
        !(i = field(buf, len, i, &maxval)))
        return drv__err(err, MDL_EFORMAT, "%s: bad PGM header (width, height, maxval)", name);
    if (w != FN_W || h != FN_H)
        return drv__err(err, MDL_EFORMAT, "%s: %ldx%ld depth, expected %dx%d", name, w, h, FN_W, FN_H);
    if (maxval < 2047 || maxval > 65535)
        return drv__err(err, MDL_EFORMAT, "%s: maxval %ld, expected 16-bit samples", name, maxval);
    if (i >= len || (buf[i] != '\n' && buf[i] != ' ' && buf[i] != '\r' && buf[i] != '\t'))
        return drv__err(err, MDL_EFORMAT, "%s: offset %zu: expected one whitespace after maxval", name, i);
    i++;
    if (len - i != (size_t)FN_PIX * 2)
        return drv__err(err, MDL_EFORMAT, "%s: offset %zu: %zu bytes of samples, expected %d", name, i,
                    len - i, FN_PIX * 2);
    for (int k = 0; k < FN_PIX; k++) {
        unsigned d = buf[i + 2 * k] | (unsigned)buf[i + 2 * k + 1] << 8;
        double z = d < 2047 ? drv_kinect1_disparity_to_m(d) : 0;
        mm[k] = z > 0 && z < 65.0 ? (uint16_t)lround(z * 1000.0) : 0;
    }
    return 0;
}

/* ------------------------------------------------------------------ the source */

#define NAME_LEN 96

typedef struct fn_src {
    char dir[4096];
    int n, next, loop;
    double *t;             /* n recorded times */
    char (*file)[NAME_LEN];/* n depth file names */
    uint8_t *buf;          /* one file */
    size_t cap;
    uint16_t *mm;
    drv_depth_tracker *trk;
    uint64_t seq;
    uint64_t t0_us;        /* monotonic time of the current pass's first frame */
    double rec0;           /* its recorded time */
} fn_src;

static uint64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void fn_free(fn_src *f)
{
    if (!f)
        return;
    free(f->t);
    free(f->file);
    free(f->buf);
    free(f->mm);
    drv_depth_tracker_destroy(f->trk);
    free(f);
}

static int fn_open(drv_source *s, const char *arg, char *err)
{
    fn_src *f = calloc(1, sizeof *f);
    if (!f)
        return drv__err(err, -ENOMEM, "fakenect: out of memory");
    const char *q = strchr(arg, '?');
    size_t dl = q ? (size_t)(q - arg) : strlen(arg);
    if (dl == 0 || dl >= sizeof f->dir) {
        fn_free(f);
        return drv__err(err, -EINVAL, "fakenect: expected fakenect:DIR[?loop=1]");
    }
    memcpy(f->dir, arg, dl);
    if (q) {
        if (!strcmp(q + 1, "loop=1"))
            f->loop = 1;
        else if (strcmp(q + 1, "loop=0")) {
            int r = drv__err(err, -EINVAL, "fakenect %s: unknown option '%s' (loop=0|1)", f->dir, q + 1);
            fn_free(f);
            return r;
        }
    }
    char path[4200];
    snprintf(path, sizeof path, "%s/INDEX.txt", f->dir);
    FILE *in = fopen(path, "r");
    if (!in) {
        int e = errno;
        fn_free(f);
        return drv__err(err, e == ENOENT ? -ENOENT : -e, "fakenect %s: %s", path, strerror(e));
    }
    char line[512], lerr[DRV_ERR_LEN];
    int cap = 0, lineno = 0, r = 0;
    while (fgets(line, sizeof line, in)) {
        lineno++;
        size_t len = strlen(line);
        if (len == sizeof line - 1 && line[len - 1] != '\n') {
            r = drv__err(err, MDL_EFORMAT, "%s:%d: line too long", path, lineno);
            break;
        }
        if (len == 0 || line[0] == '\n' || line[0] == '\r')
            continue;
        double t;
        uint32_t ts;
        int k = drv_fakenect_parse_index_line(line, len, &t, &ts, lerr);
        if (k < 0) {
            r = drv__err(err, k, "%s:%d: %s", path, lineno, lerr);
            break;
        }
        if (k == 0)
            continue;
        if (f->n == cap) {
            cap = cap ? 2 * cap : 64;
            double *nt = realloc(f->t, (size_t)cap * sizeof *nt);
            if (nt)
                f->t = nt;
            char(*nf)[NAME_LEN] = realloc(f->file, (size_t)cap * sizeof *nf);
            if (nf)
                f->file = nf;
            if (!nt || !nf) {
                r = drv__err(err, -ENOMEM, "fakenect %s: out of memory", path);
                break;
            }
        }
        if (f->n > 0 && t < f->t[f->n - 1]) {
            r = drv__err(err, MDL_EFORMAT, "%s:%d: time goes backwards", path, lineno);
            break;
        }
        size_t nl = strcspn(line, "\r\n");
        if (nl >= NAME_LEN) {
            r = drv__err(err, MDL_EFORMAT, "%s:%d: file name too long", path, lineno);
            break;
        }
        memcpy(f->file[f->n], line, nl);
        f->file[f->n][nl] = '\0';
        f->t[f->n++] = t;
    }
    fclose(in);
    if (!r && f->n == 0)
        r = drv__err(err, MDL_EFORMAT, "%s: no depth frames", path);
    if (r) {
        fn_free(f);
        return r;
    }
    f->cap = 64 + (size_t)FN_PIX * 2;
    f->buf = malloc(f->cap + 1);
    f->mm = malloc((size_t)FN_PIX * sizeof *f->mm);
    drv_depth_opts o;
    drv_depth_opts_default(&o);
    if (!f->buf || !f->mm) {
        r = drv__err(err, -ENOMEM, "fakenect %s: out of memory", f->dir);
        fn_free(f);
        return r;
    }
    if ((r = drv_depth_tracker_create(&o, &f->trk, err))) {
        fn_free(f);
        return r;
    }
    s->impl = f;
    s->count = DRV_DEPTH_NLABELS;
    s->names = (const char **)drv_depth_label_names;
    s->fps = f->n > 1 && f->t[f->n - 1] > f->t[0] ? (f->n - 1) / (f->t[f->n - 1] - f->t[0]) : 30;
    return 0;
}

static int fn_start(drv_source *s, char *err)
{
    (void)err;
    fn_src *f = s->impl;
    f->next = 0;
    f->t0_us = now_us();
    f->rec0 = f->t[0];
    drv_depth_tracker_reset(f->trk);
    return 0;
}

static int fn_read(drv_source *s, drv_frame *fr, int timeout_ms, char *err)
{
    fn_src *f = s->impl;
    if (f->next >= f->n) {
        if (!f->loop)
            return DRV_EEOF;
        f->next = 0;
        f->t0_us = now_us() + (uint64_t)(1e6 / (s->fps > 0 ? s->fps : 30));
        f->rec0 = f->t[0];
    }
    uint64_t due = f->t0_us + (uint64_t)llround((f->t[f->next] - f->rec0) * 1e6);
    uint64_t now = now_us();
    if (due > now) {
        uint64_t wait = due - now;
        if (timeout_ms >= 0 && wait > (uint64_t)timeout_ms * 1000u) {
            struct timespec ts = {timeout_ms / 1000, (long)(timeout_ms % 1000) * 1000000L};
            nanosleep(&ts, NULL);
            return DRV_ETIMEOUT;
        }
        struct timespec ts = {(time_t)(wait / 1000000u), (long)(wait % 1000000u) * 1000L};
        nanosleep(&ts, NULL);
    }
    char path[4300];
    snprintf(path, sizeof path, "%s/%s", f->dir, f->file[f->next]);
    FILE *in = fopen(path, "rb");
    if (!in)
        return drv__err(err, -errno, "fakenect %s: %s", path, strerror(errno));
    size_t len = fread(f->buf, 1, f->cap + 1, in);
    fclose(in);
    if (len > f->cap)
        return drv__err(err, MDL_EFORMAT, "fakenect %s: larger than a 640x480 depth frame", path);
    int r = drv_fakenect_parse_depth(f->buf, len, path, f->mm, err);
    if (r)
        return r;
    uint64_t t_cap = now_us();
    drv_depth_result res;
    drv_depth_tracker_process(f->trk, f->mm, t_cap, &res);
    for (int l = 0; l < DRV_DEPTH_NLABELS; l++) {
        memcpy(fr->xyz + 3 * l, res.xyz[l], 3 * sizeof(float));
        fr->valid[l] = res.valid[l];
    }
    fr->seq = f->seq++;
    fr->t_capture_us = t_cap;
    f->next++;
    return 0;
}

static void fn_stop(drv_source *s)
{
    (void)s;
}

static void fn_close(drv_source *s)
{
    fn_free(s->impl);
    s->impl = NULL;
}

const drv_source_ops drv_fakenect_ops = {
    .scheme = "fakenect",
    .open = fn_open,
    .start = fn_start,
    .read = fn_read,
    .control = NULL,
    .stop = fn_stop,
    .close = fn_close,
};
