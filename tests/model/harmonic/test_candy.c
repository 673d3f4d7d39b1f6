/* test_candy.c - the candy-wrapper effect (Sec. 4.3, model/harmonic/candy.c): a forearm-like tube held
 * still at one end and twisted about its axis by 170, 180 and 190 deg at the other, the twisted
 * end's correspondences jittered by +-2 deg (as a real hand's triangles are), must not collapse: the
 * minimum cross-section radius (distance of the vertices of every ring from the ring's centre) stays
 * >= 50 % of the rest radius. The naive sign choice (w >= 0 per constraint) is also run and printed,
 * to show what the test guards against: near 180 deg it collapses. */
#include "harmonic/harmonic_internal.h"
#include "test.h"
#include "htube.h"

static double min_radius(const double *X, int rings, int around)
{
    double mr = INFINITY;
    for (int r = 0; r < rings; r++) {
        double c[3] = {0, 0, 0};
        for (int a = 0; a < around; a++)
            for (int k = 0; k < 3; k++)
                c[k] += X[3 * (r * around + a) + k] / around;
        for (int a = 0; a < around; a++) {
            double d = 0;
            for (int k = 0; k < 3; k++)
                d += (X[3 * (r * around + a) + k] - c[k]) * (X[3 * (r * around + a) + k] - c[k]);
            mr = fmin(mr, sqrt(d));
        }
    }
    return mr;
}

int main(void)
{
    int rings = 41, around = 16;
    mdl_mesh *m = htube_create(rings, around);
    int per_ring = 2 * around; /* triangles between two rings */
    struct mdl_harmonic *h = calloc(1, sizeof *h);
    h->nv = m->nv;
    h->nf = m->nf;
    /* correspondences: every triangle of the first and the last band, each its own group */
    int nc = 2 * per_ring;
    h->ncorr = h->ngroups = nc;
    h->corr_tri = calloc((size_t)nc, sizeof(int));
    h->corr_group = calloc((size_t)nc, sizeof(int));
    double *pos = calloc(3 * (size_t)nc, sizeof *pos);
    for (int i = 0; i < nc; i++) {
        h->corr_tri[i] = i < per_ring ? i : m->nf - per_ring + (i - per_ring);
        h->corr_group[i] = i;
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                pos[3 * i + k] += m->V[3 * m->F[3 * h->corr_tri[i] + j] + k] / 3.0;
    }
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl__candy_tree(h, pos, err), err);
    mdl__hdeform d;
    ASSERT_OK(mdl__hdeform_init(&d, h, m->V, m->F, err), err);
    double *qg = calloc(4 * (size_t)nc, sizeof *qg), *S = calloc(4 * (size_t)m->nv, sizeof *S);
    const double rest_r = 0.1;
    for (int deg = 170; deg <= 190; deg += 10) {
        for (int i = 0; i < nc; i++) {
            double th = i < per_ring ? 0 : (deg + (i % 2 ? 2.0 : -2.0)) * M_PI / 180;
            qg[4 * i] = cos(th / 2);
            qg[4 * i + 1] = sin(th / 2);
            qg[4 * i + 2] = qg[4 * i + 3] = 0;
        }
        mdl__hdeform_reset(&d);
        ASSERT_OK(mdl__hdeform_run(&d, qg), "deform");
        double r = min_radius(d.X, rings, around);
        /* naive: w >= 0 per constraint, no tree */
        for (int c = 0; c < d.field.ncv; c++) {
            double *q = d.Sc + 4 * c;
            memcpy(q, qg + 4 * d.cv_group[c], 4 * sizeof *q);
            if (q[0] < 0)
                q[0] = -q[0], q[1] = -q[1], q[2] = -q[2], q[3] = -q[3];
        }
        mdl__hfield_solve(&d.field, d.Sc, S);
        double mn = INFINITY;
        for (int t = 0; t < m->nf; t++) {
            double s[4] = {0, 0, 0, 0};
            for (int j = 0; j < 3; j++)
                for (int k = 0; k < 4; k++)
                    s[k] += S[4 * m->F[3 * t + j] + k];
            mn = fmin(mn, sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]) / 3);
        }
        printf("twist %d deg: min cross-section radius %.4f m (%.0f %% of rest); naive signs: "
               "smallest mixed quaternion norm %.3f\n", deg, r, 100 * r / rest_r, mn);
        if (!(r >= 0.5 * rest_r)) {
            fprintf(stderr, "twist %d deg: radius %.4f < 50 %% of %.4f: collapsed\n", deg, r, rest_r);
            return 1;
        }
    }
    mdl__hdeform_fini(&d);
    mdl__harmonic_free(h);
    free(pos), free(qg), free(S);
    mdl_mesh_destroy(m);
    puts("candy: ok");
    return 0;
}
