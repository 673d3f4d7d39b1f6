/* test_aabb_tree.c - the box tree (model/core/aabb_tree.c): on 20000 random triangles (and on 1,
 * 4 and 5, around the leaf size), 2000 random query boxes each report exactly the triangles whose
 * boxes overlap the query, as a brute-force scan finds them; the tree is balanced (depth
 * ceil(log2(n / 4)) + 1 at most); a query can stop at the first hit; bad input is refused. */
#include "core/aabb_tree.h"
#include "test.h"

#include <errno.h>
#include <stdint.h>

static uint64_t rng = 0x243f6a8885a308d3ull;
static float frand(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (float)((rng >> 11) * (1.0 / 9007199254740992.0));
}

typedef struct seen {
    uint8_t *mark;
    int n;
} seen;

static int collect(void *ctx, int k)
{
    seen *s = ctx;
    ASSERT_INT_EQ(s->mark[k], 0); /* each triangle once */
    s->mark[k] = 1;
    s->n++;
    return 0;
}

static int stop_first(void *ctx, int k)
{
    (void)k;
    (*(int *)ctx)++;
    return 7;
}

static int depth(const mdl__aabb_tree *t, int at)
{
    const mdl__aabb_node *n = &t->node[at];
    if (n->count)
        return 1;
    int a = depth(t, n->first), b = depth(t, n->first + 1);
    return 1 + (a > b ? a : b);
}

static void run(int nf, int queries)
{
    char err[256] = "";
    float *V = malloc(9 * (size_t)nf * sizeof *V);
    uint32_t *F = malloc(3 * (size_t)nf * sizeof *F);
    for (int i = 0; i < nf; i++) {
        float c[3] = {frand(), frand(), frand()};
        for (int s = 0; s < 3; s++) {
            for (int k = 0; k < 3; k++)
                V[9 * (size_t)i + 3 * s + k] = c[k] + 0.05f * (frand() - 0.5f);
            F[3 * (size_t)i + s] = (uint32_t)(3 * i + s);
        }
    }
    mdl__aabb_tree t;
    ASSERT_OK(mdl__aabb_build(&t, V, 3 * nf, F, nf, err), err);
    int d = depth(&t, 0), dmax = 1;
    while ((MDL_AABB_LEAF << (dmax - 1)) < nf)
        dmax++;
    ASSERT_INT_LE(d, dmax);
    uint8_t *mark = calloc(nf, 1);
    long found = 0;
    for (int q = 0; q < queries; q++) {
        float lo[3], hi[3];
        for (int k = 0; k < 3; k++) {
            float a = 1.2f * frand() - 0.1f, w = 0.2f * frand();
            lo[k] = a;
            hi[k] = a + w;
        }
        memset(mark, 0, nf);
        seen s = {mark, 0};
        ASSERT_INT_EQ(mdl__aabb_query(&t, lo, hi, collect, &s), 0);
        int brute = 0;
        for (int i = 0; i < nf; i++) {
            const float *b = t.box + 6 * (size_t)i;
            int ov = mdl__box_overlap(b, b + 3, lo, hi);
            /* and the box is the triangle's */
            for (int k = 0; k < 3 && q == 0; k++) {
                float mn = V[9 * (size_t)i + k], mx = mn;
                for (int v = 1; v < 3; v++) {
                    float x = V[9 * (size_t)i + 3 * v + k];
                    mn = x < mn ? x : mn;
                    mx = x > mx ? x : mx;
                }
                ASSERT(b[k] == mn && b[3 + k] == mx);
            }
            ASSERT_INT_EQ_I(mark[i], ov, i);
            brute += ov;
        }
        ASSERT_INT_EQ(s.n, brute);
        found += brute;
        if (brute > 0) {
            int calls = 0;
            ASSERT_INT_EQ(mdl__aabb_query(&t, lo, hi, stop_first, &calls), 7);
            ASSERT_INT_EQ(calls, 1);
        }
    }
    printf("%d triangles: depth %d (<= %d), %d queries found %ld boxes, as the brute force\n", nf, d,
           dmax, queries, found);
    if (nf > 1000)
        ASSERT_INT_GT(found, queries); /* the queries are not all empty */
    free(mark);
    mdl__aabb_fini(&t);
    free(V);
    free(F);
}

int main(void)
{
    char err[256] = "";
    run(20000, 2000);
    run(1, 200);
    run(4, 200);
    run(5, 200);
    run(1000, 500);
    mdl__aabb_tree t;
    float V[9] = {0};
    uint32_t F[3] = {0, 1, 3};
    ASSERT_INT_EQ(mdl__aabb_build(&t, V, 3, F, 1, err), -EINVAL);
    ASSERT_INT_EQ(mdl__aabb_build(&t, V, 3, F, 0, err), -EINVAL);
    printf("aabb_tree: ok\n");
    return 0;
}
