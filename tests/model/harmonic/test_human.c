/* test_human.c - the paper's real use (de Aguiar et al. 2007 Sec. 5): the static human
 * (static-human/human_man.obj, an SMPL T-pose) animated by CMU BVH takes (131_03 hop, 131_01 walk)
 * through rigs/human-cmu-harmonic.json and the HDM05 ASF/AMC take (HDM_dg_06-03_03_120.amc)
 * through rigs/human-asf-harmonic.json, with automatic correspondences. Per take:
 *   - no non-finite vertex;
 *   - global position (Sec. 5): the lowest vertex of every frame within FLOOR_MAX of the mocap's
 *     lowest foot marker (ankles, toes and their end sites) mapped into the target's space; the
 *     template was once aligned by its rest pose (root at the origin) while the frames carry the
 *     hip height, and the man floated 1.2 m above the floor;
 *   - smoothness: the output's frame-to-frame jitter (mean |speed change| / mean speed) within
 *     JITTER_X times the input markers' (a flip of the candy-wrapper signs or of a bone's twist
 *     frame shows as a one-frame pop; they made it 13x);
 *   - per-triangle area change (area / rest area over all frames and triangles): the distribution
 *     is printed (volume loss at knees and elbows is the paper's own limitation) and its 0.1 % and
 *     99.9 % quantiles bounded.
 * The result is written as $MESHSTEER_BUILD/human-<take>.pc2 (tests/cli/test_cli.sh draws the
 * contact sheets with meshsteer render). Skips (77) without ../shared/data. */
#include "harmonic/harmonic_internal.h"
#include "kind.h"
#include "test.h"

/* Measured (this branch): mean 3.2 / 5.0 / 3.3 cm, max 12.9 / 18.3 / 10.9 cm (hop, walk, HDM05).
 * Before the template's rest pose was fitted to the target's (rest_fit.c: CMU legs spread ~20 deg
 * and arms hanging, against the SMPL T-pose) the mean was 7.3-8.4 cm; FLOOR_MEAN fails that. The
 * maxima are single frames (docs/MODEL.md); FLOOR_MAX catches the old 1.2 m float. */
#define FLOOR_MEAN 0.06 /* m */
#define FLOOR_MAX 0.25  /* m */
#define FIT_LEG 15.0    /* deg: a fitted thigh or shin from the vertical (the target's legs hang; the
                           template's CMU legs were 20 deg out; measured <= 5.4, HDM05 left shin 11.6) */
#define FIT_ARM 15.0    /* deg: a fitted upper arm or forearm from the horizontal (a T-pose) */
#define JITTER_X 2.0

static int cmpf(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static double tri_area(const float *V, const uint32_t *f)
{
    double e1[3], e2[3];
    for (int c = 0; c < 3; c++) {
        e1[c] = (double)V[3 * f[1] + c] - V[3 * f[0] + c];
        e2[c] = (double)V[3 * f[2] + c] - V[3 * f[0] + c];
    }
    double x = e1[1] * e2[2] - e1[2] * e2[1], y = e1[2] * e2[0] - e1[0] * e2[2],
           z = e1[0] * e2[1] - e1[1] * e2[0];
    return 0.5 * sqrt(x * x + y * y + z * z);
}

static int is_foot(const char *n)
{
    return strcasestr(n, "toe") || strcasestr(n, "ankle") || strcasestr(n, "foot") ||
           strcasestr(n, "tibia"); /* an ASF tibia's far end is the ankle */
}

/* mean |s(f) - s(f-1)| / mean s over frames 1..n-1 (cmd_synth.c's definition) */
static double jitter(const double *sp, int n)
{
    double d = 0, m = 0;
    for (int f = 1; f < n; f++)
        m += sp[f];
    for (int f = 2; f < n; f++)
        d += fabs(sp[f] - sp[f - 1]);
    return m > 0 ? (d / (n - 2)) / (m / (n - 1)) : 0;
}

/* the angle in degrees of the fitted bone from marker a to b against the axis ax (0 x, 1 y) */
static double bone_angle(const struct mdl_harmonic *h, const mdl_rig *rig, const char *a,
                         const char *b, int ax)
{
    int ia = -1, ib = -1;
    for (int i = 0; i < rig->nmarkers; i++) {
        ia = strcmp(rig->markers[i].name, a) ? ia : i;
        ib = strcmp(rig->markers[i].name, b) ? ib : i;
    }
    ASSERT(ia >= 0 && ib >= 0);
    double d[3], l = 0;
    for (int c = 0; c < 3; c++) {
        d[c] = (double)h->mk_rest[3 * ib + c] - h->mk_rest[3 * ia + c];
        l += d[c] * d[c];
    }
    return acos(fabs(d[ax]) / sqrt(l)) * 180 / M_PI;
}

/* The rest fit (rest_fit.c): every leg bone of the template hangs along the target's legs and
 * every arm bone lies along its T-posed arms. names: thigh, shin (left, right), upper arm, forearm
 * (left, right) as from/to marker pairs. */
static void check_fit(const struct mdl_harmonic *h, const mdl_rig *rig, const char *take,
                      const char *const legs[8], const char *const arms[8])
{
    for (int i = 0; i < 4; i++) {
        double al = bone_angle(h, rig, legs[2 * i], legs[2 * i + 1], 1);
        double aa = bone_angle(h, rig, arms[2 * i], arms[2 * i + 1], 0);
        printf("%s: fitted rest: %s-%s %.1f deg from vertical, %s-%s %.1f deg from horizontal\n",
               take, legs[2 * i], legs[2 * i + 1], al, arms[2 * i], arms[2 * i + 1], aa);
        ASSERT_LE(al, FIT_LEG);
        ASSERT_LE(aa, FIT_ARM);
    }
}

static const char *const cmu_legs[8] = {"LeftHip", "LeftKnee", "LeftKnee", "LeftAnkle",
                                        "RightHip", "RightKnee", "RightKnee", "RightAnkle"};
static const char *const cmu_arms[8] = {"LeftShoulder", "LeftElbow", "LeftElbow", "LeftWrist",
                                        "RightShoulder", "RightElbow", "RightElbow", "RightWrist"};
static const char *const asf_legs[8] = {"lhipjoint", "lfemur", "lfemur", "ltibia",
                                        "rhipjoint", "rfemur", "rfemur", "rtibia"};
static const char *const asf_arms[8] = {"lclavicle", "lhumerus", "lhumerus", "lradius",
                                        "rclavicle", "rhumerus", "rhumerus", "rradius"};

static void run_take(const mdl_mesh *target, const mdl_rig *rig, const char *take, const char *rel,
                     const char *const legs[8], const char *const arms[8])
{
    char err[MDL_ERR_LEN] = "";
    const char *bvh = test_data(rel);
    mdl_marker_opts mo = {0};
    mdl_markers *rest = NULL, *mk = NULL;
    mo.rest = 1;
    ASSERT_OK(mdl_markers_read(bvh, &mo, &rest, err), err);
    mo.rest = 0;
    ASSERT_OK(mdl_markers_read(bvh, &mo, &mk, err), err);
    mdl_harmonic_opts o;
    mdl_harmonic_opts_default(&o);
    o.template_motion = mk;
    o.fit_rest = 1;
    mdl_model *m = NULL;
    ASSERT_OK(mdl_harmonic_build(target, rig, rest, &o, &m, err), err);
    const struct mdl_harmonic *h = mdl__model_kind(m, MDL_KIND_HARMONIC)->impl;
    check_fit(h, rig, take, legs, arms);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int nmk = info.nmarkers, nv = info.nv, nf = info.nf, nfr = mk->frames;
    int *map = calloc((size_t)nmk, sizeof *map);
    ASSERT_INT_EQ(mdl_model_bind_markers(m, (const char *const *)mk->names, mk->count, map), 0);
    /* the lowest foot marker of the whole file, any label with Toe/Ankle/Foot */
    mdl_synth *s = NULL;
    ASSERT_OK(mdl_synth_create(m, 0, &s, err), err);
    float *in = calloc(3 * (size_t)nmk, sizeof *in), *out = calloc(3 * (size_t)nv * nfr, sizeof *out);
    float *ratio = calloc((size_t)nf * ((nfr + 9) / 10), sizeof *ratio);
    double *a0 = calloc((size_t)nf, sizeof *a0), *spo = calloc((size_t)nfr, sizeof *spo),
           *spi = calloc((size_t)nfr, sizeof *spi);
    ASSERT(map && in && out && ratio && a0 && spo && spi);
    for (int t = 0; t < nf; t++)
        a0[t] = tri_area(info.rest, info.F + 3 * t);
    double gap_max = 0, gap_sum = 0;
    int gap_at = -1, nratio = 0;
    for (int f = 0; f < nfr; f++) {
        const float *P = mk->P + 3 * (size_t)f * mk->count;
        for (int i = 0; i < nmk; i++)
            memcpy(in + 3 * i, P + 3 * map[i], 3 * sizeof *in);
        float *V = out + 3 * (size_t)nv * f;
        ASSERT_OK(mdl_synth_markers(s, in, NULL, V, NULL), take);
        double lo = INFINITY, foot = INFINITY;
        for (int v = 0; v < nv; v++) {
            for (int c = 0; c < 3; c++)
                ASSERT(isfinite(V[3 * v + c]));
            lo = V[3 * v + 1] < lo ? V[3 * v + 1] : lo;
        }
        for (int j = 0; j < mk->count; j++)
            if (is_foot(mk->names[j]))
                foot = fmin(foot, h->align_scale * P[3 * j + 1] + h->align_t[1]);
        ASSERT(isfinite(foot));
        double gap = fabs(lo - foot);
        if (getenv("HUMAN_DEBUG")) {
            int jl = 0, vl = 0;
            for (int j = 1; j < mk->count; j++)
                jl = P[3 * j + 1] < P[3 * jl + 1] ? j : jl;
            for (int v = 1; v < nv; v++)
                vl = V[3 * v + 1] < V[3 * vl + 1] ? v : vl;
            fprintf(stderr, "%d lo %.4f foot %.4f lowest marker %s %.4f, lowest vertex %d at %.3f %.3f\n",
                    f, lo, foot, mk->names[jl], h->align_scale * P[3 * jl + 1] + h->align_t[1], vl,
                    V[3 * vl], V[3 * vl + 2]);
        }
        gap_sum += gap;
        if (gap > gap_max)
            gap_max = gap, gap_at = f;
        if (f > 0) {
            const float *U = V - 3 * (size_t)nv, *Q = mk->P + 3 * (size_t)(f - 1) * mk->count;
            for (int v = 0; v < nv; v++)
                spo[f] += sqrt(((double)V[3 * v] - U[3 * v]) * (V[3 * v] - U[3 * v]) +
                               ((double)V[3 * v + 1] - U[3 * v + 1]) * (V[3 * v + 1] - U[3 * v + 1]) +
                               ((double)V[3 * v + 2] - U[3 * v + 2]) * (V[3 * v + 2] - U[3 * v + 2])) / nv;
            for (int j = 0; j < mk->count; j++)
                spi[f] += h->align_scale *
                          sqrt(((double)P[3 * j] - Q[3 * j]) * (P[3 * j] - Q[3 * j]) +
                               ((double)P[3 * j + 1] - Q[3 * j + 1]) * (P[3 * j + 1] - Q[3 * j + 1]) +
                               ((double)P[3 * j + 2] - Q[3 * j + 2]) * (P[3 * j + 2] - Q[3 * j + 2])) /
                          mk->count;
        }
        if (f % 10 == 0)
            for (int t = 0; t < nf; t++)
                ratio[nratio++] = a0[t] > 0 ? (float)(tri_area(V, info.F + 3 * t) / a0[t]) : 1.0f;
    }
    qsort(ratio, (size_t)nratio, sizeof *ratio, cmpf);
    double jo = jitter(spo, nfr), ji = jitter(spi, nfr);
#define Q_(p) ratio[(size_t)((p) * (nratio - 1))]
    printf("%s: %d frames; lowest vertex vs lowest foot marker: mean %.4f m, max %.4f m (frame %d)\n"
           "%s: jitter output %.4f input %.4f (x%.2f)\n"
           "%s: triangle area / rest area over every 10th frame: min %.3f p0.1 %.3f p1 %.3f p5 %.3f "
           "p50 %.3f p95 %.3f p99 %.3f p99.9 %.3f max %.3f\n",
           take, nfr, gap_sum / nfr, gap_max, gap_at, take, jo, ji, ji > 0 ? jo / ji : 0, take,
           Q_(0.0), Q_(0.001), Q_(0.01), Q_(0.05), Q_(0.5), Q_(0.95), Q_(0.99), Q_(0.999), Q_(1.0));
    ASSERT_LE(gap_sum / nfr, FLOOR_MEAN);
    ASSERT_LE(gap_max, FLOOR_MAX);
    ASSERT_LE(jo, JITTER_X * ji);
    ASSERT_GE(Q_(0.001), 0.1);
    ASSERT_LE(Q_(0.999), 2.0);
#undef Q_
    const char *bd = getenv("MESHSTEER_BUILD");
    if (bd) {
        char path[4096];
        snprintf(path, sizeof path, "%s/human-%s.pc2", bd, take);
        ASSERT_OK(mdl_pc2_write(path, out, nv, nfr, 0, (float)mk->fps, err), err);
        printf("%s: wrote %s\n", take, path);
    }
    free(map), free(in), free(out), free(ratio), free(a0), free(spo), free(spi);
    mdl_synth_destroy(s);
    mdl_model_destroy(m);
    mdl_markers_destroy(rest);
    mdl_markers_destroy(mk);
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_mesh *target = NULL;
    mdl_rig *rig = NULL, *arig = NULL;
    ASSERT_OK(mdl_mesh_read_obj(test_data("meshes/static-human/human_man.obj"), &target, err), err);
    ASSERT_OK(mdl_rig_read(test_src("rigs/human-cmu-harmonic.json"), 0, &rig, err), err);
    ASSERT_OK(mdl_rig_read(test_src("rigs/human-asf-harmonic.json"), 0, &arig, err), err);
    run_take(target, rig, "131_03", "mocap/bvh/cmu/131_03.bvh", cmu_legs, cmu_arms);
    run_take(target, rig, "131_01", "mocap/bvh/cmu/131_01.bvh", cmu_legs, cmu_arms);
    run_take(target, arig, "hdm05-dg", "mocap/asf_amc/hdm05/HDM_dg_06-03_03_120.amc", asf_legs,
             asf_arms);
    mdl_rig_destroy(rig);
    mdl_rig_destroy(arig);
    mdl_mesh_destroy(target);
    return 0;
}
