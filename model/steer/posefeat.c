/* posefeat.c - body frame and limb pose parameters of paper 2012 Table 1 (see posefeat.h). */
#include "steer/posefeat.h"

#include <math.h>

static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

static void cross3(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

int mdl__ref_axis(const float *P, int frames, size_t stride, const int *ref)
{
    double sum = 0;
    int n = 0;
    for (int f = 0; f < frames; f++) {
        const float *a = P + f * stride + 3 * ref[0], *b = P + f * stride + 3 * ref[1];
        double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double len = norm3(e);
        if (len > 1e-9) {
            sum += fabs(e[1]) / len;
            n++;
        }
    }
    return n > 0 && sum / n > 0.7;
}

int mdl__body_frame(const float *P, int nref, const int *ref, int axis, double R[9], double o[3])
{
    const float *a = P + 3 * ref[0], *b = P + 3 * ref[1];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double n = norm3(e1);
    if (!(n > 1e-9))
        return -1;
    for (int k = 0; k < 3; k++) {
        e1[k] /= n;
        o[k] = a[k];
    }
    double up[3] = {0, 1, 0}, e2[3], e3[3];
    if (nref >= 3) {
        const float *c = P + 3 * ref[2];
        double side[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double nrm[3];
        cross3(e1, side, nrm);
        if (norm3(nrm) > 1e-9)
            cross3(nrm, e1, up);
    } else if (axis == 1) {
        up[0] = 0;
        up[1] = 0;
        up[2] = 1;
    }
    double d = up[0] * e1[0] + up[1] * e1[1] + up[2] * e1[2];
    for (int k = 0; k < 3; k++)
        e2[k] = up[k] - d * e1[k];
    n = norm3(e2);
    if (!(n > 1e-9))
        return -1;
    for (int k = 0; k < 3; k++)
        e2[k] /= n;
    cross3(e1, e2, e3);
    for (int r = 0; r < 3; r++) {
        R[3 * r + 0] = e1[r];
        R[3 * r + 1] = e2[r];
        R[3 * r + 2] = e3[r];
    }
    return 0;
}

double mdl__body_heading(const double R[9])
{
    /* columns: e1 = (R[0], R[3], R[6]), e3 = (R[2], R[5], R[8]) */
    if (fabs(R[3]) < 0.9)
        return atan2(R[0], R[6]);
    return atan2(R[2], R[8]) - M_PI / 2;
}

int mdl__limb_nfeat(int path_len, int use_motion)
{
    int edges = path_len - 1;
    return edges * 4 + 1 + (edges - 1) + 3 + (use_motion ? 3 * path_len : 0);
}

/* body = R^T (p - o) */
static void to_body(const double R[9], const double o[3], const float *p, double out[3])
{
    double d[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
    for (int c = 0; c < 3; c++)
        out[c] = R[c] * d[0] + R[3 + c] * d[1] + R[6 + c] * d[2];
}

static double angle_between(const double u[3], const double v[3])
{
    double c = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    if (c > 1)
        c = 1;
    if (c < -1)
        c = -1;
    return acos(c);
}

void mdl__limb_features(const float *P, const float *Pprev, const int *path, int path_len,
                        const double R[9], const double o[3], int use_motion, double *feat)
{
    int k = 0;
    double prev_dir[3] = {1, 0, 0}; /* e_ref is the body frame's first axis */
    for (int j = 0; j + 1 < path_len; j++) {
        double a[3], b[3], e[3];
        to_body(R, o, P + 3 * path[j], a);
        to_body(R, o, P + 3 * path[j + 1], b);
        for (int c = 0; c < 3; c++)
            e[c] = b[c] - a[c];
        double len = norm3(e);
        double u[3] = {1, 0, 0};
        if (len > 1e-12)
            for (int c = 0; c < 3; c++)
                u[c] = e[c] / len;
        feat[k++] = u[0];
        feat[k++] = u[1];
        feat[k++] = u[2];
        feat[k++] = len;
        feat[k++] = angle_between(prev_dir, u); /* alpha_1 against e_ref, then alpha_j */
        for (int c = 0; c < 3; c++)
            prev_dir[c] = u[c];
    }
    double end[3];
    to_body(R, o, P + 3 * path[path_len - 1], end);
    feat[k++] = end[0];
    feat[k++] = end[1];
    feat[k++] = end[2];
    if (use_motion) {
        for (int j = 0; j < path_len; j++) {
            double d[3] = {0, 0, 0};
            if (Pprev) {
                const float *p = P + 3 * path[j], *q = Pprev + 3 * path[j];
                double w[3] = {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
                for (int c = 0; c < 3; c++)
                    d[c] = R[c] * w[0] + R[3 + c] * w[1] + R[6 + c] * w[2];
                /* soft normalisation: the direction for movements well above MDL_MOTION_EPS
                 * per frame, shrinking to zero below it, so that marker noise on a still
                 * marker does not become a full-size random direction */
                double n = sqrt(norm3(d) * norm3(d) + MDL_MOTION_EPS * MDL_MOTION_EPS);
                for (int c = 0; c < 3; c++)
                    d[c] /= n;
            }
            feat[k++] = d[0];
            feat[k++] = d[1];
            feat[k++] = d[2];
        }
    }
}
