/* cmd_markers.c - `meshsteer markers`: the rig vertices' trajectories of a mesh sequence as a
 * marker file (virtual markers, paper 2012 Sec. 4), for replay through meshsteerd or as input to
 * synth. Written as CSV or C3D by the output's extension. */
#include "cli.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char usage_text[] =
    "usage: meshsteer markers --mesh PATH --rig RIG.json [--rest REST.obj] [--frames SPEC]\n"
    "                         [--fps HZ] -o OUT.csv|OUT.c3d\n"
    "\n"
    "Writes the trajectories of the rig's vertices (named by their 'source' labels) as markers.\n"
    "\n"
    "  --fps HZ    frame rate to record (default: the sequence's, or 30 when it has none)\n";

int cmd_markers(int argc, char **argv)
{
    const char *cmd = "markers", *mesh = NULL, *rest = NULL, *rigp = NULL, *frames = NULL,
               *outp = NULL;
    double fps = 0;
    enum { O_MESH = 256, O_REST, O_RIG, O_FRAMES, O_FPS };
    static const struct option lo[] = {{"mesh", 1, 0, O_MESH},     {"rest", 1, 0, O_REST},
                                       {"rig", 1, 0, O_RIG},       {"frames", 1, 0, O_FRAMES},
                                       {"fps", 1, 0, O_FPS},       {"output", 1, 0, 'o'},
                                       {"help", 0, 0, 'h'},        {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:h", lo, NULL)) != -1) {
        switch (c) {
        case O_MESH: mesh = optarg; break;
        case O_REST: rest = optarg; break;
        case O_RIG: rigp = optarg; break;
        case O_FRAMES: frames = optarg; break;
        case O_FPS: if (cli_parse_double(cmd, "--fps", optarg, &fps)) return CLI_EXIT_USAGE; break;
        case 'o': outp = optarg; break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (!mesh || !rigp || !outp)
        return cli_usage_error(cmd, "--mesh, --rig and -o are required (see --help)");
    if (!(fps >= 0 && fps <= 10000))
        return cli_usage_error(cmd, "--fps must be within 0..10000");
    int c3d = cli_has_suffix(outp, ".c3d");
    if (!c3d && !cli_has_suffix(outp, ".csv"))
        return cli_usage_error(cmd, "-o %s: the output must end in .csv or .c3d", outp);
    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE, *idx = NULL, n = 0;
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    mdl_markers *mk = NULL;
    if (mdl_meshseq_read(mesh, rest, &seq, err) || mdl_rig_read(rigp, seq->nv, &rig, err) ||
        mdl_parse_frames(frames ? frames : ":", seq->frames, &idx, &n, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    if (mdl_markers_create(n, rig->nmarkers, fps > 0 ? fps : seq->fps > 0 ? seq->fps : 30, &mk, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    for (int j = 0; j < rig->nmarkers; j++) {
        char *name = strdup(rig->markers[j].source);
        if (!name) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
            goto out;
        }
        free(mk->names[j]);
        mk->names[j] = name;
    }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < rig->nmarkers; j++) {
            memcpy(mk->P + ((size_t)i * mk->count + j) * 3,
                   seq->V + ((size_t)idx[i] * seq->nv + rig->markers[j].vertex) * 3, 3 * sizeof(float));
            mk->valid[(size_t)i * mk->count + j] = 1;
        }
    if ((c3d ? mdl_markers_write_c3d : mdl_markers_write_csv)(outp, mk, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    fprintf(stderr, "meshsteer markers: %s: %d frames of %d markers at %g Hz\n", outp, n,
            rig->nmarkers, mk->fps);
    status = CLI_EXIT_OK;
out:
    free(idx);
    mdl_markers_destroy(mk);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    return status;
}
