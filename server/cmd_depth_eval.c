/* cmd_depth_eval.c - `meshsteer depth-eval`: renders a mesh sequence with the test camera
 * (drivers/depth.h, render.c), runs depth -> markers (drivers/depth.h, markers.c) on every
 * frame and compares the extracted head/hands/feet with the rig's ground-truth vertices.
 *
 * Scene: the floor is the lowest vertex of the sequence; the person's horizontal centroid stands
 * DISTANCE metres in front of the camera (camera 1.0 m high, pitched 2 degrees down) - in every
 * frame by default, since a dancer travelling 1.8 m towards the camera (samba) would leave the
 * Kinect's 43 degree vertical field of view; --travel keeps that travel, centred on DISTANCE -
 * facing it: the facing direction is (L - R) x up with L, R the means of the rig's left and right
 * hand/foot markers in the first frame; then the person is turned by YAW degrees.
 * Scores: within_10cm[kind] = the fraction of ground-truth extremities of that kind (head; lhand,
 * rhand; lfoot, rfoot) inside the image (out_of_view counts the others) with an extracted marker of the same kind (either side) within 10 cm;
 * side_correct = the fraction of hands and feet whose same-side marker is within 10 cm. Errors are
 * distances to the nearest extracted marker of the same kind (a missing marker counts as infinite
 * and is left out of the error percentiles). Times are those of drv_depth_tracker_process alone. */
#include "cli.h"

#include "depth.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const char *CMD = "depth-eval";

static void help(void)
{
    printf("usage: meshsteer depth-eval --mesh PATH [--rest REST.obj] --rig RIG.json [--frames SPEC]\n"
           "                            [--distance M] [--yaw DEG] [--fps F] [--step N] [--no-smooth]\n"
           "                            [--travel] [--per-frame] [--dump-depth FILE] [--json]\n\n"
           "Renders the mesh sequence as Kinect v1 depth (the test camera), extracts head, hand and\n"
           "foot markers from every frame and scores them against the rig markers named head,\n"
           "lhand, rhand, lfoot, rfoot.\n\n"
           "  --mesh PATH      a .pc2 point cache (needs --rest) or a directory of OBJ frames\n"
           "  --rest OBJ       topology of a .pc2\n"
           "  --rig JSON       the rig (DESIGN.md format)\n"
           "  --frames SPEC    start:stop[:step] of the sequence (default all)\n"
           "  --distance M     metres from the camera to the person (default 2.5)\n"
           "  --yaw DEG        turn the person away from facing the camera (default 0)\n"
           "  --fps F          frame rate when the file has none (default 30)\n"
           "  --step N         a fixed tracker grid of N-pixel cells (default: sized by the\n"
           "                   person's distance, 4 pixels at 2.5 m)\n"
           "  --no-smooth      score the unfiltered markers\n"
           "  --travel         keep the performer's travel towards/away from the camera (default:\n"
           "                   each frame's centroid is held at --distance; sideways travel is kept)\n"
           "  --per-frame      print one line per frame: each ground-truth marker's error to the\n"
           "                   same-label extracted marker (cm, '-' = none, 'o' = out of view) and\n"
           "                   the extrema with their labels (diagnostics, before the summary)\n"
           "  --dump-depth FILE  write every rendered frame to FILE as raw 640x480 little-endian\n"
           "                   uint16 millimetres, frame after frame (for offline debugging)\n"
           "  --json           print one JSON object (otherwise a short table)\n");
}

static int cmpd(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double pct(double *v, int n, double q)
{
    if (n == 0)
        return NAN;
    qsort(v, (size_t)n, sizeof *v, cmpd);
    return v[(int)(q * (n - 1) + 0.5)];
}

static float dist3(const float *a, const float *b)
{
    float x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return sqrtf(x * x + y * y + z * z);
}

static void jnum(const char *key, double v, int comma)
{
    if (isfinite(v))
        printf("\"%s\": %.4f%s", key, v, comma ? ", " : "");
    else
        printf("\"%s\": null%s", key, comma ? ", " : "");
}

/* ------------------------------------------------------------------ the steps */

typedef struct de_args {
    const char *mesh, *rest, *rig, *frames, *dump;
    double distance, yaw_deg, fps;
    int json, smooth, step, travel, per_frame;
} de_args;

/* Parses the command line into *o. Returns -1 to go on, otherwise the exit status (--help, a
 * usage error). */
static int parse_args(int argc, char **argv, de_args *o)
{
    *o = (de_args){.frames = ":", .distance = 2.5, .fps = 30, .smooth = 1};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            help();
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--json")) {
            o->json = 1;
        } else if (!strcmp(a, "--no-smooth")) {
            o->smooth = 0;
        } else if (!strcmp(a, "--travel")) {
            o->travel = 1;
        } else if (!strcmp(a, "--per-frame")) {
            o->per_frame = 1;
        } else if (!v) {
            return cli_usage_error(CMD, "unknown option or missing value: %s", a);
        } else if (!strcmp(a, "--mesh")) {
            o->mesh = v, i++;
        } else if (!strcmp(a, "--dump-depth")) {
            o->dump = v, i++;
        } else if (!strcmp(a, "--rest")) {
            o->rest = v, i++;
        } else if (!strcmp(a, "--rig")) {
            o->rig = v, i++;
        } else if (!strcmp(a, "--frames")) {
            o->frames = v, i++;
        } else if (!strcmp(a, "--distance")) {
            if (cli_parse_double(CMD, a, v, &o->distance))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--yaw")) {
            if (cli_parse_double(CMD, a, v, &o->yaw_deg))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--fps")) {
            if (cli_parse_double(CMD, a, v, &o->fps))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--step")) {
            if (cli_parse_int(CMD, a, v, &o->step))
                return CLI_EXIT_USAGE;
            i++;
        } else {
            return cli_usage_error(CMD, "unknown option %s", a);
        }
    }
    if (!o->mesh || !o->rig)
        return cli_usage_error(CMD, "--mesh and --rig are required (see --help)");
    if (!(o->distance >= 0.8 && o->distance <= 4.5))
        return cli_usage_error(CMD, "--distance %g: the Kinect sees 0.8 .. 4.5 m", o->distance);
    if (!(o->fps > 0 && o->fps <= 1000))
        return cli_usage_error(CMD, "--fps %g: must be in (0, 1000]", o->fps);
    if (o->step && (o->step < 1 || o->step > 16))
        return cli_usage_error(CMD, "--step %d: must be 1 .. 16", o->step);
    return -1;
}

/* Ground-truth vertices gv[5]: the rig markers named head, lhand, rhand, lfoot, rfoot (the
 * tracker's label order). Returns 0, or the exit status after a message. */
static int truth_vertices(const mdl_rig *rig, const char *rigp, int gv[5])
{
    for (int l = 0; l < 5; l++) {
        gv[l] = -1;
        for (int m = 0; m < rig->nmarkers; m++)
            if (!strcmp(rig->markers[m].name, drv_depth_label_names[l]))
                gv[l] = rig->markers[m].vertex;
        if (gv[l] < 0)
            return cli_fail(CMD, CLI_EXIT_USAGE, "%s: no marker named '%s'", rigp,
                            drv_depth_label_names[l]);
    }
    return 0;
}

/* How the sequence stands in front of the camera (the file header's "Scene"). */
typedef struct de_scene {
    double px, pz;   /* pivot: the mean horizontal centroid of the selected frames */
    float yaw;       /* radians about the vertical axis through the pivot */
    float cy, sy;    /* its cosine and sine */
    float t[3];      /* then this translation: pivot to (0, *, -distance), floor to y = 0 */
} de_scene;

/* Floor (lowest vertex), pivot and facing ((L - R) x up, turned to +Z, then by yaw). Returns 0,
 * or the exit status after a message when the left and right markers coincide. */
static int place_scene(const mdl_meshseq *seq, const int *idx, int nidx, const int gv[5],
                       const de_args *o, de_scene *sc)
{
    const int nv = seq->nv;
    float floor_y = INFINITY;
    double px = 0, pz = 0;
    for (int k = 0; k < nidx; k++) {
        const float *F0 = seq->V + (size_t)idx[k] * nv * 3;
        double sx = 0, sz = 0;
        for (int i = 0; i < nv; i++) {
            floor_y = fminf(floor_y, F0[3 * i + 1]);
            sx += F0[3 * i];
            sz += F0[3 * i + 2];
        }
        px += sx / nv;
        pz += sz / nv;
    }
    px /= nidx;
    pz /= nidx;
    const float *V0 = seq->V + (size_t)idx[0] * nv * 3;
    float ax = 0, az = 0;
    for (int s = 0; s < 2; s++) { /* L - R from hands and feet */
        int lv = gv[1 + 2 * s], rv = gv[2 + 2 * s];
        ax += V0[3 * lv] - V0[3 * rv];
        az += V0[3 * lv + 2] - V0[3 * rv + 2];
    }
    /* facing = (L - R) x up = (-az, 0, ax); turn it to +Z (towards the camera), then by yaw */
    double fx = -az, fz = ax;
    if (fx * fx + fz * fz < 1e-12)
        return cli_fail(CMD, CLI_EXIT_USAGE, "%s: left and right markers coincide", o->rig);
    sc->px = px;
    sc->pz = pz;
    sc->yaw = (float)(atan2(-fx, fz) + o->yaw_deg * M_PI / 180.0);
    sc->t[0] = (float)-px;
    sc->t[1] = -floor_y;
    sc->t[2] = (float)(-o->distance - pz);
    sc->cy = cosf(sc->yaw);
    sc->sy = sinf(sc->yaw);
    return 0;
}

/* Places frame Vf into the scene (into V, nv x 3) and, unless the travel is kept, holds its
 * centroid at the distance (sideways travel stays). */
static void place_frame(const de_scene *sc, const float *Vf, int nv, int travel, float *V)
{
    drv_render_place(Vf, nv, sc->yaw, (float)sc->px, (float)sc->pz, sc->t, V);
    if (travel)
        return;
    double sx = 0, sz = 0;
    for (int i = 0; i < nv; i++) {
        sx += Vf[3 * i] - sc->px;
        sz += Vf[3 * i + 2] - sc->pz;
    }
    float dz = (float)(-sc->sy * sx / nv + sc->cy * sz / nv); /* its offset along the axis */
    for (int i = 0; i < nv; i++)
        V[3 * i + 2] -= dz;
}

/* The counts behind the scores, per kind (0 head, 1 hand, 2 foot) and per label; errs[kind]
 * holds nerr[kind] distances (2 per frame at most), ms one time per frame. */
typedef struct de_scores {
    int hit[3], total[3], nerr[3];
    int side_ok, side_total;
    int per_label_hit[5], per_label_total[5];
    int out_of_view;
    double *ms, *errs[3];
} de_scores;

/* Scores one frame's tracker result against the ground-truth vertices of V (scene frame); with
 * per_frame, prints each marker's error and then the extrema (one line). */
static void score_frame(de_scores *sc, const drv_depth_result *res, const drv_render *ren,
                        const drv_intrinsics *k, const float *V, const int gv[5], int per_frame)
{
    for (int l = 0; l < 5; l++) {
        float gt[3];
        drv_render_world_to_camera(ren, V + 3 * gv[l], gt);
        double gu, gvv;
        if (drv_intrinsics_project(k, gt, &gu, &gvv) || gu < 4 || gvv < 4 || gu > k->width - 5 ||
            gvv > k->height - 5) {
            sc->out_of_view++;
            if (per_frame)
                printf(" %s o(%3.0f,%3.0f)", drv_depth_label_names[l], gu, gvv);
            continue; /* the camera cannot see it (a foot near the camera, a raised hand) */
        }
        if (per_frame) {
            if (res->valid[l])
                printf(" %s %3.0f(%3.0f,%3.0f)", drv_depth_label_names[l],
                       100 * dist3(res->xyz[l], gt), gu, gvv);
            else
                printf(" %s   -(%3.0f,%3.0f)", drv_depth_label_names[l], gu, gvv);
        }
        int kind = l == 0 ? 0 : l <= 2 ? 1 : 2;
        float best = INFINITY, same = INFINITY;
        for (int m = 0; m < 5; m++) {
            int mk = m == 0 ? 0 : m <= 2 ? 1 : 2;
            if (mk != kind || !res->valid[m])
                continue;
            float d = dist3(res->xyz[m], gt);
            if (d < best)
                best = d;
            if (m == l)
                same = d;
        }
        sc->total[kind]++;
        sc->per_label_total[l]++;
        if (best <= 0.10f)
            sc->hit[kind]++;
        if (same <= 0.10f)
            sc->per_label_hit[l]++;
        if (isfinite(best))
            sc->errs[kind][sc->nerr[kind]++] = best;
        if (kind) {
            sc->side_total++;
            if (same <= 0.10f)
                sc->side_ok++;
        }
    }
    if (per_frame) {
        printf(" |");
        for (int e = 0; e < res->nextrema; e++)
            printf(" %s(%d,%d g%.2f)",
                   res->extremum_label[e] >= 0 ? drv_depth_label_names[res->extremum_label[e]]
                                               : "?",
                   res->extremum_px[e][0], res->extremum_px[e][1], res->geodesic[e]);
        printf("\n");
    }
}

/* Prints the summary of nidx frames: one JSON object, or a short table. Sorts sc's arrays. */
static void print_report(const de_args *o, de_scores *sc, int nidx)
{
    double med, p99;
    cli_percentiles(sc->ms, nidx, &med, &p99);
    const char *kinds[3] = {"head", "hand", "foot"};
    double rate[3], e50[3], e90[3], e99[3];
    for (int k = 0; k < 3; k++) {
        rate[k] = sc->total[k] ? (double)sc->hit[k] / sc->total[k] : 0;
        e50[k] = pct(sc->errs[k], sc->nerr[k], 0.5);
        e90[k] = pct(sc->errs[k], sc->nerr[k], 0.9);
        e99[k] = pct(sc->errs[k], sc->nerr[k], 0.99);
    }
    double side = sc->side_total ? (double)sc->side_ok / sc->side_total : 0.0;
    if (!o->json) {
        printf("frames %d at %.2f m, yaw %.1f deg\n", nidx, o->distance, o->yaw_deg);
        for (int k = 0; k < 3; k++)
            printf("  %-5s within 10 cm %.3f   error median %.3f m, p90 %.3f m\n", kinds[k],
                   rate[k], e50[k], e90[k]);
        printf("  side correct %.3f\n  depth->markers %.3f ms median, %.3f ms p99\n", side, med,
               p99);
        return;
    }
    printf("{\"frames\": %d, \"distance\": %.3f, \"yaw\": %.3f, \"travel\": %s, \"within_10cm\": {",
           nidx, o->distance, o->yaw_deg, o->travel ? "true" : "false");
    for (int k = 0; k < 3; k++)
        jnum(kinds[k], rate[k], k < 2);
    printf("}, \"side_correct\": %.4f, \"per_marker_same_side_10cm\": {", side);
    for (int l = 0; l < 5; l++)
        jnum(drv_depth_label_names[l],
             sc->per_label_total[l] ? (double)sc->per_label_hit[l] / sc->per_label_total[l] : NAN,
             l < 4);
    printf("}, \"error_m\": {");
    for (int k = 0; k < 3; k++) {
        printf("\"%s\": {", kinds[k]);
        jnum("median", e50[k], 1);
        jnum("p90", e90[k], 1);
        jnum("p99", e99[k], 1);
        printf("\"found\": %.4f}%s", sc->total[k] ? (double)sc->nerr[k] / sc->total[k] : 0.0,
               k < 2 ? ", " : "");
    }
    printf("}, \"out_of_view\": %d, \"ms_median\": %.4f, \"ms_p99\": %.4f}\n", sc->out_of_view, med,
           p99);
}

/* ------------------------------------------------------------------ the command */

int cmd_depth_eval(int argc, char **argv);

/* Reads the sequence and the rig, places the scene, then per frame: place, render, (dump), track
 * (timed), score; then the report. */
int cmd_depth_eval(int argc, char **argv)
{
    de_args o;
    int status = parse_args(argc, argv, &o);
    if (status >= 0)
        return status;

    char err[MDL_ERR_LEN] = "", derr[DRV_ERR_LEN] = "";
    status = CLI_EXIT_FAIL;
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    int *idx = NULL, nidx = 0, gv[5];
    drv_render *ren = NULL;
    drv_depth_tracker *trk = NULL;
    float *V = NULL;
    uint16_t *depth = NULL;
    FILE *dumpf = NULL;
    de_scores sc = {0};
    de_scene scene;
    if (mdl_meshseq_read(o.mesh, o.rest, &seq, err) || mdl_rig_read(o.rig, seq->nv, &rig, err)) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "%s", err);
        goto done;
    }
    if (mdl_parse_frames(o.frames, seq->frames, &idx, &nidx, err)) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "--frames: %s", err);
        goto done;
    }
    if (nidx < 1) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "--frames %s selects no frame", o.frames);
        goto done;
    }
    if ((status = truth_vertices(rig, o.rig, gv)) ||
        (status = place_scene(seq, idx, nidx, gv, &o, &scene)))
        goto done;
    status = CLI_EXIT_FAIL;
    const int nv = seq->nv;
    const double fps = seq->fps > 0 ? seq->fps : o.fps;

    drv_render_opts ro;
    drv_render_opts_default(&ro);
    ro.cam_height = 1.0f;
    ro.cam_pitch = 2.0f;
    drv_depth_opts to;
    drv_depth_opts_default(&to);
    if (o.step) { /* a fixed grid */
        to.step = o.step;
        to.cell_m = 0;
    }
    to.smooth = o.smooth;
    if (drv_render_create(&ro, nv, &ren, derr) || drv_depth_tracker_create(&to, &trk, derr)) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "%s", derr);
        goto done;
    }
    const size_t npix = (size_t)ro.k.width * ro.k.height;
    V = malloc((size_t)nv * 3 * sizeof *V);
    depth = malloc(npix * sizeof *depth);
    sc.ms = malloc((size_t)nidx * sizeof *sc.ms);
    for (int k = 0; k < 3; k++)
        sc.errs[k] = malloc((size_t)nidx * 2 * sizeof *sc.errs[k]);
    if (!V || !depth || !sc.ms || !sc.errs[0] || !sc.errs[1] || !sc.errs[2]) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "out of memory");
        goto done;
    }
    if (o.dump && !(dumpf = fopen(o.dump, "wb"))) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "%s: %s", o.dump, strerror(errno));
        goto done;
    }
    for (int k = 0; k < nidx; k++) {
        place_frame(&scene, seq->V + (size_t)idx[k] * nv * 3, nv, o.travel, V);
        if (drv_render_frame(ren, V, nv, seq->F, seq->nf, depth, derr)) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "frame %d: %s", idx[k], derr);
            goto done;
        }
        if (dumpf && fwrite(depth, sizeof *depth, npix, dumpf) != npix) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "%s: write failed", o.dump);
            goto done;
        }
        drv_depth_result res;
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        drv_depth_tracker_process(trk, depth, (uint64_t)llround(k * 1e6 / fps), &res);
        clock_gettime(CLOCK_MONOTONIC, &b);
        sc.ms[k] = (double)(b.tv_sec - a.tv_sec) * 1e3 + (double)(b.tv_nsec - a.tv_nsec) * 1e-6;
        if (o.per_frame)
            printf("%4d", idx[k]);
        score_frame(&sc, &res, ren, &ro.k, V, gv, o.per_frame);
    }
    print_report(&o, &sc, nidx);
    status = CLI_EXIT_OK;
done:
    if (dumpf)
        fclose(dumpf);
    for (int k = 0; k < 3; k++)
        free(sc.errs[k]);
    free(sc.ms);
    free(depth);
    free(V);
    drv_depth_tracker_destroy(trk);
    drv_render_destroy(ren);
    free(idx);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    return status;
}
