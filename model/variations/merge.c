/* merge.c - assembling the components' bone animations (Zheng 2013 Sec. 4.2, Algorithm 1).
 *
 *   polar         F = U S, U a rotation, S symmetric (U by the scaled Newton iteration of
 *                 core/rigid.c mdl__rot_polar, S = U^T F)
 *   eq. (12)      D_C(i, j) = sum_t |S_c,i(t) - S_c,j(t)|_F^2 over the cut node b_c's series in
 *                 the anchor's animation (i) and the component's (j)
 *   threshold     the two are merged when D_C < T_c = 0.05 max_t {|S_c,i(t)|_F^2, |S_c,j(t)|_F^2}
 *                 (Algorithm 1's "if D_C >= T_c then return" read as: this pair is not merged)
 *   eq. (13)      F_c(t) = 1/2 U_c,i(t) (S_c,i(t) + S_c,j(t)),  t_c(t) = t_c,i(t)
 *   eq. (14)      F_b(t) = U_c,i U_c,j^T F_b,j,  t_b(t) = U_c,i U_c,j^T (t_b,j - t_c,j) + t_c,i
 *                 for the component's other bones b: one rigid motion per frame, so the
 *                 component keeps its own spatial correlation and follows b_c as the anchor moves it
 *   anchor        the other bones of the anchor (C_i) are unchanged.
 * With rigid bones (the linear blend keeps rotations rotations) every S is the identity, D_C = 0
 * and every pair merges; the test matters for affine bones. Per frame: no allocation. */
#include "variations/variations.h"
#include "core/rigid.h"

#include <math.h>
#include <string.h>

void mdl__polar(const double F[9], double U[9], double S[9])
{
    /* mdl__rot_polar(A) gives the polar factor of A^T */
    const double Ft[9] = {F[0], F[3], F[6], F[1], F[4], F[7], F[2], F[5], F[8]};
    mdl__rot_polar(Ft, U);
    double P[9];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            P[3 * r + c] = U[r] * F[c] + U[3 + r] * F[3 + c] + U[6 + r] * F[6 + c];
    /* symmetrise against rounding */
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            S[3 * r + c] = 0.5 * (P[3 * r + c] + P[3 * c + r]);
}

double mdl__merge_cost(const double *Fa, size_t sa, const double *Fb, size_t sb, int frames,
                       double *threshold)
{
    double sum = 0, mx = 0;
    for (int t = 0; t < frames; t++) {
        double U[9], Sa[9], Sb[9], na = 0, nb = 0;
        mdl__polar(Fa + sa * t, U, Sa);
        mdl__polar(Fb + sb * t, U, Sb);
        for (int k = 0; k < 9; k++) {
            sum += (Sa[k] - Sb[k]) * (Sa[k] - Sb[k]);
            na += Sa[k] * Sa[k];
            nb += Sb[k] * Sb[k];
        }
        mx = fmax(mx, fmax(na, nb));
    }
    if (threshold)
        *threshold = 0.05 * mx;
    return sum;
}

void mdl__merge_frame(const mdl__vcomp *c, const double *Tc, double *T)
{
    double *Fi = T + 12 * (size_t)c->cut;
    const double *Fj = Tc + 12 * (size_t)c->cut_local;
    double Ui[9], Si[9], Uj[9], Sj[9], G[9], ti[3], tj[3];
    mdl__polar(Fi, Ui, Si);
    mdl__polar(Fj, Uj, Sj);
    mdl__mat3_mul_t(Ui, Uj, G); /* U_c,i U_c,j^T */
    memcpy(ti, Fi + 9, sizeof ti);
    memcpy(tj, Fj + 9, sizeof tj);
    /* eq. (13) */
    double Sm[9];
    for (int k = 0; k < 9; k++)
        Sm[k] = 0.5 * (Si[k] + Sj[k]);
    mdl__mat3_mul(Ui, Sm, Fi);
    /* eq. (14) */
    for (int k = 0; k < c->nb; k++) {
        if (k == c->cut_local)
            continue;
        const double *Fb = Tc + 12 * (size_t)k;
        double *M = T + 12 * (size_t)c->bones[k];
        mdl__mat3_mul(G, Fb, M);
        double d[3] = {Fb[9] - tj[0], Fb[10] - tj[1], Fb[11] - tj[2]};
        for (int a = 0; a < 3; a++)
            M[9 + a] = G[3 * a] * d[0] + G[3 * a + 1] * d[1] + G[3 * a + 2] * d[2] + ti[a];
    }
}
