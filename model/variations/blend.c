/* blend.c - splicing two segments of the example (Zheng 2013 Sec. 3.3): the reference bone matched
 * rigidly (eq. 7), the other bones blended in its local frame over a window of L = o.blend output
 * frames, and back to the world frame (eq. 10).
 *
 *   eq. (7)   the segment S_j->b is moved by the fixed rigid transform that puts b_r of frame j on
 *             b_r of frame i: G <- G (R_r(i) R_r(j)^T, t_r(i) - R_r(i) R_r(j)^T t_r(j)), so that
 *             R~_r(k) = G_R R_r(k), t~_r(k) = G_R t_r(k) + G_t for every later frame k; the
 *             velocity of b_r stays smooth because D (eq. 5) matched it (the beta term).
 *   gradient  (the default, the paper's) the key vertices' deformation gradients blended by the
 *             1-D Poisson solve and the bones solved from them by eq. 9 (gblend.c), which needs
 *             the linear blend below as its pull for what the gradients leave undetermined.
 *   linear    (o.blend_linear, the simple scheme Fig. 6 compares against) the local-frame bone
 *             coordinates (eq. 2) of the new segment are carried from the old one's at the splice
 *             and let go linearly over the window:
 *               R~_b->r(j + k) = Exp(s_k Phi(R_b->r(i) R_b->r(j)^T)) R_b->r(j + k),
 *               x~_b(j + k) = x_b(j + k) + s_k (x_b(i) - x_b(j)),   s_k = 1 - k / L,
 *             where x_b = R_b->r c_b + t_b->r is where the bone's centre c_b (the weighted centroid
 *             of its rest vertices) goes, and t~_b->r = x~_b - R~_b->r c_b: the rotation is blended
 *             about the bone's own centre, not about the origin, whose lever arm would swing the
 *             vertices between the two ends of the window;
 *             which is the linear blend (1 - s) S_j->b + s S_a->i of the two segments wherever
 *             their difference stays what it was at the splice, and needs no frames of S_a->i
 *             after i (a splice at the last input frame has none). A splice inside an earlier
 *             window starts from the blended coordinates, so windows chain without a jump.
 *   eq. (10)  F~_b = R~_r R~_b->r,  t~_b = R~_r t~_b->r + t~_r: rotations stay rotations.
 *   ground    (Sec. 5, the dancers: "the reference bones ... rigidly transformed only on the
 *             ground plane") the transform of eq. 7 is replaced by its turn about the up axis y
 *             (the angle atan2(A_02 - A_20, A_00 + A_22) of A = R_r(i) R_r(j)^T, the closest
 *             such turn) and the horizontal part of its shift, so the reference bone keeps the
 *             input's height and tilt; what eq. 7 would have matched (the tilt and height of
 *             frame i against frame j) is carried as an offset of b_r, about its centre, and let
 *             go linearly over the window like the other bones' offsets.
 * Per step: no allocation (the offsets and the gradient blend's scratch are sized at init),
 * doubles. */
#include "variations/variations.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int mdl__vblend_init(mdl__vblend *b, const struct mdl_variations *v)
{
    memset(b, 0, sizeof *b);
    b->om = mdl__calloc(3 * (size_t)v->nb, sizeof *b->om);
    b->dt = mdl__calloc(3 * (size_t)v->nb, sizeof *b->dt);
    if (v->nkey > 0) {
        b->kom = mdl__calloc(3 * (size_t)v->nkey, sizeof *b->kom);
        b->kdS = mdl__calloc(6 * (size_t)v->nkey, sizeof *b->kdS);
        b->R = mdl__calloc(9 * (size_t)v->nkey, sizeof *b->R);
        b->X = mdl__calloc(3 * (size_t)v->nu, sizeof *b->X);
        b->X0 = mdl__calloc(3 * (size_t)v->nu, sizeof *b->X0);
        if (!b->kom || !b->kdS || !b->R || !b->X || !b->X0) {
            mdl__vblend_fini(b);
            return -ENOMEM;
        }
    }
    if (!b->om || !b->dt) {
        mdl__vblend_fini(b);
        return -ENOMEM;
    }
    mdl__vblend_reset(b, v);
    return 0;
}

void mdl__vblend_fini(mdl__vblend *b)
{
    free(b->om);
    free(b->dt);
    free(b->kom);
    free(b->kdS);
    free(b->R);
    free(b->X);
    free(b->X0);
    b->om = b->dt = b->kom = b->kdS = b->R = b->X = b->X0 = NULL;
}

void mdl__vblend_reset(mdl__vblend *b, const struct mdl_variations *v)
{
    static const double I[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    memcpy(b->G, I, sizeof I);
    memset(b->om, 0, 3 * (size_t)v->nb * sizeof *b->om);
    memset(b->dt, 0, 3 * (size_t)v->nb * sizeof *b->dt);
    memset(b->rom, 0, sizeof b->rom);
    memset(b->rdt, 0, sizeof b->rdt);
    if (b->kom) {
        memset(b->kom, 0, 3 * (size_t)v->nkey * sizeof *b->kom);
        memset(b->kdS, 0, 6 * (size_t)v->nkey * sizeof *b->kdS);
    }
    b->since = v->o.blend;
}

/* the gradient blend runs (a graph built with it, in a window) */
static int gradient(const mdl__vblend *b, const struct mdl_variations *v)
{
    return b->kom && !v->o.blend_linear && b->since < v->o.blend;
}

static double weight(const mdl__vblend *b, const struct mdl_variations *v)
{
    return b->since < v->o.blend ? 1 - (double)b->since / v->o.blend : 0;
}

/* the blended local frame of bone k at input frame c */
static void local(const mdl__vblend *b, const struct mdl_variations *v, int f, int k, double s,
                  double R[9], double t[3])
{
    const double *LR = v->LR + 9 * ((size_t)f * v->nb + k), *Lt = v->Lt + 3 * ((size_t)f * v->nb + k);
    if (s <= 0 || k == v->ref) {
        memcpy(R, LR, 9 * sizeof *R);
        memcpy(t, Lt, 3 * sizeof *t);
        return;
    }
    double w[3], E[9];
    const double *c = v->centre + 3 * (size_t)k;
    for (int a = 0; a < 3; a++)
        w[a] = s * b->om[3 * k + a];
    mdl__so3_exp(w, E);
    mdl__mat3_mul(E, LR, R);
    for (int a = 0; a < 3; a++) {
        /* x = LR c + Lt + s dx, t = x - R c */
        double x = LR[3 * a] * c[0] + LR[3 * a + 1] * c[1] + LR[3 * a + 2] * c[2] + Lt[a] +
                   s * b->dt[3 * k + a];
        t[a] = x - (R[3 * a] * c[0] + R[3 * a + 1] * c[1] + R[3 * a + 2] * c[2]);
    }
}

/* the reference bone's world pose at input frame c in the current segment (eq. 7), with the
 * ground offset at weight s */
static void ref_pose(const mdl__vblend *b, const struct mdl_variations *v, int c, double s,
                     double Rr[9], double tr[3])
{
    const double *Tr = v->T + 12 * ((size_t)c * v->nb + v->ref);
    mdl__mat3_mul(b->G, Tr, Rr);
    for (int a = 0; a < 3; a++)
        tr[a] = b->G[3 * a] * Tr[9] + b->G[3 * a + 1] * Tr[10] + b->G[3 * a + 2] * Tr[11] + b->G[9 + a];
    if (!v->o.ground || s <= 0)
        return;
    /* x = Rr c + tr moves by s rdt; the rotation Exp(s rom) turns about x */
    const double *cc = v->centre + 3 * (size_t)v->ref;
    double w[3] = {s * b->rom[0], s * b->rom[1], s * b->rom[2]}, E[9], R2[9], x[3];
    mdl__so3_exp(w, E);
    mdl__mat3_mul(E, Rr, R2);
    for (int a = 0; a < 3; a++)
        x[a] = Rr[3 * a] * cc[0] + Rr[3 * a + 1] * cc[1] + Rr[3 * a + 2] * cc[2] + tr[a] + s * b->rdt[a];
    memcpy(Rr, R2, sizeof R2);
    for (int a = 0; a < 3; a++)
        tr[a] = x[a] - (Rr[3 * a] * cc[0] + Rr[3 * a + 1] * cc[1] + Rr[3 * a + 2] * cc[2]);
}

void mdl__vblend_pose(const mdl__vblend *b, const struct mdl_variations *v, int c, double *T)
{
    double Rr[9], tr[3];
    double s = weight(b, v);
    ref_pose(b, v, c, s, Rr, tr);
    for (int k = 0; k < v->nb; k++) /* the local frames first */
        local(b, v, c, k, s, T + 12 * (size_t)k, T + 12 * (size_t)k + 9);
    if (gradient(b, v))
        mdl__gblend_local(b, v, c, v->hramp[b->since], T);
    for (int k = 0; k < v->nb; k++) { /* eq. (10) */
        double R[9], t[3];
        double *M = T + 12 * (size_t)k;
        memcpy(R, M, sizeof R);
        memcpy(t, M + 9, sizeof t);
        mdl__mat3_mul(Rr, R, M);
        for (int a = 0; a < 3; a++)
            M[9 + a] = Rr[3 * a] * t[0] + Rr[3 * a + 1] * t[1] + Rr[3 * a + 2] * t[2] + tr[a];
    }
}

void mdl__vblend_splice(mdl__vblend *b, const struct mdl_variations *v, int i, int j)
{
    double s = weight(b, v);
    if (b->kom && !v->o.blend_linear && v->o.blend > 0)
        mdl__gblend_splice(b, v, i, j, gradient(b, v) ? v->hramp[b->since] : 0);
    if (v->o.blend > 0)
        for (int k = 0; k < v->nb; k++) {
            if (k == v->ref)
                continue;
            double R[9], t[3], D[9];
            local(b, v, i, k, s, R, t);
            const double *LRj = v->LR + 9 * ((size_t)j * v->nb + k);
            const double *Ltj = v->Lt + 3 * ((size_t)j * v->nb + k);
            mdl__mat3_mul_t(R, LRj, D);
            mdl__so3_log(D, b->om + 3 * k);
            const double *c = v->centre + 3 * (size_t)k;
            for (int a = 0; a < 3; a++)
                b->dt[3 * k + a] = (R[3 * a] * c[0] + R[3 * a + 1] * c[1] + R[3 * a + 2] * c[2] + t[a]) -
                                   (LRj[3 * a] * c[0] + LRj[3 * a + 1] * c[1] + LRj[3 * a + 2] * c[2] + Ltj[a]);
        }
    /* eq. (7): G <- G * (T_r(i) T_r(j)^-1) */
    const double *Ti = v->T + 12 * ((size_t)i * v->nb + v->ref);
    const double *Tj = v->T + 12 * ((size_t)j * v->nb + v->ref);
    double A[9], At[3], G[12], Ri[9], ti[3];
    if (v->o.ground)
        ref_pose(b, v, i, s, Ri, ti); /* where b_r is shown at i, offsets included */
    mdl__mat3_mul_t(Ti, Tj, A);
    if (v->o.ground) { /* the closest turn about y */
        double th = atan2(A[2] - A[6], A[0] + A[8]), c = cos(th), sn = sin(th);
        const double Y[9] = {c, 0, sn, 0, 1, 0, -sn, 0, c};
        memcpy(A, Y, sizeof Y);
    }
    for (int a = 0; a < 3; a++)
        At[a] = Ti[9 + a] - (A[3 * a] * Tj[9] + A[3 * a + 1] * Tj[10] + A[3 * a + 2] * Tj[11]);
    if (v->o.ground)
        At[1] = 0;
    mdl__mat3_mul(b->G, A, G);
    for (int a = 0; a < 3; a++)
        G[9 + a] = b->G[3 * a] * At[0] + b->G[3 * a + 1] * At[1] + b->G[3 * a + 2] * At[2] + b->G[9 + a];
    /* keep G a rotation as splices accumulate */
    double q[4];
    mdl__mat_to_quat(G, q);
    mdl__quat_to_mat(q, b->G);
    memcpy(b->G + 9, G + 9, 3 * sizeof *G);
    b->since = 0;
    if (v->o.ground && v->o.blend > 0) {
        /* the offset that carries b_r at j (new segment) onto where it was shown at i */
        double Rj[9], tj[3], E[9], xi[3], xj[3];
        memset(b->rom, 0, sizeof b->rom);
        memset(b->rdt, 0, sizeof b->rdt);
        ref_pose(b, v, j, 0, Rj, tj);
        mdl__mat3_mul_t(Ri, Rj, E);
        mdl__so3_log(E, b->rom);
        const double *cc = v->centre + 3 * (size_t)v->ref;
        for (int a = 0; a < 3; a++) {
            xi[a] = Ri[3 * a] * cc[0] + Ri[3 * a + 1] * cc[1] + Ri[3 * a + 2] * cc[2] + ti[a];
            xj[a] = Rj[3 * a] * cc[0] + Rj[3 * a + 1] * cc[1] + Rj[3 * a + 2] * cc[2] + tj[a];
            b->rdt[a] = xi[a] - xj[a];
        }
    }
}

void mdl__vblend_advance(mdl__vblend *b)
{
    if (b->since < 1 << 30)
        b->since++;
}
