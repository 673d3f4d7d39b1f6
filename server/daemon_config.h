/* daemon_config.h - meshsteerd's settings: defaults, a `key = value` config file, command-line flags.
 *
 * Precedence: built-in defaults < config file (-c FILE) < flags. Every value is checked when it is
 * set; the file is parsed into a fresh copy and only replaces the caller's struct when the whole
 * file is valid (STYLE.md Sec. 7). Errors name FILE:LINE and the reason.
 *
 * File syntax: one `key = value` per line; `#` starts a comment (at the start of a line or after
 * whitespace); blank lines are ignored; a value may be wrapped in double quotes; a key may appear
 * once. Keys (flags are the same names with '-' for '_', e.g. --max-clients):
 *   model         path of the trained model file (required)
 *   source        marker source spec, e.g. replay:walk.c3d?loop=1 (required)
 *   listen        [ADDR:]PORT, default 127.0.0.1:8080; port 0 picks a free port
 *   record        write the incoming marker stream to this C3D file (optional)
 *   max_clients   WebSocket clients at once, 1..10000, default 256
 *   max_message   largest control message in bytes, 64..1048576, default 4096
 *   idle_timeout  seconds a client may leave a pending frame unaccepted before it is closed,
 *                 1..86400, default 30
 *   idle_after    seconds without a source frame, or without a pose from the markers, before a
 *                 model's idle animation takes over, 0.1..3600, default 2 (a lost or ended
 *                 source hands over at once)
 *   fade          seconds over which the output cross-fades from the idle animation back to the
 *                 tracked pose when tracking returns, 0..60 (0: a cut), default 0.5
 *   token         shared secret for /stream (query ?token= or header Authorization: Bearer ...)
 *   origin        "any" (default), "same" (Origin must match Host), or a comma list of origins
 *   web_root      directory served at / (default: the installed viewer)
 *   log_level     error | warn | notice | info | debug (default notice)
 *   encoding      default frame encoding for new clients: float32 | int16 (default float32)
 *   labels        label map MODEL=LABEL[,MODEL=LABEL...]: the model's marker labels (the rig's
 *                 `source`) driven by the source's labels (labels.h); default none (exact names)
 *   publish       NATS servers to publish the stream to: nats://HOST[:PORT][,nats://...] (one
 *                 cluster; libnats fails over between them); default none (publish_nats.h)
 *   subject       subject prefix of the published stream: dot-separated tokens of letters,
 *                 digits, '-' and '_', default "meshsteer"
 */
#ifndef MESHSTEER_SERVER_DAEMON_CONFIG_H
#define MESHSTEER_SERVER_DAEMON_CONFIG_H

#include <stddef.h>

#define SRV_ERR_LEN 512
#define SRV_PATH_LEN 4096

typedef struct srv_config {
    char model[SRV_PATH_LEN];
    char source[SRV_PATH_LEN];
    char listen_host[256]; /* numeric address or host name */
    int port;
    char record[SRV_PATH_LEN];
    int max_clients;
    int max_message;
    int idle_timeout;
    double idle_after; /* seconds */
    double fade;       /* seconds */
    char token[256];
    char origin[1024];
    char web_root[SRV_PATH_LEN];
    int log_level;  /* SRV_LOG_* */
    int encoding;   /* SRV_ENC_* (encode.h) */
    char labels[4096]; /* label map text, validated (labels.h, SRV_LABELS_MAX_LEN); "" = none */
    char publish[1024]; /* NATS server URLs, comma-separated; "" = no publishing */
    char subject[128];  /* NATS subject prefix */
} srv_config;

void srv_config_defaults(srv_config *c);
/* Sets one key from its text value, validating it. Errors (without file:line) go to err. */
int srv_config_set(srv_config *c, const char *key, const char *value, char *err);
/* Parses config text onto a copy of *c; on success copies the result back into *c. `name` is
 * used in messages ("meshsteerd.conf:12: ..."). */
int srv_config_parse(srv_config *c, const char *text, size_t len, const char *name, char *err);
int srv_config_read(srv_config *c, const char *path, char *err);
/* Checks cross-field requirements (model and source present). */
int srv_config_validate(const srv_config *c, char *err);

#endif
