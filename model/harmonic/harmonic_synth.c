/* harmonic_synth.c - driving the harmonic model from markers and joint rotations: the template of
 * de Aguiar et al. 2007 Sec. 5 without 3ds Max ("their bones become template triangles").
 *
 * With joint rotations (MDL_INPUT_JOINTS, a BVH or ASF/AMC source; h->bone_j >= 0): the bone's
 * rotation is A R_j(t) R_j(rest)^T A^T C_g^T (R_j the world rotation of the segment that drives the
 * bone, A the template-to-target alignment - a scale and a translation, so A's rotation is the
 * identity - and C_g the rest fit's turn of the bone), then the shortest arc from where that puts
 * the fitted rest direction onto the markers' direction (none for a one-segment bone, a chain's bend
 * otherwise): the full rotation, twist included. A bone whose joint is invalid takes the path below.
 * Without them (or for such a bone):
 * The template is a skeleton of bones, each a pair of markers (a, b) - joint positions by forward
 * kinematics from BVH or ASF/AMC, or any tracked points - with an optional third marker c. Per frame:
 *   - markers are mapped into the target's space by the rest alignment (p' = s p + t);
 *   - without c: the bone's rotation is the shortest-arc rotation of its rest direction b0 - a0 onto
 *     b - a (swing only: a turn about the bone's own axis is invisible, so a forearm's pronation or
 *     a head turning about the neck axis is lost, and the limb keeps its rest roll);
 *   - with c: the frame (e1 = b - a, e2 = the part of c - a normal to e1, e3 = e1 x e2) at rest and
 *     now gives R = E E0^T, the full rotation; as c - a becomes parallel to the bone (|e2| from 15 %
 *     down to 5 % of |c - a|) it is blended into the swing, and below that swing only;
 *   - an invalid marker is replaced by its last valid position; a bone never seen keeps identity;
 *   - groups = bones (step 1 of Sec. 4.1); the deformer does steps 2-6;
 *   - the global position (Sec. 5, "brings it to a correct global position"): the result is moved so
 *     that the target vertex nearest the root joint at rest follows the root marker, carried by the
 *     root bone's rotation: x_anchor = root + R_root (x_anchor_rest - root_rest).
 * create allocates (and factorises); frame allocates nothing. */
#include "harmonic/harmonic_internal.h"
#include "kind.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct hsynth {
    const struct mdl_harmonic *h;
    mdl__hdeform d;
    const float *rest;
    int nv;
    float *mk;       /* nmk x 3, aligned, last valid */
    uint8_t *seen;   /* nmk */
    double *qg;      /* ngroups x 4 */
} hsynth;

static void cross(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static double norm3(double *v)
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 0)
        v[0] /= n, v[1] /= n, v[2] /= n;
    return n;
}

/* the frame of a bone: e1 along a->b, e2 from c (returns 0 when c is missing or degenerate).
 * *wt: how far c is from the bone's line, as a weight of the twist (TWIST_LO .. TWIST_HI of |c - a|
 * map to 0 .. 1) */
#define TWIST_LO 0.05
#define TWIST_HI 0.15
static int bone_frame(const float *a, const float *b, const float *c, double E[9], double *wt)
{
    *wt = 0;
    double e1[3], e2[3], e3[3];
    for (int k = 0; k < 3; k++)
        e1[k] = (double)b[k] - a[k];
    if (norm3(e1) < 1e-9)
        return -1;
    E[0] = e1[0], E[3] = e1[1], E[6] = e1[2];
    if (!c)
        return 0;
    double v[3], d = 0;
    for (int k = 0; k < 3; k++) {
        v[k] = (double)c[k] - a[k];
        d += v[k] * e1[k];
    }
    for (int k = 0; k < 3; k++)
        e2[k] = v[k] - d * e1[k];
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double n2 = norm3(e2);
    if (n2 < TWIST_LO * l || l <= 0)
        return 0;
    *wt = fmin(1.0, (n2 / l - TWIST_LO) / (TWIST_HI - TWIST_LO));
    cross(e1, e2, e3);
    /* columns e1 e2 e3, row-major */
    E[1] = e2[0], E[4] = e2[1], E[7] = e2[2];
    E[2] = e3[0], E[5] = e3[1], E[8] = e3[2];
    return 1;
}

/* the shortest-arc rotation of unit d0 onto unit d */
static void swing(const double *d0, const double *d, double q[4])
{
    double ax[3];
    cross(d0, d, ax);
    double s = norm3(ax), c = d0[0] * d[0] + d0[1] * d[1] + d0[2] * d[2];
    if (s < 1e-12) {
        if (c > 0) {
            q[0] = 1, q[1] = q[2] = q[3] = 0;
            return;
        }
        /* opposite: any axis normal to d0 */
        double t[3] = {fabs(d0[0]) < 0.9 ? 1 : 0, fabs(d0[0]) < 0.9 ? 0 : 1, 0};
        cross(d0, t, ax);
        norm3(ax);
    }
    double th = atan2(s, c);
    q[0] = cos(th / 2);
    for (int k = 0; k < 3; k++)
        q[k + 1] = sin(th / 2) * ax[k];
}

void mdl__harmonic_bone_quat(const float *a0, const float *b0, const float *c0, const float *a,
                             const float *b, const float *c, double q[4])
{
    double E0[9], E[9], w0, w;
    int f0 = bone_frame(a0, b0, c0, E0, &w0), f = bone_frame(a, b, c, E, &w);
    if (f0 < 0 || f < 0) {
        q[0] = 1, q[1] = q[2] = q[3] = 0;
        return;
    }
    double d0[3] = {E0[0], E0[3], E0[6]}, d[3] = {E[0], E[3], E[6]};
    swing(d0, d, q);
    if (f0 == 1 && f == 1) {
        double R[9], qf[4];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                R[3 * i + j] = E[3 * i] * E0[3 * j] + E[3 * i + 1] * E0[3 * j + 1] + E[3 * i + 2] * E0[3 * j + 2];
        mdl__mat_to_quat(R, qf);
        mdl__qnorm(qf);
        /* the twist fades out as c nears the bone's line, where its frame spins: a thigh twisted
         * by the toe flipped by 170 deg in one frame when the bent leg brought the toe onto the
         * thigh's axis (131_03.bvh); blended, it passes through the swing instead */
        double t = fmin(w0, w), dq = q[0] * qf[0] + q[1] * qf[1] + q[2] * qf[2] + q[3] * qf[3];
        double sg = dq < 0 ? -1 : 1;
        for (int k = 0; k < 4; k++)
            q[k] = (1 - t) * q[k] + t * sg * qf[k];
        mdl__qnorm(q);
    }
}

/* quaternion product a b (w first) */
static void qmul(const double *a, const double *b, double *c)
{
    double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    c[0] = w, c[1] = x, c[2] = y, c[3] = z;
}

double mdl__harmonic_joint_quat(const double q_t[4], const double q_rest[4], const double C[4],
                                const double *d0, const double *d, double q[4])
{
    double rc[4] = {q_rest[0], -q_rest[1], -q_rest[2], -q_rest[3]}, cc[4] = {C[0], -C[1], -C[2], -C[3]};
    double Q[4];
    qmul(q_t, rc, Q);
    qmul(Q, cc, q);
    mdl__qnorm(q);
    if (!d0 || !d)
        return 0;
    /* the fitted rest direction as the joint turns it, then the arc onto the markers' direction */
    double R[9], v[3], sw[4], out[4];
    mdl__quat_to_mat(q, R);
    for (int i = 0; i < 3; i++)
        v[i] = R[3 * i] * d0[0] + R[3 * i + 1] * d0[1] + R[3 * i + 2] * d0[2];
    norm3(v);
    swing(v, d, sw);
    qmul(sw, q, out);
    memcpy(q, out, sizeof out);
    mdl__qnorm(q);
    return 2 * acos(fmin(1.0, fabs(sw[0])));
}

int mdl__harmonic_synth_create(const mdl_model *m, const void *impl, void **state, char *err)
{
    const struct mdl_harmonic *h = impl;
    *state = NULL;
    hsynth *s = mdl__calloc(1, sizeof *s);
    if (!s)
        return mdl__err(err, -ENOMEM, "harmonic synthesis: out of memory");
    s->h = h;
    s->rest = m->rest;
    s->nv = m->nv;
    s->mk = mdl__calloc(3 * (size_t)h->nmk + 3, sizeof *s->mk);
    s->seen = mdl__calloc((size_t)h->nmk + 1, 1);
    s->qg = mdl__calloc(4 * (size_t)h->ngroups + 4, sizeof *s->qg);
    int rc = 0;
    if (!s->mk || !s->seen || !s->qg)
        rc = mdl__err(err, -ENOMEM, "harmonic synthesis: out of memory");
    if (!rc)
        rc = mdl__hdeform_init(&s->d, h, m->rest, m->F, err);
    if (rc) {
        free(s->mk);
        free(s->seen);
        free(s->qg);
        free(s);
        return rc;
    }
    *state = s;
    return 0;
}

void mdl__harmonic_synth_destroy(void *state)
{
    hsynth *s = state;
    if (!s)
        return;
    mdl__hdeform_fini(&s->d);
    free(s->mk);
    free(s->seen);
    free(s->qg);
    free(s);
}

void mdl__harmonic_synth_reset(void *state)
{
    hsynth *s = state;
    memset(s->seen, 0, (size_t)s->h->nmk);
    mdl__hdeform_reset(&s->d);
}

void mdl__harmonic_synth_marker_placement(const void *state, double *scale, double t[3])
{
    const hsynth *s = state;
    *scale = s->h->align_scale;
    for (int c = 0; c < 3; c++)
        t[c] = s->h->align_t[c];
}

int mdl__harmonic_synth_frame(void *state, const mdl_synth_input *in, float *V, mdl_synth_info *info)
{
    hsynth *s = state;
    const struct mdl_harmonic *h = s->h;
    if (info)
        memset(info, 0, sizeof *info);
    if (h->nbones == 0 || !in->markers)
        return -EINVAL; /* an auto:K model has no template to be driven by */
    for (int i = 0; i < h->nmk; i++) {
        int ok = !in->valid || in->valid[i];
        const float *p = in->markers + 3 * i;
        ok = ok && isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
        if (ok) {
            for (int c = 0; c < 3; c++)
                s->mk[3 * i + c] = (float)(h->align_scale * p[c] + h->align_t[c]);
            s->seen[i] = 1;
        } else if (info) {
            info->markers_missing++;
            info->markers_held += s->seen[i];
        }
    }
    if (!s->seen[h->root_marker]) {
        if (info)
            info->reference_lost = 1;
        return -EAGAIN;
    }
    for (int g = 0; g < h->nbones; g++) {
        int a = h->bone_a[g], b = h->bone_b[g], c = h->bone_c[g];
        double *q = s->qg + 4 * g;
        /* the joint's rotation, where the source gives it (the full rotation, twist included) */
        int j = h->bone_j ? h->bone_j[g] : -1;
        if (j >= 0 && in->joint_rot && j < in->njoints && (!in->joint_valid || in->joint_valid[j])) {
            const float *r = in->joint_rot + 4 * (size_t)j;
            double qt[4] = {r[0], r[1], r[2], r[3]};
            double n = qt[0] * qt[0] + qt[1] * qt[1] + qt[2] * qt[2] + qt[3] * qt[3];
            if (isfinite(n) && n > 0.25 && n < 4) {
                double d0[3], d[3];
                int dir = s->seen[a] && s->seen[b];
                for (int k = 0; k < 3 && dir; k++) {
                    d0[k] = (double)h->mk_rest[3 * b + k] - h->mk_rest[3 * a + k];
                    d[k] = (double)s->mk[3 * b + k] - s->mk[3 * a + k];
                }
                dir = dir && norm3(d0) > 1e-9 && norm3(d) > 1e-9;
                mdl__qnorm(qt);
                double arc = mdl__harmonic_joint_quat(qt, h->bone_jrest + 4 * g, h->bone_fit + 4 * g,
                                                      dir ? d0 : NULL, dir ? d : NULL, q);
                if (info) {
                    info->joints_used++;
                    info->joint_arc_max = fmax(info->joint_arc_max, arc);
                }
                continue;
            }
        }
        if (!s->seen[a] || !s->seen[b]) {
            q[0] = 1, q[1] = q[2] = q[3] = 0;
            continue;
        }
        int twist = c >= 0 && s->seen[c];
        mdl__harmonic_bone_quat(h->mk_rest + 3 * a, h->mk_rest + 3 * b, twist ? h->mk_rest + 3 * c : NULL,
                                s->mk + 3 * a, s->mk + 3 * b, twist ? s->mk + 3 * c : NULL, q);
    }
    int rc = mdl__hdeform_run(&s->d, s->qg);
    if (rc)
        return rc;
    /* the global position (Sec. 5) */
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, off[3], goal[3], sh[3];
    if (h->root_bone >= 0)
        mdl__quat_to_mat(s->d.qg + 4 * h->root_bone, R);
    const float *r0 = h->mk_rest + 3 * h->root_marker, *r = s->mk + 3 * h->root_marker;
    const float *xa = s->rest + 3 * (size_t)h->anchor_vertex;
    for (int c = 0; c < 3; c++)
        off[c] = (double)xa[c] - r0[c];
    for (int c = 0; c < 3; c++) {
        goal[c] = r[c] + R[3 * c] * off[0] + R[3 * c + 1] * off[1] + R[3 * c + 2] * off[2];
        sh[c] = goal[c] - s->d.X[3 * (size_t)h->anchor_vertex + c];
    }
    for (int v = 0; v < s->nv; v++)
        for (int c = 0; c < 3; c++)
            V[3 * v + c] = (float)(s->d.X[3 * (size_t)v + c] + sh[c]);
    return 0;
}
