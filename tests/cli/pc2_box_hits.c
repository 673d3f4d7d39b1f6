/* pc2_box_hits.c - an independent check for test_variations.sh's --avoid (it shares no code with
 * model/): which frames of a PC2 point cache, with the triangles of an OBJ, meet a solid
 * axis-aligned box. A triangle meets the solid box iff a corner lies in it, or an edge crosses it
 * (the segment clipped by the three slabs is not empty), or an edge of the box crosses the
 * triangle (where the triangle's interior cuts through the box without its edges touching, the
 * box's section by the triangle's plane is a polygon inside the triangle whose corners are on box
 * edges). Closed: touching counts.
 * Usage: pc2_box_hits FILE.pc2 MESH.obj XMIN YMIN ZMIN XMAX YMAX ZMAX
 * Prints "frames F hits H first K" (K -1 when none). Exit 0, or 2 on bad input. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double lo[3], hi[3];

static int in_box(const double *p)
{
    for (int c = 0; c < 3; c++)
        if (p[c] < lo[c] || p[c] > hi[c])
            return 0;
    return 1;
}

/* segment a + s (b - a), s in [0, 1], clipped by the slabs: not empty */
static int seg_box(const double *a, const double *b)
{
    double s0 = 0, s1 = 1;
    for (int c = 0; c < 3; c++) {
        double d = b[c] - a[c];
        if (d == 0) {
            if (a[c] < lo[c] || a[c] > hi[c])
                return 0;
            continue;
        }
        double u = (lo[c] - a[c]) / d, v = (hi[c] - a[c]) / d;
        if (u > v) {
            double t = u;
            u = v;
            v = t;
        }
        s0 = u > s0 ? u : s0;
        s1 = v < s1 ? v : s1;
        if (s0 > s1)
            return 0;
    }
    return 1;
}

/* segment pq against triangle abc (closed), by the plane crossing and barycentric coordinates */
static int seg_tri(const double *p, const double *q, const double *a, const double *b, const double *c)
{
    double e1[3], e2[3], n[3], d[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = b[k] - a[k];
        e2[k] = c[k] - a[k];
        d[k] = q[k] - p[k];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    if (den == 0)
        return 0; /* parallel: the triangle's own edges or corners would meet the box */
    double s = (n[0] * (a[0] - p[0]) + n[1] * (a[1] - p[1]) + n[2] * (a[2] - p[2])) / den;
    if (s < 0 || s > 1)
        return 0;
    double x[3] = {p[0] + s * d[0] - a[0], p[1] + s * d[1] - a[1], p[2] + s * d[2] - a[2]};
    double d11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
    double d12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2];
    double d22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
    double x1 = x[0] * e1[0] + x[1] * e1[1] + x[2] * e1[2];
    double x2 = x[0] * e2[0] + x[1] * e2[1] + x[2] * e2[2];
    double det = d11 * d22 - d12 * d12;
    if (det == 0)
        return 0;
    double u = (d22 * x1 - d12 * x2) / det, v = (d11 * x2 - d12 * x1) / det;
    return u >= 0 && v >= 0 && u + v <= 1;
}

static int tri_box(const double *a, const double *b, const double *c)
{
    if (in_box(a) || in_box(b) || in_box(c) || seg_box(a, b) || seg_box(b, c) || seg_box(c, a))
        return 1;
    for (int e = 0; e < 12; e++) { /* the box's edges: along axis e / 4, the other two at lo/hi */
        int ax = e / 4, u = (ax + 1) % 3, w = (ax + 2) % 3;
        double p[3], q[3];
        p[ax] = lo[ax];
        q[ax] = hi[ax];
        p[u] = q[u] = (e & 1) ? hi[u] : lo[u];
        p[w] = q[w] = (e & 2) ? hi[w] : lo[w];
        if (seg_tri(p, q, a, b, c))
            return 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 9) {
        fprintf(stderr, "usage: pc2_box_hits FILE.pc2 MESH.obj XMIN YMIN ZMIN XMAX YMAX ZMAX\n");
        return 2;
    }
    for (int c = 0; c < 3; c++) {
        lo[c] = atof(argv[3 + c]);
        hi[c] = atof(argv[6 + c]);
    }
    FILE *o = fopen(argv[2], "r");
    if (!o) {
        perror(argv[2]);
        return 2;
    }
    size_t nf = 0, cap = 1024;
    int *F = malloc(cap * 3 * sizeof *F);
    char line[4096];
    while (fgets(line, sizeof line, o)) {
        if (line[0] != 'f' || line[1] != ' ')
            continue;
        int idx[64], n = 0;
        for (char *t = strtok(line + 2, " \t\r\n"); t && n < 64; t = strtok(NULL, " \t\r\n"))
            idx[n++] = atoi(t) - 1; /* "v", "v/t", "v//n": the number before the first slash */
        for (int k = 1; k + 1 < n; k++) {
            if (nf == cap)
                F = realloc(F, (cap *= 2) * 3 * sizeof *F);
            F[3 * nf] = idx[0];
            F[3 * nf + 1] = idx[k];
            F[3 * nf + 2] = idx[k + 1];
            nf++;
        }
    }
    fclose(o);
    FILE *f = fopen(argv[1], "rb");
    char magic[12];
    int32_t ver, np, nframes;
    float start, rate;
    if (!f || fread(magic, 1, 12, f) != 12 || memcmp(magic, "POINTCACHE2", 12) ||
        fread(&ver, 4, 1, f) != 1 || fread(&np, 4, 1, f) != 1 || fread(&start, 4, 1, f) != 1 ||
        fread(&rate, 4, 1, f) != 1 || fread(&nframes, 4, 1, f) != 1 || np < 1 || nframes < 0) {
        fprintf(stderr, "%s: not a PC2 file\n", argv[1]);
        return 2;
    }
    for (size_t k = 0; k < 3 * nf; k++)
        if (F[k] < 0 || F[k] >= np) {
            fprintf(stderr, "%s: a face names vertex %d of %d\n", argv[2], F[k] + 1, np);
            return 2;
        }
    float *P = malloc((size_t)np * 12);
    double *D = malloc((size_t)np * 3 * sizeof *D);
    int hits = 0, first = -1;
    for (int t = 0; t < nframes; t++) {
        if (fread(P, 12, (size_t)np, f) != (size_t)np) {
            fprintf(stderr, "%s: short at frame %d\n", argv[1], t);
            return 2;
        }
        for (int i = 0; i < 3 * np; i++)
            D[i] = P[i];
        int hit = 0;
        for (size_t k = 0; k < nf && !hit; k++)
            hit = tri_box(D + 3 * F[3 * k], D + 3 * F[3 * k + 1], D + 3 * F[3 * k + 2]);
        if (hit && first < 0)
            first = t;
        hits += hit;
    }
    fclose(f);
    printf("frames %d hits %d first %d\n", nframes, hits, first);
    free(P);
    free(D);
    free(F);
    return 0;
}
