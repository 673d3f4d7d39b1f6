/* test_example.c - the built-in example creature: sizes, determinism, a clean closed connected mesh,
 * motion everywhere, bulging limbs, and a marker recording that matches its ground truth.
 */
#include "model.h"
#include "test.h"

#include <errno.h>
#include <stdint.h>

static int uf(int *p, int x)
{
    while (p[x] != x)
        x = p[x] = p[p[x]];
    return x;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static double tri_area(const float *V, const uint32_t *t)
{
    const float *a = V + 3 * t[0], *b = V + 3 * t[1], *c = V + 3 * t[2];
    double u[3], v[3];
    for (int i = 0; i < 3; i++) {
        u[i] = b[i] - a[i];
        v[i] = c[i] - a[i];
    }
    double n0 = u[1] * v[2] - u[2] * v[1], n1 = u[2] * v[0] - u[0] * v[2], n2 = u[0] * v[1] - u[1] * v[0];
    return 0.5 * sqrt(n0 * n0 + n1 * n1 + n2 * n2);
}

static void test_topology(const mdl_meshseq *s)
{
    int nv = s->nv, nf = s->nf;
    const uint32_t *F = s->F;
    /* indices valid and distinct; no degenerate triangle in any frame */
    double amin = 1e9;
    for (int f = 0; f < nf; f++) {
        for (int x = 0; x < 3; x++)
            ASSERT(F[3 * f + x] < (uint32_t)nv);
        ASSERT(F[3 * f] != F[3 * f + 1] && F[3 * f + 1] != F[3 * f + 2] && F[3 * f] != F[3 * f + 2]);
    }
    for (int fr = 0; fr < s->frames; fr++)
        for (int f = 0; f < nf; f++) {
            double a = tri_area(s->V + (size_t)fr * nv * 3, F + 3 * f);
            if (a < amin)
                amin = a;
        }
    printf("smallest triangle area over all frames: %.3g m^2\n", amin);
    ASSERT(amin > 1e-8);

    /* closed and consistently oriented: every directed edge once, and its reverse once */
    uint64_t *e = malloc((size_t)nf * 3 * sizeof *e);
    ASSERT(e);
    for (int f = 0; f < nf; f++)
        for (int x = 0; x < 3; x++)
            e[3 * f + x] = (uint64_t)F[3 * f + x] << 32 | F[3 * f + (x + 1) % 3];
    qsort(e, (size_t)nf * 3, sizeof *e, cmp_u64);
    for (int i = 0; i < nf * 3; i++) {
        if (i > 0)
            ASSERT(e[i] != e[i - 1]);
        uint64_t rev = (e[i] & 0xffffffffu) << 32 | e[i] >> 32;
        ASSERT(bsearch(&rev, e, (size_t)nf * 3, sizeof *e, cmp_u64) != NULL);
    }
    free(e);

    /* one connected component that uses every vertex; genus 0 (Euler: V - E + F = 2) */
    int *p = malloc((size_t)nv * sizeof *p), *used = calloc((size_t)nv, sizeof *used);
    ASSERT(p && used);
    for (int v = 0; v < nv; v++)
        p[v] = v;
    for (int f = 0; f < nf; f++)
        for (int x = 0; x < 3; x++) {
            used[F[3 * f + x]] = 1;
            int a = uf(p, (int)F[3 * f]), b = uf(p, (int)F[3 * f + x]);
            p[a] = b;
        }
    int comps = 0;
    for (int v = 0; v < nv; v++) {
        ASSERT(used[v]);
        comps += uf(p, v) == v;
    }
    ASSERT_INT_EQ(comps, 1);
    ASSERT_INT_EQ(nv - nf * 3 / 2 + nf, 2);
    free(p);
    free(used);

    /* outward orientation: positive enclosed volume, plausible for a 1.7 m creature */
    double vol = 0;
    for (int f = 0; f < nf; f++) {
        const float *a = s->V + 3 * F[3 * f], *b = s->V + 3 * F[3 * f + 1], *c = s->V + 3 * F[3 * f + 2];
        vol += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
    }
    printf("enclosed volume: %.4f m^3\n", vol);
    ASSERT(vol > 0.05 && vol < 0.5);
}

static void test_shape_and_motion(const mdl_meshseq *s, const mdl_rig *r)
{
    int nv = s->nv;
    float lo[3] = {1e9f, 1e9f, 1e9f}, hi[3] = {-1e9f, -1e9f, -1e9f};
    for (int v = 0; v < nv; v++)
        for (int i = 0; i < 3; i++) {
            lo[i] = fminf(lo[i], s->V[3 * v + i]);
            hi[i] = fmaxf(hi[i], s->V[3 * v + i]);
        }
    printf("rest box: %.3f x %.3f x %.3f m\n", hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    ASSERT(hi[0] - lo[0] > 1.0 && hi[0] - lo[0] < 2.0); /* long axis X */
    ASSERT(hi[1] - lo[1] > 0.8 && hi[1] - lo[1] < 2.0); /* Y up */
    ASSERT(hi[2] - lo[2] < hi[0] - lo[0]);
    ASSERT(lo[1] > -0.05 && lo[1] < 0.15);           /* feet near the ground */

    /* every vertex moves by more than 5 mm at some frame */
    double least = 1e9;
    for (int v = 0; v < nv; v++) {
        double most = 0;
        for (int f = 1; f < s->frames; f++) {
            const float *a = s->V + 3 * v, *b = s->V + ((size_t)f * nv + v) * 3;
            double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                            (a[2] - b[2]) * (a[2] - b[2]));
            if (d > most)
                most = d;
        }
        if (most < least)
            least = most;
    }
    printf("smallest largest displacement of a vertex: %.4f m\n", least);
    ASSERT(least > 0.005);

    /* Limbs bulge. A ring in the middle of the left front upper leg (frame 0 y 0.58..0.66) and a
     * ring in the middle of the lower leg (0.22..0.30): the ring's mean distance to its centroid is
     * invariant under rigid motion, so its variation measures shape change. */
    int foot = r->markers[0].vertex;
    ASSERT(!strcmp(r->markers[0].name, "lf_foot"));
    float fx = s->V[3 * foot], fz = s->V[3 * foot + 2];
    double var[2];
    int *ring_v = malloc((size_t)nv * sizeof *ring_v);
    ASSERT(ring_v);
    for (int ring = 0; ring < 2; ring++) {
        double y0 = ring == 0 ? 0.58 : 0.22, y1 = y0 + 0.08, rmin = 1e9, rmax = 0;
        int n = 0;
        for (int v = 0; v < nv; v++) {
            const float *q = s->V + 3 * v;
            if (q[1] >= y0 && q[1] <= y1 && fabsf(q[0] - fx) < 0.12f && fabsf(q[2] - fz) < 0.1f)
                ring_v[n++] = v;
        }
        ASSERT(n > 10);
        for (int f = 0; f < s->frames; f++) {
            const float *V = s->V + (size_t)f * nv * 3;
            double c[3] = {0, 0, 0}, rad = 0;
            for (int k = 0; k < n; k++)
                for (int i = 0; i < 3; i++)
                    c[i] += V[3 * ring_v[k] + i] / n;
            for (int k = 0; k < n; k++) {
                const float *q = V + 3 * ring_v[k];
                rad += sqrt((q[0] - c[0]) * (q[0] - c[0]) + (q[1] - c[1]) * (q[1] - c[1]) +
                            (q[2] - c[2]) * (q[2] - c[2])) / n;
            }
            rmin = fmin(rmin, rad);
            rmax = fmax(rmax, rad);
        }
        var[ring] = (rmax - rmin) / rmin;
        printf("%s ring (%d vertices): radius %.4f..%.4f m, variation %.1f%%\n",
               ring == 0 ? "upper leg" : "lower leg", n, rmin, rmax, 100 * var[ring]);
    }
    free(ring_v);
    ASSERT(var[0] > 0.05); /* the muscle swells by more than 5 % */
    ASSERT(var[1] < 0.01); /* the middle of the lower leg is rigid */
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s = NULL, *s2 = NULL;
    mdl_rig *r = NULL, *r2 = NULL;
    ASSERT_OK(mdl_example_create(120, &s, &r, err), err);
    printf("example: %d vertices, %d triangles, %d frames at %g fps\n", s->nv, s->nf, s->frames, s->fps);
    ASSERT(s->nv >= 3000 && s->nv <= 6000);
    ASSERT_INT_EQ(s->frames, 120);
    ASSERT_NEAR(s->fps, 30, 0);

    /* deterministic: a second call gives identical bytes */
    ASSERT_OK(mdl_example_create(120, &s2, &r2, err), err);
    ASSERT_INT_EQ(s2->nv, s->nv);
    ASSERT_INT_EQ(s2->nf, s->nf);
    ASSERT(!memcmp(s->V, s2->V, (size_t)s->frames * s->nv * 3 * sizeof(float)));
    ASSERT(!memcmp(s->F, s2->F, (size_t)s->nf * 3 * sizeof(uint32_t)));
    ASSERT_INT_EQ(r2->nmarkers, r->nmarkers);
    ASSERT(!memcmp(r->markers, r2->markers, (size_t)r->nmarkers * sizeof *r->markers));
    mdl_meshseq_destroy(s2);
    mdl_rig_destroy(r2);

    /* the rig */
    static const char *names[] = {"lf_foot", "rf_foot", "lh_foot", "rh_foot", "head", "tail", "withers", "croup"};
    ASSERT_INT_EQ(r->nmarkers, 8);
    for (int m = 0; m < 8; m++) {
        ASSERT(!strcmp(r->markers[m].name, names[m]));
        ASSERT(!strcmp(r->markers[m].source, names[m]));
        ASSERT(r->markers[m].vertex >= 0 && r->markers[m].vertex < s->nv);
        for (int k = 0; k < m; k++)
            ASSERT(r->markers[m].vertex != r->markers[k].vertex);
    }
    ASSERT_INT_EQ(r->nref, 2);
    ASSERT(!strcmp(r->markers[r->ref[0]].name, "withers") && !strcmp(r->markers[r->ref[1]].name, "croup"));
    ASSERT_INT_EQ(r->nlimbs, 6);
    static const char *limbs[6][2] = {{"withers", "lf_foot"}, {"withers", "rf_foot"}, {"croup", "lh_foot"},
                                      {"croup", "rh_foot"},   {"withers", "head"},    {"croup", "tail"}};
    for (int l = 0; l < 6; l++) {
        ASSERT_INT_EQ(r->limb_off[l + 1] - r->limb_off[l], 2);
        ASSERT(!strcmp(r->markers[r->limb_idx[r->limb_off[l]]].name, limbs[l][0]));
        ASSERT(!strcmp(r->markers[r->limb_idx[r->limb_off[l] + 1]].name, limbs[l][1]));
    }
    for (int m = 0; m < 4; m++) { /* feet touch the ground during the stance */
        float low = 1e9f;
        for (int f = 0; f < s->frames; f++)
            low = fminf(low, s->V[((size_t)f * s->nv + r->markers[m].vertex) * 3 + 1]);
        printf("%s lowest at y = %.3f m\n", r->markers[m].name, low);
        ASSERT(low < 0.08f);
    }
    ASSERT(s->V[3 * r->markers[4].vertex] > 0.7f);  /* head in front */
    ASSERT(s->V[3 * r->markers[5].vertex] < -0.8f); /* tail tip behind */

    test_topology(s);
    test_shape_and_motion(s, r);

    /* the marker recording: a different motion, equal to the rig vertices of its ground truth */
    mdl_markers *mk = NULL;
    mdl_meshseq *truth = NULL;
    ASSERT_OK(mdl_example_markers(r, 90, 1.3, &mk, &truth, err), err);
    ASSERT_INT_EQ(mk->frames, 90);
    ASSERT_INT_EQ(mk->count, 8);
    ASSERT_NEAR(mk->fps, 30, 0);
    ASSERT_INT_EQ(truth->frames, 90);
    ASSERT_INT_EQ(truth->nv, s->nv);
    ASSERT_INT_EQ(truth->nf, s->nf);
    ASSERT(!memcmp(truth->F, s->F, (size_t)s->nf * 3 * sizeof(uint32_t)));
    for (int m = 0; m < 8; m++)
        ASSERT(!strcmp(mk->names[m], names[m]));
    double diff = 0;
    for (int f = 0; f < 90; f++)
        for (int m = 0; m < 8; m++) {
            ASSERT_INT_EQ(mk->valid[f * 8 + m], 1);
            const float *p = mk->P + (f * 8 + m) * 3;
            const float *q = truth->V + ((size_t)f * truth->nv + r->markers[m].vertex) * 3;
            for (int i = 0; i < 3; i++) {
                ASSERT_NEAR_I(p[i], q[i], 0, f);
                diff = fmax(diff, fabs(q[i] - s->V[((size_t)f * s->nv + r->markers[m].vertex) * 3 + i]));
            }
        }
    printf("largest marker difference between the two motions: %.3f m\n", diff);
    ASSERT(diff > 0.05);
    mdl_markers_destroy(mk);
    mdl_meshseq_destroy(truth);

    /* without truth, deterministic */
    mdl_markers *mk2 = NULL;
    ASSERT_OK(mdl_example_markers(r, 90, 1.3, &mk2, NULL, err), err);
    ASSERT_OK(mdl_example_markers(r, 90, 1.3, &mk, NULL, err), err);
    ASSERT(!memcmp(mk->P, mk2->P, 90 * 8 * 3 * sizeof(float)));
    mdl_markers_destroy(mk);
    mdl_markers_destroy(mk2);

    /* bad arguments are refused with a reason */
    ASSERT_INT_EQ(mdl_example_create(0, &s2, NULL, err), -EINVAL);
    ASSERT(s2 == NULL && strstr(err, "frames"));
    ASSERT_INT_EQ(mdl_example_markers(r, 10, 0, &mk, NULL, err), -EINVAL);
    ASSERT(mk == NULL && strstr(err, "speed"));
    r->markers[3].vertex = s->nv;
    ASSERT_INT_EQ(mdl_example_markers(r, 10, 1, &mk, NULL, err), -EINVAL);
    ASSERT(mk == NULL && strstr(err, "rh_foot"));

    mdl_meshseq_destroy(s);
    mdl_rig_destroy(r);
    return 0;
}
