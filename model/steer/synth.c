/* synth.c - the synthesis phase of paper 2012 (Fig. 3, Sec. 5), one frame at a time.
 *
 *   1. marker parameters M* of every limb (Table 1, posefeat.c), pose-adapted (Sec. 4.2)
 *   2. Phi(M*) and Psi(M*): each instance's rotation (unit quaternion), translation and shape
 *      prior lambda+ (eq. 1, 5); lambda+ is clamped to +-3 sigma (the Gaussian model of eq. 6)
 *   3. alternating least squares (Sec. 5, after [XZY*07, BBW*11]):
 *        a. greedy rigid alignment (Sec. 5.1): instances in the precomputed order, each aligned
 *           by its overlap with what is already placed (absolute orientation, rigid.h), with the
 *           predicted rotation as a prior; an instance without overlap keeps its prediction.
 *           Ours: when the markers live in the mesh's space (virtual markers, same subject) the
 *           rig vertices are further alignment targets, and `relax` sweeps re-align every
 *           instance against all its neighbours so that those targets reach along the chains;
 *        b. shape optimisation (Sec. 5.2, eq. 7): per instance
 *             min_lambda sum_{i in O} ||x_i - x_hat_i(lambda)||^2 + beta sum_k (lambda_k - lambda+_k)^2 / sigma_k^2
 *           where x_i are the other instances' positions of the overlap vertices O, taken into the
 *           instance's local frame. The normal matrix V_O^T V_O + beta diag(1/sigma^2) depends only
 *           on the model and is factored at training; per frame this is two triangular solves.
 *      `iterations` shape steps, each followed by alignment sweeps from the transforms found
 *      so far (a new greedy pass would only start further away).
 *   4. blending of shared clusters and overlaps with the precomputed weights of eq. (8) (Sec. 5.3)
 *   5. placement in the markers' body frame (reference edge); for a model trained on another
 *      performer's recording, ground-locked placement (model_internal.h, place_mode).
 *
 * Missing markers: a marker that is invalid in a frame is held at its last valid position
 * (counted in info->markers_held); a marker never seen makes its limbs use the training mean of
 * their parameters; without a reference edge the last body frame is kept (info->reference_lost).
 * Everything is allocated in mdl__steer_synth_create; mdl__steer_synth_frame allocates nothing.
 *
 * Layout for speed (docs/MODEL.md, "Synthesis per frame"): steps 3a-b read only the overlap
 * vertices (m->sov) and the marker vertices, kept in compact per-entry arrays; the full local
 * shape of eq. (6) is formed only inside the blend, from structure-of-arrays copies of the part
 * means and modes. Step 3 and the blend are each compiled for plain x86-64 and for AVX2 and
 * picked once in mdl__steer_synth_create; both do the same operations in the same order.
 */
#include "steer/posefeat.h"
#include "steer/heading.h"
#include "steer/mfilter.h"
#include "steer/kblend.h"
#include "core/linalg.h"
#include "steer/steer_internal.h"
#include "steer/regress.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* four and eight floats, for the blend's transform (GCC/Clang vector extension): one SSE
 * register, or one AVX register in the variant for AVX2 machines (chosen in mdl__steer_synth_create) */
typedef float mdl__v4f __attribute__((vector_size(16)));
typedef float mdl__v8f __attribute__((vector_size(32)));
typedef double mdl__v4d __attribute__((vector_size(32))); /* xyz and a zero */
#if defined(__x86_64__) && defined(__GNUC__)
#define SYNTH_AVX2 1
#endif

typedef void (*blend_place_fn)(int n8, int k, const float *mean, const float *V, const float *lam,
                               const float *iw, const float W[9], const float tw[3], float *lx,
                               float *ly, float *lz);
static void blend_place4(int n8, int k, const float *mean, const float *V, const float *lam,
                         const float *iw, const float W[9], const float tw[3], float *lx, float *ly,
                         float *lz);
static void alternate_base(mdl_steer_synth *s);
#ifdef SYNTH_AVX2
__attribute__((target("avx2"))) static void blend_place8(int n8, int k, const float *mean,
                                                         const float *V, const float *lam,
                                                         const float *iw, const float W[9],
                                                         const float tw[3], float *lx, float *ly,
                                                         float *lz);
__attribute__((target("avx2"))) static void alternate_avx2(mdl_steer_synth *s);
#endif

struct mdl_steer_synth {
    const struct mdl_steer *m;
    float *P, *Pprev, *Plast;  /* nmarkers x 3: this frame, previous frame, last valid */
    uint8_t *seen;             /* nmarkers: ever valid */
    double *fx, *fv;           /* nmarkers x 3: the input filter's state (mfilter.h) */
    uint8_t *finit;            /* nmarkers */
    int have_prev, have_body;
    double Rb[9], ob[3];
    double *feat, *row, *z, *out; /* scratch: features, design row, design row + 1, outputs */
    double *iq, *iR, *it;      /* per instance: predicted quaternion, rotation, translation */
    double *iRp;               /* per instance: the predicted rotation as a matrix */
    int *shared;               /* vertices held by several instances (the only ones in acc) */
    int nshared;
    double *lam, *lamp;        /* per instance modes (offset inst_lam) */
    int *inst_lam;             /* ninst + 1 */
    int *inst_pos;             /* ninst + 1: offsets of each instance's vertices (sizes bl_j, bl_v) */
    /* the final blend works on structure-of-arrays copies, so that its transform runs 4 vertices
     * at a time: per part, n_p rounded up to 8 (pn) x, then y, then z, zero padded */
    int *pn;                  /* nparts */
    int *smean_off, *smode_off; /* nparts + 1: offsets into smean (3 pn) and smodes (3 pn k_p) */
    float *smean, *smodes;     /* part_mean, part_modes in that layout (modes ld 3 pn) */
    int *iloc_off;             /* ninst + 1: offsets into loc (3 pn of the instance's part) */
    float *loc;                /* weighted placed positions of the instance vertices, SoA */
    int *bl_off, *bl_j, *bl_v; /* per instance (2 NI + 1 offsets): vertices it alone gives the
                                * output, then those it shares: local index, output vertex */
    int *zero, nzero;          /* output vertices not given by one instance alone */
    double *mloc;              /* 3 per marker entry (imk): local shape of the marker vertex */
    blend_place_fn place;      /* blend_place4 or, on AVX2 machines, blend_place8 */
    void (*alternate)(struct mdl_steer_synth *); /* alternate_base or alternate_avx2 */
    float *flam;               /* max modes, float copy of an instance's lambda */
    float *iw;                 /* blend weight (eq. 8) of every instance vertex, padded as loc / 3 */
    double *acc;               /* nv x 4 (xyz, 0): sum of the instances' positions */
    int *cnt;                  /* nv */
    double *rhs;               /* max modes */
    double *mb;                /* nmarkers x 3: markers in the body frame */
    uint8_t *mvalid;           /* nmarkers: valid in this frame (not held) */
    int *imk_off, *imk_local, *imk_marker; /* markers on each instance: local vertex, marker */
    /* the overlap entries (m->sov, per instance sov_off), compact: all the alignment and shape
     * steps read of an instance's vertices besides its markers */
    int *sov_v;                /* global vertex of each entry */
    double *sov_inv;           /* 1 / (number of other instances holding it), 0 if none */
    double *sloc, *spos;       /* 4 per entry (xyz, 0): local shape, placed position (body frame) */
    int *oov_e;                /* m->order_ov as entries of sov */
    double *ymom;              /* per instance: sum y (3) and sum |y|^2 over its entries */
    /* the compact form (mdl_synth_params): the blend's transforms of the last frame and the
     * layout's blend slots (eq. 8 per vertex: entry, instance, weight) */
    float *pW;                 /* ninst x 12: W row-major, then tw (the blend loop's floats) */
    int have_params;
    int nslots;
    int *slot_entry, *slot_inst;
    float *slot_w;
    double *kb;                /* with the kernel blend (m->kb_h > 0): its scratch (kblend.h) */
};

void mdl__steer_synth_destroy(mdl_steer_synth *s)
{
    if (!s)
        return;
    free(s->P);
    free(s->Pprev);
    free(s->Plast);
    free(s->fx);
    free(s->fv);
    free(s->finit);
    free(s->seen);
    free(s->feat);
    free(s->row);
    free(s->z);
    free(s->out);
    free(s->iq);
    free(s->iRp);
    free(s->shared);
    free(s->iR);
    free(s->it);
    free(s->lam);
    free(s->lamp);
    free(s->inst_lam);
    free(s->inst_pos);
    free(s->loc);
    free(s->pn);
    free(s->smean_off);
    free(s->smode_off);
    free(s->smean);
    free(s->smodes);
    free(s->iloc_off);
    free(s->bl_off);
    free(s->bl_j);
    free(s->bl_v);
    free(s->zero);
    free(s->mloc);
    free(s->flam);
    free(s->iw);
    free(s->acc);
    free(s->cnt);
    free(s->rhs);
    free(s->mb);
    free(s->mvalid);
    free(s->imk_off);
    free(s->imk_local);
    free(s->imk_marker);
    free(s->sov_v);
    free(s->sov_inv);
    free(s->sloc);
    free(s->spos);
    free(s->oov_e);
    free(s->ymom);
    free(s->pW);
    free(s->slot_entry);
    free(s->slot_inst);
    free(s->slot_w);
    free(s->kb);
    free(s);
}

void mdl__steer_synth_portable(mdl_steer_synth *s)
{
    s->place = blend_place4;
    s->alternate = alternate_base;
}

static int synth_oom(char *err)
{
    return mdl__err(err, -ENOMEM, "synth: out of memory");
}

/* Step 1: the per-frame buffers, sized for the largest limb, part and instance count: markers
 * (this frame, previous, last valid, ever seen, body frame, valid), the regression's features,
 * design row and outputs (eq. 5), every instance's predicted and current transform, the shape
 * step's right-hand side (eq. 7) and the blend's accumulators. */
static int synth_scratch(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    int nm = m->nmarkers, NI = m->ninst, maxd = 1, maxo = 1, maxk = 1, maxx = 1;
    for (int l = 0; l < m->nlimbs; l++) {
        if (m->reg[l].nin > maxd)
            maxd = m->reg[l].nin;
        if (m->reg[l].nin + m->reg[l].ncent > maxx)
            maxx = m->reg[l].nin + m->reg[l].ncent;
        if (m->reg[l].nout > maxo)
            maxo = m->reg[l].nout;
    }
    for (int p = 0; p < m->nparts; p++)
        if (m->pmodes[p] > maxk)
            maxk = m->pmodes[p];
    s->P = mdl__calloc((size_t)nm * 3, sizeof(float));
    s->Pprev = mdl__calloc((size_t)nm * 3, sizeof(float));
    s->Plast = mdl__calloc((size_t)nm * 3, sizeof(float));
    s->seen = mdl__calloc((size_t)nm, 1);
    s->fx = mdl__calloc((size_t)nm * 3, sizeof(double));
    s->fv = mdl__calloc((size_t)nm * 3, sizeof(double));
    s->finit = mdl__calloc((size_t)nm, 1);
    s->mb = mdl__calloc((size_t)nm * 3, sizeof(double));
    s->mvalid = mdl__calloc((size_t)nm, 1);
    s->feat = mdl__calloc((size_t)maxd, sizeof(double));
    s->row = mdl__calloc((size_t)maxx, sizeof(double));
    s->z = mdl__calloc((size_t)maxx + 1, sizeof(double));
    s->out = mdl__calloc((size_t)maxo, sizeof(double));
    s->iq = mdl__calloc((size_t)NI * 4, sizeof(double));
    s->iRp = mdl__calloc((size_t)NI * 9, sizeof(double));
    s->iR = mdl__calloc((size_t)NI * 9, sizeof(double));
    s->it = mdl__calloc((size_t)NI * 3, sizeof(double));
    s->flam = mdl__calloc((size_t)maxk, sizeof(float));
    s->rhs = mdl__calloc((size_t)maxk, sizeof(double));
    s->acc = mdl__calloc((size_t)m->nv * 4, sizeof(double));
    s->cnt = mdl__calloc((size_t)m->nv, sizeof(int));
    if (m->kb_h > 0 && !(s->kb = mdl__calloc(MDL_KBLEND_SCRATCH(m->ntrain, nm), sizeof(double))))
        return synth_oom(err);
    if (!s->P || !s->Pprev || !s->Plast || !s->seen || !s->fx || !s->fv || !s->finit || !s->mb || !s->mvalid || !s->feat || !s->row ||
        !s->z || !s->out || !s->iq || !s->iRp || !s->iR || !s->it || !s->flam || !s->rhs || !s->acc ||
        !s->cnt)
        return synth_oom(err);
    return 0;
}

/* Step 2: the vertices held by several instances (the overlap vertices of m->sov), the only ones
 * the alignment accumulates (Sec. 5.1). */
static int synth_shared_vertices(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    s->shared = mdl__calloc((size_t)m->nv, sizeof(int));
    uint8_t *seen = mdl__calloc((size_t)m->nv, 1);
    if (!s->shared || !seen) {
        free(seen);
        return synth_oom(err);
    }
    for (int i = 0; i < m->ninst; i++)
        for (int o = m->sov_off[i]; o < m->sov_off[i + 1]; o++) {
            int v = m->pv_idx[m->pv_off[m->inst_part[i]] + m->sov[o]];
            if (!seen[v]) {
                seen[v] = 1;
                s->shared[s->nshared++] = v;
            }
        }
    free(seen);
    return 0;
}

/* Step 3: per instance, the offsets of its mode coefficients lambda (eq. 6; s->lam, the current
 * ones, and s->lamp, the regression's prior lambda+) and of its vertices. */
static int synth_instance_offsets(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    int NI = m->ninst;
    s->inst_lam = mdl__calloc((size_t)NI + 1, sizeof(int));
    s->inst_pos = mdl__calloc((size_t)NI + 1, sizeof(int));
    if (!s->inst_lam || !s->inst_pos)
        return synth_oom(err);
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i];
        s->inst_lam[i + 1] = s->inst_lam[i] + m->pmodes[p];
        s->inst_pos[i + 1] = s->inst_pos[i] + m->pv_off[p + 1] - m->pv_off[p];
    }
    s->lam = mdl__calloc((size_t)s->inst_lam[NI] + 1, sizeof(double));
    s->lamp = mdl__calloc((size_t)s->inst_lam[NI] + 1, sizeof(double));
    if (!s->lam || !s->lamp)
        return synth_oom(err);
    return 0;
}

/* Step 4: the blend's structure-of-arrays copies of the part means and modes (eq. 6): per part
 * n_p rounded up to 8 (s->pn) x, then y, then z, zero padded; the output buffer of every
 * instance in that layout (s->loc) and its vertices' blend weights of eq. (8) (s->iw). */
static int synth_soa_layout(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    int np = m->nparts, NI = m->ninst;
    s->pn = mdl__calloc((size_t)np + 1, sizeof(int));
    s->smean_off = mdl__calloc((size_t)np + 1, sizeof(int));
    s->smode_off = mdl__calloc((size_t)np + 1, sizeof(int));
    s->iloc_off = mdl__calloc((size_t)NI + 1, sizeof(int));
    if (!s->pn || !s->smean_off || !s->smode_off || !s->iloc_off)
        return synth_oom(err);
    for (int p = 0; p < np; p++) {
        s->pn[p] = (m->pv_off[p + 1] - m->pv_off[p] + 7) & ~7;
        s->smean_off[p + 1] = s->smean_off[p] + 3 * s->pn[p];
        s->smode_off[p + 1] = s->smode_off[p] + 3 * s->pn[p] * m->pmodes[p];
    }
    for (int i = 0; i < NI; i++)
        s->iloc_off[i + 1] = s->iloc_off[i] + 3 * s->pn[m->inst_part[i]];
    s->smean = mdl__calloc((size_t)s->smean_off[np] + 1, sizeof(float));
    s->smodes = mdl__calloc((size_t)s->smode_off[np] + 1, sizeof(float));
    s->loc = mdl__calloc((size_t)s->iloc_off[NI] + 1, sizeof(float));
    s->iw = mdl__calloc((size_t)s->iloc_off[NI] / 3 + 1, sizeof(float));
    if (!s->smean || !s->smodes || !s->loc || !s->iw)
        return synth_oom(err);
    for (int p = 0; p < np; p++) {
        int n = m->pv_off[p + 1] - m->pv_off[p], n8 = s->pn[p], k = m->pmodes[p];
        const float *mean = m->part_mean + 3 * (size_t)m->pv_off[p];
        for (int j = 0; j < n; j++)
            for (int c = 0; c < 3; c++)
                s->smean[s->smean_off[p] + c * n8 + j] = mean[3 * j + c];
        for (int a = 0; a < k; a++) {
            const float *va = m->part_modes + m->pm_off[p] + (size_t)a * 3 * n;
            float *sa = s->smodes + s->smode_off[p] + (size_t)a * 3 * n8;
            for (int j = 0; j < n; j++)
                for (int c = 0; c < 3; c++)
                    sa[c * n8 + j] = va[3 * j + c];
        }
    }
    for (int v = 0; v < m->nv; v++)
        for (int b = m->blend_off[v]; b < m->blend_off[v + 1]; b++)
            s->iw[s->iloc_off[m->blend_inst[b]] / 3 + m->blend_local[b]] = m->blend_w[b];
    return 0;
}

/* Step 5: the blend lists (Sec. 5.3): per instance first the vertices it alone gives the output
 * (written), then those it shares (added), as local index and output vertex; and the output
 * vertices not given by one instance alone (cleared before the blend). */
static int synth_blend_lists(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    int NI = m->ninst;
    s->bl_off = mdl__calloc((size_t)2 * NI + 1, sizeof(int));
    s->bl_j = mdl__calloc((size_t)s->inst_pos[NI] + 1, sizeof(int));
    s->bl_v = mdl__calloc((size_t)s->inst_pos[NI] + 1, sizeof(int));
    s->zero = mdl__calloc((size_t)m->nv + 1, sizeof(int));
    uint8_t *alone = mdl__calloc((size_t)m->nv + 1, 1);
    if (!s->bl_off || !s->bl_j || !s->bl_v || !s->zero || !alone) {
        free(alone);
        return synth_oom(err);
    }
    int e = 0;
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i], n = m->pv_off[p + 1] - m->pv_off[p];
        const int *idx = m->pv_idx + m->pv_off[p];
        for (int pass = 0; pass < 2; pass++) {
            s->bl_off[2 * i + pass] = e;
            for (int j = 0; j < n; j++) {
                int v = idx[j], b = m->blend_off[v];
                int only = m->blend_off[v + 1] - b == 1 && m->blend_inst[b] == i && m->blend_local[b] == j;
                if (only != (pass == 0))
                    continue;
                alone[v] |= (uint8_t)only;
                s->bl_j[e] = j;
                s->bl_v[e++] = v;
            }
        }
    }
    s->bl_off[2 * NI] = e;
    for (int v = 0; v < m->nv; v++)
        if (!alone[v])
            s->zero[s->nzero++] = v;
    free(alone);
    return 0;
}

/* Step 6: the markers on every instance (alignment targets when the markers live in the mesh's
 * space, Sec. 5.1 and ours): local vertex and marker index, and room for the marker vertex's
 * local shape. */
static int synth_marker_entries(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    int nm = m->nmarkers, NI = m->ninst;
    s->imk_off = mdl__calloc((size_t)NI + 1, sizeof(int));
    s->imk_local = mdl__calloc((size_t)NI * nm + 1, sizeof(int));
    s->imk_marker = mdl__calloc((size_t)NI * nm + 1, sizeof(int));
    s->mloc = mdl__calloc((size_t)NI * nm * 3 + 1, sizeof(double));
    if (!s->imk_off || !s->imk_local || !s->imk_marker || !s->mloc)
        return synth_oom(err);
    int e = 0;
    for (int i = 0; i < NI; i++) {
        int p = m->inst_part[i];
        for (int mk = 0; mk < nm; mk++)
            for (int j = m->pv_off[p]; j < m->pv_off[p + 1]; j++)
                if (m->pv_idx[j] == m->markers[mk].vertex) {
                    s->imk_local[e] = j - m->pv_off[p];
                    s->imk_marker[e++] = mk;
                    break;
                }
        s->imk_off[i + 1] = e;
    }
    return 0;
}

/* Step 7: the overlap entries of eq. (7) (m->sov, per instance sov_off) in compact arrays: global
 * vertex, 1 / (number of other instances holding it), room for local shape and placed position;
 * and the greedy order's overlap (m->order_ov, Sec. 5.1) as entries of them. */
static int synth_overlap_entries(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    int NI = m->ninst, nsov = m->sov_off[NI];
    s->sov_v = mdl__calloc((size_t)nsov + 1, sizeof(int));
    s->sov_inv = mdl__calloc((size_t)nsov + 1, sizeof(double));
    s->sloc = mdl__calloc((size_t)nsov * 4 + 1, sizeof(double));
    s->spos = mdl__calloc((size_t)nsov * 4 + 1, sizeof(double));
    s->oov_e = mdl__calloc((size_t)m->order_ov_off[NI] + 1, sizeof(int));
    s->ymom = mdl__calloc((size_t)NI * 4, sizeof(double));
    int *ctot = mdl__calloc((size_t)m->nv, sizeof(int));
    if (!s->sov_v || !s->sov_inv || !s->sloc || !s->spos || !s->oov_e || !s->ymom || !ctot) {
        free(ctot);
        return synth_oom(err);
    }
    for (int i = 0; i < NI; i++)
        for (int e = m->sov_off[i]; e < m->sov_off[i + 1]; e++) {
            s->sov_v[e] = m->pv_idx[m->pv_off[m->inst_part[i]] + m->sov[e]];
            ctot[s->sov_v[e]]++;
        }
    for (int e = 0; e < nsov; e++)
        s->sov_inv[e] = ctot[s->sov_v[e]] > 1 ? 1.0 / (ctot[s->sov_v[e]] - 1) : 0;
    free(ctot);
    for (int step = 0; step < NI; step++) { /* order_ov is a subset of sov (train.c) */
        int i = m->order[step];
        for (int o = m->order_ov_off[step]; o < m->order_ov_off[step + 1]; o++) {
            int e = m->sov_off[i];
            while (e < m->sov_off[i + 1] && m->sov[e] != m->order_ov[o])
                e++;
            if (e == m->sov_off[i + 1])
                return mdl__err(err, -EINVAL, "synth: model's greedy overlap vertex %d of instance %d "
                                "is not among its overlap vertices", m->order_ov[o], i);
            s->oov_e[o] = e;
        }
    }
    return 0;
}

/* Step 8: the compact form's blend slots (model.h, mdl_params_layout): the blend entries of eq. (8)
 * of every vertex as (entry of its part's shape, instance, weight), padded to the largest count,
 * and room for the blend's transforms of each frame. */
static int synth_param_slots(mdl_steer_synth *s, char *err)
{
    const struct mdl_steer *m = s->m;
    int S = 1;
    for (int v = 0; v < m->nv; v++)
        if (m->blend_off[v + 1] - m->blend_off[v] > S)
            S = m->blend_off[v + 1] - m->blend_off[v];
    s->nslots = S;
    size_t n = (size_t)m->nv * S;
    s->slot_entry = mdl__calloc(n, sizeof(int));
    s->slot_inst = mdl__calloc(n, sizeof(int));
    s->slot_w = mdl__calloc(n, sizeof(float));
    s->pW = mdl__calloc((size_t)m->ninst * 12 + 1, sizeof(float));
    if (!s->slot_entry || !s->slot_inst || !s->slot_w || !s->pW)
        return synth_oom(err);
    for (int v = 0; v < m->nv; v++) {
        int at = 0;
        for (int b = m->blend_off[v]; b < m->blend_off[v + 1]; b++, at++) {
            int i = m->blend_inst[b];
            s->slot_entry[(size_t)v * S + at] = m->pv_off[m->inst_part[i]] + m->blend_local[b];
            s->slot_inst[(size_t)v * S + at] = i;
            s->slot_w[(size_t)v * S + at] = m->blend_w[b];
        }
        for (; at < S; at++) {
            s->slot_entry[(size_t)v * S + at] = -1;
            s->slot_inst[(size_t)v * S + at] = -1;
        }
    }
    return 0;
}

int mdl__steer_synth_params_layout(const mdl_steer_synth *s, mdl_params_layout *out)
{
    const struct mdl_steer *m = s->m;
    if (m->kb_h > 0) /* the kernel blend (kblend.h) has no parts to send */
        return -ENOTSUP;
    out->ninst = m->ninst;
    out->nparts = m->nparts;
    out->part_off = m->pv_off;
    out->mean = m->part_mean;
    out->nmodes = m->pmodes;
    out->mode_off = m->pm_off;
    out->modes = m->part_modes;
    out->inst_part = m->inst_part;
    out->slots = s->nslots;
    out->slot_entry = s->slot_entry;
    out->slot_inst = s->slot_inst;
    out->slot_w = s->slot_w;
    out->nparams = 7 * m->ninst + s->inst_lam[m->ninst];
    return 0;
}

int mdl__steer_synth_params(const mdl_steer_synth *s, float *out)
{
    const struct mdl_steer *m = s->m;
    if (m->kb_h > 0)
        return -ENOTSUP;
    if (!s->have_params)
        return -EAGAIN;
    for (int i = 0; i < m->ninst; i++) {
        const float *W = s->pW + 12 * (size_t)i;
        double R[9], q[4];
        for (int c = 0; c < 9; c++)
            R[c] = W[c];
        mdl__mat_to_quat(R, q);
        double nq = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        for (int c = 0; c < 4; c++)
            *out++ = (float)(q[c] / nq);
        for (int c = 0; c < 3; c++)
            *out++ = W[9 + c];
        int k = m->pmodes[m->inst_part[i]];
        for (int a = 0; a < k; a++)
            *out++ = (float)s->lam[s->inst_lam[i] + a];
    }
    return 0;
}

int mdl__steer_synth_create(const struct mdl_steer *m, mdl_steer_synth **out, char *err)
{
    *out = NULL;
    mdl_steer_synth *s = mdl__calloc(1, sizeof *s);
    if (!s)
        return synth_oom(err);
    s->m = m;
    s->place = blend_place4;
    s->alternate = alternate_base;
#ifdef SYNTH_AVX2
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx2")) {
        s->place = blend_place8;
        s->alternate = alternate_avx2;
    }
#endif
    int rc;
    if ((rc = synth_scratch(s, err)) || (rc = synth_shared_vertices(s, err)) ||
        (rc = synth_instance_offsets(s, err)) || (rc = synth_soa_layout(s, err)) ||
        (rc = synth_blend_lists(s, err)) || (rc = synth_marker_entries(s, err)) ||
        (rc = synth_overlap_entries(s, err)) || (rc = synth_param_slots(s, err))) {
        mdl__steer_synth_destroy(s);
        return rc;
    }
    *out = s;
    return 0;
}

void mdl__steer_synth_reset(mdl_steer_synth *s)
{
    memset(s->seen, 0, (size_t)s->m->nmarkers);
    memset(s->finit, 0, (size_t)s->m->nmarkers);
    s->have_prev = 0;
    s->have_body = 0;
}

/* One vertex j3 / 3 of a part's local shape, mean + sum_a lam_a V_a (eq. 6), in float. */
static inline __attribute__((always_inline)) void local_vertex(const float *mean, const float *V,
                                                              const float *lam, int k, int n3,
                                                              int j3, float *x, float *y, float *z)
{
    float vx = mean[j3], vy = mean[j3 + 1], vz = mean[j3 + 2];
    for (int a = 0; a < k; a++) {
        const float *va = V + (size_t)a * n3 + j3;
        vx += va[0] * lam[a];
        vy += va[1] * lam[a];
        vz += va[2] * lam[a];
    }
    *x = vx;
    *y = vy;
    *z = vz;
}

/* The same for only the vertices the alignment and shape steps read: the overlap vertices, into
 * the compact sloc (one entry per sov entry), and the marker vertices, into mloc. The full local
 * shape is needed only by the final blend. Also the moments of the overlap vertices' local
 * positions (sum y, sum |y|^2 over the entries with other instances), which the relaxation
 * sweeps reuse until the next shape step. */
static inline __attribute__((always_inline)) void update_local_needed(mdl_steer_synth *s, int i)
{
    const struct mdl_steer *m = s->m;
    int p = m->inst_part[i], k = m->pmodes[p], n3 = 3 * (m->pv_off[p + 1] - m->pv_off[p]);
    const float *mean = m->part_mean + 3 * (size_t)m->pv_off[p];
    const float *V = m->part_modes + m->pm_off[p];
    float *lam = s->flam;
    for (int a = 0; a < k; a++)
        lam[a] = (float)s->lam[s->inst_lam[i] + a];
    double sy0 = 0, sy1 = 0, sy2 = 0, syy = 0;
    for (int e = m->sov_off[i]; e < m->sov_off[i + 1]; e++) {
        int j3 = 3 * m->sov[e];
        float x, y, z;
        local_vertex(mean, V, lam, k, n3, j3, &x, &y, &z);
        double *o = s->sloc + 4 * (size_t)e;
        o[0] = x;
        o[1] = y;
        o[2] = z;
        if (s->sov_inv[e] > 0) {
            sy0 += x;
            sy1 += y;
            sy2 += z;
            syy += (double)x * x + (double)y * y + (double)z * z;
        }
    }
    double *ym = s->ymom + 4 * i;
    ym[0] = sy0;
    ym[1] = sy1;
    ym[2] = sy2;
    ym[3] = syy;
    for (int e = s->imk_off[i]; e < s->imk_off[i + 1]; e++) {
        int j3 = 3 * s->imk_local[e];
        float x, y, z;
        local_vertex(mean, V, lam, k, n3, j3, &x, &y, &z);
        double *o = s->mloc + 3 * (size_t)e;
        o[0] = x;
        o[1] = y;
        o[2] = z;
    }
}

/* Places instance i's overlap vertices R loc + t into spos (all that the alignment and shape
 * steps read of its placement). `add` 1 adds them to acc/cnt (greedy pass), 0 replaces the
 * instance's previous contribution there (acc += new - old). One 4-vector per vertex (xyz, 0). */
static inline __attribute__((always_inline)) void inst_emit(mdl_steer_synth *s, int i, int add)
{
    const struct mdl_steer *m = s->m;
    const double *R = s->iR + 9 * i, *t = s->it + 3 * i;
    const mdl__v4d c0 = {R[0], R[3], R[6], 0}, c1 = {R[1], R[4], R[7], 0}, c2 = {R[2], R[5], R[8], 0},
                   tv = {t[0], t[1], t[2], 0};
    const int *sv = s->sov_v;
    double *restrict acc = s->acc;
    for (int e = m->sov_off[i]; e < m->sov_off[i + 1]; e++) {
        double *o = s->spos + 4 * (size_t)e, *a = acc + 4 * (size_t)sv[e];
        const double *y = s->sloc + 4 * (size_t)e;
        mdl__v4d n = c0 * y[0] + c1 * y[1] + c2 * y[2] + tv, av, ov;
        memcpy(&av, a, sizeof av);
        if (add) {
            av += n;
            s->cnt[sv[e]]++;
        } else {
            memcpy(&ov, o, sizeof ov);
            av += n - ov;
        }
        memcpy(a, &av, sizeof av);
        memcpy(o, &n, sizeof n);
    }
}

/* Weighted absolute orientation of instance i onto targets, with its predicted rotation as a prior
 * (rigid.h), from the moments of its overlap vertices y and their targets x (ws = sum w,
 * sy = sum w y, sx = sum w x, syx = sum w y x^T, syy = sum w |y|^2): the instance's markers (when
 * the model uses them) are added as targets at the markers' positions. Without any target the
 * prediction stays. */
static void align_solve(mdl_steer_synth *s, int i, double ws, double sy[3], double sx[3], double syx[9],
                        double syy)
{
    const struct mdl_steer *m = s->m;
    int nmk = 0;
    for (int e = s->imk_off[i]; e < s->imk_off[i + 1]; e++)
        nmk += s->mvalid[s->imk_marker[e]];
    if (m->marker_weight > 0 && nmk > 0) {
        double w = m->marker_weight * (ws > 10 ? ws : 10) / nmk;
        for (int e = s->imk_off[i]; e < s->imk_off[i + 1]; e++) {
            int mk = s->imk_marker[e];
            if (!s->mvalid[mk])
                continue;
            const double *y = s->mloc + 3 * (size_t)e;
            const double *x = s->mb + 3 * mk;
            ws += w;
            for (int r = 0; r < 3; r++) {
                sy[r] += w * y[r];
                sx[r] += w * x[r];
                syy += w * y[r] * y[r];
                for (int c = 0; c < 3; c++)
                    syx[3 * r + c] += w * y[r] * x[c];
            }
        }
    }
    const double *Rp = s->iRp + 9 * i;
    double *R = s->iR + 9 * i, *t = s->it + 3 * i;
    if (!(ws > 0)) {
        memcpy(R, Rp, 9 * sizeof *Rp);
        return;
    }
    double cy[3] = {sy[0] / ws, sy[1] / ws, sy[2] / ws}, cx[3] = {sx[0] / ws, sx[1] / ws, sx[2] / ws};
    double S[9], spread = syy - ws * (cy[0] * cy[0] + cy[1] * cy[1] + cy[2] * cy[2]);
    /* prior: + mu * Rp^T; with (nearly) collinear targets it decides the free rotation */
    double mu = m->prior_weight * (spread > 0 ? spread : 0) + 1e-12;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            S[3 * r + c] = syx[3 * r + c] - ws * cy[r] * cx[c] + mu * Rp[3 * c + r];
    mdl__rot_polar(S, R);
    for (int r = 0; r < 3; r++)
        t[r] = cx[r] - (R[3 * r] * cy[0] + R[3 * r + 1] * cy[1] + R[3 * r + 2] * cy[2]);
}

/* Greedy step: the overlap entries `ov` (n of them, indices into sov) of instance i go to the
 * mean position of the instances placed before it. */
static inline __attribute__((always_inline)) void align_greedy(mdl_steer_synth *s, int i, const int *ov, int n)
{
    double ws = 0, sy[3] = {0}, sx[3] = {0}, syx[9] = {0}, syy = 0;
    for (int o = 0; o < n; o++) {
        int e = ov[o], v = s->sov_v[e], c = s->cnt[v];
        if (c < 1)
            continue;
        const double *y = s->sloc + 4 * (size_t)e;
        const double *a = s->acc + 4 * (size_t)v;
        double inv = 1.0 / c, x[3] = {a[0] * inv, a[1] * inv, a[2] * inv};
        ws += 1;
        for (int r = 0; r < 3; r++) {
            sy[r] += y[r];
            sx[r] += x[r];
            syy += y[r] * y[r];
            syx[3 * r] += y[r] * x[0];
            syx[3 * r + 1] += y[r] * x[1];
            syx[3 * r + 2] += y[r] * x[2];
        }
    }
    align_solve(s, i, ws, sy, sx, syx, syy);
}

/* Relaxation step: every overlap vertex of instance i goes to the mean position all other
 * instances give it, (acc - own) / (cnt - 1) with the counts fixed after the greedy pass
 * (sov_inv); sum y and sum |y|^2 come from update_local_needed. Row r of sum y x^T is the
 * 4-vector sum y_r x. */
static inline __attribute__((always_inline)) void align_relax(mdl_steer_synth *s, int i)
{
    const struct mdl_steer *m = s->m;
    const double *restrict acc = s->acc, *restrict inv = s->sov_inv;
    const double *restrict sloc = s->sloc, *restrict spos = s->spos;
    const int *restrict sv = s->sov_v;
    mdl__v4d sxv = {0, 0, 0, 0}, r0 = sxv, r1 = sxv, r2 = sxv;
    int cnt = 0;
    for (int e = m->sov_off[i]; e < m->sov_off[i + 1]; e++) {
        double w = inv[e];
        if (!(w > 0))
            continue;
        const double *y = sloc + 4 * (size_t)e;
        mdl__v4d a, own;
        memcpy(&a, acc + 4 * (size_t)sv[e], sizeof a);
        memcpy(&own, spos + 4 * (size_t)e, sizeof own);
        mdl__v4d x = (a - own) * w;
        cnt++;
        sxv += x;
        r0 += y[0] * x;
        r1 += y[1] * x;
        r2 += y[2] * x;
    }
    const double *ym = s->ymom + 4 * i;
    double sy[3] = {ym[0], ym[1], ym[2]}, sx[3] = {sxv[0], sxv[1], sxv[2]};
    double syx[9] = {r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2]};
    align_solve(s, i, (double)cnt, sy, sx, syx, ym[3]);
}

/* Sec. 5.1: greedy rigid alignment in the precomputed order, then `relax` sweeps in which every
 * instance is aligned again to all its neighbours (a block coordinate descent on the same
 * objective, which carries marker targets along the limb chains). The alignments between shape
 * steps get one sweep; the last one gets the model's full count. */
static inline __attribute__((always_inline)) void relax_all(mdl_steer_synth *s, int relax)
{
    const struct mdl_steer *m = s->m;
    for (int sweep = 0; sweep < relax; sweep++)
        for (int step = 0; step < m->ninst; step++) {
            int i = m->order[step];
            align_relax(s, i);
            inst_emit(s, i, 0);
        }
}

static inline __attribute__((always_inline)) void emit_all(mdl_steer_synth *s)
{
    for (int i = 0; i < s->m->ninst; i++)
        inst_emit(s, i, 0);
}

static inline __attribute__((always_inline)) void align_all(mdl_steer_synth *s, int relax)
{
    const struct mdl_steer *m = s->m;
    for (int e = 0; e < s->nshared; e++) { /* only shared vertices are ever accumulated */
        int v = s->shared[e];
        memset(s->acc + 4 * (size_t)v, 0, 4 * sizeof(double));
        s->cnt[v] = 0;
    }
    for (int step = 0; step < m->ninst; step++) {
        int i = m->order[step];
        align_greedy(s, i, s->oov_e + m->order_ov_off[step],
                     m->order_ov_off[step + 1] - m->order_ov_off[step]);
        inst_emit(s, i, 1);
    }
    relax_all(s, relax);
}

/* Sec. 5.2, eq. (7), for every instance with modes. */
static inline __attribute__((always_inline)) void optimise_shapes(mdl_steer_synth *s)
{
    const struct mdl_steer *m = s->m;
    for (int i = 0; i < m->ninst; i++) {
        int p = m->inst_part[i], k = m->pmodes[p], n = m->pv_off[p + 1] - m->pv_off[p];
        if (k == 0)
            continue;
        const double *R = s->iR + 9 * i, *t = s->it + 3 * i;
        const double *sig2 = m->part_sigma2 + m->ps_off[p];
        const double *lamp = s->lamp + s->inst_lam[i];
        for (int a = 0; a < k; a++)
            s->rhs[a] = m->beta * lamp[a] / sig2[a];
        for (int e = m->sov_off[i]; e < m->sov_off[i + 1]; e++) {
            int j = m->sov[e];
            double w = s->sov_inv[e];
            if (!(w > 0))
                continue;
            const double *acc = s->acc + 4 * (size_t)s->sov_v[e];
            const double *own = s->spos + 4 * (size_t)e;
            double d[3], loc[3];
            for (int r = 0; r < 3; r++) /* mean of the other instances' positions */
                d[r] = (acc[r] - own[r]) * w - t[r];
            for (int c = 0; c < 3; c++)
                loc[c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
            const float *mean = m->part_mean + 3 * ((size_t)m->pv_off[p] + j);
            const float *V = m->part_modes + m->pm_off[p] + 3 * (size_t)j;
            for (int a = 0; a < k; a++) {
                const float *va = V + (size_t)a * 3 * n;
                s->rhs[a] += va[0] * (loc[0] - mean[0]) + va[1] * (loc[1] - mean[1]) +
                             va[2] * (loc[2] - mean[2]);
            }
        }
        if (mdl_la_potrs1(k, m->chol + m->chol_off[i], k, s->rhs) == 0)
            memcpy(s->lam + s->inst_lam[i], s->rhs, sizeof(double) * (size_t)k);
    }
    for (int i = 0; i < m->ninst; i++)
        update_local_needed(s, i);
}

/* Step 3 of the header: alternate alignment and shape optimisation. Compiled for plain x86-64
 * and, on AVX2 machines, with one register per 4-vector (chosen in mdl__steer_synth_create; the same
 * operations in the same order, so the same result). */
static inline __attribute__((always_inline)) void alternate_body(mdl_steer_synth *s)
{
    const struct mdl_steer *m = s->m;
    for (int i = 0; i < m->ninst; i++)
        update_local_needed(s, i);
    align_all(s, m->iterations > 0 ? 1 : m->relax);
    for (int it = 0; it < m->iterations; it++) {
        optimise_shapes(s);
        /* the new shapes replace the old in the accumulated positions; the transforms found so
         * far are a good start, so sweeps suffice instead of another greedy pass */
        emit_all(s);
        relax_all(s, it + 1 < m->iterations ? 1 : m->relax);
    }
}

static void alternate_base(mdl_steer_synth *s)
{
    alternate_body(s);
}

#ifdef SYNTH_AVX2
__attribute__((target("avx2"))) static void alternate_avx2(mdl_steer_synth *s)
{
    alternate_body(s);
}
#endif

/* The full local shape y = mean + V lambda (eq. 6) of an instance's n8 (padded) vertices, needed
 * only by the blend, then w (W y + t) into lx, ly, lz, from the structure-of-arrays copies
 * (mean: x, y, z blocks of n8; V: k such triples), VT being vectors of WIDTH floats: four
 * vertices at a time, or eight on AVX2 - one body for both, the same operations in the same
 * order, so the same result. */
#define BLEND_PLACE(NAME, ATTR, VT, WIDTH)                                                         \
    ATTR static void NAME(int n8, int k, const float *mean, const float *V, const float *lam,     \
                          const float *iw, const float W[9], const float tw[3], float *lx,         \
                          float *ly, float *lz)                                                    \
    {                                                                                              \
        for (int q = 0; q < n8; q += WIDTH) {                                                      \
            VT x, y, z, w;                                                                         \
            memcpy(&x, mean + q, sizeof x);                                                        \
            memcpy(&y, mean + n8 + q, sizeof y);                                                   \
            memcpy(&z, mean + 2 * n8 + q, sizeof z);                                               \
            for (int a = 0; a < k; a++) {                                                          \
                const float *va = V + (size_t)a * 3 * n8 + q;                                      \
                VT vx, vy, vz;                                                                     \
                memcpy(&vx, va, sizeof vx);                                                        \
                memcpy(&vy, va + n8, sizeof vy);                                                   \
                memcpy(&vz, va + 2 * n8, sizeof vz);                                               \
                x += lam[a] * vx;                                                                  \
                y += lam[a] * vy;                                                                  \
                z += lam[a] * vz;                                                                  \
            }                                                                                      \
            memcpy(&w, iw + q, sizeof w);                                                          \
            VT ox = w * (W[0] * x + W[1] * y + W[2] * z + tw[0]);                                  \
            VT oy = w * (W[3] * x + W[4] * y + W[5] * z + tw[1]);                                  \
            VT oz = w * (W[6] * x + W[7] * y + W[8] * z + tw[2]);                                  \
            memcpy(lx + q, &ox, sizeof ox);                                                        \
            memcpy(ly + q, &oy, sizeof oy);                                                        \
            memcpy(lz + q, &oz, sizeof oz);                                                        \
        }                                                                                          \
    }

BLEND_PLACE(blend_place4, , mdl__v4f, 4)
#ifdef SYNTH_AVX2
BLEND_PLACE(blend_place8, __attribute__((target("avx2"))), mdl__v8f, 8)
#endif

int mdl__steer_synth_frame(mdl_steer_synth *s, const float *markers, const uint8_t *valid,
                           float *Vout, mdl_synth_info *info)
{
    const struct mdl_steer *m = s->m;
    int nm = m->nmarkers, missing = 0, held = 0;
    mdl_synth_info dummy;
    if (!info)
        info = &dummy;
    memset(info, 0, sizeof *info);
    for (int j = 0; j < nm; j++) {
        const float *p = markers + 3 * j;
        int ok = (!valid || valid[j]) && isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
        s->mvalid[j] = (uint8_t)ok;
        if (ok) {
            if (m->mfilt) { /* the input filter (mfilter.h) */
                mdl__mfilter_step(m->mfilt + 2 * j, 1, p, NULL, s->fx + 3 * j, s->fv + 3 * j,
                                  s->finit + j);
                for (int c = 0; c < 3; c++)
                    s->Plast[3 * j + c] = (float)s->fx[3 * j + c];
            } else {
                memcpy(s->Plast + 3 * j, p, 3 * sizeof(float));
            }
            s->seen[j] = 1;
        } else {
            missing++;
            held += s->seen[j];
        }
        memcpy(s->P + 3 * j, s->Plast + 3 * j, 3 * sizeof(float));
    }
    info->markers_missing = missing;
    info->markers_held = held;
    if (m->kb_h > 0) { /* the kernel blend instead of the part model (kblend.h); held markers
                          count as present */
        int rc = mdl__kblend_frame(m->kb_V, m->kb_mk, m->ntrain, m->nv, nm, m->kb_h, s->P, s->seen,
                                   s->kb, Vout);
        if (rc)
            info->reference_lost = 1;
        return rc;
    }
    int refok = 1;
    for (int r = 0; r < m->nref; r++)
        refok &= s->seen[m->ref[r]];
    double R[9], o[3];
    if (refok && mdl__body_frame_any(s->P, s->mvalid, nm, m->nref, m->ref,
                                     m->place_mode ? m->axis_rec : m->axis_mesh,
                                     m->place_mode ? m->hd_rec : m->hd_mesh, R, o) == 0) {
        memcpy(s->Rb, R, sizeof R);
        memcpy(s->ob, o, sizeof o);
        s->have_body = 1;
    } else {
        info->reference_lost = 1;
        if (!s->have_body)
            return -EAGAIN;
    }
    for (int j = 0; j < nm; j++) { /* markers in the body frame: alignment targets */
        const float *p = s->P + 3 * j;
        double d[3] = {p[0] - s->ob[0], p[1] - s->ob[1], p[2] - s->ob[2]};
        for (int c = 0; c < 3; c++)
            s->mb[3 * j + c] = s->Rb[c] * d[0] + s->Rb[3 + c] * d[1] + s->Rb[6 + c] * d[2];
    }
    /* 1-2. parameters and predictions per limb */
    for (int l = 0; l < m->nlimbs; l++) {
        const mdl_limb_reg *rg = &m->reg[l];
        const int *path = m->limb_idx + m->limb_off[l];
        int plen = m->limb_off[l + 1] - m->limb_off[l], all = 1;
        for (int j = 0; j < plen; j++)
            all &= s->seen[path[j]];
        if (all) {
            mdl__limb_features(s->P, s->have_prev ? s->Pprev : NULL, path, plen, s->Rb, s->ob,
                               m->use_motion_dir, s->feat);
            for (int j = 0; j < rg->nin; j++)
                s->feat[j] = rg->feat_scale[j] * s->feat[j] + rg->feat_shift[j];
        } else {
            for (int j = 0; j < rg->nin; j++)
                s->feat[j] = rg->zmean[j];
        }
        mdl__design_row(s->feat, rg->nin, rg->zmean, rg->zsd, rg->cent, rg->ncent, rg->width, s->row);
        mdl__ridge_predict(rg->coef, rg->nin + rg->ncent, rg->nout, rg->in_mean, rg->in_sd, s->row,
                           s->z, s->out);
        for (int i = 0; i < m->ninst; i++) {
            if (m->inst_limb[i] != l)
                continue;
            const double *y = s->out + m->inst_out[i];
            double *q = s->iq + 4 * i, nq = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3]);
            for (int c = 0; c < 4; c++)
                q[c] = nq > 1e-9 ? y[c] / nq : (c == 0);
            mdl__quat_to_mat(q, s->iRp + 9 * i);
            for (int c = 0; c < 3; c++)
                s->it[3 * i + c] = y[4 + c];
            int p = m->inst_part[i], k = m->pmodes[p];
            const double *sig2 = m->part_sigma2 + m->ps_off[p];
            for (int a = 0; a < k; a++) {
                double lim = 3 * sqrt(sig2[a]), v = y[7 + a];
                v = v > lim ? lim : v < -lim ? -lim : v;
                s->lamp[s->inst_lam[i] + a] = v;
                s->lam[s->inst_lam[i] + a] = v;
            }
        }
    }
    memcpy(s->Pprev, s->P, sizeof(float) * 3 * (size_t)nm);
    s->have_prev = 1;
    /* 3. alternate alignment and shape optimisation */
    s->alternate(s);
    /* 4-5. blend (eq. 8) and place in the markers' frame: every instance's transform is composed
     * with the placement, then its vertices are added into the output with their blend weights
     * (instance-major, so that the inner loop reads contiguous memory) */
    double PR[9], Po[3];
    if (m->place_mode == 1) { /* ground-locked: the mesh's own frame, turned and moved like the performer */
        double th = mdl__body_heading(s->Rb) - m->rec_heading, c = cos(th), sn = sin(th);
        double Y[9] = {c, 0, sn, 0, 1, 0, -sn, 0, c};
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 3; k++)
                PR[3 * r + k] = Y[3 * r] * m->place_R[k] + Y[3 * r + 1] * m->place_R[3 + k] +
                                Y[3 * r + 2] * m->place_R[6 + k];
        double d[3] = {s->ob[0] - m->rec_origin[0], 0, s->ob[2] - m->rec_origin[2]};
        for (int r = 0; r < 3; r++)
            Po[r] = Y[3 * r] * m->place_o[0] + Y[3 * r + 1] * m->place_o[1] + Y[3 * r + 2] * m->place_o[2] + d[r];
    } else {
        memcpy(PR, s->Rb, sizeof PR);
        memcpy(Po, s->ob, sizeof Po);
    }
    for (int e = 0; e < s->nzero; e++) {
        float *o = Vout + 3 * (size_t)s->zero[e];
        o[0] = o[1] = o[2] = 0;
    }
    for (int i = 0; i < m->ninst; i++) {
        const double *R = s->iR + 9 * i, *t = s->it + 3 * i;
        float W[9], tw[3];
        for (int r = 0; r < 3; r++) {
            for (int k = 0; k < 3; k++)
                W[3 * r + k] = (float)(PR[3 * r] * R[k] + PR[3 * r + 1] * R[3 + k] + PR[3 * r + 2] * R[6 + k]);
            tw[r] = (float)(PR[3 * r] * t[0] + PR[3 * r + 1] * t[1] + PR[3 * r + 2] * t[2] + Po[r]);
        }
        int p = m->inst_part[i], n8 = s->pn[p], k = m->pmodes[p];
        float *lx = s->loc + s->iloc_off[i], *ly = lx + n8, *lz = ly + n8, *lam = s->flam;
        const float *iw = s->iw + s->iloc_off[i] / 3, *mean = s->smean + s->smean_off[p];
        const float *V = s->smodes + s->smode_off[p];
        for (int a = 0; a < k; a++)
            lam[a] = (float)s->lam[s->inst_lam[i] + a];
        s->place(n8, k, mean, V, lam, iw, W, tw, lx, ly, lz);
        memcpy(s->pW + 12 * (size_t)i, W, sizeof W);
        memcpy(s->pW + 12 * (size_t)i + 9, tw, sizeof tw);
        const int *bj = s->bl_j, *bv = s->bl_v;
        for (int e = s->bl_off[2 * i]; e < s->bl_off[2 * i + 1]; e++) { /* its own vertices */
            int j = bj[e];
            float *o = Vout + 3 * (size_t)bv[e];
            o[0] = lx[j];
            o[1] = ly[j];
            o[2] = lz[j];
        }
        for (int e = s->bl_off[2 * i + 1]; e < s->bl_off[2 * i + 2]; e++) { /* shared ones */
            int j = bj[e];
            float *o = Vout + 3 * (size_t)bv[e];
            o[0] += lx[j];
            o[1] += ly[j];
            o[2] += lz[j];
        }
    }
    s->have_params = 1;
    return 0;
}
