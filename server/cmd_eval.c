/* cmd_eval.c - `meshsteer eval`: quality against ground truth beside the nearest-frame baseline
 * (DESIGN.md "Quality, measured"); prints one JSON object. */
#include "cli.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>

static const char usage_text[] =
    "usage: meshsteer eval --model MODEL --mesh PATH --frames SPEC [options] --json\n"
    "\n"
    "Drives the model with virtual markers (the rig vertices of the given ground-truth frames)\n"
    "and compares every vertex after best rigid alignment, as a fraction of the rest mesh's\n"
    "bounding-box diagonal, beside the nearest-training-frame baseline.\n"
    "\n"
    "  --model MODEL      the model\n"
    "  --mesh PATH        the ground-truth sequence (OBJ directory, or .pc2 with --rest)\n"
    "  --rest REST.obj    topology for a .pc2 sequence\n"
    "  --frames SPEC      frames to evaluate, a Python slice (e.g. 1:24:2)\n"
    "  --noise MM         Gaussian noise on every marker coordinate, millimetres (default 0)\n"
    "  --drop P           drop each marker in each frame with probability P (default 0)\n"
    "  --seed N           random seed for noise and drops (default 1)\n"
    "  --stretch          a harmonic model: drive it with each correspondence's rotation AND\n"
    "                     stretch (F = R U) measured on the frame, not the rotation alone (beyond\n"
    "                     the paper; the baseline and the oracle get the same; docs/MODEL.md)\n"
    "  --json             print the result as JSON (the only output format)\n";

int cmd_eval(int argc, char **argv)
{
    const char *cmd = "eval", *modelp = NULL, *mesh = NULL, *rest = NULL, *frames = NULL;
    double noise = 0, drop = 0;
    int seed = 1, stretch = 0;
    enum { O_MODEL = 256, O_MESH, O_REST, O_FRAMES, O_NOISE, O_DROP, O_SEED, O_JSON, O_STRETCH };
    static const struct option lo[] = {
        {"model", 1, 0, O_MODEL}, {"mesh", 1, 0, O_MESH},   {"rest", 1, 0, O_REST},
        {"frames", 1, 0, O_FRAMES}, {"noise", 1, 0, O_NOISE}, {"drop", 1, 0, O_DROP},
        {"seed", 1, 0, O_SEED},   {"json", 0, 0, O_JSON},   {"stretch", 0, 0, O_STRETCH},
        {"help", 0, 0, 'h'},
        {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (c) {
        case O_MODEL: modelp = optarg; break;
        case O_MESH: mesh = optarg; break;
        case O_REST: rest = optarg; break;
        case O_FRAMES: frames = optarg; break;
        case O_NOISE: if (cli_parse_double(cmd, "--noise", optarg, &noise)) return CLI_EXIT_USAGE; break;
        case O_DROP: if (cli_parse_double(cmd, "--drop", optarg, &drop)) return CLI_EXIT_USAGE; break;
        case O_SEED: if (cli_parse_int(cmd, "--seed", optarg, &seed)) return CLI_EXIT_USAGE; break;
        case O_JSON: break;
        case O_STRETCH: stretch = 1; break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (!modelp || !mesh || !frames)
        return cli_usage_error(cmd, "--model, --mesh and --frames are required (see --help)");
    if (!(noise >= 0 && noise < 1e6) || !(drop >= 0 && drop <= 1))
        return cli_usage_error(cmd, "--noise must be >= 0 and --drop within 0..1");

    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE, *idx = NULL, n = 0;
    mdl_model *model = NULL;
    mdl_meshseq *seq = NULL;
    mdl_eval_result r = {0};
    if (mdl_model_load(modelp, &model, err) || mdl_meshseq_read(mesh, rest, &seq, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (mdl_parse_frames(frames, seq->frames, &idx, &n, err)) {
        cli_fail(cmd, status, "--frames: %s", err);
        goto out;
    }
    mdl_set_blas_threads(1);
    mdl_eval_opts eo = {noise / 1000.0, drop, (uint64_t)(unsigned)seed, stretch};
    int rc = mdl_eval_run(model, seq, idx, n, &eo, &r, err);
    if (rc) {
        cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
        status = rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE;
        goto out;
    }
    double med, p99;
    cli_percentiles(r.synth_us, r.frames, &med, &p99);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "frames", r.frames);
    cJSON_AddNumberToObject(o, "mean_err", r.mean_err);
    cJSON_AddNumberToObject(o, "p95_err", r.p95_err);
    cJSON_AddNumberToObject(o, "max_err", r.max_err);
    cJSON_AddNumberToObject(o, "marker_err", r.marker_err);
    if (r.rmse > 0) { /* kinds that compute it (skin): root mean square error, mesh units */
        cJSON_AddNumberToObject(o, "rmse", r.rmse);
        cJSON_AddNumberToObject(o, "rmse_over_diag", r.rmse_over_diag);
    }
    cJSON_AddNumberToObject(o, "baseline_nn_mean_err", r.baseline_nn_mean_err);
    cJSON_AddNumberToObject(o, "baseline_nn_p95_err", r.baseline_nn_p95_err);
    if (r.baseline_name) {
        char key[96];
        snprintf(key, sizeof key, "%s_mean_err", r.baseline_name);
        cJSON_AddNumberToObject(o, key, r.baseline_nn_mean_err);
        snprintf(key, sizeof key, "%s_p95_err", r.baseline_name);
        cJSON_AddNumberToObject(o, key, r.baseline_nn_p95_err);
    }
    if (r.mode) { /* the harmonic kind: which inputs drove it, and the floor of that mode */
        cJSON_AddStringToObject(o, "harmonic_mode", r.mode);
        cJSON_AddNumberToObject(o, "oracle_mean_err", r.oracle_mean_err);
    }
    cJSON_AddNumberToObject(o, "ratio_to_baseline",
                            r.baseline_nn_mean_err > 0 ? r.mean_err / r.baseline_nn_mean_err : 0);
    cJSON_AddNumberToObject(o, "synth_us_median", med);
    cJSON_AddNumberToObject(o, "synth_us_p99", p99);
    cJSON_AddNumberToObject(o, "noise_mm", noise);
    cJSON_AddNumberToObject(o, "drop", drop);
    cJSON_AddNumberToObject(o, "seed", seed);
    cJSON_AddNumberToObject(o, "markers_dropped", r.markers_dropped);
    cJSON_AddNumberToObject(o, "frames_skipped", r.frames_skipped);
    cJSON_AddNumberToObject(o, "nan_count", r.nan_count);
    cJSON_AddNumberToObject(o, "max_bbox_excess", r.max_bbox_excess);
    cJSON *pf = cJSON_AddArrayToObject(o, "frame_err");
    cJSON *pb = cJSON_AddArrayToObject(o, "baseline_frame_err");
    for (int i = 0; i < r.frames; i++) {
        cJSON_AddItemToArray(pf, cJSON_CreateNumber(r.frame_err[i]));
        cJSON_AddItemToArray(pb, cJSON_CreateNumber(r.baseline_frame_err[i]));
    }
    if (cli_print_json(o)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
        goto out;
    }
    status = CLI_EXIT_OK;
out:
    mdl_eval_result_fini(&r);
    free(idx);
    mdl_meshseq_destroy(seq);
    mdl_model_destroy(model);
    return status;
}
