/* cmd_rig.c - `meshsteer rig`: a rig proposed from the mesh alone (issue 12): markers, reference
 * edge and limbs from the geodesic extremities of one frame (model/steer/rig_propose.c), or each
 * marker's medoid over several frames (the default for a sequence: DEFAULT_FRAMES below), written
 * as the rig JSON of docs/FORMATS.md, and optionally a sheet that draws them over the mesh from
 * the front and from the side (raster.c). */
#include "cli.h"
#include "cli_markers.h"
#include "raster.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A sequence's rig by default: the medoid over this many frames at most, spread evenly. One frame
 * alone gives a rig whose trunk markers move 7-13 cm with the pose (docs/MODEL.md "A rig proposed
 * from the mesh"); the medoid over every 10th frame of samba, pjump and horse-gallop lands within
 * 0.006-0.030 of the height whichever frames are taken (tests/model/steer/test_rig_propose.c).
 * When most of those frames are refused (pcow falls and rolls over: 6 of 23 proposed), the first
 * frame alone. */
#define DEFAULT_FRAMES 24

static const char usage_text[] =
    "usage: meshsteer rig --mesh REST.obj|SEQ [--rest REST.obj] [--frame K | --frames SPEC]\n"
    "                     [--body human|quadruped|auto] [--up AXIS] -o RIG.json [--sheet RIG.png]\n"
    "\n"
    "Proposes a rig (markers, reference edge, limbs) from the mesh alone: the geodesic extremities\n"
    "of the surface, named by the up axis and the body's left-right symmetry.\n"
    "  human:     head, lhand, rhand, lfoot, rfoot (the depth tracker's labels), pelvis, neck;\n"
    "             reference pelvis -> neck. Left/right: people face where their toes point.\n"
    "  quadruped: withers, croup, lf_hoof, rf_hoof, lh_hoof, rh_hoof, muzzle, tail;\n"
    "             reference croup -> withers. The head is the thicker end.\n"
    "\n"
    "  --mesh PATH     one OBJ, a directory of numbered OBJ frames, or a .pc2 point cache\n"
    "  --rest REST.obj topology for a .pc2 cache\n"
    "  --frame K       propose from this one frame of a sequence\n"
    "  --frames SPEC   propose from each of these frames (START:STOP:STEP, or a list) and take\n"
    "                  each marker's medoid over them: a rig that does not depend on one pose.\n"
    "                  Default for a sequence: up to %d frames spread evenly over it\n"
    "                  (0:N:ceil(N/%d)), or frame 0 alone when most of them are refused;\n"
    "                  for one OBJ, that mesh\n"
    "  --body B        human, quadruped or auto (default: auto, a quadruped when four of the\n"
    "                  extremities are near the ground)\n"
    "  --up AXIS       the mesh's up axis: x, y, z, -x, -y, -z (default y)\n"
    "  -o RIG.json     the proposed rig\n"
    "  --sheet PNG     draw the markers and limbs over the mesh, from the front and the side\n";

/* An orthographic view with the given basis, fitted to the vertices. */
static void fit_view(srv_camera *c, const float *V, int nv, const float right[3], const float up[3],
                     const float fwd[3], int w, int h)
{
    memcpy(c->right, right, sizeof c->right);
    memcpy(c->up, up, sizeof c->up);
    memcpy(c->fwd, fwd, sizeof c->fwd);
    float lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < nv; i++) {
        const float *p = V + 3 * (size_t)i;
        float x = p[0] * right[0] + p[1] * right[1] + p[2] * right[2];
        float y = p[0] * up[0] + p[1] * up[1] + p[2] * up[2];
        lo[0] = fminf(lo[0], x), hi[0] = fmaxf(hi[0], x);
        lo[1] = fminf(lo[1], y), hi[1] = fmaxf(hi[1], y);
    }
    float cx = 0.5f * (lo[0] + hi[0]), cy = 0.5f * (lo[1] + hi[1]);
    for (int k = 0; k < 3; k++)
        c->center[k] = cx * right[k] + cy * up[k];
    float sx = (hi[0] > lo[0]) ? 0.9f * (float)w / (hi[0] - lo[0]) : INFINITY;
    float sy = (hi[1] > lo[1]) ? 0.9f * (float)h / (hi[1] - lo[1]) : INFINITY;
    c->scale = fminf(sx, sy);
    if (!isfinite(c->scale))
        c->scale = 1;
    c->w = w;
    c->h = h;
}

/* The proposal over the mesh in two cells (front, side): limbs as dotted lines, markers as discs,
 * left markers blue, right red, the rest green. */
static int draw_sheet(const char *path, const float *V, int nv, const uint32_t *F, int nf,
                      const float up[3], const mdl_rig *rig, const mdl_rig_proposal *info,
                      char *err)
{
    enum { CELL = 480, DOTS = 24 };
    srv_raster *r = NULL;
    int rc = srv_raster_create(2, 1, CELL, CELL, nv, &r, err);
    if (rc)
        return rc;
    static const uint8_t bg[3] = {255, 255, 255}, body[3] = {214, 186, 150},
                         limb[3] = {40, 40, 40}, lc[3] = {30, 80, 220}, rc_[3] = {220, 30, 30},
                         mc[3] = {20, 150, 40};
    srv_raster_clear(r, bg);
    const float *f = info->forward, *l = info->left;
    float negf[3] = {-f[0], -f[1], -f[2]};
    srv_camera cam[2];
    fit_view(&cam[0], V, nv, l, up, negf, CELL, CELL); /* facing the viewer: her left on the right */
    fit_view(&cam[1], V, nv, f, up, l, CELL, CELL);    /* from her right side: forward to the right */
    for (int c = 0; c < 2 && rc == 0; c++) {
        if ((rc = srv_raster_draw_mesh(r, c, &cam[c], V, nv, F, nf, body, err)) != 0)
            break;
        for (int li = 0; li < rig->nlimbs; li++)
            for (int k = rig->limb_off[li]; k + 1 < rig->limb_off[li + 1]; k++) {
                const float *a = V + 3 * (size_t)rig->markers[rig->limb_idx[k]].vertex,
                            *b = V + 3 * (size_t)rig->markers[rig->limb_idx[k + 1]].vertex;
                float P[3 * DOTS];
                for (int d = 0; d < DOTS; d++)
                    for (int q = 0; q < 3; q++)
                        P[3 * d + q] = a[q] + (b[q] - a[q]) * (float)d / (DOTS - 1);
                srv_raster_draw_points(r, c, &cam[c], P, NULL, DOTS, 1, limb);
            }
        for (int i = 0; i < rig->nmarkers; i++) {
            const char *n = rig->markers[i].name;
            const uint8_t *col = n[0] == 'l' && n[1] != 'i' ? lc : n[0] == 'r' ? rc_ : mc;
            srv_raster_draw_points(r, c, &cam[c], V + 3 * (size_t)rig->markers[i].vertex, NULL, 1,
                                   5, col);
        }
    }
    if (rc == 0)
        rc = srv_raster_write_png(r, path, err);
    srv_raster_destroy(r);
    return rc;
}

int cmd_rig(int argc, char **argv)
{
    const char *cmd = "rig", *mesh = NULL, *rest = NULL, *outp = NULL, *sheet = NULL,
               *frames_spec = NULL;
    int frame = 0, frame_given = 0, body = MDL_BODY_AUTO, upax = MDL_UP_Y;
    char default_spec[48];
    enum { O_MESH = 256, O_REST, O_FRAME, O_FRAMES, O_BODY, O_UP, O_SHEET };
    static const struct option lo[] = {{"mesh", 1, 0, O_MESH},   {"rest", 1, 0, O_REST},
                                       {"frame", 1, 0, O_FRAME}, {"body", 1, 0, O_BODY},
                                       {"up", 1, 0, O_UP},       {"sheet", 1, 0, O_SHEET},
                                       {"output", 1, 0, 'o'},    {"help", 0, 0, 'h'},
                                       {"frames", 1, 0, O_FRAMES},
                                       {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:h", lo, NULL)) != -1) {
        switch (c) {
        case O_MESH: mesh = optarg; break;
        case O_REST: rest = optarg; break;
        case O_FRAME:
            if (cli_parse_int(cmd, "--frame", optarg, &frame))
                return CLI_EXIT_USAGE;
            frame_given = 1;
            break;
        case O_BODY:
            if (!strcmp(optarg, "human"))
                body = MDL_BODY_HUMAN;
            else if (!strcmp(optarg, "quadruped"))
                body = MDL_BODY_QUADRUPED;
            else if (!strcmp(optarg, "auto"))
                body = MDL_BODY_AUTO;
            else
                return cli_usage_error(cmd, "--body %s: use human, quadruped or auto", optarg);
            break;
        case O_UP:
            upax = cli_parse_up(optarg);
            if (upax < 0 || upax == MDL_UP_AUTO)
                return cli_usage_error(cmd, "--up %s: use x, y, z, -x, -y or -z", optarg);
            break;
        case O_SHEET: sheet = optarg; break;
        case O_FRAMES: frames_spec = optarg; break;
        case 'o': outp = optarg; break;
        case 'h': printf(usage_text, DEFAULT_FRAMES, DEFAULT_FRAMES); return CLI_EXIT_OK;
        default: fprintf(stderr, usage_text, DEFAULT_FRAMES, DEFAULT_FRAMES); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (!mesh || !outp)
        return cli_usage_error(cmd, "--mesh and -o are required (see --help)");
    if (frame < 0)
        return cli_usage_error(cmd, "--frame %d is negative", frame);
    if (frames_spec && frame_given)
        return cli_usage_error(cmd, "give --frame or --frames, not both");
    float up[3] = {0, 0, 0};
    int axis = (upax - MDL_UP_X) % 3;
    up[axis] = upax >= MDL_UP_NEG_X ? -1.0f : 1.0f;

    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE, rc;
    mdl_meshseq *seq = NULL;
    mdl_mesh *one = NULL;
    mdl_rig *rig = NULL;
    int *idx = NULL, nidx = 0, nused = 1;
    float *fr = NULL; /* the --frames, contiguous: nidx x nv x 3 */
    const float *V;
    const uint32_t *F;
    int nv, nf;
    if (cli_has_suffix(mesh, ".obj")) {
        if ((rc = mdl_mesh_read_obj(mesh, &one, err)) != 0) {
            status = cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
            goto out;
        }
        if (frame != 0 || frames_spec) {
            status = cli_usage_error(cmd, "--frame%s: %s is one mesh (frame 0)",
                                     frames_spec ? "s" : "", mesh);
            goto out;
        }
        V = one->V, F = one->F, nv = one->nv, nf = one->nf;
    } else {
        if ((rc = mdl_meshseq_read(mesh, rest, &seq, err)) != 0) {
            status = cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s", err);
            goto out;
        }
        if (frame >= seq->frames) {
            status = cli_usage_error(cmd, "--frame %d: %s has %d frames", frame, mesh, seq->frames);
            goto out;
        }
        V = seq->V + (size_t)frame * seq->nv * 3, F = seq->F, nv = seq->nv, nf = seq->nf;
        if (!frames_spec && !frame_given && seq->frames > 1) { /* the default: see the header */
            int n = seq->frames, step = (n + DEFAULT_FRAMES - 1) / DEFAULT_FRAMES;
            snprintf(default_spec, sizeof default_spec, "0:%d:%d", n, step);
            frames_spec = default_spec;
            fprintf(stderr,
                    "rig: %s has %d frames: proposing from each of %d (--frames %s) and taking "
                    "each marker's medoid (--frame K proposes from one)\n",
                    mesh, n, (n + step - 1) / step, frames_spec);
        }
    }
    if (frames_spec) {
        if ((rc = mdl_parse_frames(frames_spec, seq->frames, &idx, &nidx, err)) != 0) {
            status = cli_usage_error(cmd, "--frames %s: %s", frames_spec, err);
            goto out;
        }
        if (!(fr = malloc((size_t)nidx * nv * 3 * sizeof *fr))) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
            goto out;
        }
        for (int k = 0; k < nidx; k++)
            memcpy(fr + (size_t)k * nv * 3, seq->V + (size_t)idx[k] * nv * 3,
                   (size_t)nv * 3 * sizeof *fr);
        frame = idx[0];
        V = fr; /* the first of the frames: the sheet and the medoids are drawn in it */
    }
    mdl_rig_proposal info;
    rc = frames_spec
             ? mdl_rig_propose_frames(fr, nv, nidx, idx, F, nf, up, body, &rig, &info, &nused, err)
             : mdl_rig_propose(V, nv, F, nf, up, body, &rig, &info, err);
    if (rc == -EINVAL && frames_spec == default_spec) {
        /* most frames refused (a body that lies down or rolls over, pcow): its first frame alone,
           which still refuses a wrong --up */
        fprintf(stderr, "rig: %s: frames %s: %s; proposing from frame 0 alone\n", mesh,
                frames_spec, err);
        frames_spec = NULL;
        frame = 0;
        V = seq->V;
        rc = mdl_rig_propose(V, nv, F, nf, up, body, &rig, &info, err);
    }
    if (rc != 0) {
        if (frames_spec)
            status = cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE,
                              "%s: frames %s: %s", mesh, frames_spec, err);
        else
            status = cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE,
                              "%s: frame %d: %s", mesh, frame, err);
        goto out;
    }
    char comment[1024], fbuf[16], nbuf[48] = "";
    snprintf(fbuf, sizeof fbuf, "%d", frame);
    if (frames_spec)
        snprintf(nbuf, sizeof nbuf, ", %d of %d frames proposed", nused, nidx);
    snprintf(comment, sizeof comment,
             "Proposed by 'meshsteer rig' from %s, %s%s (%d vertices%s): a %s, up (%g, %g, %g), "
             "facing (%.2f, %.2f, %.2f), left (%.2f, %.2f, %.2f); %d geodesic extremities from "
             "vertex %d. Check it on the sheet (--sheet) before training.",
             mesh, frames_spec ? "the medoid over frames " : "frame ",
             frames_spec ? frames_spec : fbuf, nv, nbuf, info.body == MDL_BODY_HUMAN ? "human" : "quadruped", up[0], up[1],
             up[2], info.forward[0], info.forward[1], info.forward[2], info.left[0], info.left[1],
             info.left[2], info.ntips, info.centre);
    if ((rc = mdl_rig_write(outp, rig, comment, err)) != 0) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    if (sheet && (rc = draw_sheet(sheet, V, nv, F, nf, up, rig, &info, err)) != 0) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "--sheet %s: %s", sheet, err);
        goto out;
    }
    fprintf(stderr, "meshsteer rig: %s: a %s (fourth-lowest extremity at %.2f of the height), %d "
            "markers:", outp, info.body == MDL_BODY_HUMAN ? "human" : "quadruped",
            info.fourth_lowest, rig->nmarkers);
    for (int i = 0; i < rig->nmarkers; i++)
        fprintf(stderr, " %s=%d", rig->markers[i].name, rig->markers[i].vertex);
    fprintf(stderr, "; extremities (farthest first):");
    for (int i = 0; i < info.ntips; i++)
        fprintf(stderr, " %d", info.tips[i]);
    fputc('\n', stderr);
    status = CLI_EXIT_OK;
out:
    mdl_rig_destroy(rig);
    free(idx);
    free(fr);
    mdl_mesh_destroy(one);
    mdl_meshseq_destroy(seq);
    return status;
}
