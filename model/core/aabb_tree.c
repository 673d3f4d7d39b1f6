/* aabb_tree.c - the box tree of aabb_tree.h: top-down median split, box-overlap query. */
#include "core/aabb_tree.h"
#include "core/util.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

/* the build's working state: each triangle's centroid */
typedef struct build {
    mdl__aabb_tree *t;
    float *cen; /* ntri x 3 */
} build;

static void box_of(const mdl__aabb_tree *t, const int *ids, int n, float lo[3], float hi[3])
{
    for (int c = 0; c < 3; c++) {
        lo[c] = t->box[6 * (size_t)ids[0] + c];
        hi[c] = t->box[6 * (size_t)ids[0] + 3 + c];
    }
    for (int k = 1; k < n; k++) {
        const float *b = t->box + 6 * (size_t)ids[k];
        for (int c = 0; c < 3; c++) {
            lo[c] = b[c] < lo[c] ? b[c] : lo[c];
            hi[c] = b[3 + c] > hi[c] ? b[3 + c] : hi[c];
        }
    }
}

/* Hoare-style selection: ids[0..n) reordered so ids[k] has the k-th smallest centroid on axis a
 * and every id before it is <= it, every one after >= it (deterministic: the middle pivot) */
static void select_kth(const float *cen, int *ids, int n, int k, int a)
{
    int l = 0, r = n - 1;
    while (l < r) {
        float p = cen[3 * (size_t)ids[l + (r - l) / 2] + a];
        int i = l, j = r;
        while (i <= j) {
            while (cen[3 * (size_t)ids[i] + a] < p)
                i++;
            while (cen[3 * (size_t)ids[j] + a] > p)
                j--;
            if (i <= j) {
                int s = ids[i];
                ids[i++] = ids[j];
                ids[j--] = s;
            }
        }
        if (k <= j)
            r = j;
        else if (k >= i)
            l = i;
        else
            return;
    }
}

/* node `at` over tri[first .. first + n); children are appended at t->nnodes */
static void build_node(build *b, int at, int first, int n)
{
    mdl__aabb_tree *t = b->t;
    mdl__aabb_node *nd = &t->node[at];
    box_of(t, t->tri + first, n, nd->lo, nd->hi);
    if (n <= MDL_AABB_LEAF) {
        nd->first = first;
        nd->count = n;
        return;
    }
    float clo[3], chi[3];
    for (int c = 0; c < 3; c++)
        clo[c] = chi[c] = b->cen[3 * (size_t)t->tri[first] + c];
    for (int k = 1; k < n; k++)
        for (int c = 0; c < 3; c++) {
            float x = b->cen[3 * (size_t)t->tri[first + k] + c];
            clo[c] = x < clo[c] ? x : clo[c];
            chi[c] = x > chi[c] ? x : chi[c];
        }
    int a = 0;
    for (int c = 1; c < 3; c++)
        if (chi[c] - clo[c] > chi[a] - clo[a])
            a = c;
    int half = n / 2;
    select_kth(b->cen, t->tri + first, n, half, a);
    int kid = t->nnodes;
    t->nnodes += 2;
    nd->first = kid;
    nd->count = 0;
    build_node(b, kid, first, half);
    build_node(b, kid + 1, first + half, n - half);
}

int mdl__aabb_build(mdl__aabb_tree *t, const float *V, int nv, const uint32_t *F, int nf, char *err)
{
    memset(t, 0, sizeof *t);
    if (nf < 1 || !V || !F)
        return mdl__err(err, -EINVAL, "aabb tree: no triangles");
    for (size_t k = 0; k < 3 * (size_t)nf; k++)
        if (F[k] >= (uint32_t)nv)
            return mdl__err(err, -EINVAL, "aabb tree: triangle %zu: vertex %u of %d", k / 3, F[k], nv);
    t->ntri = nf;
    t->node = mdl__calloc(2 * (size_t)nf, sizeof *t->node); /* a binary tree of <= nf leaves */
    t->tri = mdl__calloc(nf, sizeof *t->tri);
    t->box = mdl__calloc(6 * (size_t)nf, sizeof *t->box);
    float *cen = mdl__calloc(3 * (size_t)nf, sizeof *cen);
    if (!t->node || !t->tri || !t->box || !cen) {
        free(cen);
        mdl__aabb_fini(t);
        return mdl__err(err, -ENOMEM, "aabb tree: out of memory for %d triangles", nf);
    }
    for (int i = 0; i < nf; i++) {
        float *b = t->box + 6 * (size_t)i;
        const float *p = V + 3 * (size_t)F[3 * (size_t)i];
        for (int c = 0; c < 3; c++)
            b[c] = b[3 + c] = p[c];
        for (int s = 1; s < 3; s++) {
            p = V + 3 * (size_t)F[3 * (size_t)i + s];
            for (int c = 0; c < 3; c++) {
                b[c] = p[c] < b[c] ? p[c] : b[c];
                b[3 + c] = p[c] > b[3 + c] ? p[c] : b[3 + c];
            }
        }
        for (int c = 0; c < 3; c++)
            cen[3 * (size_t)i + c] = 0.5f * (b[c] + b[3 + c]);
        t->tri[i] = i;
    }
    build b = {t, cen};
    t->nnodes = 1;
    build_node(&b, 0, 0, nf);
    free(cen);
    return 0;
}

void mdl__aabb_fini(mdl__aabb_tree *t)
{
    free(t->node);
    free(t->tri);
    free(t->box);
    memset(t, 0, sizeof *t);
}

int mdl__aabb_query(const mdl__aabb_tree *t, const float lo[3], const float hi[3],
                    int (*hit)(void *ctx, int tri), void *ctx)
{
    if (t->nnodes < 1)
        return 0;
    int stack[64], sp = 0; /* depth <= 32: two entries per level at most */
    stack[sp++] = 0;
    while (sp > 0) {
        const mdl__aabb_node *nd = &t->node[stack[--sp]];
        if (!mdl__box_overlap(nd->lo, nd->hi, lo, hi))
            continue;
        if (nd->count == 0) {
            stack[sp++] = nd->first;
            stack[sp++] = nd->first + 1;
            continue;
        }
        for (int k = nd->first; k < nd->first + nd->count; k++) {
            int id = t->tri[k];
            const float *b = t->box + 6 * (size_t)id;
            if (mdl__box_overlap(b, b + 3, lo, hi)) {
                int r = hit(ctx, id);
                if (r)
                    return r;
            }
        }
    }
    return 0;
}
