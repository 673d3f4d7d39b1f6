/* laplacian.h - the cotangent Laplacian of a triangle mesh.
 *
 * [Desbrun, Meyer, Alliez 2002, "Intrinsic parameterizations of surface meshes", Sec. 3 (the
 * discrete Dirichlet energy)], the geometric Laplacian de Aguiar et al. 2007 Sec. 4.1 use:
 *   L_ij = -(cot alpha_ij + cot beta_ij) / 2   for an edge ij (alpha, beta: the angles opposite it),
 *   L_ii = -sum_j L_ij,
 * i.e. the stiffness matrix of linear finite elements: symmetric, positive semi-definite, L 1 = 0.
 * No mass matrix (the systems here are solved with L alone, as eq. 2 and 4 are written).
 * Per triangle t = (a, b, c) the half-cotangents of its corners, w^t = (cot A, cot B, cot C) / 2;
 * the edge opposite corner A (b-c) gets w^t_A. Cotangents are clamped to +-MDL_COT_MAX so a
 * degenerate triangle cannot make the matrix infinite.
 * Positions are floats (a mesh), weights doubles (they go into a factorisation). */
#ifndef MESHSTEER_MODEL_LAPLACIAN_H
#define MESHSTEER_MODEL_LAPLACIAN_H

#include <stddef.h>
#include <stdint.h>

#define MDL_COT_MAX 1e4

/* w: nf x 3 half-cotangents, w[3t + k] for the corner k of triangle t (opposite edge
 * F[t][k+1]-F[t][k+2]). */
void mdl__cot_weights(const float *V, const uint32_t *F, int nf, double *w);

/* The Laplacian as lower-triangle triplets (i >= j, duplicates to be summed): at most
 * 3 * nf + nv entries; ti, tj, tx must hold that many. Returns the count written. */
size_t mdl__laplacian_triplets(const double *w, const uint32_t *F, int nf, int nv, int *ti,
                               int *tj, double *tx);

#endif
