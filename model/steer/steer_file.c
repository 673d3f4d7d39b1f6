/* steer_file.c - the steering model's chunk of the model file ("STER", docs/FORMATS.md), its
 * summary (`meshsteer inspect`) and training report, and freeing it.
 *
 * The chunk holds the fields of struct mdl_steer (steer_internal.h) in a fixed order; every array
 * is preceded by its u32 element count. The mesh and the rig are the model file's MESH and RIG
 * chunks, copied into the steering model on load. Loading recomputes every count from dimensions
 * read before it and refuses any mismatch, checks every index against what it indexes, every offset
 * table for monotonicity and every float for finiteness: a corrupt or hostile file gives a clear
 * error, never an out-of-bounds access (tests/fuzz/fuzz_model.c).
 * A version-1 file is this chunk with the mesh and the rig inline (v1 = 1 below): it is read the same
 * way and converted to a model on load (formats/modelfile.c).
 */
#include "steer/posefeat.h"
#include "steer/steer_internal.h"
#include "steer/heading.h"
#include "steer/select.h"
#include "formats/chunkio.h"
#include "kind.h"
#include "core/util.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_COUNT MDL_CHUNK_MAX_COUNT

void mdl__steer_free(struct mdl_steer *m)
{
    if (!m)
        return;
    free(m->rest);
    free(m->F);
    free(m->train_frames);
    free(m->markers);
    free(m->limb_off);
    free(m->limb_idx);
    free(m->part);
    free(m->part_rms);
    free(m->pv_off);
    free(m->pv_idx);
    free(m->pmodes);
    free(m->pm_off);
    free(m->part_mean);
    free(m->part_modes);
    free(m->part_sigma2);
    free(m->ps_off);
    free(m->part_explained);
    free(m->inst_part);
    free(m->inst_limb);
    free(m->inst_out);
    free(m->inst_shared);
    free(m->lpath_off);
    free(m->lpath);
    free(m->lctrl);
    if (m->reg)
        for (int l = 0; l < m->nlimbs; l++) {
            free(m->reg[l].feat_scale);
            free(m->reg[l].feat_shift);
            free(m->reg[l].zmean);
            free(m->reg[l].zsd);
            free(m->reg[l].cent);
            free(m->reg[l].in_mean);
            free(m->reg[l].in_sd);
            free(m->reg[l].coef);
        }
    free(m->reg);
    free(m->sel);
    free(m->mfilt);
    free(m->kb_V);
    free(m->kb_mk);
    free(m->hd_mesh);
    free(m->hd_rec);
    free(m->order);
    free(m->order_ov_off);
    free(m->order_ov);
    free(m->sov_off);
    free(m->sov);
    free(m->chol_off);
    free(m->chol);
    free(m->blend_off);
    free(m->blend_inst);
    free(m->blend_local);
    free(m->blend_w);
    free(m);
}

/* ------------------------------------------------------------------ writing */

void mdl__steer_save(const struct mdl_steer *m, mdl__wbuf *b)
{
    /* synthesis options and placement */
    mdl__put_u32(b, (uint32_t)m->virtual_markers);
    mdl__put_f64(b, m->train_seconds);
    mdl__put_f64(b, m->beta);
    mdl__put_u32(b, (uint32_t)m->iterations);
    mdl__put_u32(b, (uint32_t)m->use_motion_dir);
    mdl__put_f64(b, m->prior_weight);
    mdl__put_f64(b, m->marker_weight);
    mdl__put_u32(b, (uint32_t)m->relax);
    mdl__put_u32(b, (uint32_t)m->place_mode);
    mdl__put_u32(b, (uint32_t)m->axis_mesh);
    mdl__put_u32(b, (uint32_t)m->axis_rec);
    mdl__put_f64s(b, m->place_R, 9);
    mdl__put_f64s(b, m->place_o, 3);
    mdl__put_f64(b, m->rec_heading);
    mdl__put_f64s(b, m->rec_origin, 3);
    if (m->axis_mesh == MDL_AXIS_FIT)
        mdl__put_f64s(b, m->hd_mesh, 4 * (size_t)m->nmarkers);
    if (m->axis_rec == MDL_AXIS_FIT)
        mdl__put_f64s(b, m->hd_rec, 4 * (size_t)m->nmarkers);
    mdl__put_i32s(b, m->train_frames, (size_t)m->ntrain);
    /* parts */
    int P = m->nparts, NI = m->ninst, L = m->nlimbs;
    mdl__put_u32(b, (uint32_t)P);
    mdl__put_i32s(b, m->part, (size_t)m->nv);
    mdl__put_f64s(b, m->part_rms, (size_t)P);
    mdl__put_i32s(b, m->pv_off, (size_t)P + 1);
    mdl__put_i32s(b, m->pv_idx, (size_t)m->pv_off[P]);
    mdl__put_i32s(b, m->pmodes, (size_t)P);
    mdl__put_i32s(b, m->pm_off, (size_t)P + 1);
    mdl__put_i32s(b, m->ps_off, (size_t)P + 1);
    mdl__put_f32s(b, m->part_mean, 3 * (size_t)m->pv_off[P]);
    mdl__put_f32s(b, m->part_modes, (size_t)m->pm_off[P]);
    mdl__put_f64s(b, m->part_sigma2, (size_t)m->ps_off[P]);
    mdl__put_f64s(b, m->part_explained, (size_t)P);
    /* instances and limbs */
    mdl__put_u32(b, (uint32_t)NI);
    mdl__put_i32s(b, m->inst_part, (size_t)NI);
    mdl__put_i32s(b, m->inst_limb, (size_t)NI);
    mdl__put_i32s(b, m->inst_out, (size_t)NI);
    mdl__put_i32s(b, m->inst_shared, (size_t)NI);
    mdl__put_i32s(b, m->lpath_off, (size_t)L + 1);
    mdl__put_i32s(b, m->lpath, (size_t)m->lpath_off[L]);
    mdl__put_f64s(b, m->lctrl, 3 * ((size_t)m->lpath_off[L] + L));
    for (int l = 0; l < L; l++) {
        const mdl_limb_reg *r = &m->reg[l];
        mdl__put_u32(b, (uint32_t)r->nin);
        mdl__put_u32(b, (uint32_t)r->nout);
        mdl__put_f64s(b, r->feat_scale, (size_t)r->nin);
        mdl__put_f64s(b, r->feat_shift, (size_t)r->nin);
        mdl__put_f64s(b, r->zmean, (size_t)r->nin);
        mdl__put_f64s(b, r->zsd, (size_t)r->nin);
        mdl__put_u32(b, (uint32_t)r->ncent);
        mdl__put_f64s(b, r->cent, (size_t)r->ncent * r->nin);
        mdl__put_f64(b, r->width);
        mdl__put_f64s(b, r->in_mean, (size_t)(r->nin + r->ncent));
        mdl__put_f64s(b, r->in_sd, (size_t)(r->nin + r->ncent));
        mdl__put_f64s(b, r->coef, (size_t)(r->nin + r->ncent + 1) * r->nout);
        mdl__put_f64(b, r->ridge);
        mdl__put_f64(b, r->rms_train);
        mdl__put_f64(b, r->rms_loo);
    }
    /* synthesis precomputations */
    mdl__put_i32s(b, m->order, (size_t)NI);
    mdl__put_i32s(b, m->order_ov_off, (size_t)NI + 1);
    mdl__put_i32s(b, m->order_ov, (size_t)m->order_ov_off[NI]);
    mdl__put_i32s(b, m->sov_off, (size_t)NI + 1);
    mdl__put_i32s(b, m->sov, (size_t)m->sov_off[NI]);
    mdl__put_i32s(b, m->chol_off, (size_t)NI + 1);
    mdl__put_f64s(b, m->chol, (size_t)m->chol_off[NI]);
    mdl__put_i32s(b, m->blend_off, (size_t)m->nv + 1);
    mdl__put_i32s(b, m->blend_inst, (size_t)m->blend_off[m->nv]);
    mdl__put_i32s(b, m->blend_local, (size_t)m->blend_off[m->nv]);
    mdl__put_f32s(b, m->blend_w, (size_t)m->blend_off[m->nv]);
    /* the trailer (only with the input filter, mfilter.h, or the kernel blend, kblend.h):
     * version 1: u32 1, f64 filter noise, nmarkers x (alpha, beta) f64;
     * version 2: u32 2, f64 filter noise (0: no filter), the gains if > 0, f64 kernel bandwidth
     * factor (> 0), ntrain x nv x 3 f32 training meshes, ntrain x nmarkers x 3 f32 rig vertices */
    if (m->mfilt || m->kb_h > 0) {
        mdl__put_u32(b, m->kb_h > 0 ? 2 : 1);
        mdl__put_f64(b, m->mfilt ? m->filter_noise : 0);
        if (m->mfilt)
            mdl__put_f64s(b, m->mfilt, 2 * (size_t)m->nmarkers);
        if (m->kb_h > 0) {
            mdl__put_f64(b, m->kb_h);
            mdl__put_f32s(b, m->kb_V, (size_t)m->ntrain * m->nv * 3);
            mdl__put_f32s(b, m->kb_mk, (size_t)m->ntrain * m->nmarkers * 3);
        }
    }
}

/* the trailer: the input filter's gains (mfilter.h), when the chunk has bytes left */
static int parse_trailer(mdl__rbuf *b, struct mdl_steer *m)
{
    if (b->rc || b->n - b->at < 4) /* none (fewer bytes are reported as not read) */
        return b->rc;
    int ver = mdl__get_int(b, "trailer version", 1, 2);
    if (b->rc)
        return b->rc;
    m->filter_noise = mdl__get_f64(b, "filter noise");
    if (!b->rc && !(m->filter_noise > 0 && m->filter_noise < 1) && !(ver == 2 && m->filter_noise == 0))
        return mdl__rfail(b, "the input filter's noise is not within (0, 1) m");
    if (m->filter_noise > 0) {
        m->mfilt = mdl__get_f64s(b, 2 * (size_t)m->nmarkers, "input filter gains");
        for (int j = 0; j < m->nmarkers && !b->rc; j++)
            if (!(m->mfilt[2 * j] > 0 && m->mfilt[2 * j] <= 1 && m->mfilt[2 * j + 1] >= 0 &&
                  m->mfilt[2 * j + 1] < 2))
                mdl__rfail(b, "an input filter gain is outside alpha (0, 1], beta [0, 2)");
    }
    if (ver == 2 && !b->rc) {
        m->kb_h = mdl__get_f64(b, "kernel blend bandwidth");
        if (!b->rc && !(m->kb_h > 0 && m->kb_h < 1e3))
            return mdl__rfail(b, "the kernel blend's bandwidth factor is not within (0, 1000)");
        /* mdl__get_f32s refuses non-finite values */
        m->kb_V = mdl__get_f32s(b, (size_t)m->ntrain * m->nv * 3, "kernel blend meshes");
        m->kb_mk = mdl__get_f32s(b, (size_t)m->ntrain * m->nmarkers * 3, "kernel blend markers");
    }
    return b->rc;
}

/* ------------------------------------------------------------------ reading */

static int copy_mesh(struct mdl_steer *s, const mdl_model *m)
{
    memcpy(s->name, m->name, sizeof s->name);
    s->nv = m->nv;
    s->nf = m->nf;
    s->topology = m->topology;
    s->fps = m->fps;
    memcpy(s->bbox_min, m->bbox_min, sizeof s->bbox_min);
    memcpy(s->bbox_max, m->bbox_max, sizeof s->bbox_max);
    s->rest = mdl__calloc(3 * (size_t)m->nv, sizeof *s->rest);
    s->F = mdl__calloc(3 * (size_t)m->nf, sizeof *s->F);
    if (!s->rest || !s->F)
        return -ENOMEM;
    memcpy(s->rest, m->rest, 3 * (size_t)m->nv * sizeof *s->rest);
    memcpy(s->F, m->F, 3 * (size_t)m->nf * sizeof *s->F);
    return 0;
}

static int copy_rig(struct mdl_steer *s, const mdl_rig *r)
{
    s->nmarkers = r->nmarkers;
    s->nref = r->nref;
    memcpy(s->ref, r->ref, sizeof s->ref);
    s->nlimbs = r->nlimbs;
    s->markers = mdl__calloc((size_t)r->nmarkers, sizeof *s->markers);
    s->limb_off = mdl__calloc((size_t)r->nlimbs + 1, sizeof *s->limb_off);
    s->limb_idx = mdl__calloc((size_t)r->limb_off[r->nlimbs] + 1, sizeof *s->limb_idx);
    if (!s->markers || !s->limb_off || !s->limb_idx)
        return -ENOMEM;
    memcpy(s->markers, r->markers, (size_t)r->nmarkers * sizeof *s->markers);
    memcpy(s->limb_off, r->limb_off, ((size_t)r->nlimbs + 1) * sizeof *s->limb_off);
    memcpy(s->limb_idx, r->limb_idx, (size_t)r->limb_off[r->nlimbs] * sizeof *s->limb_idx);
    return 0;
}

/* The return value of a parse step that failed: its error code. */
static int fail_rc(mdl__rbuf *b)
{
    return b->rc ? b->rc : (b->rc = MDL_EFORMAT);
}

static int oom(mdl__rbuf *b)
{
    if (!b->rc)
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
    return b->rc;
}

/* version 1 only: the mesh header (name, counts, fingerprint, fps, box) comes first */
static int parse_header_v1(mdl__rbuf *b, struct mdl_steer *m)
{
    mdl__get_name(b, m->name);
    m->nv = mdl__get_int(b, "vertex count", 1, 1 << 24);
    m->nf = mdl__get_int(b, "triangle count", 1, 1 << 25);
    m->topology = mdl__get_u64(b);
    m->fps = mdl__get_f64(b, "fps");
    float *bb = mdl__get_f32s(b, 3, "bbox_min");
    if (bb) {
        memcpy(m->bbox_min, bb, sizeof m->bbox_min);
        free(bb);
    }
    bb = mdl__get_f32s(b, 3, "bbox_max");
    if (bb) {
        memcpy(m->bbox_max, bb, sizeof m->bbox_max);
        free(bb);
    }
    return b->rc;
}

/* the synthesis options, the placement of the result and the heading fit (heading.h) */
static int parse_options(mdl__rbuf *b, struct mdl_steer *m, const mdl_model *mm, int v1)
{
    m->virtual_markers = mdl__get_int(b, "virtual_markers", 0, 1);
    m->train_seconds = mdl__get_f64(b, "train_seconds");
    m->beta = mdl__get_f64(b, "beta");
    m->iterations = mdl__get_int(b, "iterations", 0, 100);
    m->use_motion_dir = mdl__get_int(b, "use_motion_dir", 0, 1);
    m->prior_weight = mdl__get_f64(b, "prior_weight");
    m->marker_weight = mdl__get_f64(b, "marker_weight");
    m->relax = mdl__get_int(b, "relax", 0, 100);
    m->place_mode = mdl__get_int(b, "placement", 0, 1);
    m->axis_mesh = mdl__get_int(b, "mesh frame axis", 0, v1 ? 1 : MDL_AXIS_FIT);
    m->axis_rec = mdl__get_int(b, "recording frame axis", 0, v1 ? 1 : MDL_AXIS_FIT);
    {
        double *pr = mdl__get_f64s(b, 9, "place_R"), *po = mdl__get_f64s(b, 3, "place_o");
        m->rec_heading = mdl__get_f64(b, "rec_heading");
        double *ro = mdl__get_f64s(b, 3, "rec_origin");
        if (pr && po && ro) {
            memcpy(m->place_R, pr, sizeof m->place_R);
            memcpy(m->place_o, po, sizeof m->place_o);
            memcpy(m->rec_origin, ro, sizeof m->rec_origin);
        }
        free(pr);
        free(po);
        free(ro);
    }
    /* the heading fit (heading.h): after the placement, only for MDL_AXIS_FIT */
    int nmk = mm && mm->rig ? mm->rig->nmarkers : 0;
    if ((m->axis_mesh == MDL_AXIS_FIT || m->axis_rec == MDL_AXIS_FIT) && !b->rc &&
        (nmk < 1 || !mm->rig || mm->rig->nref != 2))
        mdl__rfail(b, "a fitted heading needs a rig with a two-marker reference edge");
    if (m->axis_mesh == MDL_AXIS_FIT && !b->rc)
        m->hd_mesh = mdl__get_f64s(b, 4 * (size_t)nmk, "mesh heading");
    if (m->axis_rec == MDL_AXIS_FIT && !b->rc)
        m->hd_rec = mdl__get_f64s(b, 4 * (size_t)nmk, "recording heading");
    if (b->rc)
        return fail_rc(b);
    return b->rc;
}

/* version 1 only: the rest pose and the faces, checked against the fingerprint */
static int parse_mesh_v1(mdl__rbuf *b, struct mdl_steer *m)
{
    int nv = m->nv;
    m->rest = mdl__get_f32s(b, 3 * (size_t)nv, "rest");
    if (mdl__get_count(b, 3 * (size_t)m->nf, "faces"))
        return fail_rc(b);
    m->F = mdl__calloc(3 * (size_t)m->nf, sizeof *m->F);
    if (!m->F)
        return oom(b);
    for (size_t i = 0; i < 3 * (size_t)m->nf && !b->rc; i++) {
        m->F[i] = mdl__get_u32(b);
        if (m->F[i] >= (uint32_t)nv)
            mdl__rfail(b, "a face index is out of range");
    }
    if (b->rc)
        return fail_rc(b);
    if (mdl_topology_fingerprint(m->F, m->nf, nv) != m->topology) {
        mdl__rfail(b, "the face list does not match its fingerprint");
        return fail_rc(b);
    }
    return b->rc;
}

/* the training frames, and the rig (inline in version 1, the RIG chunk in version 2) */
static int parse_training(mdl__rbuf *b, struct mdl_steer *m, const mdl_model *mm, int v1)
{
    int nv = m->nv;
    uint32_t nt = mdl__get_u32(b);
    b->at -= 4;
    if (nt > MAX_COUNT) {
        mdl__rfail(b, "training frame count is too large");
        return fail_rc(b);
    }
    m->ntrain = (int)nt;
    m->train_frames = mdl__get_ints(b, nt, "train_frames", 0, 0x7fffffff);
    if (v1) {
        mdl_rig *rig = NULL;
        if (mdl__rig_read(b, nv, &rig))
            return fail_rc(b);
        int rc = copy_rig(m, rig);
        mdl_rig_destroy(rig);
        if (rc)
            return oom(b);
    } else if (!mm->rig) {
        mdl__rfail(b, "a steering model needs a rig chunk");
        return fail_rc(b);
    } else if (copy_rig(m, mm->rig)) {
        return oom(b);
    }
    return b->rc;
}

/* the disjoint parts and their shape models (Sec. 4.4, eq. 6) */
static int parse_parts(mdl__rbuf *b, struct mdl_steer *m)
{
    int nv = m->nv;
    int P = m->nparts = mdl__get_int(b, "part count", 1, 1 << 16);
    if (b->rc)
        return fail_rc(b);
    m->part = mdl__get_ints(b, (size_t)nv, "part", 0, P - 1);
    m->part_rms = mdl__get_f64s(b, (size_t)P, "part_rms");
    m->pv_off = mdl__get_ints(b, (size_t)P + 1, "pv_off", 0, MAX_COUNT);
    if (mdl__check_offsets(b, m->pv_off, P, "pv_off"))
        return fail_rc(b);
    m->pv_idx = mdl__get_ints(b, (size_t)m->pv_off[P], "pv_idx", 0, nv - 1);
    m->pmodes = mdl__get_ints(b, (size_t)P, "pmodes", 0, 64);
    m->pm_off = mdl__get_ints(b, (size_t)P + 1, "pm_off", 0, MAX_COUNT);
    m->ps_off = mdl__get_ints(b, (size_t)P + 1, "ps_off", 0, MAX_COUNT);
    if (b->rc)
        return fail_rc(b);
    for (int p = 0; p < P; p++) {
        size_t n = (size_t)(m->pv_off[p + 1] - m->pv_off[p]);
        if (n == 0 || (size_t)m->pm_off[p + 1] - (size_t)m->pm_off[p] != 3 * n * (size_t)m->pmodes[p] ||
            m->ps_off[p + 1] - m->ps_off[p] != m->pmodes[p] || m->pm_off[p + 1] < m->pm_off[p]) {
            mdl__rfail(b, "part mode tables are inconsistent");
            return fail_rc(b);
        }
    }
    if (m->pm_off[0] != 0 || m->ps_off[0] != 0) {
        mdl__rfail(b, "part mode tables do not start at 0");
        return fail_rc(b);
    }
    m->part_mean = mdl__get_f32s(b, 3 * (size_t)m->pv_off[P], "part_mean");
    m->part_modes = mdl__get_f32s(b, (size_t)m->pm_off[P], "part_modes");
    m->part_sigma2 = mdl__get_f64s(b, (size_t)m->ps_off[P], "part_sigma2");
    m->part_explained = mdl__get_f64s(b, (size_t)P, "part_explained");
    if (b->rc)
        return fail_rc(b);
    for (int i = 0; i < m->ps_off[P]; i++)
        if (!(m->part_sigma2[i] > 0)) {
            mdl__rfail(b, "a shape variance is not positive");
            return fail_rc(b);
        }
    return b->rc;
}

/* the instances, the limb paths and control points (eq. 2) and the regressions Phi, Psi (eq. 5) */
static int parse_limbs(mdl__rbuf *b, struct mdl_steer *m)
{
    int P = m->nparts;
    int NI = m->ninst = mdl__get_int(b, "instance count", 1, 1 << 20), L = m->nlimbs;
    if (b->rc)
        return fail_rc(b);
    m->inst_part = mdl__get_ints(b, (size_t)NI, "inst_part", 0, P - 1);
    m->inst_limb = mdl__get_ints(b, (size_t)NI, "inst_limb", 0, L - 1);
    m->inst_out = mdl__get_ints(b, (size_t)NI, "inst_out", 0, MAX_COUNT);
    m->inst_shared = mdl__get_ints(b, (size_t)NI, "inst_shared", 0, 1);
    m->lpath_off = mdl__get_ints(b, (size_t)L + 1, "lpath_off", 0, MAX_COUNT);
    if (mdl__check_offsets(b, m->lpath_off, L, "lpath_off"))
        return fail_rc(b);
    m->lpath = mdl__get_ints(b, (size_t)m->lpath_off[L], "lpath", 0, P - 1);
    m->lctrl = mdl__get_f64s(b, 3 * ((size_t)m->lpath_off[L] + L), "control points");
    m->reg = mdl__calloc((size_t)L, sizeof *m->reg);
    if (!m->reg)
        return oom(b);
    for (int l = 0; l < L && !b->rc; l++) {
        mdl_limb_reg *r = &m->reg[l];
        int plen = m->limb_off[l + 1] - m->limb_off[l];
        r->nin = mdl__get_int(b, "regression inputs", 0, 4096);
        r->nout = mdl__get_int(b, "regression outputs", 1, 1 << 20);
        if (b->rc)
            break;
        if (r->nin != mdl__limb_nfeat(plen, m->use_motion_dir)) {
            mdl__rfail(b, "a regression's input count does not match its limb");
            break;
        }
        r->feat_scale = mdl__get_f64s(b, (size_t)r->nin, "feat_scale");
        r->feat_shift = mdl__get_f64s(b, (size_t)r->nin, "feat_shift");
        r->zmean = mdl__get_f64s(b, (size_t)r->nin, "zmean");
        r->zsd = mdl__get_f64s(b, (size_t)r->nin, "zsd");
        r->ncent = mdl__get_int(b, "kernel centres", 0, 1 << 16);
        r->cent = mdl__get_f64s(b, (size_t)r->ncent * r->nin, "cent");
        r->width = mdl__get_f64(b, "kernel width");
        r->in_mean = mdl__get_f64s(b, (size_t)(r->nin + r->ncent), "in_mean");
        r->in_sd = mdl__get_f64s(b, (size_t)(r->nin + r->ncent), "in_sd");
        r->coef = mdl__get_f64s(b, (size_t)(r->nin + r->ncent + 1) * r->nout, "coef");
        r->ridge = mdl__get_f64(b, "ridge");
        r->rms_train = mdl__get_f64(b, "rms_train");
        r->rms_loo = mdl__get_f64(b, "rms_loo");
        for (int j = 0; j < r->nin + r->ncent && !b->rc; j++)
            if (!(r->in_sd[j] > 0))
                mdl__rfail(b, "a feature scale is not positive");
        for (int j = 0; j < r->nin && !b->rc; j++)
            if (!(r->zsd[j] > 0))
                mdl__rfail(b, "a feature scale is not positive");
        if (!b->rc && r->ncent > 0 && !(r->width > 0))
            mdl__rfail(b, "a kernel width is not positive");
    }
    if (b->rc)
        return fail_rc(b);
    for (int i = 0; i < NI; i++) {
        const mdl_limb_reg *r = &m->reg[m->inst_limb[i]];
        if (m->inst_out[i] + 7 + m->pmodes[m->inst_part[i]] > r->nout) {
            mdl__rfail(b, "an instance's outputs exceed its regression");
            return fail_rc(b);
        }
    }
    return b->rc;
}

/* the synthesis precomputations: alignment order (Sec. 5.1), shape-optimisation factors (eq. 7), blend weights (eq. 8) */
static int parse_precompute(mdl__rbuf *b, struct mdl_steer *m)
{
    int nv = m->nv;
    int NI = m->ninst;
    m->order = mdl__get_ints(b, (size_t)NI, "order", 0, NI - 1);
    m->order_ov_off = mdl__get_ints(b, (size_t)NI + 1, "order_ov_off", 0, MAX_COUNT);
    if (mdl__check_offsets(b, m->order_ov_off, NI, "order_ov_off"))
        return fail_rc(b);
    m->order_ov = mdl__get_ints(b, (size_t)m->order_ov_off[NI], "order_ov", 0, MAX_COUNT);
    m->sov_off = mdl__get_ints(b, (size_t)NI + 1, "sov_off", 0, MAX_COUNT);
    if (mdl__check_offsets(b, m->sov_off, NI, "sov_off"))
        return fail_rc(b);
    m->sov = mdl__get_ints(b, (size_t)m->sov_off[NI], "sov", 0, MAX_COUNT);
    m->chol_off = mdl__get_ints(b, (size_t)NI + 1, "chol_off", 0, MAX_COUNT);
    if (mdl__check_offsets(b, m->chol_off, NI, "chol_off"))
        return fail_rc(b);
    m->chol = mdl__get_f64s(b, (size_t)m->chol_off[NI], "chol");
    m->blend_off = mdl__get_ints(b, (size_t)nv + 1, "blend_off", 0, MAX_COUNT);
    if (mdl__check_offsets(b, m->blend_off, nv, "blend_off"))
        return fail_rc(b);
    m->blend_inst = mdl__get_ints(b, (size_t)m->blend_off[nv], "blend_inst", 0, NI - 1);
    m->blend_local = mdl__get_ints(b, (size_t)m->blend_off[nv], "blend_local", 0, MAX_COUNT);
    m->blend_w = mdl__get_f32s(b, (size_t)m->blend_off[nv], "blend_w");
    return b->rc;
}

/* cross-checks of every local index against the part it indexes, and of the Cholesky factors */
static int check_local_indices(mdl__rbuf *b, struct mdl_steer *m)
{
    int nv = m->nv;
    int NI = m->ninst;
    /* cross-checks of local indices against part sizes */
    {
        uint8_t *seen = mdl__calloc((size_t)NI, 1);
        if (!seen)
            return oom(b);
        for (int s = 0; s < NI; s++) {
            int i = m->order[s];
            if (seen[i]++)
                mdl__rfail(b, "the alignment order repeats an instance");
        }
        free(seen);
        for (int i = 0; i < NI && !b->rc; i++) {
            int p = m->inst_part[i], n = m->pv_off[p + 1] - m->pv_off[p], k = m->pmodes[p];
            if (m->chol_off[i + 1] - m->chol_off[i] != k * k)
                mdl__rfail(b, "a Cholesky factor has the wrong size");
            for (int o = m->sov_off[i]; o < m->sov_off[i + 1] && !b->rc; o++)
                if (m->sov[o] >= n)
                    mdl__rfail(b, "a shape-optimisation vertex is outside its part");
        }
        for (int s = 0; s < NI && !b->rc; s++) {
            int i = m->order[s], p = m->inst_part[i], n = m->pv_off[p + 1] - m->pv_off[p];
            for (int o = m->order_ov_off[s]; o < m->order_ov_off[s + 1] && !b->rc; o++) {
                if (m->order_ov[o] >= n)
                    mdl__rfail(b, "an alignment overlap vertex is outside its part");
                /* synthesis aligns on these among the instance's overlap vertices (synth.c) */
                int e = m->sov_off[i];
                while (e < m->sov_off[i + 1] && m->sov[e] != m->order_ov[o])
                    e++;
                if (!b->rc && e == m->sov_off[i + 1])
                    mdl__rfail(b, "an alignment overlap vertex is not an overlap vertex of its "
                                  "instance");
            }
        }
        for (int j = 0; j < m->blend_off[nv] && !b->rc; j++) {
            int p = m->inst_part[m->blend_inst[j]];
            if (m->blend_local[j] >= m->pv_off[p + 1] - m->pv_off[p])
                mdl__rfail(b, "a blend entry is outside its part");
        }
        for (int i = 0; i < NI && !b->rc; i++) {
            int k = m->pmodes[m->inst_part[i]];
            const double *A = m->chol + m->chol_off[i];
            for (int a = 0; a < k; a++)
                if (!(A[a * k + a] > 0))
                    mdl__rfail(b, "a Cholesky factor has a non-positive diagonal");
        }
    }
    return b->rc;
}

int mdl__steer_parse(mdl__rbuf *b, const mdl_model *mm, int v1, struct mdl_steer **out)
{
    *out = NULL;
    struct mdl_steer *m = mdl__calloc(1, sizeof *m);
    if (!m)
        return mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
    if (v1 ? parse_header_v1(b, m) != 0 : copy_mesh(m, mm) != 0)
        goto bad_or_oom;
    if (parse_options(b, m, mm, v1))
        goto bad;
    if (v1 && parse_mesh_v1(b, m))
        goto bad;
    if (parse_training(b, m, mm, v1) || parse_parts(b, m) || parse_limbs(b, m) ||
        parse_precompute(b, m) || check_local_indices(b, m) || (!v1 && parse_trailer(b, m)))
        goto bad;
    if (b->rc)
        goto bad;
    *out = m;
    return 0;
bad_or_oom:
    if (!b->rc) /* copy_mesh failed */
        b->rc = mdl__err(b->err, -ENOMEM, "%s: out of memory", b->name);
bad:
    mdl__steer_free(m);
    return b->rc ? b->rc : MDL_EFORMAT;
}


/* ------------------------------------------------------------------ views */

static void steer_describe(const void *impl, const mdl_model *mm, char *buf, size_t len, size_t *at)
{
    const struct mdl_steer *m = impl;
    (void)mm;
    mdl__appendf(buf, len, at, "training   %d frames (", m->ntrain);
    for (int i = 0; i < m->ntrain && i < 12; i++)
        mdl__appendf(buf, len, at, "%s%d", i ? " " : "", m->train_frames[i]);
    mdl__appendf(buf, len, at, "%s), %s markers, %.2f s\n", m->ntrain > 12 ? " ..." : "",
           m->virtual_markers ? "virtual" : "recorded", m->train_seconds);
    mdl__appendf(buf, len, at, "bbox       [%.3f %.3f %.3f] .. [%.3f %.3f %.3f] m\n", m->bbox_min[0], m->bbox_min[1],
           m->bbox_min[2], m->bbox_max[0], m->bbox_max[1], m->bbox_max[2]);
    mdl__appendf(buf, len, at, "markers    %d:", m->nmarkers);
    for (int i = 0; i < m->nmarkers; i++) {
        mdl__appendf(buf, len, at, " %s@%d", m->markers[i].name, m->markers[i].vertex);
        if (strcmp(m->markers[i].name, m->markers[i].source))
            mdl__appendf(buf, len, at, "<-%s", m->markers[i].source);
    }
    mdl__appendf(buf, len, at, "\nreference  %s -> %s%s%s\n", m->markers[m->ref[0]].name, m->markers[m->ref[1]].name,
           m->nref > 2 ? ", side " : "", m->nref > 2 ? m->markers[m->ref[2]].name : "");
    int modes = 0;
    for (int p = 0; p < m->nparts; p++)
        modes += m->pmodes[p];
    long ivert = 0;
    for (int i = 0; i < m->ninst; i++)
        ivert += m->pv_off[m->inst_part[i] + 1] - m->pv_off[m->inst_part[i]];
    mdl__appendf(buf, len, at, "parts      %d near-rigid clusters, %d shape modes, %d instances holding %ld vertices "
           "(%d shared between instances)\n",
           m->nparts, modes, m->ninst, ivert, m->sov_off[m->ninst]);
    for (int p = 0; p < m->nparts; p++) {
        int core = 0;
        for (int v = 0; v < m->nv; v++)
            core += m->part[v] == p;
        mdl__appendf(buf, len, at, "  part %-3d %5d vertices (+%d overlap), %d modes, %5.1f%% explained, rigid rms %.4f\n",
               p, core, m->pv_off[p + 1] - m->pv_off[p] - core, m->pmodes[p],
               100 * m->part_explained[p], m->part_rms[p]);
    }
    mdl__appendf(buf, len, at, "limbs      %d\n", m->nlimbs);
    for (int l = 0; l < m->nlimbs; l++) {
        mdl__appendf(buf, len, at, "  limb %-2d ", l);
        for (int j = m->limb_off[l]; j < m->limb_off[l + 1]; j++)
            mdl__appendf(buf, len, at, "%s%s", j > m->limb_off[l] ? "-" : "", m->markers[m->limb_idx[j]].name);
        mdl__appendf(buf, len, at, "  path in H:");
        for (int j = m->lpath_off[l]; j < m->lpath_off[l + 1]; j++)
            mdl__appendf(buf, len, at, " %d", m->lpath[j]);
        mdl__appendf(buf, len, at, ", %d control points", m->lpath_off[l + 1] - m->lpath_off[l] + 1);
        mdl__appendf(buf, len, at, "  regression: %d (+%d rbf) -> %d, ridge %g, residual %.3f (leave-one-out %.3f)\n",
               m->reg[l].nin, m->reg[l].ncent, m->reg[l].nout, m->reg[l].ridge, m->reg[l].rms_train,
               m->reg[l].rms_loo);
    }
    mdl__appendf(buf, len, at, "synthesis  beta %g, %d iterations, %d relaxation sweeps, marker weight %g, motion "
           "directions %s\n",
           m->beta, m->iterations, m->relax, m->marker_weight, m->use_motion_dir ? "on" : "off");
    if (m->mfilt) {
        mdl__appendf(buf, len, at, "filter     input markers for %g mm noise, alpha", 1000 * m->filter_noise);
        for (int j = 0; j < m->nmarkers; j++)
            mdl__appendf(buf, len, at, " %s %.2f", m->markers[j].name, m->mfilt[2 * j]);
        mdl__appendf(buf, len, at, "\n");
    } else {
        mdl__appendf(buf, len, at, "filter     none\n");
    }
    if (m->kb_h > 0)
        mdl__appendf(buf, len, at, "kernel     synthesis is the kernel blend of the %d training meshes, bandwidth "
                     "%g x the nearest frame's marker fit (kblend.h); the parts above are unused\n",
                     m->ntrain, m->kb_h);
    if (m->sel) {
        const mdl_select_cand *c = &m->sel->cand[m->sel->chosen];
        char rd[32];
        snprintf(rd, sizeof rd, "%g", c->ridge);
        mdl__appendf(buf, len, at, "selection  %d candidates, %d folds, %.2f s; chose motion directions %s, %s, "
                     "ridge %s, input filter %s, train noise %g mm, overlap %d, modes <= %d, parts <= %d, kernel blend %g (score %.3f)\n",
                     m->sel->ncand, m->sel->folds, m->sel->seconds, c->use_motion_dir ? "on" : "off",
                     c->linear == 1 ? "linear" : "rbf", c->ridge < 0 ? "leave-one-out" : rd, c->filter_noise > 0 ? "on" : "off", 1000 * c->train_noise,
                     c->overlap_rings, c->max_modes, c->max_clusters, c->kblend, c->score);
    }
}

static void steer_report(const void *impl, const mdl_model *mm, void *obj)
{
    const struct mdl_steer *m = impl;
    cJSON *o = obj;
    (void)mm;
    cJSON_AddNumberToObject(o, "training_frames", m->ntrain);
    cJSON_AddNumberToObject(o, "training_seconds", m->train_seconds);
    cJSON_AddBoolToObject(o, "virtual_markers", m->virtual_markers);
    cJSON_AddNumberToObject(o, "clusters", m->nparts);
    cJSON_AddNumberToObject(o, "instances", m->ninst);
    cJSON *parts = cJSON_AddArrayToObject(o, "parts");
    for (int p = 0; p < m->nparts; p++) {
        int core = 0;
        for (int v = 0; v < m->nv; v++)
            core += m->part[v] == p;
        cJSON *e = cJSON_CreateObject();
        cJSON_AddNumberToObject(e, "part", p);
        cJSON_AddNumberToObject(e, "vertices", core);
        cJSON_AddNumberToObject(e, "with_overlap", m->pv_off[p + 1] - m->pv_off[p]);
        cJSON_AddNumberToObject(e, "modes", m->pmodes[p]);
        cJSON_AddNumberToObject(e, "explained_variance", m->part_explained[p]);
        cJSON_AddNumberToObject(e, "rigid_rms", m->part_rms[p]);
        cJSON_AddItemToArray(parts, e);
    }
    if (m->sel) { /* the option selection (select.h): every candidate and the choice */
        const mdl_select_result *r = m->sel;
        cJSON *se = cJSON_AddObjectToObject(o, "selection");
        cJSON_AddNumberToObject(se, "folds", r->folds);
        cJSON_AddNumberToObject(se, "noise_m", r->select_noise);
        cJSON_AddNumberToObject(se, "seconds", r->seconds);
        cJSON_AddNumberToObject(se, "chosen", r->chosen);
        cJSON *ca = cJSON_AddArrayToObject(se, "candidates");
        for (int i = 0; i < r->ncand; i++) {
            const mdl_select_cand *c = &r->cand[i];
            cJSON *e = cJSON_CreateObject();
            cJSON_AddBoolToObject(e, "motion_dir", c->use_motion_dir);
            cJSON_AddStringToObject(e, "regression", c->linear == 1 ? "linear" : "rbf");
            if (c->ridge < 0)
                cJSON_AddStringToObject(e, "ridge", "leave-one-out");
            else
                cJSON_AddNumberToObject(e, "ridge", c->ridge);
            cJSON_AddNumberToObject(e, "filter_noise_m", c->filter_noise);
            cJSON_AddNumberToObject(e, "kernel_blend", c->kblend);
            cJSON_AddNumberToObject(e, "train_noise_m", c->train_noise);
            cJSON_AddNumberToObject(e, "overlap_rings", c->overlap_rings);
            cJSON_AddNumberToObject(e, "max_modes", c->max_modes);
            cJSON_AddNumberToObject(e, "max_clusters", c->max_clusters);
            cJSON_AddNumberToObject(e, "val_err_clean", c->err_clean);
            cJSON_AddNumberToObject(e, "val_baseline_clean", c->base_clean);
            cJSON_AddNumberToObject(e, "val_err_noisy", c->err_noisy);
            cJSON_AddNumberToObject(e, "val_baseline_noisy", c->base_noisy);
            if (c->spaced) {
                cJSON_AddNumberToObject(e, "val2_err_clean", c->err2_clean);
                cJSON_AddNumberToObject(e, "val2_baseline_clean", c->base2_clean);
                cJSON_AddNumberToObject(e, "val2_err_noisy", c->err2_noisy);
                cJSON_AddNumberToObject(e, "val2_baseline_noisy", c->base2_noisy);
                cJSON_AddNumberToObject(e, "score_at_test_spacing", c->score_spaced);
            }
            cJSON_AddNumberToObject(e, "score", c->score);
            cJSON_AddBoolToObject(e, "chosen", i == r->chosen);
            cJSON_AddItemToArray(ca, e);
        }
    }
    cJSON *limbs = cJSON_AddArrayToObject(o, "limbs");
    for (int l = 0; l < m->nlimbs; l++) {
        cJSON *e = cJSON_CreateObject(), *mk = cJSON_AddArrayToObject(e, "markers");
        for (int j = m->limb_off[l]; j < m->limb_off[l + 1]; j++)
            cJSON_AddItemToArray(mk, cJSON_CreateString(m->markers[m->limb_idx[j]].name));
        cJSON *path = cJSON_AddArrayToObject(e, "path_parts");
        for (int j = m->lpath_off[l]; j < m->lpath_off[l + 1]; j++)
            cJSON_AddItemToArray(path, cJSON_CreateNumber(m->lpath[j]));
        cJSON *cp = cJSON_AddArrayToObject(e, "control_points");
        const double *c = m->lctrl + 3 * ((size_t)m->lpath_off[l] + l);
        for (int j = 0; j <= m->lpath_off[l + 1] - m->lpath_off[l]; j++)
            cJSON_AddItemToArray(cp, cJSON_CreateDoubleArray(c + 3 * j, 3));
        cJSON_AddNumberToObject(e, "inputs", m->reg[l].nin);
        cJSON_AddNumberToObject(e, "rbf_centres", m->reg[l].ncent);
        cJSON_AddNumberToObject(e, "outputs", m->reg[l].nout);
        cJSON_AddNumberToObject(e, "ridge", m->reg[l].ridge);
        cJSON_AddNumberToObject(e, "residual", m->reg[l].rms_train);
        cJSON_AddNumberToObject(e, "residual_loo", m->reg[l].rms_loo);
        cJSON_AddItemToArray(limbs, e);
    }
}

/* ------------------------------------------------------------------ the kind table */

static void steer_destroy(void *impl)
{
    mdl__steer_free(impl);
}

static void steer_save_chunk(const void *impl, const mdl_model *m, mdl__wbuf *b)
{
    (void)m;
    mdl__steer_save(impl, b);
}

static int steer_parse_chunk(mdl__rbuf *b, const mdl_model *m, void **impl)
{
    struct mdl_steer *s = NULL;
    int rc = mdl__steer_parse(b, m, 0, &s);
    *impl = s;
    return rc;
}

static void steer_info(const void *impl, mdl_model_info *info)
{
    const struct mdl_steer *m = impl;
    info->nclusters = m->nparts;
    info->part = m->part;
    info->ntrain = m->ntrain;
    info->train_frames = m->train_frames;
    info->virtual_markers = m->virtual_markers;
}

static int steer_synth_create(const mdl_model *m, const void *impl, void **state, char *err)
{
    (void)m;
    mdl_steer_synth *s = NULL;
    int rc = mdl__steer_synth_create(impl, &s, err);
    *state = s;
    return rc;
}

static int steer_synth_frame(void *state, const mdl_synth_input *in, float *V, mdl_synth_info *info)
{
    if (!in->markers)
        return -EINVAL;
    return mdl__steer_synth_frame(state, in->markers, in->valid, V, info);
}

static void steer_synth_reset(void *state)
{
    mdl__steer_synth_reset(state);
}

static int steer_synth_params_layout(const void *state, mdl_params_layout *out)
{
    return mdl__steer_synth_params_layout(state, out);
}

static int steer_synth_params(const void *state, float *out)
{
    return mdl__steer_synth_params(state, out);
}

static void steer_synth_destroy(void *state)
{
    mdl__steer_synth_destroy(state);
}

const mdl_kind_ops mdl__steer_kind = {
    .id = MDL_KIND_STEER,
    .name = "steer",
    .tag = {'S', 'T', 'E', 'R'},
    .inputs = MDL_INPUT_MARKERS,
    .destroy = steer_destroy,
    .save = steer_save_chunk,
    .parse = steer_parse_chunk,
    .info = steer_info,
    .describe = steer_describe,
    .report = steer_report,
    .synth_create = steer_synth_create,
    .synth_frame = steer_synth_frame,
    .synth_reset = steer_synth_reset,
    .synth_destroy = steer_synth_destroy,
    .synth_params_layout = steer_synth_params_layout,
    .synth_params = steer_synth_params,
    .eval = mdl__steer_eval,
};

const struct mdl_steer *mdl__model_steer(const mdl_model *m)
{
    const mdl_kind_slot *k = mdl__model_kind(m, MDL_KIND_STEER);
    return k ? k->impl : NULL;
}

mdl_steer_synth *mdl__synth_steer(mdl_synth *s)
{
    return s && s->ops == &mdl__steer_kind ? s->state : NULL;
}

/* The rig of a trained steering model, as a model's rig chunk. */
static int steer_rig(const struct mdl_steer *s, mdl_rig *r)
{
    r->nmarkers = s->nmarkers;
    r->markers = s->markers;
    r->nref = s->nref;
    memcpy(r->ref, s->ref, sizeof r->ref);
    r->nlimbs = s->nlimbs;
    r->limb_off = s->limb_off;
    r->limb_idx = s->limb_idx;
    return 0;
}

/* A version-1 file: the steering model with the mesh and the rig inline (formats/modelfile.c). */
int mdl__steer_model_from(struct mdl_steer *s, mdl_model **out, char *err)
{
    mdl_rig rig;
    steer_rig(s, &rig);
    int rc = mdl__model_create(s->name, s->rest, s->nv, s->F, s->nf, s->fps, s->bbox_min,
                               s->bbox_max, &rig, out, err);
    if (rc) {
        mdl__steer_free(s);
        return rc;
    }
    rc = mdl__model_add_kind(*out, &mdl__steer_kind, s, err);
    if (rc) {
        mdl_model_destroy(*out);
        *out = NULL;
    }
    return rc;
}

int mdl_steer_train(const mdl_meshseq *seq, const int *frames, int nframes, const mdl_rig *rig,
                    const mdl_markers *markers, const mdl_train_opts *o, mdl_model **out, char *err)
{
    *out = NULL;
    struct mdl_steer *s = NULL;
    int rc = mdl__steer_train(seq, frames, nframes, rig, markers, o, &s, err);
    if (rc)
        return rc;
    return mdl__steer_model_from(s, out, err);
}
