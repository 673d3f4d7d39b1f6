/* pipeline.h - the daemon's two worker threads (DESIGN.md, "Threads of the daemon").
 *
 *   source thread:    drv_source_read (paced by the source) -> newest-marker slot (+ recording)
 *   synthesis thread: newest slot -> model marker order -> mdl_synth_frame -> srv_frame_encode
 *                     -> publish as the latest frame under `pub` -> wake()
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
#include "drivers.h"
#include "encode.h"
#include "metrics.h"

#include <pthread.h>
#include <stdatomic.h>

#define SRV_CTL_QUEUE 32

typedef struct srv_pipeline srv_pipeline;

/* Everything synthesis needs for one model. */
typedef struct srv_bundle {
    srv_gen *gen;       /* one reference */
    mdl_model *model;
    mdl_synth *synth;
    float *V;           /* nv x 3 */
    float *mk;          /* nm x 3, model marker order */
    uint8_t *mv;        /* nm */
} srv_bundle;

typedef struct srv_ctl_result {
    uint64_t tag;
    char reply[SRV_REPLY_LEN];
    size_t len;
} srv_ctl_result;

/* Opens the model and binds it to the source's markers through the label map `labels` (labels.h;
 * NULL or "" binds by exact names). No marker bound is an error; map entries that cannot take
 * effect and unbound markers are logged as warnings. `id` becomes the generation number. */
int srv_pipeline_load(const char *model_path, const char *labels, const drv_source *src,
                      const char *spec, uint32_t id, srv_bundle *out, char *err);
void srv_bundle_fini(srv_bundle *b);

/* On success takes the source and the bundle (on failure the caller keeps both). record may be
 * NULL. */
int srv_pipeline_create(drv_source *src, const char *spec, srv_bundle *b, srv_metrics *m, const char *record,
                        void (*wake)(void *), void *wake_ud, srv_pipeline **out, char *err);
int srv_pipeline_start(srv_pipeline *p, char *err);
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
const drv_source *srv_pipeline_source(srv_pipeline *p);
/* The control kinds a source accepts, as SRV_CTL_BIT()s: pause and resume for DRV_CTL_PAUSE, seek
 * for DRV_CTL_SEEK, speed for DRV_CTL_SPEED (what the hello advertises). */
unsigned srv_pipeline_source_controls(const drv_source *src);
uint64_t srv_now_us(void);

#endif
