/* bone_graph.c - the weakly coupled bone components of a skin (Zheng 2013 Sec. 4.1).
 *
 *   eq. (11)   bone graph: an edge e_ij when some vertex has non-zero weights for both bones,
 *              of weight d_ij = max_v w_vi w_vj
 *   T_e        edges with d_ij < T_e = te_factor x max d_ij (0.1, the paper's) are dropped,
 *              "without breaking the graph into disconnected components": an edge below T_e
 *              that a maximum spanning forest of the full graph needs is kept (Kruskal on
 *              descending d_ij), so the kept graph connects what the full graph connects
 *   cut nodes  the articulation points of the kept graph, by the linear-time depth-first search
 *              of Hopcroft & Tarjan (the algorithm of Thulasiraman & Swamy 1992 the paper cites):
 *              low(u) = the smallest discovery time reachable from u's subtree by one back edge;
 *              a non-root u is a cut node when a child c has low(c) >= disc(u), the root when it
 *              has two children or more. Iterative (an explicit stack), so no recursion limit.
 *   components the blocks (biconnected components) the cut nodes separate, each with its cut
 *              nodes (B_1 u {b_c}, B_2 u {b_c}); found by the same search with an edge stack.
 *              A bone without edges is a block of its own.
 * Analysis, not a per-frame path: it allocates freely. */
#include "variations/variations.h"
#include "core/util.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

void mdl__bone_graph_fini(mdl__bone_graph *g)
{
    free(g->d);
    free(g->kept);
    free(g->cut);
    free(g->block_off);
    free(g->block_bone);
    memset(g, 0, sizeof *g);
}

/* union-find with path halving, for Kruskal */
static int uf_find(int *p, int x)
{
    while (p[x] != x)
        x = p[x] = p[p[x]];
    return x;
}

typedef struct edge {
    int a, b;
    double d;
} edge;

static int cmp_edge_desc(const void *x, const void *y)
{
    const edge *a = x, *b = y;
    if (a->d != b->d)
        return a->d < b->d ? 1 : -1;
    if (a->a != b->a)
        return a->a - b->a;
    return a->b - b->b;
}

/* eq. (11) and T_e: g->d (nb x nb) and g->kept (nb x nb, 0/1) */
static int weigh_edges(mdl__bone_graph *g, int nv, int K, const int *bone, const double *w,
                       double te_factor, char *err)
{
    int nb = g->nb;
    for (int v = 0; v < nv; v++)
        for (int s = 0; s < K; s++)
            for (int u = s + 1; u < K; u++) {
                int i = bone[(size_t)K * v + s], j = bone[(size_t)K * v + u];
                double p = w[(size_t)K * v + s] * w[(size_t)K * v + u];
                if (i == j || !(p > 0))
                    continue;
                if (p > g->d[(size_t)nb * i + j])
                    g->d[(size_t)nb * i + j] = g->d[(size_t)nb * j + i] = p;
            }
    g->dmax = 0;
    int ne = 0;
    for (int i = 0; i < nb; i++)
        for (int j = i + 1; j < nb; j++)
            if (g->d[(size_t)nb * i + j] > 0) {
                ne++;
                if (g->d[(size_t)nb * i + j] > g->dmax)
                    g->dmax = g->d[(size_t)nb * i + j];
            }
    g->te = te_factor * g->dmax;
    edge *e = mdl__calloc(ne ? ne : 1, sizeof *e);
    int *parent = mdl__calloc(nb, sizeof *parent);
    if (!e || !parent) {
        free(e);
        free(parent);
        return mdl__err(err, -ENOMEM, "bone graph: out of memory");
    }
    int n = 0;
    for (int i = 0; i < nb; i++)
        for (int j = i + 1; j < nb; j++)
            if (g->d[(size_t)nb * i + j] > 0)
                e[n++] = (edge){i, j, g->d[(size_t)nb * i + j]};
    qsort(e, n, sizeof *e, cmp_edge_desc);
    for (int i = 0; i < nb; i++)
        parent[i] = i;
    g->nedges = g->nedges_all = 0;
    for (int k = 0; k < n; k++) {
        int ra = uf_find(parent, e[k].a), rb = uf_find(parent, e[k].b);
        int spanning = ra != rb;
        if (spanning)
            parent[ra] = rb;
        g->nedges_all++;
        if (e[k].d >= g->te || spanning) {
            g->kept[(size_t)nb * e[k].a + e[k].b] = g->kept[(size_t)nb * e[k].b + e[k].a] = 1;
            g->nedges++;
            g->nrescued += e[k].d < g->te;
        }
    }
    free(e);
    free(parent);
    return 0;
}

/* the iterative Hopcroft-Tarjan search: g->cut and the blocks */
static int find_blocks(mdl__bone_graph *g, char *err)
{
    int nb = g->nb, rc = 0;
    int *disc = mdl__calloc(nb, sizeof *disc), *low = mdl__calloc(nb, sizeof *low);
    int *par = mdl__calloc(nb, sizeof *par), *next = mdl__calloc(nb, sizeof *next);
    int *stack = mdl__calloc(nb, sizeof *stack);
    int *es = mdl__calloc(2 * (size_t)nb * nb + 2, sizeof *es); /* edge stack: pairs */
    int *mark = mdl__calloc(nb, sizeof *mark);
    g->block_off = mdl__calloc((size_t)2 * nb + 1, sizeof *g->block_off);
    g->block_bone = mdl__calloc((size_t)2 * nb * nb + nb, sizeof *g->block_bone);
    if (!disc || !low || !par || !next || !stack || !es || !mark || !g->block_off ||
        !g->block_bone) {
        rc = mdl__err(err, -ENOMEM, "bone graph: out of memory");
        goto out;
    }
    int time = 0, nblock = 0, nbb = 0, nes = 0, stamp = 0;
    for (int i = 0; i < nb; i++)
        disc[i] = -1;
    for (int root = 0; root < nb; root++) {
        if (disc[root] >= 0)
            continue;
        disc[root] = low[root] = time++;
        par[root] = -1;
        next[root] = 0;
        int sp = 0, root_children = 0;
        stack[sp++] = root;
        while (sp > 0) {
            int u = stack[sp - 1];
            int v = next[u];
            while (v < nb && !(g->kept[(size_t)nb * u + v] && v != par[u]))
                v++;
            if (v < nb) {
                next[u] = v + 1;
                if (disc[v] < 0) { /* tree edge: descend */
                    es[2 * nes] = u;
                    es[2 * nes + 1] = v;
                    nes++;
                    par[v] = u;
                    disc[v] = low[v] = time++;
                    next[v] = 0;
                    stack[sp++] = v;
                    if (u == root)
                        root_children++;
                } else if (disc[v] < disc[u]) { /* back edge to an ancestor */
                    es[2 * nes] = u;
                    es[2 * nes + 1] = v;
                    nes++;
                    if (disc[v] < low[u])
                        low[u] = disc[v];
                }
                continue;
            }
            /* u is finished: back to its parent p */
            sp--;
            int p = par[u];
            if (p < 0)
                continue;
            if (low[u] < low[p])
                low[p] = low[u];
            if (low[u] >= disc[p]) {
                /* p separates u's subtree: the edges down to (p, u) make one block */
                if (p != root)
                    g->cut[p] = 1;
                stamp++;
                g->block_off[nblock] = nbb;
                int a, b;
                do {
                    nes--;
                    a = es[2 * nes];
                    b = es[2 * nes + 1];
                    if (mark[a] != stamp) {
                        mark[a] = stamp;
                        g->block_bone[nbb++] = a;
                    }
                    if (mark[b] != stamp) {
                        mark[b] = stamp;
                        g->block_bone[nbb++] = b;
                    }
                } while (!(a == p && b == u));
                nblock++;
            }
        }
        if (root_children >= 2)
            g->cut[root] = 1;
        if (root_children == 0) { /* an isolated bone */
            g->block_off[nblock] = nbb;
            g->block_bone[nbb++] = root;
            nblock++;
        }
    }
    g->block_off[nblock] = nbb;
    g->nblocks = nblock;
    /* each block's bones ascending */
    for (int k = 0; k < nblock; k++) {
        int *bb = g->block_bone + g->block_off[k], n = g->block_off[k + 1] - g->block_off[k];
        for (int x = 1; x < n; x++)
            for (int y = x; y > 0 && bb[y - 1] > bb[y]; y--) {
                int t = bb[y];
                bb[y] = bb[y - 1];
                bb[y - 1] = t;
            }
    }
out:
    free(disc);
    free(low);
    free(par);
    free(next);
    free(stack);
    free(es);
    free(mark);
    return rc;
}

int mdl__bone_graph_build(mdl__bone_graph *g, int nb, int nv, int K, const int *bone,
                          const double *w, double te_factor, char *err)
{
    memset(g, 0, sizeof *g);
    if (nb < 1 || nv < 0 || K < 1 || !(te_factor >= 0 && te_factor <= 1))
        return mdl__err(err, -EINVAL, "bone graph: bad arguments (bones %d, T_e factor %g)", nb,
                        te_factor);
    g->nb = nb;
    g->d = mdl__calloc((size_t)nb * nb, sizeof *g->d);
    g->kept = mdl__calloc((size_t)nb * nb, sizeof *g->kept);
    g->cut = mdl__calloc(nb, sizeof *g->cut);
    if (!g->d || !g->kept || !g->cut) {
        mdl__bone_graph_fini(g);
        return mdl__err(err, -ENOMEM, "bone graph: out of memory");
    }
    for (size_t i = 0; i < (size_t)nv * K; i++)
        if (bone[i] < 0 || bone[i] >= nb) {
            mdl__bone_graph_fini(g);
            return mdl__err(err, -EINVAL, "bone graph: vertex %zu names bone %d of %d", i / K,
                            bone[i], nb);
        }
    int rc = weigh_edges(g, nv, K, bone, w, te_factor, err);
    if (!rc)
        rc = find_blocks(g, err);
    if (rc)
        mdl__bone_graph_fini(g);
    return rc;
}
