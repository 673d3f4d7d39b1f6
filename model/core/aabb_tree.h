/* aabb_tree.h - a bounding-volume hierarchy of axis-aligned boxes over triangles, and the query
 * "which triangles' boxes overlap this box".
 *
 * Build (top down, median split; as in Ericson, "Real-Time Collision Detection", 2005, Sec. 6.2):
 * a node holds the box of its triangles; a node of more than MDL_AABB_LEAF triangles is split at
 * the median of the triangles' centroids along the longest axis of the centroids' box (so both
 * halves hold n/2 triangles and the depth is ceil(log2(n / leaf)) + 1), the two halves built in
 * turn. Query: from the root, a node whose box overlaps the query box (closed intervals on all
 * three axes, Ericson eq. in Sec. 4.2.1: a.min <= b.max and b.min <= a.max) is opened; at a leaf,
 * every triangle whose own box overlaps is reported. The query walks an explicit stack of fixed
 * size (the depth is at most 32 for 2^31 triangles) and allocates nothing, so several threads may
 * query one tree at once.
 *
 * paper -> code: the node boxes lo, hi (float, xyz), the triangles reordered into tri[] so each
 * node covers tri[first .. first + count). Built once (allocates); read-only afterwards. */
#ifndef MESHSTEER_MODEL_AABB_TREE_H
#define MESHSTEER_MODEL_AABB_TREE_H

#include <stdint.h>

#define MDL_AABB_LEAF 4

typedef struct mdl__aabb_node {
    float lo[3], hi[3];
    int first, count; /* a leaf: tri[first .. first + count); an inner node: count 0, children
                         first and first + 1 */
} mdl__aabb_node;

typedef struct mdl__aabb_tree {
    int ntri, nnodes;
    mdl__aabb_node *node; /* node[0] the root */
    int *tri;             /* ntri: triangle ids in leaf order */
    float *box;           /* ntri x 6: each triangle's lo, hi (by triangle id) */
} mdl__aabb_tree;

/* The tree over the nf triangles F (nf x 3 indices into V, nv x 3). -EINVAL for nf < 1 or an
 * index out of range, -ENOMEM. */
int mdl__aabb_build(mdl__aabb_tree *t, const float *V, int nv, const uint32_t *F, int nf, char *err);
void mdl__aabb_fini(mdl__aabb_tree *t);

/* Calls hit(ctx, triangle id) for each triangle whose box overlaps [lo, hi]; stops at the first
 * nonzero return of hit and returns it (0 when every call returned 0). */
int mdl__aabb_query(const mdl__aabb_tree *t, const float lo[3], const float hi[3],
                    int (*hit)(void *ctx, int tri), void *ctx);

/* 1 when the boxes [alo, ahi] and [blo, bhi] overlap (closed). */
static inline int mdl__box_overlap(const float alo[3], const float ahi[3], const float blo[3],
                                   const float bhi[3])
{
    return alo[0] <= bhi[0] && blo[0] <= ahi[0] && alo[1] <= bhi[1] && blo[1] <= ahi[1] &&
           alo[2] <= bhi[2] && blo[2] <= ahi[2];
}

#endif
