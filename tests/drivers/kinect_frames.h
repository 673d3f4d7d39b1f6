/* kinect_frames.h - loads one of the real Kinect depth frames of ../shared/data (Skeltrack's test
 * inputs: raw little-endian uint16 millimetres, 640 x 480, no header) for the drivers tests.
 * Exits 77 (skip) when the data set is absent, 1 when the file is short. */
#ifndef MESHSTEER_TEST_KINECT_FRAMES_H
#define MESHSTEER_TEST_KINECT_FRAMES_H

#include "test.h"

#include <stdint.h>

/* name: e.g. "depth-data-1045879925"; mm: 640 x 480 */
static inline void kinect_frame_load(const char *name, uint16_t *mm)
{
    char rel[256];
    snprintf(rel, sizeof rel, "depth/skeltrack-kinect-raw16/%s", name);
    const char *path = test_data(rel);
    FILE *f = fopen(path, "rb");
    ASSERT(f);
    uint8_t *b = malloc(640 * 480 * 2);
    ASSERT(b);
    size_t n = fread(b, 1, 640 * 480 * 2, f);
    fclose(f);
    if (n != 640 * 480 * 2) {
        fprintf(stderr, "%s: %zu bytes, expected %d\n", path, n, 640 * 480 * 2);
        exit(1);
    }
    for (int i = 0; i < 640 * 480; i++)
        mm[i] = (uint16_t)(b[2 * i] | b[2 * i + 1] << 8);
    free(b);
}

#endif
