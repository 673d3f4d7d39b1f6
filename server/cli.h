/* cli.h - shared pieces of the meshsteer command-line tool: usage errors, progress, options.
 * Exit status: 0 success, 2 bad usage or bad input (message on stderr), 1 internal failure. */
#ifndef MESHSTEER_CLI_H
#define MESHSTEER_CLI_H

#include "model.h"

#define CLI_EXIT_OK 0
#define CLI_EXIT_FAIL 1
#define CLI_EXIT_USAGE 2

typedef struct cli_command {
    const char *name;
    const char *summary;
    int (*run)(int argc, char **argv); /* argv[0] is the command name */
} cli_command;

/* Prints "meshsteer CMD: message" to stderr and returns CLI_EXIT_USAGE. */
int cli_usage_error(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prints "meshsteer CMD: message" and returns the given exit status. */
int cli_fail(const char *cmd, int status, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* Progress on a terminal (stderr is a tty): "\r<stage> 42%". Silent otherwise. Usable as an
 * mdl_progress_fn with ud = the command name. */
void cli_progress(void *ud, const char *stage, double fraction);
void cli_progress_done(void);

/* A parallel-for over pthreads (cli_parallel.c), an mdl_parallel_fn with ud = a cli_pool: up to
 * threads workers (64 at most; fewer when a thread cannot start), worker 0 the caller. */
typedef struct cli_pool {
    int threads;
} cli_pool;
void cli_parallel_for(void *ud, int n, mdl_parallel_body body, void *ctx);

/* Parses a double / int option value; on error prints a usage error and returns -1. */
int cli_parse_double(const char *cmd, const char *opt, const char *s, double *out);
int cli_parse_int(const char *cmd, const char *opt, const char *s, int *out);

/* True when s ends with suffix (case-insensitive). */
int cli_has_suffix(const char *s, const char *suffix);

/* Prints a cJSON object (void * keeps cJSON out of this header) to stdout, indented, and deletes
 * it. Returns 0, or -ENOMEM when it could not be printed. */
int cli_print_json(void *cjson_object);

/* Median and 99th percentile of n values (sorts v in place). */
void cli_percentiles(double *v, int n, double *median, double *p99);

#endif
