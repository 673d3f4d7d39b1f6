/* daemon_harness.h - starting meshsteerd for a test: a fresh directory with a model trained on the
 * built-in example (make_model), the daemon on an ephemeral port with its log in a file, plain
 * HTTP GETs, and reading /metrics values. */
#ifndef MESHSTEER_TESTS_DAEMON_HARNESS_H
#define MESHSTEER_TESTS_DAEMON_HARNESS_H

#include <stddef.h>
#include <sys/types.h>

typedef struct harness {
    char dir[1024];
    char log[1100];
    pid_t pid;
    int port;
    char token[64]; /* when set, harness_get sends it (Authorization: Bearer) */
} harness;

/* Makes an empty dir/ (under the build directory) for a test that brings its own files. */
void harness_dir(harness *h);
/* Makes dir/ with example.msm, model.msm (a copy), corrupt.msm and trot.csv. */
void harness_fixtures(harness *h, const char *make_model);
/* Starts meshsteerd with the given extra arguments (NULL-terminated); waits for its port.
 * Should the daemon be built with AddressSanitizer, its quarantine is kept small
 * (ASAN_OPTIONS), so that freed memory is reused and RSS measures what the daemon holds. */
void harness_start(harness *h, const char *meshsteerd, const char *const *args);
/* GET path; returns the HTTP status, the body in a malloc'd string. */
int harness_get(const harness *h, const char *path, char **body);
/* Sends the raw bytes of request (n of them) and reads until the daemon closes or 5 s pass;
 * returns the HTTP status (0 when the answer is not HTTP, -1 when nothing came) and the whole
 * answer, headers included, in a malloc'd string. */
int harness_raw(const harness *h, const char *request, size_t n, char **answer);
/* The value of a /metrics sample (name with labels, exactly as printed); -1 if absent. */
double harness_metric(const harness *h, const char *sample);
/* The values of every sample of a labelled metric family ("name{...} value"), in /metrics order;
 * returns how many (at most max), or -1. */
int harness_metric_family(const harness *h, const char *prefix, double *v, int max);
/* Sends sig and waits up to timeout_ms for exit; returns the exit status, or -1 on timeout. */
int harness_stop(harness *h, int sig, int timeout_ms);
void harness_copy(const char *from, const char *to);
/* 1 when the daemon's log contains needle. */
int harness_log_has(const harness *h, const char *needle);
long harness_rss_kb(const harness *h);
/* A WebSocket client on a raw socket (a small receive buffer) that completes the handshake and
 * then never reads; returns the socket. */
int harness_stalled_client(const harness *h);
/* Runs argv (NULL-terminated) to completion with stdout and stderr into out_path; returns the exit
 * status (128 + signal when killed). */
int harness_run(const char *const *argv, const char *out_path);
/* The same without waiting: returns the child's pid, for harness_wait. */
pid_t harness_spawn(const char *const *argv, const char *out_path);
int harness_wait(pid_t pid);
/* The first cap - 1 bytes of a file (the output of harness_run) into buf, NUL-terminated; exits on
 * a missing file. Returns buf. */
char *harness_read(const char *path, char *buf, size_t cap);

#endif
