/* defgrad.c - the deformation gradients at the key vertices, in the reference bone's frame
 * (Zheng 2013 Sec. 3.3, "Deformation Gradients at Key Vertices" and "Representation of
 * Deformation Gradient"):
 *
 *   eq. (8)   D_i(t) = dv_i(t)/dv_bar_i
 *                    = sum_b (R_b->r(t) v_bar_i + t_b->r(t)) (dw_ib/dv_bar_i)^T + w_ib R_b->r(t)
 *             over key vertex i's bones (weight_grad.c), with the local frames of eq. 2
 *             (transitions.c; b_r's own is the identity)
 *   polar     D_i(t) = U_i(t) S_i(t) (merge.c's mdl__polar), and the rotation-strain
 *             coordinates d_i(t) = [Phi(U_i(t)); S_00 S_01 S_02 S_11 S_12 S_22]
 *
 * precomputed for every input frame at analysis (g->kD, g->kd). Because sum_b w_ib = 1 and
 * sum_b dw_ib/dv_bar_i = 0, bones that all move by one affine {F, t} give D_i = F (Appendix A).
 * Analysis: allocates freely; mdl__defgrad itself allocates nothing. */
#include "variations/variations.h"
#include "core/util.h"

#include <errno.h>
#include <string.h>

void mdl__defgrad(const struct mdl_variations *g, int i, const double *LR, const double *Lt,
                  double D[9])
{
    const double *x = g->key_x + 3 * (size_t)i;
    memset(D, 0, 9 * sizeof *D);
    for (int k = g->kb_off[i]; k < g->kb_off[i + 1]; k++) {
        int b = g->kb_bone[k];
        const double *R = LR + 9 * (size_t)b, *t = Lt + 3 * (size_t)b, *gr = g->kb_g + 3 * (size_t)k;
        double w = g->kb_w[k];
        for (int r = 0; r < 3; r++) {
            double p = R[3 * r] * x[0] + R[3 * r + 1] * x[1] + R[3 * r + 2] * x[2] + t[r];
            for (int c = 0; c < 3; c++)
                D[3 * r + c] += p * gr[c] + w * R[3 * r + c];
        }
    }
}

int mdl__defgrads(struct mdl_variations *g, char *err)
{
    size_t n = (size_t)g->nframes * g->nkey * 9;
    g->kD = mdl__calloc(n, sizeof *g->kD);
    g->kd = mdl__calloc(n, sizeof *g->kd);
    if (!g->kD || !g->kd)
        return mdl__err(err, -ENOMEM, "variations: out of memory for deformation gradients");
    for (int t = 0; t < g->nframes; t++)
        for (int i = 0; i < g->nkey; i++) {
            size_t at = 9 * ((size_t)t * g->nkey + i);
            double *D = g->kD + at, *d = g->kd + at, U[9], S[9];
            mdl__defgrad(g, i, g->LR + 9 * (size_t)t * g->nb, g->Lt + 3 * (size_t)t * g->nb, D);
            mdl__polar(D, U, S);
            mdl__so3_log(U, d);
            d[3] = S[0];
            d[4] = S[1];
            d[5] = S[2];
            d[6] = S[4];
            d[7] = S[5];
            d[8] = S[8];
        }
    return 0;
}
