/* kind.c - the registry of model kinds and the kind-neutral calls of model.h (kind.h).
 *
 * A model is a mesh, an optional rig and up to MDL_MAX_KINDS kinds over that mesh; every call here
 * either reads the mesh and rig or forwards to the primary kind's (or a named kind's) table.
 */
#include "kind.h"
#include "core/util.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Every kind this build knows, in id order. A new kind adds its table here. */
static const mdl_kind_ops *const kinds[] = {&mdl__steer_kind, &mdl__harmonic_kind,
                                             &mdl__skin_kind};

const mdl_kind_ops *mdl__kind_ops(int id)
{
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++)
        if (kinds[i]->id == id)
            return kinds[i];
    return NULL;
}

const mdl_kind_ops *mdl__kind_ops_by_tag(const char tag[4])
{
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++)
        if (memcmp(kinds[i]->tag, tag, 4) == 0)
            return kinds[i];
    return NULL;
}

const char *mdl_kind_name(int kind)
{
    static const char *const names[] = {[MDL_KIND_STEER] = "steer", [MDL_KIND_HARMONIC] = "harmonic",
                                        [MDL_KIND_SKIN] = "skin"};
    return kind > 0 && kind < (int)(sizeof names / sizeof names[0]) ? names[kind] : NULL;
}

int mdl_kind_from_name(const char *name)
{
    for (int k = 1; mdl_kind_name(k); k++)
        if (name && strcmp(name, mdl_kind_name(k)) == 0)
            return k;
    return 0;
}

const mdl_kind_slot *mdl__model_kind(const mdl_model *m, int id)
{
    if (m->nkinds == 0)
        return NULL;
    if (id == 0)
        return &m->kinds[0];
    for (int i = 0; i < m->nkinds; i++)
        if (m->kinds[i].ops->id == id)
            return &m->kinds[i];
    return NULL;
}

/* ------------------------------------------------------------------ the model */

int mdl__rig_copy(const mdl_rig *src, mdl_rig **out, char *err)
{
    *out = NULL;
    mdl_rig *r = mdl__calloc(1, sizeof *r);
    if (!r)
        return mdl__err(err, -ENOMEM, "out of memory");
    *r = *src;
    size_t nidx = (size_t)src->limb_off[src->nlimbs];
    r->markers = mdl__calloc((size_t)src->nmarkers + 1, sizeof *r->markers);
    r->limb_off = mdl__calloc((size_t)src->nlimbs + 1, sizeof *r->limb_off);
    r->limb_idx = mdl__calloc(nidx + 1, sizeof *r->limb_idx);
    if (!r->markers || !r->limb_off || !r->limb_idx) {
        mdl_rig_destroy(r);
        return mdl__err(err, -ENOMEM, "out of memory");
    }
    memcpy(r->markers, src->markers, (size_t)src->nmarkers * sizeof *r->markers);
    memcpy(r->limb_off, src->limb_off, ((size_t)src->nlimbs + 1) * sizeof *r->limb_off);
    memcpy(r->limb_idx, src->limb_idx, nidx * sizeof *r->limb_idx);
    *out = r;
    return 0;
}

int mdl__model_create(const char *name, const float *rest, int nv, const uint32_t *F, int nf,
                      double fps, const float bbox_min[3], const float bbox_max[3],
                      const mdl_rig *rig, mdl_model **out, char *err)
{
    *out = NULL;
    mdl_model *m = mdl__calloc(1, sizeof *m);
    if (!m)
        return mdl__err(err, -ENOMEM, "out of memory");
    snprintf(m->name, sizeof m->name, "%s", name ? name : "");
    m->nv = nv;
    m->nf = nf;
    m->fps = fps;
    m->rest = mdl__calloc(3 * (size_t)nv, sizeof *m->rest);
    m->F = mdl__calloc(3 * (size_t)nf, sizeof *m->F);
    if (!m->rest || !m->F) {
        mdl_model_destroy(m);
        return mdl__err(err, -ENOMEM, "out of memory");
    }
    memcpy(m->rest, rest, 3 * (size_t)nv * sizeof *rest);
    memcpy(m->F, F, 3 * (size_t)nf * sizeof *F);
    m->topology = mdl_topology_fingerprint(F, nf, nv);
    if (bbox_min && bbox_max) {
        memcpy(m->bbox_min, bbox_min, sizeof m->bbox_min);
        memcpy(m->bbox_max, bbox_max, sizeof m->bbox_max);
    } else {
        for (int c = 0; c < 3; c++) {
            m->bbox_min[c] = INFINITY;
            m->bbox_max[c] = -INFINITY;
        }
        for (int v = 0; v < nv; v++)
            for (int c = 0; c < 3; c++) {
                m->bbox_min[c] = fminf(m->bbox_min[c], rest[3 * v + c]);
                m->bbox_max[c] = fmaxf(m->bbox_max[c], rest[3 * v + c]);
            }
    }
    int rc = rig ? mdl__rig_copy(rig, &m->rig, err) : 0;
    if (rc) {
        mdl_model_destroy(m);
        return rc;
    }
    *out = m;
    return 0;
}

int mdl__model_add_kind(mdl_model *m, const mdl_kind_ops *ops, void *impl, char *err)
{
    if (m->nkinds == MDL_MAX_KINDS || mdl__model_kind(m, ops->id)) {
        ops->destroy(impl);
        return mdl__err(err, -EEXIST, "model '%s': %s", m->name,
                        m->nkinds == MDL_MAX_KINDS ? "holds the most kinds a model may hold"
                                                   : "already holds a model of this kind");
    }
    m->kinds[m->nkinds].ops = ops;
    m->kinds[m->nkinds].impl = impl;
    m->nkinds++;
    return 0;
}

void mdl_model_destroy(mdl_model *m)
{
    if (!m)
        return;
    for (int i = 0; i < m->nkinds; i++)
        m->kinds[i].ops->destroy(m->kinds[i].impl);
    mdl_rig_destroy(m->rig);
    free(m->rest);
    free(m->F);
    free(m);
}

int mdl_model_merge(mdl_model *dst, mdl_model **srcp, char *err)
{
    mdl_model *src = *srcp;
    if (src->nv != dst->nv || src->nf != dst->nf || src->topology != dst->topology)
        return mdl__err(err, MDL_ETOPOLOGY,
                        "model '%s' (%d vertices, %d triangles) and '%s' (%d vertices, %d "
                        "triangles) are not over the same mesh",
                        dst->name, dst->nv, dst->nf, src->name, src->nv, src->nf);
    if (dst->nkinds + src->nkinds > MDL_MAX_KINDS)
        return mdl__err(err, -EEXIST, "model '%s': %d + %d kinds are more than a model holds (%d)",
                        dst->name, dst->nkinds, src->nkinds, MDL_MAX_KINDS);
    for (int i = 0; i < src->nkinds; i++)
        if (mdl__model_kind(dst, src->kinds[i].ops->id))
            return mdl__err(err, -EEXIST, "model '%s' already holds a %s model", dst->name,
                            src->kinds[i].ops->name);
    if (!dst->rig && src->rig) {
        dst->rig = src->rig;
        src->rig = NULL;
    }
    for (int i = 0; i < src->nkinds; i++)
        dst->kinds[dst->nkinds++] = src->kinds[i];
    src->nkinds = 0;
    mdl_model_destroy(src);
    *srcp = NULL;
    return 0;
}

void mdl_model_get_info(const mdl_model *m, mdl_model_info *info)
{
    memset(info, 0, sizeof *info);
    info->name = m->name;
    info->nkinds = m->nkinds;
    for (int i = 0; i < m->nkinds; i++)
        info->kinds[i] = m->kinds[i].ops->id;
    if (m->nkinds) {
        info->kind = m->kinds[0].ops->id;
        info->inputs = m->kinds[0].ops->inputs_of ? m->kinds[0].ops->inputs_of(m->kinds[0].impl)
                                                  : m->kinds[0].ops->inputs;
    }
    info->nv = m->nv;
    info->nf = m->nf;
    info->rest = m->rest;
    info->F = m->F;
    info->topology = m->topology;
    /* the rig's markers whatever the primary kind reads: another kind of the same model may be
     * driven by them, and its caller must know how many to pass */
    if (m->rig) {
        info->nmarkers = m->rig->nmarkers;
        info->markers = m->rig->markers;
    }
    info->fps = m->fps;
    memcpy(info->bbox_min, m->bbox_min, sizeof info->bbox_min);
    memcpy(info->bbox_max, m->bbox_max, sizeof info->bbox_max);
    if (m->nkinds && m->kinds[0].ops->info)
        m->kinds[0].ops->info(m->kinds[0].impl, info);
}

int mdl_model_bind_markers(const mdl_model *m, const char *const *names, int count, int *map)
{
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int missing = 0;
    for (int i = 0; i < info.nmarkers; i++) {
        map[i] = -1;
        for (int j = 0; j < count; j++)
            if (names[j] && strcmp(names[j], info.markers[i].source) == 0) {
                map[i] = j;
                break;
            }
        missing += map[i] < 0;
    }
    return missing;
}

int mdl_model_describe(const mdl_model *m, char *buf, size_t len)
{
    size_t at = 0;
    if (len)
        buf[0] = 0;
    mdl__appendf(buf, len, &at, "model      %s (file version %d)\n", m->name, 2);
    mdl__appendf(buf, len, &at, "kinds      ");
    for (int i = 0; i < m->nkinds; i++)
        mdl__appendf(buf, len, &at, "%s%s%s", i ? ", " : "", m->kinds[i].ops->name,
                     i == 0 && m->nkinds > 1 ? " (primary)" : "");
    mdl__appendf(buf, len, &at, "\nmesh       %d vertices, %d triangles, topology %016llx\n", m->nv,
                 m->nf, (unsigned long long)m->topology);
    for (int i = 0; i < m->nkinds; i++) {
        if (m->nkinds > 1)
            mdl__appendf(buf, len, &at, "-- %s\n", m->kinds[i].ops->name);
        if (m->kinds[i].ops->describe)
            m->kinds[i].ops->describe(m->kinds[i].impl, m, buf, len, &at);
    }
    return at < len ? 0 : -ENOSPC;
}

char *mdl_model_report_json(const mdl_model *m)
{
    cJSON *o = cJSON_CreateObject();
    if (!o)
        return NULL;
    cJSON_AddStringToObject(o, "model", m->name);
    cJSON_AddStringToObject(o, "kind", m->nkinds ? m->kinds[0].ops->name : "");
    cJSON_AddNumberToObject(o, "vertices", m->nv);
    cJSON_AddNumberToObject(o, "triangles", m->nf);
    for (int i = 0; i < m->nkinds; i++) {
        if (!m->kinds[i].ops->report)
            continue;
        if (i == 0) {
            m->kinds[i].ops->report(m->kinds[i].impl, m, o);
        } else {
            cJSON *sub = cJSON_AddObjectToObject(o, m->kinds[i].ops->name);
            if (sub)
                m->kinds[i].ops->report(m->kinds[i].impl, m, sub);
        }
    }
    char *js = cJSON_Print(o);
    cJSON_Delete(o);
    return js;
}

/* ------------------------------------------------------------------ synthesis */

int mdl_synth_create(const mdl_model *m, int kind, mdl_synth **out, char *err)
{
    *out = NULL;
    const mdl_kind_slot *k = mdl__model_kind(m, kind);
    if (!k)
        return mdl__err(err, -ENOENT, "model '%s' holds no %s model", m->name,
                        kind ? (mdl_kind_name(kind) ? mdl_kind_name(kind) : "such") : "");
    mdl_synth *s = mdl__calloc(1, sizeof *s);
    if (!s)
        return mdl__err(err, -ENOMEM, "synthesis: out of memory");
    s->ops = k->ops;
    s->inputs = k->ops->inputs_of ? k->ops->inputs_of(k->impl) : k->ops->inputs;
    int rc = k->ops->synth_create(m, k->impl, &s->state, err);
    if (rc) {
        free(s);
        return rc;
    }
    *out = s;
    return 0;
}

void mdl_synth_destroy(mdl_synth *s)
{
    if (!s)
        return;
    s->ops->synth_destroy(s->state);
    free(s);
}

unsigned mdl_synth_inputs(const mdl_synth *s)
{
    return s->inputs;
}

int mdl_synth_frame(mdl_synth *s, const mdl_synth_input *in, float *V, mdl_synth_info *info)
{
    return s->ops->synth_frame(s->state, in, V, info);
}

int mdl_synth_markers(mdl_synth *s, const float *markers, const uint8_t *valid, float *V,
                      mdl_synth_info *info)
{
    mdl_synth_input in = {.markers = markers, .valid = valid};
    return s->ops->synth_frame(s->state, &in, V, info);
}

int mdl_synth_params_layout(const mdl_synth *s, mdl_params_layout *out)
{
    memset(out, 0, sizeof *out);
    if (!s->ops->synth_params_layout)
        return -ENOTSUP;
    int rc = s->ops->synth_params_layout(s->state, out);
    out->kind = s->ops->id;
    return rc;
}

void mdl_synth_marker_placement(const mdl_synth *s, double *scale, double t[3])
{
    *scale = 1;
    t[0] = t[1] = t[2] = 0;
    if (s->ops->synth_marker_placement)
        s->ops->synth_marker_placement(s->state, scale, t);
}

int mdl_synth_params(const mdl_synth *s, float *out)
{
    return s->ops->synth_params ? s->ops->synth_params(s->state, out) : -ENOTSUP;
}

void mdl_synth_reset(mdl_synth *s)
{
    s->ops->synth_reset(s->state);
}

/* ------------------------------------------------------------------ evaluation */

int mdl_eval_run(const mdl_model *m, const mdl_meshseq *seq, const int *frames, int n,
                 const mdl_eval_opts *o, mdl_eval_result *r, char *err)
{
    memset(r, 0, sizeof *r);
    if (!m->nkinds || !m->kinds[0].ops->eval)
        return mdl__err(err, -ENOTSUP, "model '%s': its kind (%s) has no evaluation", m->name,
                        m->nkinds ? m->kinds[0].ops->name : "none");
    return m->kinds[0].ops->eval(m, seq, frames, n, o, r, err);
}

void mdl_eval_result_fini(mdl_eval_result *r)
{
    free(r->synth_us);
    free(r->frame_err);
    free(r->baseline_frame_err);
    memset(r, 0, sizeof *r);
}
