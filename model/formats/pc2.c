/* pc2.c - PC2 point caches (Blender / 3ds Max "Point Cache 2"): parser and writer.
 *
 * Layout, all little-endian:
 *   offset  0  char[12]  "POINTCACHE2\0"
 *   offset 12  int32     version, 1
 *   offset 16  int32     numPoints   (N)
 *   offset 20  float32   startFrame
 *   offset 24  float32   sampleRate  (frames between samples)
 *   offset 28  int32     numSamples  (F)
 *   offset 32  float32   F x N x 3 positions, sample-major (our frames x nv x 3)
 * The file size must be exactly 32 + 12 N F. Values are assembled byte by byte, so the code is
 * independent of the host's byte order and alignment.
 */
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PC2_HEADER 32

static uint32_t rd_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float rd_f32(const uint8_t *p)
{
    uint32_t u = rd_u32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static void wr_u32(uint8_t *p, uint32_t u)
{
    p[0] = (uint8_t)u;
    p[1] = (uint8_t)(u >> 8);
    p[2] = (uint8_t)(u >> 16);
    p[3] = (uint8_t)(u >> 24);
}

static void wr_f32(uint8_t *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    wr_u32(p, u);
}

int mdl_pc2_parse(const uint8_t *buf, size_t len, const char *name, int *nv, int *frames,
                  float *start, float *rate, float **V, char *err)
{
    *V = NULL;
    if (!name)
        name = "<pc2>";
    if (len < PC2_HEADER)
        return mdl__err(err, MDL_EFORMAT, "%s: %zu bytes is shorter than the 32-byte PC2 header",
                        name, len);
    if (memcmp(buf, "POINTCACHE2\0", 12) != 0)
        return mdl__err(err, MDL_EFORMAT, "%s: offset 0: bad magic (expected \"POINTCACHE2\\0\")",
                        name);
    int32_t version = (int32_t)rd_u32(buf + 12);
    int32_t n = (int32_t)rd_u32(buf + 16);
    float st = rd_f32(buf + 20), rt = rd_f32(buf + 24);
    int32_t f = (int32_t)rd_u32(buf + 28);
    if (version != 1)
        return mdl__err(err, MDL_EVERSION, "%s: offset 12: version %d is not supported (expected 1)",
                        name, (int)version);
    if (n <= 0)
        return mdl__err(err, MDL_EFORMAT, "%s: offset 16: numPoints %d (must be positive)", name,
                        (int)n);
    if (f <= 0)
        return mdl__err(err, MDL_EFORMAT, "%s: offset 28: numSamples %d (must be positive)", name,
                        (int)f);
    if (!isfinite(st))
        return mdl__err(err, MDL_EFORMAT, "%s: offset 20: startFrame is not finite", name);
    if (!isfinite(rt))
        return mdl__err(err, MDL_EFORMAT, "%s: offset 24: sampleRate is not finite", name);
    /* both counts are < 2^31, so 3 N F < 3 * 2^62 fits in 64 bits; 32 + 12 N F may not */
    uint64_t values = (uint64_t)n * (uint64_t)f * 3u;
    if (values > (UINT64_MAX - PC2_HEADER) / 4u)
        return mdl__err(err, MDL_EFORMAT,
                        "%s: size %zu bytes, but %d points x %d samples need 32 + 12*%d*%d bytes, "
                        "more than 2^64", name, len, (int)n, (int)f, (int)n, (int)f);
    uint64_t want = PC2_HEADER + values * 4u;
    if ((uint64_t)len != want)
        return mdl__err(err, MDL_EFORMAT,
                        "%s: size %zu bytes, but %d points x %d samples need 32 + 12*%d*%d = %llu",
                        name, len, (int)n, (int)f, (int)n, (int)f, (unsigned long long)want);
    if ((uint64_t)n * (uint64_t)f > (uint64_t)INT_MAX)
        return mdl__err(err, MDL_EFORMAT, "%s: %d points x %d samples is too large", name, (int)n,
                        (int)f);
    float *out = mdl__calloc((size_t)values, sizeof(float));
    if (!out)
        return mdl__err(err, -ENOMEM, "%s: out of memory for %d x %d points", name, (int)f, (int)n);
    const uint8_t *p = buf + PC2_HEADER;
    for (size_t i = 0; i < (size_t)values; i++) {
        out[i] = rd_f32(p + 4 * i);
        if (!isfinite(out[i])) {
            size_t pt = i / 3;
            free(out);
            return mdl__err(err, MDL_EFORMAT,
                            "%s: offset %zu: sample %zu point %zu %c is not finite", name,
                            (size_t)PC2_HEADER + 4 * i, pt / (size_t)n, pt % (size_t)n, "xyz"[i % 3]);
        }
    }
    *nv = n;
    *frames = f;
    if (start)
        *start = st;
    if (rate)
        *rate = rt;
    *V = out;
    return 0;
}

int mdl_pc2_write(const char *path, const float *V, int nv, int frames, float start, float rate,
                  char *err)
{
    if (nv <= 0 || frames <= 0 || !V)
        return mdl__err(err, -EINVAL, "%s: invalid point cache (%d points, %d frames)", path, nv,
                        frames);
    uint8_t head[PC2_HEADER];
    memcpy(head, "POINTCACHE2\0", 12);
    wr_u32(head + 12, 1);
    wr_u32(head + 16, (uint32_t)nv);
    wr_f32(head + 20, start);
    wr_f32(head + 24, rate);
    wr_u32(head + 28, (uint32_t)frames);
    FILE *f = fopen(path, "wb");
    if (!f)
        return mdl__err(err, -errno, "%s: cannot create: %s", path, strerror(errno));
    int bad = fwrite(head, 1, sizeof head, f) != sizeof head;
    /* through a fixed chunk buffer, converted to little-endian */
    uint8_t chunk[12 * 1024];
    size_t total = (size_t)nv * (size_t)frames * 3, used = 0;
    for (size_t i = 0; i < total && !bad; i++) {
        wr_f32(chunk + used, V[i]);
        used += 4;
        if (used == sizeof chunk || i + 1 == total) {
            bad = fwrite(chunk, 1, used, f) != used;
            used = 0;
        }
    }
    int e = errno;
    if (fclose(f) != 0 && !bad) {
        bad = 1;
        e = errno;
    }
    if (bad) {
        remove(path);
        return mdl__err(err, -(e ? e : EIO), "%s: write failed: %s", path, strerror(e ? e : EIO));
    }
    return 0;
}
