/* meshgraph.c - mesh edge graph (CSR) and multi-source Dijkstra (see meshgraph.h). */
#include "core/meshgraph.h"
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static int cmp_int(const void *a, const void *b)
{
    int x = *(const int *)a, y = *(const int *)b;
    return (x > y) - (x < y);
}

int mdl__graph_init(mdl_graph *g, int nv, const uint32_t *F, int nf, char *err)
{
    memset(g, 0, sizeof *g);
    g->nv = nv;
    int *deg = mdl__calloc((size_t)nv + 1, sizeof *deg);
    if (!deg)
        return mdl__err(err, -ENOMEM, "graph: out of memory");
    for (int f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++)
            deg[F[3 * f + k]] += 2;
    g->off = mdl__calloc((size_t)nv + 1, sizeof *g->off);
    for (int v = 0; v < nv; v++)
        g->off[v + 1] = g->off[v] + deg[v];
    int *raw = mdl__calloc((size_t)g->off[nv] + 1, sizeof *raw);
    if (!g->off || !raw) {
        free(deg);
        free(raw);
        mdl__graph_fini(g);
        return mdl__err(err, -ENOMEM, "graph: out of memory");
    }
    memset(deg, 0, sizeof *deg * ((size_t)nv + 1));
    for (int f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++) {
            int a = (int)F[3 * f + k], b = (int)F[3 * f + (k + 1) % 3], c = (int)F[3 * f + (k + 2) % 3];
            raw[g->off[a] + deg[a]++] = b;
            raw[g->off[a] + deg[a]++] = c;
        }
    /* sort and deduplicate each row */
    int *off2 = mdl__calloc((size_t)nv + 1, sizeof *off2);
    if (!off2) {
        free(deg);
        free(raw);
        mdl__graph_fini(g);
        return mdl__err(err, -ENOMEM, "graph: out of memory");
    }
    int w = 0;
    for (int v = 0; v < nv; v++) {
        int s = g->off[v], e = g->off[v + 1];
        qsort(raw + s, (size_t)(e - s), sizeof *raw, cmp_int);
        off2[v] = w;
        for (int i = s; i < e; i++)
            if (raw[i] != v && (w == off2[v] || raw[w - 1] != raw[i]))
                raw[w++] = raw[i];
    }
    off2[nv] = w;
    free(g->off);
    g->off = off2;
    g->nbr = raw;
    free(deg);
    return 0;
}

void mdl__graph_fini(mdl_graph *g)
{
    free(g->off);
    free(g->nbr);
    g->off = g->nbr = NULL;
}

typedef struct heap {
    int n;
    int *v;
    double *d;
} heap;

static void heap_push(heap *h, int v, double d)
{
    int i = h->n++;
    while (i > 0) {
        int p = (i - 1) / 2;
        if (h->d[p] <= d)
            break;
        h->v[i] = h->v[p];
        h->d[i] = h->d[p];
        i = p;
    }
    h->v[i] = v;
    h->d[i] = d;
}

static void heap_pop(heap *h, int *v, double *d)
{
    *v = h->v[0];
    *d = h->d[0];
    int lv = h->v[--h->n];
    double ld = h->d[h->n];
    int i = 0;
    for (;;) {
        int c = 2 * i + 1;
        if (c >= h->n)
            break;
        if (c + 1 < h->n && h->d[c + 1] < h->d[c])
            c++;
        if (h->d[c] >= ld)
            break;
        h->v[i] = h->v[c];
        h->d[i] = h->d[c];
        i = c;
    }
    h->v[i] = lv;
    h->d[i] = ld;
}

int mdl__geodesic(const mdl_graph *g, const float *X, const int *src, int nsrc,
                  const uint8_t *allowed, double *dist, char *err)
{
    int nv = g->nv;
    /* lazy deletion: at most one push per directed edge plus the sources */
    size_t cap = (size_t)g->off[nv] + (size_t)nsrc + 1;
    heap h = {0, malloc(cap * sizeof(int)), malloc(cap * sizeof(double))};
    if (!h.v || !h.d) {
        free(h.v);
        free(h.d);
        return mdl__err(err, -ENOMEM, "geodesic: out of memory");
    }
    for (int v = 0; v < nv; v++)
        dist[v] = INFINITY;
    for (int i = 0; i < nsrc; i++) {
        int s = src[i];
        if (allowed && !allowed[s])
            continue;
        if (dist[s] > 0) {
            dist[s] = 0;
            heap_push(&h, s, 0);
        }
    }
    while (h.n > 0) {
        int v;
        double d;
        heap_pop(&h, &v, &d);
        if (d > dist[v])
            continue;
        for (int i = g->off[v]; i < g->off[v + 1]; i++) {
            int u = g->nbr[i];
            if (allowed && !allowed[u])
                continue;
            double dx = X[3 * u] - X[3 * v], dy = X[3 * u + 1] - X[3 * v + 1],
                   dz = X[3 * u + 2] - X[3 * v + 2];
            double nd = d + sqrt(dx * dx + dy * dy + dz * dz);
            if (nd < dist[u]) {
                dist[u] = nd;
                if ((size_t)h.n < cap)
                    heap_push(&h, u, nd);
            }
        }
    }
    free(h.v);
    free(h.d);
    return 0;
}
