/* cmd_render.c - `meshsteer render`: a contact sheet (PNG) of shaded frames of a mesh sequence,
 * optionally with marker positions drawn on top, or coloured by the bones of a skin (issue 10:
 * each bone a colour, each vertex the weight blend of its bones' colours, so the regions a bone
 * moves show, and their soft borders). One camera, fitted to the bounding box of all selected
 * frames, so that motion is visible between cells. Rendering: raster.c; colours: bone_colours.c. */
#include "bone_colours.h"
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
            "                        [--size PX] [--markers FILE] [--skin SKIN.msm] [--model MODEL]\n"
            "                        -o SHEET.png\n\n"
            "Draws a contact sheet of shaded frames of a mesh sequence.\n\n"
            "  --mesh PATH      a directory of numbered OBJ frames, or a .pc2 point cache\n"
            "  --rest REST.obj  topology for a .pc2 cache\n"
            "  --frames SPEC    frames to draw: N, start:stop[:step] (default: %d evenly spaced)\n"
            "  --cols N         cells per row (default 4)\n"
            "  --size PX        cell width in pixels, height is 3/4 of it (default 256)\n"
            "  --markers FILE   a marker file (.c3d .trc .bvh .csv .amc); frame i of the sheet shows\n"
            "                   marker frame i of the mesh sequence's numbering\n"
            "  --skin SKIN.msm  colour by the bones of the skin in this model file (meshsteer skin;\n"
            "                   same vertices as the mesh): each bone its own colour, each vertex\n"
            "                   the weight blend of its bones' colours\n"
            "  --model MODEL    a harmonic model of this mesh: its correspondence triangles drawn\n"
            "                   in one colour per group (template bone)\n"
            "  -o SHEET.png     output image\n",
            DEFAULT_FRAMES);
}

int cmd_render(int argc, char **argv);

/* Per-vertex colours (nv x 3) from the skin in model file `path`; 0 or an exit status. */
static int skin_colours(const char *path, int nv, uint8_t **out)
{
    char err[MDL_ERR_LEN] = "";
    mdl_model *m = NULL;
    int rc = mdl_model_load(path, &m, err);
    if (rc != 0)
        return cli_fail(CMD, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
    int nb, K, nframes, status = CLI_EXIT_OK;
    const int *bone;
    const double *w, *T;
    mdl_skin_stats st;
    if (mdl_skin_get(m, &nb, &K, &nframes, &bone, &w, &T) != 0 || mdl_skin_get_stats(m, &st) != 0)
        status = cli_usage_error(CMD, "--skin %s: the model holds no skin (see meshsteer skin)", path);
    else if (st.vertices != nv)
        status = cli_usage_error(CMD, "--skin %s: the skin has %d vertices, the mesh %d", path,
                                 st.vertices, nv);
    else if (!(*out = malloc((size_t)nv * 3)))
        status = cli_fail(CMD, CLI_EXIT_FAIL, "out of memory");
    if (status == CLI_EXIT_OK)
        srv_skin_vertex_colours(nv, K, bone, w, *out);
    mdl_model_destroy(m);
    return status;
}

/* group g's colour for --model: the bone colours of --skin (one scheme for both sheets) */
static void group_colour(int g, uint8_t c[3])
{
    float rgb[3];
    srv_bone_colour(g, rgb);
    for (int k = 0; k < 3; k++)
        c[k] = (uint8_t)(255.0f * rgb[k] + 0.5f);
}

int cmd_render(int argc, char **argv)
{
    const char *mesh = NULL, *rest = NULL, *spec = NULL, *markers_path = NULL, *out = NULL,
               *skin_path = NULL, *model_path = NULL;
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
        else if (!strcmp(a, "--skin"))
            skin_path = v;
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
    uint8_t *vertex_rgb = NULL;
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
    if (skin_path && (status = skin_colours(skin_path, seq->nv, &vertex_rgb)) != CLI_EXIT_OK)
        goto done;
    status = CLI_EXIT_FAIL;
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
        rc = vertex_rgb ? srv_raster_draw_mesh_coloured(r, i, &cam, V, seq->nv, seq->F, seq->nf,
                                                        vertex_rgb, err)
                        : srv_raster_draw_mesh(r, i, &cam, V, seq->nv, seq->F, seq->nf, body, err);
        if (rc != 0) {
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
    free(vertex_rgb);
    free(idx);
    free(cf);
    free(goff);
    mdl_model_destroy(model);
    srv_raster_destroy(r);
    mdl_markers_destroy(mk);
    mdl_meshseq_destroy(seq);
    return status;
}
