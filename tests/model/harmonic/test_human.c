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

/* the file's rest pose and motion (*rest, *mk: caller frees) and the template built from them
 * with the rest fit, as joint rotations need it */
static mdl_model *build_fitted(const mdl_mesh *target, const mdl_rig *rig, const char *path,
                               mdl_markers **rest, mdl_markers **mk)
{
    char err[MDL_ERR_LEN] = "";
    mdl_marker_opts mo = {.rest = 1};
    ASSERT_OK(mdl_markers_read(path, &mo, rest, err), err);
    mo.rest = 0;
    ASSERT_OK(mdl_markers_read(path, &mo, mk, err), err);
    mdl_harmonic_opts o;
    mdl_harmonic_opts_default(&o);
    o.template_motion = *mk;
    o.fit_rest = 1;
    mdl_model *m = NULL;
    ASSERT_OK(mdl_harmonic_build(target, rig, *rest, &o, &m, err), err);
    return m;
}

/* joints: drive the bones by the file's joint rotations (MDL_INPUT_JOINTS) as well */
static void run_take(const mdl_mesh *target, const mdl_rig *rig, const char *take, const char *rel,
                     const char *const legs[8], const char *const arms[8], int joints)
{
    char err[MDL_ERR_LEN] = "";
    const char *bvh = test_data(rel);
    mdl_markers *rest = NULL, *mk = NULL;
    mdl_model *m = build_fitted(target, rig, bvh, &rest, &mk);
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
    ASSERT(mdl_synth_inputs(s) & MDL_INPUT_JOINTS);
    float *jr = calloc(4 * (size_t)nmk, sizeof *jr);
    int used = 0;
    double arc = 0;
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
        for (int i = 0; i < nmk; i++) {
            memcpy(in + 3 * i, P + 3 * map[i], 3 * sizeof *in);
            memcpy(jr + 4 * i, mk->rot + 4 * ((size_t)f * mk->count + map[i]), 4 * sizeof *jr);
        }
        float *V = out + 3 * (size_t)nv * f;
        mdl_synth_input si = {.markers = in, .njoints = joints ? nmk : 0, .joint_rot = joints ? jr : NULL};
        mdl_synth_info sinfo;
        ASSERT_OK(mdl_synth_frame(s, &si, V, &sinfo), take);
        used = sinfo.joints_used > used ? sinfo.joints_used : used;
        arc = fmax(arc, sinfo.joint_arc_max);
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
    printf("%s, %s: bones driven by joint rotations: %d of %d; largest arc onto the markers "
           "%.2f deg\n", take, joints ? "with joint rotations" : "markers only", used, h->nbones,
           arc * 180 / M_PI);
    ASSERT_INT_EQ(used > 0, joints);
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
        snprintf(path, sizeof path, "%s/human-%s%s.pc2", bd, take, joints ? "" : "-markers");
        ASSERT_OK(mdl_pc2_write(path, out, nv, nfr, 0, (float)mk->fps, err), err);
        printf("%s: wrote %s\n", take, path);
    }
    free(jr), free(map), free(in), free(out), free(ratio), free(a0), free(spo), free(spi);
    mdl_synth_destroy(s);
    mdl_model_destroy(m);
    mdl_markers_destroy(rest);
    mdl_markers_destroy(mk);
}

/* A forearm twisted about its own axis by rotation channels alone: a BVH written here with
 * 131_01.bvh's skeleton, every channel 0 but LeftElbow's Yrotation (the forearm's own axis: the
 * wrist's OFFSET is along -y) = deg and LeftWrist's = -deg (the hand stays), for deg in TWIST_DEG.
 * Every marker stays where it is, so the direction path sees nothing. With the joint rotations, a
 * vertex of a forearm correspondence triangle turns about the forearm by deg (within TWIST_TOL),
 * and no cross-section of the forearm collapses (the candy wrapper, Sec. 4.3: its smallest radius,
 * per slab, >= CANDY_MIN of frame 0's); without them it does not turn (< 0.01 deg). */
#define TWIST_TOL 10.0  /* deg (measured <= 4.1) */
#define CANDY_MIN 0.5
static const double twist_deg[] = {0, 90, 170, 180, 190};
#define NTWIST 5

static double angle_about(const double *u, const double *a, const double *b)
{
    double pa[3], pb[3], da = 0, db = 0;
    for (int c = 0; c < 3; c++)
        da += a[c] * u[c], db += b[c] * u[c];
    for (int c = 0; c < 3; c++)
        pa[c] = a[c] - da * u[c], pb[c] = b[c] - db * u[c];
    double x = pa[0] * pb[0] + pa[1] * pb[1] + pa[2] * pb[2];
    double cr[3] = {pa[1] * pb[2] - pa[2] * pb[1], pa[2] * pb[0] - pa[0] * pb[2], pa[0] * pb[1] - pa[1] * pb[0]};
    return atan2(cr[0] * u[0] + cr[1] * u[1] + cr[2] * u[2], x) * 180 / M_PI;
}

static void run_twist(const mdl_mesh *target, const mdl_rig *rig)
{
    char err[MDL_ERR_LEN] = "";
    FILE *f = fopen(test_data("mocap/bvh/cmu/131_01.bvh"), "rb");
    ASSERT(f);
    static char text[1 << 16];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = 0;
    char *mo = strstr(text, "MOTION");
    ASSERT(mo);
    *mo = 0;
    /* the channel indices: CHANNELS belong to the last ROOT/JOINT named before them */
    int nch = 0, elbow_y = -1, wrist_y = -1;
    char joint[64] = "";
    for (char *t = strtok(text, " \t\r\n"); t; t = strtok(NULL, " \t\r\n")) {
        if (!strcmp(t, "ROOT") || !strcmp(t, "JOINT")) {
            snprintf(joint, sizeof joint, "%s", strtok(NULL, " \t\r\n"));
        } else if (!strcmp(t, "CHANNELS")) {
            int k = atoi(strtok(NULL, " \t\r\n"));
            for (int i = 0; i < k; i++, nch++) {
                const char *c = strtok(NULL, " \t\r\n");
                if (!strcmp(c, "Yrotation") && !strcmp(joint, "LeftElbow"))
                    elbow_y = nch;
                if (!strcmp(c, "Yrotation") && !strcmp(joint, "LeftWrist"))
                    wrist_y = nch;
            }
        }
    }
    ASSERT(elbow_y >= 0 && wrist_y >= 0);
    /* strtok cut the text: read the hierarchy again */
    f = fopen(test_data("mocap/bvh/cmu/131_01.bvh"), "rb");
    ASSERT(f && fread(text, 1, n, f) == n);
    fclose(f);
    *strstr(text, "MOTION") = 0;
    char path[4096];
    snprintf(path, sizeof path, "%s/twist-forearm.bvh", getenv("MESHSTEER_BUILD") ? getenv("MESHSTEER_BUILD") : "/tmp");
    f = fopen(path, "w");
    ASSERT(f);
    fprintf(f, "%sMOTION\nFrames: %d\nFrame Time: 0.0333333\n", text, NTWIST);
    for (int i = 0; i < NTWIST; i++) {
        for (int k = 0; k < nch; k++)
            fprintf(f, "%g ", k == elbow_y ? twist_deg[i] : k == wrist_y ? -twist_deg[i] : 0.0);
        fprintf(f, "\n");
    }
    ASSERT(fclose(f) == 0);
    mdl_markers *rest = NULL, *mk = NULL;
    mdl_model *m = build_fitted(target, rig, path, &rest, &mk);
    for (size_t k = 0; k < 3 * (size_t)mk->count; k++)
        for (int i = 1; i < NTWIST; i++)
            ASSERT_NEAR_I(mk->P[3 * (size_t)mk->count * i + k], mk->P[k], 1e-5, k);
    const struct mdl_harmonic *h = mdl__model_kind(m, MDL_KIND_HARMONIC)->impl;
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int nmk = info.nmarkers, nv = info.nv;
    int *map = calloc((size_t)nmk, sizeof *map);
    ASSERT(map);
    ASSERT_INT_EQ(mdl_model_bind_markers(m, (const char *const *)mk->names, mk->count, map), 0);
    int ie = -1, iw = -1, g = -1;
    for (int i = 0; i < nmk; i++) {
        ie = strcmp(info.markers[i].name, "LeftElbow") ? ie : i;
        iw = strcmp(info.markers[i].name, "LeftWrist") ? iw : i;
    }
    for (int b = 0; b < h->nbones; b++)
        g = h->bone_a[b] == ie && h->bone_b[b] == iw ? b : g;
    ASSERT(ie >= 0 && iw >= 0 && g >= 0);
    ASSERT_INT_EQ(h->bone_j[g], iw);
    /* the marker vertex: of the forearm's correspondence triangles, the one nearest its middle */
    const float *E = h->mk_rest + 3 * ie, *W = h->mk_rest + 3 * iw;
    double mid[3], ax[3], L = 0;
    for (int c = 0; c < 3; c++)
        mid[c] = 0.5 * ((double)E[c] + W[c]), ax[c] = (double)W[c] - E[c], L += ax[c] * ax[c];
    L = sqrt(L);
    for (int c = 0; c < 3; c++)
        ax[c] /= L;
    int mv = -1;
    double best = INFINITY;
    for (int i = 0; i < h->ncorr; i++) {
        if (h->corr_group[i] != g)
            continue;
        int v = (int)info.F[3 * h->corr_tri[i]];
        double d = 0;
        for (int c = 0; c < 3; c++)
            d += (info.rest[3 * v + c] - mid[c]) * (info.rest[3 * v + c] - mid[c]);
        if (d < best)
            best = d, mv = v;
    }
    ASSERT(mv >= 0);
    /* the forearm's vertices in 5 slabs (0.25 .. 0.75 of the bone, within 0.08 m of its axis) */
    int *slab = calloc((size_t)nv, sizeof *slab);
    ASSERT(slab);
    for (int v = 0; v < nv; v++) {
        double p[3], t = 0, r2 = 0;
        for (int c = 0; c < 3; c++)
            p[c] = (double)info.rest[3 * v + c] - E[c], t += p[c] * ax[c];
        for (int c = 0; c < 3; c++)
            r2 += (p[c] - t * ax[c]) * (p[c] - t * ax[c]);
        t /= L;
        slab[v] = t >= 0.25 && t < 0.75 && r2 < 0.08 * 0.08 ? (int)((t - 0.25) * 10) : -1;
    }
    float *V = calloc(3 * (size_t)nv * NTWIST, sizeof *V), *in = calloc(3 * (size_t)nmk, sizeof *in),
          *jr = calloc(4 * (size_t)nmk, sizeof *jr);
    ASSERT(V && in && jr);
    mdl_synth *s = NULL;
    ASSERT_OK(mdl_synth_create(m, 0, &s, err), err);
    for (int joints = 1; joints >= 0; joints--) {
        mdl_synth_reset(s);
        double r0[5] = {0}, worst_ratio = INFINITY;
        for (int i = 0; i < NTWIST; i++) {
            for (int k = 0; k < nmk; k++) {
                memcpy(in + 3 * k, mk->P + 3 * ((size_t)i * mk->count + map[k]), 3 * sizeof *in);
                memcpy(jr + 4 * k, mk->rot + 4 * ((size_t)i * mk->count + map[k]), 4 * sizeof *jr);
            }
            mdl_synth_input si = {.markers = in, .njoints = joints ? nmk : 0, .joint_rot = joints ? jr : NULL};
            float *X = V + 3 * (size_t)nv * i;
            ASSERT_OK(mdl_synth_frame(s, &si, X, NULL), "twist");
            /* the output's forearm axis: its aligned markers */
            double e[3], u[3], l = 0, a[3], b[3];
            for (int c = 0; c < 3; c++) {
                e[c] = h->align_scale * in[3 * ie + c] + h->align_t[c];
                u[c] = h->align_scale * ((double)in[3 * ie + c] - in[3 * iw + c]);
                l += u[c] * u[c];
            }
            /* about the centre of the marker vertex's own cross-section (the mesh's forearm need not
             * lie on the markers' line) */
            double c0[3] = {0, 0, 0}, c1[3] = {0, 0, 0}, cnt = 0;
            for (int v = 0; v < nv; v++)
                if (slab[v] >= 0 && slab[v] == slab[mv]) {
                    for (int c = 0; c < 3; c++)
                        c0[c] += V[3 * v + c], c1[c] += X[3 * v + c];
                    cnt++;
                }
            ASSERT(cnt > 0);
            for (int c = 0; c < 3; c++) {
                u[c] /= sqrt(l);
                a[c] = (double)V[3 * mv + c] - c0[c] / cnt;
                b[c] = (double)X[3 * mv + c] - c1[c] / cnt;
            }
            (void)e;
            if (getenv("HUMAN_DEBUG"))
                for (int ci = 0; ci < h->ncorr; ci++)
                    if (h->corr_group[ci] == g) {
                        double q[4];
                        mdl__tri_rotation(V, X, info.F + 3 * h->corr_tri[ci], q);
                        fprintf(stderr, "  corr tri %d: %.1f deg about (%.2f %.2f %.2f) u (%.2f %.2f %.2f)\n",
                                h->corr_tri[ci], 2 * acos(fmin(1, fabs(q[0]))) * 180 / M_PI, q[1], q[2], q[3], u[0], u[1], u[2]);
                    }
            double ang = angle_about(u, a, b), want = fmod(twist_deg[i] + 180, 360) - 180;
            double off = fabs(fmod(ang - want + 540, 360) - 180);
            /* the smallest radius per slab about the slab's centroid */
            double ratio = INFINITY;
            for (int k = 0; k < 5; k++) {
                double cen[3] = {0, 0, 0}, cnt = 0, rmin = INFINITY;
                for (int v = 0; v < nv; v++)
                    if (slab[v] == k) {
                        for (int c = 0; c < 3; c++)
                            cen[c] += X[3 * v + c];
                        cnt++;
                    }
                ASSERT(cnt > 0);
                for (int v = 0; v < nv; v++)
                    if (slab[v] == k) {
                        double p[3], t = 0, r2 = 0;
                        for (int c = 0; c < 3; c++)
                            p[c] = X[3 * v + c] - cen[c] / cnt, t += p[c] * u[c];
                        for (int c = 0; c < 3; c++)
                            r2 += (p[c] - t * u[c]) * (p[c] - t * u[c]);
                        rmin = fmin(rmin, sqrt(r2));
                    }
                if (i == 0)
                    r0[k] = rmin;
                ratio = fmin(ratio, rmin / r0[k]);
            }
            worst_ratio = fmin(worst_ratio, ratio);
            printf("twist %s: forearm %.0f deg: marker vertex %d turned %.1f deg about the forearm "
                   "(off by %.1f); smallest cross-section radius %.2f of frame 0's\n",
                   joints ? "with joint rotations" : "markers only", twist_deg[i], mv, ang, off, ratio);
            if (joints) {
                ASSERT_LE(off, TWIST_TOL);
                ASSERT_GE(ratio, CANDY_MIN);
            } else {
                ASSERT_LE(fabs(ang), 0.01);
            }
        }
        (void)worst_ratio;
    }
    mdl_synth_destroy(s);
    free(V), free(in), free(jr), free(slab), free(map);
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
    run_twist(target, rig);
    for (int joints = 1; joints >= 0 && !getenv("HUMAN_TWIST_ONLY"); joints--) {
        run_take(target, rig, "131_03", "mocap/bvh/cmu/131_03.bvh", cmu_legs, cmu_arms, joints);
        run_take(target, rig, "131_01", "mocap/bvh/cmu/131_01.bvh", cmu_legs, cmu_arms, joints);
        run_take(target, arig, "hdm05-dg", "mocap/asf_amc/hdm05/HDM_dg_06-03_03_120.amc", asf_legs,
                 asf_arms, joints);
    }
    mdl_rig_destroy(rig);
    mdl_rig_destroy(arig);
    mdl_mesh_destroy(target);
    return 0;
}
