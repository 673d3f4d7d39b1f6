/* candy.c - the candy-wrapper effect, de Aguiar et al. 2007 Sec. 4.3.
 *
 * q and -q are the same rotation, but the harmonic field of eq. 2 interpolates the components, so
 * two neighbouring constraints in opposite hemispheres pull the field through zero: the mixed
 * quaternion degenerates and the skin between them collapses ("candy wrapper"). Choosing w >= 0
 * for every constraint independently is exactly what breaks at a twist near 180 deg (w ~ 0, the
 * paper's detector): one triangle at 179 deg keeps its sign, its neighbour at 181 deg flips.
 * So signs are chosen along a tree of the groups instead (minimum spanning tree over their rest
 * positions, a skeleton-like chain): each child takes the sign that agrees with its parent, so two
 * neighbouring constraints are never more than 90 deg apart in quaternion space and every mix of
 * them has norm >= 1/sqrt(2). Where a child's rotation relative to its parent is itself near
 * 180 deg (|<q_c, q_p>| < MDL_CANDY_EPS, the relative w ~ 0), the sign is ambiguous; there the
 * previous frame is the reference (the paper's first remedy, "a previous frame ... as the
 * reference pose"): the child keeps the hemisphere of its own last value, so a twist that passes
 * through 180 deg continues smoothly instead of snapping back. The root keeps its previous frame's
 * hemisphere too (w >= 0 on the first frame).
 * With a previous frame, every group whose rotation moved by less than ~120 deg since
 * (|<q, q_prev>| >= MDL_CANDY_PREV) keeps its own hemisphere: the tree decides only on the first
 * frame, after a reset, and for a group that jumped. Mixing the two rules frame by frame (tree
 * sign while |<q_c, q_p>| >= MDL_CANDY_EPS, own sign below) flipped a group when the relative
 * rotation crossed the threshold: 42 of the 47 one-frame pops of the static human hopping
 * (131_03.bvh) were such flips. */
#include "harmonic/harmonic_internal.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

int mdl__candy_tree(struct mdl_harmonic *h, const double *pos, char *err)
{
    int n = h->ngroups;
    free(h->group_parent);
    free(h->group_order);
    h->group_parent = mdl__calloc((size_t)n + 1, sizeof(int));
    h->group_order = mdl__calloc((size_t)n + 1, sizeof(int));
    double *best = mdl__calloc((size_t)n + 1, sizeof *best);
    uint8_t *in = mdl__calloc((size_t)n + 1, 1);
    if (!h->group_parent || !h->group_order || !best || !in) {
        free(best);
        free(in);
        return mdl__err(err, -ENOMEM, "harmonic: out of memory");
    }
    /* Prim from group 0 (O(n^2): n is a few hundred) */
    for (int g = 0; g < n; g++) {
        best[g] = INFINITY;
        h->group_parent[g] = -1;
    }
    if (n > 0)
        best[0] = 0;
    for (int it = 0; it < n; it++) {
        int u = -1;
        for (int g = 0; g < n; g++)
            if (!in[g] && (u < 0 || best[g] < best[u]))
                u = g;
        in[u] = 1;
        h->group_order[it] = u;
        for (int g = 0; g < n; g++) {
            if (in[g])
                continue;
            double d = 0;
            for (int c = 0; c < 3; c++)
                d += (pos[3 * g + c] - pos[3 * u + c]) * (pos[3 * g + c] - pos[3 * u + c]);
            if (d < best[g]) {
                best[g] = d;
                h->group_parent[g] = u;
            }
        }
    }
    free(best);
    free(in);
    return 0;
}

static double qdot(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

static void qneg(double *q)
{
    q[0] = -q[0], q[1] = -q[1], q[2] = -q[2], q[3] = -q[3];
}

int mdl__candy_align(const int *parent, const int *order, int ngroups, double *q,
                     const double *prev)
{
    int ambiguous = 0;
    for (int i = 0; i < ngroups; i++) {
        int g = order[i], p = parent[g];
        double *qg = q + 4 * g;
        if (p < 0) {
            if (prev ? qdot(qg, prev + 4 * g) < 0 : qg[0] < 0)
                qneg(qg);
            continue;
        }
        double d = qdot(qg, q + 4 * p);
        double dp = prev ? qdot(qg, prev + 4 * g) : 0;
        if (prev && fabs(dp) >= MDL_CANDY_PREV) {
            /* continuity first: the sign of the group's own last value, whatever its parent's
             * relative rotation (switching rules where |d| crosses MDL_CANDY_EPS made the two
             * rules disagree and the field jump by a whole limb in one frame) */
            ambiguous += fabs(d) < MDL_CANDY_EPS;
            if (dp < 0)
                qneg(qg);
        } else if (fabs(d) < MDL_CANDY_EPS && prev) {
            ambiguous++;
            if (qdot(qg, prev + 4 * g) < 0)
                qneg(qg);
        } else if (d < 0) {
            ambiguous += fabs(d) < MDL_CANDY_EPS;
            qneg(qg);
        }
    }
    return ambiguous;
}
