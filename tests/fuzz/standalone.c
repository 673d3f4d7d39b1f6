/* standalone.c - runs a libFuzzer target without libFuzzer, as a regression test.
 *
 * Usage: fuzz_X FILE...   Each file is fed whole, then every prefix at a stride (truncation), then
 * with deterministic byte corruptions (a small xorshift sequence), so that the suite exercises the
 * parser's error paths on every run. Built with -Dfuzz=true the same target links against libFuzzer
 * instead (clang -fsanitize=fuzzer) and this file is left out. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint8_t *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    uint8_t *b = malloc(cap);
    size_t got;
    while (b && (got = fread(b + n, 1, cap - n, f)) > 0) {
        n += got;
        if (n == cap) {
            uint8_t *nb = realloc(b, cap *= 2);
            if (!nb) {
                free(b);
                b = NULL;
            }
            b = nb;
        }
    }
    fclose(f);
    *len = n;
    return b;
}

int main(int argc, char **argv)
{
    uint32_t state = 2463534242u;
    int inputs = 0, files = 0, absent = 0;
    for (int i = 1; i < argc; i++) {
        size_t len;
        errno = 0;
        uint8_t *buf = read_all(argv[i], &len);
        if (!buf && errno == ENOENT) {
            /* a seed from ../shared/data on a checkout without it: run the others, skip if none */
            fprintf(stderr, "seed %s is absent: not run\n", argv[i]);
            absent++;
            continue;
        }
        if (!buf) {
            fprintf(stderr, "cannot read %s\n", argv[i]);
            return 1;
        }
        files++;
        LLVMFuzzerTestOneInput(buf, len);
        inputs++;
        /* truncations: about 64 prefixes per file, plus the small ones */
        size_t stride = len / 64 ? len / 64 : 1;
        for (size_t n = 0; n < len; n += (n < 64 ? 1 : stride)) {
            uint8_t *p = malloc(n ? n : 1);
            memcpy(p, buf, n);
            LLVMFuzzerTestOneInput(p, n);
            free(p);
            inputs++;
        }
        /* corruptions: 200 variants, each with a few bytes changed */
        uint8_t *c = malloc(len ? len : 1);
        for (int v = 0; v < 200 && len; v++) {
            memcpy(c, buf, len);
            for (int k = 0; k < 4; k++) {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                size_t at = state % len;
                /* bias towards the first 4 KiB, where headers live */
                if (v % 2 == 0 && len > 4096)
                    at %= 4096;
                c[at] = (uint8_t)(state >> 8);
            }
            LLVMFuzzerTestOneInput(c, len);
            inputs++;
        }
        free(c);
        free(buf);
    }
    if (files == 0 && absent > 0) {
        printf("no seed file is present: skipped\n");
        return 77;
    }
    printf("%d inputs from %d seed files (%d absent), no crash\n", inputs, files, absent);
    return 0;
}
