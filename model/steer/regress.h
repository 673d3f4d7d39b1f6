/* regress.h - multivariate multiple linear regression (paper 2012 Sec. 4.3, eq. 5).
 *
 *   min_Phi || Phi [M; 1] - P ||_F^2  (+ ridge * ||Phi without its intercept||_F^2)
 *
 * Inputs are standardised (z = (x - mean) / sd) so that one ridge value fits features of any
 * unit; the intercept is not penalised (targets are centred). With ridge < 0 the value is chosen
 * for every output column separately from a grid by leave-one-out error, computed in closed form
 * from the hat matrix, e_loo_i = r_i / (1 - h_ii) with the intercept's 1/n in h_ii; with fewer
 * samples than inputs the dual form (regress.c), where the primal one degenerates as h_ii -> 1.
 * Reported residuals weight the columns by colw (what an error in
 * that column costs in vertex space; NULL: the inverse variance) relative to the columns' variance.
 *
 * paper -> code: M_mocap -> X (n x d, column-major, ld n); P_vskel and S_shape -> Y (n x q);
 * Phi^l and Psi^l -> coef ((d + 1) x q, column-major, ld d + 1; row 0 = intercept). */
#ifndef MESHSTEER_MODEL_REGRESS_H
#define MESHSTEER_MODEL_REGRESS_H

#define MDL_MAX_GROUP 16 /* largest leave-one-out group (noisy copies of one frame + 1) */

/* gs > 0: samples i, i + gs, i + 2 gs, ... form one group that leave-one-out leaves out together
 * (n must be a multiple of gs, at most MDL_MAX_GROUP per group); 0: every sample alone. */
int mdl__ridge_fit(const double *X, int n, int d, const double *Y, int q, double ridge,
                   const double *colw, int gs, double *mean, double *sd, double *coef, double *chosen, double *rms_train,
                   double *rms_loo, char *err);

/* Radial basis extension (the paper's Sec. 6 names non-linear regression, kernel CCA, as the
 * remedy for the linear model's artefacts): the design row of an input x is
 *     [x, exp(-|z - c_1|^2 / (2 w^2)), ..., exp(-|z - c_m|^2 / (2 w^2))],  z = (x - zmean) / zsd,
 * with centres c_j taken from the training inputs (at most MDL_RBF_MAX_CENTRES, evenly spread over
 * the samples), and the ridge regression above fitted on these rows. The width w and the ridge are
 * both chosen by leave-one-out error. With m = 0 it is eq. (5) exactly. */
#define MDL_RBF_MAX_CENTRES 96
void mdl__design_row(const double *x, int d, const double *zmean, const double *zsd,
                     const double *cent, int m, double width, double *row);

/* Fits everything above: X n x d (column-major), Y n x q. Allocates *zmean, *zsd, *cent, *mean,
 * *sd (sizes d, d, m*d, d+m, d+m) and *coef ((d+m+1) x q). use_rbf = 0 gives the linear model. */
int mdl__regression_fit(const double *X, int n, int d, const double *Y, int q, double ridge,
                        const double *colw, int gs, int use_rbf, double **zmean, double **zsd, double **cent, int *m,
                        double *width, double **mean, double **sd, double **coef, double *chosen,
                        double *rms_train, double *rms_loo, char *err);

/* y (q) = coef^T [1; (x - mean) / sd]; scratch z has d + 1 entries. No allocation. */
void mdl__ridge_predict(const double *coef, int d, int q, const double *mean, const double *sd,
                        const double *x, double *z, double *y);

#endif
