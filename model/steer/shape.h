/* shape.h - linear shape model of one part (paper 2012 Sec. 4.4, eq. 6).
 *
 *   x_hat = x_bar + V lambda,   s = V_{1..k}^T (x - x_bar)
 * from the eigendecomposition of the scatter matrix (1/(F-1)) (X - X_bar)(X - X_bar)^T = V S^2 V^T.
 * With F frames much smaller than 3n, the eigenvectors come from the F x F Gram matrix
 * (X - X_bar)^T (X - X_bar) = U M U^T as V = (X - X_bar) U M^{-1/2}, sigma^2 = M / (F - 1).
 * Modes are kept until they explain `explained` of the variance (at most max_modes).
 *
 * X: m x F column-major (m = 3n, columns are aligned frames). Outputs: mean (m), modes (m x k,
 * column-major, allocated), sigma2 (k, allocated), *k, *expl (fraction explained). */
#ifndef MESHSTEER_MODEL_SHAPE_H
#define MESHSTEER_MODEL_SHAPE_H

int mdl__pca(const double *X, int m, int F, double explained, int max_modes, double *mean,
             double **modes, double **sigma2, int *k, double *expl, char *err);

#endif
