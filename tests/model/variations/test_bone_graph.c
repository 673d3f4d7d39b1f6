/* test_bone_graph.c - Zheng 2013 Sec. 4.1 (model/variations/bone_graph.c): eq. 11's edge weights
 * d_ij = max_v w_vi w_vj; T_e drops weak edges but keeps one a spanning forest needs; the cut
 * nodes and blocks of small graphs with known answers (a chain, a bow tie, a weak chord, an
 * isolated bone); on 300 random graphs the cut nodes equal brute force (remove the node, count
 * the parts) and the blocks are those of the definition (every kept edge in exactly one block,
 * two blocks share at most one bone, and it is a cut node); a chain of 3000 bones (no recursion
 * limit) has every inner bone a cut node. */
#include "model.h"
#include "test.h"
#include "variations/variations.h"

#include <errno.h>

/* a skin whose vertex k has weight wa on bone a[k] and 1 - wa on bone b[k] */
typedef struct pairs {
    int n, *bone;
    double *w;
} pairs;

static void add(pairs *p, int a, int b, double wa)
{
    p->bone = realloc(p->bone, 2 * sizeof(int) * (p->n + 1));
    p->w = realloc(p->w, 2 * sizeof(double) * (p->n + 1));
    p->bone[2 * p->n] = a;
    p->bone[2 * p->n + 1] = b;
    p->w[2 * p->n] = wa;
    p->w[2 * p->n + 1] = 1 - wa;
    p->n++;
}

static void build(mdl__bone_graph *g, int nb, pairs *p)
{
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl__bone_graph_build(g, nb, p->n, 2, p->bone, p->w, 0.1, err), err);
    free(p->bone);
    free(p->w);
    memset(p, 0, sizeof *p);
}

static int is_cut(const mdl__bone_graph *g, int b)
{
    return g->cut[b];
}

/* does block k hold exactly these bones */
static int block_is(const mdl__bone_graph *g, const int *bones, int n)
{
    for (int k = 0; k < g->nblocks; k++) {
        if (g->block_off[k + 1] - g->block_off[k] != n)
            continue;
        if (!memcmp(g->block_bone + g->block_off[k], bones, n * sizeof *bones))
            return 1;
    }
    return 0;
}

/* parts of the kept graph without bone x (x = -1: none removed) */
static int parts_without(const mdl__bone_graph *g, int x, int *seen, int *stack)
{
    int nb = g->nb, parts = 0;
    memset(seen, 0, nb * sizeof *seen);
    for (int s = 0; s < nb; s++) {
        if (s == x || seen[s])
            continue;
        parts++;
        int sp = 0;
        stack[sp++] = s;
        seen[s] = 1;
        while (sp) {
            int u = stack[--sp];
            for (int v = 0; v < nb; v++)
                if (v != x && !seen[v] && g->kept[(size_t)nb * u + v]) {
                    seen[v] = 1;
                    stack[sp++] = v;
                }
        }
    }
    return parts;
}

static uint64_t rng = 12345;
static double uni(void)
{
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng >> 11) / 9007199254740992.0;
}

int main(void)
{
    mdl__bone_graph g;
    pairs p = {0};
    char err[MDL_ERR_LEN] = "";

    /* a chain 0 - 1 - 2 - 3: d = 0.25 on each edge, cut nodes 1 and 2, three blocks */
    add(&p, 0, 1, 0.5);
    add(&p, 1, 2, 0.5);
    add(&p, 2, 3, 0.5);
    add(&p, 1, 2, 0.9); /* a weaker product on the same pair: d is the maximum */
    build(&g, 4, &p);
    ASSERT_NEAR(g.d[1 * 4 + 2], 0.25, 1e-15);
    ASSERT_NEAR(g.d[2 * 4 + 1], 0.25, 1e-15);
    ASSERT_NEAR(g.d[0 * 4 + 3], 0, 0);
    ASSERT_NEAR(g.dmax, 0.25, 1e-15);
    ASSERT_NEAR(g.te, 0.025, 1e-15);
    ASSERT_INT_EQ(g.nedges, 3);
    ASSERT(!is_cut(&g, 0) && is_cut(&g, 1) && is_cut(&g, 2) && !is_cut(&g, 3));
    ASSERT_INT_EQ(g.nblocks, 3);
    ASSERT(block_is(&g, (int[]){0, 1}, 2) && block_is(&g, (int[]){1, 2}, 2) &&
           block_is(&g, (int[]){2, 3}, 2));
    mdl__bone_graph_fini(&g);

    /* a bow tie: triangles 0 1 2 and 2 3 4 share bone 2, the only cut node */
    add(&p, 0, 1, 0.5);
    add(&p, 1, 2, 0.5);
    add(&p, 0, 2, 0.5);
    add(&p, 2, 3, 0.5);
    add(&p, 3, 4, 0.5);
    add(&p, 2, 4, 0.5);
    build(&g, 5, &p);
    for (int b = 0; b < 5; b++)
        ASSERT_INT_EQ_I(g.cut[b], b == 2, b);
    ASSERT_INT_EQ(g.nblocks, 2);
    ASSERT(block_is(&g, (int[]){0, 1, 2}, 3) && block_is(&g, (int[]){2, 3, 4}, 3));
    mdl__bone_graph_fini(&g);

    /* a weak chord: triangle 0 1 2, bone 3 strongly on 2 and weakly on 0 (d = 0.0099 < T_e):
     * the chord is dropped, 2 becomes a cut node */
    add(&p, 0, 1, 0.5);
    add(&p, 1, 2, 0.5);
    add(&p, 0, 2, 0.5);
    add(&p, 2, 3, 0.5);
    add(&p, 3, 0, 0.99);
    build(&g, 4, &p);
    ASSERT_INT_EQ(g.nedges_all, 5);
    ASSERT_INT_EQ(g.nedges, 4);
    ASSERT(!g.kept[3 * 4 + 0] && !g.kept[0 * 4 + 3]);
    ASSERT(is_cut(&g, 2) && !is_cut(&g, 0) && !is_cut(&g, 1) && !is_cut(&g, 3));
    ASSERT_INT_EQ(g.nblocks, 2);
    mdl__bone_graph_fini(&g);

    /* a weak edge the graph needs stays (the paper: "without breaking the graph"), and a bone
     * without any shared vertex is a block of its own */
    add(&p, 0, 1, 0.5);
    add(&p, 1, 2, 0.999); /* d = 0.000999 < T_e, but 2 has no other edge */
    add(&p, 3, 3, 1.0);   /* bone 3 alone */
    build(&g, 4, &p);
    ASSERT_INT_EQ(g.nedges, 2);
    ASSERT_INT_EQ(g.nrescued, 1);
    ASSERT(g.kept[1 * 4 + 2]);
    ASSERT(is_cut(&g, 1) && !is_cut(&g, 3));
    ASSERT_INT_EQ(g.nblocks, 3);
    ASSERT(block_is(&g, (int[]){3}, 1));
    mdl__bone_graph_fini(&g);

    /* bad input */
    int badbone[2] = {0, 7};
    double badw[2] = {0.5, 0.5};
    ASSERT_INT_EQ(mdl__bone_graph_build(&g, 4, 1, 2, badbone, badw, 0.1, err), -EINVAL);
    printf("bad bone: %s\n", err);
    ASSERT_INT_EQ(mdl__bone_graph_build(&g, 4, 1, 2, badbone, badw, 1.5, err), -EINVAL);

    /* random graphs against brute force */
    int checked_cuts = 0;
    for (int trial = 0; trial < 300; trial++) {
        int nb = 2 + (int)(uni() * 14), nv = (int)(uni() * 3 * nb);
        for (int k = 0; k < nv; k++) {
            int a = (int)(uni() * nb), b = (int)(uni() * nb);
            add(&p, a, b, 0.02 + 0.96 * uni());
        }
        if (p.n == 0)
            add(&p, 0, 0, 1.0);
        build(&g, nb, &p);
        int seen[16], stack[16 * 16];
        int base = parts_without(&g, -1, seen, stack);
        for (int b = 0; b < nb; b++) {
            /* removing b: parts rise when b is a cut node (an isolated b lowers them by one) */
            int isolated = 1;
            for (int v = 0; v < nb; v++)
                isolated &= !g.kept[(size_t)nb * b + v];
            int after = parts_without(&g, b, seen, stack);
            int cut = after > base - isolated;
            ASSERT_INT_EQ_I(g.cut[b], cut, trial * 100 + b);
            checked_cuts += cut;
        }
        /* every kept edge in exactly one block; blocks meet only at cut nodes */
        for (int a = 0; a < nb; a++)
            for (int b = a + 1; b < nb; b++) {
                if (!g.kept[(size_t)nb * a + b])
                    continue;
                int in = 0;
                for (int k = 0; k < g.nblocks; k++) {
                    int ha = 0, hb = 0;
                    for (int x = g.block_off[k]; x < g.block_off[k + 1]; x++) {
                        ha |= g.block_bone[x] == a;
                        hb |= g.block_bone[x] == b;
                    }
                    in += ha && hb;
                }
                ASSERT_INT_EQ_I(in, 1, trial * 1000 + a * 16 + b);
            }
        for (int k = 0; k < g.nblocks; k++)
            for (int l = k + 1; l < g.nblocks; l++) {
                int shared = 0;
                for (int x = g.block_off[k]; x < g.block_off[k + 1]; x++)
                    for (int y = g.block_off[l]; y < g.block_off[l + 1]; y++)
                        if (g.block_bone[x] == g.block_bone[y]) {
                            shared++;
                            ASSERT_INT_EQ_I(g.cut[g.block_bone[x]], 1, trial);
                        }
                ASSERT_INT_LE_I(shared, 1, trial);
            }
        mdl__bone_graph_fini(&g);
    }
    printf("300 random graphs: cut nodes equal brute force (%d cut nodes)\n", checked_cuts);
    ASSERT_INT_GT(checked_cuts, 50);

    /* a long chain: no recursion limit */
    const int L = 3000;
    for (int b = 0; b + 1 < L; b++)
        add(&p, b, b + 1, 0.5);
    build(&g, L, &p);
    for (int b = 0; b < L; b++)
        ASSERT_INT_EQ_I(g.cut[b], b > 0 && b < L - 1, b);
    ASSERT_INT_EQ(g.nblocks, L - 1);
    mdl__bone_graph_fini(&g);
    printf("bone_graph: ok\n");
    return 0;
}
