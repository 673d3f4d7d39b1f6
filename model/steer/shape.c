/* shape.c - per-part PCA shape model through the Gram matrix (paper 2012 eq. 6; see shape.h). */
#include "steer/shape.h"
#include "core/linalg.h"
#include "model.h"
#include "core/util.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

int mdl__pca(const double *X, int m, int F, double explained, int max_modes, double *mean,
             double **modes, double **sigma2, int *k, double *expl, char *err)
{
    *modes = NULL;
    *sigma2 = NULL;
    *k = 0;
    *expl = 1;
    for (int i = 0; i < m; i++) {
        double s = 0;
        for (int f = 0; f < F; f++)
            s += X[(size_t)f * m + i];
        mean[i] = s / F;
    }
    if (F < 2 || max_modes <= 0)
        return 0;
    double *Xc = mdl__calloc((size_t)m * F, sizeof *Xc);
    double *G = mdl__calloc((size_t)F * F, sizeof *G);
    double *w = mdl__calloc((size_t)F, sizeof *w);
    int rc = 0;
    if (!Xc || !G || !w) {
        rc = mdl__err(err, -ENOMEM, "shape model: out of memory");
        goto out;
    }
    for (int f = 0; f < F; f++)
        for (int i = 0; i < m; i++)
            Xc[(size_t)f * m + i] = X[(size_t)f * m + i] - mean[i];
    mdl_la_gemm('T', 'N', F, F, m, 1.0, Xc, m, Xc, m, 0.0, G, F);
    if ((rc = mdl_la_syev(F, G, F, w, err)))
        goto out;
    double total = 0;
    for (int i = 0; i < F; i++)
        total += w[i] > 0 ? w[i] : 0;
    if (!(total > 1e-24)) /* a part that never changes shape */
        goto out;
    int kk = 0;
    double acc = 0;
    /* eigenvalues ascend: walk from the largest */
    while (kk < max_modes && kk < F - 1 && acc < explained * total) {
        double lam = w[F - 1 - kk];
        if (!(lam > 1e-12 * total))
            break;
        acc += lam;
        kk++;
    }
    double *V = mdl__calloc((size_t)m * (kk ? kk : 1), sizeof *V);
    double *s2 = mdl__calloc((size_t)(kk ? kk : 1), sizeof *s2);
    if (!V || !s2) {
        free(V);
        free(s2);
        rc = mdl__err(err, -ENOMEM, "shape model: out of memory");
        goto out;
    }
    for (int j = 0; j < kk; j++) {
        int col = F - 1 - j;
        double lam = w[col];
        /* v_j = Xc u_j / sqrt(lam) */
        mdl_la_gemv('N', m, F, 1.0 / sqrt(lam), Xc, m, G + (size_t)col * F, 0.0, V + (size_t)j * m);
        s2[j] = lam / (F - 1);
    }
    *modes = V;
    *sigma2 = s2;
    *k = kk;
    *expl = acc / total;
out:
    free(Xc);
    free(G);
    free(w);
    return rc;
}
