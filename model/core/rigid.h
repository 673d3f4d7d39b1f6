/* rigid.h - rigid alignment kernels: the rotation that best maps one point set onto another.
 *
 * [Horn 1987, "Closed-form solution of absolute orientation using unit quaternions", Sec. 4]:
 * the optimal rotation is the unit quaternion of the largest eigenvalue of the symmetric 4x4
 * matrix N built from S = sum_i y_i x_i^T (source y, target x). Written by hand (a 4x4 cyclic
 * Jacobi) because a LAPACK call costs more than the arithmetic at this size, and because the
 * per-frame synthesis must not allocate.
 *
 * A rotation prior (used by the greedy alignment of paper 2012 Sec. 5.1): maximising
 * sum x_i^T R y_i + mu * tr(Rp^T R) is the same problem with S replaced by S + mu * Rp^T.
 *
 * Matrices are 3x3 row-major doubles here (R[3*r + c]); quaternions are (w, x, y, z). */
#ifndef MESHSTEER_MODEL_RIGID_H
#define MESHSTEER_MODEL_RIGID_H

/* Rotation R maximising tr(R S) where S = sum y x^T (row-major: S[3a+b] = sum y_a x_b). */
void mdl__rot_from_cov(const double S[9], double q[4], double R[9]);

/* The same maximiser by the orthogonal polar factor of S^T (scaled Newton iteration [Higham 1986,
 * "Computing the polar decomposition - with applications", Sec. 3]), which needs no 4x4
 * eigenproblem and converges in a handful of steps; falls back to Horn for a reflection or a
 * singular S. Returns the iterations used, or -1 for the fallback. */
int mdl__rot_polar(const double S[9], double R[9]);

void mdl__quat_to_mat(const double q[4], double R[9]);
void mdl__mat_to_quat(const double R[9], double q[4]);

/* Best rigid transform x ~ R y + t over n points (xyz interleaved, doubles), optional weights w.
 * Returns the RMS residual. */
double mdl__kabsch(const double *y, const double *x, const double *w, int n, double R[9],
                   double t[3]);

#endif
