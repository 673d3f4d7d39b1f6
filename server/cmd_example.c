/* cmd_example.c - `meshsteer example`: writes the built-in example (model/example.c) as files a user
 * can open and feed back to the other commands:
 *   DIR/mesh/0000.obj ...   the walk sequence (training mesh frames)
 *   DIR/rig.json            its rig (DESIGN.md "The rig file")
 *   DIR/markers.csv         a marker recording of a trot of the same creature
 *   DIR/truth/0000.obj ...  the trot's ground-truth mesh frames, for measuring synthesis error */
#include "cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define CMD "example"

static void example_usage(FILE *f)
{
    fprintf(f, "usage: meshsteer example -o DIR [--frames N] [--speed S]\n\n"
               "Writes the built-in example creature: DIR/mesh/NNNN.obj (a walk), DIR/rig.json,\n"
               "DIR/markers.csv (a trot of the same creature) and DIR/truth/NNNN.obj (the trot's\n"
               "ground-truth meshes).\n\n"
               "  -o DIR       output directory (created if missing)\n"
               "  --frames N   frames of the walk and of the trot (default 120)\n"
               "  --speed S    trot cycle rate relative to the walk (default 1.3)\n");
}

static int make_dir(const char *path)
{
    if (mkdir(path, 0777) == 0 || errno == EEXIST) {
        struct stat st;
        if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
            return 0;
        errno = ENOTDIR;
    }
    return cli_fail(CMD, CLI_EXIT_USAGE, "%s: cannot create directory: %s", path, strerror(errno));
}

static void json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\')
            fprintf(f, "\\%c", ch);
        else if (ch < 0x20)
            fprintf(f, "\\u%04x", ch);
        else
            fputc(ch, f);
    }
    fputc('"', f);
}

static int write_rig(const char *path, const mdl_rig *r)
{
    FILE *f = fopen(path, "w");
    if (!f)
        return cli_fail(CMD, CLI_EXIT_USAGE, "%s: cannot create: %s", path, strerror(errno));
    fprintf(f, "{\n  \"markers\": [\n");
    for (int m = 0; m < r->nmarkers; m++) {
        fprintf(f, "    {\"name\": ");
        json_string(f, r->markers[m].name);
        fprintf(f, ", \"vertex\": %d, \"source\": ", r->markers[m].vertex);
        json_string(f, r->markers[m].source);
        fprintf(f, "}%s\n", m + 1 < r->nmarkers ? "," : "");
    }
    fprintf(f, "  ],\n  \"reference\": [");
    for (int k = 0; k < r->nref; k++) {
        json_string(f, r->markers[r->ref[k]].name);
        fprintf(f, "%s", k + 1 < r->nref ? ", " : "");
    }
    fprintf(f, "],\n  \"limbs\": [\n");
    for (int l = 0; l < r->nlimbs; l++) {
        fprintf(f, "    [");
        for (int k = r->limb_off[l]; k < r->limb_off[l + 1]; k++) {
            json_string(f, r->markers[r->limb_idx[k]].name);
            fprintf(f, "%s", k + 1 < r->limb_off[l + 1] ? ", " : "");
        }
        fprintf(f, "]%s\n", l + 1 < r->nlimbs ? "," : "");
    }
    fprintf(f, "  ]\n}\n");
    int bad = ferror(f);
    if (fclose(f) != 0 || bad)
        return cli_fail(CMD, CLI_EXIT_FAIL, "%s: write failed", path);
    return 0;
}

static int write_frames(const char *dir, const mdl_meshseq *s)
{
    int st = make_dir(dir);
    if (st)
        return st;
    char path[4096], err[MDL_ERR_LEN] = "";
    for (int f = 0; f < s->frames; f++) {
        snprintf(path, sizeof path, "%s/%04d.obj", dir, f);
        if (mdl_mesh_write_obj(path, s->V + (size_t)f * s->nv * 3, s->nv, s->F, s->nf, err) != 0)
            return cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
    }
    return 0;
}

int cmd_example(int argc, char **argv);

int cmd_example(int argc, char **argv)
{
    const char *dir = NULL;
    int frames = 120;
    double speed = 1.3;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            example_usage(stdout);
            return CLI_EXIT_OK;
        }
        if (i + 1 >= argc)
            return cli_usage_error(CMD, "%s: unknown option or missing value (see --help)", a);
        const char *v = argv[++i];
        if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            dir = v;
        else if (!strcmp(a, "--frames")) {
            if (cli_parse_int(CMD, a, v, &frames))
                return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--speed")) {
            if (cli_parse_double(CMD, a, v, &speed))
                return CLI_EXIT_USAGE;
        } else
            return cli_usage_error(CMD, "unknown option '%s' (see --help)", a);
    }
    if (!dir)
        return cli_usage_error(CMD, "-o DIR is required");
    if (frames < 1 || frames > 100000)
        return cli_usage_error(CMD, "--frames %d is outside 1..100000", frames);
    if (!(speed > 0 && speed <= 10))
        return cli_usage_error(CMD, "--speed %g is outside (0, 10]", speed);

    char err[MDL_ERR_LEN] = "", path[4096];
    mdl_meshseq *seq = NULL, *truth = NULL;
    mdl_rig *rig = NULL;
    mdl_markers *mk = NULL;
    int status = CLI_EXIT_FAIL;
    if (strlen(dir) > sizeof path - 32) {
        status = cli_usage_error(CMD, "-o: path too long");
        goto done;
    }
    if (mdl_example_create(frames, &seq, &rig, err) != 0 ||
        mdl_example_markers(rig, frames, speed, &mk, &truth, err) != 0) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
        goto done;
    }
    if ((status = make_dir(dir)) != 0)
        goto done;
    snprintf(path, sizeof path, "%s/mesh", dir);
    if ((status = write_frames(path, seq)) != 0)
        goto done;
    snprintf(path, sizeof path, "%s/truth", dir);
    if ((status = write_frames(path, truth)) != 0)
        goto done;
    snprintf(path, sizeof path, "%s/rig.json", dir);
    if ((status = write_rig(path, rig)) != 0)
        goto done;
    snprintf(path, sizeof path, "%s/markers.csv", dir);
    if (mdl_markers_write_csv(path, mk, err) != 0) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
        goto done;
    }
    printf("%s: %d frames of %d vertices, %d triangles; rig of %d markers; %d marker frames\n", dir,
           seq->frames, seq->nv, seq->nf, rig->nmarkers, mk->frames);
    status = CLI_EXIT_OK;
done:
    mdl_markers_destroy(mk);
    mdl_meshseq_destroy(truth);
    mdl_meshseq_destroy(seq);
    mdl_rig_destroy(rig);
    return status;
}
