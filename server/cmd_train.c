/* cmd_train.c - `meshsteer train`: learn a model from a mesh sequence and a rig (paper 2012 Sec. 4). */
#include "cli.h"
#include "cli_markers.h"

#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static const char usage_text[] =
    "usage: meshsteer train --mesh PATH --rig RIG.json -o MODEL [options]\n"
    "       meshsteer train --kind harmonic --mesh TARGET [--rig RIG.json --template FILE]\n"
    "                       [--correspondences auto|auto:K|rings:K|FILE] [--fit-rest] -o MODEL\n"
    "\n"
    "Learns the part-based pose and shape model (Voegele et al. 2012) from an example animation.\n"
    "\n"
    "  --mesh PATH        a directory of numbered OBJ frames, or a .pc2 point cache (with --rest)\n"
    "  --rest REST.obj    topology for a .pc2 mesh\n"
    "  --rig RIG.json     how markers attach to the mesh (docs/FORMATS.md)\n"
    "  --markers FILE     a marker recording (C3D, TRC, BVH, AMC, CSV) to learn from; without it the\n"
    "                     rig vertices' own trajectories are the markers (virtual markers)\n"
    "  --frames SPEC      training frames, a Python slice start:stop[:step] (default: all)\n"
    "  -o, --output MODEL where to write the model\n"
    "  --report FILE      write a JSON training report\n"
    "  --name NAME        model name stored in the file (default: the output file name)\n"
    "  --clusters N       number of near-rigid parts (default: automatic)\n"
    "  --max-clusters N   upper bound for the automatic choice (default: selected, 24 or 12)\n"
    "  --rigid-tol F      automatic clustering target: RMS rigid residual per part as a fraction\n"
    "                     of the bounding-box diagonal (default 0.004)\n"
    "  --overlap N        rings of overlap between parts (default: selected, 2, 1 or 3)\n"
    "  --explained F      shape variance kept per part (default 0.95)\n"
    "  --max-modes N      shape modes per part at most (default: selected, 6 or 3)\n"
    "  --ridge F          regression regularisation (default: leave-one-out per output, or 1,\n"
    "                     selected)\n"
    "  --beta F           shape prior weight of eq. 7 (default 0.5)\n"
    "  --iterations N     alternating alignment/shape iterations at synthesis (default 1)\n"
    "  --motion-dir       include directions of movement in the marker parameters\n"
    "  --no-motion-dir    do not (default: selected)\n"
    "  --linear           purely linear regressions (eq. 5; the default with --markers)\n"
    "  --rbf              linear + radial basis regressions (with virtual markers: selected)\n"
    "  --marker-weight F  markers as alignment targets at synthesis (default: 1 with virtual\n"
    "                     markers, 0 with a recording of another subject)\n"
    "  --relax N          alignment sweeps against all neighbours after the greedy pass (default 4)\n"
    "  --train-noise MM   with virtual markers: marker noise (mm) the regressions learn to\n"
    "                     ignore from 4 noisy copies of each frame (default: selected, 0, 5\n"
    "                     or 10; 0 without selection)\n"
    "  --filter-noise MM  with virtual markers: filter the input markers at synthesis for this\n"
    "                     much noise, gains from each marker's training motion (docs/MODEL.md;\n"
    "                     default: selected, 0 = off or the --cv-noise, off for a blend; off\n"
    "                     without selection)\n"
    "  --kernel-blend H   with virtual markers: synthesise by the kernel blend of the training\n"
    "                     meshes in marker space, bandwidth H x the nearest frame's marker fit,\n"
    "                     instead of the part model (docs/MODEL.md; default: selected, 0 = the\n"
    "                     part model, 0.5, 0.7 or 1; the part model without selection)\n"
    "  --align-samples N  shared vertices per part used by alignment and shape steps (default\n"
    "                     16; 0 = all)\n"
    "  --cv-folds K       with virtual markers, the options marked \"selected\" that are not given\n"
    "                     are chosen by leave-a-block-out cross-validation over K time blocks\n"
    "                     of the training frames, clean and with --cv-noise (docs/MODEL.md;\n"
    "                     default 3; 0 = no selection: 24 parts, overlap 2, 6 modes, motion\n"
    "                     directions off, rbf, leave-one-out ridge); --report lists them\n"
    "  --cv-noise MM      marker noise of the noisy validation (default 10 mm)\n"
    "  --kind KIND        steer (default: the above) or harmonic (de Aguiar et al. 2007: a static\n"
    "                     mesh, the first frame of --mesh, animated by a template skeleton)\n"
    "harmonic options:\n"
    "  --rig RIG.json     the template's bones: limbs [from, to] or [from, to, twist] of marker\n"
    "                     names, reference[0] the root (docs/MODEL.md); not needed with auto:K\n"
    "  --template FILE    the template's rest pose: a BVH's or ASF/AMC's rest pose (all rotations\n"
    "                     zero), or frame 0 of another marker file\n"
    "  --correspondences auto|auto:K|rings:K|FILE\n"
    "                     auto (default with a rig): --per-bone triangles along every bone;\n"
    "                     FILE: a JSON file of target triangles per rig limb, each completed by\n"
    "                     its cross-section; bones it does not name stay auto (docs/FORMATS.md)\n"
    "                     auto:K: K triangles spread over the mesh, no template (for eval)\n"
    "                     rings:K: as auto:K, each grown to a ring across the local principal\n"
    "                     axis (a limb's cross-section) instead of a patch\n"
    "  --per-bone N       automatic correspondence triangles per bone (default 8)\n"
    "  --fit-rest         pose the template's rest skeleton onto the target's limbs first (a\n"
    "                     mocap rest pose vs a T-posed scan; docs/MODEL.md)\n" CLI_MARKER_OPTS_HELP;

static int write_report(const char *cmd, const mdl_model *model, const char *report)
{
    char *js = mdl_model_report_json(model);
    FILE *f = js ? fopen(report, "w") : NULL;
    if (!f || fputs(js, f) < 0 || fclose(f) != 0) {
        free(js);
        return cli_fail(cmd, CLI_EXIT_FAIL, "%s: cannot write the report", report);
    }
    free(js);
    return CLI_EXIT_OK;
}

/* --kind harmonic: de Aguiar et al. 2007, built from the first frame of --mesh (model.h) */
static int train_harmonic(const char *mesh, const char *rest, const char *rigp, const char *tmpl,
                          const char *corr, int per_bone, int fit_rest, const mdl_marker_opts *mo,
                          const char *outp, const char *report, const char *name)
{
    const char *cmd = "train";
    if (!mesh || !outp)
        return cli_usage_error(cmd, "--kind harmonic needs --mesh and -o (see --help)");
    mdl_harmonic_opts o;
    mdl_harmonic_opts_default(&o);
    o.per_bone = per_bone;
    o.fit_rest = fit_rest;
    o.name = name;
    if (corr && (strncmp(corr, "auto:", 5) == 0 || strncmp(corr, "rings:", 6) == 0)) {
        o.rings = corr[0] == 'r';
        if (cli_parse_int(cmd, "--correspondences auto:K", corr + 5 + o.rings, &o.auto_k) ||
            o.auto_k < 1)
            return cli_usage_error(cmd, "--correspondences: '%s': K must be a positive integer", corr);
    }
    const char *corr_file = corr && o.auto_k == 0 && strcmp(corr, "auto") != 0 ? corr : NULL;
    if (o.auto_k == 0 && (!rigp || !tmpl))
        return cli_usage_error(cmd, "--kind harmonic needs --rig and --template, or "
                               "--correspondences auto:K");
    if (per_bone < 1 || per_bone > 10000)
        return cli_usage_error(cmd, "--per-bone must be within 1..10000");
    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE;
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    mdl_markers *tm = NULL, *tmotion = NULL;
    mdl_model *model = NULL;
    int *goff = NULL, *gidx = NULL; /* --correspondences FILE */
    if (mdl_meshseq_read(mesh, rest, &seq, err) || (rigp && mdl_rig_read(rigp, 0, &rig, err))) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (tmpl && o.auto_k == 0) {
        mdl_marker_opts to = *mo;
        const char *dot = strrchr(tmpl, '.');
        to.rest = dot && (strcasecmp(dot, ".bvh") == 0 || strcasecmp(dot, ".amc") == 0 ||
                          strcasecmp(dot, ".asf") == 0);
        if (mdl_markers_read(tmpl, &to, &tm, err)) {
            cli_fail(cmd, status, "%s", err);
            goto out;
        }
        /* the motion too, for the mocap's floor (a BVH rest pose has its root at the origin) */
        to.rest = 0;
        if (mdl_markers_read(tmpl, &to, &tmotion, err)) {
            cli_fail(cmd, status, "%s", err);
            goto out;
        }
        o.template_motion = tmotion;
    }
    if (corr_file) {
        if (mdl_corr_read(corr_file, rig, seq->nf, &goff, &gidx, err)) {
            cli_fail(cmd, status, "%s", err);
            goto out;
        }
        o.given_off = goff;
        o.given_idx = gidx;
    }
    mdl_mesh target = {.nv = seq->nv, .nf = seq->nf, .V = seq->V, .F = seq->F};
    int r = mdl_harmonic_build(&target, o.auto_k ? NULL : rig, tm, &o, &model, err);
    if (r) {
        status = cli_fail(cmd, r == -ENOMEM || r == MDL_ENUMERIC ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
        goto out;
    }
    if (mdl_model_save(model, outp, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    if (report && (status = write_report(cmd, model, report)) != CLI_EXIT_OK)
        goto out;
    mdl_model_info info;
    mdl_model_get_info(model, &info);
    fprintf(stderr, "meshsteer train: %s: harmonic model of %d vertices, %d markers\n", outp,
            info.nv, info.nmarkers);
    status = CLI_EXIT_OK;
out:
    free(goff);
    free(gidx);
    mdl_model_destroy(model);
    mdl_markers_destroy(tm);
    mdl_markers_destroy(tmotion);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    return status;
}

int cmd_train(int argc, char **argv)
{
    const char *cmd = "train", *mesh = NULL, *rest = NULL, *rigp = NULL, *mk = NULL,
               *frames = NULL, *outp = NULL, *report = NULL, *name = NULL, *kind = "steer",
               *tmpl = NULL, *corr = NULL;
    int per_bone = 8, fit_rest = 0;
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    o.select_folds = 3; /* the user's default: options chosen by the data (docs/MODEL.md) */
    mdl_marker_opts mo = {0, MDL_UP_AUTO, 0};
    enum { O_REST = 256, O_RIG, O_MARKERS, O_FRAMES, O_REPORT, O_NAME, O_CLUSTERS, O_MAXCL, O_TOL,
           O_OVERLAP, O_EXPL, O_MODES, O_RIDGE, O_BETA, O_ITER, O_MOTION, O_MSCALE, O_MUP, O_LINEAR,
           O_MWEIGHT, O_RELAX, O_SAMPLES, O_RBF, O_TNOISE, O_KIND, O_TEMPLATE, O_CORR, O_PERBONE,
           O_FITREST, O_NOMOTION, O_CVFOLDS, O_CVNOISE, O_FNOISE, O_KBLEND };
    double tnoise_mm = -1, cvnoise_mm = 1000 * o.select_noise, fnoise_mm = -1;
    static const struct option lo[] = {
        {"mesh", 1, 0, 'm'},          {"rest", 1, 0, O_REST},         {"rig", 1, 0, O_RIG},
        {"markers", 1, 0, O_MARKERS}, {"frames", 1, 0, O_FRAMES},     {"output", 1, 0, 'o'},
        {"report", 1, 0, O_REPORT},   {"name", 1, 0, O_NAME},         {"clusters", 1, 0, O_CLUSTERS},
        {"max-clusters", 1, 0, O_MAXCL}, {"rigid-tol", 1, 0, O_TOL},  {"overlap", 1, 0, O_OVERLAP},
        {"explained", 1, 0, O_EXPL},  {"max-modes", 1, 0, O_MODES},   {"ridge", 1, 0, O_RIDGE},
        {"beta", 1, 0, O_BETA},       {"iterations", 1, 0, O_ITER},   {"motion-dir", 0, 0, O_MOTION},
        {"marker-scale", 1, 0, O_MSCALE}, {"marker-up", 1, 0, O_MUP}, {"help", 0, 0, 'h'},
        {"linear", 0, 0, O_LINEAR},   {"marker-weight", 1, 0, O_MWEIGHT}, {"relax", 1, 0, O_RELAX},
        {"align-samples", 1, 0, O_SAMPLES}, {"rbf", 0, 0, O_RBF}, {"train-noise", 1, 0, O_TNOISE},
        {"kind", 1, 0, O_KIND}, {"template", 1, 0, O_TEMPLATE}, {"correspondences", 1, 0, O_CORR},
        {"per-bone", 1, 0, O_PERBONE}, {"fit-rest", 0, 0, O_FITREST},
        {"no-motion-dir", 0, 0, O_NOMOTION}, {"cv-folds", 1, 0, O_CVFOLDS},
        {"cv-noise", 1, 0, O_CVNOISE}, {"filter-noise", 1, 0, O_FNOISE},
        {"kernel-blend", 1, 0, O_KBLEND}, {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "m:o:h", lo, NULL)) != -1) {
        switch (c) {
        case 'm': mesh = optarg; break;
        case O_REST: rest = optarg; break;
        case O_RIG: rigp = optarg; break;
        case O_MARKERS: mk = optarg; break;
        case O_FRAMES: frames = optarg; break;
        case 'o': outp = optarg; break;
        case O_REPORT: report = optarg; break;
        case O_NAME: name = optarg; break;
        case O_CLUSTERS: if (cli_parse_int(cmd, "--clusters", optarg, &o.clusters)) return CLI_EXIT_USAGE; break;
        case O_MAXCL: if (cli_parse_int(cmd, "--max-clusters", optarg, &o.max_clusters)) return CLI_EXIT_USAGE; break;
        case O_TOL: if (cli_parse_double(cmd, "--rigid-tol", optarg, &o.rigid_tol)) return CLI_EXIT_USAGE; break;
        case O_OVERLAP: if (cli_parse_int(cmd, "--overlap", optarg, &o.overlap_rings)) return CLI_EXIT_USAGE; break;
        case O_EXPL: if (cli_parse_double(cmd, "--explained", optarg, &o.explained)) return CLI_EXIT_USAGE; break;
        case O_MODES: if (cli_parse_int(cmd, "--max-modes", optarg, &o.max_modes)) return CLI_EXIT_USAGE; break;
        case O_RIDGE: if (cli_parse_double(cmd, "--ridge", optarg, &o.ridge)) return CLI_EXIT_USAGE; break;
        case O_BETA: if (cli_parse_double(cmd, "--beta", optarg, &o.beta)) return CLI_EXIT_USAGE; break;
        case O_ITER: if (cli_parse_int(cmd, "--iterations", optarg, &o.iterations)) return CLI_EXIT_USAGE; break;
        case O_MOTION: o.use_motion_dir = 1; break;
        case O_NOMOTION: o.use_motion_dir = 0; break;
        case O_CVFOLDS: if (cli_parse_int(cmd, "--cv-folds", optarg, &o.select_folds)) return CLI_EXIT_USAGE; break;
        case O_FNOISE: if (cli_parse_double(cmd, "--filter-noise", optarg, &fnoise_mm)) return CLI_EXIT_USAGE; break;
        case O_KBLEND: if (cli_parse_double(cmd, "--kernel-blend", optarg, &o.kblend)) return CLI_EXIT_USAGE; break;
        case O_CVNOISE: if (cli_parse_double(cmd, "--cv-noise", optarg, &cvnoise_mm)) return CLI_EXIT_USAGE; break;
        case O_LINEAR: o.linear = 1; break;
        case O_RBF: o.linear = 0; break;
        case O_TNOISE: if (cli_parse_double(cmd, "--train-noise", optarg, &tnoise_mm)) return CLI_EXIT_USAGE; break;
        case O_MWEIGHT: if (cli_parse_double(cmd, "--marker-weight", optarg, &o.marker_weight)) return CLI_EXIT_USAGE; break;
        case O_RELAX: if (cli_parse_int(cmd, "--relax", optarg, &o.relax)) return CLI_EXIT_USAGE; break;
        case O_SAMPLES: if (cli_parse_int(cmd, "--align-samples", optarg, &o.align_samples)) return CLI_EXIT_USAGE; break;
        case O_MSCALE:
        case O_MUP:
            if (cli_marker_option(cmd, c == O_MSCALE ? "marker-scale" : "marker-up", optarg, &mo))
                return CLI_EXIT_USAGE;
            break;
        case O_KIND: kind = optarg; break;
        case O_TEMPLATE: tmpl = optarg; break;
        case O_CORR: corr = optarg; break;
        case O_PERBONE: if (cli_parse_int(cmd, "--per-bone", optarg, &per_bone)) return CLI_EXIT_USAGE; break;
        case O_FITREST: fit_rest = 1; break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (strcmp(kind, "harmonic") == 0) {
        if (!name) {
            const char *slash = outp ? strrchr(outp, '/') : NULL;
            name = slash ? slash + 1 : outp;
        }
        return train_harmonic(mesh, rest, rigp, tmpl, corr, per_bone, fit_rest, &mo, outp, report,
                              name);
    }
    if (strcmp(kind, "steer") != 0)
        return cli_usage_error(cmd, "--kind: '%s' is not steer or harmonic", kind);
    if (!mesh || !rigp || !outp)
        return cli_usage_error(cmd, "--mesh, --rig and -o are required (see --help)");
    if (o.clusters < 0 || (o.max_clusters != -1 && (o.max_clusters < 1 || o.max_clusters > 1000)) ||
        !(o.rigid_tol > 0) || o.overlap_rings < -1 || o.overlap_rings > 10 ||
        !(o.explained > 0 && o.explained <= 1) || o.max_modes < -1 || o.max_modes > 64 ||
        o.select_folds < 0 || o.select_folds > 8 || !(o.beta >= 0) || o.iterations < 0 || o.iterations > 100 ||
        o.relax < 0 || o.relax > 100 || o.align_samples < 0 || !(o.marker_weight >= 0 || o.marker_weight == -1))
        return cli_usage_error(cmd, "an option is out of range (see --help)");
    if (tnoise_mm != -1 && !(tnoise_mm >= 0 && tnoise_mm < 1000))
        return cli_usage_error(cmd, "--train-noise must be within 0..1000 mm");
    o.train_noise = tnoise_mm == -1 ? -1 : tnoise_mm / 1000.0;
    if (!(cvnoise_mm >= 0 && cvnoise_mm < 1000))
        return cli_usage_error(cmd, "--cv-noise must be within 0..1000 mm");
    o.select_noise = cvnoise_mm / 1000.0;
    if (fnoise_mm != -1 && !(fnoise_mm >= 0 && fnoise_mm < 1000))
        return cli_usage_error(cmd, "--filter-noise must be within 0..1000 mm");
    o.filter_noise = fnoise_mm == -1 ? -1 : fnoise_mm / 1000.0;
    if (o.kblend != -1 && !(o.kblend >= 0 && o.kblend < 1000))
        return cli_usage_error(cmd, "--kernel-blend must be within 0..1000");
    if (o.ridge != -1 && !(o.ridge >= 0))
        return cli_usage_error(cmd, "--ridge must be >= 0");

    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE;
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    mdl_markers *markers = NULL;
    mdl_model *model = NULL;
    int *idx = NULL, n = 0;
    if (mdl_meshseq_read(mesh, rest, &seq, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (mdl_rig_read(rigp, seq->nv, &rig, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (mk && mdl_markers_read(mk, &mo, &markers, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (mdl_parse_frames(frames ? frames : ":", seq->frames, &idx, &n, err)) {
        cli_fail(cmd, status, "--frames: %s", err);
        goto out;
    }
    if (!name) {
        const char *slash = strrchr(outp, '/');
        name = slash ? slash + 1 : outp;
    }
    o.name = name;
    o.progress = cli_progress;
    o.progress_ud = (void *)"train";
    int r = mdl_steer_train(seq, idx, n, rig, markers, &o, &model, err);
    cli_progress_done();
    if (r) {
        cli_fail(cmd, r == -ENOMEM || r == MDL_ENUMERIC ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
        status = r == -ENOMEM || r == MDL_ENUMERIC ? CLI_EXIT_FAIL : CLI_EXIT_USAGE;
        goto out;
    }
    if (mdl_model_save(model, outp, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    if (report) {
        char *js = mdl_model_report_json(model);
        FILE *f = js ? fopen(report, "w") : NULL;
        if (!f || fputs(js, f) < 0 || fclose(f) != 0) {
            free(js);
            status = cli_fail(cmd, CLI_EXIT_FAIL, "%s: cannot write the report", report);
            goto out;
        }
        free(js);
    }
    mdl_model_info info;
    mdl_model_get_info(model, &info);
    fprintf(stderr, "meshsteer train: %s: %d parts from %d frames of %d vertices\n", outp,
            info.nclusters, n, info.nv);
    status = CLI_EXIT_OK;
out:
    free(idx);
    mdl_model_destroy(model);
    mdl_markers_destroy(markers);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    return status;
}
