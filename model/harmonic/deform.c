/* deform.c - one frame of de Aguiar et al. 2007 Sec. 4.1 (steps 1-6): group rotations ->
 * sign-aligned constraint quaternions (candy.c, Sec. 4.3) -> harmonic field per vertex (eq. 1-2,
 * harmonic_field.c) -> one rotation per triangle, the normalised mean of its three vertices'
 * quaternions ("we average the quaternion rotations of the vertices") -> Poisson glue (eq. 3-4,
 * poisson.c). init allocates and factorises; run allocates nothing. */
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

int mdl__hdeform_init(mdl__hdeform *d, const struct mdl_harmonic *h, const float *rest,
                      const uint32_t *F, char *err)
{
    memset(d, 0, sizeof *d);
    d->h = h;
    d->F = F;
    int nv = h->nv, nf = h->nf, rc = 0;
    double *w = mdl__calloc(3 * (size_t)nf, sizeof *w);
    int *cv = mdl__calloc(3 * (size_t)h->ncorr + 1, sizeof *cv);
    int *grp = mdl__calloc(3 * (size_t)h->ncorr + 1, sizeof *grp);
    int *vseen = mdl__calloc((size_t)nv, sizeof *vseen);
    d->qg = mdl__calloc(4 * (size_t)h->ngroups + 4, sizeof *d->qg);
    d->qprev = mdl__calloc(4 * (size_t)h->ngroups + 4, sizeof *d->qprev);
    d->S = mdl__calloc(4 * (size_t)nv, sizeof *d->S);
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
    d->Sc = mdl__calloc(4 * (size_t)ncv + 4, sizeof *d->Sc);
    if (!d->Sc) {
        rc = mdl__err(err, -ENOMEM, "harmonic: out of memory");
        goto out;
    }
    mdl__cot_weights(rest, F, nf, w);
    if ((rc = mdl__hfield_precompute(&d->field, F, nf, nv, w, cv, ncv, err)) ||
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

void mdl__hdeform_reset(mdl__hdeform *d)
{
    d->have_prev = 0;
}

int mdl__hdeform_tri_rotations(mdl__hdeform *d, const double *qg_in)
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
    for (int c = 0; c < d->field.ncv; c++)
        memcpy(d->Sc + 4 * c, d->qg + 4 * d->cv_group[c], 4 * sizeof *d->Sc);
    /* eq. 2, the four components at once */
    int rc = mdl__hfield_solve(&d->field, d->Sc, d->S);
    if (rc)
        return rc;
    for (int t = 0; t < h->nf; t++) {
        const double *a = d->S + 4 * (size_t)d->F[3 * t], *b = d->S + 4 * (size_t)d->F[3 * t + 1],
                     *c = d->S + 4 * (size_t)d->F[3 * t + 2];
        double q[4] = {a[0] + b[0] + c[0], a[1] + b[1] + c[1], a[2] + b[2] + c[2], a[3] + b[3] + c[3]};
        mdl__qnorm(q);
        mdl__quat_to_mat(q, d->Rt + 9 * (size_t)t);
    }
    return 0;
}

int mdl__hdeform_run(mdl__hdeform *d, const double *qg_in)
{
    int rc = mdl__hdeform_tri_rotations(d, qg_in);
    if (rc)
        return rc;
    return mdl__poisson_solve(&d->pois, d->Rt, d->X);
}
