/* overlap.c - the overlap test of Zheng 2013 Sec. 3.4: "we compare the current path with existing
 * results. If it overlaps largely with some existing result, we discard the current search to
 * avoid generating animations utterly alike each other." Two walks overlap at an output frame when
 * every component shows the same input frame there; their overlap is the fraction of output frames
 * where they do (the paper gives no measure; this one is 1 for a repeat and about 1 / N for two
 * unrelated walks over N input frames). */
#include "model.h"

double mdl_variations_overlap(const int *src_a, const int *src_b, int frames, int components)
{
    if (frames < 1 || components < 1)
        return 0;
    int same = 0;
    for (int f = 0; f < frames; f++) {
        int eq = 1;
        for (int c = 0; c < components && eq; c++)
            eq = src_a[(size_t)components * f + c] == src_b[(size_t)components * f + c];
        same += eq;
    }
    return (double)same / frames;
}
