/* avoid.c - collision avoidance against static objects (Zheng 2013 Sec. 3.4): "When searching on
 * the graph, we conduct AABB-tree-based collision detection, and discard the current searching
 * path if the newly created transitions introduces collisions. We also label each input mesh
 * deformation frames in which a collision occurs and avoid using these frames in the synthesis."
 *
 * The obstacle: the triangles of one or more OBJ meshes (static, in the skin's world frame), an
 * AABB tree over them (core/aabb_tree.c: median split, box-overlap query), built once and
 * read-only, so any number of threads test against it.
 * "Intersects": the skinned surface and the obstacle's surface share a point: some mesh triangle
 * and some obstacle triangle intersect (core/tri_tri.c, Möller 1997; touching counts). Per frame
 * every mesh triangle whose box overlaps the obstacle's box queries the obstacle's tree with its
 * box, and the triangles found are tested exactly; the first hit ends the frame. A mesh wholly
 * inside a closed obstacle, or an obstacle wholly inside the mesh, with no surfaces crossing, is
 * not a hit (docs/MODEL.md: a departure; the paper does not say).
 * Input frames: each fitted frame skinned and tested (the labels); walks are kept off them by
 * leaving them out of the graph's alive frames (mdl__variations_alive: nor any frame from which
 * every walk must reach one), for the random walk, the targeted search and the start alike, and
 * per component the same frames; a component (Sec. 4) that no walk could keep off them keeps
 * them (the frame may collide by another component's vertices: the horse's tail), and the
 * output check decides. That is not enough: a splice moves the reference bone (eq. 7,
 * or on the ground plane), the blend makes frames that are in no input, and merged components
 * (Sec. 4) pair frames never seen together; so every output frame of a walk is skinned and
 * tested, and a walk with a colliding frame is discarded and walked again from another seed
 * (the paper discards the search path), up to max_tries walks, then -EAGAIN naming the frame.
 * What holds is the final output: no output frame intersects the obstacle.
 * The check's scratch (one frame's vertices) is the caller's, so nothing is allocated per frame. */
#include "variations/variations.h"
#include "core/aabb_tree.h"
#include "core/tri_tri.h"
#include "core/util.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

struct mdl_obstacle {
    int nv, nf;
    float *V;          /* nv x 3 */
    uint32_t *F;       /* nf x 3 */
    mdl__aabb_tree tree;
};

int mdl_obstacle_create(const mdl_mesh *const *meshes, int n, mdl_obstacle **out, char *err)
{
    *out = NULL;
    size_t nv = 0, nf = 0;
    for (int k = 0; k < n; k++) {
        nv += (size_t)meshes[k]->nv;
        nf += (size_t)meshes[k]->nf;
    }
    if (nf < 1)
        return mdl__err(err, -EINVAL, "obstacle: no triangles");
    if (nv > (size_t)1 << 30 || nf > (size_t)1 << 30)
        return mdl__err(err, -E2BIG, "obstacle: %zu triangles: too many", nf);
    mdl_obstacle *o = mdl__calloc(1, sizeof *o);
    if (!o)
        return mdl__err(err, -ENOMEM, "obstacle: out of memory");
    o->nv = (int)nv;
    o->nf = (int)nf;
    o->V = mdl__calloc(3 * nv, sizeof *o->V);
    o->F = mdl__calloc(3 * nf, sizeof *o->F);
    if (!o->V || !o->F) {
        mdl_obstacle_destroy(o);
        return mdl__err(err, -ENOMEM, "obstacle: out of memory for %zu triangles", nf);
    }
    size_t v0 = 0, f0 = 0;
    for (int k = 0; k < n; k++) {
        const mdl_mesh *m = meshes[k];
        memcpy(o->V + 3 * v0, m->V, 3 * (size_t)m->nv * sizeof *o->V);
        for (size_t i = 0; i < 3 * (size_t)m->nf; i++)
            o->F[3 * f0 + i] = m->F[i] + (uint32_t)v0;
        v0 += (size_t)m->nv;
        f0 += (size_t)m->nf;
    }
    int rc = mdl__aabb_build(&o->tree, o->V, o->nv, o->F, o->nf, err);
    if (rc) {
        mdl_obstacle_destroy(o);
        return rc;
    }
    *out = o;
    return 0;
}

void mdl_obstacle_destroy(mdl_obstacle *o)
{
    if (!o)
        return;
    mdl__aabb_fini(&o->tree);
    free(o->V);
    free(o->F);
    free(o);
}

void mdl_obstacle_get_info(const mdl_obstacle *o, int *triangles, float lo[3], float hi[3])
{
    if (triangles)
        *triangles = o->nf;
    for (int c = 0; c < 3; c++) {
        if (lo)
            lo[c] = o->tree.node[0].lo[c];
        if (hi)
            hi[c] = o->tree.node[0].hi[c];
    }
}

/* a mesh triangle against the obstacle's triangles the tree finds */
typedef struct tri_query {
    const mdl_obstacle *o;
    const float *a, *b, *c;
} tri_query;

static int test_tri(void *ctx, int k)
{
    const tri_query *q = ctx;
    const uint32_t *f = q->o->F + 3 * (size_t)k;
    const float *V = q->o->V;
    return mdl__tri_tri(q->a, q->b, q->c, V + 3 * (size_t)f[0], V + 3 * (size_t)f[1],
                        V + 3 * (size_t)f[2]);
}

int mdl_obstacle_hits(const mdl_obstacle *o, const float *V, const uint32_t *F, int nf)
{
    const float *rlo = o->tree.node[0].lo, *rhi = o->tree.node[0].hi;
    for (int i = 0; i < nf; i++) {
        const float *a = V + 3 * (size_t)F[3 * (size_t)i], *b = V + 3 * (size_t)F[3 * (size_t)i + 1],
                    *c = V + 3 * (size_t)F[3 * (size_t)i + 2];
        float lo[3], hi[3];
        for (int k = 0; k < 3; k++) {
            lo[k] = a[k] < b[k] ? a[k] : b[k];
            lo[k] = c[k] < lo[k] ? c[k] : lo[k];
            hi[k] = a[k] > b[k] ? a[k] : b[k];
            hi[k] = c[k] > hi[k] ? c[k] : hi[k];
        }
        if (!mdl__box_overlap(lo, hi, rlo, rhi))
            continue;
        tri_query q = {o, a, b, c};
        if (mdl__aabb_query(&o->tree, lo, hi, test_tri, &q))
            return 1;
    }
    return 0;
}

int mdl_variations_colliding_frames(const mdl_variations *v, const mdl_obstacle *o,
                                    const uint32_t *F, int nf, uint8_t *flags, char *err)
{
    float *V = mdl__calloc(3 * (size_t)v->nv, sizeof *V);
    if (!V)
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    for (int n = 0; n < v->nframes; n++) {
        mdl__variations_skin(v, v->T + 12 * (size_t)v->nb * n, V);
        flags[n] = (uint8_t)mdl_obstacle_hits(o, V, F, nf);
    }
    free(V);
    return 0;
}

int mdl_variations_block_frames(mdl_variations *v, const uint8_t *blocked, char *err)
{
    mdl__variations_alive(v, blocked);
    int freed = 0;
    for (int c = 0; c < v->ncomp; c++) {
        mdl__variations_alive(v->comp[c].g, blocked);
        if (v->comp[c].g->nalive < 1) { /* this component cannot avoid the frames: it keeps them */
            mdl__variations_alive(v->comp[c].g, NULL);
            freed++;
        }
    }
    if (v->ncomp > 1 && freed == v->ncomp)
        return mdl__err(err, -ENOENT, "variations: in every component, every frame collides or "
                        "leads only to colliding ones");
    if (v->ncomp < 2 && v->nalive < 1)
        return mdl__err(err, -ENOENT, "variations: every frame collides or leads only to "
                        "colliding ones");
    return 0;
}

int mdl_variations_walk_avoiding(const mdl_variations *v, const mdl_obstacle *o,
                                 const uint32_t *F, int nf, uint64_t seed, int frames,
                                 const mdl_variations_target *targets, int nt, int max_tries,
                                 double *T, int *src, float *V, uint64_t *used_seed, int *redraws,
                                 char *err)
{
    int last = -1;
    uint64_t s = seed;
    for (int attempt = 0; attempt < (max_tries > 0 ? max_tries : 1); attempt++) {
        /* the seeds of the redraws: a function of the variation's seed, not of the order in
         * which variations are walked (so any --threads gives the same) */
        s = attempt ? mdl__vwalk_comp_seed(seed ^ 0x6a09e667f3bcc909ull, attempt) : seed;
        int rc = mdl_variations_walk_targets(v, s, frames, targets, nt, T, NULL, src, err);
        if (rc)
            return rc;
        last = -1;
        for (int f = 0; o && f < frames && last < 0; f++) {
            mdl__variations_skin(v, T + 12 * (size_t)v->nb * f, V);
            if (mdl_obstacle_hits(o, V, F, nf))
                last = f;
        }
        if (last < 0) {
            if (used_seed)
                *used_seed = s;
            if (redraws)
                *redraws = attempt;
            return 0;
        }
    }
    return mdl__err(err, -EAGAIN, "variations: %d walks from seed %llu each have an output frame "
                    "intersecting the obstacle (the last at output frame %d)",
                    max_tries > 0 ? max_tries : 1, (unsigned long long)seed, last);
}
