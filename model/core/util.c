/* util.c - error formatting, whole-file reading and checked allocation for model/. */
#include "core/util.h"
#include "model.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int mdl__err(char *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, MDL_ERR_LEN, fmt, ap);
        va_end(ap);
    }
    return code;
}

void *mdl__calloc(size_t n, size_t size)
{
    if (size && n > SIZE_MAX / size)
        return NULL;
    return calloc(n ? n : 1, size ? size : 1);
}

int mdl__read_file(const char *path, size_t max_bytes, char **buf, size_t *len, char *err)
{
    *buf = NULL;
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return mdl__err(err, -errno, "%s: cannot open: %s", path, strerror(errno));
    struct stat st; /* a directory opens, and "seeks" to LONG_MAX */
    if (fstat(fileno(f), &st) == 0 && !S_ISREG(st.st_mode)) {
        fclose(f);
        if (S_ISDIR(st.st_mode))
            return mdl__err(err, -EISDIR, "%s: is a directory, not a file", path);
        return mdl__err(err, -EINVAL, "%s: not a regular file", path);
    }
    if (fseek(f, 0, SEEK_END) != 0) {
        int e = errno;
        fclose(f);
        return mdl__err(err, -e, "%s: cannot seek: %s", path, strerror(e));
    }
    long size = ftell(f);
    if (size < 0 || (unsigned long)size > max_bytes) {
        fclose(f);
        if (size < 0)
            return mdl__err(err, -EIO, "%s: cannot tell size", path);
        return mdl__err(err, -EFBIG, "%s: %ld bytes is larger than the limit of %zu", path, size,
                        max_bytes);
    }
    rewind(f);
    char *b = malloc((size_t)size + 1);
    if (!b) {
        fclose(f);
        return mdl__err(err, -ENOMEM, "%s: out of memory for %ld bytes", path, size);
    }
    size_t got = fread(b, 1, (size_t)size, f);
    int rerr = ferror(f);
    fclose(f);
    if (got != (size_t)size || rerr) {
        free(b);
        return mdl__err(err, -EIO, "%s: short read (%zu of %ld bytes)", path, got, size);
    }
    b[size] = 0;
    *buf = b;
    *len = (size_t)size;
    return 0;
}

static uint64_t splitmix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

double mdl__uniform(uint64_t *state)
{
    return ((double)(splitmix(state) >> 11) + 0.5) / 9007199254740992.0;
}

double mdl__gauss(uint64_t *state)
{
    double u = mdl__uniform(state), v = mdl__uniform(state);
    return sqrt(-2 * log(u)) * cos(2 * M_PI * v);
}

void mdl__appendf(char *buf, size_t len, size_t *at, const char *fmt, ...)
{
    if (*at >= len)
        return;
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(buf + *at, len - *at, fmt, ap);
    va_end(ap);
    if (w > 0)
        *at = (size_t)w < len - *at ? *at + (size_t)w : len;
}
