/* chunkio.c - little-endian encoding and validated decoding of model file chunks (chunkio.h). */
#include "formats/chunkio.h"
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_COUNT MDL_CHUNK_MAX_COUNT


void mdl__put_bytes(mdl__wbuf *b, const void *src, size_t n)
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

void mdl__put_u32(mdl__wbuf *b, uint32_t v)
{
    uint8_t x[4] = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24)};
    mdl__put_bytes(b, x, 4);
}

void mdl__put_u64(mdl__wbuf *b, uint64_t v)
{
    mdl__put_u32(b, (uint32_t)v);
    mdl__put_u32(b, (uint32_t)(v >> 32));
}

void mdl__put_f64(mdl__wbuf *b, double d)
{
    uint64_t v;
    memcpy(&v, &d, 8);
    mdl__put_u64(b, v);
}

void mdl__put_i32s(mdl__wbuf *b, const int *a, size_t n)
{
    mdl__put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++)
        mdl__put_u32(b, (uint32_t)a[i]);
}

void mdl__put_u32s(mdl__wbuf *b, const uint32_t *a, size_t n)
{
    mdl__put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++)
        mdl__put_u32(b, a[i]);
}

void mdl__put_f32s(mdl__wbuf *b, const float *a, size_t n)
{
    mdl__put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++) {
        uint32_t v;
        memcpy(&v, &a[i], 4);
        mdl__put_u32(b, v);
    }
}

void mdl__put_f64s(mdl__wbuf *b, const double *a, size_t n)
{
    mdl__put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++)
        mdl__put_f64(b, a[i]);
}



int mdl__rfail(mdl__rbuf *b, const char *what)
{
    if (!b->rc)
        b->rc = mdl__err(b->err, MDL_EFORMAT, "%s: byte %zu: %s", b->name, b->at, what);
    return b->rc;
}

int mdl__get_bytes(mdl__rbuf *b, void *dst, size_t n)
{
    if (b->rc)
        return b->rc;
    if (n > b->n - b->at)
        return mdl__rfail(b, "unexpected end of file");
    memcpy(dst, b->p + b->at, n);
    b->at += n;
    return 0;
}

uint32_t mdl__get_u32(mdl__rbuf *b)
{
    uint8_t x[4] = {0};
    mdl__get_bytes(b, x, 4);
    return (uint32_t)x[0] | (uint32_t)x[1] << 8 | (uint32_t)x[2] << 16 | (uint32_t)x[3] << 24;
}

int mdl__get_int(mdl__rbuf *b, const char *what, int lo, int hi)
{
    uint32_t v = mdl__get_u32(b);
    if (b->rc)
        return lo;
    int iv = (int)v;
    if (v > 0x7fffffffu || iv < lo || iv > hi) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s = %u is outside %d..%d", what, v, lo, hi);
        mdl__rfail(b, msg);
        return lo;
    }
    return iv;
}

uint64_t mdl__get_u64(mdl__rbuf *b)
{
    uint64_t lo = mdl__get_u32(b);
    return lo | (uint64_t)mdl__get_u32(b) << 32;
}

double mdl__get_f64(mdl__rbuf *b, const char *what)
{
    uint64_t v = mdl__get_u64(b);
    double d;
    memcpy(&d, &v, 8);
    if (!b->rc && !isfinite(d)) {
        char msg[120];
        snprintf(msg, sizeof msg, "%s is not a finite number", what);
        mdl__rfail(b, msg);
    }
    return d;
}

int mdl__get_count(mdl__rbuf *b, size_t expect, const char *what)
{
    uint32_t n = mdl__get_u32(b);
    if (b->rc)
        return b->rc;
    if (n != expect || n > MAX_COUNT) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s has %u entries, expected %zu", what, n, expect);
        return mdl__rfail(b, msg);
    }
    if ((size_t)n * 4 > b->n - b->at)
        return mdl__rfail(b, "unexpected end of file");
    return 0;
}

int *mdl__get_ints(mdl__rbuf *b, size_t n, const char *what, int lo, int hi)
{
    if (mdl__get_count(b, n, what))
        return NULL;
    int *a = mdl__calloc(n ? n : 1, sizeof *a);
    if (!a) {
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
        return NULL;
    }
    for (size_t i = 0; i < n && !b->rc; i++) {
        uint32_t v = mdl__get_u32(b);
        if (v > 0x7fffffffu || (int)v < lo || (int)v > hi) {
            char msg[200];
            snprintf(msg, sizeof msg, "%s[%zu] = %u is outside %d..%d", what, i, v, lo, hi);
            mdl__rfail(b, msg);
        }
        a[i] = (int)v;
    }
    if (b->rc) {
        free(a);
        return NULL;
    }
    return a;
}

float *mdl__get_f32s(mdl__rbuf *b, size_t n, const char *what)
{
    if (mdl__get_count(b, n, what))
        return NULL;
    float *a = mdl__calloc(n ? n : 1, sizeof *a);
    if (!a) {
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
        return NULL;
    }
    for (size_t i = 0; i < n && !b->rc; i++) {
        uint32_t v = mdl__get_u32(b);
        memcpy(&a[i], &v, 4);
        if (!isfinite(a[i])) {
            char msg[160];
            snprintf(msg, sizeof msg, "%s[%zu] is not a finite number", what, i);
            mdl__rfail(b, msg);
        }
    }
    if (b->rc) {
        free(a);
        return NULL;
    }
    return a;
}

double *mdl__get_f64s(mdl__rbuf *b, size_t n, const char *what)
{
    uint32_t c = mdl__get_u32(b);
    if (b->rc)
        return NULL;
    if (c != n || n > MAX_COUNT || n * 8 > b->n - b->at) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s has %u entries, expected %zu (or the file is short)", what, c, n);
        mdl__rfail(b, msg);
        return NULL;
    }
    double *a = mdl__calloc(n ? n : 1, sizeof *a);
    if (!a) {
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
        return NULL;
    }
    for (size_t i = 0; i < n && !b->rc; i++)
        a[i] = mdl__get_f64(b, what);
    if (b->rc) {
        free(a);
        return NULL;
    }
    return a;
}

/* offsets: off[0] == 0, non-decreasing, off[n] <= limit */
int mdl__check_offsets(mdl__rbuf *b, const int *off, int n, const char *what)
{
    if (b->rc)
        return b->rc;
    if (off[0] != 0)
        return mdl__rfail(b, what);
    for (int i = 0; i < n; i++)
        if (off[i + 1] < off[i]) {
            char msg[160];
            snprintf(msg, sizeof msg, "%s decreases at %d", what, i);
            return mdl__rfail(b, msg);
        }
    return 0;
}

void mdl__get_name(mdl__rbuf *b, char *dst)
{
    mdl__get_bytes(b, dst, MDL_NAME_LEN);
    dst[MDL_NAME_LEN - 1] = 0;
}

