/* components.c - the weakly coupled components of Zheng 2013 Sec. 4, each with its own
 * transition graph (Sec. 3.2 on its bones), and the order Algorithm 1 merges them in.
 *
 *   components  the blocks of the bone graph between its cut nodes (bone_graph.c), each with its
 *               cut nodes: B_1 u {b_c}, B_2 u {b_c}
 *   order       a breadth-first search of the block-cut tree from the anchor: the block holding
 *               the skin's reference bone (the largest one when b_r is itself a cut node). Each
 *               later component shares exactly one cut node with the components before it, its
 *               parent's ("if there exists a cut node b_c separating them, i.e. {b_c} = C_i n
 *               C_j"), so merging in this order meets every cut node once (Sec. 4.2: "the merged
 *               components C_i and C_j form a new component C_ij, which is then used to merge
 *               with another component if they share a cut node").
 *   fusion      (not in the paper, which needs every component to have a motion graph) a
 *               component of one bone, or whose own graph has no frame a walk can go on for ever
 *               from, is fused into its parent (its children then hang on the parent); blocks
 *               the anchor's part of the graph does not reach (a bone graph in several parts)
 *               are fused into the anchor. One component left: the skin's own graph is used.
 *   per component  T restricted to its bones, its own reference bone (largest weight sum among
 *               them), D, alpha, beta and T_c on its own frames (mdl__variations_analyse), and
 *               for the gradient blend its own key vertices, on its bones' weights renormalised
 *               (gblend.c).
 * Analysis: allocates freely. */
#include "variations/variations.h"
#include "core/util.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

void mdl__components_fini(struct mdl_variations *v)
{
    for (int c = 0; c < v->ncomp && v->comp; c++) {
        mdl_variations_destroy(v->comp[c].g);
        free(v->comp[c].bones);
    }
    free(v->comp);
    v->comp = NULL;
    v->ncomp = 0;
    if (v->bg) {
        mdl__bone_graph_fini(v->bg);
        free(v->bg);
        v->bg = NULL;
    }
}

/* the graph of the bones where in[b] (count n) */
static int build_sub(const struct mdl_variations *v, const uint8_t *in, int n,
                     const mdl__vskin *sk, struct mdl_variations **out, char *err)
{
    struct mdl_variations *g = mdl__calloc(1, sizeof *g);
    if (!g)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    g->o = v->o;
    g->o.components = 1;
    g->nb = n;
    g->nframes = v->nframes;
    g->T = mdl__calloc(12 * (size_t)n * v->nframes, sizeof *g->T);
    g->wsum = mdl__calloc(n, sizeof *g->wsum);
    g->centre = mdl__calloc(3 * (size_t)n, sizeof *g->centre);
    if (!g->T || !g->wsum || !g->centre) {
        mdl_variations_destroy(g);
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    }
    for (int b = 0, k = 0; b < v->nb; b++) {
        if (!in[b])
            continue;
        for (int t = 0; t < v->nframes; t++)
            memcpy(g->T + 12 * ((size_t)t * n + k), v->T + 12 * ((size_t)t * v->nb + b),
                   12 * sizeof *g->T);
        g->wsum[k] = v->wsum[b];
        memcpy(g->centre + 3 * k, v->centre + 3 * b, 3 * sizeof *g->centre);
        k++;
    }
    int rc = mdl__variations_analyse(g, err);
    if (!rc && !g->o.blend_linear && g->o.blend > 0) { /* its key vertices, on its bones' weights */
        int *map = mdl__calloc((size_t)v->nb, sizeof *map);
        if (!map)
            rc = mdl__err(err, -ENOMEM, "variations: out of memory");
        for (int b = 0, k = 0; map && b < v->nb; b++)
            map[b] = in[b] ? k++ : -1;
        if (!rc)
            rc = mdl__gblend_build(g, sk, map, err);
        free(map);
    }
    if (rc) {
        mdl_variations_destroy(g);
        return rc;
    }
    *out = g;
    return 0;
}

typedef struct proto {
    uint8_t *in;     /* nb */
    int n, parent, cut, live, order;
    struct mdl_variations *g;
} proto;

static void fuse(proto *p, int nb, int x)
{
    int q = p[x].parent;
    for (int b = 0; b < nb; b++)
        if (p[x].in[b] && !p[q].in[b]) {
            p[q].in[b] = 1;
            p[q].n++;
        }
    p[x].live = 0;
    mdl_variations_destroy(p[x].g);
    p[x].g = NULL;
    mdl_variations_destroy(p[q].g); /* its bones changed: rebuilt */
    p[q].g = NULL;
}

int mdl__components_build(struct mdl_variations *v, const int *bone, const double *w,
                          const mdl__vskin *sk, char *err)
{
    int nb = v->nb, rc = 0;
    v->bg = mdl__calloc(1, sizeof *v->bg);
    if (!v->bg)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    rc = mdl__bone_graph_build(v->bg, nb, v->nv, v->K, bone, w, v->o.te_factor, err);
    if (rc) {
        free(v->bg);
        v->bg = NULL;
        return rc;
    }
    const mdl__bone_graph *bg = v->bg;
    int nk = bg->nblocks;
    proto *p = mdl__calloc(nk, sizeof *p);
    int *queue = mdl__calloc(nk, sizeof *queue);
    if (!p || !queue) {
        rc = mdl__err(err, -ENOMEM, "variations: out of memory");
        goto out;
    }
    for (int k = 0; k < nk; k++) {
        p[k].in = mdl__calloc(nb, 1);
        if (!p[k].in) {
            rc = mdl__err(err, -ENOMEM, "variations: out of memory");
            goto out;
        }
        for (int x = bg->block_off[k]; x < bg->block_off[k + 1]; x++)
            p[k].in[bg->block_bone[x]] = 1;
        p[k].n = bg->block_off[k + 1] - bg->block_off[k];
        p[k].parent = p[k].cut = -1;
        p[k].order = -1;
    }
    /* the anchor: the largest block holding b_r */
    int root = -1;
    for (int k = 0; k < nk; k++)
        if (p[k].in[v->ref] && (root < 0 || p[k].n > p[root].n))
            root = k;
    /* breadth-first over the block-cut tree */
    int qh = 0, qt = 0;
    queue[qt++] = root;
    p[root].order = 0;
    p[root].live = 1;
    while (qh < qt) {
        int k = queue[qh++];
        for (int b = 0; b < nb; b++) {
            if (!p[k].in[b] || !bg->cut[b])
                continue;
            for (int j = 0; j < nk; j++)
                if (p[j].order < 0 && p[j].in[b]) {
                    p[j].order = qt;
                    p[j].parent = k;
                    p[j].cut = b;
                    p[j].live = 1;
                    queue[qt++] = j;
                }
        }
    }
    for (int k = 0; k < nk; k++)
        if (p[k].order < 0) { /* another part of the graph: into the anchor */
            p[k].parent = root;
            p[k].live = 1;
            fuse(p, nb, k);
        }
    /* fusion, deepest first, until every component walks */
    for (int changed = 1; changed && !rc;) {
        changed = 0;
        for (int x = qt - 1; x >= 0 && !rc; x--) {
            int k = queue[x];
            if (!p[k].live)
                continue;
            if (k != root && p[k].n < 2) {
                fuse(p, nb, k);
                changed = 1;
                continue;
            }
            if (!p[k].g)
                rc = build_sub(v, p[k].in, p[k].n, sk, &p[k].g, err);
            if (!rc && k != root && p[k].g->nalive < 1) {
                fuse(p, nb, k);
                changed = 1;
            }
        }
        /* children of fused components now hang on the nearest live ancestor */
        for (int x = 0; x < qt; x++) {
            int k = queue[x];
            while (p[k].live && p[k].parent >= 0 && !p[p[k].parent].live)
                p[k].parent = p[p[k].parent].parent;
        }
    }
    if (rc)
        goto out;
    int n = 0;
    for (int x = 0; x < qt; x++)
        n += p[queue[x]].live;
    if (n < 2) /* one component: the skin's own graph */
        goto out;
    v->comp = mdl__calloc(n, sizeof *v->comp);
    int *index = mdl__calloc(nk, sizeof *index);
    if (!v->comp || !index) {
        free(index);
        rc = mdl__err(err, -ENOMEM, "variations: out of memory");
        goto out;
    }
    for (int x = 0; x < qt; x++) {
        int k = queue[x];
        if (!p[k].live)
            continue;
        mdl__vcomp *c = &v->comp[v->ncomp];
        index[k] = v->ncomp++;
        c->g = p[k].g;
        p[k].g = NULL;
        c->nb = p[k].n;
        c->bones = mdl__calloc(c->nb, sizeof *c->bones);
        if (!c->bones) {
            free(index);
            rc = mdl__err(err, -ENOMEM, "variations: out of memory");
            goto out;
        }
        for (int b = 0, j = 0; b < nb; b++)
            if (p[k].in[b]) {
                if (b == p[k].cut)
                    c->cut_local = j;
                c->bones[j++] = b;
            }
        c->parent = p[k].parent >= 0 ? index[p[k].parent] : -1;
        c->cut = p[k].cut;
    }
    free(index);
out:
    for (int k = 0; p && k < nk; k++) {
        free(p[k].in);
        mdl_variations_destroy(p[k].g);
    }
    free(p);
    free(queue);
    if (rc)
        mdl__components_fini(v);
    return rc;
}

int mdl_variations_get_component(const mdl_variations *v, int c, mdl_variations_component *out)
{
    memset(out, 0, sizeof *out);
    int n = v->ncomp > 1 ? v->ncomp : 1;
    if (c < 0 || c >= n)
        return -ERANGE;
    if (v->ncomp > 1) {
        const mdl__vcomp *k = &v->comp[c];
        out->nbones = k->nb;
        out->bones = k->bones;
        out->cut = k->cut;
        out->parent = k->parent;
        out->ref_bone = k->bones[k->g->ref];
        out->transitions = k->g->ntrans;
        out->alive_frames = k->g->nalive;
        out->tc = k->g->tc;
        return 0;
    }
    out->nbones = v->nb;
    out->bones = NULL; /* all bones: 0 .. nb - 1 */
    out->cut = out->parent = -1;
    out->ref_bone = v->ref;
    out->transitions = v->ntrans;
    out->alive_frames = v->nalive;
    out->tc = v->tc;
    return 0;
}

int mdl_variations_component_transition(const mdl_variations *v, int c, int k, int *from, int *to,
                                        double *cost)
{
    if (!v || c < 0 || c >= (v->ncomp > 1 ? v->ncomp : 1))
        return -ERANGE;
    return mdl_variations_transition(v->ncomp > 1 ? v->comp[c].g : v, k, from, to, cost);
}
