/* deform.c - one frame of de Aguiar et al. 2007 Sec. 4.1 (steps 1-6): group rotations ->
 * sign-aligned constraint quaternions (candy.c, Sec. 4.3) -> harmonic field per vertex (eq. 1-2,
 * harmonic_field.c) -> one rotation per triangle, the normalised mean of its three vertices'
 * quaternions ("we average the quaternion rotations of the vertices") -> Poisson glue (eq. 3-4,
 * poisson.c). init allocates and factorises; run allocates nothing.
 * Beyond the paper, for a template that stretches (eval --stretch; docs/MODEL.md): each group also
 * carries a symmetric stretch U (right polar factor, F = R U, in rest coordinates); its six
 * components are interpolated by the same harmonic solve (six more columns), a triangle's U is the
 * mean of its vertices', and the glue receives R_t U_t instead of R_t. */
#include "harmonic/harmonic_internal.h"
#include "core/laplacian.h"
#include "core/rigid.h"
#include "core/util.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

void mdl__hdeform_fini(mdl__hdeform *d)
{
    mdl__hfield_fini(&d->field);
    mdl__poisson_fini(&d->pois);
    free(d->cv_group);
    free(d->qg);
    free(d->qprev);
    free(d->Sc);
    free(d->S);
    free(d->Rt);
    free(d->X);
    memset(d, 0, sizeof *d);
}

int mdl__hdeform_init_mode(mdl__hdeform *d, const struct mdl_harmonic *h, const float *rest,
                           const uint32_t *F, int stretch, char *err)
{
    memset(d, 0, sizeof *d);
    d->h = h;
    d->F = F;
    d->ncomp = stretch ? MDL_HFIELD_NCOMP_STRETCH : 4;
    int nv = h->nv, nf = h->nf, rc = 0;
    double *w = mdl__calloc(3 * (size_t)nf, sizeof *w);
    int *cv = mdl__calloc(3 * (size_t)h->ncorr + 1, sizeof *cv);
    int *grp = mdl__calloc(3 * (size_t)h->ncorr + 1, sizeof *grp);
    int *vseen = mdl__calloc((size_t)nv, sizeof *vseen);
    d->qg = mdl__calloc(4 * (size_t)h->ngroups + 4, sizeof *d->qg);
    d->qprev = mdl__calloc(4 * (size_t)h->ngroups + 4, sizeof *d->qprev);
    d->S = mdl__calloc((size_t)d->ncomp * (size_t)nv, sizeof *d->S);
    d->Rt = mdl__calloc(9 * (size_t)nf, sizeof *d->Rt);
    d->X = mdl__calloc(3 * (size_t)nv, sizeof *d->X);
    if (!w || !cv || !grp || !vseen || !d->qg || !d->qprev || !d->S || !d->Rt || !d->X) {
        rc = mdl__err(err, -ENOMEM, "harmonic: out of memory");
        goto out;
    }
    /* the constrained vertices: those of the correspondence triangles, each in the group of the
     * first correspondence that holds it */
    int ncv = 0;
    for (int i = 0; i < h->ncorr; i++)
        for (int k = 0; k < 3; k++) {
            int v = (int)F[3 * h->corr_tri[i] + k];
            if (!vseen[v]) {
                vseen[v] = 1;
                cv[ncv] = v;
                grp[ncv++] = h->corr_group[i];
            }
        }
    d->cv_group = grp;
    grp = NULL;
    d->Sc = mdl__calloc((size_t)d->ncomp * ((size_t)ncv + 1), sizeof *d->Sc);
    if (!d->Sc) {
        rc = mdl__err(err, -ENOMEM, "harmonic: out of memory");
        goto out;
    }
    mdl__cot_weights(rest, F, nf, w);
    if ((rc = mdl__hfield_precompute(&d->field, F, nf, nv, w, cv, ncv, d->ncomp, err)) ||
        (rc = mdl__poisson_precompute(&d->pois, rest, F, nf, nv, w, err)))
        goto out;
out:
    free(w);
    free(cv);
    free(grp);
    free(vseen);
    if (rc)
        mdl__hdeform_fini(d);
    return rc;
}

int mdl__hdeform_init(mdl__hdeform *d, const struct mdl_harmonic *h, const float *rest,
                      const uint32_t *F, char *err)
{
    return mdl__hdeform_init_mode(d, h, rest, F, 0, err);
}

void mdl__hdeform_reset(mdl__hdeform *d)
{
    d->have_prev = 0;
}

/* steps 1-3 (and the stretch when ug_in is given): d->Rt */
static int tri_gradients(mdl__hdeform *d, const double *qg_in, const double *ug_in)
{
    const struct mdl_harmonic *h = d->h;
    memcpy(d->qg, qg_in, 4 * (size_t)h->ngroups * sizeof *d->qg);
    for (int g = 0; g < h->ngroups; g++)
        mdl__qnorm(d->qg + 4 * g);
    /* Sec. 4.3: one hemisphere along the tree of groups */
    d->near_180 = mdl__candy_align(h->group_parent, h->group_order, h->ngroups, d->qg,
                                   d->have_prev ? d->qprev : NULL);
    memcpy(d->qprev, d->qg, 4 * (size_t)h->ngroups * sizeof *d->qg);
    d->have_prev = 1;
    int nc = ug_in ? d->ncomp : 4;
    for (int c = 0; c < d->field.ncv; c++) {
        int g = d->cv_group[c];
        memcpy(d->Sc + (size_t)nc * c, d->qg + 4 * g, 4 * sizeof *d->Sc);
        if (ug_in)
            memcpy(d->Sc + (size_t)nc * c + 4, ug_in + 6 * g, 6 * sizeof *d->Sc);
    }
    /* eq. 2, the four components at once (ten with the stretch) */
    int rc = mdl__hfield_solve_n(&d->field, d->Sc, d->S, nc);
    if (rc)
        return rc;
    for (int t = 0; t < h->nf; t++) {
        const double *a = d->S + (size_t)nc * d->F[3 * t], *b = d->S + (size_t)nc * d->F[3 * t + 1],
                     *c = d->S + (size_t)nc * d->F[3 * t + 2];
        double q[4] = {a[0] + b[0] + c[0], a[1] + b[1] + c[1], a[2] + b[2] + c[2], a[3] + b[3] + c[3]};
        mdl__qnorm(q);
        double *M = d->Rt + 9 * (size_t)t;
        mdl__quat_to_mat(q, M);
        if (ug_in) {
            double u[6], R[9], U[9];
            for (int j = 0; j < 6; j++)
                u[j] = (a[4 + j] + b[4 + j] + c[4 + j]) / 3;
            mdl__sym_from6(u, U);
            memcpy(R, M, sizeof R);
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    M[3 * i + j] = R[3 * i] * U[j] + R[3 * i + 1] * U[3 + j] + R[3 * i + 2] * U[6 + j];
        }
    }
    return 0;
}

int mdl__hdeform_tri_rotations(mdl__hdeform *d, const double *qg_in)
{
    return tri_gradients(d, qg_in, NULL);
}

int mdl__hdeform_run(mdl__hdeform *d, const double *qg_in)
{
    int rc = tri_gradients(d, qg_in, NULL);
    if (rc)
        return rc;
    return mdl__poisson_solve(&d->pois, d->Rt, d->X);
}

int mdl__hdeform_run_stretch(mdl__hdeform *d, const double *qg_in, const double *ug_in)
{
    if (d->ncomp != MDL_HFIELD_NCOMP_STRETCH)
        return -EINVAL;
    int rc = tri_gradients(d, qg_in, ug_in);
    if (rc)
        return rc;
    return mdl__poisson_solve(&d->pois, d->Rt, d->X);
}
