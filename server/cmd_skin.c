/* cmd_skin.c - `meshsteer skin`: a skinning decomposition (SSDR, Le & Deng 2012; model.h "the
 * skin") of any mesh animation: a model file holding the skin kind, optionally beside an existing
 * model (--add-to), and a glTF 2.0 binary (--gltf).
 *
 * The threads live here (model/ creates none, STYLE.md Sec. 1): cli_parallel_for (cli_parallel.c)
 * is handed to mdl_skin_fit; the model splits its work into blocks whose results do not depend on
 * the thread that runs them, so the output is identical for every --threads. */
#include "cli.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char usage_text[] =
    "usage: meshsteer skin --mesh SEQ [--rest REST.obj] --bones N [options] -o SKIN.msm\n"
    "\n"
    "Decomposes a mesh animation into a linear blend skin with rigid bones (SSDR, Le & Deng\n"
    "2012): N bone transforms per frame and per-vertex weights that are non-negative, sum to 1\n"
    "and have at most K non-zeros. The model file holds it as the 'skin' kind.\n"
    "\n"
    "  --mesh SEQ            OBJ directory, or .pc2 with --rest\n"
    "  --rest REST.obj       topology (and rest pose) for a .pc2; for an OBJ directory the rest\n"
    "                        pose (default: the first fitted frame)\n"
    "  --bones N             number of bones (required)\n"
    "  --max-influences K    non-zero weights per vertex at most (default 4)\n"
    "  --frames SPEC         frames to fit, a Python slice (default all)\n"
    "  --iterations N        alternations at most (default 100)\n"
    "  --tolerance F         stop when the RMSE improves by less than F (relative) 3 times in a\n"
    "                        row (default 1e-3)\n"
    "  --smooth F            weight smoothness over mesh edges (default 0, off)\n"
    "  --threads T           worker threads (default: online CPUs); results do not depend on it\n"
    "  --seed N              recorded; the fit is deterministic\n"
    "  -o SKIN.msm           the model file to write\n"
    "  --add-to MODEL.msm    put the skin beside the kinds of an existing model over the same\n"
    "                        mesh and write the result to -o (default: MODEL.msm itself)\n"
    "  --gltf OUT.glb        also write a glTF 2.0 binary (needs K <= 4); its clip ends with\n"
    "                        frame 0 again at N / fps, so that an engine looping it plays the\n"
    "                        skin's own loop without a jump\n"
    "  --gltf-once           the clip ends at frame N - 1 instead (a clip played once)\n"
    "  --name NAME           model name (default 'skin')\n"
    "  --json                print bones, max_influences, frames, vertices, rmse, rmse_over_diag,\n"
    "                        max_err, seconds, threads as one JSON object\n";


int cmd_skin(int argc, char **argv)
{
    const char *cmd = "skin", *mesh = NULL, *rest = NULL, *frames = NULL, *outp = NULL,
               *addto = NULL, *gltf = NULL, *name = NULL;
    int json = 0, threads = (int)sysconf(_SC_NPROCESSORS_ONLN), seed = 1, gltf_once = 0;
    mdl_skin_opts so;
    mdl_skin_opts_default(&so);
    so.bones = 0;
    enum { O_MESH = 256, O_REST, O_BONES, O_K, O_FRAMES, O_ITER, O_TOL, O_SMOOTH, O_THREADS,
           O_SEED, O_ADD, O_GLTF, O_GLTF_ONCE, O_NAME, O_JSON };
    static const struct option lo[] = {
        {"mesh", 1, 0, O_MESH},         {"rest", 1, 0, O_REST},       {"bones", 1, 0, O_BONES},
        {"max-influences", 1, 0, O_K},  {"frames", 1, 0, O_FRAMES},   {"iterations", 1, 0, O_ITER},
        {"tolerance", 1, 0, O_TOL},     {"smooth", 1, 0, O_SMOOTH},   {"threads", 1, 0, O_THREADS},
        {"seed", 1, 0, O_SEED},         {"add-to", 1, 0, O_ADD},      {"gltf", 1, 0, O_GLTF},
        {"name", 1, 0, O_NAME},         {"json", 0, 0, O_JSON},       {"help", 0, 0, 'h'},
        {"gltf-once", 0, 0, O_GLTF_ONCE}, {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "ho:", lo, NULL)) != -1) {
        switch (c) {
        case O_MESH: mesh = optarg; break;
        case O_REST: rest = optarg; break;
        case O_BONES: if (cli_parse_int(cmd, "--bones", optarg, &so.bones)) return CLI_EXIT_USAGE; break;
        case O_K: if (cli_parse_int(cmd, "--max-influences", optarg, &so.max_influences)) return CLI_EXIT_USAGE; break;
        case O_FRAMES: frames = optarg; break;
        case O_ITER: if (cli_parse_int(cmd, "--iterations", optarg, &so.iterations)) return CLI_EXIT_USAGE; break;
        case O_TOL: if (cli_parse_double(cmd, "--tolerance", optarg, &so.tolerance)) return CLI_EXIT_USAGE; break;
        case O_SMOOTH: if (cli_parse_double(cmd, "--smooth", optarg, &so.smooth)) return CLI_EXIT_USAGE; break;
        case O_THREADS: if (cli_parse_int(cmd, "--threads", optarg, &threads)) return CLI_EXIT_USAGE; break;
        case O_SEED: if (cli_parse_int(cmd, "--seed", optarg, &seed)) return CLI_EXIT_USAGE; break;
        case O_ADD: addto = optarg; break;
        case O_GLTF: gltf = optarg; break;
        case O_GLTF_ONCE: gltf_once = 1; break;
        case O_NAME: name = optarg; break;
        case O_JSON: json = 1; break;
        case 'o': outp = optarg; break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (!mesh || so.bones <= 0 || (!outp && !addto))
        return cli_usage_error(cmd, "--mesh, --bones (> 0) and -o (or --add-to) are required "
                               "(see --help)");
    if (so.max_influences < 1 || so.max_influences > 64)
        return cli_usage_error(cmd, "--max-influences must be within 1..64");
    if (gltf && so.max_influences > 4)
        return cli_usage_error(cmd, "--gltf needs --max-influences 4 or less (JOINTS_0/WEIGHTS_0)");
    if (so.iterations < 0 || !(so.tolerance >= 0) || !(so.smooth >= 0))
        return cli_usage_error(cmd, "--iterations, --tolerance and --smooth must be >= 0");
    if (threads < 1 || threads > 64)
        return cli_usage_error(cmd, "--threads must be within 1..64");
    if (!outp)
        outp = addto;

    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE, *idx = NULL, n = 0;
    mdl_meshseq *seq = NULL;
    mdl_mesh *restm = NULL;
    mdl_model *model = NULL, *dst = NULL;
    if (mdl_meshseq_read(mesh, rest, &seq, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (rest) {
        if (mdl_mesh_read_obj(rest, &restm, err)) {
            cli_fail(cmd, status, "%s", err);
            goto out;
        }
        if (restm->nv != seq->nv) {
            cli_fail(cmd, status, "--rest %s has %d vertices, the sequence %d", rest, restm->nv,
                     seq->nv);
            goto out;
        }
        so.rest = restm->V;
    }
    if (mdl_parse_frames(frames ? frames : ":", seq->frames, &idx, &n, err)) {
        cli_fail(cmd, status, "--frames: %s", err);
        goto out;
    }
    mdl_set_blas_threads(1);
    cli_pool p = {threads};
    so.workers = threads;
    so.parallel = threads > 1 ? cli_parallel_for : NULL;
    so.parallel_ud = &p;
    so.seed = (uint64_t)(unsigned)seed;
    so.name = name ? name : "skin";
    so.progress = cli_progress;
    so.progress_ud = (void *)cmd;
    int rc = mdl_skin_fit(seq, idx, n, &so, &model, err);
    cli_progress_done();
    if (rc) {
        status = rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE;
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    mdl_skin_stats st;
    mdl_skin_get_stats(model, &st);
    if (gltf && mdl_skin_write_gltf(model, gltf, !gltf_once, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    if (addto) {
        if (mdl_model_load(addto, &dst, err) || mdl_model_merge(dst, &model, err)) {
            cli_fail(cmd, status, "--add-to: %s", err);
            goto out;
        }
        model = dst;
        dst = NULL;
    }
    if (mdl_model_save(model, outp, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    if (json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "bones", st.bones);
        cJSON_AddNumberToObject(o, "max_influences", st.max_influences);
        cJSON_AddNumberToObject(o, "frames", st.frames);
        cJSON_AddNumberToObject(o, "vertices", st.vertices);
        cJSON_AddNumberToObject(o, "rmse", st.rmse);
        cJSON_AddNumberToObject(o, "rmse_over_diag", st.rmse_over_diag);
        cJSON_AddNumberToObject(o, "max_err", st.max_err);
        cJSON_AddNumberToObject(o, "seconds", st.seconds);
        cJSON_AddNumberToObject(o, "threads", threads);
        cJSON_AddNumberToObject(o, "iterations", st.iterations);
        cJSON_AddNumberToObject(o, "diag", st.diag);
        if (cli_print_json(o)) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
            goto out;
        }
    }
    status = CLI_EXIT_OK;
out:
    free(idx);
    mdl_model_destroy(model);
    mdl_model_destroy(dst);
    mdl_mesh_destroy(restm);
    mdl_meshseq_destroy(seq);
    return status;
}
