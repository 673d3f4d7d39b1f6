/* target.c - targeted frames (Zheng 2013 Sec. 3.4): "a set of frames f_i, i = 1..M from the input
 * animation must appear at frame f~_j in the output animation. The targeted frames split the
 * output time axis into intervals ... We use multi-start bidirectional search to find sequences
 * of input animation segments forming the desired intervals."
 *
 * On the motion graph of walk.c (nodes: input frames a walk can go on for ever from; edges
 * n -> n + 1 and the transitions (n, j) -> j + 1), an interval from output frame f_a (input a)
 * to f_b (input b) needs a path of exactly f_b - f_a edges. The backward half of the search
 * marks, for every output frame f, the input frames from which all later targets can still be
 * met (a layered reachability from each target back to the previous one, allowed[f][n] = alive(n)
 * and some successor of n allowed at f + 1, and at a target frame only its input frame); the
 * forward half is the walk itself (walk.c's rule, its choices restricted to allowed frames), so
 * a walk from any allowed start meets every target exactly and stays as random as the constraints
 * let it. "Multi-start": with no start given, the start is drawn among all the input frames that
 * can reach the first target in time. Where the paper searches and backtracks, this finds a path
 * whenever one exists, in O(frames x (frames + transitions)). After the last target the walk is
 * free. With several components each one's walk meets the targets on its own graph, so the
 * merged frame at a target is the input frame (each component at it). Batch, not per frame. */
#include "variations/variations.h"
#include "core/util.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

static int cmp_target(const void *a, const void *b)
{
    const mdl_variations_target *x = a, *y = b;
    return (x->out > y->out) - (x->out < y->out);
}

/* mask (frames x N) of g for the sorted targets t[0..nt) */
static void backward(const struct mdl_variations *g, const mdl_variations_target *t, int nt,
                     int frames, uint8_t *mask)
{
    int N = g->nframes, last = nt ? t[nt - 1].out : -1, k = nt - 1;
    for (int f = frames - 1; f >= 0; f--) {
        uint8_t *m = mask + (size_t)N * f;
        const uint8_t *next = f + 1 < frames ? m + N : NULL;
        for (int n = 0; n < N; n++) {
            int ok = g->alive[n];
            if (ok && f < last && next) {
                ok = n + 1 < N && next[n + 1];
                for (int e = g->off[n]; !ok && e < g->off[n + 1]; e++)
                    ok = g->to[e] + 1 < N && next[g->to[e] + 1];
            }
            m[n] = (uint8_t)ok;
        }
        while (k >= 0 && t[k].out > f)
            k--;
        if (k >= 0 && t[k].out == f)
            for (int n = 0; n < N; n++)
                m[n] = m[n] && n == t[k].in;
    }
}

int mdl_variations_walk_targets(const mdl_variations *v, uint64_t seed, int frames,
                                const mdl_variations_target *targets, int nt, double *T, float *V,
                                int *src, char *err)
{
    if (!v || frames < 0 || (frames > 0 && !T) || nt < 0 || (nt > 0 && !targets))
        return mdl__err(err, -EINVAL, "variations walk: bad arguments");
    int N = v->nframes, nc = v->ncomp > 1 ? v->ncomp : 1, rc = 0, start = -1;
    for (int k = 0; k < nt; k++) {
        if (targets[k].in < 0 || targets[k].in >= N)
            return mdl__err(err, -EINVAL, "variations: target %d:%d: input frame %d of %d",
                            targets[k].in, targets[k].out, targets[k].in, N);
        if (targets[k].out < 0 || targets[k].out >= frames)
            return mdl__err(err, -EINVAL, "variations: target %d:%d: output frame %d of %d",
                            targets[k].in, targets[k].out, targets[k].out, frames);
    }
    if (nt > 0 && (double)frames * N * nc > 1e9)
        return mdl__err(err, -E2BIG, "variations: targets over %d frames x %d input frames: too "
                        "many", frames, N);
    mdl_variations_target *t = NULL;
    uint8_t **masks = NULL, *all = NULL;
    if (nt > 0) {
        t = mdl__calloc(nt, sizeof *t);
        masks = mdl__calloc(nc, sizeof *masks);
        all = mdl__calloc((size_t)frames * N * nc, 1);
        if (!t || !masks || !all) {
            rc = mdl__err(err, -ENOMEM, "variations: out of memory for %d frames", frames);
            goto out;
        }
        memcpy(t, targets, nt * sizeof *t);
        qsort(t, nt, sizeof *t, cmp_target);
        for (int k = 1; k < nt; k++)
            if (t[k].out == t[k - 1].out && t[k].in != t[k - 1].in) {
                rc = mdl__err(err, -EINVAL, "variations: output frame %d targeted twice (input "
                              "frames %d and %d)", t[k].out, t[k - 1].in, t[k].in);
                goto out;
            }
        for (int c = 0; c < nc; c++) {
            masks[c] = all + (size_t)frames * N * c;
            backward(nc > 1 ? v->comp[c].g : v, t, nt, frames, masks[c]);
        }
        /* the start: among the frames allowed at output frame 0 in every component */
        int n0 = 0;
        for (int n = 0; n < N; n++) {
            int ok = 1;
            for (int c = 0; c < nc; c++)
                ok &= masks[c][n];
            n0 += ok;
        }
        if (n0 == 0) {
            rc = mdl__err(err, -ENOENT, "variations: no walk meets the targets (input frame %d at "
                          "output frame %d%s): the transitions do not connect them in time",
                          t[0].in, t[0].out, nt > 1 ? ", ..." : "");
            goto out;
        }
        start = v->o.start;
        int ok_start = start >= 0;
        for (int c = 0; ok_start && c < nc; c++)
            ok_start = masks[c][start];
        if (!ok_start) {
            uint64_t rng = seed ^ 0x9e3779b97f4a7c15ull;
            int k = (int)(mdl__uniform(&rng) * n0);
            k = k < n0 ? k : n0 - 1;
            for (start = 0; start < N; start++) {
                int ok = 1;
                for (int c = 0; c < nc; c++)
                    ok &= masks[c][start];
                if (ok && k-- == 0)
                    break;
            }
        }
    }
    if (v->nalive < 1 && nc == 1) {
        rc = mdl__err(err, -ENOENT, "variations: no transitions (T_c %.4g): the example cannot "
                      "be extended", v->tc);
        goto out;
    }
    rc = mdl__variations_walk_masked(v, seed, frames, masks, start, T, src, err);
    for (int f = 0; !rc && V && f < frames; f++)
        mdl__variations_skin(v, T + 12 * (size_t)f * v->nb, V + 3 * (size_t)f * v->nv);
out:
    free(t);
    free(masks);
    free(all);
    return rc;
}
