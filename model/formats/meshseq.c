/* meshseq.c - mesh sequences: a directory of numbered OBJ frames, or a PC2 cache plus a rest OBJ;
 * the topology fingerprint; writing a sequence back as numbered OBJ frames.
 *
 * Directory order is "natural": runs of digits compare by value, so 2.obj < 10.obj and
 * 0009.obj < 0010.obj; names equal by value ("01" vs "1") fall back to byte order. Every frame must
 * have the faces of the first one (DESIGN.md: one topology per sequence).
 *
 * Topology fingerprint: FNV-1a 64 (Fowler, Noll, Vo; offset basis 0xcbf29ce484222325, prime
 * 0x100000001b3) over the bytes of nv, nf and then the 3 nf indices, each as a little-endian uint32.
 */
#include "model.h"
#include "core/util.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define PC2_MAX_FILE (SIZE_MAX / 2)

static int has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return n > e && strcasecmp(name + n - e, ext) == 0;
}

/* Natural order: digit runs by numeric value (leading zeros skipped), other bytes as unsigned. */
static int natural_cmp(const char *a, const char *b)
{
    const char *pa = a, *pb = b;
    while (*pa && *pb) {
        if (isdigit((unsigned char)*pa) && isdigit((unsigned char)*pb)) {
            while (*pa == '0')
                pa++;
            while (*pb == '0')
                pb++;
            const char *ea = pa, *eb = pb;
            while (isdigit((unsigned char)*ea))
                ea++;
            while (isdigit((unsigned char)*eb))
                eb++;
            if (ea - pa != eb - pb)
                return ea - pa < eb - pb ? -1 : 1;
            int c = memcmp(pa, pb, (size_t)(ea - pa));
            if (c)
                return c;
            pa = ea;
            pb = eb;
        } else {
            if (*pa != *pb)
                return (unsigned char)*pa < (unsigned char)*pb ? -1 : 1;
            pa++;
            pb++;
        }
    }
    if (*pa || *pb)
        return *pa ? 1 : -1;
    return strcmp(a, b);
}

static int natural_qsort(const void *a, const void *b)
{
    return natural_cmp(*(char *const *)a, *(char *const *)b);
}

static void free_names(char **names, size_t n)
{
    for (size_t i = 0; i < n; i++)
        free(names[i]);
    free(names);
}

/* The *.obj names of `dir` in natural order. */
static int list_obj(const char *dir, char ***out, size_t *count, char *err)
{
    *out = NULL;
    *count = 0;
    DIR *d = opendir(dir);
    if (!d)
        return mdl__err(err, -errno, "%s: cannot open directory: %s", dir, strerror(errno));
    char **names = NULL;
    size_t n = 0, cap = 0;
    struct dirent *de;
    int r = 0;
    errno = 0;
    while ((de = readdir(d)) != NULL) {
        if (de->d_name[0] == '.' || !has_ext(de->d_name, ".obj"))
            continue;
        if (n == cap) {
            size_t nc = cap ? 2 * cap : 64;
            char **nn = realloc(names, nc * sizeof *nn);
            if (!nn) {
                r = -ENOMEM;
                break;
            }
            names = nn;
            cap = nc;
        }
        if (!(names[n] = strdup(de->d_name))) {
            r = -ENOMEM;
            break;
        }
        n++;
    }
    if (!r && errno)
        r = -errno;
    closedir(d);
    if (r) {
        free_names(names, n);
        return mdl__err(err, r, "%s: cannot list directory: %s", dir, strerror(-r));
    }
    if (n == 0) {
        free(names);
        return mdl__err(err, -ENOENT, "%s: no .obj files in the directory", dir);
    }
    qsort(names, n, sizeof *names, natural_qsort);
    *out = names;
    *count = n;
    return 0;
}

static int seq_alloc(int nv, int nf, int frames, mdl_meshseq **out)
{
    mdl_meshseq *s = calloc(1, sizeof *s);
    if (!s)
        return -ENOMEM;
    s->nv = nv;
    s->nf = nf;
    s->frames = frames;
    s->V = mdl__calloc((size_t)frames * (size_t)nv, 3 * sizeof(float));
    s->F = mdl__calloc((size_t)nf, 3 * sizeof(uint32_t));
    if (!s->V || !s->F) {
        mdl_meshseq_destroy(s);
        return -ENOMEM;
    }
    *out = s;
    return 0;
}

static int read_dir(const char *dir, mdl_meshseq **out, char *err)
{
    char **names;
    size_t n;
    int r = list_obj(dir, &names, &n, err);
    if (r)
        return r;
    if (n > INT_MAX) {
        free_names(names, n);
        return mdl__err(err, -E2BIG, "%s: too many files", dir);
    }
    size_t plen = strlen(dir) + 256 + 2;
    char *path = malloc(plen), *first = malloc(plen);
    mdl_meshseq *s = NULL;
    mdl_mesh *m = NULL;
    if (!path || !first) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", dir);
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        snprintf(path, plen, "%s/%s", dir, names[i]);
        if ((r = mdl_mesh_read_obj(path, &m, err)) != 0)
            goto done;
        if (i == 0) {
            memcpy(first, path, plen);
            if ((r = seq_alloc(m->nv, m->nf, (int)n, &s)) != 0) {
                r = mdl__err(err, r, "%s: out of memory for %zu frames of %d vertices", dir, n,
                             m->nv);
                goto done;
            }
            memcpy(s->F, m->F, (size_t)m->nf * 3 * sizeof(uint32_t));
        } else if (m->nv != s->nv) {
            r = mdl__err(err, MDL_ETOPOLOGY, "%s: %d vertices, but %s has %d", path, m->nv, first,
                         s->nv);
            goto done;
        } else if (m->nf != s->nf) {
            r = mdl__err(err, MDL_ETOPOLOGY, "%s: %d triangles, but %s has %d", path, m->nf, first,
                         s->nf);
            goto done;
        } else if (memcmp(m->F, s->F, (size_t)m->nf * 3 * sizeof(uint32_t)) != 0) {
            int t = 0;
            while (memcmp(m->F + 3 * t, s->F + 3 * t, 3 * sizeof(uint32_t)) == 0)
                t++;
            r = mdl__err(err, MDL_ETOPOLOGY,
                         "%s: faces differ from %s (first difference at triangle %d: %u %u %u vs %u %u %u, 0-based)",
                         path, first, t, m->F[3 * t], m->F[3 * t + 1], m->F[3 * t + 2], s->F[3 * t],
                         s->F[3 * t + 1], s->F[3 * t + 2]);
            goto done;
        }
        memcpy(s->V + i * (size_t)s->nv * 3, m->V, (size_t)m->nv * 3 * sizeof(float));
        mdl_mesh_destroy(m);
        m = NULL;
    }
done:
    mdl_mesh_destroy(m);
    free(path);
    free(first);
    free_names(names, n);
    if (r) {
        mdl_meshseq_destroy(s);
        return r;
    }
    *out = s;
    return 0;
}

static int read_pc2(const char *path, const char *rest_obj, mdl_meshseq **out, char *err)
{
    if (!rest_obj || !*rest_obj)
        return mdl__err(err, -EINVAL, "%s: a PC2 cache needs a rest OBJ for its faces", path);
    mdl_mesh *m = NULL;
    int r = mdl_mesh_read_obj(rest_obj, &m, err);
    if (r)
        return r;
    char *buf;
    size_t len;
    if ((r = mdl__read_file(path, PC2_MAX_FILE, &buf, &len, err)) != 0) {
        mdl_mesh_destroy(m);
        return r;
    }
    int nv, frames;
    float *V;
    r = mdl_pc2_parse((const uint8_t *)buf, len, path, &nv, &frames, NULL, NULL, &V, err);
    free(buf);
    if (r) {
        mdl_mesh_destroy(m);
        return r;
    }
    if (nv != m->nv) {
        r = mdl__err(err, MDL_ETOPOLOGY, "%s: %d points, but the rest mesh %s has %d vertices",
                     path, nv, rest_obj, m->nv);
        free(V);
        mdl_mesh_destroy(m);
        return r;
    }
    mdl_meshseq *s = calloc(1, sizeof *s);
    if (!s) {
        free(V);
        mdl_mesh_destroy(m);
        return mdl__err(err, -ENOMEM, "%s: out of memory", path);
    }
    s->nv = nv;
    s->nf = m->nf;
    s->frames = frames;
    s->fps = 0; /* PC2 stores a sample rate in frames, not a frame rate */
    s->V = V;
    s->F = m->F; /* take the faces over from the rest mesh */
    m->F = NULL;
    mdl_mesh_destroy(m);
    *out = s;
    return 0;
}

static int read_one_obj(const char *path, mdl_meshseq **out, char *err)
{
    mdl_mesh *m;
    int r = mdl_mesh_read_obj(path, &m, err);
    if (r)
        return r;
    mdl_meshseq *s = calloc(1, sizeof *s);
    if (!s) {
        mdl_mesh_destroy(m);
        return mdl__err(err, -ENOMEM, "%s: out of memory", path);
    }
    s->nv = m->nv;
    s->nf = m->nf;
    s->frames = 1;
    s->V = m->V;
    s->F = m->F;
    free(m);
    *out = s;
    return 0;
}

int mdl_meshseq_read(const char *path, const char *rest_obj, mdl_meshseq **out, char *err)
{
    *out = NULL;
    struct stat st;
    if (stat(path, &st) != 0)
        return mdl__err(err, -errno, "%s: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode))
        return read_dir(path, out, err);
    if (has_ext(path, ".pc2"))
        return read_pc2(path, rest_obj, out, err);
    if (has_ext(path, ".obj"))
        return read_one_obj(path, out, err);
    return mdl__err(err, -EINVAL,
                    "%s: not a mesh sequence (expected a directory of .obj frames, a .pc2 or a .obj)",
                    path);
}

void mdl_meshseq_destroy(mdl_meshseq *s)
{
    if (!s)
        return;
    free(s->V);
    free(s->F);
    free(s);
}

int mdl_meshseq_write_objdir(const char *dir, const mdl_meshseq *s, char *err)
{
    if (!s || s->frames <= 0 || s->nv <= 0)
        return mdl__err(err, -EINVAL, "%s: empty mesh sequence", dir);
    if (mkdir(dir, 0777) != 0) {
        int e = errno;
        struct stat st;
        if (e != EEXIST || stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
            return mdl__err(err, -e, "%s: cannot create directory: %s", dir,
                            strerror(e == EEXIST ? ENOTDIR : e));
    }
    size_t plen = strlen(dir) + 32;
    char *path = malloc(plen);
    if (!path)
        return mdl__err(err, -ENOMEM, "%s: out of memory", dir);
    int r = 0;
    for (int i = 0; i < s->frames && r == 0; i++) {
        snprintf(path, plen, "%s/%04d.obj", dir, i);
        r = mdl_mesh_write_obj(path, s->V + (size_t)i * (size_t)s->nv * 3, s->nv, s->F, s->nf, err);
    }
    free(path);
    return r;
}

static uint64_t fnv1a_u32(uint64_t h, uint32_t u)
{
    for (int b = 0; b < 4; b++) {
        h ^= (u >> (8 * b)) & 0xffu;
        h *= 0x100000001b3ull;
    }
    return h;
}

uint64_t mdl_topology_fingerprint(const uint32_t *F, int nf, int nv)
{
    uint64_t h = 0xcbf29ce484222325ull;
    h = fnv1a_u32(h, (uint32_t)nv);
    h = fnv1a_u32(h, (uint32_t)nf);
    for (long i = 0; i < 3L * (nf > 0 ? nf : 0); i++)
        h = fnv1a_u32(h, F[i]);
    return h;
}
