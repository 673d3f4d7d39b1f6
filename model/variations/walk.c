/* walk.c - random walks on the motion graph (Zheng 2013 Sec. 3.4): "it is possible that the start
 * frame or the end frame or both of them are not specified for an interval, then bidirectional
 * search is unnecessary, and we simply conduct a random walk on the graph to generate diverse
 * results."
 *
 * The graph's nodes are the input frames, its edges the steps t -> t + 1 and the transitions
 * (i, j) of transitions.c (after i, continue with j + 1), restricted to frames from which a walk
 * can go on for ever (alive), so every walk has any length. Each open transition k has the weight
 * w_k = exp(-D_k / sigma), sigma = temperature x max_i D(i, i-1) (1 for temperature 0): the paper
 * leaves the choice open; this is video textures' rule (Schoedl et al. 2000), so that the cheap
 * transitions below a loose T_c are preferred. Per output frame, once min_segment frames have
 * passed since the last transition, a transition is taken with chance jump_prob x max_k w_k, and
 * then transition k with chance w_k / sum w, spliced by blend.c; at the end of the example (or
 * before a frame without a future) one must be taken. The start frame is o.start or drawn from the seed.
 * Targeted frames, collision avoidance and the overlap test of Sec. 3.4 are not implemented.
 * A step allocates nothing; its state is the walker (mdl__vwalk), so several walks may run at
 * once over one read-only graph. */
#include "variations/variations.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int mdl__vwalk_init(mdl__vwalk *w, const struct mdl_variations *v, uint64_t seed, char *err)
{
    memset(w, 0, sizeof *w);
    if (v->nalive < 1)
        return mdl__err(err, -ENOENT,
                        "variations: no transitions (T_c %.4g): the example cannot be extended", v->tc);
    if (mdl__vblend_init(&w->b, v))
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    w->v = v;
    mdl__vwalk_reset(w, seed);
    return 0;
}

void mdl__vwalk_reset(mdl__vwalk *w, uint64_t seed)
{
    const struct mdl_variations *v = w->v;
    mdl__vblend_reset(&w->b, v);
    w->rng = seed ^ 0x9e3779b97f4a7c15ull;
    int start = v->o.start;
    if (start < 0 || !v->alive[start]) {
        int k = (int)(mdl__uniform(&w->rng) * v->nalive);
        if (k >= v->nalive)
            k = v->nalive - 1;
        for (start = 0; start < v->nframes; start++)
            if (v->alive[start] && k-- == 0)
                break;
    }
    w->cur = start;
    w->seg = 0;
}

void mdl__vwalk_fini(mdl__vwalk *w)
{
    mdl__vblend_fini(&w->b);
}

int mdl__vwalk_step(mdl__vwalk *w, double *T)
{
    const struct mdl_variations *v = w->v;
    int c = w->cur;
    mdl__vblend_pose(&w->b, v, c, T);
    int cont = c + 1 < v->nframes && v->alive[c + 1], open = 0;
    for (int k = v->off[c]; k < v->off[c + 1]; k++)
        open += v->alive[v->to[k] + 1];
    /* the open transitions' weights exp(-D / sigma) (1 for temperature 0) */
    double sigma = v->o.temperature * v->max_adjacent, sum = 0, best = 0;
    for (int k = v->off[c]; k < v->off[c + 1]; k++)
        if (v->alive[v->to[k] + 1]) {
            double wk = sigma > 0 ? exp(-v->cost[k] / sigma) : 1;
            sum += wk;
            best = wk > best ? wk : best;
        }
    /* a jump where the best open transition is cheap; at a dead end one must be taken */
    int take = !cont;
    if (cont && open > 0 && w->seg >= v->o.min_segment && v->o.jump_prob > 0)
        take = mdl__uniform(&w->rng) < v->o.jump_prob * best;
    if (take && open > 0) {
        double u = mdl__uniform(&w->rng) * sum;
        int j = -1;
        for (int k = v->off[c]; k < v->off[c + 1]; k++)
            if (v->alive[v->to[k] + 1]) {
                j = v->to[k];
                u -= sigma > 0 ? exp(-v->cost[k] / sigma) : 1;
                if (u <= 0)
                    break;
            }
        mdl__vblend_splice(&w->b, v, c, j);
        w->cur = j + 1;
        w->seg = 0;
    } else {
        w->cur = c + 1 < v->nframes ? c + 1 : 0; /* not reached for an alive frame */
        w->seg++;
    }
    mdl__vblend_advance(&w->b);
    return c;
}

void mdl__variations_skin(const struct mdl_variations *v, const double *T, float *V)
{
    for (int i = 0; i < v->nv; i++) {
        const float *p = v->rest + 3 * (size_t)i;
        double o[3] = {0, 0, 0};
        for (int s = 0; s < v->K; s++) {
            double wt = v->w[(size_t)v->K * i + s];
            if (wt == 0)
                continue;
            const double *M = T + 12 * (size_t)v->bone[(size_t)v->K * i + s];
            for (int c = 0; c < 3; c++)
                o[c] += wt * (M[3 * c] * p[0] + M[3 * c + 1] * p[1] + M[3 * c + 2] * p[2] + M[9 + c]);
        }
        for (int c = 0; c < 3; c++)
            V[3 * (size_t)i + c] = (float)o[c];
    }
}

int mdl_variations_walk(const mdl_variations *v, uint64_t seed, int frames, double *T, float *V,
                        int *src, char *err)
{
    if (!v || frames < 0 || (frames > 0 && !T))
        return mdl__err(err, -EINVAL, "variations walk: bad arguments");
    mdl__vwalk w;
    int rc = mdl__vwalk_init(&w, v, seed, err);
    if (rc)
        return rc;
    for (int f = 0; f < frames; f++) {
        double *Tf = T + 12 * (size_t)f * v->nb;
        int c = mdl__vwalk_step(&w, Tf);
        if (src)
            src[f] = c;
        if (V)
            mdl__variations_skin(v, Tf, V + 3 * (size_t)f * v->nv);
    }
    mdl__vwalk_fini(&w);
    return 0;
}
