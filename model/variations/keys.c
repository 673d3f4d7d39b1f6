/* keys.c - the key vertices of Zheng 2013 Sec. 3.3 ("Selection of Key Vertices"):
 *
 *   per bone b       v_b = argmax_v w_vb
 *   per bone pair    v_ij = argmax_v w_vi w_vj, added when w_vi w_vj > 0
 *
 * each vertex added once ("these vertices serve as coupling points to capture how the bones move
 * spatially coherently"). For a component's graph (Sec. 4) the weights are those of its bones,
 * renormalised to sum 1 over them (mdl__vskin_vertex): the component is skinned by its own bones
 * only, as its walk moves them. Ties go to the lower vertex index. Analysis: allocates freely. */
#include "variations/variations.h"
#include "core/util.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

int mdl__vskin_vertex(const mdl__vskin *s, const int *map, int v, int *lb, double *w)
{
    int n = 0;
    double sum = 0;
    for (int k = 0; k < s->K; k++) {
        double x = s->w[(size_t)s->K * v + k];
        int b = s->bone[(size_t)s->K * v + k];
        int l = map ? map[b] : b;
        if (!(x > 0) || l < 0)
            continue;
        int at = -1;
        for (int q = 0; q < n; q++)
            if (lb[q] == l)
                at = q;
        if (at < 0) {
            lb[n] = l;
            w[n++] = x;
        } else {
            w[at] += x;
        }
        sum += x;
    }
    if (!(sum > 0))
        return 0;
    for (int q = 0; q < n; q++)
        w[q] /= sum;
    return n;
}

int mdl__keys_select(struct mdl_variations *g, const mdl__vskin *s, const int *map, char *err)
{
    int nb = g->nb, rc = 0;
    double *best = mdl__calloc((size_t)nb * nb, sizeof *best);
    int *arg = mdl__calloc((size_t)nb * nb, sizeof *arg);
    uint8_t *mark = mdl__calloc((size_t)s->nv, 1);
    int *lb = mdl__calloc((size_t)s->K, sizeof *lb);
    double *w = mdl__calloc((size_t)s->K, sizeof *w);
    if (!best || !arg || !mark || !lb || !w) {
        rc = mdl__err(err, -ENOMEM, "variations: out of memory for key vertices");
        goto out;
    }
    for (size_t k = 0; k < (size_t)nb * nb; k++)
        arg[k] = -1;
    /* diagonal: max w_vb; off the diagonal (a < b): max w_va w_vb */
    for (int v = 0; v < s->nv; v++) {
        int n = mdl__vskin_vertex(s, map, v, lb, w);
        for (int p = 0; p < n; p++)
            for (int q = 0; q < n; q++) {
                int a = lb[p], b = lb[q];
                if (a > b)
                    continue;
                double x = a == b ? w[p] : w[p] * w[q];
                size_t at = (size_t)nb * a + b;
                if (x > best[at]) {
                    best[at] = x;
                    arg[at] = v;
                }
            }
    }
    int n = 0;
    for (size_t k = 0; k < (size_t)nb * nb; k++)
        if (arg[k] >= 0 && !mark[arg[k]]) {
            mark[arg[k]] = 1;
            n++;
        }
    g->nkey = n;
    g->key_v = mdl__calloc(n > 0 ? (size_t)n : 1, sizeof *g->key_v);
    if (!g->key_v) {
        rc = mdl__err(err, -ENOMEM, "variations: out of memory for key vertices");
        goto out;
    }
    for (int v = 0, i = 0; v < s->nv; v++) /* in vertex order */
        if (mark[v])
            g->key_v[i++] = v;
    if (n < 1)
        rc = mdl__err(err, -EDOM, "variations: no key vertices (no vertex moves with the bones)");
out:
    free(best);
    free(arg);
    free(mark);
    free(lb);
    free(w);
    return rc;
}
