/* cmd_render.c - `meshsteer render`: a contact sheet (PNG) of shaded frames of a mesh sequence,
 * optionally with marker positions drawn on top. One camera, fitted to the bounding box of all
 * selected frames, so that motion is visible between cells. Rendering: raster.c. */
#include "cli.h"
#include "raster.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CMD "render"
#define DEFAULT_FRAMES 12

static void render_usage(FILE *f)
{
    fprintf(f,
            "usage: meshsteer render --mesh PATH [--rest REST.obj] [--frames SPEC] [--cols N]\n"
            "                        [--size PX] [--markers FILE] [--model MODEL] -o SHEET.png\n\n"
            "Draws a contact sheet of shaded frames of a mesh sequence.\n\n"
            "  --mesh PATH      a directory of numbered OBJ frames, or a .pc2 point cache\n"
            "  --rest REST.obj  topology for a .pc2 cache\n"
            "  --frames SPEC    frames to draw: N, start:stop[:step] (default: %d evenly spaced)\n"
            "  --cols N         cells per row (default 4)\n"
            "  --size PX        cell width in pixels, height is 3/4 of it (default 256)\n"
            "  --markers FILE   a marker file (.c3d .trc .bvh .csv .amc); frame i of the sheet shows\n"
            "                   marker frame i of the mesh sequence's numbering\n"
            "  --model MODEL    a harmonic model of this mesh: its correspondence triangles drawn\n"
            "                   in one colour per group (template bone)\n"
            "  -o SHEET.png     output image\n",
            DEFAULT_FRAMES);
}

int cmd_render(int argc, char **argv);

/* a saturated colour per group, hues spread by the golden angle */
static void group_colour(int g, uint8_t c[3])
{
    double h = fmod(g * 137.508, 360.0) / 60.0, x = 1 - fabs(fmod(h, 2.0) - 1);
    double rgb[6][3] = {{1, x, 0}, {x, 1, 0}, {0, 1, x}, {0, x, 1}, {x, 0, 1}, {1, 0, x}};
    const double *p = rgb[(int)h % 6];
    for (int k = 0; k < 3; k++)
        c[k] = (uint8_t)(40 + 200 * p[k]);
}

int cmd_render(int argc, char **argv)
{
    const char *mesh = NULL, *rest = NULL, *spec = NULL, *markers_path = NULL, *out = NULL,
               *model_path = NULL;
    int cols = 4, size = 256;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            render_usage(stdout);
            return CLI_EXIT_OK;
        }
        if (i + 1 >= argc)
            return cli_usage_error(CMD, "%s: unknown option or missing value (see --help)", a);
        const char *v = argv[++i];
        if (!strcmp(a, "--mesh"))
            mesh = v;
        else if (!strcmp(a, "--rest"))
            rest = v;
        else if (!strcmp(a, "--frames"))
            spec = v;
        else if (!strcmp(a, "--markers"))
            markers_path = v;
        else if (!strcmp(a, "--model"))
            model_path = v;
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out = v;
        else if (!strcmp(a, "--cols")) {
            if (cli_parse_int(CMD, a, v, &cols))
                return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--size")) {
            if (cli_parse_int(CMD, a, v, &size))
                return CLI_EXIT_USAGE;
        } else
            return cli_usage_error(CMD, "unknown option '%s' (see --help)", a);
    }
    if (!mesh)
        return cli_usage_error(CMD, "--mesh is required");
    if (!out)
        return cli_usage_error(CMD, "-o SHEET.png is required");
    if (cols < 1 || cols > 64)
        return cli_usage_error(CMD, "--cols %d is outside 1..64", cols);
    if (size < 32 || size > 4096)
        return cli_usage_error(CMD, "--size %d is outside 32..4096", size);

    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_FAIL, rc;
    mdl_meshseq *seq = NULL;
    mdl_markers *mk = NULL;
    srv_raster *r = NULL;
    mdl_model *model = NULL;
    int *idx = NULL, n = 0;
    uint32_t *cf = NULL; /* --model: the correspondence triangles, ordered by group */
    int *goff = NULL, ngroups = 0;

    if ((rc = mdl_meshseq_read(mesh, rest, &seq, err)) != 0) {
        status = cli_fail(CMD, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
        goto done;
    }
    if (spec) {
        if ((rc = mdl_parse_frames(spec, seq->frames, &idx, &n, err)) != 0) {
            status = cli_usage_error(CMD, "--frames: %s", err);
            goto done;
        }
    } else {
        n = seq->frames < DEFAULT_FRAMES ? seq->frames : DEFAULT_FRAMES;
        idx = malloc((size_t)(n > 0 ? n : 1) * sizeof *idx);
        if (!idx) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "out of memory");
            goto done;
        }
        for (int i = 0; i < n; i++)
            idx[i] = n > 1 ? (int)((long long)i * (seq->frames - 1) / (n - 1)) : 0;
    }
    if (n < 1) {
        status = cli_usage_error(CMD, "no frames selected");
        goto done;
    }
    if (n > 4096) {
        status = cli_usage_error(CMD, "%d frames selected; a sheet holds at most 4096", n);
        goto done;
    }
    if (markers_path) {
        if ((rc = mdl_markers_read(markers_path, NULL, &mk, err)) != 0) {
            status = cli_fail(CMD, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
            goto done;
        }
    }

    if (model_path) {
        const int *ct, *cg;
        int nc;
        if ((rc = mdl_model_load(model_path, &model, err)) != 0 ||
            (rc = mdl_harmonic_correspondences(model, &ct, &cg, &nc, &ngroups)) != 0) {
            status = cli_fail(CMD, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s",
                              err[0] ? err : "--model: not a harmonic model");
            goto done;
        }
        cf = malloc(3 * (size_t)nc * sizeof *cf + 1);
        goff = calloc((size_t)ngroups + 1, sizeof *goff);
        if (!cf || !goff) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "out of memory");
            goto done;
        }
        for (int k = 0; k < nc; k++)
            goff[cg[k] + 1]++;
        for (int g = 0; g < ngroups; g++)
            goff[g + 1] += goff[g];
        for (int k = 0, *at = goff; k < nc; k++) {
            if (ct[k] >= seq->nf) {
                status = cli_usage_error(CMD, "--model %s: triangle %d is not in --mesh (%d "
                                         "triangles)", model_path, ct[k], seq->nf);
                goto done;
            }
            memcpy(cf + 3 * (size_t)at[cg[k]]++, seq->F + 3 * (size_t)ct[k], 3 * sizeof *cf);
        }
        for (int g = ngroups; g > 0; g--)
            goff[g] = goff[g - 1];
        goff[0] = 0;
    }

    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < n; i++)
        srv_bbox_extend(lo, hi, seq->V + (size_t)idx[i] * seq->nv * 3, seq->nv);
    int c = n < cols ? n : cols, rows = (n + c - 1) / c, cw = size, ch = size * 3 / 4;
    srv_camera cam;
    if (srv_camera_fit(&cam, lo, hi, cw, ch, 15.0f, 0.04f) != 0) {
        status = cli_usage_error(CMD, "%s: the selected frames have no finite extent", mesh);
        goto done;
    }
    if ((rc = srv_raster_create(c, rows, cw, ch, seq->nv, &r, err)) != 0) {
        status = cli_fail(CMD, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
        goto done;
    }
    static const uint8_t bg[3] = {255, 255, 255}, body[3] = {214, 186, 150}, ink[3] = {40, 40, 40},
                         marker[3] = {220, 30, 30};
    srv_raster_clear(r, bg);
    int scale = size >= 192 ? 2 : 1;
    for (int i = 0; i < n; i++) {
        const float *V = seq->V + (size_t)idx[i] * seq->nv * 3;
        /* correspondences first: the body's same triangles then fail the strict depth test */
        for (int g = 0; g < ngroups; g++) {
            uint8_t col[3];
            group_colour(g, col);
            if ((rc = srv_raster_draw_mesh(r, i, &cam, V, seq->nv, cf + 3 * (size_t)goff[g],
                                           goff[g + 1] - goff[g], col, err)) != 0) {
                status = cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
                goto done;
            }
        }
        if ((rc = srv_raster_draw_mesh(r, i, &cam, V, seq->nv, seq->F, seq->nf, body, err)) != 0) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
            goto done;
        }
        if (mk && idx[i] < mk->frames)
            srv_raster_draw_points(r, i, &cam, mk->P + (size_t)idx[i] * mk->count * 3,
                                   mk->valid + (size_t)idx[i] * mk->count, mk->count,
                                   size >= 192 ? 3 : 2, marker);
        char label[16];
        snprintf(label, sizeof label, "%d", idx[i]);
        srv_raster_draw_text(r, i, 3 * scale, 3 * scale, label, scale, ink);
    }
    if ((rc = srv_raster_write_png(r, out, err)) != 0) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
        goto done;
    }
    status = CLI_EXIT_OK;
done:
    free(idx);
    free(cf);
    free(goff);
    mdl_model_destroy(model);
    srv_raster_destroy(r);
    mdl_markers_destroy(mk);
    mdl_meshseq_destroy(seq);
    return status;
}
