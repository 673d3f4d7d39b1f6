/* heading.c - the body frame of an upright reference edge from all present markers (heading.h). */
#include "steer/heading.h"
#include "steer/posefeat.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Weighted absolute orientation (Horn 1987, rigid.h) of the canonical configuration (hd) onto the
 * points X (nm x 3, double or float through the accessor below): R, t with X ~ R c + t. */
static int fit(const double *hd, const float *Pf, const double *Pd, const uint8_t *valid, int nm,
               double R[9], double t[3])
{
    double W = 0, cb[3] = {0, 0, 0}, pb[3] = {0, 0, 0};
    for (int j = 0; j < nm; j++) {
        double w = hd[4 * j + 3];
        if (w <= 0 || (valid && !valid[j]))
            continue;
        W += w;
        for (int c = 0; c < 3; c++) {
            cb[c] += w * hd[4 * j + c];
            pb[c] += w * (Pf ? Pf[3 * j + c] : Pd[3 * j + c]);
        }
    }
    if (!(W > 0))
        return -1;
    for (int c = 0; c < 3; c++) {
        cb[c] /= W;
        pb[c] /= W;
    }
    double S[9] = {0}; /* S = sum w (c - cb)(p - pb)^T */
    int n = 0;
    for (int j = 0; j < nm; j++) {
        double w = hd[4 * j + 3];
        if (w <= 0 || (valid && !valid[j]))
            continue;
        n++;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                S[3 * a + b] += w * (hd[4 * j + a] - cb[a]) *
                                ((Pf ? Pf[3 * j + b] : Pd[3 * j + b]) - pb[b]);
    }
    if (n < 3)
        return -1;
    double q[4];
    mdl__rot_from_cov(S, q, R);
    for (int r = 0; r < 3; r++)
        t[r] = pb[r] - (R[3 * r] * cb[0] + R[3 * r + 1] * cb[1] + R[3 * r + 2] * cb[2]);
    return 0;
}

int mdl__heading_frame(const float *P, const uint8_t *valid, int nm, const int *ref,
                       const double *hd, double R[9], double o[3])
{
    if (fit(hd, P, NULL, valid, nm, R, o) == 0)
        return 0;
    return mdl__body_frame(P, 2, ref, 1, R, o); /* too few markers: the edge alone */
}

int mdl__heading_train(const float *P, int frames, size_t stride, int nm, const int *ref,
                       double noise, double *hd)
{
    double *B = mdl__calloc((size_t)frames * nm * 3, sizeof *B);
    double *C = mdl__calloc((size_t)nm * 4, sizeof *C); /* sums: xyz, squared norm */
    uint8_t *ok = mdl__calloc((size_t)frames, 1);
    if (!B || !ok || !C) {
        free(B);
        free(C);
        free(ok);
        return -ENOMEM;
    }
    int first = -1;
    for (int f = 0; f < frames; f++) { /* start: every frame in its reference-edge frame */
        double R[9], o[3];
        const float *Pf = P + (size_t)f * stride;
        if (mdl__body_frame(Pf, 2, ref, 1, R, o))
            continue;
        ok[f] = 1;
        if (first < 0)
            first = f;
        for (int j = 0; j < nm; j++) {
            double d[3] = {Pf[3 * j] - o[0], Pf[3 * j + 1] - o[1], Pf[3 * j + 2] - o[2]};
            for (int c = 0; c < 3; c++)
                B[((size_t)f * nm + j) * 3 + c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
        }
    }
    if (first < 0) {
        free(B);
        free(C);
        free(ok);
        return -EINVAL;
    }
    for (int j = 0; j < nm; j++) {
        memcpy(hd + 4 * j, B + ((size_t)first * nm + j) * 3, 3 * sizeof(double));
        hd[4 * j + 3] = 1;
    }
    for (int it = 0; it < 8; it++) { /* generalised Procrustes: align, average, reweight */
        memset(C, 0, (size_t)nm * 4 * sizeof *C);
        int n = 0;
        for (int f = 0; f < frames; f++) {
            const double *b = B + (size_t)f * nm * 3;
            double R[9], t[3];
            if (!ok[f] || fit(hd, NULL, b, NULL, nm, R, t))
                continue;
            for (int j = 0; j < nm; j++) { /* aligned = R^T (b - t) */
                double d[3] = {b[3 * j] - t[0], b[3 * j + 1] - t[1], b[3 * j + 2] - t[2]}, a[3];
                for (int c = 0; c < 3; c++) {
                    a[c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
                    C[4 * j + c] += a[c];
                }
                C[4 * j + 3] += a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
            }
            n++;
        }
        if (n == 0)
            break;
        for (int j = 0; j < nm; j++) {
            double m2 = 0;
            for (int c = 0; c < 3; c++) {
                hd[4 * j + c] = C[4 * j + c] / n;
                m2 += hd[4 * j + c] * hd[4 * j + c];
            }
            double var = C[4 * j + 3] / n - m2;
            hd[4 * j + 3] = 1.0 / ((var > 0 ? var : 0) + MDL_HEADING_EPS * MDL_HEADING_EPS +
                                   3 * noise * noise);
        }
    }
    /* the gauge: the canonical configuration's own reference edge along e1, +Z made orthogonal
     * to it along e2, the first reference marker at the origin (posefeat.h's axis-1 frame) */
    double *A = hd + 4 * ref[0], *Bm = hd + 4 * ref[1];
    double e1[3] = {Bm[0] - A[0], Bm[1] - A[1], Bm[2] - A[2]}, o[3] = {A[0], A[1], A[2]};
    double n1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    if (n1 > 1e-9) {
        for (int c = 0; c < 3; c++)
            e1[c] /= n1;
        double e2[3] = {-e1[2] * e1[0], -e1[2] * e1[1], 1 - e1[2] * e1[2]}; /* Z - (Z.e1) e1 */
        double n2 = sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
        if (n2 > 1e-9) {
            for (int c = 0; c < 3; c++)
                e2[c] /= n2;
            double e3[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                            e1[0] * e2[1] - e1[1] * e2[0]};
            for (int j = 0; j < nm; j++) {
                double d[3] = {hd[4 * j] - o[0], hd[4 * j + 1] - o[1], hd[4 * j + 2] - o[2]};
                hd[4 * j] = e1[0] * d[0] + e1[1] * d[1] + e1[2] * d[2];
                hd[4 * j + 1] = e2[0] * d[0] + e2[1] * d[1] + e2[2] * d[2];
                hd[4 * j + 2] = e3[0] * d[0] + e3[1] * d[1] + e3[2] * d[2];
            }
        }
    }
    free(C);
    free(B);
    free(ok);
    return 0;
}

int mdl__body_frame_any(const float *P, const uint8_t *valid, int nm, int nref, const int *ref,
                        int axis, const double *hd, double R[9], double o[3])
{
    if (axis == MDL_AXIS_FIT && hd && nref == 2)
        return mdl__heading_frame(P, valid, nm, ref, hd, R, o);
    return mdl__body_frame(P, nref, ref, axis == MDL_AXIS_FIT ? 1 : axis, R, o);
}
