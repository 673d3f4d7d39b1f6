/* pipeline.c - source thread -> synthesis thread -> latest frame (see pipeline.h). */
#include "srv_err.h"
#include "pipeline.h"
#include "daemon_config.h"
#include "labels.h"
#include "log.h"
#include "record.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SLOT_COUNT 2
#define SOURCE_TIMEOUT_MS 50

typedef struct slot {
    uint64_t t_capture_us;
    float *xyz;
    uint8_t *valid;
    float *jrot;       /* count x 4 when the source gives joint rotations, else NULL */
    uint8_t *jvalid;   /* count, likewise */
} slot;

typedef struct ctl_entry {
    uint64_t tag;
    srv_control c;
} ctl_entry;

/* A control's reply on its way back. An ack waits until the frames made from markers the source
 * read before the control have been published (`after`: the source frames written by then), so
 * that it can name the newest of them (its "seq") and a client knows which frames follow it. */
typedef struct ctl_pending {
    srv_ctl_result r;
    srv_control c;
    uint64_t after;
    int waiting;
} ctl_pending;

struct srv_pipeline {
    drv_source *src;
    srv_source_info si;            /* what other threads may read of the source */
    atomic_uint controls;          /* SRV_CTL_BIT()s the source accepts now (changes on reopen) */
    atomic_int idle_on;            /* the idle synthesis drives the output */
    atomic_int paused;             /* a client paused the source: no frames, but someone is there */
    uint64_t idle_after_us, fade_us; /* srv_pipeline_set_idle */
    uint64_t fade_start_us;        /* synthesis thread: start of the cross-fade back, 0 if none */
    uint64_t t_start_us;           /* synthesis thread: the clock of clock-driven kinds */
    srv_metrics *m;
    void (*wake)(void *);
    void *wake_ud;
    srv_recorder *rec;

    pthread_t source_thread, synth_thread;
    pthread_t usb_thread;          /* depth sources: watches USB for the sensor coming and going */
    drv_device_watch *usb;
    atomic_int device_hint;        /* a depth sensor arrived: reopen a lost source now */
    int started;
    atomic_int stop;
    atomic_int src_state;
    atomic_int reset_synth;

    /* newest marker frames: written by the source thread, taken by the synthesis thread */
    pthread_mutex_t slot_lock;
    pthread_cond_t slot_cond;
    slot slots[SLOT_COUNT];
    uint64_t written, taken; /* frames written / position up to which they were taken */
    uint64_t settled; /* position up to which the taken frames are published: synthesis thread */

    /* publication: under pub */
    pthread_mutex_t pub;
    srv_bundle cur;       /* the synthesis thread's bundle; cur.gen is the current generation */
    srv_bundle pending;   /* offered by a reload, swapped in by the synthesis thread */
    srv_frame *latest;
    uint64_t seq;

    /* controls and their results: under ctl_lock */
    pthread_mutex_t ctl_lock;
    ctl_entry ctl[SRV_CTL_QUEUE];
    int nctl;
    ctl_pending res[SRV_CTL_QUEUE];
    int res_head, nres;

    /* reload */
    pthread_t reload_thread;
    atomic_int reload_state; /* 0 idle, 1 running, 2 finished (join pending) */
    int reload_ok;
    char reload_err[SRV_ERR_LEN];
    char reload_path[SRV_PATH_LEN];
    char reload_labels[SRV_LABELS_MAX_LEN];
    atomic_uint next_gen;

    /* synthesis health (synth_health): the run of frames synthesis refused, by the synthesis
     * thread; degraded and its reason (under pub) for /healthz */
    uint64_t fail_run, fail_logged_us;
    atomic_int degraded;
    char degraded_why[160];
};

uint64_t srv_now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* ------------------------------------------------------------------ bundles */

void srv_bundle_fini(srv_bundle *b)
{
    if (!b)
        return;
    mdl_synth_destroy(b->synth);
    mdl_synth_destroy(b->idle);
    mdl_model_destroy(b->model);
    srv_gen_unref(b->gen);
    free(b->map);
    free(b->jr);
    free(b->jv);
    free(b->V);
    free(b->V_idle);
    free(b->mk);
    free(b->mv);
    free(b->prm);
    memset(b, 0, sizeof *b);
}

unsigned srv_controls_of_source(unsigned drv_controls)
{
    unsigned c = 0;
    if (drv_controls & DRV_CTL_PAUSE)
        c |= SRV_CTL_BIT(SRV_CTL_PAUSE) | SRV_CTL_BIT(SRV_CTL_RESUME);
    if (drv_controls & DRV_CTL_SEEK)
        c |= SRV_CTL_BIT(SRV_CTL_SEEK);
    if (drv_controls & DRV_CTL_SPEED)
        c |= SRV_CTL_BIT(SRV_CTL_SPEED);
    return c;
}

int srv_source_info_init(srv_source_info *si, const drv_source *src, const char *spec, char *err)
{
    memset(si, 0, sizeof *si);
    snprintf(si->spec, sizeof si->spec, "%s", spec ? spec : "");
    snprintf(si->scheme, sizeof si->scheme, "%s", src->ops->scheme);
    si->count = src->count;
    si->fps = src->fps;
    si->frames = src->frames;
    si->caps = src->caps;
    si->joints = src->joints;
    si->controls = src->ops->control ? srv_controls_of_source(src->controls) : 0;
    si->names = calloc((size_t)src->count + 1, sizeof *si->names);
    for (int i = 0; si->names && i < src->count; i++)
        if (!(si->names[i] = strdup(src->names[i] ? src->names[i] : ""))) {
            srv_source_info_fini(si);
            break;
        }
    if (!si->names)
        return srv_err(err, -ENOMEM, "source: out of memory");
    return 0;
}

void srv_source_info_fini(srv_source_info *si)
{
    if (si->names)
        for (int i = 0; i < si->count; i++)
            free(si->names[i]);
    free(si->names);
    memset(si, 0, sizeof *si);
}

static void warn_labels(void *ud, const char *msg)
{
    srv_log(SRV_LOG_WARN, "model %s: labels: %s", (const char *)ud, msg);
}

/* Binds the model's markers to the source's labels through the label map; fills b->map and the
 * hello's view of it (lookup, bound: lookup[] may point into the label map, which the caller frees
 * with srv_labels_destroy once the generation has copied them). Logs what stays unbound. */
static int bind_markers(srv_bundle *b, const mdl_model_info *info, const char *model_path,
                        const char *labels, const srv_source_info *src, const char **lookup,
                        uint8_t *bound, srv_labels **lmap_out, char *err)
{
    char e[MDL_ERR_LEN] = "";
    srv_labels *lmap = NULL;
    int r = srv_labels_create(labels, &lmap, e); /* validated with the settings already */
    if (r)
        return srv_err(err, r, "labels: %s", e);
    *lmap_out = lmap;
    r = srv_labels_bind(lmap, info, (const char *const *)src->names, src->count, b->map,
                        warn_labels, (void *)model_path);
    int nbound = 0;
    for (int i = 0; r >= 0 && i < info->nmarkers; i++)
        nbound += b->map[i] >= 0 && b->map[i] < src->count;
    if (r < 0 || nbound == 0)
        return srv_err(err, r < 0 ? r : -ENOENT,
                       "model %s: none of its %d markers is among the source's %d markers "
                       "(the rig's 'source' names must match the marker labels, or be mapped to "
                       "them with --labels / 'labels = MODEL=LABEL,...')",
                       model_path, info->nmarkers, src->count);
    if (nbound < info->nmarkers) {
        char names[512];
        size_t at = 0;
        names[0] = '\0';
        for (int i = 0; i < info->nmarkers && at < sizeof names; i++)
            if (b->map[i] < 0) {
                int w = snprintf(names + at, sizeof names - at, "%s%s", at ? ", " : "",
                                 srv_labels_lookup(lmap, info->markers[i].source));
                at += w > 0 ? (size_t)w : 0;
            }
        srv_log(SRV_LOG_WARN, "model %s: %d of %d markers are not in the source (%s); they count "
                "as missing", model_path, info->nmarkers - nbound, info->nmarkers, names);
    }
    /* the live label each marker is bound to, or looks up in vain, for the hello */
    for (int i = 0; i < info->nmarkers; i++) {
        bound[i] = b->map[i] >= 0;
        lookup[i] = b->map[i] >= 0 ? src->names[b->map[i]]
                                   : srv_labels_lookup(lmap, info->markers[i].source);
    }
    return 0;
}

/* The idle synthesis: the first clock-driven kind of the model other than the primary one. */
static int create_idle(srv_bundle *b, const mdl_model_info *info, const char *model_path,
                       char *err)
{
    if (!(b->inputs & MDL_INPUT_MARKERS))
        return 0; /* the primary kind already runs on the clock */
    for (int k = 1; k < info->nkinds; k++) {
        char e[MDL_ERR_LEN] = "";
        mdl_synth *s = NULL;
        int r = mdl_synth_create(b->model, info->kinds[k], &s, e);
        if (r)
            return srv_err(err, r, "model %s: idle synthesis (%s): %s", model_path,
                           mdl_kind_name(info->kinds[k]), e);
        if (mdl_synth_inputs(s) & MDL_INPUT_CLOCK && !(mdl_synth_inputs(s) & MDL_INPUT_MARKERS)) {
            b->idle = s;
            srv_log(SRV_LOG_NOTICE, "model %s: its %s model drives the mesh when no one is "
                    "tracked", model_path, mdl_kind_name(info->kinds[k]));
            return 0;
        }
        mdl_synth_destroy(s);
    }
    return 0;
}

int srv_pipeline_load(const char *model_path, const char *labels, const srv_source_info *src,
                      uint32_t id, srv_bundle *out, char *err)
{
    memset(out, 0, sizeof *out);
    char e[MDL_ERR_LEN] = "";
    int r = mdl_model_load(model_path, &out->model, e);
    if (r)
        return srv_err(err, r, "model: %s", e);
    mdl_model_info info;
    mdl_model_get_info(out->model, &info);
    r = mdl_synth_create(out->model, 0, &out->synth, e);
    if (r) {
        srv_bundle_fini(out);
        return srv_err(err, r, "model %s: synthesis: %s", model_path, e);
    }
    out->inputs = mdl_synth_inputs(out->synth);
    mdl_synth_marker_placement(out->synth, &out->mk_scale, out->mk_t);
    out->clock_fps = info.fps > 0 && info.fps <= 240 ? info.fps : 30;
    out->nm = info.inputs & MDL_INPUT_MARKERS ? info.nmarkers : 0;
    size_t nm1 = (size_t)out->nm + 1;
    out->map = calloc(nm1, sizeof *out->map);
    out->V = calloc((size_t)info.nv * 3, sizeof(float));
    out->mk = calloc(nm1 * 3, sizeof(float));
    out->mv = calloc(nm1, 1);
    const char **lookup = calloc(nm1, sizeof *lookup);
    uint8_t *bound = calloc(nm1, 1);
    srv_labels *lmap = NULL;
    out->joints = src->joints && (out->inputs & MDL_INPUT_JOINTS) && out->nm > 0;
    if (out->joints) {
        out->jr = calloc(nm1 * 4, sizeof(float));
        out->jv = calloc(nm1, 1);
    }
    if (!out->map || !out->V || !out->mk || !out->mv || !lookup || !bound ||
        (out->joints && (!out->jr || !out->jv))) {
        r = srv_err(err, -ENOMEM, "model %s: out of memory", model_path);
        goto fail;
    }
    memcpy(out->V, info.rest, (size_t)info.nv * 3 * sizeof(float)); /* the pose before any */
    if (out->nm > 0) {
        r = bind_markers(out, &info, model_path, labels, src, lookup, bound, &lmap, err);
        if (r)
            goto fail;
    } else if (labels && labels[0]) {
        srv_log(SRV_LOG_WARN, "model %s: its %s model reads no markers; --labels is ignored",
                model_path, mdl_kind_name(info.kind));
    }
    if (out->joints)
        srv_log(SRV_LOG_NOTICE, "model %s: its bones turn with the source's joint rotations "
                "(twist included)", model_path);
    else if (out->inputs & MDL_INPUT_JOINTS)
        srv_log(SRV_LOG_NOTICE, "model %s: the source gives no joint rotations: its bones turn by "
                "their markers' directions (the twist about a bone without a twist marker is lost)",
                model_path);
    if ((r = create_idle(out, &info, model_path, err)))
        goto fail;
    if (out->idle && !(out->V_idle = calloc((size_t)info.nv * 3, sizeof(float)))) {
        r = srv_err(err, -ENOMEM, "model %s: out of memory", model_path);
        goto fail;
    }
    srv_source_desc desc = {
        .spec = src->spec,
        .scheme = src->scheme,
        .fps = src->fps,
        .frames = src->frames,
        .count = src->count,
        .names = (const char *const *)src->names,
        .controls = src->controls,
        .lookup = lookup,
        .bound = bound,
        .idle = out->idle != NULL,
    };
    info.nmarkers = out->nm; /* the hello lists the markers the model is driven by */
    /* the compact forms (the params encoding): the primary kind's, then the idle kind's */
    mdl_params_layout lay[SRV_PARAMS_MAX_LAYOUTS];
    int nlay = 0, most = 1;
    out->layout_synth = out->layout_idle = -1;
    if (mdl_synth_params_layout(out->synth, &lay[nlay]) == 0)
        out->layout_synth = nlay++;
    if (out->idle && mdl_synth_params_layout(out->idle, &lay[nlay]) == 0)
        out->layout_idle = nlay++;
    for (int l = 0; l < nlay; l++)
        most = lay[l].nparams > most ? lay[l].nparams : most;
    out->prm = calloc((size_t)most, sizeof *out->prm);
    if (!out->prm) {
        r = srv_err(err, -ENOMEM, "model %s: out of memory", model_path);
        goto fail;
    }
    r = srv_gen_create_params(&info, &desc, id, lay, nlay, &out->gen, e);
    if (r) {
        r = srv_err(err, r, "model %s: %s", model_path, e);
        goto fail;
    }
    free(lookup);
    free(bound);
    srv_labels_destroy(lmap);
    return 0;
fail:
    free(lookup);
    free(bound);
    srv_labels_destroy(lmap);
    srv_bundle_fini(out);
    return r;
}

/* ------------------------------------------------------------------ creation */

int srv_pipeline_create(drv_source *src, srv_source_info *si, srv_bundle *b, srv_metrics *m,
                        const char *record, void (*wake)(void *), void *wake_ud,
                        srv_pipeline **out, char *err)
{
    *out = NULL;
    srv_pipeline *p = calloc(1, sizeof *p);
    if (!p)
        return srv_err(err, -ENOMEM, "pipeline: out of memory");
    p->src = src;
    atomic_init(&p->controls, si->controls);
    srv_pipeline_set_idle(p, 2.0, 0.5);
    p->m = m;
    p->wake = wake;
    p->wake_ud = wake_ud;
    pthread_mutex_init(&p->slot_lock, NULL);
    pthread_cond_init(&p->slot_cond, NULL);
    pthread_mutex_init(&p->pub, NULL);
    pthread_mutex_init(&p->ctl_lock, NULL);
    atomic_init(&p->next_gen, b->gen->id + 1);
    atomic_init(&p->src_state, src->state);
    for (int k = 0; k < SLOT_COUNT; k++) {
        p->slots[k].xyz = calloc((size_t)src->count * 3, sizeof(float));
        p->slots[k].valid = calloc((size_t)src->count, 1);
        if (si->joints) {
            p->slots[k].jrot = calloc((size_t)src->count * 4, sizeof(float));
            p->slots[k].jvalid = calloc((size_t)src->count, 1);
        }
        if (!p->slots[k].xyz || !p->slots[k].valid ||
            (si->joints && (!p->slots[k].jrot || !p->slots[k].jvalid))) {
            p->src = NULL; /* on failure the caller keeps the source and the bundle */
            srv_pipeline_destroy(p);
            return srv_err(err, -ENOMEM, "pipeline: out of memory");
        }
    }
    if (record && *record) {
        int r = srv_recorder_create(record, src->count, (const char *const *)src->names, src->fps,
                                    &p->rec, err);
        if (r) {
            p->src = NULL;
            srv_pipeline_destroy(p);
            return r;
        }
    }
    p->cur = *b;
    memset(b, 0, sizeof *b);
    p->si = *si;
    memset(si, 0, sizeof *si);
    *out = p;
    return 0;
}

/* ------------------------------------------------------------------ the source thread */

/* Queues a reply: an error now, an ack (ack != NULL: the control) once the synthesis thread has
 * settled the source frames written so far (settle_acks). The order of locks: ctl_lock, then
 * slot_lock or pub; settle_acks takes them one after the other, so an ack queued as waiting is
 * always seen by the settle_acks call that passes it. */
static void push_result(srv_pipeline *p, uint64_t tag, const char *reply, size_t len,
                        const srv_control *ack)
{
    pthread_mutex_lock(&p->ctl_lock);
    if (p->nres < SRV_CTL_QUEUE) {
        ctl_pending *e = &p->res[(p->res_head + p->nres) % SRV_CTL_QUEUE];
        e->r.tag = tag;
        e->waiting = 0;
        if (ack) {
            e->c = *ack;
            pthread_mutex_lock(&p->slot_lock);
            e->after = p->written;
            e->waiting = p->settled < e->after;
            pthread_mutex_unlock(&p->slot_lock);
            if (!e->waiting) { /* all out, and no newer frame before the source reads again */
                pthread_mutex_lock(&p->pub);
                uint64_t seq = p->seq;
                pthread_mutex_unlock(&p->pub);
                e->r.len = srv_reply_ack(e->r.reply, ack, (int64_t)seq);
            }
        } else {
            e->r.len = len < SRV_REPLY_LEN ? len : SRV_REPLY_LEN - 1;
            memcpy(e->r.reply, reply, e->r.len);
            e->r.reply[e->r.len] = '\0';
        }
        p->nres++;
    }
    pthread_mutex_unlock(&p->ctl_lock);
}

/* By the synthesis thread after it dealt with the source frames up to `upto` (take_slot's
 * position): the acks waiting for frames up to there get their seq, the newest frame made from
 * markers read before the control. That is seq_after (after this step's frame) when the step's
 * markers were the last ones before the control, else seq_before (the step's markers came after
 * it; the ones before were superseded and never synthesised). */
static void settle_acks(srv_pipeline *p, uint64_t upto, uint64_t seq_before, uint64_t seq_after)
{
    pthread_mutex_lock(&p->slot_lock);
    p->settled = upto;
    pthread_mutex_unlock(&p->slot_lock);
    int woke = 0;
    pthread_mutex_lock(&p->ctl_lock);
    for (int i = 0; i < p->nres; i++) {
        ctl_pending *e = &p->res[(p->res_head + i) % SRV_CTL_QUEUE];
        if (!e->waiting || e->after > upto)
            continue;
        e->r.len = srv_reply_ack(e->r.reply, &e->c, (int64_t)(e->after == upto ? seq_after
                                                                                 : seq_before));
        e->waiting = 0;
        woke = 1;
    }
    pthread_mutex_unlock(&p->ctl_lock);
    if (woke)
        p->wake(p->wake_ud);
}

/* A control kind as the source takes it: its DRV_CTL_* bit and value. */
static unsigned drv_control_of(const srv_control *c, double *value)
{
    switch (c->kind) {
    case SRV_CTL_PAUSE: *value = 1; return DRV_CTL_PAUSE;
    case SRV_CTL_RESUME: *value = 0; return DRV_CTL_PAUSE;
    case SRV_CTL_SEEK: *value = c->value; return DRV_CTL_SEEK;
    case SRV_CTL_SPEED: *value = c->value; return DRV_CTL_SPEED;
    }
    return 0;
}

static void apply_controls(srv_pipeline *p)
{
    ctl_entry q[SRV_CTL_QUEUE];
    pthread_mutex_lock(&p->ctl_lock);
    int n = p->nctl;
    memcpy(q, p->ctl, sizeof(ctl_entry) * (size_t)n);
    p->nctl = 0;
    pthread_mutex_unlock(&p->ctl_lock);
    for (int i = 0; i < n; i++) {
        const srv_control *c = &q[i].c;
        double v = 0;
        unsigned ctl = drv_control_of(c, &v);
        char e[DRV_ERR_LEN] = "";
        char reply[SRV_REPLY_LEN];
        size_t len;
        int r = drv_source_control(p->src, ctl, v, e);
        if (r == 0) {
            if (ctl == DRV_CTL_SEEK)
                atomic_store(&p->reset_synth, 1);
            if (ctl == DRV_CTL_PAUSE)
                atomic_store(&p->paused, v != 0);
            srv_metrics_count(&p->m->control_ok, 1);
            srv_log(SRV_LOG_INFO, "source control %s %g", srv_control_name(c->kind), v);
            push_result(p, q[i].tag, NULL, 0, c);
        } else {
            len = srv_reply_error(reply, r == -ENOTSUP ? "unsupported" : "source_error", e, c);
            srv_metrics_count(&p->m->control_errors, 1);
            srv_log(SRV_LOG_INFO, "source control %s %g refused: %s", srv_control_name(c->kind), v,
                    e);
            push_result(p, q[i].tag, reply, len, NULL);
        }
    }
    if (n)
        p->wake(p->wake_ud);
}

static void mirror_osc_counts(srv_osc_metrics *m, const drv_osc_counts *c)
{
    srv_metrics_set(&m->packets, c->packets);
    srv_metrics_set(&m->malformed, c->malformed);
    srv_metrics_set(&m->messages, c->messages);
    srv_metrics_set(&m->bad_messages, c->bad_messages);
    srv_metrics_set(&m->unknown_names, c->unknown_names);
    srv_metrics_set(&m->ignored, c->ignored);
    srv_metrics_set(&m->frames, c->frames);
    srv_metrics_set(&m->coalesced, c->coalesced);
}

static void *source_main(void *arg)
{
    srv_pipeline *p = arg;
    drv_source *s = p->src;
    float *xyz = calloc((size_t)s->count * 3, sizeof(float));
    uint8_t *valid = calloc((size_t)s->count, 1);
    /* the joints block, sized here once (a skeleton file's replay) */
    int joints = p->si.joints;
    float *jrot = joints ? calloc((size_t)s->count * 4, sizeof(float)) : NULL;
    uint8_t *jvalid = joints ? calloc((size_t)s->count, 1) : NULL;
    char e[DRV_ERR_LEN];
    int last_state = -1;
    drv_osc_counts oc;
    int osc = drv_osc_counts_get(s, &oc) == 0; /* an osc: source: its counters go to /metrics */
    atomic_store(&p->m->osc.present, osc);
    while (xyz && valid && (!joints || (jrot && jvalid)) && !atomic_load(&p->stop)) {
        apply_controls(p);
        drv_frame f = {.count = s->count, .xyz = xyz, .valid = valid, .joint_rot = jrot,
                       .joint_valid = jvalid};
        int r = drv_source_read(s, &f, SOURCE_TIMEOUT_MS, e);
        if (osc && drv_osc_counts_get(s, &oc) == 0)
            mirror_osc_counts(&p->m->osc, &oc);
        if ((int)s->state != last_state) {
            last_state = (int)s->state;
            atomic_store(&p->src_state, last_state);
            srv_log(SRV_LOG_NOTICE, "source %s", drv_state_name(s->state));
        }
        if (r == 0) {
            srv_metrics_count(&p->m->frames_in, 1);
            if (p->rec && srv_recorder_add(p->rec, xyz, valid) == -ENOMEM &&
                srv_recorder_frames(p->rec) > 0 && srv_recorder_frames(p->rec) % 1024 == 0)
                srv_log(SRV_LOG_WARN, "record: out of memory, recording stopped");
            pthread_mutex_lock(&p->slot_lock);
            slot *sl = &p->slots[p->written % SLOT_COUNT];
            memcpy(sl->xyz, xyz, (size_t)s->count * 3 * sizeof(float));
            memcpy(sl->valid, valid, (size_t)s->count);
            if (joints) {
                memcpy(sl->jrot, jrot, (size_t)s->count * 4 * sizeof(float));
                memcpy(sl->jvalid, jvalid, (size_t)s->count);
            }
            sl->t_capture_us = f.t_capture_us;
            p->written++;
            pthread_cond_signal(&p->slot_cond);
            pthread_mutex_unlock(&p->slot_lock);
        } else if (r == DRV_ETIMEOUT) {
            continue;
        } else if (r == DRV_ELOST) {
            /* the device went away: clients keep the last pose; try to open it again once a
             * second, so that the daemon recovers by itself when the device returns */
            for (int i = 0; i < 10 && !atomic_load(&p->stop) && !atomic_exchange(&p->device_hint, 0);
                 i++) {
                struct timespec ts = {0, 100 * 1000000L};
                nanosleep(&ts, NULL);
            }
            if (atomic_load(&p->stop))
                break;
            if (drv_source_reopen(s, p->si.spec, e) == 0 && drv_source_start(s, e) == 0) {
                /* the one field of the source that may differ after a reopen */
                atomic_store(&p->controls, s->ops->control ? srv_controls_of_source(s->controls) : 0);
                srv_log(SRV_LOG_NOTICE, "source %s: the device is back", p->si.spec);
            } else {
                srv_log(SRV_LOG_DEBUG, "source %s: still lost: %s", p->si.spec, e);
            }
        } else if (r == DRV_EEOF) {
            struct timespec ts = {0, 50 * 1000000L}; /* wait for a seek (or the end) */
            nanosleep(&ts, NULL);
        } else {
            srv_metrics_count(&p->m->drops[SRV_DROP_SOURCE_ERROR], 1);
            srv_log(SRV_LOG_WARN, "source: %s", e);
            struct timespec ts = {0, 100 * 1000000L};
            nanosleep(&ts, NULL);
        }
    }
    free(xyz);
    free(valid);
    free(jrot);
    free(jvalid);
    return NULL;
}

/* ------------------------------------------------------------------ the synthesis thread */

/* 1 when a pending generation was swapped in. */
static int swap_pending(srv_pipeline *p)
{
    srv_bundle old = {0};
    pthread_mutex_lock(&p->pub);
    if (p->pending.gen) {
        old = p->cur;
        p->cur = p->pending;
        memset(&p->pending, 0, sizeof p->pending);
    }
    pthread_mutex_unlock(&p->pub);
    if (old.gen) {
        srv_log(SRV_LOG_NOTICE, "model generation %u (%s, %d vertices) now serving", p->cur.gen->id,
                p->cur.gen->name, p->cur.gen->nv);
        srv_bundle_fini(&old); /* frames still held by clients keep their generation alive */
        p->wake(p->wake_ud);
        return 1;
    }
    return 0;
}

/* After each synthesis step (r its result): a run of refused frames (no reference marker was
 * ever valid, e.g. a source whose every marker is invalid) makes the pipeline degraded with the
 * reason, logged at its start and then at most every 10 s; the first good frame ends it. The
 * refused frames still go out with the last good pose (the rest pose before any), flagged
 * reference lost, so clients see that the source is there but not tracked. */
#define SYNTH_DEGRADED_AFTER 3
#define SYNTH_LOG_EVERY_US 10000000u

static void synth_health(srv_pipeline *p, const srv_bundle *b, int r)
{
    if (r == 0) {
        if (p->fail_run >= SYNTH_DEGRADED_AFTER)
            srv_log(SRV_LOG_NOTICE, "synthesis works again after %llu refused frames",
                    (unsigned long long)p->fail_run);
        p->fail_run = 0;
        atomic_store(&p->degraded, 0);
        return;
    }
    srv_metrics_count(&p->m->drops[SRV_DROP_SYNTH_FAILED], 1);
    srv_log(SRV_LOG_DEBUG, "synthesis refused a frame (%d)", r);
    if (++p->fail_run < SYNTH_DEGRADED_AFTER)
        return;
    int valid = 0;
    for (int i = 0; i < b->nm; i++)
        valid += b->mv[i];
    uint64_t now = srv_now_us();
    if (p->fail_run == SYNTH_DEGRADED_AFTER || now - p->fail_logged_us >= SYNTH_LOG_EVERY_US) {
        pthread_mutex_lock(&p->pub);
        snprintf(p->degraded_why, sizeof p->degraded_why,
                 "synthesis refuses every frame: the model's reference markers were never valid "
                 "(%d of %d model markers valid)", valid, b->nm);
        pthread_mutex_unlock(&p->pub);
        srv_log(SRV_LOG_WARN, "%llu frames in a row: %s; %s (check the source and --labels)",
                (unsigned long long)p->fail_run, p->degraded_why,
                b->idle ? "the idle animation takes over" : "sending the last good pose");
        p->fail_logged_us = now;
    }
    atomic_store(&p->degraded, 1);
}

int srv_pipeline_degraded(srv_pipeline *p, char *why, size_t n)
{
    if (!atomic_load(&p->degraded))
        return 0;
    pthread_mutex_lock(&p->pub);
    snprintf(why, n, "%s", p->degraded_why);
    pthread_mutex_unlock(&p->pub);
    return 1;
}

/* Publishes b->V (and the model-ordered markers b->mk, b->mv) as the newest frame, with the
 * compact form of synthesis s (the one that made b->V: its last frame) where it has one. */
static void publish(srv_pipeline *p, srv_bundle *b, const mdl_synth *s, uint64_t t_capture,
                    uint64_t t0, int flags, int missing)
{
    srv_frame *f = srv_gen_free_frame(b->gen);
    if (!f) { /* cannot happen with SRV_POOL >= 3; count it rather than trust it */
        srv_metrics_count(&p->m->drops[SRV_DROP_SYNTH_BUSY], 1);
        return;
    }
    uint64_t t1 = srv_now_us();
    srv_frame_encode(f, p->seq + 1, t_capture, t1, b->V, b->mk, b->mv, flags, missing);
    int layout = s == b->synth ? b->layout_synth : s && s == b->idle ? b->layout_idle : -1;
    if (layout >= 0 && mdl_synth_params(s, b->prm) == 0)
        srv_frame_encode_params(f, layout, b->prm);
    uint64_t t2 = srv_now_us();
    srv_hist_observe(&p->m->synth, t2 - t0);
    srv_frame_ref(f);
    pthread_mutex_lock(&p->pub);
    srv_frame *old = p->latest;
    p->latest = f;
    p->seq++;
    pthread_mutex_unlock(&p->pub);
    srv_frame_unref(old);
    srv_metrics_count(&p->m->frames_synth, 1);
    p->wake(p->wake_ud);
}

/* Waits for a source frame newer than the last one taken, until deadline_us (CLOCK_MONOTONIC) or
 * stop, and copies it. Returns 1 with a frame and *upto the count of source frames it covers (it
 * supersedes those before it), 0 without. */
static int take_slot(srv_pipeline *p, uint64_t deadline_us, float *xyz, uint8_t *valid,
                     float *jrot, uint8_t *jvalid, uint64_t *t_capture, uint64_t *upto)
{
    int count = p->si.count;
    pthread_mutex_lock(&p->slot_lock);
    while (p->written == p->taken && !atomic_load(&p->stop)) {
        uint64_t now = srv_now_us();
        if (now >= deadline_us)
            break;
        /* the condition variable waits on CLOCK_REALTIME: a relative wait of what is left */
        uint64_t left = deadline_us - now;
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_sec += (time_t)(left / 1000000u);
        ts.tv_nsec += (long)(left % 1000000u) * 1000L;
        if (ts.tv_nsec >= 1000000000L) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&p->slot_cond, &p->slot_lock, &ts);
    }
    if (p->written == p->taken || atomic_load(&p->stop)) {
        pthread_mutex_unlock(&p->slot_lock);
        return 0;
    }
    uint64_t skipped = p->written - p->taken - 1;
    const slot *sl = &p->slots[(p->written - 1) % SLOT_COUNT];
    memcpy(xyz, sl->xyz, (size_t)count * 3 * sizeof(float));
    memcpy(valid, sl->valid, (size_t)count);
    if (sl->jrot && jrot) {
        memcpy(jrot, sl->jrot, (size_t)count * 4 * sizeof(float));
        memcpy(jvalid, sl->jvalid, (size_t)count);
    }
    *t_capture = sl->t_capture_us;
    p->taken = p->written;
    *upto = p->taken;
    pthread_mutex_unlock(&p->slot_lock);
    if (skipped)
        srv_metrics_count(&p->m->drops[SRV_DROP_SYNTH_BUSY], skipped);
    return 1;
}

void srv_pipeline_set_idle(srv_pipeline *p, double idle_after_s, double fade_s)
{
    p->idle_after_us = (uint64_t)llround(idle_after_s * 1e6);
    p->fade_us = (uint64_t)llround(fade_s * 1e6);
}

/* The cross-fade back from the idle animation: while it lasts, b->V (the tracked pose) becomes
 * s V + (1 - s) V_idle, s = smoothstep of the time since it began, V_idle the idle synthesis at
 * the same clock. Returns 1 when b->V is such a blend (it then has no compact form), 0 if not. */
static int fade_back(srv_pipeline *p, srv_bundle *b, uint64_t now)
{
    if (!p->fade_start_us || !b->idle)
        return 0;
    double a = (double)(now - p->fade_start_us) / (double)p->fade_us;
    if (a >= 1) {
        p->fade_start_us = 0;
        return 0;
    }
    mdl_synth_input in = {.t = (double)(now - p->t_start_us) * 1e-6};
    if (mdl_synth_frame(b->idle, &in, b->V_idle, NULL) != 0) {
        p->fade_start_us = 0; /* no idle pose to fade from: the tracked one as it is */
        return 0;
    }
    float s = (float)(a * a * (3 - 2 * a));
    size_t n = (size_t)b->gen->nv * 3;
    for (size_t i = 0; i < n; i++)
        b->V[i] = s * b->V[i] + (1 - s) * b->V_idle[i];
    return 1;
}

/* One frame of the tracked (marker-driven) kind. Returns 0 when a frame was published. */
static int synth_tracked(srv_pipeline *p, srv_bundle *b, const float *xyz, const uint8_t *valid,
                         const float *jrot, const uint8_t *jvalid, uint64_t t_capture)
{
    int count = p->si.count;
    if (atomic_exchange(&p->reset_synth, 0))
        mdl_synth_reset(b->synth);
    /* source order -> model marker order */
    for (int i = 0; i < b->nm; i++) {
        int j = b->map[i];
        int ok = j >= 0 && j < count && valid[j];
        b->mv[i] = (uint8_t)ok;
        for (int a = 0; a < 3; a++)
            b->mk[i * 3 + a] = ok ? xyz[j * 3 + a] : 0.0f;
        if (b->joints) { /* the segment ending at each marker (MDL_INPUT_JOINTS) */
            b->jv[i] = (uint8_t)(ok && jrot && jvalid[j]);
            for (int a = 0; a < 4; a++)
                b->jr[i * 4 + a] = b->jv[i] ? jrot[j * 4 + a] : (a == 0);
        }
    }
    uint64_t t0 = srv_now_us();
    mdl_synth_info si = {0};
    mdl_synth_input in = {.markers = b->mk, .valid = b->mv};
    if (b->joints)
        in.njoints = b->nm, in.joint_rot = b->jr, in.joint_valid = b->jv;
    int r = mdl_synth_frame(b->synth, &in, b->V, &si); /* V kept when refused */
    /* the frame's markers where the model placed them (a harmonic model's template is aligned
     * to its target), so that a viewer draws them on the mesh */
    if (b->mk_scale != 1 || b->mk_t[0] != 0 || b->mk_t[1] != 0 || b->mk_t[2] != 0)
        for (int i = 0; i < b->nm; i++)
            for (int a = 0; a < 3 && b->mv[i]; a++)
                b->mk[i * 3 + a] = (float)(b->mk_scale * b->mk[i * 3 + a] + b->mk_t[a]);
    synth_health(p, b, r);
    if (r != 0) {
        if (!b->idle) /* the last good pose again (the idle animation takes over otherwise) */
            publish(p, b, b->synth, t_capture, t0, SRV_FLAG_REFERENCE_LOST, si.markers_missing);
        return r;
    }
    int flags = (si.reference_lost ? SRV_FLAG_REFERENCE_LOST : 0) |
                (si.markers_held ? SRV_FLAG_HELD : 0);
    if (atomic_load(&p->idle_on) && b->idle && p->fade_us > 0)
        p->fade_start_us = srv_now_us(); /* back from idle: this frame is all idle pose */
    int blended = fade_back(p, b, srv_now_us());
    publish(p, b, blended ? NULL : b->synth, t_capture, t0, flags, si.markers_missing);
    return 0;
}

/* One frame of a clock-driven synthesis (the primary kind, or the idle one) at t seconds. */
static void synth_clock(srv_pipeline *p, srv_bundle *b, mdl_synth *s, double t, int flags)
{
    uint64_t t0 = srv_now_us();
    mdl_synth_input in = {.t = t};
    int r = mdl_synth_frame(s, &in, b->V, NULL);
    if (r != 0) {
        srv_metrics_count(&p->m->drops[SRV_DROP_SYNTH_FAILED], 1);
        return;
    }
    memset(b->mv, 0, (size_t)b->nm); /* no marker drives it */
    publish(p, b, s, t0, t0, flags, b->nm);
}

static void set_idle(srv_pipeline *p, int on, const char *why)
{
    if (atomic_exchange(&p->idle_on, on) != on) {
        srv_log(SRV_LOG_NOTICE, on ? "no one is tracked (%s): the idle animation takes over"
                                   : "tracking again (%s)", why);
        srv_metrics_count(on ? &p->m->to_idle : &p->m->to_tracked, 1);
    }
}

static void *synth_main(void *arg)
{
    srv_pipeline *p = arg;
    int count = p->si.count;
    float *xyz = calloc((size_t)count * 3 + 3, sizeof(float));
    uint8_t *valid = calloc((size_t)count + 1, 1);
    float *jrot = p->si.joints ? calloc((size_t)count * 4 + 4, sizeof(float)) : NULL;
    uint8_t *jvalid = p->si.joints ? calloc((size_t)count + 1, 1) : NULL;
    uint64_t t_start = srv_now_us(), next_tick = t_start, last_frame = t_start;
    p->t_start_us = t_start;
    p->fade_start_us = 0;
    int failed = 0; /* consecutive frames the tracked kind could not synthesise */
    uint64_t failing_since = 0; /* when the first of them came */
    uint64_t last_capture = 0; /* of the markers in xyz, valid */
    int have_markers = 0;
    while (xyz && valid && (!p->si.joints || (jrot && jvalid)) && !atomic_load(&p->stop)) {
        srv_bundle *b = &p->cur;
        int clocked = !(b->inputs & MDL_INPUT_MARKERS);
        uint64_t now = srv_now_us();
        drv_state st = (drv_state)atomic_load(&p->src_state);
        const char *why = st == DRV_STATE_LOST    ? "the source is lost"
                        : st == DRV_STATE_ENDED   ? "the source ended"
                        : !atomic_load(&p->paused) && now - last_frame > p->idle_after_us
                            ? "no source frames"
                        : failed && now - failing_since >= p->idle_after_us
                            ? "the markers do not allow a pose"
                            : NULL;
        int idle = !clocked && b->idle && why;
        uint64_t deadline = clocked || idle ? next_tick : now + 100000u;
        uint64_t t_capture = 0, upto = 0, seq_before = p->seq; /* seq: written by this thread */
        int got = take_slot(p, deadline, xyz, valid, jrot, jvalid, &t_capture, &upto);
        int from_source = got;
        if (atomic_load(&p->stop))
            break;
        int swapped = swap_pending(p);
        b = &p->cur;
        clocked = !(b->inputs & MDL_INPUT_MARKERS);
        now = srv_now_us();
        if (got) {
            last_capture = t_capture;
            have_markers = 1;
        } else if (swapped && !clocked && have_markers) {
            /* a reload while no frame comes (paused): the last markers through the new model, so
             * that clients are greeted with it now, not at the resume */
            t_capture = last_capture;
            got = 1;
        }
        if (got) {
            last_frame = now;
            if (!clocked) {
                if (synth_tracked(p, b, xyz, valid, jrot, jvalid, t_capture) == 0) {
                    failed = 0;
                    set_idle(p, 0, "a pose from the markers");
                } else if (!failed++) {
                    failing_since = now;
                }
                if (from_source)
                    settle_acks(p, upto, seq_before, p->seq);
                continue;
            }
        }
        if (from_source) /* markers a clock-driven synthesis does not read */
            settle_acks(p, upto, p->seq, p->seq);
        idle = !clocked && b->idle && why;
        if ((clocked || idle) && now >= next_tick) {
            uint64_t period = (uint64_t)(1e6 / b->clock_fps);
            next_tick += period;
            if (next_tick < now) /* late (a reload, a stall): no burst to catch up */
                next_tick = now + period;
            if (idle)
                set_idle(p, 1, why);
            synth_clock(p, b, clocked ? b->synth : b->idle, (double)(now - t_start) * 1e-6,
                        idle ? SRV_FLAG_IDLE : 0);
        }
    }
    free(xyz);
    free(valid);
    free(jrot);
    free(jvalid);
    return NULL;
}

/* ------------------------------------------------------------------ control of the threads */

/* ------------------------------------------------------------------ the USB watcher (depth) */

static void usb_event(void *user, int arrived, const char *what)
{
    srv_pipeline *p = user;
    srv_log(SRV_LOG_NOTICE, "usb: %s %s", what, arrived ? "arrived" : "left");
    if (arrived)
        atomic_store(&p->device_hint, 1);
}

static void *usb_main(void *arg)
{
    srv_pipeline *p = arg;
    char e[DRV_ERR_LEN];
    while (!atomic_load(&p->stop))
        if (drv_device_watch_poll(p->usb, 250, e) < 0) {
            srv_log(SRV_LOG_WARN, "usb: %s; no longer watching", e);
            break;
        }
    return NULL;
}

/* Live USB devices (DRV_CAP_USB_DEVICE: depth cameras) get a watcher that logs sensors arriving and leaving and, when
 * one arrives, lets a lost source reopen at once instead of at its next once-a-second try. */
static void usb_watch_start(srv_pipeline *p)
{
    if (!(p->si.caps & DRV_CAP_USB_DEVICE))
        return;
    char e[DRV_ERR_LEN];
    int r = drv_device_watch_create(usb_event, p, &p->usb, e);
    if (r) {
        srv_log(SRV_LOG_INFO, "usb: not watching for sensors: %s", e);
        return;
    }
    srv_log(SRV_LOG_INFO, "usb: watching for depth sensors (%s)",
            drv_device_watch_hotplug(p->usb) ? "hotplug events" : "polling the bus");
    if (pthread_create(&p->usb_thread, NULL, usb_main, p) != 0) {
        drv_device_watch_destroy(p->usb);
        p->usb = NULL;
    }
}

int srv_pipeline_start(srv_pipeline *p, char *err)
{
    char e[DRV_ERR_LEN];
    int r = drv_source_start(p->src, e);
    if (r)
        return srv_err(err, r, "source: %s", e);
    atomic_store(&p->src_state, p->src->state);
    /* the daemon's main thread takes the signals */
    sigset_t all, old;
    sigfillset(&all);
    pthread_sigmask(SIG_BLOCK, &all, &old);
    r = pthread_create(&p->synth_thread, NULL, synth_main, p);
    if (r == 0) {
        r = pthread_create(&p->source_thread, NULL, source_main, p);
        if (r) {
            atomic_store(&p->stop, 1);
            pthread_join(p->synth_thread, NULL);
        }
    }
    if (r == 0)
        usb_watch_start(p);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (r)
        return srv_err(err, -r, "pipeline: cannot start threads: %s", strerror(r));
    p->started = 1;
    return 0;
}

int srv_pipeline_stop(srv_pipeline *p, char *err)
{
    if (!p || !p->started)
        return 0;
    atomic_store(&p->stop, 1);
    pthread_mutex_lock(&p->slot_lock);
    pthread_cond_broadcast(&p->slot_cond);
    pthread_mutex_unlock(&p->slot_lock);
    pthread_join(p->source_thread, NULL);
    pthread_join(p->synth_thread, NULL);
    if (p->usb) {
        pthread_join(p->usb_thread, NULL);
        drv_device_watch_destroy(p->usb);
        p->usb = NULL;
    }
    p->started = 0;
    drv_source_stop(p->src);
    if (atomic_load(&p->reload_state) != 0) {
        pthread_join(p->reload_thread, NULL);
        atomic_store(&p->reload_state, 0);
    }
    int r = 0;
    if (p->rec) {
        r = srv_recorder_write(p->rec, err);
        if (r == 0)
            srv_log(SRV_LOG_NOTICE, "recorded %d frames", srv_recorder_frames(p->rec));
        srv_recorder_destroy(p->rec);
        p->rec = NULL;
    }
    return r;
}

void srv_pipeline_destroy(srv_pipeline *p)
{
    if (!p)
        return;
    srv_pipeline_stop(p, NULL);
    srv_frame_unref(p->latest);
    srv_bundle_fini(&p->cur);
    srv_bundle_fini(&p->pending);
    srv_recorder_destroy(p->rec);
    for (int k = 0; k < SLOT_COUNT; k++) {
        free(p->slots[k].xyz);
        free(p->slots[k].valid);
        free(p->slots[k].jrot);
        free(p->slots[k].jvalid);
    }
    pthread_mutex_destroy(&p->slot_lock);
    pthread_cond_destroy(&p->slot_cond);
    pthread_mutex_destroy(&p->pub);
    pthread_mutex_destroy(&p->ctl_lock);
    drv_source_close(p->src);
    srv_source_info_fini(&p->si);
    free(p);
}

srv_frame *srv_pipeline_latest(srv_pipeline *p)
{
    pthread_mutex_lock(&p->pub);
    srv_frame *f = p->latest;
    if (f)
        srv_frame_ref(f);
    pthread_mutex_unlock(&p->pub);
    return f;
}

srv_gen *srv_pipeline_current(srv_pipeline *p)
{
    pthread_mutex_lock(&p->pub);
    srv_gen *g = p->cur.gen;
    srv_gen_ref(g);
    pthread_mutex_unlock(&p->pub);
    return g;
}

int srv_pipeline_control(srv_pipeline *p, uint64_t tag, const srv_control *c)
{
    int r = 0;
    pthread_mutex_lock(&p->ctl_lock);
    if (p->nctl == SRV_CTL_QUEUE) {
        r = -EBUSY;
    } else {
        p->ctl[p->nctl].tag = tag;
        p->ctl[p->nctl].c = *c;
        p->nctl++;
    }
    pthread_mutex_unlock(&p->ctl_lock);
    return r;
}

int srv_pipeline_result(srv_pipeline *p, srv_ctl_result *r)
{
    int got = 0;
    pthread_mutex_lock(&p->ctl_lock);
    if (p->nres > 0 && !p->res[p->res_head].waiting) { /* in order: none overtakes a waiting ack */
        *r = p->res[p->res_head].r;
        p->res_head = (p->res_head + 1) % SRV_CTL_QUEUE;
        p->nres--;
        got = 1;
    }
    pthread_mutex_unlock(&p->ctl_lock);
    return got;
}

/* ------------------------------------------------------------------ reload */

static void *reload_main(void *arg)
{
    srv_pipeline *p = arg;
    srv_bundle b;
    uint32_t id = atomic_fetch_add(&p->next_gen, 1);
    int r = srv_pipeline_load(p->reload_path, p->reload_labels, &p->si, id, &b, p->reload_err);
    if (r == 0) {
        srv_bundle old;
        pthread_mutex_lock(&p->pub);
        old = p->pending;
        p->pending = b;
        pthread_mutex_unlock(&p->pub);
        srv_bundle_fini(&old);
    }
    p->reload_ok = r == 0;
    atomic_store(&p->reload_state, 2);
    p->wake(p->wake_ud);
    return NULL;
}

int srv_pipeline_reload(srv_pipeline *p, const char *model_path, const char *labels)
{
    if (atomic_load(&p->reload_state) != 0)
        return -EBUSY;
    snprintf(p->reload_path, sizeof p->reload_path, "%s", model_path);
    snprintf(p->reload_labels, sizeof p->reload_labels, "%s", labels ? labels : "");
    p->reload_err[0] = '\0';
    atomic_store(&p->reload_state, 1);
    sigset_t all, old;
    sigfillset(&all);
    pthread_sigmask(SIG_BLOCK, &all, &old);
    int r = pthread_create(&p->reload_thread, NULL, reload_main, p);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (r) {
        atomic_store(&p->reload_state, 0);
        return -r;
    }
    return 0;
}

int srv_pipeline_reload_done(srv_pipeline *p, int *ok, char *err)
{
    if (atomic_load(&p->reload_state) != 2)
        return 0;
    pthread_join(p->reload_thread, NULL);
    *ok = p->reload_ok;
    if (err)
        snprintf(err, SRV_ERR_LEN, "%s", p->reload_err);
    atomic_store(&p->reload_state, 0);
    return 1;
}

drv_state srv_pipeline_source_state(srv_pipeline *p)
{
    return (drv_state)atomic_load(&p->src_state);
}

const srv_source_info *srv_pipeline_source_info(srv_pipeline *p)
{
    return &p->si;
}

unsigned srv_pipeline_controls(srv_pipeline *p)
{
    return atomic_load(&p->controls);
}

int srv_pipeline_idle(srv_pipeline *p)
{
    return atomic_load(&p->idle_on);
}
