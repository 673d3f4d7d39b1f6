/* cmd_synth.c - `meshsteer synth`: drive a model with a marker recording (paper 2012 Sec. 5). */
#include "cli.h"
#include "cli_markers.h"

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
    "'source' names. Invalid samples (occlusion) are held at their last position.\n"
    "\n"
    "  --model MODEL      a model written by 'meshsteer train'\n"
    "  --markers FILE     C3D, TRC, BVH or CSV marker recording\n"
    "  -o, --output FILE  the result as a PC2 point cache (opens in Blender)\n"
    "  --obj-dir DIR      also write every frame as DIR/NNNN.obj\n"
    "  --frames SPEC      which marker frames, a Python slice (default: all)\n" CLI_MARKER_OPTS_HELP;

int cmd_synth(int argc, char **argv)
{
    const char *cmd = "synth", *modelp = NULL, *mk = NULL, *outp = NULL, *objdir = NULL,
               *frames = NULL;
    mdl_marker_opts mo = {0, MDL_UP_AUTO};
    enum { O_MODEL = 256, O_MARKERS, O_OBJDIR, O_FRAMES, O_MSCALE, O_MUP };
    static const struct option lo[] = {
        {"model", 1, 0, O_MODEL},   {"markers", 1, 0, O_MARKERS},     {"output", 1, 0, 'o'},
        {"obj-dir", 1, 0, O_OBJDIR}, {"frames", 1, 0, O_FRAMES},      {"marker-scale", 1, 0, O_MSCALE},
        {"marker-up", 1, 0, O_MUP}, {"help", 0, 0, 'h'},              {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:h", lo, NULL)) != -1) {
        switch (c) {
        case O_MODEL: modelp = optarg; break;
        case O_MARKERS: mk = optarg; break;
        case 'o': outp = optarg; break;
        case O_OBJDIR: objdir = optarg; break;
        case O_FRAMES: frames = optarg; break;
        case O_MSCALE: if (cli_parse_double(cmd, "--marker-scale", optarg, &mo.scale)) return CLI_EXIT_USAGE; break;
        case O_MUP:
            if ((mo.up = cli_parse_up(optarg)) < 0)
                return cli_usage_error(cmd, "--marker-up: '%s' is not one of x y z -x -y -z", optarg);
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
    int status = CLI_EXIT_USAGE, *idx = NULL, n = 0, *map = NULL;
    mdl_model *model = NULL;
    mdl_markers *markers = NULL;
    mdl_synth *s = NULL;
    float *out = NULL, *P = NULL;
    uint8_t *valid = NULL;
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
    if (!map || !P || !valid || !out || !times) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
        goto out;
    }
    if (mdl_model_bind_markers(model, (const char *const *)markers->names, markers->count, map) > 0) {
        for (int i = 0; i < info.nmarkers; i++)
            if (map[i] < 0)
                cli_fail(cmd, status, "%s has no marker '%s' (wanted by rig marker '%s')", mk,
                         info.markers[i].source, info.markers[i].name);
        goto out;
    }
    if (mdl_synth_create(model, &s, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    long missing = 0, held = 0, lost = 0;
    int first = -1;
    for (int i = 0; i < n; i++) {
        int f = idx[i];
        for (int j = 0; j < info.nmarkers; j++) {
            size_t k = (size_t)f * markers->count + map[j];
            memcpy(P + 3 * j, markers->P + 3 * k, 3 * sizeof(float));
            valid[j] = markers->valid[k];
        }
        mdl_synth_info si;
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        int r = mdl_synth_frame(s, P, valid, out + (size_t)i * info.nv * 3, &si);
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
        cli_progress((void *)"synth", "frames", (double)(i + 1) / n);
    }
    cli_progress_done();
    if (first < 0) {
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
    fprintf(stderr,
            "meshsteer synth: %s: %d frames of %d vertices; %.1f us/frame median, %.1f p99; "
            "%ld missing marker samples (%ld held), %ld frames without reference edge\n",
            outp, n, info.nv, med, p99, missing, held, lost);
    status = CLI_EXIT_OK;
out:
    mdl_synth_destroy(s);
    mdl_model_destroy(model);
    mdl_markers_destroy(markers);
    free(idx);
    free(map);
    free(P);
    free(valid);
    free(out);
    free(times);
    return status;
}
