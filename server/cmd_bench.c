/* cmd_bench.c - `meshsteer bench`: training time and per-frame synthesis time (median, p99) on one
 * core, beside the nearest-training-frame baseline measured in the same run (the machines are
 * shared and noisy, so ratios within one run are what can be compared). */
#include "cli.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const char usage_text[] =
    "usage: meshsteer bench --mesh PATH --rig RIG.json [options]\n"
    "\n"
    "Trains a model several times and synthesises the evaluation frames many times on one core,\n"
    "then prints median and p99 of each, beside the nearest-frame baseline in the same run.\n"
    "\n"
    "  --mesh PATH        OBJ directory, or .pc2 with --rest\n"
    "  --rest REST.obj    topology for a .pc2 sequence\n"
    "  --rig RIG.json     the rig\n"
    "  --frames SPEC      training frames (default 0:24:2)\n"
    "  --eval-frames SPEC frames whose rig vertices drive synthesis (default 1:24:2)\n"
    "  --train-runs N     training repetitions (default 5)\n"
    "  --synth-frames N   synthesised frames in all (default 2000)\n"
    "  --kernel-blend H   train as 'meshsteer train --kernel-blend H' does: synthesis is the kernel\n"
    "                     blend of the training meshes (0: the part model, the default)\n";

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void cpu_name(char *buf, size_t len)
{
    snprintf(buf, len, "unknown cpu");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, "model name", 10)) {
            char *c = strchr(line, ':');
            if (c) {
                c += 2;
                c[strcspn(c, "\n")] = 0;
                snprintf(buf, len, "%s", c);
            }
            break;
        }
    fclose(f);
}

int cmd_bench(int argc, char **argv)
{
    const char *cmd = "bench", *mesh = NULL, *rest = NULL, *rigp = NULL, *tspec = "0:24:2",
               *espec = "1:24:2";
    int runs = 5, nsynth = 2000;
    double kblend = -1; /* -1: not given, the library's default */
    enum { O_MESH = 256, O_REST, O_RIG, O_FRAMES, O_EFRAMES, O_RUNS, O_NSYNTH, O_KBLEND };
    static const struct option lo[] = {
        {"mesh", 1, 0, O_MESH},       {"rest", 1, 0, O_REST},           {"rig", 1, 0, O_RIG},
        {"frames", 1, 0, O_FRAMES},   {"eval-frames", 1, 0, O_EFRAMES}, {"train-runs", 1, 0, O_RUNS},
        {"synth-frames", 1, 0, O_NSYNTH}, {"kernel-blend", 1, 0, O_KBLEND},
        {"help", 0, 0, 'h'},          {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (c) {
        case O_MESH: mesh = optarg; break;
        case O_REST: rest = optarg; break;
        case O_RIG: rigp = optarg; break;
        case O_FRAMES: tspec = optarg; break;
        case O_EFRAMES: espec = optarg; break;
        case O_RUNS: if (cli_parse_int(cmd, "--train-runs", optarg, &runs)) return CLI_EXIT_USAGE; break;
        case O_NSYNTH: if (cli_parse_int(cmd, "--synth-frames", optarg, &nsynth)) return CLI_EXIT_USAGE; break;
        case O_KBLEND: if (cli_parse_double(cmd, "--kernel-blend", optarg, &kblend)) return CLI_EXIT_USAGE; break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (!mesh || !rigp)
        return cli_usage_error(cmd, "--mesh and --rig are required (see --help)");
    if (runs < 1 || runs > 1000 || nsynth < 1 || nsynth > 10000000)
        return cli_usage_error(cmd, "--train-runs must be 1..1000 and --synth-frames 1..10^7");
    if (kblend != -1 && !(kblend >= 0 && kblend < 1000))
        return cli_usage_error(cmd, "--kernel-blend must be within 0..1000");

    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE, *ti = NULL, *ei = NULL, nt = 0, ne = 0;
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    mdl_model *model = NULL;
    mdl_synth *s = NULL;
    double *tt = NULL, *st = NULL, *bt = NULL;
    float *V = NULL, *mk = NULL;
    if (mdl_meshseq_read(mesh, rest, &seq, err) || mdl_rig_read(rigp, seq->nv, &rig, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (mdl_parse_frames(tspec, seq->frames, &ti, &nt, err) ||
        mdl_parse_frames(espec, seq->frames, &ei, &ne, err)) {
        cli_fail(cmd, status, "frames: %s", err);
        goto out;
    }
    mdl_set_blas_threads(1);
    int nm = rig->nmarkers, nv = seq->nv;
    tt = calloc((size_t)runs, sizeof *tt);
    st = calloc((size_t)nsynth, sizeof *st);
    bt = calloc((size_t)nsynth, sizeof *bt);
    V = calloc((size_t)nv * 3, sizeof *V);
    mk = calloc((size_t)ne * nm * 3, sizeof *mk);
    if (!tt || !st || !bt || !V || !mk) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
        goto out;
    }
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    if (kblend != -1)
        o.kblend = kblend;
    for (int r = 0; r < runs; r++) {
        mdl_model_destroy(model);
        model = NULL;
        double t0 = now_s();
        if (mdl_steer_train(seq, ti, nt, rig, NULL, &o, &model, err)) {
            status = cli_fail(cmd, CLI_EXIT_USAGE, "%s", err);
            goto out;
        }
        tt[r] = now_s() - t0;
    }
    for (int i = 0; i < ne; i++)
        for (int j = 0; j < nm; j++)
            memcpy(mk + ((size_t)i * nm + j) * 3,
                   seq->V + ((size_t)ei[i] * nv + rig->markers[j].vertex) * 3, 3 * sizeof(float));
    if (mdl_synth_create(model, 0, &s, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    float *gmk = calloc((size_t)nm * 3, sizeof *gmk);
    if (!gmk) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
        goto out;
    }
    double sink = 0;
    for (int k = 0; k < nsynth; k++) {
        const float *m = mk + (size_t)(k % ne) * nm * 3;
        double t0 = now_s();
        mdl_synth_markers(s, m, NULL, V, NULL);
        st[k] = 1e6 * (now_s() - t0);
        sink += V[0];
        /* baseline: best-fitting training frame by rigid marker alignment, then copy its mesh */
        t0 = now_s();
        double best = INFINITY;
        int bf = 0;
        for (int t = 0; t < nt; t++) {
            const float *G = seq->V + (size_t)ti[t] * nv * 3;
            for (int j = 0; j < nm; j++)
                memcpy(gmk + 3 * j, G + 3 * rig->markers[j].vertex, 3 * sizeof(float));
            double f = mdl_rigid_aligned_error(gmk, m, nm, NULL);
            if (f < best) {
                best = f;
                bf = ti[t];
            }
        }
        memcpy(V, seq->V + (size_t)bf * nv * 3, sizeof(float) * 3 * (size_t)nv);
        bt[k] = 1e6 * (now_s() - t0);
        sink += V[0];
    }
    free(gmk);
    double tmed, tp99, smed, sp99, bmed, bp99;
    cli_percentiles(tt, runs, &tmed, &tp99);
    cli_percentiles(st, nsynth, &smed, &sp99);
    cli_percentiles(bt, nsynth, &bmed, &bp99);
    char cpu[256];
    cpu_name(cpu, sizeof cpu);
    mdl_model_info info;
    mdl_model_get_info(model, &info);
    printf("machine      %s, BLAS pinned to 1 thread\n", cpu);
    printf("mesh         %s: %d vertices, %d triangles; %d markers; %d parts\n", mesh, nv, seq->nf,
           nm, info.nclusters);
    if (kblend > 0)
        printf("synthesis    the kernel blend of the %d training meshes, bandwidth %g (the parts unused)\n",
               nt, kblend);
    printf("train        %d runs on %d frames: median %.3f s, p99 %.3f s\n", runs, nt, tmed, tp99);
    printf("synth        %d frames: median %.1f us, p99 %.1f us (%.0f frames/s at the median)\n",
           nsynth, smed, sp99, 1e6 / smed);
    printf("baseline     nearest training frame (marker fit + copy): median %.1f us, p99 %.1f us\n",
           bmed, bp99);
    printf("ratio        synth / baseline median %.2f\n", smed / bmed);
    if (sink == 12345.678)
        printf("\n");
    status = CLI_EXIT_OK;
out:
    mdl_synth_destroy(s);
    mdl_model_destroy(model);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    free(ti);
    free(ei);
    free(tt);
    free(st);
    free(bt);
    free(V);
    free(mk);
    return status;
}
