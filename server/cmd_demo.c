/* cmd_demo.c - `meshsteer demo`: the main job on the built-in example, needing nothing outside the
 * repository. The example creature walks (the training animation); its marker recording is a trot
 * of the same creature, whose true meshes are known, so the demo prints a real quality report:
 * error against ground truth beside the nearest-training-frame baseline. */
#include "cli.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char usage_text[] =
    "usage: meshsteer demo [--out DIR] [--frames N] [--speed S] [--markers FILE]\n"
    "\n"
    "Generates the built-in example (a four-legged creature walking, and a marker recording of\n"
    "it trotting), trains a model on the walk, synthesises the trot from its markers and prints\n"
    "the error against the trot's true meshes beside the nearest-training-frame baseline.\n"
    "\n"
    "  --out DIR      where to write model.msm, trot.csv (the markers), trot.pc2 and rest.obj\n"
    "                 (default demo-out); `meshsteerd --model DIR/model.msm --source\n"
    "                 replay:DIR/trot.csv?loop=1` then streams the trot to browsers\n"
    "  --frames N     frames of walk and of trot (default 60)\n"
    "  --speed S      trot cycle rate relative to the walk (default 1.3)\n"
    "  --markers FILE drive the model with this recording of the trot (its first N frames)\n"
    "                 instead of generating it: the committed take recordings/example-trot.c3d\n"
    "                 (`meshsteer record markers`); refused unless it is the trot at --speed S\n"
    "                 (every marker within 1 mm of the generated one)\n";

/* Replaces the generated trot *rec by the recording at path (its first rec->frames frames), after
 * checking that it is that trot: the same labels, every marker within 1 mm (a C3D keeps float
 * millimetres). The true meshes the demo measures against stay the generated ones. */
static int use_recording(const char *cmd, const char *path, double speed, mdl_markers **rec)
{
    char err[MDL_ERR_LEN] = "";
    mdl_markers *file = NULL, *gen = *rec;
    if (mdl_markers_read(path, NULL, &file, err))
        return cli_fail(cmd, CLI_EXIT_USAGE, "--markers: %s", err);
    int bad = file->count != gen->count || file->frames < gen->frames;
    for (int m = 0; !bad && m < gen->count; m++)
        bad = strcmp(file->names[m], gen->names[m]) != 0;
    if (bad) {
        cli_fail(cmd, CLI_EXIT_USAGE, "--markers %s: %d markers, %d frames; the example's trot has "
                 "%d markers (%s, ...) and needs %d frames", path, file->count, file->frames,
                 gen->count, gen->names[0], gen->frames);
        mdl_markers_destroy(file);
        return CLI_EXIT_USAGE;
    }
    for (size_t i = 0; i < (size_t)gen->frames * gen->count; i++) {
        float d = 0;
        for (int k = 0; k < 3; k++)
            d = fmaxf(d, fabsf(file->P[3 * i + k] - gen->P[3 * i + k]));
        if (!file->valid[i] || d > 1e-3f) {
            cli_fail(cmd, CLI_EXIT_USAGE, "--markers %s: frame %zu, marker %s is %.4f m from the "
                     "example's trot at --speed %g: not that recording", path, i / gen->count,
                     gen->names[i % gen->count], d, speed);
            mdl_markers_destroy(file);
            return CLI_EXIT_USAGE;
        }
    }
    file->frames = gen->frames; /* the demo's length; the arrays stay as read */
    mdl_markers_destroy(gen);
    *rec = file;
    return CLI_EXIT_OK;
}

int cmd_demo(int argc, char **argv)
{
    const char *cmd = "demo", *outdir = "demo-out", *markers = NULL;
    int frames = 60;
    double speed = 1.3;
    static const struct option lo[] = {{"out", 1, 0, 'o'}, {"frames", 1, 0, 'f'},
                                       {"speed", 1, 0, 's'}, {"markers", 1, 0, 'm'},
                                       {"help", 0, 0, 'h'}, {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:h", lo, NULL)) != -1) {
        switch (c) {
        case 'o': outdir = optarg; break;
        case 'f': if (cli_parse_int(cmd, "--frames", optarg, &frames)) return CLI_EXIT_USAGE; break;
        case 's': if (cli_parse_double(cmd, "--speed", optarg, &speed)) return CLI_EXIT_USAGE; break;
        case 'm': markers = optarg; break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (frames < 8 || frames > 10000 || !(speed > 0 && speed < 10))
        return cli_usage_error(cmd, "--frames must be 8..10000 and --speed within (0, 10)");
    if (mkdir(outdir, 0777) != 0 && errno != EEXIST)
        return cli_fail(cmd, CLI_EXIT_FAIL, "%s: cannot create: %s", outdir, strerror(errno));

    char err[MDL_ERR_LEN] = "", path[4096];
    int status = CLI_EXIT_FAIL, *ti = NULL, *ei = NULL;
    mdl_meshseq *walk = NULL, *truth = NULL, both = {0};
    mdl_rig *rig = NULL;
    mdl_markers *rec = NULL;
    mdl_model *model = NULL;
    mdl_eval_result r = {0};
    mdl_set_blas_threads(1);
    fprintf(stderr, "meshsteer demo: generating the example creature (%d frames of walk and trot)\n",
            frames);
    if (mdl_example_create(frames, &walk, &rig, err) ||
        mdl_example_markers(rig, frames, speed, &rec, &truth, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (markers && (status = use_recording(cmd, markers, speed, &rec)) != CLI_EXIT_OK)
        goto out;
    status = CLI_EXIT_FAIL;
    /* one sequence holding the walk (training) and the trot's truth (evaluation) */
    both.nv = walk->nv;
    both.nf = walk->nf;
    both.frames = 2 * frames;
    both.fps = walk->fps;
    both.F = walk->F;
    both.V = malloc(sizeof(float) * 3 * (size_t)walk->nv * 2 * frames);
    ti = malloc(sizeof(int) * (size_t)frames);
    ei = malloc(sizeof(int) * (size_t)frames);
    if (!both.V || !ti || !ei) {
        cli_fail(cmd, status, "out of memory");
        goto out;
    }
    size_t fsz = 3 * (size_t)walk->nv;
    memcpy(both.V, walk->V, sizeof(float) * fsz * frames);
    memcpy(both.V + fsz * frames, truth->V, sizeof(float) * fsz * frames);
    for (int i = 0; i < frames; i++) {
        ti[i] = i;
        ei[i] = frames + i;
    }
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    o.name = "example-creature";
    o.progress = cli_progress;
    o.progress_ud = (void *)"demo";
    if (mdl_steer_train(&both, ti, frames, rig, NULL, &o, &model, err)) {
        cli_progress_done();
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    cli_progress_done();
    snprintf(path, sizeof path, "%s/model.msm", outdir);
    if (mdl_model_save(model, path, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    mdl_eval_opts eo = {0, 0, 1, 0};
    if (mdl_eval_run(model, &both, ei, frames, &eo, &r, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    /* the synthesised trot, for Blender (or `meshsteer render --mesh DIR/trot.pc2 --rest ...`) */
    {
        mdl_synth *s = NULL;
        float *out = malloc(sizeof(float) * fsz * frames);
        int ok = out && mdl_synth_create(model, 0, &s, err) == 0;
        for (int i = 0; ok && i < frames; i++)
            ok = mdl_synth_markers(s, rec->P + (size_t)i * rec->count * 3, rec->valid + (size_t)i * rec->count,
                                 out + fsz * i, NULL) == 0;
        snprintf(path, sizeof path, "%s/trot.pc2", outdir);
        if (ok)
            ok = mdl_pc2_write(path, out, walk->nv, frames, 0, 1, err) == 0;
        snprintf(path, sizeof path, "%s/rest.obj", outdir);
        if (ok)
            ok = mdl_mesh_write_obj(path, walk->V, walk->nv, walk->F, walk->nf, err) == 0;
        snprintf(path, sizeof path, "%s/trot.csv", outdir);
        if (ok)
            ok = mdl_markers_write_csv(path, rec, err) == 0;
        mdl_synth_destroy(s);
        free(out);
        if (!ok) {
            cli_fail(cmd, status, "writing results: %s", err[0] ? err : "failed");
            goto out;
        }
    }
    double med, p99;
    cli_percentiles(r.synth_us, r.frames, &med, &p99);
    mdl_model_info info;
    mdl_model_get_info(model, &info);
    printf("meshsteer demo: built-in example creature, %d vertices, %d near-rigid parts\n", info.nv,
           info.nclusters);
    printf("  trained on %d walk frames; driven by %d markers of a trot (%d frames)\n", frames,
           info.nmarkers, r.frames);
    printf("  error vs. ground truth (fraction of bounding-box diagonal, after rigid alignment):\n");
    printf("    model                     mean %.4f  p95 %.4f  max %.4f\n", r.mean_err, r.p95_err,
           r.max_err);
    printf("    nearest training frame    mean %.4f  p95 %.4f\n", r.baseline_nn_mean_err,
           r.baseline_nn_p95_err);
    printf("    model / baseline          %.2f\n", r.mean_err / r.baseline_nn_mean_err);
    printf("  synthesis: %.1f us/frame median, %.1f us p99 (one core)\n", med, p99);
    printf("  written: %s/model.msm, %s/trot.csv, %s/trot.pc2, %s/rest.obj\n", outdir, outdir,
           outdir, outdir);
    status = CLI_EXIT_OK;
out:
    mdl_eval_result_fini(&r);
    mdl_model_destroy(model);
    mdl_markers_destroy(rec);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(walk);
    mdl_meshseq_destroy(truth);
    free(both.V);
    free(ti);
    free(ei);
    return status;
}
