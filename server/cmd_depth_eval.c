/* cmd_depth_eval.c - `meshsteer depth-eval`: renders a mesh sequence with the test camera
 * (drivers/depth/render.h), runs depth -> markers (drivers/depth/depth.h) on every frame and
 * compares the extracted head/hands/feet with the rig's ground-truth vertices.
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

#include "depth/depth.h"
#include "depth/render.h"

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

int cmd_depth_eval(int argc, char **argv);

int cmd_depth_eval(int argc, char **argv)
{
    const char *mesh = NULL, *rest = NULL, *rigp = NULL, *frames = ":";
    double distance = 2.5, yaw_deg = 0, fps_opt = 30;
    int json = 0, smooth = 1, step = 0, travel = 0, per_frame = 0;
    const char *dump = NULL;
    FILE *dumpf = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            help();
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--no-smooth")) {
            smooth = 0;
        } else if (!strcmp(a, "--travel")) {
            travel = 1;
        } else if (!strcmp(a, "--per-frame")) {
            per_frame = 1;
        } else if (!v) {
            return cli_usage_error(CMD, "unknown option or missing value: %s", a);
        } else if (!strcmp(a, "--mesh")) {
            mesh = v, i++;
        } else if (!strcmp(a, "--dump-depth")) {
            dump = v, i++;
        } else if (!strcmp(a, "--rest")) {
            rest = v, i++;
        } else if (!strcmp(a, "--rig")) {
            rigp = v, i++;
        } else if (!strcmp(a, "--frames")) {
            frames = v, i++;
        } else if (!strcmp(a, "--distance")) {
            if (cli_parse_double(CMD, a, v, &distance))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--yaw")) {
            if (cli_parse_double(CMD, a, v, &yaw_deg))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--fps")) {
            if (cli_parse_double(CMD, a, v, &fps_opt))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--step")) {
            if (cli_parse_int(CMD, a, v, &step))
                return CLI_EXIT_USAGE;
            i++;
        } else {
            return cli_usage_error(CMD, "unknown option %s", a);
        }
    }
    if (!mesh || !rigp)
        return cli_usage_error(CMD, "--mesh and --rig are required (see --help)");
    if (!(distance >= 0.8 && distance <= 4.5))
        return cli_usage_error(CMD, "--distance %g: the Kinect sees 0.8 .. 4.5 m", distance);
    if (!(fps_opt > 0 && fps_opt <= 1000))
        return cli_usage_error(CMD, "--fps %g: must be in (0, 1000]", fps_opt);
    if (step && (step < 1 || step > 16))
        return cli_usage_error(CMD, "--step %d: must be 1 .. 16", step);

    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_FAIL;
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    int *idx = NULL, nidx = 0;
    drv_render *ren = NULL;
    drv_depth_tracker *trk = NULL;
    float *V = NULL;
    uint16_t *depth = NULL;
    double *ms = NULL, *errs[3] = {NULL, NULL, NULL};
    int r = mdl_meshseq_read(mesh, rest, &seq, err);
    if (r) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "%s", err);
        goto done;
    }
    if ((r = mdl_rig_read(rigp, seq->nv, &rig, err))) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "%s", err);
        goto done;
    }
    if ((r = mdl_parse_frames(frames, seq->frames, &idx, &nidx, err))) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "--frames: %s", err);
        goto done;
    }
    if (nidx < 1) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "--frames %s selects no frame", frames);
        goto done;
    }
    /* ground-truth vertices: head, lhand, rhand, lfoot, rfoot (the tracker's label order) */
    int gv[5];
    for (int l = 0; l < 5; l++) {
        gv[l] = -1;
        for (int m = 0; m < rig->nmarkers; m++)
            if (!strcmp(rig->markers[m].name, drv_depth_label_names[l]))
                gv[l] = rig->markers[m].vertex;
        if (gv[l] < 0) {
            status = cli_fail(CMD, CLI_EXIT_USAGE, "%s: no marker named '%s'", rigp,
                              drv_depth_label_names[l]);
            goto done;
        }
    }
    const int nv = seq->nv;
    double fps = seq->fps > 0 ? seq->fps : fps_opt;
    /* scene: floor, facing, pivot */
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
    if (fx * fx + fz * fz < 1e-12) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "%s: left and right markers coincide", rigp);
        goto done;
    }
    float yaw = (float)(atan2(-fx, fz) + yaw_deg * M_PI / 180.0);
    float t[3] = {(float)-px, -floor_y, (float)(-distance - pz)};
    float cy = cosf(yaw), sy = sinf(yaw);

    drv_render_opts ro;
    drv_render_opts_default(&ro);
    ro.cam_height = 1.0f;
    ro.cam_pitch = 2.0f;
    drv_depth_opts to;
    drv_depth_opts_default(&to);
    if (step) { /* a fixed grid */
        to.step = step;
        to.cell_m = 0;
    }
    to.smooth = smooth;
    char derr[DRV_ERR_LEN] = "";
    if ((r = drv_render_create(&ro, nv, &ren, derr)) ||
        (r = drv_depth_tracker_create(&to, &trk, derr))) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "%s", derr);
        goto done;
    }
    V = malloc((size_t)nv * 3 * sizeof *V);
    depth = malloc((size_t)ro.k.width * ro.k.height * sizeof *depth);
    ms = malloc((size_t)nidx * sizeof *ms);
    for (int k = 0; k < 3; k++)
        errs[k] = malloc((size_t)nidx * 2 * sizeof *errs[k]);
    if (!V || !depth || !ms || !errs[0] || !errs[1] || !errs[2]) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "out of memory");
        goto done;
    }
    int hit[3] = {0, 0, 0}, total[3] = {0, 0, 0}, side_ok = 0, side_total = 0, nerr[3] = {0, 0, 0};
    int per_label_hit[5] = {0}, per_label_total[5] = {0}, out_of_view = 0;
    for (int k = 0; k < nidx; k++) {
        const float *Vf = seq->V + (size_t)idx[k] * nv * 3;
        drv_render_place(Vf, nv, yaw, (float)px, (float)pz, t, V);
        if (!travel) { /* hold this frame's centroid at `distance`, keep sideways travel */
            double sx = 0, sz = 0;
            for (int i = 0; i < nv; i++) {
                sx += Vf[3 * i] - px;
                sz += Vf[3 * i + 2] - pz;
            }
            float dz = (float)(-sy * sx / nv + cy * sz / nv); /* its offset along the axis */
            for (int i = 0; i < nv; i++)
                V[3 * i + 2] -= dz;
        }
        if ((r = drv_render_frame(ren, V, nv, seq->F, seq->nf, depth, derr))) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "frame %d: %s", idx[k], derr);
            goto done;
        }
        if (dump && !dumpf && !(dumpf = fopen(dump, "wb"))) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "%s: %s", dump, strerror(errno));
            goto done;
        }
        if (dumpf && fwrite(depth, sizeof *depth, (size_t)ro.k.width * ro.k.height, dumpf) !=
                         (size_t)ro.k.width * ro.k.height) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "%s: write failed", dump);
            goto done;
        }
        drv_depth_result res;
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        drv_depth_tracker_process(trk, depth, (uint64_t)llround(k * 1e6 / fps), &res);
        clock_gettime(CLOCK_MONOTONIC, &b);
        ms[k] = (double)(b.tv_sec - a.tv_sec) * 1e3 + (double)(b.tv_nsec - a.tv_nsec) * 1e-6;
        if (per_frame)
            printf("%4d", idx[k]);
        for (int l = 0; l < 5; l++) {
            float gt[3];
            drv_render_world_to_camera(ren, V + 3 * gv[l], gt);
            double gu, gvv;
            if (drv_intrinsics_project(&ro.k, gt, &gu, &gvv) || gu < 4 || gvv < 4 ||
                gu > ro.k.width - 5 || gvv > ro.k.height - 5) {
                out_of_view++;
                if (per_frame)
                    printf(" %s o(%3.0f,%3.0f)", drv_depth_label_names[l], gu, gvv);
                continue; /* the camera cannot see it (a foot near the camera, a raised hand) */
            }
            if (per_frame) {
                if (res.valid[l])
                    printf(" %s %3.0f(%3.0f,%3.0f)", drv_depth_label_names[l],
                           100 * dist3(res.xyz[l], gt), gu, gvv);
                else
                    printf(" %s   -(%3.0f,%3.0f)", drv_depth_label_names[l], gu, gvv);
            }
            int kind = l == 0 ? 0 : l <= 2 ? 1 : 2;
            float best = INFINITY, same = INFINITY;
            for (int m = 0; m < 5; m++) {
                int mk = m == 0 ? 0 : m <= 2 ? 1 : 2;
                if (mk != kind || !res.valid[m])
                    continue;
                float d = dist3(res.xyz[m], gt);
                if (d < best)
                    best = d;
                if (m == l)
                    same = d;
            }
            total[kind]++;
            per_label_total[l]++;
            if (best <= 0.10f)
                hit[kind]++;
            if (same <= 0.10f)
                per_label_hit[l]++;
            if (isfinite(best))
                errs[kind][nerr[kind]++] = best;
            if (kind) {
                side_total++;
                if (same <= 0.10f)
                    side_ok++;
            }
        }
        if (per_frame) {
            printf(" |");
            for (int e = 0; e < res.nextrema; e++)
                printf(" %s(%d,%d g%.2f)",
                       res.extremum_label[e] >= 0 ? drv_depth_label_names[res.extremum_label[e]]
                                                  : "?",
                       res.extremum_px[e][0], res.extremum_px[e][1], res.geodesic[e]);
            printf("\n");
        }
    }
    double med, p99;
    cli_percentiles(ms, nidx, &med, &p99);
    const char *kinds[3] = {"head", "hand", "foot"};
    double rate[3], e50[3], e90[3], e99[3];
    for (int k = 0; k < 3; k++) {
        rate[k] = total[k] ? (double)hit[k] / total[k] : 0;
        e50[k] = pct(errs[k], nerr[k], 0.5);
        e90[k] = pct(errs[k], nerr[k], 0.9);
        e99[k] = pct(errs[k], nerr[k], 0.99);
    }
    if (json) {
        printf("{\"frames\": %d, \"distance\": %.3f, \"yaw\": %.3f, \"travel\": %s, \"within_10cm\": {",
               nidx, distance, yaw_deg, travel ? "true" : "false");
        for (int k = 0; k < 3; k++)
            jnum(kinds[k], rate[k], k < 2);
        printf("}, \"side_correct\": %.4f, \"per_marker_same_side_10cm\": {",
               side_total ? (double)side_ok / side_total : 0.0);
        for (int l = 0; l < 5; l++)
            jnum(drv_depth_label_names[l],
                 per_label_total[l] ? (double)per_label_hit[l] / per_label_total[l] : NAN, l < 4);
        printf("}, \"error_m\": {");
        for (int k = 0; k < 3; k++) {
            printf("\"%s\": {", kinds[k]);
            jnum("median", e50[k], 1);
            jnum("p90", e90[k], 1);
            jnum("p99", e99[k], 1);
            printf("\"found\": %.4f}%s", total[k] ? (double)nerr[k] / total[k] : 0.0,
                   k < 2 ? ", " : "");
        }
        printf("}, \"out_of_view\": %d, \"ms_median\": %.4f, \"ms_p99\": %.4f}\n", out_of_view, med,
               p99);
    } else {
        printf("frames %d at %.2f m, yaw %.1f deg\n", nidx, distance, yaw_deg);
        for (int k = 0; k < 3; k++)
            printf("  %-5s within 10 cm %.3f   error median %.3f m, p90 %.3f m\n", kinds[k],
                   rate[k], e50[k], e90[k]);
        printf("  side correct %.3f\n  depth->markers %.3f ms median, %.3f ms p99\n",
               side_total ? (double)side_ok / side_total : 0.0, med, p99);
    }
    status = CLI_EXIT_OK;
done:
    if (dumpf)
        fclose(dumpf);
    for (int k = 0; k < 3; k++)
        free(errs[k]);
    free(ms);
    free(depth);
    free(V);
    drv_depth_tracker_destroy(trk);
    drv_render_destroy(ren);
    free(idx);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    return status;
}
