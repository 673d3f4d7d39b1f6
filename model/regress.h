/* regress.h - multivariate multiple linear regression (paper 2012 Sec. 4.3, eq. 5).
 *
 *   min_Phi || Phi [M; 1] - P ||_F^2  (+ ridge * ||Phi without its intercept||_F^2)
 *
 * Inputs are standardised (z = (x - mean) / sd) so that one ridge value fits features of any
 * unit; the intercept is not penalised (targets are centred). With ridge < 0 the value is chosen
 * from a grid by leave-one-out error, computed in closed form from the hat matrix
 * (e_loo_i = r_i / (1 - h_ii)), each target column weighted by its inverse variance.
 *
 * paper -> code: M_mocap -> X (n x d, column-major, ld n); P_vskel and S_shape -> Y (n x q);
 * Phi^l and Psi^l -> coef ((d + 1) x q, column-major, ld d + 1; row 0 = intercept). */
#ifndef MESHSTEER_MODEL_REGRESS_H
#define MESHSTEER_MODEL_REGRESS_H

int mdl__ridge_fit(const double *X, int n, int d, const double *Y, int q, double ridge,
                   double *mean, double *sd, double *coef, double *chosen, double *rms_train,
                   double *rms_loo, char *err);

/* y (q) = coef^T [1; (x - mean) / sd]; scratch z has d + 1 entries. No allocation. */
void mdl__ridge_predict(const double *coef, int d, int q, const double *mean, const double *sd,
                        const double *x, double *z, double *y);

#endif
