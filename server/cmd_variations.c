/* cmd_variations.c - `meshsteer variations`: many different animations of any length from the one
 * example a skin was fitted to (Zheng 2013, model.h "variations"): the transition graph of the
 * skin (per component of its bone graph unless --components 1), N walks of F frames meeting the
 * targeted frames, all bone motions in one file (variations.bones) and the first K as PC2 point
 * caches of the skinned mesh, and with --json the graph's figures and, per variation, its largest
 * frame-to-frame vertex jump beside the example's own (the skin's fitted frames, skinned), the
 * largest vertex acceleration near its transitions beside the 99th percentile of the example's,
 * and its lowest vertex against the example's floor. With --avoid, the fitted frames that
 * intersect the obstacle are kept out of the walks and every output frame is checked against it
 * (model/variations/avoid.c), a walk with a colliding frame redrawn from a seed of its own. The
 * walks run in chunks on --threads threads (cli_parallel_for; per worker one frame of scratch
 * for the check, the obstacle's tree shared read-only); the overlap test, the files and the
 * figures follow in order, so the output does not depend on the thread count. */
#include "cli.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <stdint.h>
#include <unistd.h>

static const char usage_text[] =
    "usage: meshsteer variations --model SKIN.msm --count N --frames F [options] -o OUT_DIR\n"
    "       meshsteer variations --add-to MODEL.msm [options]\n"
    "\n"
    "Synthesises N different animations of F frames each from the example a skin was fitted to\n"
    "(`meshsteer skin`; Zheng 2013): transitions between frames whose bone poses, seen from the\n"
    "most influential bone, are close (Sec. 3.2), spliced with that bone matched rigidly and the\n"
    "others blended through the deformation gradients at key vertices (Sec. 3.3), and random\n"
    "walks on the graph they make (Sec. 3.4). Writes\n"
    "OUT_DIR/variations.bones (every variation's bone transforms and source frames;\n"
    "docs/FORMATS.md) and OUT_DIR/variation_000.pc2, ... (the skinned mesh; topology: the\n"
    "model's rest pose). Where\n"
    "the bone graph has cut nodes, each component between them walks on its own graph and\n"
    "the components are merged at their cut nodes (Sec. 4, Algorithm 1).\n"
    "\n"
    "  --model SKIN.msm      a model file holding a skin\n"
    "  --count N             number of variations (required, >= 1)\n"
    "  --frames F            frames per variation (required, >= 1)\n"
    "  --seed S              variation k uses seed S + k (default 1)\n"
    "  --threshold F         T_c itself (default: max D(i, i-1) / 40; docs/MODEL.md)\n"
    "  --tc-factor F         T_c = F x max D(i, i-1) (default 0.025; the paper prints 40)\n"
    "  --components auto|1   auto (default): the bone graph's blocks between its cut nodes\n"
    "                        walk apart and are merged (Sec. 4); 1: the skin as one\n"
    "  --te-factor F         bone graph edges below F x the largest are dropped (default 0.1)\n"
    "  --blend gradient|linear  how a transition is blended: linear (default; as smooth on our\n"
    "                        data at 1/40 of the cost, docs/MODEL.md) or gradient (Sec. 3.3: the\n"
    "                        key vertices' deformation gradients blended by a 1-D Poisson solve,\n"
    "                        the bones solved from them, eq. 9) or linear (the bones' local\n"
    "                        coordinates, the comparison of the paper's Fig. 6). Before the\n"
    "                        gradient blend, --blend N was the window: that is now\n"
    "  --blend-frames N      frames over which a transition is blended (default 8, 0: none)\n"
    "  --jump-prob P         chance per frame of taking an open transition (default 0.2)\n"
    "  --temperature F       prefer cheap transitions: chance ~ exp(-D / (F x max D(i, i-1)))\n"
    "                        (default 0.1; 0: uniform)\n"
    "  --min-segment N       frames between transitions at least (default 8)\n"
    "  --start FRAME         every walk starts at this fitted frame (default: by its seed)\n"
    "  --end FRAME           every walk ends at this fitted frame\n"
    "  --target IN:OUT,...   fitted frame IN at output frame OUT (Sec. 3.4; with --start and\n"
    "                        --end met exactly, or an error when no walk can)\n"
    "  --ground              the most influential bone moves only on the ground plane at a\n"
    "                        transition (a turn about y, a horizontal shift: feet stay down)\n"
    "  --avoid OBSTACLE.obj  a static obstacle (its triangles, in the skin's coordinates;\n"
    "                        repeat for several files, up to 16: one obstacle): fitted frames\n"
    "                        whose skinned mesh intersects it are kept out of every walk, and\n"
    "                        a variation with an output frame that intersects it (a triangle\n"
    "                        of each sharing a point) is walked again from another seed, 32\n"
    "                        walks at most, then an error (Sec. 3.4)\n"
    "  --max-overlap F       a variation showing the same fitted frames as an earlier one on\n"
    "                        more than F of its frames is walked again with a new seed\n"
    "                        (Sec. 3.4; default 0.9; 1: never)\n"
    "  --threads T           walks on T threads (default: online CPUs); the output does not\n"
    "                        depend on T\n"
    "  --pc2 K               write the skinned meshes of the first K variations only\n"
    "                        (default: all; 0: bone motions only)\n"
    "  --gltf                also OUT_DIR/variations.glb: the skinned mesh with one animation\n"
    "                        per variation written as PC2 (the first K of --pc2), glTF 2.0\n"
    "                        as `meshsteer skin --gltf` writes it (docs/MODEL.md)\n"
    "  -o OUT_DIR            directory for the files (created)\n"
    "  --add-to MODEL.msm    make the skin in MODEL.msm play an endless random walk (the given\n"
    "                        options, --seed S) instead of looping its frames, and rewrite the\n"
    "                        file: the daemon's idle source then walks (with --components,\n"
    "                        --te-factor and --ground too). --model defaults to it;\n"
    "                        --count, --frames and -o are then optional\n"
    "  --json                print bones, frames, ref_bone, rank, alpha, beta, max_adjacent,\n"
    "                        tc, blend (gradient, linear or none), blend_frames, key_vertices\n"
    "                        (the gradient blend's; the components' sum), transitions (the components' sum), single_transitions (the\n"
    "                        whole skin's graph), the transition list (from, to, cost) of\n"
    "                        the whole skin's graph, cut_nodes, components (per component\n"
    "                        its bones, cut node, parent, ref_bone, tc, transitions and\n"
    "                        their list),\n"
    "                        example_max_jump, example_p99_accel and example_max_accel (the\n"
    "                        99th percentile and the largest of the example's vertex\n"
    "                        accelerations), synth_s and per variation its\n"
    "                        file, transitions taken, max_jump and max_jump_ratio (to the\n"
    "                        example's), transition_max_accel (the largest vertex acceleration\n"
    "                        within 3 frames of a transition) and transition_accel_ratio (to the\n"
    "                        example's 99th percentile), floor_excursion (how far the lowest\n"
    "                        vertex of a frame leaves the example's range of it), overlap,\n"
    "                        and per component the transitions taken as \"from>to ...\"\n"
    "                        (components_taken); also analysis_s, threads, targets,\n"
    "                        targets_met, overlap_redrawn, example_floor_min/max (variations\n"
    "                        with a mesh only: the first K of --pc2); with --avoid also\n"
    "                        obstacle (files, triangles, box_min, box_max),\n"
    "                        colliding_input_frames, colliding_input_count, collision_redrawn\n"
    "                        (walks discarded in all), collision_redraws_max, collision_tries,\n"
    "                        avoid_setup_s and per variation collision_redraws\n";

static double max_jump(const float *V, int nv, int frames)
{
    double mx = 0;
    for (int f = 1; f < frames; f++)
        for (int i = 0; i < nv; i++) {
            const float *a = V + 3 * ((size_t)(f - 1) * nv + i), *b = V + 3 * ((size_t)f * nv + i);
            double d = 0;
            for (int c = 0; c < 3; c++)
                d += ((double)a[c] - b[c]) * ((double)a[c] - b[c]);
            mx = d > mx ? d : mx;
        }
    return sqrt(mx);
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

/* the largest vertex acceleration |V(f+1) - 2 V(f) + V(f-1)| at output frame f (1..frames-2) */
static double accel_at(const float *V, int nv, int f)
{
    double mx = 0;
    for (int i = 0; i < nv; i++) {
        double d = 0;
        for (int c = 0; c < 3; c++) {
            size_t k = 3 * (size_t)i + c;
            double a = (double)V[3 * (size_t)(f + 1) * nv + k] - 2.0 * V[3 * (size_t)f * nv + k] +
                       V[3 * (size_t)(f - 1) * nv + k];
            d += a * a;
        }
        mx = d > mx ? d : mx;
    }
    return sqrt(mx);
}

/* The example as the skin reproduces it (its fitted frames, skinned): the largest vertex jump
 * between consecutive frames, and the 99th percentile of the vertex accelerations over all
 * vertices and interior frames (the smoothness reference) and their maximum. 0 when not
 * computable. */
static double lowest_y(const float *V, int nv)
{
    double lo = INFINITY;
    for (int i = 0; i < nv; i++)
        lo = V[3 * (size_t)i + 1] < lo ? V[3 * (size_t)i + 1] : lo;
    return lo;
}

static void example_motion(const mdl_model *m, double *jump, double *p99, double *amax,
                           double floor_range[2])
{
    *jump = *p99 = *amax = 0;
    floor_range[0] = floor_range[1] = 0;
    int nb, K, N;
    const int *bone;
    const double *w, *T;
    if (mdl_skin_get(m, &nb, &K, &N, &bone, &w, &T) || N < 3)
        return;
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    float *V = calloc((size_t)N * info.nv * 3, sizeof *V);
    float *acc = calloc((size_t)(N - 2) * info.nv, sizeof *acc);
    if (!V || !acc) {
        free(V);
        free(acc);
        return;
    }
    for (int f = 0; f < N; f++)
        mdl_skin_lbs(info.nv, K, bone, w, info.rest, T + 12 * (size_t)f * nb,
                     V + 3 * (size_t)f * info.nv);
    *jump = max_jump(V, info.nv, N);
    floor_range[0] = INFINITY;
    floor_range[1] = -INFINITY;
    for (int f = 0; f < N; f++) {
        double lo = lowest_y(V + 3 * (size_t)f * info.nv, info.nv);
        floor_range[0] = lo < floor_range[0] ? lo : floor_range[0];
        floor_range[1] = lo > floor_range[1] ? lo : floor_range[1];
    }
    size_t n = 0;
    for (int f = 1; f + 1 < N; f++)
        for (int i = 0; i < info.nv; i++) {
            double d = 0;
            for (int c = 0; c < 3; c++) {
                size_t k = 3 * (size_t)i + c;
                double a = (double)V[3 * (size_t)(f + 1) * info.nv + k] -
                           2.0 * V[3 * (size_t)f * info.nv + k] + V[3 * (size_t)(f - 1) * info.nv + k];
                d += a * a;
            }
            acc[n++] = (float)sqrt(d);
        }
    qsort(acc, n, sizeof *acc, cmp_float);
    *p99 = acc[(size_t)(0.99 * (double)(n - 1))];
    *amax = acc[n - 1];
    free(V);
    free(acc);
}

/* the transitions component q took, as "from>to from>to ..." (malloc'd); *taken counts them */
static char *walk_taken(const int *src, int ncomp, int q, int frames, int *taken)
{
    size_t cap = 64, len = 0;
    char *s = malloc(cap);
    if (!s)
        return NULL;
    s[0] = 0;
    for (int f = 1; f < frames; f++) {
        int a = src[(size_t)ncomp * (f - 1) + q], b = src[(size_t)ncomp * f + q];
        if (b == a + 1)
            continue;
        (*taken)++;
        if (len + 32 > cap) {
            char *t = realloc(s, cap *= 2);
            if (!t) {
                free(s);
                return NULL;
            }
            s = t;
        }
        /* the walk continued with b after a: the transition (a, b - 1) */
        len += (size_t)snprintf(s + len, cap - len, "%s%d>%d", len ? " " : "", a, b - 1);
    }
    return s;
}

/* "IN:OUT,IN:OUT,..." appended to t (capacity cap), *n updated; -1 on a malformed list */
static int parse_targets(const char *s, mdl_variations_target *t, int cap, int *n)
{
    while (*s) {
        char *end;
        long in = strtol(s, &end, 10);
        if (end == s || *end != ':')
            return -1;
        s = end + 1;
        long out = strtol(s, &end, 10);
        if (end == s || (*end && *end != ',') || in < 0 || out < 0 || in > 1 << 30 || out > 1 << 30)
            return -1;
        if (*n >= cap)
            return -1;
        t[(*n)++] = (mdl_variations_target){(int)in, (int)out};
        s = *end ? end + 1 : end;
    }
    return 0;
}

/* a chunk of variations walked in parallel: slot i walks seeds[i] into T, src */
typedef struct walk_batch {
    const mdl_variations *v;
    int frames, nb, nc, nt;
    const mdl_variations_target *t;
    uint64_t *seeds;
    double *T;
    int *src, *rc;
    char (*err)[MDL_ERR_LEN];
    /* --avoid: the obstacle, the mesh's triangles, per worker one frame's vertices (nv x 3) */
    const mdl_obstacle *ob;
    const uint32_t *F;
    int nf, nv, *redraws;
    float *scratch;
} walk_batch;

/* the walks of --avoid are redrawn at most this often (then an error) */
enum { AVOID_TRIES = 32 };

static void batch_body(void *ctx, int i, int worker)
{
    walk_batch *b = ctx;
    b->redraws[i] = 0;
    b->rc[i] = mdl_variations_walk_avoiding(b->v, b->ob, b->F, b->nf, b->seeds[i], b->frames, b->t,
                                            b->nt, AVOID_TRIES,
                                            b->T + (size_t)i * b->frames * b->nb * 12,
                                            b->src + (size_t)i * b->frames * b->nc,
                                            b->scratch + 3 * (size_t)b->nv * worker, &b->seeds[i],
                                            &b->redraws[i], b->err[i]);
}

/* The bone file (docs/FORMATS.md): header, then per variation u64 seed, frames x bones x 12
 * float32 (R row-major, t) and frames x components int32 input frames. */
static int bones_header(FILE *f, int count, int frames, int bones, int comps, float fps)
{
    uint32_t h[6] = {1, (uint32_t)count, (uint32_t)frames, (uint32_t)bones, (uint32_t)comps, 0};
    memcpy(&h[5], &fps, sizeof fps);
    return fwrite("MSVB", 1, 4, f) == 4 && fwrite(h, sizeof h, 1, f) == 1 ? 0 : -1;
}

static int bones_record(FILE *f, uint64_t seed, const double *T, const int *src, int frames,
                        int bones, int comps)
{
    if (fwrite(&seed, sizeof seed, 1, f) != 1)
        return -1;
    float buf[12 * 64];
    size_t n = (size_t)frames * bones * 12;
    for (size_t k = 0; k < n;) {
        size_t m = n - k < sizeof buf / sizeof *buf ? n - k : sizeof buf / sizeof *buf;
        for (size_t i = 0; i < m; i++)
            buf[i] = (float)T[k + i];
        if (fwrite(buf, sizeof *buf, m, f) != m)
            return -1;
        k += m;
    }
    for (size_t k = 0; k < (size_t)frames * comps; k++) {
        int32_t s = src[k];
        if (fwrite(&s, sizeof s, 1, f) != 1)
            return -1;
    }
    return 0;
}

/* "cut_nodes" and "components" (bones, cut, parent, ref_bone, tc, transitions and their list) */
static int add_components(cJSON *jo, const mdl_variations *v, const mdl_variations_stats *st)
{
    cJSON *cuts = cJSON_AddArrayToObject(jo, "cut_nodes");
    cJSON *comps = cJSON_AddArrayToObject(jo, "components");
    if (!cuts || !comps)
        return -1;
    cJSON_AddNumberToObject(jo, "component_count", st->components);
    for (int c = 0; c < st->components; c++) {
        mdl_variations_component k;
        mdl_variations_get_component(v, c, &k);
        if (k.cut >= 0)
            cJSON_AddItemToArray(cuts, cJSON_CreateNumber(k.cut));
        cJSON *e = cJSON_CreateObject(), *bones = cJSON_AddArrayToObject(e, "bones");
        if (!e || !bones)
            return -1;
        for (int b = 0; b < k.nbones; b++)
            cJSON_AddItemToArray(bones, cJSON_CreateNumber(k.bones ? k.bones[b] : b));
        cJSON_AddNumberToObject(e, "cut", k.cut);
        cJSON_AddNumberToObject(e, "parent", k.parent);
        cJSON_AddNumberToObject(e, "ref_bone", k.ref_bone);
        cJSON_AddNumberToObject(e, "tc", k.tc);
        cJSON_AddNumberToObject(e, "transitions", k.transitions);
        cJSON_AddNumberToObject(e, "alive_frames", k.alive_frames);
        cJSON *tl = cJSON_AddArrayToObject(e, "transition_list");
        for (int t = 0; tl && t < k.transitions; t++) {
            int a, b;
            double cost;
            mdl_variations_component_transition(v, c, t, &a, &b, &cost);
            cJSON *x = cJSON_CreateObject();
            cJSON_AddNumberToObject(x, "from", a);
            cJSON_AddNumberToObject(x, "to", b);
            cJSON_AddNumberToObject(x, "cost", cost);
            cJSON_AddItemToArray(tl, x);
        }
        cJSON_AddItemToArray(comps, e);
    }
    return 0;
}

int cmd_variations(int argc, char **argv)
{
    const char *cmd = "variations", *modelp = NULL, *outdir = NULL, *addto = NULL;
    int count = 0, frames = 0, seed = 1, json = 0, end = -1, npc2 = -1, ntargets = 0, gltf = 0;
    int threads = (int)sysconf(_SC_NPROCESSORS_ONLN);
    double max_overlap = 0.9;
    mdl_variations_target targets[258];
    const char *avoidp[16];
    int navoid = 0;
    mdl_variations_opts vo;
    mdl_variations_opts_default(&vo);
    vo.components = 0;
    enum { O_MODEL = 256, O_COUNT, O_FRAMES, O_SEED, O_THRESH, O_TCF, O_BLEND, O_BLENDF, O_JUMP, O_TEMP,
           O_MINSEG, O_START, O_JSON, O_ADD, O_COMP, O_TEF, O_END, O_TARGET, O_THREADS, O_PC2,
           O_OVERLAP, O_GROUND, O_GLTF, O_AVOID };
    static const struct option lo[] = {
        {"model", 1, 0, O_MODEL},         {"count", 1, 0, O_COUNT},   {"frames", 1, 0, O_FRAMES},
        {"seed", 1, 0, O_SEED},           {"threshold", 1, 0, O_THRESH},
        {"tc-factor", 1, 0, O_TCF},       {"blend", 1, 0, O_BLEND},   {"jump-prob", 1, 0, O_JUMP}, {"blend-frames", 1, 0, O_BLENDF},
        {"temperature", 1, 0, O_TEMP},    {"min-segment", 1, 0, O_MINSEG},
        {"start", 1, 0, O_START},         {"json", 0, 0, O_JSON},     {"help", 0, 0, 'h'},
        {"add-to", 1, 0, O_ADD},          {"components", 1, 0, O_COMP},
        {"te-factor", 1, 0, O_TEF},       {"end", 1, 0, O_END},       {"target", 1, 0, O_TARGET},
        {"ground", 0, 0, O_GROUND},       {"threads", 1, 0, O_THREADS},     {"pc2", 1, 0, O_PC2},       {"max-overlap", 1, 0, O_OVERLAP},
        {"gltf", 0, 0, O_GLTF},           {"avoid", 1, 0, O_AVOID},
        {0, 0, 0, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "ho:", lo, NULL)) != -1) {
        switch (c) {
        case O_MODEL: modelp = optarg; break;
        case O_COUNT: if (cli_parse_int(cmd, "--count", optarg, &count)) return CLI_EXIT_USAGE; break;
        case O_FRAMES: if (cli_parse_int(cmd, "--frames", optarg, &frames)) return CLI_EXIT_USAGE; break;
        case O_SEED: if (cli_parse_int(cmd, "--seed", optarg, &seed)) return CLI_EXIT_USAGE; break;
        case O_THRESH: if (cli_parse_double(cmd, "--threshold", optarg, &vo.threshold)) return CLI_EXIT_USAGE; break;
        case O_TCF: if (cli_parse_double(cmd, "--tc-factor", optarg, &vo.tc_factor)) return CLI_EXIT_USAGE; break;
        case O_BLEND:
            if (!strcmp(optarg, "gradient") || !strcmp(optarg, "linear"))
                vo.blend_linear = !strcmp(optarg, "linear");
            else
                return cli_usage_error(cmd, "--blend '%s': gradient or linear (the window's length "
                                       "is --blend-frames N)", optarg);
            break;
        case O_BLENDF: if (cli_parse_int(cmd, "--blend-frames", optarg, &vo.blend)) return CLI_EXIT_USAGE; break;
        case O_JUMP: if (cli_parse_double(cmd, "--jump-prob", optarg, &vo.jump_prob)) return CLI_EXIT_USAGE; break;
        case O_TEMP: if (cli_parse_double(cmd, "--temperature", optarg, &vo.temperature)) return CLI_EXIT_USAGE; break;
        case O_MINSEG: if (cli_parse_int(cmd, "--min-segment", optarg, &vo.min_segment)) return CLI_EXIT_USAGE; break;
        case O_START: if (cli_parse_int(cmd, "--start", optarg, &vo.start)) return CLI_EXIT_USAGE; break;
        case O_JSON: json = 1; break;
        case O_GLTF: gltf = 1; break;
        case O_AVOID:
            if (navoid >= 16)
                return cli_usage_error(cmd, "--avoid: 16 obstacle files at most");
            avoidp[navoid++] = optarg;
            break;
        case O_ADD: addto = optarg; break;
        case O_COMP:
            if (!strcmp(optarg, "auto"))
                vo.components = 0;
            else if (!strcmp(optarg, "1"))
                vo.components = 1;
            else
                return cli_usage_error(cmd, "--components '%s': auto or 1", optarg);
            break;
        case O_GROUND: vo.ground = 1; break;
        case O_END: if (cli_parse_int(cmd, "--end", optarg, &end)) return CLI_EXIT_USAGE; break;
        case O_TARGET:
            if (parse_targets(optarg, targets, 256, &ntargets))
                return cli_usage_error(cmd, "--target '%s': IN:OUT[,IN:OUT...] (frames >= 0, "
                                       "256 at most)", optarg);
            break;
        case O_THREADS: if (cli_parse_int(cmd, "--threads", optarg, &threads)) return CLI_EXIT_USAGE; break;
        case O_PC2: if (cli_parse_int(cmd, "--pc2", optarg, &npc2)) return CLI_EXIT_USAGE; break;
        case O_OVERLAP: if (cli_parse_double(cmd, "--max-overlap", optarg, &max_overlap)) return CLI_EXIT_USAGE; break;
        case O_TEF: if (cli_parse_double(cmd, "--te-factor", optarg, &vo.te_factor)) return CLI_EXIT_USAGE; break;
        case 'o': outdir = optarg; break;
        case 'h': fputs(usage_text, stdout); return CLI_EXIT_OK;
        default: fputs(usage_text, stderr); return CLI_EXIT_USAGE;
        }
    }
    if (optind < argc)
        return cli_usage_error(cmd, "unexpected argument '%s'", argv[optind]);
    if (!modelp)
        modelp = addto;
    int batch = !addto || outdir || count || frames;
    if (!modelp || (batch && (!outdir || count < 1 || frames < 1)))
        return cli_usage_error(cmd, "--model, --count (>= 1), --frames (>= 1) and -o are required "
                               "(or --add-to alone; see --help)");
    if (count > 100000 || frames > 10000000 || (double)count * frames > 1e9)
        return cli_usage_error(cmd, "--count x --frames is too large");
    if (vo.threshold < 0 || !(vo.tc_factor > 0) || vo.blend < 0 || !(vo.jump_prob >= 0) ||
        vo.jump_prob > 1 || !(vo.temperature >= 0) || vo.min_segment < 0 || vo.start < -1 ||
        !(vo.te_factor >= 0 && vo.te_factor <= 1) || end < -1 || threads < 1 || npc2 < -1 ||
        !(max_overlap >= 0 && max_overlap <= 1))
        return cli_usage_error(cmd, "--threshold, --tc-factor, --blend-frames, --jump-prob, "
                               "--temperature, --min-segment, --start, --te-factor, --end, --threads, --pc2 or "
                               "--max-overlap out of range");

    if (navoid && addto && !batch)
        return cli_usage_error(cmd, "--avoid checks the batch's walks; the idle source of "
                               "--add-to does not avoid obstacles");
    if (gltf && npc2 == 0)
        return cli_usage_error(cmd, "--gltf animates the variations --pc2 writes; --pc2 0 leaves none");
    char err[MDL_ERR_LEN] = "";
    int status = CLI_EXIT_USAGE;
    mdl_model *model = NULL;
    mdl_variations *v = NULL;
    double *T = NULL;
    float *V = NULL;
    int *src = NULL;
    cJSON *jo = NULL, *jvars = NULL;
    mdl_gltf *glb = NULL;
    char gpath[4096] = "";
    mdl_obstacle *ob = NULL;
    uint8_t *colliding = NULL;
    float *scratch = NULL;
    int *redraws = NULL;
    if (mdl_model_load(modelp, &model, err)) {
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    mdl_model_info info;
    mdl_model_get_info(model, &info);
    int nskinframes = 0, rc;
    {
        int nb, K;
        const int *bone;
        const double *w, *Ts;
        if (mdl_skin_get(model, &nb, &K, &nskinframes, &bone, &w, &Ts)) {
            cli_fail(cmd, status, "%s holds no skin (fit one with `meshsteer skin`)", modelp);
            goto out;
        }
    }
    if (vo.start >= nskinframes) {
        cli_fail(cmd, status, "--start %d: the skin has %d frames", vo.start, nskinframes);
        goto out;
    }
    mdl_set_blas_threads(1);
    struct timespec t0, t1;
    double analysis_s = 0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    rc = mdl_variations_build(model, &vo, &v, err);
    if (rc) {
        status = rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE;
        cli_fail(cmd, status, "%s", err);
        goto out;
    }
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    if (addto) {
        mdl_model *dst = NULL;
        rc = strcmp(addto, modelp) ? mdl_model_load(addto, &dst, err) : 0;
        if (!rc)
            rc = mdl_variations_attach(dst ? dst : model, &vo, (uint64_t)(unsigned)seed, err);
        if (!rc && mdl_model_save(dst ? dst : model, addto, err))
            rc = CLI_EXIT_FAIL;
        mdl_model_destroy(dst);
        if (rc) {
            status = rc == CLI_EXIT_FAIL ? CLI_EXIT_FAIL : CLI_EXIT_USAGE;
            cli_fail(cmd, status, "--add-to %s: %s", addto, err);
            goto out;
        }
        if (!batch) {
            if (json)
                printf("{\n\t\"transitions\":\t%d,\n\t\"tc\":\t%.17g,\n\t\"alive_frames\":\t%d\n}\n",
                       st.transitions, st.tc, st.alive_frames);
            status = CLI_EXIT_OK;
            goto out;
        }
    }
    if (mkdir(outdir, 0777) != 0 && errno != EEXIST) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s: %s", outdir, strerror(errno));
        goto out;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    analysis_s = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    /* --start and --end are targets at the first and last output frames */
    if (vo.start >= 0)
        targets[ntargets++] = (mdl_variations_target){vo.start, 0};
    if (end >= 0)
        targets[ntargets++] = (mdl_variations_target){end, frames - 1};
    for (int k = 0; k < ntargets; k++)
        if (targets[k].in >= nskinframes || targets[k].out >= frames) {
            status = cli_fail(cmd, CLI_EXIT_USAGE, "target %d:%d: the skin has %d frames, the "
                              "variations %d", targets[k].in, targets[k].out, nskinframes, frames);
            goto out;
        }
    /* --avoid (Sec. 3.4): the obstacle's tree, the colliding fitted frames kept out of the walks */
    int ncolliding = 0;
    double avoid_s = 0;
    if (navoid) {
        clock_gettime(CLOCK_MONOTONIC, &t1);
        mdl_mesh *meshes[16] = {0};
        rc = 0;
        for (int k = 0; k < navoid && !rc; k++) {
            rc = mdl_mesh_read_obj(avoidp[k], &meshes[k], err); /* the error names the file */
            if (rc)
                status = cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE,
                                  "--avoid: %s", err);
        }
        if (!rc && (rc = mdl_obstacle_create((const mdl_mesh *const *)meshes, navoid, &ob, err)))
            status = cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "--avoid %s: %s",
                              avoidp[0], err);
        for (int k = 0; k < navoid; k++)
            mdl_mesh_destroy(meshes[k]);
        if (rc)
            goto out;
        colliding = calloc(nskinframes, 1);
        if (!colliding) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
            goto out;
        }
        if ((rc = mdl_variations_colliding_frames(v, ob, info.F, info.nf, colliding, err))) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
            goto out;
        }
        for (int n = 0; n < nskinframes; n++)
            ncolliding += colliding[n];
        for (int k = 0; k < ntargets; k++)
            if (colliding[targets[k].in]) {
                status = cli_fail(cmd, CLI_EXIT_USAGE, "target %d:%d: fitted frame %d intersects "
                                  "the obstacle (--avoid %s)", targets[k].in, targets[k].out,
                                  targets[k].in, avoidp[0]);
                goto out;
            }
        if ((rc = mdl_variations_block_frames(v, colliding, err))) {
            status = cli_fail(cmd, CLI_EXIT_USAGE, "--avoid %s: %s (%d of %d fitted frames "
                              "intersect it)", avoidp[0], err, ncolliding, nskinframes);
            goto out;
        }
        mdl_variations_get_stats(v, &st);
        struct timespec t2;
        clock_gettime(CLOCK_MONOTONIC, &t2);
        avoid_s = (t2.tv_sec - t1.tv_sec) + 1e-9 * (t2.tv_nsec - t1.tv_nsec);
    }
    if (npc2 < 0 || npc2 > count)
        npc2 = count;
    int ncomp = st.components, nb = st.bones;
    /* a chunk of variations walked at once: at most 64, and about 256 MB of bone transforms */
    size_t per = (size_t)frames * nb * 12 * sizeof(double);
    int chunk = (int)((256u << 20) / (per ? per : 1));
    chunk = chunk < 1 ? 1 : chunk > 64 ? 64 : chunk;
    chunk = chunk > count ? count : chunk;
    T = malloc((size_t)chunk * per);
    V = malloc((size_t)frames * info.nv * 3 * sizeof *V);
    src = malloc((size_t)count * frames * ncomp * sizeof *src);
    uint64_t *seeds = calloc(chunk, sizeof *seeds);
    int *rcs = calloc(chunk, sizeof *rcs);
    char(*errs)[MDL_ERR_LEN] = calloc(chunk, sizeof *errs);
    redraws = calloc(chunk, sizeof *redraws);
    scratch = malloc((size_t)(threads < 64 ? threads : 64) * info.nv * 3 * sizeof *scratch);
    char bpath[4096];
    snprintf(bpath, sizeof bpath, "%s/variations.bones", outdir);
    FILE *bf = fopen(bpath, "wb");
    if (json) {
        jo = cJSON_CreateObject();
        jvars = cJSON_CreateArray();
    }
    if (!T || !V || !src || !seeds || !rcs || !errs || !redraws || !scratch || !bf ||
        (json && (!jo || !jvars)) ||
        bones_header(bf, count, frames, nb, ncomp, info.fps > 0 ? (float)info.fps : 30.0f)) {
        if (bf)
            status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory for %d frames", frames);
        else
            status = cli_fail(cmd, CLI_EXIT_FAIL, "%s: %s", bpath, strerror(errno));
        free(seeds);
        free(rcs);
        free(errs);
        if (bf)
            fclose(bf);
        goto out;
    }
    if (gltf && npc2 > 0) {
        snprintf(gpath, sizeof gpath, "%s/variations.glb", outdir);
        if ((rc = mdl_gltf_begin(model, &glb, err))) {
            status = cli_fail(cmd, rc == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE, "%s: %s", gpath, err);
            free(seeds);
            free(rcs);
            free(errs);
            fclose(bf);
            goto out;
        }
    }
    double ej, ea, eamax, worst = 0, worst_acc = 0, floor_range[2], worst_floor = 0;
    example_motion(model, &ej, &ea, &eamax, floor_range);
    cli_pool pool = {threads};
    walk_batch bt = {v, frames, nb, ncomp, ntargets, targets, seeds, T, NULL, rcs, errs,
                     ob, info.F, info.nf, info.nv, redraws, scratch};
    uint64_t next_seed = (uint64_t)(unsigned)seed + (uint64_t)count;
    int redrawn = 0, over = 0, met = 0, bad = 0, avoid_redrawn = 0, avoid_max = 0;
    for (int k0 = 0; k0 < count && !bad; k0 += chunk) {
        int n = count - k0 < chunk ? count - k0 : chunk;
        for (int i = 0; i < n; i++)
            seeds[i] = (uint64_t)(unsigned)seed + (uint64_t)(k0 + i);
        bt.src = src + (size_t)k0 * frames * ncomp;
        if (threads > 1)
            cli_parallel_for(&pool, n, batch_body, &bt);
        else
            for (int i = 0; i < n; i++)
                batch_body(&bt, i, 0);
        for (int i = 0; i < n; i++) {
            int k = k0 + i;
            double *Tk = T + (size_t)i * frames * nb * 12;
            int *sk = src + (size_t)k * frames * ncomp;
            /* Sec. 3.4's overlap test against the earlier variations, in order (so the result
             * does not depend on --threads): a repeat is walked again with the next seed */
            double ov = 0;
            for (int tries = 0; !rcs[i]; tries++) {
                ov = 0;
                for (int l = 0; l < k; l++) {
                    double o = mdl_variations_overlap(sk, src + (size_t)l * frames * ncomp, frames, ncomp);
                    ov = o > ov ? o : ov;
                }
                if (ov <= max_overlap || tries >= 20)
                    break;
                seeds[i] = next_seed++;
                redrawn++;
                int more = 0;
                rcs[i] = mdl_variations_walk_avoiding(v, ob, info.F, info.nf, seeds[i], frames,
                                                      targets, ntargets, AVOID_TRIES, Tk, sk,
                                                      scratch, &seeds[i], &more, errs[i]);
                redraws[i] += more;
            }
            avoid_redrawn += redraws[i];
            avoid_max = redraws[i] > avoid_max ? redraws[i] : avoid_max;
            if (rcs[i]) {
                status = rcs[i] == -ENOMEM ? CLI_EXIT_FAIL : CLI_EXIT_USAGE;
                if (rcs[i] == -EAGAIN && ob)
                    cli_fail(cmd, status, "--avoid %s: variation %d: %s", avoidp[0], k, errs[i]);
                else
                    cli_fail(cmd, status, "%s", errs[i]);
                bad = 1;
                break;
            }
            over += ov > max_overlap;
            int ok = 1;
            for (int t = 0; t < ntargets; t++)
                for (int q = 0; q < ncomp; q++)
                    ok &= sk[(size_t)ncomp * targets[t].out + q] == targets[t].in;
            met += ok;
            if (bones_record(bf, seeds[i], Tk, sk, frames, nb, ncomp)) {
                status = cli_fail(cmd, CLI_EXIT_FAIL, "%s: %s", bpath, strerror(errno));
                bad = 1;
                break;
            }
            if (k >= npc2)
                continue;
            if (glb) {
                char name[32];
                snprintf(name, sizeof name, "variation_%03d", k);
                if (mdl_gltf_add_clip(glb, name, Tk, frames, info.fps > 0 ? info.fps : 30, 0, err)) {
                    status = cli_fail(cmd, CLI_EXIT_FAIL, "%s: %s", gpath, err);
                    bad = 1;
                    break;
                }
            }
            for (int f = 0; f < frames; f++)
                mdl_variations_skin_frame(v, Tk + (size_t)f * nb * 12, V + 3 * (size_t)f * info.nv);
            char path[4096];
            snprintf(path, sizeof path, "%s/variation_%03d.pc2", outdir, k);
            if (mdl_pc2_write(path, V, info.nv, frames, 0.0f, 1.0f, err)) {
                status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
                bad = 1;
                break;
            }
            double j = max_jump(V, info.nv, frames);
            worst = j > worst ? j : worst;
            /* the lowest vertex per frame against the example's range of it */
            double fe = 0;
            for (int f = 0; f < frames; f++) {
                double lo = lowest_y(V + 3 * (size_t)f * info.nv, info.nv);
                double d = lo < floor_range[0] ? floor_range[0] - lo : lo > floor_range[1] ? lo - floor_range[1] : 0;
                fe = d > fe ? d : fe;
            }
            worst_floor = fe > worst_floor ? fe : worst_floor;
            /* smoothness at the transitions (of any component): the largest vertex acceleration
             * within 3 frames */
            double ta = 0;
            for (int f = 1; f < frames; f++) {
                int jumped = 0;
                for (int q = 0; q < ncomp; q++)
                    jumped |= sk[(size_t)ncomp * f + q] != sk[(size_t)ncomp * (f - 1) + q] + 1;
                if (!jumped)
                    continue;
                for (int g = f - 3; g <= f + 3; g++)
                    if (g >= 1 && g + 1 < frames) {
                        double a = accel_at(V, info.nv, g);
                        ta = a > ta ? a : ta;
                    }
            }
            worst_acc = ta > worst_acc ? ta : worst_acc;
            if (jvars) {
                int taken = 0;
                cJSON *e = cJSON_CreateObject();
                cJSON *ct = cJSON_AddArrayToObject(e, "components_taken");
                for (int q = 0; q < ncomp; q++) {
                    char *seq = walk_taken(sk, ncomp, q, frames, &taken);
                    if (!seq) {
                        cJSON_Delete(e);
                        e = NULL;
                        break;
                    }
                    cJSON_AddItemToArray(ct, cJSON_CreateString(seq));
                    free(seq);
                }
                if (!e) {
                    status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
                    bad = 1;
                    break;
                }
                cJSON_AddStringToObject(e, "file", path);
                cJSON_AddNumberToObject(e, "seed", (double)seeds[i]);
                cJSON_AddNumberToObject(e, "start", sk[0]);
                cJSON_AddNumberToObject(e, "transitions_taken", taken);
                cJSON_AddNumberToObject(e, "overlap", ov);
                if (ob)
                    cJSON_AddNumberToObject(e, "collision_redraws", redraws[i]);
                cJSON_AddNumberToObject(e, "max_jump", j);
                cJSON_AddNumberToObject(e, "floor_excursion", fe);
                cJSON_AddNumberToObject(e, "max_jump_ratio", ej > 0 ? j / ej : 0);
                cJSON_AddNumberToObject(e, "transition_max_accel", ta);
                cJSON_AddNumberToObject(e, "transition_accel_ratio", ea > 0 ? ta / ea : 0);
                cJSON_AddItemToArray(jvars, e);
            }
        }
    }
    free(seeds);
    free(rcs);
    free(errs);
    if (fclose(bf) != 0 && !bad) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s: %s", bpath, strerror(errno));
        bad = 1;
    }
    if (bad)
        goto out;
    if (glb && mdl_gltf_write(glb, gpath, err)) {
        status = cli_fail(cmd, CLI_EXIT_FAIL, "%s", err);
        goto out;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    if (jo) {
        cJSON_AddNumberToObject(jo, "bones", st.bones);
        cJSON_AddNumberToObject(jo, "frames", st.frames);
        cJSON_AddNumberToObject(jo, "ref_bone", st.ref_bone);
        cJSON_AddNumberToObject(jo, "rank", st.rank);
        cJSON_AddNumberToObject(jo, "alpha", st.alpha);
        cJSON_AddNumberToObject(jo, "beta", st.beta);
        cJSON_AddNumberToObject(jo, "max_adjacent", st.max_adjacent);
        cJSON_AddNumberToObject(jo, "tc", st.tc);
        cJSON_AddStringToObject(jo, "blend", vo.blend < 1 ? "none" : vo.blend_linear ? "linear" : "gradient");
        cJSON_AddNumberToObject(jo, "blend_frames", vo.blend);
        cJSON_AddNumberToObject(jo, "key_vertices", st.key_vertices);
        cJSON_AddNumberToObject(jo, "transitions", st.transitions);
        cJSON_AddNumberToObject(jo, "single_transitions", st.single_transitions);
        if (add_components(jo, v, &st)) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
            goto out;
        }
        cJSON_AddNumberToObject(jo, "alive_frames", st.alive_frames);
        cJSON *tl = cJSON_AddArrayToObject(jo, "transition_list");
        for (int k = 0; tl && k < st.transitions; k++) {
            int a, b;
            double cost;
            mdl_variations_transition(v, k, &a, &b, &cost);
            cJSON *e = cJSON_CreateObject();
            cJSON_AddNumberToObject(e, "from", a);
            cJSON_AddNumberToObject(e, "to", b);
            cJSON_AddNumberToObject(e, "cost", cost);
            cJSON_AddItemToArray(tl, e);
        }
        cJSON_AddNumberToObject(jo, "count", count);
        cJSON_AddNumberToObject(jo, "frames_per_variation", frames);
        cJSON_AddNumberToObject(jo, "frames_total", (double)count * frames);
        cJSON_AddNumberToObject(jo, "example_max_jump", ej);
        cJSON_AddNumberToObject(jo, "max_jump", worst);
        cJSON_AddNumberToObject(jo, "max_jump_ratio", ej > 0 ? worst / ej : 0);
        cJSON_AddNumberToObject(jo, "example_p99_accel", ea);
        cJSON_AddNumberToObject(jo, "example_max_accel", eamax);
        cJSON_AddNumberToObject(jo, "transition_max_accel", worst_acc);
        cJSON_AddNumberToObject(jo, "transition_accel_ratio", ea > 0 ? worst_acc / ea : 0);
        cJSON_AddNumberToObject(jo, "synth_s",
                                (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec));
        cJSON_AddNumberToObject(jo, "analysis_s", analysis_s);
        cJSON_AddNumberToObject(jo, "example_floor_min", floor_range[0]);
        cJSON_AddNumberToObject(jo, "example_floor_max", floor_range[1]);
        cJSON_AddNumberToObject(jo, "floor_excursion", worst_floor);
        cJSON_AddNumberToObject(jo, "threads", threads);
        cJSON_AddNumberToObject(jo, "targets", ntargets);
        cJSON_AddNumberToObject(jo, "targets_met", met);
        cJSON_AddNumberToObject(jo, "max_overlap", max_overlap);
        cJSON_AddNumberToObject(jo, "overlap_redrawn", redrawn);
        cJSON_AddNumberToObject(jo, "overlap_kept_over", over);
        cJSON_AddNumberToObject(jo, "pc2_written", npc2);
        if (ob) {
            int ntri;
            float lo[3], hi[3];
            mdl_obstacle_get_info(ob, &ntri, lo, hi);
            cJSON *jb = cJSON_AddObjectToObject(jo, "obstacle");
            cJSON *files = cJSON_AddArrayToObject(jb, "files");
            for (int k = 0; files && k < navoid; k++)
                cJSON_AddItemToArray(files, cJSON_CreateString(avoidp[k]));
            cJSON_AddNumberToObject(jb, "triangles", ntri);
            cJSON *bl = cJSON_AddArrayToObject(jb, "box_min"), *bh = cJSON_AddArrayToObject(jb, "box_max");
            for (int c = 0; bl && bh && c < 3; c++) {
                cJSON_AddItemToArray(bl, cJSON_CreateNumber(lo[c]));
                cJSON_AddItemToArray(bh, cJSON_CreateNumber(hi[c]));
            }
            cJSON *cf = cJSON_AddArrayToObject(jo, "colliding_input_frames");
            for (int n = 0; cf && n < nskinframes; n++)
                if (colliding[n])
                    cJSON_AddItemToArray(cf, cJSON_CreateNumber(n));
            cJSON_AddNumberToObject(jo, "colliding_input_count", ncolliding);
            cJSON_AddNumberToObject(jo, "collision_redrawn", avoid_redrawn);
            cJSON_AddNumberToObject(jo, "collision_redraws_max", avoid_max);
            cJSON_AddNumberToObject(jo, "collision_tries", AVOID_TRIES);
            cJSON_AddNumberToObject(jo, "avoid_setup_s", avoid_s);
        }
        cJSON_AddStringToObject(jo, "bones_file", bpath);
        if (glb)
            cJSON_AddStringToObject(jo, "gltf", gpath);
        cJSON_AddItemToObject(jo, "variations", jvars);
        jvars = NULL;
        int pr = cli_print_json(jo);
        jo = NULL;
        if (pr) {
            status = cli_fail(cmd, CLI_EXIT_FAIL, "out of memory");
            goto out;
        }
    }
    status = CLI_EXIT_OK;
out:
    cJSON_Delete(jvars);
    cJSON_Delete(jo);
    mdl_gltf_free(glb);
    mdl_obstacle_destroy(ob);
    free(colliding);
    free(scratch);
    free(redraws);
    free(T);
    free(V);
    free(src);
    mdl_variations_destroy(v);
    mdl_model_destroy(model);
    return status;
}
