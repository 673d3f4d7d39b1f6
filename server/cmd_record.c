/* cmd_record.c - `meshsteer record KIND`: the recordings of recordings/ (recordings/README.md),
 * made by our own code from the built-in example (model/example/creature.c), deterministic so
 * that making one again gives the same bytes:
 *   markers  the example's trot marker take (mdl_example_markers), C3D or CSV by extension;
 *   osc      the same take as an OSC capture (drivers.h "OSC captures"): one bundle per frame;
 *   depth    the trot's true meshes seen by the test camera (drivers/depth.h, render.c) as a
 *            libfreenect fakenect dump, every K-th frame;
 *   oni      a fakenect dump served by the test-camera OpenNI2 driver (libMeshsteerTestCam.so.0,
 *            which the caller stages beside libOpenNI2: scripts/recordings.sh) and written by
 *            OpenNI2's own recorder, through the openni2: source's record= option. */
#include "cli.h"

#include "depth.h"
#include "drivers.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#define CMD "record"

static void record_usage(FILE *f)
{
    fprintf(f,
            "usage: meshsteer record markers -o FILE.c3d|FILE.csv [--frames N] [--speed S]\n"
            "       meshsteer record osc -o FILE.osc [--frames N] [--speed S]\n"
            "       meshsteer record depth -o DIR [--frames N] [--speed S] [--every K]\n"
            "                                      [--distance M] [--noise SIGMA]\n"
            "       meshsteer record oni --dump DIR -o FILE.oni [--fps F]\n\n"
            "The recordings of recordings/ (recordings/README.md), made from the built-in example's\n"
            "trot (the marker take `meshsteer example` writes, at 30 frames/s). Equal arguments\n"
            "give identical bytes.\n\n"
            "  markers       the trot's rig markers (C3D: Intel float, mm, Z up; or CSV)\n"
            "  osc           the same take as an OSC capture: per frame one bundle of\n"
            "                /marker NAME x y z messages (docs/OSC.md); `meshsteer osc-play` sends it\n"
            "  depth         the trot's true meshes seen by the test camera (Kinect v1 depth,\n"
            "                640x480) as a libfreenect fakenect dump; DIR must not hold one yet\n"
            "  oni           a fakenect dump through OpenNI2's recorder, served by the test-camera\n"
            "                driver plugin (it must be staged beside libOpenNI2:\n"
            "                scripts/recordings.sh does), each frame once\n\n"
            "  -o PATH       output file or directory\n"
            "  --frames N    frames of the trot (default 240; depth: 90)\n"
            "  --speed S     trot cycle rate relative to the walk (default 1.3)\n"
            "  --every K     depth: keep every K-th frame (default 30: one frame per second)\n"
            "  --distance M  depth: metres from the camera to the creature (default 2.5)\n"
            "  --noise SIGMA depth: the test camera's disparity noise (1/8 pixel units; default\n"
            "                its own, drivers/depth.h)\n"
            "  --dump DIR    oni: the fakenect dump to serve\n"
            "  --fps F       oni: the rate the plugin serves it at (default: its recorded rate)\n");
}

typedef struct rec_args {
    const char *kind, *out, *dump;
    int frames, every;
    double speed, distance, fps, noise;
} rec_args;

static int parse_args(int argc, char **argv, rec_args *a)
{
    *a = (rec_args){.frames = -1, .every = 30, .speed = 1.3, .distance = 2.5, .noise = -1};
    if (argc < 2)
        return cli_usage_error(CMD, "which recording? markers, osc, depth or oni (see --help)");
    a->kind = argv[1];
    for (int i = 2; i < argc; i++) {
        const char *o = argv[i];
        if (i + 1 >= argc)
            return cli_usage_error(CMD, "%s: unknown option or missing value (see --help)", o);
        const char *v = argv[++i];
        int bad = 0;
        if (!strcmp(o, "-o") || !strcmp(o, "--output"))
            a->out = v;
        else if (!strcmp(o, "--dump"))
            a->dump = v;
        else if (!strcmp(o, "--frames"))
            bad = cli_parse_int(CMD, o, v, &a->frames);
        else if (!strcmp(o, "--every"))
            bad = cli_parse_int(CMD, o, v, &a->every);
        else if (!strcmp(o, "--speed"))
            bad = cli_parse_double(CMD, o, v, &a->speed);
        else if (!strcmp(o, "--distance"))
            bad = cli_parse_double(CMD, o, v, &a->distance);
        else if (!strcmp(o, "--noise"))
            bad = cli_parse_double(CMD, o, v, &a->noise);
        else if (!strcmp(o, "--fps"))
            bad = cli_parse_double(CMD, o, v, &a->fps);
        else
            return cli_usage_error(CMD, "unknown option '%s' (see --help)", o);
        if (bad)
            return CLI_EXIT_USAGE;
    }
    if (!a->out)
        return cli_usage_error(CMD, "-o PATH is required");
    if (a->frames < 0)
        a->frames = strcmp(a->kind, "depth") ? 240 : 90;
    if (a->frames < 1 || a->frames > 100000)
        return cli_usage_error(CMD, "--frames %d is outside 1..100000", a->frames);
    if (!(a->speed > 0 && a->speed <= 10))
        return cli_usage_error(CMD, "--speed %g is outside (0, 10]", a->speed);
    if (a->every < 1 || a->every > a->frames)
        return cli_usage_error(CMD, "--every %d is outside 1..%d (the frames)", a->every, a->frames);
    if (!(a->distance >= 0.8 && a->distance <= 4.5))
        return cli_usage_error(CMD, "--distance %g: the Kinect sees 0.8 .. 4.5 m", a->distance);
    if (!(a->noise == -1 || (a->noise >= 0 && a->noise <= 10)))
        return cli_usage_error(CMD, "--noise %g is outside 0..10", a->noise);
    if (!(a->fps == 0 || (a->fps >= 1 && a->fps <= 120)))
        return cli_usage_error(CMD, "--fps %g is outside 1..120", a->fps);
    return 0;
}

/* The example's trot: its markers, and (truth != NULL) its true meshes. */
static int example_trot(const rec_args *a, mdl_markers **mk, mdl_meshseq **truth)
{
    char err[MDL_ERR_LEN] = "";
    mdl_rig *rig = NULL;
    int r = mdl_example_create(1, NULL, &rig, err);
    if (r == 0)
        r = mdl_example_markers(rig, a->frames, a->speed, mk, truth, err);
    mdl_rig_destroy(rig);
    return r ? cli_fail(CMD, CLI_EXIT_FAIL, "%s", err) : 0;
}

static int record_markers(const rec_args *a)
{
    mdl_markers *mk = NULL;
    int st = example_trot(a, &mk, NULL);
    if (st)
        return st;
    char err[MDL_ERR_LEN] = "";
    int r = cli_has_suffix(a->out, ".c3d")   ? mdl_markers_write_c3d(a->out, mk, err)
            : cli_has_suffix(a->out, ".csv") ? mdl_markers_write_csv(a->out, mk, err)
                                             : (snprintf(err, sizeof err, "%s: the name must end in "
                                                         ".c3d or .csv", a->out), -EINVAL);
    if (r == 0)
        printf("%s: %d frames of %d markers at %g fps\n", a->out, mk->frames, mk->count, mk->fps);
    mdl_markers_destroy(mk);
    return r ? cli_fail(CMD, r == -EINVAL ? CLI_EXIT_USAGE : CLI_EXIT_FAIL, "%s", err) : 0;
}

static int record_osc(const rec_args *a)
{
    mdl_markers *mk = NULL;
    int st = example_trot(a, &mk, NULL);
    if (st)
        return st;
    char err[DRV_ERR_LEN] = "";
    drv_osc_capture *c = NULL;
    int r = drv_osc_capture_from_markers(mk, &c, err);
    if (r == 0)
        r = drv_osc_capture_write(a->out, c, err);
    if (r == 0)
        printf("%s: %d datagrams (one bundle of %d markers per frame) over %.3f s\n", a->out,
               c->count, mk->count, (double)c->t_us[c->count - 1] * 1e-6);
    drv_osc_capture_destroy(c);
    mdl_markers_destroy(mk);
    return r ? cli_fail(CMD, CLI_EXIT_FAIL, "%s", err) : 0;
}

/* The scene of `record depth`: the creature in profile (it faces +X, the camera looks along -Z),
 * its first frame's horizontal centroid `distance` metres in front of the camera, feet on the
 * floor; the same translation in every frame, so its in-place gait stays in place. */
static void scene_offset(const mdl_meshseq *s, double distance, float t[3])
{
    double cx = 0, cz = 0, ymin = INFINITY;
    for (int i = 0; i < s->nv; i++) {
        cx += s->V[3 * i];
        cz += s->V[3 * i + 2];
        ymin = fmin(ymin, s->V[3 * i + 1]);
    }
    t[0] = (float)(-cx / s->nv);
    t[1] = (float)-ymin;
    t[2] = (float)(-cz / s->nv - distance);
}

static int record_depth(const rec_args *a)
{
    mdl_markers *mk = NULL;
    mdl_meshseq *truth = NULL;
    int st = example_trot(a, &mk, &truth);
    if (st)
        return st;
    char err[DRV_ERR_LEN] = "";
    drv_render_opts ro;
    drv_render_opts_default(&ro);
    if (a->noise >= 0)
        ro.disparity_noise = a->noise;
    drv_render *rd = NULL;
    drv_fakenect_writer *w = NULL;
    uint16_t *mm = malloc(sizeof *mm * (size_t)ro.k.width * ro.k.height);
    float *V = malloc(sizeof *V * 3 * (size_t)truth->nv), t[3];
    int r = mm && V ? 0 : -ENOMEM, written = 0;
    if (r == 0)
        r = drv_render_create(&ro, truth->nv, &rd, err);
    if (r == 0)
        r = drv_fakenect_writer_open(a->out, &w, err);
    scene_offset(truth, a->distance, t);
    for (int f = 0; r == 0 && f < truth->frames; f++) {
        /* the test camera's noise follows the frame order: every frame is rendered, so that
         * --every picks frames of the same full-rate sequence */
        drv_render_place(truth->V + (size_t)f * truth->nv * 3, truth->nv, 0, 0, 0, t, V);
        r = drv_render_frame(rd, V, truth->nv, truth->F, truth->nf, mm, err);
        if (r == 0 && f % a->every == 0) {
            r = drv_fakenect_writer_depth(w, f / mk->fps, (uint32_t)f, mm, err);
            written++;
        }
    }
    int rc = drv_fakenect_writer_close(w, r ? NULL : err);
    if (r == 0)
        r = rc;
    if (r == 0)
        printf("%s: %d depth frames (every %d of %d at %g fps, %.3f s)\n", a->out, written,
               a->every, truth->frames, mk->fps, truth->frames / mk->fps);
    drv_render_destroy(rd);
    free(mm);
    free(V);
    mdl_meshseq_destroy(truth);
    mdl_markers_destroy(mk);
    if (r == -ENOMEM && !err[0])
        snprintf(err, sizeof err, "out of memory");
    return r ? cli_fail(CMD, r == -EEXIST ? CLI_EXIT_USAGE : CLI_EXIT_FAIL, "%s", err) : 0;
}

/* Depth entries of DIR/INDEX.txt, or a negative errno. */
static int dump_frames(const char *dir)
{
    char path[4096], line[512];
    snprintf(path, sizeof path, "%s/INDEX.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f)
        return -errno;
    int n = 0;
    while (fgets(line, sizeof line, f))
        n += line[0] == 'd' && line[1] == '-';
    fclose(f);
    return n;
}

static int record_oni(const rec_args *a)
{
    if (!a->dump)
        return cli_usage_error(CMD, "oni: --dump DIR is required");
    int n = dump_frames(a->dump);
    if (n <= 0)
        return cli_usage_error(CMD, "%s: %s", a->dump,
                               n ? "no INDEX.txt (not a fakenect dump)" : "the dump has no depth frame");
    struct stat sb;
    if (stat(a->out, &sb) == 0) /* the recorder would go on in a new name; say so instead */
        return cli_usage_error(CMD, "%s exists; remove it first", a->out);
    char spec[9000], err[DRV_ERR_LEN] = "", fps[32] = "";
    if (a->fps > 0)
        snprintf(fps, sizeof fps, "&fps=%g", a->fps);
    /* vanish=n: the plugin serves each frame once, then the device leaves (DRV_ELOST); delay:
     * its first frame comes after OpenNI2's recorder (started on its own thread) runs */
    snprintf(spec, sizeof spec, "openni2:meshsteer-testcam:%s?vanish=%d&delay=500%s#width=640&height=480&record=%s",
             a->dump, n, fps, a->out);
    drv_source *s = NULL;
    int r = drv_source_open(spec, &s, err);
    if (r == 0)
        r = drv_source_start(s, err);
    int got = 0;
    float xyz[DRV_DEPTH_NLABELS * 3];
    uint8_t valid[DRV_DEPTH_NLABELS];
    for (int tries = 0; r == 0 && tries < 4 * n + 20; tries++) {
        drv_frame fr = {.count = DRV_DEPTH_NLABELS, .xyz = xyz, .valid = valid};
        int rr = drv_source_read(s, &fr, 500, err);
        if (rr == 0)
            got++;
        else if (rr == DRV_ELOST)
            break;
        else if (rr != DRV_ETIMEOUT)
            r = rr;
    }
    drv_source_close(s); /* stops OpenNI2's recorder: the file is complete after this */
    if (r)
        return cli_fail(CMD, CLI_EXIT_FAIL, "%s", err);
    if (stat(a->out, &sb) != 0)
        return cli_fail(CMD, CLI_EXIT_FAIL, "%s: OpenNI2's recorder wrote nothing", a->out);
    printf("%s: %d of %d frames of %s through OpenNI2's recorder, %lld bytes\n", a->out, got, n,
           a->dump, (long long)sb.st_size);
    return got == n ? 0 : cli_fail(CMD, CLI_EXIT_FAIL, "%s: %d of %d frames came", a->out, got, n);
}

int cmd_record(int argc, char **argv);

int cmd_record(int argc, char **argv)
{
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            record_usage(stdout);
            return CLI_EXIT_OK;
        }
    rec_args a;
    int st = parse_args(argc, argv, &a);
    if (st)
        return st;
    if (!strcmp(a.kind, "markers"))
        return record_markers(&a);
    if (!strcmp(a.kind, "osc"))
        return record_osc(&a);
    if (!strcmp(a.kind, "depth"))
        return record_depth(&a);
    if (!strcmp(a.kind, "oni"))
        return record_oni(&a);
    return cli_usage_error(CMD, "unknown recording '%s' (markers, osc, depth, oni)", a.kind);
}
