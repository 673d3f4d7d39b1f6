/* cmd_depth_eval.c - `meshsteer depth-eval`: renders a mesh sequence with the test camera
 * (drivers/depth.h, render.c), runs depth -> markers (drivers/depth.h, markers.c) on every
 * frame and compares the extracted head/hands/feet with the rig's ground-truth vertices.
 *
 * Scene: the floor is the lowest vertex of the sequence; the person's horizontal centroid stands
 * DISTANCE metres in front of the camera (camera 1.0 m high, pitched 2 degrees down) - in every
 * frame by default, since a dancer travelling 1.8 m towards the camera (samba) would leave the
 * Kinect's 43 degree vertical field of view; --travel keeps that travel, centred on DISTANCE -
 * facing it: the facing direction is (L - R) x up with L, R the means of the rig's left and right
 * hand/foot markers in the first frame; then the person is turned by YAW degrees. A performer who
 * turns on her own is seen from other angles than YAW in later frames (samba turns by 40 degrees
 * towards her last frames: her -20 degree row reaches -60); --hold-facing turns each frame back by
 * its torso's own turn (torso_turns, smooth_turns), so that YAW is the torso's angle to the camera
 * in every frame. Either way the report gives the range of that own turn.
 * Scores: within_10cm[kind] = the fraction of ground-truth extremities of that kind (head; lhand,
 * rhand; lfoot, rfoot) inside the image (out_of_view counts the others) with an extracted marker of
 * the same kind (either side; found, whether its side is certain or not) within 10 cm;
 * side_correct = the fraction of hands and feet whose same-side marker is reported valid (found,
 * its side certain: drv_depth_result.side_uncertain) and within 10 cm; side_uncertain = the
 * fraction whose same-side marker was found with its side uncertain; side_wrong = of the hands and
 * feet reported valid, the fraction that lie more than 10 cm from their own side's ground truth and
 * within 10 cm of the other side's (a confident swap). wrong_reports[kind] = of the markers of that
 * kind reported (found), the fraction with no ground truth of the kind within 10 cm (also when it
 * is out of view: a confident marker where there is none); confident_wrong[kind] = the same, of
 * the markers reported valid (what a consumer takes for a measurement). hidden_hands: hands inside
 * the image whose pixel shows a surface more than HIDDEN_BEHIND nearer than the hand (behind the
 * body); of them, the fraction found within 10 cm (predicted), the fraction whose same-label
 * marker is reported inferred (drv_depth_result.inferred: not valid) and the fraction with no
 * same-label marker (marked missing). Errors are distances to the nearest extracted marker of the same kind (a
 * missing marker counts as infinite and is left out of the error percentiles). Times are those of
 * drv_depth_tracker_process alone.
 * Lists of yaws and distances (--yaw -35,0,35 --distance 2,2.5) run every placement in turn, each
 * with a fresh tracker, one report per placement (a table row, or one JSON object per line). */
#include "cli.h"

#include "depth.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const char *CMD = "depth-eval";

#define MAX_PLACEMENTS 16 /* values per list of --yaw and --distance */
#define HIDDEN_BEHIND 0.08f /* metres: a hand this far behind the surface its pixel shows */
/* The trunk band whose turn is the torso's: from the hip joint (0.530 of the standing height) to
 * the chest (0.720), Drillis & Contini's segment proportions, as a fraction of the first frame's
 * height above its lowest vertex. */
#define TRUNK_FROM 0.53
#define TRUNK_TO 0.72
/* metres: the residual of the trunk fit at which a vertex's weight halves (an arm or a skirt
 * crossing the band moves by more than this against the trunk) */
#define TRUNK_RESIDUAL 0.03
/* seconds: the torso's turn is averaged over this window, centred on the frame, before it is
 * undone - one gait cycle (a stride, ~1.0-1.1 s at a walk, Inman et al.), so that the pelvis'
 * swing with every stride (+-16 degrees on the SMPL run) and a dancer's hip sway stay in the
 * image and only the performer's slower turns (samba's 40 degrees) are undone */
#define TURN_WINDOW 1.0

static void help(void)
{
    printf("usage: meshsteer depth-eval --mesh PATH [--rest REST.obj] --rig RIG.json [--frames SPEC]\n"
           "                            [--distance M[,M..]] [--yaw DEG[,DEG..]] [--fps F] [--step N]\n"
           "                            [--no-smooth] [--travel] [--hold-facing] [--per-frame]\n"
           "                            [--dump-depth FILE] [--json]\n\n"
           "Renders the mesh sequence as Kinect v1 depth (the test camera), extracts head, hand and\n"
           "foot markers from every frame and scores them against the rig markers named head,\n"
           "lhand, rhand, lfoot, rfoot.\n\n"
           "  --mesh PATH      a .pc2 point cache (needs --rest) or a directory of OBJ frames\n"
           "  --rest OBJ       topology of a .pc2\n"
           "  --rig JSON       the rig (DESIGN.md format)\n"
           "  --frames SPEC    start:stop[:step] of the sequence (default all)\n"
           "  --distance M     metres from the camera to the person (default 2.5); a comma-separated\n"
           "                   list (up to %d) scores each distance in turn\n"
           "  --yaw DEG        turn the person away from facing the camera (default 0); a list as\n"
           "                   for --distance: every yaw at every distance (the grid). It turns\n"
           "                   the first frame; the performer's own turns add to it\n"
           "  --fps F          frame rate when the file has none (default 30)\n"
           "  --step N         a fixed tracker grid of N-pixel cells (default: sized by the\n"
           "                   person's distance, 4 pixels at 2.5 m)\n"
           "  --no-smooth      score the unfiltered markers\n"
           "  --travel         keep the performer's travel towards/away from the camera (default:\n"
           "                   each frame's centroid is held at --distance; sideways travel is kept)\n"
           "  --hold-facing    undo the performer's own turns (the torso's turn, averaged over 1 s):\n"
           "                   every frame's torso is at --yaw to the camera\n"
           "  --per-frame      print one line per frame: each ground-truth marker's error to the\n"
           "                   same-label extracted marker (cm, '-' = none, '?' after it = side\n"
           "                   uncertain, '~' = inferred, 'o' = out of view, 'h' = hidden behind\n"
           "                   the body) and the\n"
           "                   extrema with their labels (diagnostics, before the summary)\n"
           "  --dump-depth FILE  write every rendered frame to FILE as raw 640x480 little-endian\n"
           "                   uint16 millimetres, frame after frame (for offline debugging)\n"
           "  --json           print one JSON object per placement (otherwise a short table)\n\n"
           "Scores (one placement): within_10cm per kind (head, hand, foot: a marker of the kind,\n"
           "either side, within 10 cm of the ground truth in view), side_correct (the same side's\n"
           "marker reported valid - its side certain - and within 10 cm), side_uncertain,\n"
           "side_wrong (confident swaps), wrong_reports (markers reported where no ground truth\n"
           "of the kind is within 10 cm), confident_wrong (the same, of the markers reported\n"
           "valid), hidden_hands (hands behind the body: how many, how many predicted within\n"
           "10 cm, how many reported inferred - not valid - and how many marked missing).\n",
           MAX_PLACEMENTS);
}

static int cmpd(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double pct(double *v, int n, double q)
{
    if (n == 0)
        return NAN;
    qsort(v, (size_t)n, sizeof *v, cmpd);
    return v[(int)(q * (n - 1) + 0.5)];
}

static float dist3(const float *a, const float *b)
{
    float x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return sqrtf(x * x + y * y + z * z);
}

static void jnum(const char *key, double v, int comma)
{
    if (isfinite(v))
        printf("\"%s\": %.4f%s", key, v, comma ? ", " : "");
    else
        printf("\"%s\": null%s", key, comma ? ", " : "");
}

static double ratio(int a, int b)
{
    return b ? (double)a / b : NAN;
}

/* ------------------------------------------------------------------ the steps */

typedef struct de_args {
    const char *mesh, *rest, *rig, *frames, *dump;
    double distance[MAX_PLACEMENTS], yaw_deg[MAX_PLACEMENTS], fps;
    int ndistance, nyaw;
    int json, smooth, step, travel, hold, per_frame;
} de_args;

/* A comma-separated list of numbers of option opt into v (at most MAX_PLACEMENTS); returns 0 or
 * the usage error's status. */
static int parse_list(const char *opt, const char *s, double *v, int *n)
{
    char buf[512];
    if (strlen(s) >= sizeof buf)
        return cli_usage_error(CMD, "%s: list too long", opt);
    strcpy(buf, s);
    *n = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (*n == MAX_PLACEMENTS)
            return cli_usage_error(CMD, "%s: more than %d values", opt, MAX_PLACEMENTS);
        if (cli_parse_double(CMD, opt, tok, &v[*n]))
            return CLI_EXIT_USAGE;
        (*n)++;
    }
    if (*n == 0)
        return cli_usage_error(CMD, "%s: no value in '%s'", opt, s);
    return 0;
}

/* Parses the command line into *o. Returns -1 to go on, otherwise the exit status (--help, a
 * usage error). */
static int parse_args(int argc, char **argv, de_args *o)
{
    *o = (de_args){.frames = ":", .distance = {2.5}, .ndistance = 1, .nyaw = 1, .fps = 30,
                   .smooth = 1};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            help();
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--json")) {
            o->json = 1;
        } else if (!strcmp(a, "--no-smooth")) {
            o->smooth = 0;
        } else if (!strcmp(a, "--travel")) {
            o->travel = 1;
        } else if (!strcmp(a, "--hold-facing")) {
            o->hold = 1;
        } else if (!strcmp(a, "--per-frame")) {
            o->per_frame = 1;
        } else if (!v) {
            return cli_usage_error(CMD, "unknown option or missing value: %s", a);
        } else if (!strcmp(a, "--mesh")) {
            o->mesh = v, i++;
        } else if (!strcmp(a, "--dump-depth")) {
            o->dump = v, i++;
        } else if (!strcmp(a, "--rest")) {
            o->rest = v, i++;
        } else if (!strcmp(a, "--rig")) {
            o->rig = v, i++;
        } else if (!strcmp(a, "--frames")) {
            o->frames = v, i++;
        } else if (!strcmp(a, "--distance")) {
            if (parse_list(a, v, o->distance, &o->ndistance))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--yaw")) {
            if (parse_list(a, v, o->yaw_deg, &o->nyaw))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--fps")) {
            if (cli_parse_double(CMD, a, v, &o->fps))
                return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--step")) {
            if (cli_parse_int(CMD, a, v, &o->step))
                return CLI_EXIT_USAGE;
            i++;
        } else {
            return cli_usage_error(CMD, "unknown option %s", a);
        }
    }
    if (!o->mesh || !o->rig)
        return cli_usage_error(CMD, "--mesh and --rig are required (see --help)");
    for (int k = 0; k < o->ndistance; k++)
        if (!(o->distance[k] >= 0.8 && o->distance[k] <= 4.5))
            return cli_usage_error(CMD, "--distance %g: the Kinect sees 0.8 .. 4.5 m",
                                   o->distance[k]);
    for (int k = 0; k < o->nyaw; k++)
        if (!(fabs(o->yaw_deg[k]) <= 180))
            return cli_usage_error(CMD, "--yaw %g: must be in [-180, 180]", o->yaw_deg[k]);
    if (!(o->fps > 0 && o->fps <= 1000))
        return cli_usage_error(CMD, "--fps %g: must be in (0, 1000]", o->fps);
    if (o->step && (o->step < 1 || o->step > 16))
        return cli_usage_error(CMD, "--step %d: must be 1 .. 16", o->step);
    if (o->dump && o->ndistance * o->nyaw > 1)
        return cli_usage_error(CMD, "--dump-depth takes one placement (one --yaw, one --distance)");
    return -1;
}

/* Ground-truth vertices gv[5]: the rig markers named head, lhand, rhand, lfoot, rfoot (the
 * tracker's label order). Returns 0, or the exit status after a message. */
static int truth_vertices(const mdl_rig *rig, const char *rigp, int gv[5])
{
    for (int l = 0; l < 5; l++) {
        gv[l] = -1;
        for (int m = 0; m < rig->nmarkers; m++)
            if (!strcmp(rig->markers[m].name, drv_depth_label_names[l]))
                gv[l] = rig->markers[m].vertex;
        if (gv[l] < 0)
            return cli_fail(CMD, CLI_EXIT_USAGE, "%s: no marker named '%s'", rigp,
                            drv_depth_label_names[l]);
    }
    return 0;
}

/* How the sequence stands in front of the camera (the file header's "Scene"). */
typedef struct de_scene {
    double px, pz;   /* pivot: the mean horizontal centroid of the selected frames */
    float yaw;       /* radians about the vertical axis through the pivot */
    float cy, sy;    /* its cosine and sine */
    float t[3];      /* then this translation: pivot to (0, *, -distance), floor to y = 0 */
} de_scene;

/* Floor (lowest vertex), pivot and facing ((L - R) x up, turned to +Z, then by yaw_deg). Returns
 * 0, or the exit status after a message when the left and right markers coincide. */
static int place_scene(const mdl_meshseq *seq, const int *idx, int nidx, const int gv[5],
                       const char *rigp, double distance, double yaw_deg, de_scene *sc)
{
    const int nv = seq->nv;
    float floor_y = INFINITY;
    double px = 0, pz = 0;
    for (int k = 0; k < nidx; k++) {
        const float *F0 = seq->V + (size_t)idx[k] * nv * 3;
        double sx = 0, sz = 0;
        for (int i = 0; i < nv; i++) {
            floor_y = fminf(floor_y, F0[3 * i + 1]);
            sx += F0[3 * i];
            sz += F0[3 * i + 2];
        }
        px += sx / nv;
        pz += sz / nv;
    }
    px /= nidx;
    pz /= nidx;
    const float *V0 = seq->V + (size_t)idx[0] * nv * 3;
    float ax = 0, az = 0;
    for (int s = 0; s < 2; s++) { /* L - R from hands and feet */
        int lv = gv[1 + 2 * s], rv = gv[2 + 2 * s];
        ax += V0[3 * lv] - V0[3 * rv];
        az += V0[3 * lv + 2] - V0[3 * rv + 2];
    }
    /* facing = (L - R) x up = (-az, 0, ax); turn it to +Z (towards the camera), then by yaw */
    double fx = -az, fz = ax;
    if (fx * fx + fz * fz < 1e-12)
        return cli_fail(CMD, CLI_EXIT_USAGE, "%s: left and right markers coincide", rigp);
    sc->px = px;
    sc->pz = pz;
    sc->yaw = (float)(atan2(-fx, fz) + yaw_deg * M_PI / 180.0);
    sc->t[0] = (float)-px;
    sc->t[1] = -floor_y;
    sc->t[2] = (float)(-distance - pz);
    sc->cy = cosf(sc->yaw);
    sc->sy = sinf(sc->yaw);
    return 0;
}

/* The torso's turn about the vertical from the first selected frame to each (turn[k], radians, in
 * drv_render_place's sense): the rotation, in the horizontal plane, that best carries the trunk
 * band's vertices (TRUNK_FROM .. TRUNK_TO of the first frame's height) from the first frame onto
 * frame k, each centred on its weighted mean (Procrustes: the angle of sum w (q x p, q . p)).
 * Three rounds, each vertex weighted 1 / (1 + (r / TRUNK_RESIDUAL)^2) by its residual r in the
 * last, so that an arm or a skirt crossing the band follows the trunk rather than turning it.
 * Returns 0, or -1 when out of memory. */
static int torso_turns(const mdl_meshseq *seq, const int *idx, int nidx, float *turn)
{
    const int nv = seq->nv;
    const float *A = seq->V + (size_t)idx[0] * nv * 3;
    float lo = INFINITY, hi = -INFINITY;
    for (int i = 0; i < nv; i++) {
        lo = fminf(lo, A[3 * i + 1]);
        hi = fmaxf(hi, A[3 * i + 1]);
    }
    int *band = malloc((size_t)nv * sizeof *band), nb = 0;
    double *w = malloc((size_t)nv * sizeof *w);
    if (!band || !w) {
        free(band);
        free(w);
        return -1;
    }
    for (int i = 0; i < nv; i++) {
        double h = (A[3 * i + 1] - lo) / (hi - lo);
        if (h >= TRUNK_FROM && h <= TRUNK_TO)
            band[nb++] = i;
    }
    for (int k = 0; k < nidx; k++) {
        const float *B = seq->V + (size_t)idx[k] * nv * 3;
        double th = 0;
        for (int j = 0; j < nb; j++)
            w[j] = 1;
        for (int round = 0; round < 3 && nb > 0; round++) {
            double sw = 0, a[2] = {0, 0}, b[2] = {0, 0};
            for (int j = 0; j < nb; j++) {
                const float *p = A + 3 * band[j], *q = B + 3 * band[j];
                sw += w[j];
                a[0] += w[j] * p[0], a[1] += w[j] * p[2];
                b[0] += w[j] * q[0], b[1] += w[j] * q[2];
            }
            a[0] /= sw, a[1] /= sw, b[0] /= sw, b[1] /= sw;
            double sn = 0, cs = 0;
            for (int j = 0; j < nb; j++) {
                double px = A[3 * band[j]] - a[0], pz = A[3 * band[j] + 2] - a[1];
                double qx = B[3 * band[j]] - b[0], qz = B[3 * band[j] + 2] - b[1];
                sn += w[j] * (qx * pz - qz * px);
                cs += w[j] * (qx * px + qz * pz);
            }
            th = atan2(sn, cs);
            double c = cos(th), s = sin(th);
            for (int j = 0; j < nb; j++) {
                double px = A[3 * band[j]] - a[0], pz = A[3 * band[j] + 2] - a[1];
                double qx = B[3 * band[j]] - b[0], qz = B[3 * band[j] + 2] - b[1];
                double rx = c * px + s * pz - qx, rz = -s * px + c * pz - qz;
                double r = sqrt(rx * rx + rz * rz) / TRUNK_RESIDUAL;
                w[j] = 1 / (1 + r * r);
            }
        }
        turn[k] = (float)th;
    }
    free(band);
    free(w);
    return 0;
}

/* Unwraps turn[] (nidx angles, radians, of frames idx[] at fps) into a continuous curve and
 * replaces each by the mean over the frames within TURN_WINDOW / 2 of it. tmp: nidx floats. */
static void smooth_turns(const int *idx, int nidx, double fps, float *turn, float *tmp)
{
    for (int k = 1; k < nidx; k++) {
        while (turn[k] - turn[k - 1] > (float)M_PI)
            turn[k] -= (float)(2 * M_PI);
        while (turn[k] - turn[k - 1] < -(float)M_PI)
            turn[k] += (float)(2 * M_PI);
    }
    const double half = TURN_WINDOW / 2 * fps; /* in frames of the sequence */
    for (int k = 0, lo = 0, hi = 0; k < nidx; k++) {
        while (idx[k] - idx[lo] > half)
            lo++;
        while (hi + 1 < nidx && idx[hi + 1] - idx[k] <= half)
            hi++;
        double sum = 0;
        for (int j = lo; j <= hi; j++)
            sum += turn[j];
        tmp[k] = (float)(sum / (hi - lo + 1));
    }
    memcpy(turn, tmp, (size_t)nidx * sizeof *turn);
}

/* Places frame Vf into the scene (into V, nv x 3): first turned back by turn radians about its
 * own centroid (the torso's own turn with --hold-facing, otherwise 0), then turned and moved as
 * the scene says; unless the travel is kept, its centroid is held at the distance (sideways
 * travel stays). */
static void place_frame(const de_scene *sc, const float *Vf, int nv, float turn, int travel,
                        float *V)
{
    if (turn != 0) {
        double cx = 0, cz = 0;
        for (int i = 0; i < nv; i++) {
            cx += Vf[3 * i];
            cz += Vf[3 * i + 2];
        }
        const float zero[3] = {0, 0, 0};
        drv_render_place(Vf, nv, -turn, (float)(cx / nv), (float)(cz / nv), zero, V);
        drv_render_place(V, nv, sc->yaw, (float)sc->px, (float)sc->pz, sc->t, V);
    } else {
        drv_render_place(Vf, nv, sc->yaw, (float)sc->px, (float)sc->pz, sc->t, V);
    }
    if (travel)
        return;
    double sx = 0, sz = 0;
    for (int i = 0; i < nv; i++) {
        sx += Vf[3 * i] - sc->px;
        sz += Vf[3 * i + 2] - sc->pz;
    }
    float dz = (float)(-sc->sy * sx / nv + sc->cy * sz / nv); /* its offset along the axis */
    for (int i = 0; i < nv; i++)
        V[3 * i + 2] -= dz;
}

/* The counts behind the scores, per kind (0 head, 1 hand, 2 foot) and per label; errs[kind]
 * holds nerr[kind] distances (2 per frame at most), ms one time per frame. */
typedef struct de_scores {
    int hit[3], total[3], nerr[3];
    int side_ok, side_total, side_unsure, side_wrong, side_reported;
    int reported[3], reported_wrong[3], confident[3], confident_wrong[3];
    int hidden, hidden_hit, hidden_missing, hidden_inferred;
    int per_label_hit[5], per_label_total[5];
    int out_of_view;
    double *ms, *errs[3];
} de_scores;

static int kind_of(int l)
{
    return l == 0 ? 0 : l <= 2 ? 1 : 2;
}

/* The other side's label of a hand or foot. */
static int other_side(int l)
{
    return l == DRV_DEPTH_LHAND ? DRV_DEPTH_RHAND : l == DRV_DEPTH_RHAND ? DRV_DEPTH_LHAND
                                                  : l == DRV_DEPTH_LFOOT ? DRV_DEPTH_RFOOT
                                                                         : DRV_DEPTH_LFOOT;
}

/* Scores one frame's tracker result against the ground-truth vertices of V (scene frame); depth
 * is the rendered image (for hands hidden behind the body). With per_frame, prints each marker's
 * error and then the extrema (one line). */
static void score_frame(de_scores *sc, const drv_depth_result *res, const drv_render *ren,
                        const drv_intrinsics *k, const uint16_t *depth, const float *V,
                        const int gv[5], int per_frame)
{
    float gt[5][3];
    int inview[5];
    uint8_t found[5];
    for (int l = 0; l < 5; l++) {
        drv_render_world_to_camera(ren, V + 3 * gv[l], gt[l]);
        found[l] = res->valid[l] || res->side_uncertain[l] || res->inferred[l];
        double gu, gvv;
        inview[l] = !drv_intrinsics_project(k, gt[l], &gu, &gvv) && gu >= 4 && gvv >= 4 &&
                    gu <= k->width - 5 && gvv <= k->height - 5;
        if (!inview[l]) {
            sc->out_of_view++;
            if (per_frame)
                printf(" %s o(%3.0f,%3.0f)", drv_depth_label_names[l], gu, gvv);
            continue; /* the camera cannot see it (a foot near the camera, a raised hand) */
        }
        const int kind = kind_of(l);
        const uint16_t mm = depth[(size_t)lround(gvv) * k->width + lround(gu)];
        const int hidden = kind == 1 && mm > 0 && mm * 0.001f < -gt[l][2] - HIDDEN_BEHIND;
        if (per_frame) {
            if (found[l])
                printf(" %s %3.0f%s(%3.0f,%3.0f)", drv_depth_label_names[l],
                       100 * dist3(res->xyz[l], gt[l]),
                       res->side_uncertain[l] ? "?" : res->inferred[l] ? "~" : hidden ? "h" : "",
                       gu, gvv);
            else
                printf(" %s   -%s(%3.0f,%3.0f)", drv_depth_label_names[l], hidden ? "h" : "", gu,
                       gvv);
        }
        float best = INFINITY, same = INFINITY;
        for (int m = 0; m < 5; m++) {
            if (kind_of(m) != kind || !found[m])
                continue;
            float d = dist3(res->xyz[m], gt[l]);
            if (d < best)
                best = d;
            if (m == l)
                same = d;
        }
        sc->total[kind]++;
        sc->per_label_total[l]++;
        if (best <= 0.10f)
            sc->hit[kind]++;
        if (same <= 0.10f)
            sc->per_label_hit[l]++;
        if (isfinite(best))
            sc->errs[kind][sc->nerr[kind]++] = best;
        if (kind) {
            sc->side_total++;
            if (same <= 0.10f && res->valid[l])
                sc->side_ok++;
            if (res->side_uncertain[l])
                sc->side_unsure++;
        }
        if (hidden) {
            sc->hidden++;
            sc->hidden_hit += best <= 0.10f;
            sc->hidden_missing += !found[l];
            sc->hidden_inferred += res->inferred[l];
        }
    }
    /* the reports: is there a ground truth of the kind where a marker was reported? */
    for (int m = 0; m < 5; m++) {
        if (!found[m])
            continue;
        const int kind = kind_of(m);
        float own = dist3(res->xyz[m], gt[m]), other = kind ? dist3(res->xyz[m], gt[other_side(m)]) : INFINITY;
        sc->reported[kind]++;
        sc->reported_wrong[kind] += !(own <= 0.10f) && !(other <= 0.10f);
        if (res->valid[m]) {
            sc->confident[kind]++;
            sc->confident_wrong[kind] += !(own <= 0.10f) && !(other <= 0.10f);
        }
        if (kind && res->valid[m] && inview[m]) {
            sc->side_reported++;
            sc->side_wrong += !(own <= 0.10f) && other <= 0.10f;
        }
    }
    if (per_frame) {
        printf(" | left (%.2f %.2f %.2f) |", res->left[0], res->left[1], res->left[2]);
        for (int e = 0; e < res->nextrema; e++)
            printf(" %s(%d,%d g%.2f)",
                   res->extremum_label[e] >= 0 ? drv_depth_label_names[res->extremum_label[e]]
                                               : "?",
                   res->extremum_px[e][0], res->extremum_px[e][1], res->geodesic[e]);
        printf("\n");
    }
}

/* Prints the summary of nidx frames at one placement: one JSON object, or a table row (with a
 * header before the first). Sorts sc's arrays. */
static void print_report(const de_args *o, double distance, double yaw, de_scores *sc, int nidx,
                         const float *turn, int first)
{
    float tmin = INFINITY, tmax = -INFINITY; /* the performer's own turn, degrees */
    for (int k = 0; k < nidx; k++) {
        tmin = fminf(tmin, turn[k] * (float)(180 / M_PI));
        tmax = fmaxf(tmax, turn[k] * (float)(180 / M_PI));
    }
    double med, p99;
    cli_percentiles(sc->ms, nidx, &med, &p99);
    const char *kinds[3] = {"head", "hand", "foot"};
    double rate[3], e50[3], e90[3], e99[3];
    for (int k = 0; k < 3; k++) {
        rate[k] = ratio(sc->hit[k], sc->total[k]);
        e50[k] = pct(sc->errs[k], sc->nerr[k], 0.5);
        e90[k] = pct(sc->errs[k], sc->nerr[k], 0.9);
        e99[k] = pct(sc->errs[k], sc->nerr[k], 0.99);
    }
    double side = ratio(sc->side_ok, sc->side_total);
    if (!o->json) {
        if (first)
            printf("the performer turns by %.0f .. %.0f degrees from the first frame: %s\n",
                   tmin, tmax, o->hold ? "undone (--hold-facing)" : "kept, added to the yaw");
        if (first)
            printf("frames %d; within 10 cm per kind (ground truths in view), side: correct / "
                   "uncertain / confidently wrong; hands behind the body: found / inferred / "
                   "missing; hand reports confident and wrong\n"
                   "  dist    yaw   head         hand         foot         side               "
                   "hidden hands            wrong   ms median/p99\n",
                   nidx);
        printf("  %.2f %6.1f", distance, yaw);
        for (int k = 0; k < 3; k++)
            printf("   %5.3f %4d", rate[k], sc->total[k]);
        printf("   %5.3f %5.3f %5.3f   %4d %5.3f %5.3f %5.3f   %5.3f   %.3f/%.3f\n", side,
               ratio(sc->side_unsure, sc->side_total), ratio(sc->side_wrong, sc->side_reported),
               sc->hidden, ratio(sc->hidden_hit, sc->hidden),
               ratio(sc->hidden_inferred, sc->hidden), ratio(sc->hidden_missing, sc->hidden),
               ratio(sc->confident_wrong[1], sc->confident[1]), med, p99);
        return;
    }
    printf("{\"frames\": %d, \"distance\": %.3f, \"yaw\": %.3f, \"travel\": %s, "
           "\"hold_facing\": %s, \"own_turn_deg\": [%.1f, %.1f], \"within_10cm\": {",
           nidx, distance, yaw, o->travel ? "true" : "false", o->hold ? "true" : "false", tmin,
           tmax);
    for (int k = 0; k < 3; k++)
        jnum(kinds[k], rate[k], k < 2);
    printf("}, \"in_view\": {\"head\": %d, \"hand\": %d, \"foot\": %d}, ", sc->total[0],
           sc->total[1], sc->total[2]);
    jnum("side_correct", side, 1);
    jnum("side_uncertain", ratio(sc->side_unsure, sc->side_total), 1);
    jnum("side_wrong", ratio(sc->side_wrong, sc->side_reported), 1);
    printf("\"wrong_reports\": {");
    for (int k = 0; k < 3; k++)
        jnum(kinds[k], ratio(sc->reported_wrong[k], sc->reported[k]), k < 2);
    printf("}, \"confident_wrong\": {");
    for (int k = 0; k < 3; k++)
        jnum(kinds[k], ratio(sc->confident_wrong[k], sc->confident[k]), k < 2);
    printf("}, \"hidden_hands\": {\"count\": %d, ", sc->hidden);
    jnum("found_10cm", ratio(sc->hidden_hit, sc->hidden), 1);
    jnum("inferred", ratio(sc->hidden_inferred, sc->hidden), 1);
    jnum("missing", ratio(sc->hidden_missing, sc->hidden), 0);
    printf("}, \"per_marker_same_side_10cm\": {");
    for (int l = 0; l < 5; l++)
        jnum(drv_depth_label_names[l], ratio(sc->per_label_hit[l], sc->per_label_total[l]), l < 4);
    printf("}, \"error_m\": {");
    for (int k = 0; k < 3; k++) {
        printf("\"%s\": {", kinds[k]);
        jnum("median", e50[k], 1);
        jnum("p90", e90[k], 1);
        jnum("p99", e99[k], 1);
        printf("\"found\": %.4f}%s", sc->total[k] ? (double)sc->nerr[k] / sc->total[k] : 0.0,
               k < 2 ? ", " : "");
    }
    printf("}, \"out_of_view\": %d, \"ms_median\": %.4f, \"ms_p99\": %.4f}\n", sc->out_of_view, med,
           p99);
}

/* ------------------------------------------------------------------ the command */

/* What every placement shares: the sequence, the frames, the ground truth, the buffers. */
typedef struct de_run {
    const de_args *o;
    const mdl_meshseq *seq;
    const int *idx;
    int nidx, gv[5];
    float *turn; /* per selected frame: the torso's own turn (radians), undone by --hold-facing */
    double fps;
    drv_render *ren;
    drv_render_opts ro;
    drv_depth_opts to;
    float *V;
    uint16_t *depth;
    FILE *dumpf;
} de_run;

/* One placement: a fresh test camera (its noise starts over) and tracker, then per frame: place, render, (dump), track (timed), score;
 * then the report. Returns 0 or the exit status after a message. */
static int run_placement(de_run *r, double distance, double yaw, de_scores *sc, int first)
{
    char derr[DRV_ERR_LEN] = "";
    de_scene scene;
    int status = place_scene(r->seq, r->idx, r->nidx, r->gv, r->o->rig, distance, yaw, &scene);
    if (status)
        return status;
    drv_depth_tracker *trk = NULL;
    drv_render_destroy(r->ren);
    r->ren = NULL;
    if (drv_render_create(&r->ro, r->seq->nv, &r->ren, derr) ||
        drv_depth_tracker_create(&r->to, &trk, derr))
        return cli_fail(CMD, CLI_EXIT_FAIL, "%s", derr);
    const int nv = r->seq->nv;
    const size_t npix = (size_t)r->ro.k.width * r->ro.k.height;
    *sc = (de_scores){.ms = sc->ms, .errs = {sc->errs[0], sc->errs[1], sc->errs[2]}}; /* counts 0 */
    for (int k = 0; k < r->nidx; k++) {
        const float turn = r->o->hold ? r->turn[k] : 0.f;
        place_frame(&scene, r->seq->V + (size_t)r->idx[k] * nv * 3, nv, turn, r->o->travel, r->V);
        if (drv_render_frame(r->ren, r->V, nv, r->seq->F, r->seq->nf, r->depth, derr)) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "frame %d: %s", r->idx[k], derr);
            break;
        }
        if (r->dumpf && fwrite(r->depth, sizeof *r->depth, npix, r->dumpf) != npix) {
            status = cli_fail(CMD, CLI_EXIT_FAIL, "%s: write failed", r->o->dump);
            break;
        }
        drv_depth_result res;
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        drv_depth_tracker_process(trk, r->depth, (uint64_t)llround(k * 1e6 / r->fps), &res);
        clock_gettime(CLOCK_MONOTONIC, &b);
        sc->ms[k] = (double)(b.tv_sec - a.tv_sec) * 1e3 + (double)(b.tv_nsec - a.tv_nsec) * 1e-6;
        if (r->o->per_frame)
            printf("%4d", r->idx[k]);
        score_frame(sc, &res, r->ren, &r->ro.k, r->depth, r->V, r->gv, r->o->per_frame);
    }
    drv_depth_tracker_destroy(trk);
    if (!status)
        print_report(r->o, distance, yaw, sc, r->nidx, r->turn, first);
    return status;
}

int cmd_depth_eval(int argc, char **argv);

/* Reads the sequence and the rig, then scores every placement (distance x yaw). */
int cmd_depth_eval(int argc, char **argv)
{
    de_args o;
    int status = parse_args(argc, argv, &o);
    if (status >= 0)
        return status;

    char err[MDL_ERR_LEN] = "";
    status = CLI_EXIT_FAIL;
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    int *idx = NULL;
    de_run r = {.o = &o};
    de_scores sc = {0};
    if (mdl_meshseq_read(o.mesh, o.rest, &seq, err) || mdl_rig_read(o.rig, seq->nv, &rig, err)) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "%s", err);
        goto done;
    }
    if (mdl_parse_frames(o.frames, seq->frames, &idx, &r.nidx, err)) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "--frames: %s", err);
        goto done;
    }
    if (r.nidx < 1) {
        status = cli_fail(CMD, CLI_EXIT_USAGE, "--frames %s selects no frame", o.frames);
        goto done;
    }
    r.seq = seq;
    r.idx = idx;
    if ((status = truth_vertices(rig, o.rig, r.gv)))
        goto done;
    status = CLI_EXIT_FAIL;
    const int nv = seq->nv;
    r.fps = seq->fps > 0 ? seq->fps : o.fps;
    drv_render_opts_default(&r.ro);
    r.ro.cam_height = 1.0f;
    r.ro.cam_pitch = 2.0f;
    drv_depth_opts_default(&r.to);
    if (o.step) { /* a fixed grid */
        r.to.step = o.step;
        r.to.cell_m = 0;
    }
    r.to.smooth = o.smooth;
    const size_t npix = (size_t)r.ro.k.width * r.ro.k.height;
    r.V = malloc((size_t)nv * 3 * sizeof *r.V);
    r.depth = malloc(npix * sizeof *r.depth);
    r.turn = calloc((size_t)r.nidx * 2, sizeof *r.turn); /* and room for smooth_turns */
    sc.ms = malloc((size_t)r.nidx * sizeof *sc.ms);
    for (int k = 0; k < 3; k++)
        sc.errs[k] = malloc((size_t)r.nidx * 2 * sizeof *sc.errs[k]);
    if (!r.V || !r.depth || !r.turn || !sc.ms || !sc.errs[0] || !sc.errs[1] || !sc.errs[2] ||
        torso_turns(seq, idx, r.nidx, r.turn)) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "out of memory");
        goto done;
    }
    smooth_turns(idx, r.nidx, r.fps, r.turn, r.turn + r.nidx);
    if (o.dump && !(r.dumpf = fopen(o.dump, "wb"))) {
        status = cli_fail(CMD, CLI_EXIT_FAIL, "%s: %s", o.dump, strerror(errno));
        goto done;
    }
    status = CLI_EXIT_OK;
    for (int d = 0; d < o.ndistance && status == CLI_EXIT_OK; d++)
        for (int y = 0; y < o.nyaw && status == CLI_EXIT_OK; y++)
            status = run_placement(&r, o.distance[d], o.yaw_deg[y], &sc, d == 0 && y == 0);
done:
    if (r.dumpf)
        fclose(r.dumpf);
    for (int k = 0; k < 3; k++)
        free(sc.errs[k]);
    free(sc.ms);
    free(r.depth);
    free(r.turn);
    free(r.V);
    drv_render_destroy(r.ren);
    free(idx);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    return status;
}
