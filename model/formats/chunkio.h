/* chunkio.h - little-endian encoding of model file chunks (formats/modelfile.c and each kind's
 * chunk): a growing write buffer, and a bounded reader that validates as it goes.
 *
 * Reader contract: the first failure sets b->rc (MDL_EFORMAT, or -ENOMEM) and the message
 * "NAME: byte N: WHAT" in b->err; every later call returns at once, so a parser may read a run of
 * fields and check b->rc once. Arrays are preceded by their u32 element count, which must equal
 * the count the reader expects from dimensions read before it (never trusted to size memory), and
 * is checked against the bytes left before anything is allocated.
 */
#ifndef MESHSTEER_CHUNKIO_H
#define MESHSTEER_CHUNKIO_H

#include <stddef.h>
#include <stdint.h>

/* The largest element count of one array (2^28). */
#define MDL_CHUNK_MAX_COUNT (1u << 28)

typedef struct mdl__wbuf {
    /* p: the bytes so far (malloc'd; the caller frees), oom: set once a growth failed */
    uint8_t *p;
    size_t n, cap;
    int oom;
} mdl__wbuf;

void mdl__put_bytes(mdl__wbuf *b, const void *src, size_t n);
void mdl__put_u32(mdl__wbuf *b, uint32_t v);
void mdl__put_u64(mdl__wbuf *b, uint64_t v);
void mdl__put_f64(mdl__wbuf *b, double d);
/* arrays: u32 count, then the elements */
void mdl__put_i32s(mdl__wbuf *b, const int *a, size_t n);
void mdl__put_u32s(mdl__wbuf *b, const uint32_t *a, size_t n);
void mdl__put_f32s(mdl__wbuf *b, const float *a, size_t n);
void mdl__put_f64s(mdl__wbuf *b, const double *a, size_t n);

typedef struct mdl__rbuf {
    const uint8_t *p;
    size_t n, at;
    const char *name;
    char *err;
    int rc;
} mdl__rbuf;

int mdl__rfail(mdl__rbuf *b, const char *what);
int mdl__get_bytes(mdl__rbuf *b, void *dst, size_t n);
uint32_t mdl__get_u32(mdl__rbuf *b);
uint64_t mdl__get_u64(mdl__rbuf *b);
/* an int in lo..hi */
int mdl__get_int(mdl__rbuf *b, const char *what, int lo, int hi);
/* a finite double */
double mdl__get_f64(mdl__rbuf *b, const char *what);
/* an array's count, which must be `expect` */
int mdl__get_count(mdl__rbuf *b, size_t expect, const char *what);
/* arrays of exactly n elements, allocated (free()); NULL on failure. Ints must lie in lo..hi,
 * floats must be finite. */
int *mdl__get_ints(mdl__rbuf *b, size_t n, const char *what, int lo, int hi);
float *mdl__get_f32s(mdl__rbuf *b, size_t n, const char *what);
double *mdl__get_f64s(mdl__rbuf *b, size_t n, const char *what);
/* off[0] == 0 and non-decreasing over n + 1 entries */
int mdl__check_offsets(mdl__rbuf *b, const int *off, int n, const char *what);
/* MDL_NAME_LEN bytes, NUL-terminated on return */
void mdl__get_name(mdl__rbuf *b, char *dst);

#endif
