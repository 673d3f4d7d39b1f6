/* test_rig_propose.c - the rig proposed from the mesh alone (steer/rig_propose.c, issue 12) is
 * stable: proposed from any frame of a captured sequence, it is the rig proposed from frame 0
 * (the rest pose: samba's and pjump's rest.obj are their frame 0), give or take a neighbouring
 * vertex. Measured per marker as the geodesic distance (Dijkstra along mesh edges, in frame 0)
 * between the vertex proposed from frame k and the one proposed from frame 0, and the body and
 * the sides must agree (a left marker is not nearer frame 0's right one).
 *
 * The radius: STABLE_RADIUS of the body's height along up, for the medoid over frames
 * (mdl_rig_propose_frames) from two disjoint sets of frames. A proposal that snaps each marker to
 * a region (a cap's middle, a slab's top) lands anywhere on that region as its shape changes
 * with the pose; a region a few edges across on a 1.7-1.9 m body is 5-8 cm, 3-5 % of the height.
 * One frame proposed alone is held to SINGLE_RADIUS: not yet a neighbouring vertex, since the
 * trunk markers (samba's pelvis on a dress, pjump's neck, the horse's withers) sit on wide
 * regions; measured 0.061-0.080 of the height on 2026-12-02 after the tips were refined (0.118
 * before, pjump's head on its cut neck), so this guards against falling back.
 *
 * Usage: test_rig_propose [STEP]  (every STEP-th frame; default 10) prints the table of
 * docs/MODEL.md "Stability" and checks the bound on every sequence; exits 77 without the data. */
#include "core/meshgraph.h"
#include "model.h"
#include "test.h"

#define STABLE_RADIUS 0.05 /* of the body's height */
#define SINGLE_RADIUS 0.085 /* of the body's height, one frame alone */

typedef struct seqcase {
    const char *name, *path, *rest;
    int step; /* every step-th frame: 12 or more frames of each */
} seqcase;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static int find_marker(const mdl_rig *r, const char *name)
{
    for (int i = 0; i < r->nmarkers; i++)
        if (!strcmp(r->markers[i].name, name))
            return i;
    return -1;
}

/* The marker of the other side: lhand <-> rhand, lf_hoof <-> rf_hoof; -1 for the mid-line. */
static int mirror_marker(const mdl_rig *r, const char *name)
{
    char m[64];
    if (name[0] != 'l' && name[0] != 'r')
        return -1;
    snprintf(m, sizeof m, "%c%s", name[0] == 'l' ? 'r' : 'l', name + 1);
    return find_marker(r, m);
}

static void run(const seqcase *c, int step, double *worst_frac)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    ASSERT_OK(mdl_meshseq_read(test_data(c->path), c->rest ? test_data(c->rest) : NULL, &s, err),
              err);
    const float up[3] = {0, 1, 0};
    mdl_rig *ref;
    mdl_rig_proposal info0;
    ASSERT_OK(mdl_rig_propose(s->V, s->nv, s->F, s->nf, up, MDL_BODY_AUTO, &ref, &info0, err), err);
    int nm = ref->nmarkers;
    /* geodesic distance in frame 0 from each of frame 0's markers */
    mdl_graph g;
    ASSERT_OK(mdl__graph_init(&g, s->nv, s->F, s->nf, err), err);
    double **D = calloc((size_t)nm, sizeof *D);
    ASSERT(D);
    for (int i = 0; i < nm; i++) {
        D[i] = malloc((size_t)s->nv * sizeof **D);
        ASSERT(D[i]);
        ASSERT_OK(mdl__geodesic(&g, s->V, &ref->markers[i].vertex, 1, NULL, D[i], err), err);
    }
    double lo = INFINITY, hi = -INFINITY;
    for (int v = 0; v < s->nv; v++) {
        lo = fmin(lo, s->V[3 * (size_t)v + 1]);
        hi = fmax(hi, s->V[3 * (size_t)v + 1]);
    }
    double height = hi - lo, radius = STABLE_RADIUS * height;
    int nk = 0;
    for (int k = 0; k < s->frames; k += step)
        nk++;
    double *gd = calloc((size_t)nm * nk, sizeof *gd), *ed = calloc((size_t)nm * nk, sizeof *ed);
    int *worst_k = calloc((size_t)nm, sizeof *worst_k), refused = 0, flips = 0, bodies = 0;
    ASSERT(gd && ed && worst_k);
    int j = 0;
    for (int k = 0; k < s->frames; k += step, j++) {
        mdl_rig *r;
        mdl_rig_proposal info;
        const float *V = s->V + (size_t)k * s->nv * 3;
        int e = mdl_rig_propose(V, s->nv, s->F, s->nf, up, MDL_BODY_AUTO, &r, &info, err);
        if (e) {
            printf("%s frame %d: refused: %s\n", c->name, k, err);
            refused++;
            for (int i = 0; i < nm; i++)
                gd[(size_t)i * nk + j] = ed[(size_t)i * nk + j] = INFINITY;
            continue;
        }
        if (info.body != info0.body) {
            printf("%s frame %d: body %d, frame 0's %d\n", c->name, k, info.body, info0.body);
            bodies++;
        }
        for (int i = 0; i < nm; i++) {
            int q = find_marker(r, ref->markers[i].name);
            double g1 = INFINITY, e1 = INFINITY;
            if (q >= 0) {
                int v = r->markers[q].vertex, v0 = ref->markers[i].vertex;
                const float *a = s->V + 3 * (size_t)v, *b = s->V + 3 * (size_t)v0;
                g1 = D[i][v];
                e1 = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                          (a[2] - b[2]) * (a[2] - b[2]));
                int o = mirror_marker(ref, ref->markers[i].name);
                if (o >= 0 && D[o][v] < g1) {
                    printf("%s frame %d: %s (vertex %d) is nearer frame 0's %s\n", c->name, k,
                           ref->markers[i].name, v, ref->markers[o].name);
                    flips++;
                }
            }
            gd[(size_t)i * nk + j] = g1;
            ed[(size_t)i * nk + j] = e1;
            if (g1 > gd[(size_t)i * nk + worst_k[i]])
                worst_k[i] = j;
        }
        mdl_rig_destroy(r);
    }
    printf("%s: %d frames (every %d), height %.3f m, radius %.3f m (%.2f of the height); per "
           "marker: geodesic distance from frame 0's vertex, median / max cm (frame of the max), "
           "euclidean max cm\n",
           c->name, nk, step, height, radius, STABLE_RADIUS);
    double worst = 0;
    for (int i = 0; i < nm; i++) {
        double *row = gd + (size_t)i * nk, emax = 0, *sorted = malloc((size_t)nk * sizeof *sorted);
        ASSERT(sorted);
        memcpy(sorted, row, (size_t)nk * sizeof *sorted);
        qsort(sorted, (size_t)nk, sizeof *sorted, cmp_double);
        for (int q = 0; q < nk; q++)
            emax = fmax(emax, ed[(size_t)i * nk + q]);
        printf("  %-8s %6.1f / %6.1f (frame %3d)  %6.1f\n", ref->markers[i].name,
               100 * sorted[nk / 2], 100 * row[worst_k[i]], worst_k[i] * step, 100 * emax);
        worst = fmax(worst, row[worst_k[i]]);
        free(sorted);
    }
    printf("%s: worst %.1f cm = %.3f of the height; %d refused, %d side flips, %d other bodies\n",
           c->name, 100 * worst, worst / height, refused, flips, bodies);
    if (worst / height > *worst_frac)
        *worst_frac = worst / height;
    ASSERT_INT_EQ(refused, 0);
    ASSERT_INT_EQ(bodies, 0);
    ASSERT_INT_EQ(flips, 0);
    ASSERT_LE(worst / height, SINGLE_RADIUS);
    /* the medoid over frames (mdl_rig_propose_frames) from two disjoint sets of frames, every
     * step-th from 0 and every step-th from step / 2: the same rig within the radius */
    int half = step / 2 > 0 ? step / 2 : 1, na = 0, nb = 0;
    float *A = malloc((size_t)s->frames * s->nv * 3 * sizeof *A),
          *B = malloc((size_t)s->frames * s->nv * 3 * sizeof *B);
    ASSERT(A && B);
    memcpy(A, s->V, (size_t)s->nv * 3 * sizeof *A); /* frame 0 first: medoids measured in it */
    na = 1;
    memcpy(B, s->V, (size_t)s->nv * 3 * sizeof *B);
    for (int k = step; k < s->frames; k += step)
        memcpy(A + (size_t)na++ * s->nv * 3, s->V + (size_t)k * s->nv * 3,
               (size_t)s->nv * 3 * sizeof *A);
    for (int k = half; k < s->frames; k += step)
        memcpy(B + (size_t)++nb * s->nv * 3, s->V + (size_t)k * s->nv * 3,
               (size_t)s->nv * 3 * sizeof *B);
    /* B's frame 0 is the measuring frame only; its proposal votes too, so drop it: B + nv*3 */
    mdl_rig *ra, *rb;
    int ua, ub;
    ASSERT_OK(mdl_rig_propose_frames(A, s->nv, na, NULL, s->F, s->nf, up, MDL_BODY_AUTO, &ra,
                                     NULL, &ua, err), err);
    ASSERT_OK(mdl_rig_propose_frames(B + (size_t)s->nv * 3, s->nv, nb, NULL, s->F, s->nf, up,
                                     MDL_BODY_AUTO, &rb, NULL, &ub, err), err);
    ASSERT_INT_EQ(ra->nmarkers, nm);
    ASSERT_INT_EQ(rb->nmarkers, nm);
    double cworst = 0;
    printf("%s: the medoid over %d frames (0:%d:%d) and over %d others (%d:%d:%d), geodesic cm in "
           "frame 0:", c->name, ua, s->frames, step, ub, half, s->frames, step);
    for (int i = 0; i < nm; i++) {
        double *Dm = malloc((size_t)s->nv * sizeof *Dm);
        ASSERT(Dm);
        ASSERT_OK(mdl__geodesic(&g, s->V, &ra->markers[i].vertex, 1, NULL, Dm, err), err);
        double d = Dm[rb->markers[i].vertex];
        printf(" %s %.1f", ra->markers[i].name, 100 * d);
        cworst = fmax(cworst, d);
        free(Dm);
    }
    printf("; worst %.3f of the height\n", cworst / height);
    for (int i = 0; i < nm; i++) {
        double *Dm = malloc((size_t)s->nv * sizeof *Dm);
        ASSERT(Dm);
        ASSERT_OK(mdl__geodesic(&g, s->V, &ra->markers[i].vertex, 1, NULL, Dm, err), err);
        ASSERT_LE_I(Dm[rb->markers[i].vertex], radius, i);
        free(Dm);
    }
    mdl_rig_destroy(ra);
    mdl_rig_destroy(rb);
    free(A);
    free(B);
    free(gd);
    free(ed);
    free(worst_k);
    for (int i = 0; i < nm; i++)
        free(D[i]);
    free(D);
    mdl__graph_fini(&g);
    mdl_rig_destroy(ref);
    mdl_meshseq_destroy(s);
}

int main(int argc, char **argv)
{
    int step = argc > 1 ? atoi(argv[1]) : 0; /* 0: each sequence's own */
    ASSERT_INT_GE(step, 0);
    static const seqcase cases[] = {
        {"samba", "meshes/samba/samba.pc2", "meshes/samba/rest.obj", 10},
        {"pjump", "meshes/pjump/pjump.pc2", "meshes/pjump/rest.obj", 10},
        {"horse-gallop", "meshes/horse-gallop", NULL, 4},
    };
    /* the check is per sequence (run asserts); this keeps the measurement going in a table run */
    double worst = 0;
    int only = argc > 2 ? atoi(argv[2]) : -1;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        if (only < 0 || (size_t)only == i)
            run(&cases[i], step ? step : cases[i].step, &worst);
    printf("worst over the sequences, one frame alone: %.3f of the height (bound %.3f)\n", worst,
           SINGLE_RADIUS);
    return 0;
}
