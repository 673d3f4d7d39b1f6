/* ssdr_init.c - the initialisation of SSDR: N rigid vertex groups [Le & Deng 2012, the
 * clustering initialisation] (ssdr.h).
 *
 * Le & Deng start from hard labels: every vertex belongs to one bone, each bone's transforms are
 * the rigid fits (Kabsch / Procrustes, ssdr_transforms.c with one-hot weights) of its vertices,
 * and the labels are updated to the bone that reconstructs the vertex best,
 *   label_i = argmin_j sum_t || v_i^t - (R_j^t p_i + T_j^t) ||^2 = argmin_j (p~^T G_jj p~ - 2 c_ij)
 * (the normal-equation terms of ssdr.h, one dgemm for all vertices), alternating a few times.
 * The number of groups grows from one by splitting: each round splits the groups of largest total
 * error (at most as many as are still missing), each into the vertices nearer (in the rest pose)
 * to its worst-fitting vertex and those nearer to the member farthest from it. Groups that the
 * label update empties below MIN_SIZE vertices are dropped and split again later; in the second
 * half of the bounded number of rounds nothing is dropped, so the loop always ends with exactly
 * N groups (Dem Bones can end with fewer, or not end: issue 10) unless the mesh has fewer than
 * MIN_SIZE vertices per bone, which is refused with -EDOM. Deterministic: ties go to the lower
 * index. */
#include "skin/ssdr.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MIN_SIZE 3

static void onehot(mdl__ssdr *s)
{
    for (int i = 0; i < s->nv; i++)
        for (int q = 0; q < s->K; q++) {
            s->bone[(size_t)s->K * i + q] = s->label[i];
            s->w[(size_t)s->K * i + q] = q == 0;
        }
}

static void assign_block(void *ctx, int bi, int worker)
{
    mdl__ssdr *s = ctx;
    int nb = s->nb;
    int i0 = bi * SSDR_BLOCK, i1 = i0 + SSDR_BLOCK < s->nv ? i0 + SSDR_BLOCK : s->nv;
    double *y = s->Yw + (size_t)worker * SSDR_BLOCK * 4 * nb;
    double *c = s->Sw + (size_t)worker * s->sw_len, *d = c + (size_t)SSDR_BLOCK * nb;
    mdl__ssdr_block_cd(s, i0, i1, y, c, d);
    for (int i = i0; i < i1; i++) {
        const double *ci = c + (size_t)(i - i0) * nb, *di = d + (size_t)(i - i0) * nb;
        int bj = 0;
        double be = INFINITY;
        for (int j = 0; j < nb; j++) {
            double e = di[j] - 2 * ci[j];
            if (e < be) {
                be = e;
                bj = j;
            }
        }
        s->new_bone[i] = bj;
        s->verr[i] = fmax(0, s->vv[i] + be);
    }
}

/* label update against the current transforms */
static void assign(mdl__ssdr *s)
{
    mdl__ssdr_normal_setup(s);
    mdl__ssdr_parallel(s, (s->nv + SSDR_BLOCK - 1) / SSDR_BLOCK, assign_block, s);
    memcpy(s->label, s->new_bone, (size_t)s->nv * sizeof *s->label);
    onehot(s);
}

static void fit(mdl__ssdr *s)
{
    onehot(s);
    mdl__ssdr_transforms(s, 1, NULL);
}

/* per-vertex error of its own label (after fit) */
static void label_errors(mdl__ssdr *s)
{
    /* the residual of a one-hot fit is the vertex's own error: recompute through assign's
     * machinery restricted to the label, by a direct pass over the frames */
    int nv = s->nv, nb = s->nb;
    for (int i = 0; i < nv; i++)
        s->verr[i] = 0;
    for (int t = 0; t < s->nf; t++) {
        const double *X0 = s->X + (size_t)nv * 3 * t;
        const double *Tf = s->T + 12 * (size_t)t * nb;
        for (int i = 0; i < nv; i++) {
            const double *T = Tf + 12 * (size_t)s->label[i], *p = s->U + 3 * (size_t)i;
            double e = 0;
            for (int a = 0; a < 3; a++) {
                double o = T[3 * a] * p[0] + T[3 * a + 1] * p[1] + T[3 * a + 2] * p[2] + T[9 + a];
                double dd = X0[i + (size_t)nv * a] - o;
                e += dd * dd;
            }
            s->verr[i] += e;
        }
    }
}

/* Drops groups smaller than MIN_SIZE; returns how many remain. */
static int prune(mdl__ssdr *s, int *count, int *remap)
{
    int nb = s->nb, keep = 0;
    for (int j = 0; j < nb; j++) {
        if (count[j] >= MIN_SIZE) {
            remap[j] = keep;
            if (keep != j)
                for (int t = 0; t < s->nf; t++)
                    memcpy(s->T + 12 * ((size_t)t * s->nb + keep), s->T + 12 * ((size_t)t * s->nb + j),
                           12 * sizeof *s->T);
            keep++;
        } else {
            remap[j] = -1;
        }
    }
    if (keep == nb)
        return nb;
    /* compact the frame layout from stride nb to stride keep */
    for (int t = 0; t < s->nf; t++)
        memmove(s->T + 12 * (size_t)t * keep, s->T + 12 * (size_t)t * nb, 12 * (size_t)keep * sizeof *s->T);
    s->nb = keep;
    assign(s);
    return keep;
}

/* T is stored with stride nb per frame; growing nb to nb2 re-spaces it. */
static void grow(mdl__ssdr *s, int nb2)
{
    int nb = s->nb;
    for (int t = s->nf - 1; t >= 0; t--) {
        memmove(s->T + 12 * (size_t)t * nb2, s->T + 12 * (size_t)t * nb, 12 * (size_t)nb * sizeof *s->T);
        for (int j = nb; j < nb2; j++) {
            double *T = s->T + 12 * ((size_t)t * nb2 + j);
            memset(T, 0, 12 * sizeof *T);
            T[0] = T[4] = T[8] = 1;
        }
    }
    s->nb = nb2;
}

static double dist2(const double *a, const double *b)
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return x * x + y * y + z * z;
}

int mdl__ssdr_init(mdl__ssdr *s, int iterations, char *err)
{
    int target = s->nb, nv = s->nv;
    if (nv < MIN_SIZE * target)
        return mdl__err(err, -EDOM,
                        "the mesh has %d vertices: it cannot support %d bones (%d vertices each at "
                        "least)", nv, target, MIN_SIZE);
    int *count = mdl__calloc((size_t)target + 1, sizeof *count);
    int *remap = mdl__calloc((size_t)target + 1, sizeof *remap);
    double *cerr = mdl__calloc((size_t)target + 1, sizeof *cerr);
    int *order = mdl__calloc((size_t)target + 1, sizeof *order);
    if (!count || !remap || !cerr || !order) {
        free(count);
        free(remap);
        free(cerr);
        free(order);
        return mdl__err(err, -ENOMEM, "out of memory");
    }
    for (int i = 0; i < nv; i++)
        s->label[i] = 0;
    s->nb = 1;
    fit(s);
    int max_rounds = 2 * target + 16, rc = 0;
    for (int round = 0; s->nb < target; round++) {
        int late = round >= max_rounds / 2;
        if (round >= max_rounds) {
            rc = mdl__err(err, -EDOM, "initialisation: %d of %d bones after %d rounds", s->nb,
                          target, round);
            break;
        }
        label_errors(s);
        int nb = s->nb;
        memset(count, 0, (size_t)nb * sizeof *count);
        memset(cerr, 0, (size_t)nb * sizeof *cerr);
        for (int i = 0; i < nv; i++) {
            count[s->label[i]]++;
            cerr[s->label[i]] += s->verr[i];
        }
        /* the groups by descending error (selection; nb is small) */
        for (int j = 0; j < nb; j++)
            order[j] = j;
        for (int a = 0; a < nb; a++)
            for (int b = a + 1; b < nb; b++)
                if (cerr[order[b]] > cerr[order[a]] ||
                    (cerr[order[b]] == cerr[order[a]] && order[b] < order[a])) {
                    int x = order[a];
                    order[a] = order[b];
                    order[b] = x;
                }
        int want = target - nb < nb ? target - nb : nb, made = 0, nb2 = nb;
        for (int r = 0; r < nb && made < want; r++) {
            int j = order[r];
            if (count[j] < 2 * MIN_SIZE)
                continue;
            int a = -1, b = -1;
            for (int i = 0; i < nv; i++)
                if (s->label[i] == j && (a < 0 || s->verr[i] > s->verr[a]))
                    a = i;
            double far = -1;
            for (int i = 0; i < nv; i++)
                if (s->label[i] == j) {
                    double d = dist2(s->U + 3 * (size_t)i, s->U + 3 * (size_t)a);
                    if (d > far) {
                        far = d;
                        b = i;
                    }
                }
            int nnew = 0, nold = 0;
            for (int i = 0; i < nv; i++)
                if (s->label[i] == j) {
                    if (dist2(s->U + 3 * (size_t)i, s->U + 3 * (size_t)a) <
                        dist2(s->U + 3 * (size_t)i, s->U + 3 * (size_t)b)) {
                        s->label[i] = nb2;
                        nnew++;
                    } else {
                        nold++;
                    }
                }
            if (nnew < MIN_SIZE || nold < MIN_SIZE) { /* undo a lopsided split */
                for (int i = 0; i < nv; i++)
                    if (s->label[i] == nb2)
                        s->label[i] = j;
                continue;
            }
            nb2++;
            made++;
        }
        if (made == 0) {
            rc = mdl__err(err, -EDOM, "initialisation: no group of %d can be split further (%d of "
                          "%d bones)", nb, nb, target);
            break;
        }
        grow(s, nb2);
        fit(s);
        for (int it = 0; it < iterations && !late; it++) {
            assign(s);
            fit(s);
        }
        if (!late) {
            memset(count, 0, (size_t)s->nb * sizeof *count);
            for (int i = 0; i < nv; i++)
                count[s->label[i]]++;
            int before = s->nb;
            if (prune(s, count, remap) != before)
                fit(s);
        }
    }
    if (!rc) {
        /* a last label update and fit over all N groups, keeping every group populated */
        fit(s);
    }
    free(count);
    free(remap);
    free(cerr);
    free(order);
    s->nb = target;
    return rc;
}
