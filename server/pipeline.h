/* pipeline.h - the daemon's two worker threads (DESIGN.md, "Threads of the daemon").
 *
 *   source thread:    drv_source_read (paced by the source) -> newest-marker slot (+ recording)
 *   synthesis thread: newest slot -> model marker order (the bundle's map) -> mdl_synth_frame
 *                     -> srv_frame_encode (+ mdl_synth_params -> srv_frame_encode_params)
 *                     -> publish as the latest frame under `pub` -> wake()
 * A bundle whose kind reads no markers (a clock-driven kind, MDL_INPUT_CLOCK) is run on a clock at
 * its model's fps instead of at the source's frames. A bundle may also hold an *idle* synthesis:
 * the clock-driven kind of the same model file (so the same mesh, and no new hello when it takes
 * over), which the synthesis thread runs whenever no one is tracked: the source is lost or ended,
 * no source frame came for idle_after seconds (unless a client paused it: a paused replay holds
 * its pose), or the tracked kind could not synthesise for idle_after seconds (no reference yet,
 * every marker invalid). Its frames carry SRV_FLAG_IDLE. When tracking returns, the output
 * cross-fades from the idle animation (still running) to the tracked pose over `fade` seconds
 * (srv_pipeline_set_idle): smoothstep weights on the two vertex sets, frames without a compact
 * form (params clients get int16 for those).
 * wake() is lws_cancel_service in the daemon (the only lws call made from these threads).
 * Per frame nothing is allocated: buffers come with the generation (srv_pipeline_load).
 *
 * Controls (pause/seek/speed) are queued by the lws thread and applied by the source thread
 * between reads; their results come back through a result queue with the session's tag.
 * A model reload builds a complete new generation (model, synthesiser, buffers) on another thread
 * and offers it; the synthesis thread swaps it in between frames. */
#ifndef MESHSTEER_SERVER_PIPELINE_H
#define MESHSTEER_SERVER_PIPELINE_H

#include "control.h"
#include "daemon_config.h"
#include "drivers.h"
#include "encode.h"
#include "encode_params.h"
#include "metrics.h"

#include <pthread.h>
#include <stdatomic.h>

#define SRV_CTL_QUEUE 32

typedef struct srv_pipeline srv_pipeline;

/* What the daemon knows of its source, copied once at start so that other threads never read the
 * drv_source that the source thread reopens (names, fps and the scheme cannot change on a reopen:
 * drv_source_reopen refuses another marker set; the controls can, see srv_pipeline_controls). */
typedef struct srv_source_info {
    char spec[SRV_PATH_LEN];
    char scheme[32];
    int count;
    char **names;       /* count labels */
    double fps;
    int frames;         /* frames of a recording, 0 for a live source */
    unsigned caps;      /* DRV_CAP_* */
    unsigned controls;  /* SRV_CTL_BIT()s accepted when opened */
    int joints;         /* the source's frames carry joint rotations (drv_source.joints) */
} srv_source_info;

int srv_source_info_init(srv_source_info *si, const drv_source *src, const char *spec, char *err);
void srv_source_info_fini(srv_source_info *si);

/* Everything synthesis needs for one model: the model, its synthesis, the binding of source labels
 * to its inputs, the generation it is streamed as, and every buffer a frame needs. */
typedef struct srv_bundle {
    srv_gen *gen;       /* one reference */
    mdl_model *model;
    mdl_synth *synth;   /* the primary kind */
    unsigned inputs;    /* MDL_INPUT_* bits of synth */
    double clock_fps;   /* the rate of a clock-driven synth (or idle): the model's fps, or 30 */
    int nm;             /* model markers */
    int *map;           /* nm: the source marker feeding each model marker, or -1 */
    mdl_synth *idle;    /* the idle synthesis (a clock-driven kind of the same model), or NULL */
    int layout_synth;   /* the params layout (gen) of synth's compact form, or -1 */
    int layout_idle;    /* the same for idle */
    float *prm;         /* the largest layout's floats: one frame's parameters */
    float *V;           /* nv x 3 */
    float *V_idle;      /* nv x 3 when there is an idle synthesis: its pose during a fade */
    float *mk;          /* nm x 3, model marker order */
    double mk_scale, mk_t[3]; /* where synth places the markers (mdl_synth_marker_placement) */
    uint8_t *mv;        /* nm */
    int joints;         /* synth reads joint rotations (MDL_INPUT_JOINTS) and the source gives them */
    float *jr;          /* nm x 4 when joints: the joint rotations, model marker order */
    uint8_t *jv;        /* nm when joints */
} srv_bundle;

typedef struct srv_ctl_result {
    uint64_t tag;
    char reply[SRV_REPLY_LEN];
    size_t len;
} srv_ctl_result;

/* Opens the model and binds it to the source's markers through the label map `labels` (labels.h;
 * NULL or "" binds by exact names). For a kind driven by markers no marker bound is an error; map
 * entries that cannot take effect and unbound markers are logged as warnings. A kind that reads no
 * markers needs no binding. `id` becomes the generation number. */
int srv_pipeline_load(const char *model_path, const char *labels, const srv_source_info *src,
                      uint32_t id, srv_bundle *out, char *err);
void srv_bundle_fini(srv_bundle *b);

/* On success takes the source, its description and the bundle (on failure the caller keeps all
 * three). record may be NULL. */
int srv_pipeline_create(drv_source *src, srv_source_info *si, srv_bundle *b, srv_metrics *m,
                        const char *record, void (*wake)(void *), void *wake_ud,
                        srv_pipeline **out, char *err);
int srv_pipeline_start(srv_pipeline *p, char *err);
/* The idle animation's hand-over (daemon_config.h idle_after, fade; defaults 2 s and 0.5 s);
 * before srv_pipeline_start. */
void srv_pipeline_set_idle(srv_pipeline *p, double idle_after_s, double fade_s);
/* Stops the threads, writes the recording (its error goes to err), keeps the object. */
int srv_pipeline_stop(srv_pipeline *p, char *err);
void srv_pipeline_destroy(srv_pipeline *p);

/* The newest frame with a reference (srv_frame_unref it), or NULL. */
srv_frame *srv_pipeline_latest(srv_pipeline *p);
/* The generation clients should be greeted with now (referenced; srv_gen_unref it). */
srv_gen *srv_pipeline_current(srv_pipeline *p);

/* Queues a source control (pause/resume/seek/speed) for the source thread. -EBUSY when full. */
int srv_pipeline_control(srv_pipeline *p, uint64_t tag, const srv_control *c);
/* Takes one finished control result; returns 0 when there was none. */
int srv_pipeline_result(srv_pipeline *p, srv_ctl_result *r);

/* Starts a background reload of the model, bound through `labels` (may be NULL); -EBUSY if one is
 * running. */
int srv_pipeline_reload(srv_pipeline *p, const char *model_path, const char *labels);
/* 1 once a reload has finished since the last call (*ok says whether it was swapped in). */
int srv_pipeline_reload_done(srv_pipeline *p, int *ok, char *err);

drv_state srv_pipeline_source_state(srv_pipeline *p);
/* 1 while synthesis refuses every frame (its reason into why, n bytes), else 0. */
int srv_pipeline_degraded(srv_pipeline *p, char *why, size_t n);
/* The source as copied at start (any thread). */
const srv_source_info *srv_pipeline_source_info(srv_pipeline *p);
/* The control kinds the source accepts now, as SRV_CTL_BIT()s (any thread). */
unsigned srv_pipeline_controls(srv_pipeline *p);
/* 1 while the idle synthesis is driving the output. */
int srv_pipeline_idle(srv_pipeline *p);
/* The control kinds of a source's DRV_CTL_* bits: pause and resume for DRV_CTL_PAUSE, seek for
 * DRV_CTL_SEEK, speed for DRV_CTL_SPEED (what the hello advertises). */
unsigned srv_controls_of_source(unsigned drv_controls);
uint64_t srv_now_us(void);

#endif
