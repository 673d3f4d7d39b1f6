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
 * Targeted frames restrict the choices (mdl__vwalk_step_to, target.c); the overlap test is
 * overlap.c; collision avoidance (Sec. 3.4, avoid.c) leaves colliding frames out of alive (so
 * the walk never shows them) and checks the output frames.
 * Several components (Sec. 4, components.c): one walker per component on its own graph, each
 * with its own seed (mdl__vwalk_comp_seed) but from one common start frame (alive in every
 * component; the paper leaves the start open: a common one makes the merged animation begin as
 * the input's frame does, and components whose graphs only join corresponding frames stay in
 * phase), merged per frame by eq. 13-14 (merge.c) in the components' order.
 * A step allocates nothing; its state is the walker (mdl__vwalk), so several walks may run at
 * once over one read-only graph. */
#include "variations/variations.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

uint64_t mdl__vwalk_comp_seed(uint64_t seed, int c)
{
    /* splitmix64 of the pair */
    uint64_t z = seed + 0x9e3779b97f4a7c15ull * (uint64_t)(c + 1);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static int alive_everywhere(const struct mdl_variations *v, int f)
{
    if (v->ncomp < 2)
        return v->alive[f];
    for (int c = 0; c < v->ncomp; c++)
        if (!v->comp[c].g->alive[f])
            return 0;
    return 1;
}

int mdl__vwalk_start(const struct mdl_variations *v, uint64_t seed)
{
    int start = v->o.start;
    if (start >= 0 && alive_everywhere(v, start))
        return start;
    int n = 0;
    for (int f = 0; f < v->nframes; f++)
        n += alive_everywhere(v, f);
    if (n < 1) /* no frame alive in all: the anchor's */
        return v->ncomp > 1 ? mdl__vwalk_start(v->comp[0].g, seed) : 0;
    uint64_t rng = seed ^ 0x9e3779b97f4a7c15ull;
    int k = (int)(mdl__uniform(&rng) * n);
    if (k >= n)
        k = n - 1;
    for (int f = 0; f < v->nframes; f++)
        if (alive_everywhere(v, f) && k-- == 0)
            return f;
    return 0;
}

int mdl__vwalk_init(mdl__vwalk *w, const struct mdl_variations *v, uint64_t seed, char *err)
{
    memset(w, 0, sizeof *w);
    if (v->ncomp > 1) {
        w->v = v;
        w->ncomp = v->ncomp;
        size_t nt = 0;
        for (int c = 0; c < v->ncomp; c++)
            nt += 12 * (size_t)v->comp[c].nb;
        w->sub = mdl__calloc(v->ncomp, sizeof *w->sub);
        w->Tc = mdl__calloc(nt, sizeof *w->Tc);
        w->src = mdl__calloc(v->ncomp, sizeof *w->src);
        if (!w->sub || !w->Tc || !w->src) {
            mdl__vwalk_fini(w);
            return mdl__err(err, -ENOMEM, "variations: out of memory");
        }
        for (int c = 0; c < v->ncomp; c++) {
            int rc = mdl__vwalk_init(&w->sub[c], v->comp[c].g, seed, err);
            if (rc) {
                mdl__vwalk_fini(w);
                return rc;
            }
        }
        mdl__vwalk_reset(w, seed);
        return 0;
    }
    if (v->nalive < 1)
        return mdl__err(err, -ENOENT,
                        "variations: no transitions (T_c %.4g): the example cannot be extended", v->tc);
    if (mdl__vblend_init(&w->b, v))
        return mdl__err(err, -ENOMEM, "variations: out of memory");
    w->v = v;
    mdl__vwalk_reset(w, seed);
    return 0;
}

void mdl__vwalk_reset_at(mdl__vwalk *w, uint64_t seed, int start)
{
    const struct mdl_variations *v = w->v;
    mdl__vblend_reset(&w->b, v);
    w->rng = seed ^ 0x9e3779b97f4a7c15ull;
    mdl__uniform(&w->rng); /* the draw of the start frame (mdl__vwalk_start) */
    w->cur = start >= 0 && start < v->nframes && v->alive[start] ? start : mdl__vwalk_start(v, seed);
    w->seg = 0;
}

void mdl__vwalk_reset(mdl__vwalk *w, uint64_t seed)
{
    const struct mdl_variations *v = w->v;
    int start = mdl__vwalk_start(v, seed);
    if (w->ncomp > 1) {
        for (int c = 0; c < w->ncomp; c++)
            mdl__vwalk_reset_at(&w->sub[c], mdl__vwalk_comp_seed(seed, c), start);
        return;
    }
    mdl__vwalk_reset_at(w, seed, start);
}

void mdl__vwalk_fini(mdl__vwalk *w)
{
    for (int c = 0; c < w->ncomp && w->sub; c++)
        mdl__vwalk_fini(&w->sub[c]);
    free(w->sub);
    free(w->Tc);
    free(w->src);
    w->sub = NULL;
    w->Tc = NULL;
    w->src = NULL;
    w->ncomp = 0;
    mdl__vblend_fini(&w->b);
}

/* several components: each steps, then the merge (eq. 13-14) in order */
static int step_components(mdl__vwalk *w, double *T)
{
    const struct mdl_variations *v = w->v;
    double *Tc = w->Tc;
    for (int c = 0; c < w->ncomp; c++) {
        const mdl__vcomp *k = &v->comp[c];
        w->src[c] = mdl__vwalk_step(&w->sub[c], Tc);
        if (c == 0)
            for (int b = 0; b < k->nb; b++)
                memcpy(T + 12 * (size_t)k->bones[b], Tc + 12 * (size_t)b, 12 * sizeof *T);
        else
            mdl__merge_frame(k, Tc, T);
        Tc += 12 * (size_t)k->nb;
    }
    return w->src[0];
}

int mdl__vwalk_step(mdl__vwalk *w, double *T)
{
    if (w->ncomp > 1)
        return step_components(w, T);
    return mdl__vwalk_step_to(w, T, NULL);
}

/* may the walk go on to input frame n */
static int open_to(const struct mdl_variations *v, const uint8_t *ok, int n)
{
    return n < v->nframes && v->alive[n] && (!ok || ok[n]);
}

int mdl__vwalk_step_to(mdl__vwalk *w, double *T, const uint8_t *ok)
{
    const struct mdl_variations *v = w->v;
    int c = w->cur;
    mdl__vblend_pose(&w->b, v, c, T);
    int cont = open_to(v, ok, c + 1), open = 0;
    for (int k = v->off[c]; k < v->off[c + 1]; k++)
        open += open_to(v, ok, v->to[k] + 1);
    /* the open transitions' weights exp(-D / sigma) (1 for temperature 0) */
    double sigma = v->o.temperature * v->max_adjacent, sum = 0, best = 0;
    for (int k = v->off[c]; k < v->off[c + 1]; k++)
        if (open_to(v, ok, v->to[k] + 1)) {
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
            if (open_to(v, ok, v->to[k] + 1)) {
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

/* The whole animation at once, per component (one component: the skin's graph as component 0):
 * each component's walk, next input frames restricted by its masks (target.c; NULL: free), from
 * the common start frame; then Algorithm 1 in the components' order, with D_C (eq. 12) checked
 * against its threshold, a component that does not match walked again with another seed. Equal to
 * the stepping walker's frames whenever the first seed matches (always with rigid bones). */
int mdl__variations_walk_masked(const struct mdl_variations *v, uint64_t seed, int frames,
                                uint8_t *const *masks, int start, double *T, int *src, char *err)
{
    int nc = v->ncomp > 1 ? v->ncomp : 1, rc = 0;
    if (start < 0)
        start = mdl__vwalk_start(v, seed);
    size_t nmax = v->nb;
    double *S = nc > 1 ? mdl__calloc(12 * nmax * (size_t)frames + 1, sizeof *S) : NULL;
    if (nc > 1 && !S)
        return mdl__err(err, -ENOMEM, "variations: out of memory for %d frames", frames);
    for (int c = 0; c < nc && !rc; c++) {
        const mdl__vcomp *k = nc > 1 ? &v->comp[c] : NULL;
        const struct mdl_variations *g = k ? k->g : v;
        double *out = k ? S : T;
        const uint8_t *mask = masks ? masks[c] : NULL;
        mdl__vwalk w;
        rc = mdl__vwalk_init(&w, g, seed, err);
        if (rc)
            break;
        int merged = 0;
        double dc = 0, thr = 0;
        for (int attempt = 0; attempt < 16 && !merged; attempt++) {
            uint64_t s = k ? mdl__vwalk_comp_seed(seed, c) : seed;
            if (attempt > 0)
                s = mdl__vwalk_comp_seed(s, attempt);
            mdl__vwalk_reset_at(&w, s, start);
            for (int f = 0; f < frames; f++) {
                const uint8_t *ok = mask && f + 1 < frames ? mask + (size_t)g->nframes * (f + 1) : NULL;
                int in = mdl__vwalk_step_to(&w, out + 12 * (size_t)g->nb * f, ok);
                if (src)
                    src[(size_t)nc * f + c] = in;
            }
            if (c == 0)
                break;
            dc = mdl__merge_cost(T + 12 * (size_t)k->cut, 12 * (size_t)v->nb,
                                 S + 12 * (size_t)k->cut_local, 12 * (size_t)k->nb, frames, &thr);
            merged = dc < thr || (dc == 0 && thr == 0);
        }
        mdl__vwalk_fini(&w);
        if (c > 0 && !merged) {
            rc = mdl__err(err, -EAGAIN, "variations: component %d (cut node %d): no walk whose cut "
                          "node's stretch matches the anchor's (D_C %.4g >= %.4g, 16 seeds)",
                          c, k->cut, dc, thr);
            break;
        }
        for (int f = 0; k && f < frames; f++) {
            double *Tf = T + 12 * (size_t)v->nb * f;
            const double *Sf = S + 12 * (size_t)k->nb * f;
            if (c == 0)
                for (int b = 0; b < k->nb; b++)
                    memcpy(Tf + 12 * (size_t)k->bones[b], Sf + 12 * (size_t)b, 12 * sizeof *T);
            else
                mdl__merge_frame(k, Sf, Tf);
        }
    }
    free(S);
    return rc;
}

void mdl_variations_skin_frame(const mdl_variations *v, const double *T, float *V)
{
    mdl__variations_skin(v, T, V);
}

int mdl_variations_walk(const mdl_variations *v, uint64_t seed, int frames, double *T, float *V,
                        int *src, char *err)
{
    return mdl_variations_walk_targets(v, seed, frames, NULL, 0, T, V, src, err);
}
