/* bone_colours.c - a skin's weights as colour (see bone_colours.h). The hue sequence is the
 * golden-ratio one (successive hues j * 0.618... of the circle), converted from HSV. */
#include "bone_colours.h"

#include <math.h>
#include <string.h>

void srv_bone_colour(int j, float rgb[3])
{
    double h = fmod(j * 0.6180339887498949, 1.0) * 6, f = h - floor(h);
    float v = 0.95f, p = v * 0.25f, q = v * (1 - 0.75f * (float)f), t = v * (1 - 0.75f * (1 - (float)f));
    const float sector[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
    memcpy(rgb, sector[(int)h % 6], 3 * sizeof *rgb);
}

void srv_skin_vertex_colours(int nv, int K, const int *bone, const double *w, uint8_t *out)
{
    for (int i = 0; i < nv; i++) {
        float sum[3] = {0, 0, 0}, c[3];
        for (int k = 0; k < K; k++) {
            srv_bone_colour(bone[i * K + k], c);
            for (int x = 0; x < 3; x++)
                sum[x] += (float)w[i * K + k] * c[x];
        }
        for (int x = 0; x < 3; x++)
            out[3 * i + x] = (uint8_t)fminf(255.0f, fmaxf(0.0f, 255.0f * sum[x] + 0.5f));
    }
}
