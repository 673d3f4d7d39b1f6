/* obj.c - Wavefront OBJ meshes: reader (v and f lines) and writer.
 *
 * Implements the geometry subset of the OBJ format (Wavefront "Advanced Visualizer" appendix B1):
 *   v x y z [w | r g b]      a vertex; only x y z are kept, further numbers are ignored
 *   f a b c ...              a polygon; each corner is v, v/t, v//n or v/t/n with 1-based indices,
 *                            negative indices count back from the last vertex read so far
 * Polygons with k > 3 corners are fan-triangulated: (c0, c_j, c_j+1) for j = 1 .. k-2.
 * Every other statement (vt, vn, g, o, s, usemtl, mtllib, l, p, comments) is ignored.
 *
 * Numbers are converted to double as strtod does in the "C" locale, then rounded to float, which is
 * exactly float32(float(text)) as Python, Blender and our PC2 converter compute it. A verified fast
 * path (fast_float) handles plain decimals; anything it is not sure about goes to strtod_l, with the
 * token copied into a small stack buffer so that strtod never reads past the caller's buffer, which
 * need not be NUL-terminated. Vertex and triangle arrays grow geometrically: no per-line malloc.
 */
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <limits.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define OBJ_MAX_FILE ((size_t)1 << 31) /* 2 GiB */
#define OBJ_MAX_TOKEN 128               /* longest number we accept, in characters */
#define OBJ_MAX_COUNT (INT_MAX / 4)     /* vertices or triangles */

typedef struct obj_parser {
    const char *name;
    char *err;
    locale_t c_locale;
    long line;
    float *V;
    size_t nv, cap_v;
    uint32_t *F;
    size_t nf, cap_f;
    long max_index;      /* the largest positive vertex index used (1-based), checked at the end */
    long max_index_line; /* where it was used */
} obj_parser;

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* Next token of [*p, end): skips blanks, stops at blanks or '#'. Returns its length (0 at end). */
static size_t next_token(const char **p, const char *end, const char **tok)
{
    const char *s = *p;
    while (s < end && is_space(*s))
        s++;
    if (s < end && *s == '#')
        s = end;
    const char *t = s;
    while (t < end && !is_space(*t) && *t != '#')
        t++;
    *tok = s;
    *p = t;
    return (size_t)(t - s);
}

/* Fast path for plain decimals "[-+]digits[.digits][e[-+]digits]", giving exactly
 * (float)strtod(text), or -1 to leave the token to strtod.
 * The first 19 significant digits form an integer m (later digits only change the value by less
 * than 1e-18 relative), and A = m * 10^e or m / 10^-e with |e| <= 22, where 10^|e| is exact in
 * double. Two roundings make A differ from the correctly rounded double D of the text by at most
 * about 2 units in the last place. Rounding to float drops the low 29 bits of the double's
 * mantissa; A and D round to the same float unless a float rounding midpoint (low bits 2^28) lies
 * between them, so tokens whose A has low bits within 8 of 2^28 go to strtod, as do values outside
 * the normal float range. (Clinger 1990, "How to read floating point numbers accurately", Sec. 3
 * fast path, with an explicit error bound instead of the exact-mantissa condition.) */
static const char *scan_float(const char *p, const char *e, float *out)
{
    static const double pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                     1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                     1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    int neg = 0, digits = 0, any = 0, exp10 = 0;
    uint64_t m = 0;
    if (p < e && (*p == '-' || *p == '+'))
        neg = *p++ == '-';
    for (; p < e && *p >= '0' && *p <= '9'; p++) {
        any = 1;
        if (digits < 19) {
            m = m * 10 + (uint64_t)(*p - '0');
            digits += m != 0;
        } else {
            exp10++;
        }
    }
    if (p < e && *p == '.')
        for (p++; p < e && *p >= '0' && *p <= '9'; p++) {
            any = 1;
            if (digits < 19) {
                m = m * 10 + (uint64_t)(*p - '0');
                digits += m != 0;
                exp10--;
            }
        }
    if (!any)
        return NULL;
    if (p < e && (*p == 'e' || *p == 'E')) {
        int eneg = 0, ev = 0;
        p++;
        if (p < e && (*p == '-' || *p == '+'))
            eneg = *p++ == '-';
        const char *ed = p;
        for (; p < e && *p >= '0' && *p <= '9'; p++)
            if (ev < 10000)
                ev = ev * 10 + (*p - '0');
        if (p == ed)
            return NULL;
        exp10 += eneg ? -ev : ev;
    }
    if (m == 0) {
        *out = neg ? -0.0f : 0.0f;
        return p;
    }
    if (exp10 < -22 || exp10 > 22)
        return NULL;
    double a = (double)m;
    a = exp10 < 0 ? a / pow10[-exp10] : a * pow10[exp10];
    if (!(a >= 0x1p-125 && a < 0x1p127))
        return NULL;
    uint64_t bits;
    memcpy(&bits, &a, sizeof bits);
    uint64_t low = bits & ((1ull << 29) - 1);
    if (low > (1ull << 28) - 8 && low < (1ull << 28) + 8)
        return NULL;
    float f = (float)a;
    *out = neg ? -f : f;
    return p;
}

static int parse_float(obj_parser *ps, const char *tok, size_t n, int which, float *out)
{
    char buf[OBJ_MAX_TOKEN + 1];
    if (n == 0)
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: vertex has only %d coordinates, need 3",
                        ps->name, ps->line, which);
    if (n > OBJ_MAX_TOKEN)
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: bad number: coordinate %d is %zu characters long",
                        ps->name, ps->line, which + 1, n);
    memcpy(buf, tok, n);
    buf[n] = 0;
    char *e;
    double d = strtod_l(buf, &e, ps->c_locale);
    if (e != buf + n || e == buf)
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: bad number \"%s\" for coordinate %d",
                        ps->name, ps->line, buf, which + 1);
    /* 2^128 - 2^103, halfway between FLT_MAX and 2^128: from here on (float)d would be infinite,
     * and the conversion of an out-of-range double is undefined behaviour in C */
    if (!isfinite(d) || fabs(d) >= 0x1.ffffffp127)
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: coordinate %d is not a finite float: \"%s\"",
                        ps->name, ps->line, which + 1, buf);
    *out = (float)d;
    return 0;
}

static int grow(void **arr, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    size_t nc = *cap ? *cap : 1024;
    while (nc < need)
        nc *= 2;
    if (nc > SIZE_MAX / elem)
        return -ENOMEM;
    void *n = realloc(*arr, nc * elem);
    if (!n)
        return -ENOMEM;
    *arr = n;
    *cap = nc;
    return 0;
}

static int parse_vertex(obj_parser *ps, const char *p, const char *end)
{
    if (ps->nv >= OBJ_MAX_COUNT)
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: more than %d vertices", ps->name, ps->line,
                        OBJ_MAX_COUNT);
    if (grow((void **)&ps->V, &ps->cap_v, (ps->nv + 1) * 3, sizeof(float)))
        return mdl__err(ps->err, -ENOMEM, "%s:%ld: out of memory for %zu vertices", ps->name,
                        ps->line, ps->nv + 1);
    float *v = ps->V + ps->nv * 3;
    for (int k = 0; k < 3; k++) {
        while (p < end && is_space(*p))
            p++;
        const char *q = p < end && *p != '#' ? scan_float(p, end, &v[k]) : NULL;
        if (q && (q == end || is_space(*q) || *q == '#')) {
            p = q;
            continue;
        }
        const char *tok; /* not a plain decimal, or too close to call: strtod decides */
        size_t n = next_token(&p, end, &tok);
        int r = parse_float(ps, tok, n, k, &v[k]);
        if (r)
            return r;
    }
    ps->nv++;
    return 0;
}

/* An optional-sign decimal integer filling all of [s, e). Saturates at +-LONG_MAX/2. */
static int parse_int(const char *s, const char *e, long *out)
{
    int neg = 0;
    if (s < e && (*s == '-' || *s == '+'))
        neg = *s++ == '-';
    if (s == e)
        return -1;
    long v = 0;
    for (; s < e; s++) {
        if (*s < '0' || *s > '9')
            return -1;
        if (v < LONG_MAX / 20)
            v = v * 10 + (*s - '0');
    }
    *out = neg ? -v : v;
    return 0;
}

/* One face corner "v", "v/t", "v//n" or "v/t/n"; returns the 0-based vertex index. */
static int parse_corner(obj_parser *ps, const char *tok, size_t n, int corner, uint32_t *out)
{
    const char *end = tok + n;
    const char *s1 = memchr(tok, '/', n);
    const char *ve = s1 ? s1 : end;
    long idx;
    if (parse_int(tok, ve, &idx))
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: face corner %d: bad vertex index \"%.*s\"",
                        ps->name, ps->line, corner + 1, (int)(ve - tok), tok);
    if (s1) { /* texture and normal parts: syntax only, their ranges are not our business */
        const char *s2 = memchr(s1 + 1, '/', (size_t)(end - s1 - 1));
        long dummy;
        int bad;
        if (!s2) /* v/t */
            bad = parse_int(s1 + 1, end, &dummy) != 0;
        else     /* v/t/n or v//n; parse_int also rejects a further '/' */
            bad = (s2 > s1 + 1 && parse_int(s1 + 1, s2, &dummy)) || parse_int(s2 + 1, end, &dummy);
        if (bad)
            return mdl__err(ps->err, MDL_EFORMAT,
                            "%s:%ld: face corner %d: malformed \"%.*s\" (expected v, v/t, v//n or v/t/n)",
                            ps->name, ps->line, corner + 1, (int)n, tok);
    }
    if (idx == 0)
        return mdl__err(ps->err, MDL_EFORMAT,
                        "%s:%ld: face corner %d: vertex index 0 is invalid (OBJ indices start at 1)",
                        ps->name, ps->line, corner + 1);
    if (idx < 0) {
        long abs = (long)ps->nv + idx; /* -1 is the last vertex read so far */
        if (abs < 0)
            return mdl__err(ps->err, MDL_EFORMAT,
                            "%s:%ld: face corner %d: relative index %ld is out of range (%zu vertices so far)",
                            ps->name, ps->line, corner + 1, idx, ps->nv);
        *out = (uint32_t)abs;
        return 0;
    }
    if (idx > OBJ_MAX_COUNT)
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: face corner %d: vertex index %ld is out of range",
                        ps->name, ps->line, corner + 1, idx);
    if (idx > ps->max_index) { /* forward references are allowed; range checked at the end */
        ps->max_index = idx;
        ps->max_index_line = ps->line;
    }
    *out = (uint32_t)(idx - 1);
    return 0;
}

static int parse_face(obj_parser *ps, const char *p, const char *end)
{
    uint32_t first = 0, prev = 0;
    int k = 0;
    for (;; k++) {
        const char *tok;
        size_t n = next_token(&p, end, &tok);
        if (!n)
            break;
        uint32_t c = 0;
        int r = parse_corner(ps, tok, n, k, &c);
        if (r)
            return r;
        if (k == 0) {
            first = c;
        } else if (k >= 2) {
            if (ps->nf >= OBJ_MAX_COUNT)
                return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: more than %d triangles", ps->name,
                                ps->line, OBJ_MAX_COUNT);
            if (grow((void **)&ps->F, &ps->cap_f, (ps->nf + 1) * 3, sizeof(uint32_t)))
                return mdl__err(ps->err, -ENOMEM, "%s:%ld: out of memory for %zu triangles",
                                ps->name, ps->line, ps->nf + 1);
            uint32_t *t = ps->F + ps->nf * 3;
            t[0] = first;
            t[1] = prev;
            t[2] = c;
            ps->nf++;
        }
        prev = c;
    }
    if (k < 3)
        return mdl__err(ps->err, MDL_EFORMAT, "%s:%ld: face with %d vertices (need at least 3)",
                        ps->name, ps->line, k);
    return 0;
}

int mdl_mesh_parse_obj(const char *buf, size_t len, const char *name, mdl_mesh **out, char *err)
{
    *out = NULL;
    if (!name)
        name = "<obj>";
    obj_parser ps = {.name = name, .err = err};
    ps.c_locale = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    if (ps.c_locale == (locale_t)0)
        return mdl__err(err, -errno, "%s: cannot create the C locale: %s", name, strerror(errno));

    int r = 0;
    const char *p = buf, *end = buf + len;
    while (p < end && r == 0) {
        ps.line++;
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        const char *le = nl ? nl : end;
        const char *q = p, *tok;
        size_t n = next_token(&q, le, &tok);
        if (n == 1 && tok[0] == 'v')
            r = parse_vertex(&ps, q, le);
        else if (n == 1 && tok[0] == 'f')
            r = parse_face(&ps, q, le);
        p = nl ? nl + 1 : end;
    }
    freelocale(ps.c_locale);
    if (r == 0 && ps.nv == 0)
        r = mdl__err(err, MDL_EFORMAT, "%s: no vertices (no `v` lines)", name);
    if (r == 0 && ps.max_index > (long)ps.nv)
        r = mdl__err(err, MDL_EFORMAT, "%s:%ld: vertex index %ld is out of range (file has %zu vertices)",
                     name, ps.max_index_line, ps.max_index, ps.nv);
    if (r == 0 && ps.nf == 0)
        r = mdl__err(err, MDL_EFORMAT, "%s: no faces (no `f` lines)", name);
    mdl_mesh *m = NULL;
    if (r == 0 && !(m = calloc(1, sizeof *m)))
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
    if (r) {
        free(ps.V);
        free(ps.F);
        return r;
    }
    /* give back the slack of the geometric growth */
    float *V = realloc(ps.V, ps.nv * 3 * sizeof(float));
    uint32_t *F = realloc(ps.F, ps.nf * 3 * sizeof(uint32_t));
    m->V = V ? V : ps.V;
    m->F = F ? F : ps.F;
    m->nv = (int)ps.nv;
    m->nf = (int)ps.nf;
    *out = m;
    return 0;
}

int mdl_mesh_read_obj(const char *path, mdl_mesh **out, char *err)
{
    *out = NULL;
    char *buf;
    size_t len;
    int r = mdl__read_file(path, OBJ_MAX_FILE, &buf, &len, err);
    if (r)
        return r;
    r = mdl_mesh_parse_obj(buf, len, path, out, err);
    free(buf);
    return r;
}

int mdl_mesh_write_obj(const char *path, const float *V, int nv, const uint32_t *F, int nf, char *err)
{
    if (nv <= 0 || nf <= 0 || !V || !F)
        return mdl__err(err, -EINVAL, "%s: invalid mesh (%d vertices, %d faces)", path, nv, nf);
    for (long i = 0; i < 3L * nf; i++)
        if (F[i] >= (uint32_t)nv)
            return mdl__err(err, -EINVAL, "%s: face %ld has vertex %u, mesh has %d vertices", path,
                            i / 3, F[i], nv);
    locale_t c_locale = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    if (c_locale == (locale_t)0)
        return mdl__err(err, -errno, "%s: cannot create the C locale: %s", path, strerror(errno));
    FILE *f = fopen(path, "w");
    if (!f) {
        int e = errno;
        freelocale(c_locale);
        return mdl__err(err, -e, "%s: cannot create: %s", path, strerror(e));
    }
    /* %.9g round-trips every float exactly. uselocale is per thread, so the decimal point is '.'
     * whatever the program set with setlocale. */
    locale_t old = uselocale(c_locale);
    for (int i = 0; i < nv; i++)
        fprintf(f, "v %.9g %.9g %.9g\n", (double)V[3 * i], (double)V[3 * i + 1], (double)V[3 * i + 2]);
    for (int i = 0; i < nf; i++)
        fprintf(f, "f %u %u %u\n", F[3 * i] + 1, F[3 * i + 1] + 1, F[3 * i + 2] + 1);
    uselocale(old);
    freelocale(c_locale);
    int bad = ferror(f);
    int e = errno;
    if (fclose(f) != 0 && !bad) {
        bad = 1;
        e = errno;
    }
    if (bad)
        return mdl__err(err, -(e ? e : EIO), "%s: write failed: %s", path, strerror(e ? e : EIO));
    return 0;
}

void mdl_mesh_destroy(mdl_mesh *m)
{
    if (!m)
        return;
    free(m->V);
    free(m->F);
    free(m);
}
