/* test_kblend.c - model/steer/kblend.c: the kernel blend of the training meshes in marker space.
 *   - markers of a training frame, turned and moved anywhere, give that frame turned and moved
 *     (its fit is exact, so the bandwidth is 0 and it stands alone);
 *   - markers halfway between two training frames that fit equally well give the mean of the two
 *     placed meshes (equal weights), and a third frame far away gets no weight;
 *   - the unused markers are ignored, and fewer than 3 give -EAGAIN with the output untouched. */
#include "steer/kblend.h"
#include "test.h"

#include <errno.h>
#include <math.h>
#include <string.h>

enum { NV = 6, NM = 4, NT = 3 };

static void place(const float *P, int n, double a, const double t[3], float *out)
{
    double c = cos(a), s = sin(a);
    for (int i = 0; i < n; i++) {
        const float *p = P + 3 * i;
        out[3 * i] = (float)(c * p[0] + s * p[2] + t[0]);
        out[3 * i + 1] = (float)(p[1] + t[1]);
        out[3 * i + 2] = (float)(-s * p[0] + c * p[2] + t[2]);
    }
}

int main(void)
{
    /* three training meshes; the markers are vertices 0..3 */
    float V[NT * NV * 3], mk[NT * NM * 3];
    for (int g = 0; g < NT; g++)
        for (int v = 0; v < NV; v++) {
            float *p = V + (g * NV + v) * 3;
            p[0] = (float)(0.1 * v + (g == 2 ? 0.5 * (v % 2) : 0));
            p[1] = (float)(0.3 * (v % 3) + 0.05 * g * v);
            p[2] = (float)(0.2 * (v % 2) - 0.1 * v);
        }
    for (int g = 0; g < NT; g++)
        memcpy(mk + g * NM * 3, V + g * NV * 3, sizeof(float) * NM * 3);
    double scratch[MDL_KBLEND_SCRATCH(NT, NM)];
    uint8_t use[NM] = {1, 1, 1, 1};
    float out[NV * 3], want[NV * 3], P[NM * 3];
    const double t[3] = {0.4, -0.1, 1.2};

    /* a training frame's own markers, turned and moved */
    for (int g = 0; g < NT; g++) {
        place(V + g * NV * 3, NV, 0.7, t, want);
        place(mk + g * NM * 3, NM, 0.7, t, P);
        ASSERT_INT_EQ(mdl__kblend_frame(V, mk, NT, NV, NM, 0.5, P, use, scratch, out), 0);
        for (int i = 0; i < NV * 3; i++)
            ASSERT_LT_I(fabs(out[i] - want[i]), 1e-5, i);
    }

    /* halfway between frames 0 and 1: both fit equally (their markers differ by a non-rigid
     * change), frame 2 is far */
    {
        float mid[NV * 3], Pm[NM * 3];
        for (int i = 0; i < NV * 3; i++)
            mid[i] = 0.5f * (V[i] + V[NV * 3 + i]);
        for (int i = 0; i < NM * 3; i++)
            Pm[i] = mid[i];
        place(Pm, NM, -0.3, t, P);
        ASSERT_INT_EQ(mdl__kblend_frame(V, mk, NT, NV, NM, 1.0, P, use, scratch, out), 0);
        /* the result, placed back by the same motion, is the mean of frames 0 and 1 placed by
         * their own fits; with the two fits mirror images of each other about the mean, that is
         * close to the mean itself */
        place(mid, NV, -0.3, t, want);
        double e = 0;
        for (int i = 0; i < NV * 3; i++)
            e = fmax(e, fabs(out[i] - want[i]));
        printf("halfway: max |blend - mean| %.2e\n", e);
        ASSERT_LT(e, 0.02);
    }

    /* an unused marker may be anything */
    {
        place(mk + NM * 3, NM, 0.2, t, P);
        place(V + NV * 3, NV, 0.2, t, want);
        P[0] = 1e3f;
        uint8_t u3[NM] = {0, 1, 1, 1};
        ASSERT_INT_EQ(mdl__kblend_frame(V, mk, NT, NV, NM, 0.5, P, u3, scratch, out), 0);
        for (int i = 0; i < NV * 3; i++)
            ASSERT_LT_I(fabs(out[i] - want[i]), 1e-4, i);
        uint8_t u2[NM] = {0, 1, 0, 1};
        for (int i = 0; i < NV * 3; i++)
            out[i] = -7;
        ASSERT_INT_EQ(mdl__kblend_frame(V, mk, NT, NV, NM, 0.5, P, u2, scratch, out), -EAGAIN);
        for (int i = 0; i < NV * 3; i++)
            ASSERT_INT_EQ(out[i] == -7, 1);
    }
    printf("kblend: ok\n");
    return 0;
}
