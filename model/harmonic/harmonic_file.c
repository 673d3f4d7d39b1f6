/* harmonic_file.c - the harmonic model kind: building it (mdl_harmonic_build, model.h), its chunk of
 * the model file ("HARM", docs/FORMATS.md), its summary and report, and its kind table.
 *
 * The chunk: u32 version (2; 1 still reads, without joints), then auto_k, the correspondences
 * (triangles, groups), the group tree (candy.c), the bones (a, b, c over the rig's markers), the
 * aligned template rest pose, the alignment, root marker, root bone and anchor vertex, then
 * (version 2) per bone its joint + 1 (0: none), R_j(rest) and the rest fit's C_g (4 f64 each). Every count is checked against the model's
 * mesh and rig, every index against what it indexes; the tree is checked to be a tree in order. */
#include "harmonic/harmonic_internal.h"
#include "kind.h"
#include "core/util.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void mdl__harmonic_free(struct mdl_harmonic *h)
{
    if (!h)
        return;
    free(h->corr_tri);
    free(h->corr_group);
    free(h->group_parent);
    free(h->group_order);
    free(h->bone_a);
    free(h->bone_b);
    free(h->bone_c);
    free(h->mk_rest);
    free(h->bone_j);
    free(h->bone_jrest);
    free(h->bone_fit);
    free(h);
}

void mdl_harmonic_opts_default(mdl_harmonic_opts *o)
{
    memset(o, 0, sizeof *o);
    o->per_bone = 8;
}

/* the template's rest pose aligned to the target: scale by height, feet on its floor, centres over
 * each other (Sec. 4.1: "both reference poses are roughly aligned a priori").
 * Two translations come out of it. The rest pose is overlaid on the target by its own lowest
 * marker (mk_rest, used for correspondences and bone rest directions). The motion frames are
 * mapped by align_t, which puts the mocap's floor on the target's floor (Sec. 5, "brings it to a
 * correct global position"): a BVH or ASF/AMC rest pose has its root at the origin, while its
 * frames carry the root's height above the mocap's floor, so aligning those frames by the rest
 * pose's feet would lift the target by the hip height. The floor is the lowest marker over every
 * frame of `motion` (a hop still touches down), or the rest pose's lowest marker without it. */
static int align_template(struct mdl_harmonic *h, const mdl_mesh *tg, const mdl_rig *rig,
                          const mdl_markers *tr, const mdl_markers *motion, char *err)
{
    float tlo[3] = {INFINITY, INFINITY, INFINITY}, thi[3] = {-INFINITY, -INFINITY, -INFINITY};
    float mlo[3] = {INFINITY, INFINITY, INFINITY}, mhi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int v = 0; v < tg->nv; v++)
        for (int c = 0; c < 3; c++) {
            tlo[c] = fminf(tlo[c], tg->V[3 * v + c]);
            thi[c] = fmaxf(thi[c], tg->V[3 * v + c]);
        }
    for (int i = 0; i < rig->nmarkers; i++) {
        int j = mdl_markers_find(tr, rig->markers[i].source);
        if (j < 0)
            return mdl__err(err, -EINVAL, "harmonic: the template's rest pose has no marker '%s' "
                            "(rig marker '%s')", rig->markers[i].source, rig->markers[i].name);
        for (int c = 0; c < 3; c++) {
            float x = tr->P[3 * j + c];
            h->mk_rest[3 * i + c] = x;
            mlo[c] = fminf(mlo[c], x);
            mhi[c] = fmaxf(mhi[c], x);
        }
    }
    double mh = (double)mhi[1] - mlo[1], th = (double)thi[1] - tlo[1];
    if (!(mh > 0) || !(th > 0))
        return mdl__err(err, -EINVAL, "harmonic: the template or the target has no height");
    double s = th / mh;
    h->align_scale = s;
    h->align_t[0] = 0.5 * ((double)tlo[0] + thi[0]) - s * 0.5 * ((double)mlo[0] + mhi[0]);
    h->align_t[1] = (double)tlo[1] - s * mlo[1];
    h->align_t[2] = 0.5 * ((double)tlo[2] + thi[2]) - s * 0.5 * ((double)mlo[2] + mhi[2]);
    for (int i = 0; i < rig->nmarkers; i++)
        for (int c = 0; c < 3; c++)
            h->mk_rest[3 * i + c] = (float)(s * h->mk_rest[3 * i + c] + h->align_t[c]);
    if (motion && motion->frames > 0) {
        /* the mocap's floor: its lowest valid sample of the rig's markers over all frames */
        double floor = INFINITY;
        for (int i = 0; i < rig->nmarkers; i++) {
            int j = mdl_markers_find(motion, rig->markers[i].source);
            if (j < 0)
                return mdl__err(err, -EINVAL, "harmonic: the template's motion has no marker '%s' "
                                "(rig marker '%s')", rig->markers[i].source, rig->markers[i].name);
            for (int f = 0; f < motion->frames; f++) {
                size_t at = (size_t)f * (size_t)motion->count + (size_t)j;
                double y = motion->P[3 * at + 1];
                if (motion->valid[at] && isfinite(y) && y < floor)
                    floor = y;
            }
        }
        if (isfinite(floor))
            h->align_t[1] = (double)tlo[1] - s * floor;
    }
    return 0;
}

/* Which joint rotation drives each bone (MDL_INPUT_JOINTS, harmonic_synth.c), from the template's
 * skeleton (tr->parent, tr->rot; a template without them: none, every bone on the direction path):
 * a bone a -> b whose b hangs below a (through any number of segments) turns with the segment
 * ending at b (a chain's last: Neck -> Head_End turns with the head); one whose a hangs below b, with
 * the segment ending at a. bone_jrest: that rotation in the template's rest frame; bone_fit: the
 * identity until the rest fit sets it. */
static int bone_joints(struct mdl_harmonic *h, const mdl_rig *rig, const mdl_markers *tr, char *err)
{
    int nb = h->nbones;
    h->bone_j = mdl__calloc((size_t)nb + 1, sizeof *h->bone_j);
    h->bone_jrest = mdl__calloc(4 * (size_t)nb + 4, sizeof *h->bone_jrest);
    h->bone_fit = mdl__calloc(4 * (size_t)nb + 4, sizeof *h->bone_fit);
    if (!h->bone_j || !h->bone_jrest || !h->bone_fit)
        return mdl__err(err, -ENOMEM, "harmonic: out of memory");
    for (int g = 0; g < nb; g++) {
        h->bone_j[g] = -1;
        h->bone_jrest[4 * g] = h->bone_fit[4 * g] = 1;
        if (!tr->rot || !tr->parent)
            continue;
        int a = h->bone_a[g], b = h->bone_b[g];
        int sa = mdl_markers_find(tr, rig->markers[a].source),
            sb = mdl_markers_find(tr, rig->markers[b].source);
        if (sa < 0 || sb < 0 || sa == sb)
            continue;
        int j = -1, sj = -1;
        for (int x = tr->parent[sb], n = 0; x >= 0 && n < tr->count && j < 0; x = tr->parent[x], n++)
            if (x == sa)
                j = b, sj = sb;
        for (int x = tr->parent[sa], n = 0; x >= 0 && n < tr->count && j < 0; x = tr->parent[x], n++)
            if (x == sb)
                j = a, sj = sa;
        if (j < 0)
            continue;
        const float *q = tr->rot + 4 * (size_t)sj;
        double n = (double)q[0] * q[0] + (double)q[1] * q[1] + (double)q[2] * q[2] + (double)q[3] * q[3];
        if (!tr->valid[sj] || !(n > 0.25 && n < 4))
            continue;
        h->bone_j[g] = j;
        for (int k = 0; k < 4; k++)
            h->bone_jrest[4 * g + k] = q[k];
        mdl__qnorm(h->bone_jrest + 4 * g);
    }
    return 0;
}

int mdl_harmonic_build(const mdl_mesh *target, const mdl_rig *rig, const mdl_markers *template_rest,
                       const mdl_harmonic_opts *o, mdl_model **out, char *err)
{
    *out = NULL;
    mdl_harmonic_opts def;
    if (!o) {
        mdl_harmonic_opts_default(&def);
        o = &def;
    }
    if (!target || target->nv < 3 || target->nf < 1)
        return mdl__err(err, -EINVAL, "harmonic: the target mesh is empty");
    if (o->auto_k <= 0 && (!rig || !template_rest || template_rest->frames < 1))
        return mdl__err(err, -EINVAL, "harmonic: without auto:K, a rig (the template's bones) and "
                        "the template's rest pose are needed");
    struct mdl_harmonic *h = mdl__calloc(1, sizeof *h);
    if (!h)
        return mdl__err(err, -ENOMEM, "harmonic: out of memory");
    h->nv = target->nv;
    h->nf = target->nf;
    h->root_bone = -1;
    h->align_scale = 1;
    int rc = 0;
    mdl_rig *mrig = NULL;
    if (o->auto_k > 0) {
        rc = mdl__corr_auto_k(h, target->V, target->F, target->nf, target->nv, o->auto_k, o->rings,
                              err);
    } else {
        if ((rc = mdl__rig_copy(rig, &mrig, err)))
            goto fail;
        int nb = rig->nlimbs;
        h->nmk = rig->nmarkers;
        h->nbones = nb;
        h->bone_a = mdl__calloc((size_t)nb, sizeof(int));
        h->bone_b = mdl__calloc((size_t)nb, sizeof(int));
        h->bone_c = mdl__calloc((size_t)nb, sizeof(int));
        h->mk_rest = mdl__calloc(3 * (size_t)h->nmk, sizeof(float));
        if (!h->bone_a || !h->bone_b || !h->bone_c || !h->mk_rest) {
            rc = mdl__err(err, -ENOMEM, "harmonic: out of memory");
            goto fail;
        }
        for (int b = 0; b < nb; b++) {
            int n = rig->limb_off[b + 1] - rig->limb_off[b];
            if (n > 3) {
                rc = mdl__err(err, -EINVAL, "harmonic: rig limb %d has %d markers: a bone is [from, "
                              "to] or [from, to, twist]", b, n);
                goto fail;
            }
            h->bone_a[b] = rig->limb_idx[rig->limb_off[b]];
            h->bone_b[b] = rig->limb_idx[rig->limb_off[b] + 1];
            h->bone_c[b] = n == 3 ? rig->limb_idx[rig->limb_off[b] + 2] : -1;
        }
        h->root_marker = rig->ref[0];
        for (int b = 0; b < nb && h->root_bone < 0; b++)
            if (h->bone_a[b] == h->root_marker)
                h->root_bone = b;
        if ((rc = align_template(h, target, rig, template_rest, o->template_motion, err)) ||
            (rc = bone_joints(h, rig, template_rest, err)))
            goto fail;
        /* the template's rest pose onto the target's (rest_fit.c), before the correspondences */
        int kept = 0;
        if (o->fit_rest &&
            (rc = mdl__rest_fit(h, target->V, target->F, target->nv, target->nf, &kept, err)))
            goto fail;
        /* joint rotations turn the target's limbs about the template's rest axes: only where the
         * rest fit has matched those to the target's (C_g) is that the limb's own turn. Without it
         * a CMU forearm's roll about its hanging rest axis swings the T-posed arm (131_01, frames
         * 232-238: 22 cm per frame against 4.4 with markers), so the bones stay on the direction
         * path. */
        if (!o->fit_rest)
            for (int g = 0; g < h->nbones; g++)
                h->bone_j[g] = -1;
        /* the model's rig: each marker at the target vertex nearest its aligned joint */
        for (int i = 0; i < h->nmk; i++) {
            double best = INFINITY;
            for (int v = 0; v < target->nv; v++) {
                double d = 0;
                for (int c = 0; c < 3; c++)
                    d += ((double)target->V[3 * v + c] - h->mk_rest[3 * i + c]) *
                         ((double)target->V[3 * v + c] - h->mk_rest[3 * i + c]);
                if (d < best) {
                    best = d;
                    mrig->markers[i].vertex = v;
                }
            }
        }
        h->anchor_vertex = mrig->markers[h->root_marker].vertex;
        rc = mdl__corr_bones(h, target->V, target->F, target->nf, o->per_bone, o->given_off,
                             o->given_idx, err);
    }
    if (rc)
        goto fail;
    /* the factorisations must succeed on this mesh: try them once here */
    {
        mdl__hdeform d;
        if ((rc = mdl__hdeform_init(&d, h, target->V, target->F, err)))
            goto fail;
        mdl__hdeform_fini(&d);
    }
    rc = mdl__model_create(o->name ? o->name : "harmonic", target->V, target->nv, target->F,
                           target->nf, 0, NULL, NULL, mrig, out, err);
    mdl_rig_destroy(mrig);
    mrig = NULL;
    if (rc)
        goto fail;
    return mdl__model_add_kind(*out, &mdl__harmonic_kind, h, err) ? (mdl_model_destroy(*out), *out = NULL, -EEXIST) : 0;
fail:
    mdl_rig_destroy(mrig);
    mdl__harmonic_free(h);
    return rc;
}

int mdl_harmonic_correspondences(const mdl_model *m, const int **tri, const int **group, int *n,
                                 int *ngroups)
{
    const mdl_kind_slot *k = m ? mdl__model_kind(m, MDL_KIND_HARMONIC) : NULL;
    *tri = *group = NULL;
    *n = *ngroups = 0;
    if (!k)
        return -EINVAL;
    const struct mdl_harmonic *h = k->impl;
    *tri = h->corr_tri;
    *group = h->corr_group;
    *n = h->ncorr;
    *ngroups = h->ngroups;
    return 0;
}

/* ------------------------------------------------------------------ the chunk */

/* an array of indices that may be -1, stored + 1 (the reader's ints are non-negative) */
static void put_plus1(mdl__wbuf *b, const int *a, int n)
{
    mdl__put_u32(b, (uint32_t)n);
    for (int i = 0; i < n; i++)
        mdl__put_u32(b, (uint32_t)(a[i] + 1));
}

static int *get_plus1(mdl__rbuf *b, int n, const char *what, int hi)
{
    int *a = mdl__get_ints(b, (size_t)n, what, 0, hi + 1);
    for (int i = 0; a && i < n; i++)
        a[i]--;
    return a;
}

static void harm_save(const void *impl, const mdl_model *m, mdl__wbuf *b)
{
    const struct mdl_harmonic *h = impl;
    (void)m;
    mdl__put_u32(b, 2);
    mdl__put_u32(b, (uint32_t)h->auto_k);
    mdl__put_u32(b, (uint32_t)h->ncorr);
    mdl__put_i32s(b, h->corr_tri, (size_t)h->ncorr);
    mdl__put_u32(b, (uint32_t)h->ngroups);
    mdl__put_i32s(b, h->corr_group, (size_t)h->ncorr);
    put_plus1(b, h->group_parent, h->ngroups);
    mdl__put_i32s(b, h->group_order, (size_t)h->ngroups);
    mdl__put_u32(b, (uint32_t)h->nbones);
    if (h->nbones) {
        mdl__put_i32s(b, h->bone_a, (size_t)h->nbones);
        mdl__put_i32s(b, h->bone_b, (size_t)h->nbones);
        put_plus1(b, h->bone_c, h->nbones);
        mdl__put_f32s(b, h->mk_rest, 3 * (size_t)h->nmk);
        mdl__put_f64(b, h->align_scale);
        for (int c = 0; c < 3; c++)
            mdl__put_f64(b, h->align_t[c]);
        mdl__put_u32(b, (uint32_t)h->root_marker);
        mdl__put_u32(b, (uint32_t)(h->root_bone + 1));
        mdl__put_u32(b, (uint32_t)h->anchor_vertex);
        /* version 2: the joints (bone_joints) */
        for (int g = 0; g < h->nbones; g++) {
            mdl__put_u32(b, (uint32_t)(h->bone_j[g] + 1));
            for (int k = 0; k < 4; k++)
                mdl__put_f64(b, h->bone_jrest[4 * g + k]);
            for (int k = 0; k < 4; k++)
                mdl__put_f64(b, h->bone_fit[4 * g + k]);
        }
    }
}

static int harm_parse(mdl__rbuf *b, const mdl_model *m, void **impl)
{
    *impl = NULL;
    struct mdl_harmonic *h = mdl__calloc(1, sizeof *h);
    if (!h)
        return b->rc = -ENOMEM;
    h->nv = m->nv;
    h->nf = m->nf;
    h->align_scale = 1;
    h->root_bone = -1;
    int version = mdl__get_int(b, "harmonic chunk version", 1, 2);
    h->auto_k = mdl__get_int(b, "auto:K", 0, m->nf);
    h->ncorr = mdl__get_int(b, "correspondences", 1, m->nf);
    h->corr_tri = mdl__get_ints(b, (size_t)h->ncorr, "correspondence triangles", 0, m->nf - 1);
    h->ngroups = mdl__get_int(b, "groups", 1, m->nf);
    h->corr_group = mdl__get_ints(b, (size_t)h->ncorr, "correspondence groups", 0, h->ngroups - 1);
    h->group_parent = get_plus1(b, h->ngroups, "group tree", h->ngroups - 1);
    h->group_order = mdl__get_ints(b, (size_t)h->ngroups, "group order", 0, h->ngroups - 1);
    int nmk = m->rig ? m->rig->nmarkers : 0;
    h->nbones = mdl__get_int(b, "bones", 0, nmk ? h->ngroups : 0);
    if (!b->rc && h->nbones) {
        if (h->nbones != h->ngroups)
            mdl__rfail(b, "bones: not one per group");
        h->nmk = nmk;
        h->bone_a = mdl__get_ints(b, (size_t)h->nbones, "bone start markers", 0, nmk - 1);
        h->bone_b = mdl__get_ints(b, (size_t)h->nbones, "bone end markers", 0, nmk - 1);
        h->bone_c = get_plus1(b, h->nbones, "bone twist markers", nmk - 1);
        h->mk_rest = mdl__get_f32s(b, 3 * (size_t)nmk, "template rest pose");
        h->align_scale = mdl__get_f64(b, "alignment scale");
        for (int c = 0; c < 3; c++)
            h->align_t[c] = mdl__get_f64(b, "alignment translation");
        h->root_marker = mdl__get_int(b, "root marker", 0, nmk - 1);
        h->root_bone = mdl__get_int(b, "root bone", 0, h->nbones) - 1;
        h->anchor_vertex = mdl__get_int(b, "anchor vertex", 0, m->nv - 1);
        /* version 1 has no joints: every bone stays on the direction path */
        h->bone_j = mdl__calloc((size_t)h->nbones + 1, sizeof *h->bone_j);
        h->bone_jrest = mdl__calloc(4 * (size_t)h->nbones + 4, sizeof *h->bone_jrest);
        h->bone_fit = mdl__calloc(4 * (size_t)h->nbones + 4, sizeof *h->bone_fit);
        if (!h->bone_j || !h->bone_jrest || !h->bone_fit)
            b->rc = b->rc ? b->rc : -ENOMEM;
        for (int g = 0; !b->rc && g < h->nbones; g++) {
            h->bone_j[g] = -1;
            h->bone_jrest[4 * g] = h->bone_fit[4 * g] = 1;
            if (version < 2)
                continue;
            h->bone_j[g] = mdl__get_int(b, "bone joint", 0, nmk) - 1;
            for (int k = 0; k < 8; k++) {
                double x = mdl__get_f64(b, "bone joint rotations");
                if (!b->rc && !(fabs(x) <= 1.0 + 1e-6))
                    mdl__rfail(b, "bone joint rotations: not a unit quaternion");
                (k < 4 ? h->bone_jrest + 4 * g : h->bone_fit + 4 * g - 4)[k] = x;
            }
            if (!b->rc && (h->bone_j[g] != h->bone_a[g] && h->bone_j[g] != h->bone_b[g] &&
                           h->bone_j[g] != -1))
                mdl__rfail(b, "bone joint: neither of the bone's markers");
            mdl__qnorm(h->bone_jrest + 4 * g);
            mdl__qnorm(h->bone_fit + 4 * g);
        }
    }
    if (!b->rc) {
        /* the order visits every group once, each after its parent; the first is the root */
        uint8_t *done = mdl__calloc((size_t)h->ngroups, 1);
        if (!done)
            b->rc = -ENOMEM;
        for (int i = 0; !b->rc && i < h->ngroups; i++) {
            int g = h->group_order[i], p = h->group_parent[g];
            if (done[g] || (i == 0) != (p < 0) || (p >= 0 && !done[p]))
                mdl__rfail(b, "group tree: not a tree in parent-first order");
            done[g] = 1;
        }
        free(done);
    }
    if (b->rc) {
        mdl__harmonic_free(h);
        return b->rc;
    }
    *impl = h;
    return 0;
}

/* ------------------------------------------------------------------ summary, report, table */

static void harm_describe(const void *impl, const mdl_model *m, char *buf, size_t len, size_t *at)
{
    const struct mdl_harmonic *h = impl;
    mdl__appendf(buf, len, at, "harmonic   %d correspondence triangles in %d groups", h->ncorr, h->ngroups);
    if (h->auto_k)
        mdl__appendf(buf, len, at, " (auto:%d, no template)\n", h->auto_k);
    else
        mdl__appendf(buf, len, at, "\ntemplate   %d bones over %d markers, root %s, scale %.4f\n",
                     h->nbones, h->nmk, m->rig ? m->rig->markers[h->root_marker].name : "?",
                     h->align_scale);
    for (int g = 0; g < h->nbones && m->rig; g++) {
        int n = 0;
        for (int i = 0; i < h->ncorr; i++)
            n += h->corr_group[i] == g;
        mdl__appendf(buf, len, at, "  bone %-2d %s -> %s%s%s%s%s: %d triangles\n", g,
                     m->rig->markers[h->bone_a[g]].name, m->rig->markers[h->bone_b[g]].name,
                     h->bone_c[g] >= 0 ? ", twist " : "",
                     h->bone_c[g] >= 0 ? m->rig->markers[h->bone_c[g]].name : "",
                     h->bone_j[g] >= 0 ? ", joint " : "",
                     h->bone_j[g] >= 0 ? m->rig->markers[h->bone_j[g]].name : "", n);
    }
    mdl__appendf(buf, len, at, "triangles ");
    for (int i = 0; i < h->ncorr && *at < len; i++)
        mdl__appendf(buf, len, at, " %d", h->corr_tri[i]);
    mdl__appendf(buf, len, at, "\n");
}

static void harm_report(const void *impl, const mdl_model *m, void *obj)
{
    const struct mdl_harmonic *h = impl;
    cJSON *o = obj;
    (void)m;
    cJSON_AddNumberToObject(o, "correspondences", h->ncorr);
    cJSON_AddNumberToObject(o, "groups", h->ngroups);
    cJSON_AddNumberToObject(o, "bones", h->nbones);
    cJSON_AddNumberToObject(o, "auto_k", h->auto_k);
    cJSON_AddItemToObject(o, "correspondence_triangles", cJSON_CreateIntArray(h->corr_tri, h->ncorr));
    cJSON_AddItemToObject(o, "correspondence_groups", cJSON_CreateIntArray(h->corr_group, h->ncorr));
}

static void harm_info(const void *impl, mdl_model_info *info)
{
    const struct mdl_harmonic *h = impl;
    if (h->nbones == 0) {
        info->nmarkers = 0;
        info->markers = NULL;
    }
}

/* joints only when some bone has one (a template read from a skeleton: BVH, ASF/AMC) */
static unsigned harm_inputs(const void *impl)
{
    const struct mdl_harmonic *h = impl;
    for (int g = 0; g < h->nbones; g++)
        if (h->bone_j && h->bone_j[g] >= 0)
            return MDL_INPUT_MARKERS | MDL_INPUT_JOINTS;
    return MDL_INPUT_MARKERS;
}

static void harm_destroy(void *impl)
{
    mdl__harmonic_free(impl);
}

const mdl_kind_ops mdl__harmonic_kind = {
    .id = MDL_KIND_HARMONIC,
    .name = "harmonic",
    .tag = {'H', 'A', 'R', 'M'},
    .inputs = MDL_INPUT_MARKERS | MDL_INPUT_JOINTS,
    .inputs_of = harm_inputs,
    .destroy = harm_destroy,
    .save = harm_save,
    .parse = harm_parse,
    .info = harm_info,
    .describe = harm_describe,
    .report = harm_report,
    .synth_create = mdl__harmonic_synth_create,
    .synth_frame = mdl__harmonic_synth_frame,
    .synth_reset = mdl__harmonic_synth_reset,
    .synth_destroy = mdl__harmonic_synth_destroy,
    .synth_marker_placement = mdl__harmonic_synth_marker_placement,
    .eval = mdl__harmonic_eval,
};
