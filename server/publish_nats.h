/* publish_nats.h - meshsteerd's frames, hello and topology published to NATS (docs/PROTOCOL.md,
 * "NATS"), so that an audience subscribes through any node of a NATS cluster instead of the daemon.
 *
 * Subjects, under a prefix P (--subject, default "meshsteer"):
 *   P.hello            the hello (JSON text), published on connect and whenever the model changes
 *   P.topology         the topology message (binary), likewise
 *   P.frames.ENC       every frame in encoding ENC (srv_encoding_name: float32, int16, ...), as
 *                      plain core-NATS publishes: latest wins, nothing is stored or queued
 *   P.get.hello        request-reply: answers with the current hello (late joiners)
 *   P.get.topology     request-reply: answers with the current topology
 *   P.get.ping         request-reply: answers {"type":"pong","server_us":T}, the daemon's clock
 *
 * Threads: a publisher thread of its own. srv_publisher_notify (called from the synthesis thread
 * through the daemon's wake callback) only signals it; the thread takes the pipeline's newest
 * frame, copies each encoding into its own buffer (with its own send time and skipped count:
 * the shared frame's per-send fields belong to the lws thread), releases the frame and publishes.
 * So a slow or blocked NATS connection never holds up synthesis or the WebSocket clients: the
 * frames it could not take in time are superseded (counted). A publish is also refused while the
 * connection's outgoing buffer holds more than SRV_NATS_PENDING_MAX bytes, and while it is not
 * connected: counted in /metrics as meshsteer_nats_drops_total{reason}.
 * libnats does connecting and reconnecting (forever, every SRV_NATS_RECONNECT_MS); a server that
 * is down at start is logged and retried, the daemon serves WebSocket clients meanwhile.
 * The request-reply answers run on libnats' own thread and read srv_pipeline_current.
 * Buffers are sized per model generation; publishing a frame allocates nothing of ours. */
#ifndef MESHSTEER_SERVER_PUBLISH_NATS_H
#define MESHSTEER_SERVER_PUBLISH_NATS_H

#include "metrics.h"
#include "pipeline.h"

#define SRV_NATS_PENDING_MAX (4 << 20) /* bytes buffered towards the server before frames drop */
#define SRV_NATS_RECONNECT_MS 250

typedef struct srv_publisher srv_publisher;

/* Starts publishing the pipeline's frames to the servers `urls` (comma list of nats://HOST:PORT,
 * validated by daemon_config.c) under the subject prefix `prefix`. Does not wait for a server:
 * returns 0 even when none is reachable yet. Errors only for bad options or no memory/thread. */
int srv_publisher_create(const char *urls, const char *prefix, srv_pipeline *pipe,
                         srv_metrics *m, srv_publisher **out, char *err);
/* A new frame may be there: wakes the publisher thread; never blocks for long (any thread). */
void srv_publisher_notify(srv_publisher *p);
/* Stops the thread, closes the connection and waits for libnats' own threads to end (so it also
 * ends the library: one publisher per process, destroyed at exit). NULL is fine. */
void srv_publisher_destroy(srv_publisher *p);

#endif
