/* frames.c - frame selections written as Python slices: "start:stop[:step]", or "N" for one frame.
 *
 * Resolution follows Python's slice.indices(count) (CPython Objects/sliceobject.c semantics):
 *   step omitted -> 1; step 0 -> error;
 *   step > 0: bounds [0, count],    omitted start -> 0,        omitted stop -> count;
 *   step < 0: bounds [-1, count-1], omitted start -> count-1,  omitted stop -> -1;
 *   a given negative start/stop gets count added, then is clamped into the bounds;
 * and the result is range(start, stop, step). "N" is Python indexing: -1 is the last frame, and an
 * index outside [-count, count) is an error. A selection of no frames is an error too.
 */
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

#define FRAMES_BIG (LLONG_MAX / 4) /* integers saturate here; any frame count is far below */

/* An optional integer in [s, e) with surrounding blanks. *given = 0 when only blanks. */
static int parse_part(const char *s, const char *e, long long *v, int *given)
{
    while (s < e && (*s == ' ' || *s == '\t'))
        s++;
    while (e > s && (e[-1] == ' ' || e[-1] == '\t'))
        e--;
    *given = s < e;
    if (!*given)
        return 0;
    int neg = 0;
    if (*s == '+' || *s == '-')
        neg = *s++ == '-';
    if (s == e)
        return -1;
    long long x = 0;
    for (; s < e; s++) {
        if (*s < '0' || *s > '9')
            return -1;
        x = x < FRAMES_BIG / 10 ? x * 10 + (*s - '0') : FRAMES_BIG;
    }
    *v = neg ? -x : x;
    return 0;
}

static long long clamp_index(long long x, long long count, long long lo, long long hi)
{
    if (x < 0) {
        x += count;
        return x < lo ? lo : x;
    }
    return x > hi ? hi : x;
}

int mdl_parse_frames(const char *spec, int count, int **idx, int *n, char *err)
{
    *idx = NULL;
    *n = 0;
    if (!spec)
        return mdl__err(err, -EINVAL, "frames: no selection given");
    if (count < 0)
        return mdl__err(err, -EINVAL, "frames \"%s\": negative frame count %d", spec, count);
    const char *end = spec + strlen(spec);
    const char *c1 = strchr(spec, ':');
    const char *c2 = c1 ? strchr(c1 + 1, ':') : NULL;
    if (c2 && strchr(c2 + 1, ':'))
        return mdl__err(err, -EINVAL, "frames \"%s\": too many ':' (expected start:stop[:step])",
                        spec);
    long long start = 0, stop = 0, step = 1;
    int has_start, has_stop, has_step = 0;
    if (!c1) { /* a single index */
        if (parse_part(spec, end, &start, &has_start) || !has_start)
            return mdl__err(err, -EINVAL,
                            "frames \"%s\": not a frame number or a slice start:stop[:step]", spec);
        if (start < -(long long)count || start >= count)
            return mdl__err(err, -EINVAL, "frames \"%s\": frame %lld is out of range (%d frames)",
                            spec, start, count);
        if (!(*idx = malloc(sizeof **idx)))
            return mdl__err(err, -ENOMEM, "frames \"%s\": out of memory", spec);
        **idx = (int)(start < 0 ? start + count : start);
        *n = 1;
        return 0;
    }
    if (parse_part(spec, c1, &start, &has_start))
        return mdl__err(err, -EINVAL, "frames \"%s\": bad start \"%.*s\"", spec, (int)(c1 - spec),
                        spec);
    const char *se = c2 ? c2 : end;
    if (parse_part(c1 + 1, se, &stop, &has_stop))
        return mdl__err(err, -EINVAL, "frames \"%s\": bad stop \"%.*s\"", spec,
                        (int)(se - c1 - 1), c1 + 1);
    if (c2 && parse_part(c2 + 1, end, &step, &has_step))
        return mdl__err(err, -EINVAL, "frames \"%s\": bad step \"%s\"", spec, c2 + 1);
    if (!has_step)
        step = 1;
    if (step == 0)
        return mdl__err(err, -EINVAL, "frames \"%s\": step must not be zero", spec);

    long long cnt = count;
    long long lo = step < 0 ? -1 : 0, hi = step < 0 ? cnt - 1 : cnt;
    start = has_start ? clamp_index(start, cnt, lo, hi) : (step < 0 ? hi : lo);
    stop = has_stop ? clamp_index(stop, cnt, lo, hi) : (step < 0 ? lo : hi);

    long long m = 0; /* len(range(start, stop, step)) */
    if (step > 0 && stop > start)
        m = (stop - start - 1) / step + 1;
    else if (step < 0 && stop < start)
        m = (start - stop - 1) / (-step) + 1;
    if (m == 0)
        return mdl__err(err, -EINVAL, "frames \"%s\": selects no frames (%d frames)", spec, count);
    int *out = malloc((size_t)m * sizeof *out);
    if (!out)
        return mdl__err(err, -ENOMEM, "frames \"%s\": out of memory", spec);
    for (long long i = 0; i < m; i++)
        out[i] = (int)(start + i * step);
    *idx = out;
    *n = (int)m;
    return 0;
}
