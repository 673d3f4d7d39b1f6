/* util.h - small helpers shared inside model/ (not part of the public interface).
 * Error formatting into the caller's `err` buffer and whole-file reading with size limits. */
#ifndef MESHSTEER_MODEL_UTIL_H
#define MESHSTEER_MODEL_UTIL_H

#include <stddef.h>
#include <stdint.h>

/* Formats into err (MDL_ERR_LEN bytes) when err is non-NULL; returns `code` so that callers can
 * write `return mdl__err(err, -EINVAL, "%s:%d: ...", ...)`. */
int mdl__err(char *err, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* Reads a whole file into a new NUL-terminated buffer (*len excludes the NUL). Refuses files
 * larger than max_bytes. */
int mdl__read_file(const char *path, size_t max_bytes, char **buf, size_t *len, char *err);

/* Overflow-checked allocation of n * size bytes, zeroed. Returns NULL on overflow or failure. */
void *mdl__calloc(size_t n, size_t size);

/* printf into buf + *at (buf holds len bytes), advancing *at; output past the end is cut and *at
 * then reaches len, which callers test to report truncation. */
void mdl__appendf(char *buf, size_t len, size_t *at, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* A reproducible random stream (splitmix64): uniform in (0, 1) and standard normal (Box-Muller). */
double mdl__uniform(uint64_t *state);
double mdl__gauss(uint64_t *state);

#endif
