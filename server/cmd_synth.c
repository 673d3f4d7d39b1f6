/* cmd_synth.c - `meshsteer synth`: drive a model with a marker recording (paper 2012 Sec. 5). */
#include "cli.h"
#include "cli_markers.h"
#include "labels.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const char usage_text[] =
    "usage: meshsteer synth --model MODEL --markers FILE -o OUT.pc2 [options]\n"
    "\n"
    "Synthesises one mesh per marker frame. Markers are matched to the model by the rig's\n"
    "'source' names (or through --labels). Invalid samples (occlusion) are held at their last\n"
    "position.\n"
    "\n"
    "  --model MODEL      a model written by 'meshsteer train'\n"
    "  --markers FILE     C3D, TRC, BVH, ASF/AMC or CSV marker recording\n"
    "  -o, --output FILE  the result as a PC2 point cache (opens in Blender)\n"
    "  --obj-dir DIR      also write every frame as DIR/NNNN.obj\n"
    "  --frames SPEC      which marker frames, a Python slice (default: all)\n"
    "  --labels MAP       drive the model with other labels: MODEL=LABEL[,MODEL=LABEL...] maps\n"
    "                     the rig's 'source' label MODEL to the file's marker LABEL (one LABEL\n"
    "                     may feed several); labels not in the map match by their own name\n"
    "  --json             print statistics as JSON on stdout: timing, missing markers, output and\n"
    "                     input speed per frame, jitter, bounding box, non-finite values, bones\n"
    "                     driven by joint rotations\n"
    "  --no-joints        a harmonic model built with --fit-rest and driven by a BVH or ASF/AMC\n"
    "                     file: ignore the file's joint rotations (used only with the fit) and\n"
    "                     take each bone's rotation from its markers'\n"
    "                     directions, as for a marker-only source (the twist about a bone without\n"
    "                     a twist marker is lost; docs/MODEL.md)\n" CLI_MARKER_OPTS_HELP;

/* Motion statistics: mean per-frame displacement of the output vertices against that of the
 * input markers, and jitter = mean |speed(f) - speed(f-1)| / mean speed, for both. */
static void speeds(const float *P, int stride, const int *sel, int nsel, int frames,
                   const uint8_t *valid, int vstride, double *sp)
{
    for (int f = 1; f < frames; f++) {
        double sum = 0;
        int cnt = 0;
        for (int i = 0; i < nsel; i++) {
            int k = sel ? sel[i] : i;
            if (valid && (!valid[(size_t)f * vstride + k] || !valid[(size_t)(f - 1) * vstride + k]))
                continue;
            const float *a = P + ((size_t)f * stride + k) * 3, *b = a - (size_t)stride * 3;
            sum += sqrt((double)(a[0] - b[0]) * (a[0] - b[0]) + (double)(a[1] - b[1]) * (a[1] - b[1]) +
                        (double)(a[2] - b[2]) * (a[2] - b[2]));
            cnt++;
        }
        sp[f - 1] = cnt ? sum / cnt : 0;
    }
}

static double jitter(const double *sp, int n)
{
    double ds = 0, s = 0;
    for (int i = 0; i < n; i++) {
        s += sp[i];
        if (i)
            ds += fabs(sp[i] - sp[i - 1]);
    }
    return s > 0 ? (ds / (n > 1 ? n - 1 : 1)) / (s / n) : 0;
}

static int print_stats(const float *out, int nv, const mdl_markers *mk, const int *idx, int n,
                       const int *map, int nmap, double med, double p99, long missing, long held,
                       long lost, int joint_bones)
{
    /* the input markers of the selected frames, contiguous */
    float *in = malloc(sizeof(float) * 3 * (size_t)n * nmap);
    uint8_t *iv = malloc((size_t)n * nmap);
    double *so = malloc(sizeof(double) * (size_t)(n > 1 ? n : 2));
    double *si = malloc(sizeof(double) * (size_t)(n > 1 ? n : 2));
    if (!in || !iv || !so || !si) {
        free(in);
        free(iv);
        free(so);
        free(si);
        return -1;
    }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < nmap; j++) {
            if (map[j] < 0) { /* not in the file: never valid */
                memset(in + ((size_t)i * nmap + j) * 3, 0, 3 * sizeof(float));
                iv[(size_t)i * nmap + j] = 0;
                continue;
            }
            size_t k = (size_t)idx[i] * mk->count + map[j];
            memcpy(in + ((size_t)i * nmap + j) * 3, mk->P + 3 * k, 3 * sizeof(float));
            iv[(size_t)i * nmap + j] = mk->valid[k];
        }
    speeds(out, nv, NULL, nv, n, NULL, 0, so);
    speeds(in, nmap, NULL, nmap, n, iv, nmap, si);
    long nonfinite = 0;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < (size_t)n * nv * 3; i++) {
        if (!isfinite(out[i])) {
            nonfinite++;
            continue;
        }
        lo[i % 3] = fminf(lo[i % 3], out[i]);
        hi[i % 3] = fmaxf(hi[i % 3], out[i]);
    }
    int ns = n > 1 ? n - 1 : 0;
    double jo = jitter(so, ns), ji = jitter(si, ns), om, op, im, ip;
    cli_percentiles(so, ns, &om, &op);
    cli_percentiles(si, ns, &im, &ip);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "frames", n);
    cJSON_AddNumberToObject(o, "synth_us_median", med);
    cJSON_AddNumberToObject(o, "synth_us_p99", p99);
    cJSON_AddNumberToObject(o, "missing_marker_samples", (double)missing);
    cJSON_AddNumberToObject(o, "held_marker_samples", (double)held);
    cJSON_AddNumberToObject(o, "frames_without_reference", (double)lost);
    cJSON_AddNumberToObject(o, "nonfinite", (double)nonfinite);
    cJSON_AddNumberToObject(o, "joint_bones", joint_bones);
    cJSON_AddNumberToObject(o, "output_speed_median", om);
    cJSON_AddNumberToObject(o, "output_speed_p99", op);
    cJSON_AddNumberToObject(o, "input_speed_median", im);
    cJSON_AddNumberToObject(o, "input_speed_p99", ip);
    cJSON_AddNumberToObject(o, "output_jitter", jo);
    cJSON_AddNumberToObject(o, "input_jitter", ji);
    cJSON *bl = cJSON_AddArrayToObject(o, "bbox_min"), *bh = cJSON_AddArrayToObject(o, "bbox_max");
    for (int k = 0; k < 3; k++) {
        cJSON_AddItemToArray(bl, cJSON_CreateNumber(lo[k]));
        cJSON_AddItemToArray(bh, cJSON_CreateNumber(hi[k]));
    }
    int r = cli_print_json(o);
    free(in);
    free(iv);
    free(so);
    free(si);
    return r ? -1 : 0;
}

static void warn_labels(void *ud, const char *msg)
{
    (void)ud;
    fprintf(stderr, "meshsteer synth: warning: --labels: %s\n", msg);
}

int cmd_synth(int argc, char **argv)
{
    const char *cmd = "synth", *modelp = NULL, *mk = NULL, *outp = NULL, *objdir = NULL,
               *frames = NULL;
    mdl_marker_opts mo = {0, MDL_UP_AUTO, 0};
    enum { O_MODEL = 256, O_MARKERS, O_OBJDIR, O_FRAMES, O_MSCALE, O_MUP, O_JSON, O_LABELS, O_NOJ };
    int json = 0, nojoints = 0;
    static const struct option lo[] = {
        {"model", 1, 0, O_MODEL},   {"markers", 1, 0, O_MARKERS},     {"output", 1, 0, 'o'},
        {"obj-dir", 1, 0, O_OBJDIR}, {"frames", 1, 0, O_FRAMES},      {"marker-scale", 1, 0, O_MSCALE},
        {"marker-up", 1, 0, O_MUP}, {"json", 0, 0, O_JSON}, {"labels", 1, 0, O_LABELS},
        {"no-joints", 0, 0, O_NOJ},
        {"help", 0, 0, 'h'}, {0, 0, 0, 0}};
    const char *labels = NULL;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:h", lo, NULL)) != -1) {
        switch (c) {
        case O_MODEL: modelp = optarg; break;
        case O_MARKERS: mk = optarg; break;
        case 'o': outp = optarg; break;
        case O_OBJDIR: objdir = optarg; break;
        case O_FRAMES: frames = optarg; break;
        case O_JSON: json = 1; break;
        case O_LABELS: labels = optarg; break;
        case O_NOJ: nojoints = 1; break;
        case O_MSCALE:
        case O_MUP:
            if (cli_marker_option(cmd, c == O_MSCALE ? "marker-scale" : "marker-up", optarg, &mo))
                return CLI_EXIT_USAGE;
            break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (!modelp || !mk || !outp)
        return cli_usage_error(cmd, "--model, --markers and -o are required (see --help)");

    char err[MDL_ERR_LEN] = "";
    srv_labels *lmap = NULL;
    if (labels && srv_labels_create(labels, &lmap, err))
        return cli_usage_error(cmd, "--labels: %s", err);
    int status = CLI_EXIT_USAGE, *idx = NULL, n = 0, *map = NULL;
    mdl_model *model = NULL;
    mdl_markers *markers = NULL;
    mdl_synth *s = NULL;
    float *out = NULL, *P = NULL, *J = NULL;
    uint8_t *valid = NULL, *jvalid = NULL;
    double *times = NULL;
    if (mdl_model_load(modelp, &model, err) || mdl_markers_read(mk, &mo, &markers, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (mdl_parse_frames(frames ? frames : ":", markers->frames, &idx, &n, err)) {
        cli_fail(cmd, status, "--frames: %s", err);
        goto out;
    }
    mdl_model_info info;
    mdl_model_get_info(model, &info);
    map = calloc((size_t)info.nmarkers, sizeof *map);
    P = calloc((size_t)info.nmarkers * 3, sizeof *P);
    valid = calloc((size_t)info.nmarkers, 1);
    out = calloc((size_t)n * info.nv * 3, sizeof *out);
    times = calloc((size_t)n, sizeof *times);
    J = calloc((size_t)info.nmarkers * 4 + 4, sizeof *J);
    jvalid = calloc((size_t)info.nmarkers + 1, 1);
    if (!map || !P || !valid || !out || !times || !J || !jvalid) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
        goto out;
    }
    /* markers the file lacks count as missing in every frame (as in meshsteerd); none bound, or
     * no reference edge in any frame (below), is an error */
    int unbound = srv_labels_bind(lmap, &info, (const char *const *)markers->names,
                                  markers->count, map, warn_labels, NULL);
    if (unbound < 0) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "binding the markers: %s", strerror(-unbound));
        goto out;
    }
    for (int i = 0; i < info.nmarkers; i++)
        if (map[i] < 0)
            fprintf(stderr, "meshsteer synth: %s%s has no marker '%s' (wanted by rig marker '%s')%s\n",
                    unbound == info.nmarkers ? "" : "warning: ", mk,
                    srv_labels_lookup(lmap, info.markers[i].source), info.markers[i].name,
                    unbound == info.nmarkers ? "" : "; it counts as missing in every frame");
    if (unbound == info.nmarkers) {
        cli_fail(cmd, status,
                 "%s: none of the model's %d markers is among the file's %d markers: map the "
                 "rig's 'source' labels to the file's with --labels MODEL=LABEL,... (README, "
                 "'Driving a model with other labels')", mk, info.nmarkers, markers->count);
        goto out;
    }
    if (mdl_synth_create(model, 0, &s, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    long missing = 0, held = 0, lost = 0;
    int first = -1, joint_bones = 0;
    /* a skeleton file's joint rotations (model marker i: the segment ending at it), for a kind
     * that reads them */
    int joints = !nojoints && markers->rot && (mdl_synth_inputs(s) & MDL_INPUT_JOINTS);
    for (int i = 0; i < n; i++) {
        int f = idx[i];
        for (int j = 0; j < info.nmarkers; j++) {
            if (map[j] < 0) {
                memset(P + 3 * j, 0, 3 * sizeof(float));
                valid[j] = 0;
                continue;
            }
            size_t k = (size_t)f * markers->count + map[j];
            memcpy(P + 3 * j, markers->P + 3 * k, 3 * sizeof(float));
            valid[j] = markers->valid[k];
            if (joints)
                memcpy(J + 4 * j, markers->rot + 4 * k, 4 * sizeof(float));
        }
        for (int j = 0; j < info.nmarkers; j++)
            jvalid[j] = valid[j];
        mdl_synth_input in = {.markers = P, .valid = valid};
        if (joints)
            in.njoints = info.nmarkers, in.joint_rot = J, in.joint_valid = jvalid;
        mdl_synth_info si;
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        int r = mdl_synth_frame(s, &in, out + (size_t)i * info.nv * 3, &si);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        times[i] = 1e6 * (double)(t1.tv_sec - t0.tv_sec) + 1e-3 * (double)(t1.tv_nsec - t0.tv_nsec);
        if (r == -EAGAIN) { /* no reference edge yet: fill with the rest pose later */
            lost++;
            continue;
        }
        if (first < 0)
            first = i;
        missing += si.markers_missing;
        held += si.markers_held;
        lost += si.reference_lost;
        joint_bones = si.joints_used > joint_bones ? si.joints_used : joint_bones;
        cli_progress((void *)"synth", "frames", (double)(i + 1) / n);
    }
    cli_progress_done();
    if (first < 0) {
        if (unbound)
            status = cli_fail(cmd, CLI_EXIT_USAGE,
                              "%s: the reference markers are never valid (%d of the model's %d "
                              "markers are not in the file: map the rig's 'source' labels to the "
                              "file's with --labels MODEL=LABEL,...; README, 'Driving a model "
                              "with other labels')", mk, unbound, info.nmarkers);
        else
            status = cli_fail(cmd, CLI_EXIT_USAGE, "%s: the reference markers are never valid", mk);
        goto out;
    }
    for (int i = 0; i < first; i++) /* frames before the reference appeared: the first result */
        memcpy(out + (size_t)i * info.nv * 3, out + (size_t)first * info.nv * 3,
               sizeof(float) * 3 * (size_t)info.nv);
    if (mdl_pc2_write(outp, out, info.nv, n, 0.0f, 1.0f, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    if (objdir) {
        mdl_meshseq seq = {info.nv, info.nf, n, markers->fps, out, (uint32_t *)info.F};
        if (mdl_meshseq_write_objdir(objdir, &seq, err)) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
            goto out;
        }
    }
    double med, p99;
    cli_percentiles(times, n, &med, &p99);
    if (json && print_stats(out, info.nv, markers, idx, n, map, info.nmarkers, med, p99, missing,
                            held, lost, joint_bones)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
        goto out;
    }
    fprintf(stderr,
            "meshsteer synth: %s: %d frames of %d vertices; %.1f us/frame median, %.1f p99; "
            "%ld missing marker samples (%ld held), %ld frames without reference edge%s\n",
            outp, n, info.nv, med, p99, missing, held, lost,
            joint_bones ? "; bones driven by the file's joint rotations" : "");
    status = CLI_EXIT_OK;
out:
    srv_labels_destroy(lmap);
    mdl_synth_destroy(s);
    mdl_model_destroy(model);
    mdl_markers_destroy(markers);
    free(idx);
    free(map);
    free(P);
    free(valid);
    free(J);
    free(jvalid);
    free(out);
    free(times);
    return status;
}
