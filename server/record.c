/* record.c - the marker stream recorder behind --record (see record.h). */
#include "srv_err.h"
#include "record.h"
#include "daemon_config.h"
#include "model.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define REC_MAX_FRAMES (1 << 24)

struct srv_recorder {
    char *path;
    int count, frames, cap, truncated;
    double fps;
    char **names;
    float *P;
    uint8_t *valid;
};

int srv_recorder_create(const char *path, int count, const char *const *names, double fps,
                        srv_recorder **out, char *err)
{
    *out = NULL;
    srv_recorder *r = calloc(1, sizeof *r);
    if (!r)
        return srv_err(err, -ENOMEM, "record %s: out of memory", path);
    r->path = strdup(path);
    r->names = calloc((size_t)count, sizeof *r->names);
    r->count = count;
    r->fps = fps > 0 ? fps : 30;
    int ok = r->path && r->names;
    for (int i = 0; ok && i < count; i++)
        ok = (r->names[i] = strdup(names[i])) != NULL;
    if (!ok) {
        srv_recorder_destroy(r);
        return srv_err(err, -ENOMEM, "record %s: out of memory", path);
    }
    /* fail early when the file cannot be created */
    FILE *f = fopen(path, "wb");
    if (!f) {
        int e = errno;
        srv_recorder_destroy(r);
        return srv_err(err, -e, "record %s: %s", path, strerror(e));
    }
    fclose(f);
    *out = r;
    return 0;
}

int srv_recorder_add(srv_recorder *r, const float *xyz, const uint8_t *valid)
{
    if (r->truncated)
        return -ENOMEM;
    if (r->frames == r->cap) {
        int cap = r->cap ? r->cap * 2 : 1024;
        if (cap > REC_MAX_FRAMES) {
            r->truncated = 1;
            return -ENOMEM;
        }
        float *P = realloc(r->P, (size_t)cap * (size_t)r->count * 3 * sizeof(float));
        if (P)
            r->P = P;
        uint8_t *v = P ? realloc(r->valid, (size_t)cap * (size_t)r->count) : NULL;
        if (v)
            r->valid = v;
        if (!P || !v) {
            r->truncated = 1;
            return -ENOMEM;
        }
        r->cap = cap;
    }
    size_t c = (size_t)r->count;
    memcpy(r->P + (size_t)r->frames * c * 3, xyz, c * 3 * sizeof(float));
    memcpy(r->valid + (size_t)r->frames * c, valid, c);
    r->frames++;
    return 0;
}

int srv_recorder_frames(const srv_recorder *r)
{
    return r ? r->frames : 0;
}

int srv_recorder_write(srv_recorder *r, char *err)
{
    char e[MDL_ERR_LEN];
    if (r->frames == 0)
        return srv_err(err, -ENODATA, "record %s: no frames were received", r->path);
    mdl_markers *m = NULL;
    int rc = mdl_markers_create(r->frames, r->count, r->fps, &m, e);
    if (rc)
        return srv_err(err, rc, "record %s: %s", r->path, e);
    size_t c = (size_t)r->count;
    memcpy(m->P, r->P, (size_t)r->frames * c * 3 * sizeof(float));
    memcpy(m->valid, r->valid, (size_t)r->frames * c);
    for (int i = 0; i < r->count; i++) {
        char *n = strdup(r->names[i]);
        if (!n) {
            mdl_markers_destroy(m);
            return srv_err(err, -ENOMEM, "record %s: out of memory", r->path);
        }
        free(m->names[i]);
        m->names[i] = n;
    }
    rc = mdl_markers_write_c3d(r->path, m, e);
    mdl_markers_destroy(m);
    if (rc)
        return srv_err(err, rc, "record: %s", e);
    if (r->truncated)
        return srv_err(err, -ENOMEM, "record %s: memory ran out; only the first %d frames written",
                       r->path, r->frames);
    return 0;
}

void srv_recorder_destroy(srv_recorder *r)
{
    if (!r)
        return;
    for (int i = 0; r->names && i < r->count; i++)
        free(r->names[i]);
    free(r->names);
    free(r->path);
    free(r->P);
    free(r->valid);
    free(r);
}
