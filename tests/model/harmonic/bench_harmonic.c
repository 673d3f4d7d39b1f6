/* bench_harmonic.c - speed of the harmonic kind (issue 9; meson benchmark, not a timed test):
 * the static human (static-human/human_man.obj, 13,776 triangles) subdivided 1-to-4 once and twice
 * (midpoint subdivision, below: ~55K and ~220K triangles), driven by 131_03.bvh through
 * rigs/human-cmu-harmonic.json; beside it, in the same run, the steering model of the built-in
 * example creature. One thread (BLAS pinned to 1).
 * Printed per mesh: set-up (mdl_harmonic_build: correspondences + a trial factorisation; and
 * mdl__hdeform_init alone: cotangent weights, both Laplacian assemblies and CHOLMOD
 * factorisations), per-frame synthesis median and p99, frames/s, the factors' nonzeros and the
 * memory-traffic floor: per frame both factors are read twice (forward and backward sweep; one pass
 * serves all 4 (field) or 3 (Poisson) columns), 12 bytes per nonzero (a double and an int index),
 * divided by this machine's read bandwidth (a sum over a 256 MB buffer, best of 3).
 * Then the deformer alone (mdl__hdeform_run) against the same with the stretch (eval --stretch:
 * six more field columns and R U per triangle, mdl__hdeform_run_stretch), same varied group
 * rotations, U near I: CPU median and p99 of each.
 * argv[1]: frames per mesh (default 300). Targets (issue 9): >= 100 frames/s at ~55K, >= 20 at
 * ~220K, set-up <= 2 s at ~220K; reported, not asserted (the machines are shared). */
#include "harmonic/harmonic_internal.h"
#include "kind.h"
#include "test.h"

#include <stdint.h>
#include <time.h>

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* this thread's CPU time: on a shared machine the steadier figure (wall time includes waiting
 * for a core) */
static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmpd(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void pct(double *t, int n, double *med, double *p99)
{
    qsort(t, (size_t)n, sizeof *t, cmpd);
    *med = t[n / 2];
    *p99 = t[(size_t)(0.99 * (n - 1))];
}

/* 1-to-4 midpoint subdivision: one new vertex per edge (an open-addressing table keyed by the
 * sorted vertex pair), each triangle into four. Returns a new mesh (mdl_mesh_destroy). */
static mdl_mesh *subdivide(const mdl_mesh *m)
{
    size_t cap = 1;
    while (cap < 6 * (size_t)m->nf)
        cap <<= 1;
    uint64_t *key = malloc(cap * sizeof *key);
    int *val = malloc(cap * sizeof *val);
    mdl_mesh *o = calloc(1, sizeof *o);
    int nvmax = m->nv + 3 * m->nf;
    ASSERT(key && val && o);
    o->V = malloc(3 * (size_t)nvmax * sizeof *o->V);
    o->F = malloc(12 * (size_t)m->nf * sizeof *o->F);
    ASSERT(o->V && o->F);
    memset(key, 0xff, cap * sizeof *key);
    memcpy(o->V, m->V, 3 * (size_t)m->nv * sizeof *o->V);
    int nv = m->nv;
    for (int t = 0; t < m->nf; t++) {
        uint32_t c[3], mid[3];
        for (int k = 0; k < 3; k++)
            c[k] = m->F[3 * t + k];
        for (int k = 0; k < 3; k++) {
            uint32_t a = c[k], b = c[(k + 1) % 3], lo = a < b ? a : b, hi = a < b ? b : a;
            uint64_t kk = ((uint64_t)lo << 32) | hi;
            size_t h = (size_t)((kk * 0x9E3779B97F4A7C15ull) >> 20) & (cap - 1);
            while (key[h] != UINT64_MAX && key[h] != kk)
                h = (h + 1) & (cap - 1);
            if (key[h] != kk) {
                key[h] = kk;
                val[h] = nv;
                for (int d = 0; d < 3; d++)
                    o->V[3 * (size_t)nv + d] = 0.5f * (m->V[3 * a + d] + m->V[3 * b + d]);
                nv++;
            }
            mid[k] = (uint32_t)val[h]; /* the midpoint of edge c[k] c[k+1] */
        }
        uint32_t *f = o->F + 12 * (size_t)t;
        uint32_t q[12] = {c[0], mid[0], mid[2], c[1], mid[1], mid[0], c[2], mid[2], mid[1],
                          mid[0], mid[1], mid[2]};
        memcpy(f, q, sizeof q);
    }
    o->nv = nv;
    o->nf = 4 * m->nf;
    free(key);
    free(val);
    return o;
}

/* read bandwidth in bytes/s: the best of 3 sums over a 256 MB buffer */
static double bandwidth(void)
{
    size_t n = (256u << 20) / sizeof(double);
    double *b = malloc(n * sizeof *b), best = 0, sink = 0;
    ASSERT(b);
    for (size_t i = 0; i < n; i++)
        b[i] = (double)(i & 7);
    for (int r = 0; r < 3; r++) {
        double t0 = now_s(), s0 = 0, s1 = 0, s2 = 0, s3 = 0;
        for (size_t i = 0; i < n; i += 4)
            s0 += b[i], s1 += b[i + 1], s2 += b[i + 2], s3 += b[i + 3];
        double dt = now_s() - t0;
        sink += s0 + s1 + s2 + s3;
        if (n * sizeof *b / dt > best)
            best = (double)(n * sizeof *b) / dt;
    }
    free(b);
    if (sink == 42)
        printf(" ");
    return best;
}

static void bench_mesh(const char *label, const mdl_mesh *target, const mdl_rig *rig,
                       const mdl_markers *rest, const mdl_markers *mk, int frames, double bw)
{
    char err[MDL_ERR_LEN] = "";
    mdl_harmonic_opts o;
    mdl_harmonic_opts_default(&o);
    o.template_motion = mk;
    mdl_model *m = NULL;
    double t0 = now_s(), b0 = cpu_s();
    ASSERT_OK(mdl_harmonic_build(target, rig, rest, &o, &m, err), err);
    double tbuild = now_s() - t0, tbuildc = cpu_s() - b0;
    const struct mdl_harmonic *h = mdl__model_kind(m, MDL_KIND_HARMONIC)->impl;
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    mdl__hdeform d;
    t0 = now_s();
    double c0 = cpu_s();
    ASSERT_OK(mdl__hdeform_init(&d, h, info.rest, info.F, err), err);
    double tinit = now_s() - t0, tinitc = cpu_s() - c0;
    size_t lf = mdl__spd_factor_nnz(d.field.spd), lp = mdl__spd_factor_nnz(d.pois.spd);
    /* the deformer alone, rotation-only and with the stretch */
    mdl__hdeform ds;
    ASSERT_OK(mdl__hdeform_init_mode(&ds, h, info.rest, info.F, 1, err), err);
    double *qg = calloc(4 * (size_t)h->ngroups, sizeof *qg), *ug = calloc(6 * (size_t)h->ngroups, sizeof *ug);
    double *tr = calloc((size_t)frames, sizeof *tr), *ts = calloc((size_t)frames, sizeof *ts);
    ASSERT(qg && ug && tr && ts);
    for (int f = 0; f < frames; f++) {
        for (int g = 0; g < h->ngroups; g++) {
            double a = 0.3 * sin(0.05 * f + g);
            qg[4 * g] = cos(a), qg[4 * g + 1] = sin(a), qg[4 * g + 2] = qg[4 * g + 3] = 0;
            double u[6] = {1 + 0.05 * sin(0.1 * f + g), 0.01, 0, 1, 0, 1};
            memcpy(ug + 6 * g, u, sizeof u);
        }
        double ac = cpu_s();
        ASSERT_OK(mdl__hdeform_run(&d, qg), label);
        tr[f] = 1e6 * (cpu_s() - ac);
        ac = cpu_s();
        ASSERT_OK(mdl__hdeform_run_stretch(&ds, qg, ug), label);
        ts[f] = 1e6 * (cpu_s() - ac);
    }
    double rmed, rp99, smed, sp99;
    pct(tr, frames, &rmed, &rp99);
    pct(ts, frames, &smed, &sp99);
    size_t lfs = mdl__spd_factor_nnz(ds.field.spd);
    free(qg), free(ug), free(tr), free(ts);
    mdl__hdeform_fini(&ds);
    mdl__hdeform_fini(&d);
    mdl_synth *s = NULL;
    ASSERT_OK(mdl_synth_create(m, 0, &s, err), err);
    int nmk = info.nmarkers, nv = info.nv;
    int *map = calloc((size_t)nmk, sizeof *map);
    float *in = calloc(3 * (size_t)nmk, sizeof *in), *V = calloc(3 * (size_t)nv, sizeof *V);
    double *t = calloc((size_t)frames, sizeof *t), *tc = calloc((size_t)frames, sizeof *tc);
    ASSERT(map && in && V && t && tc);
    ASSERT_INT_EQ(mdl_model_bind_markers(m, (const char *const *)mk->names, mk->count, map), 0);
    for (int f = 0; f < frames; f++) {
        const float *P = mk->P + 3 * (size_t)(f % mk->frames) * mk->count;
        for (int i = 0; i < nmk; i++)
            memcpy(in + 3 * i, P + 3 * map[i], 3 * sizeof *in);
        double a = now_s(), ac = cpu_s();
        ASSERT_OK(mdl_synth_markers(s, in, NULL, V, NULL), label);
        t[f] = 1e6 * (now_s() - a);
        tc[f] = 1e6 * (cpu_s() - ac);
    }
    double med, p99, cmed, cp99;
    pct(t, frames, &med, &p99);
    pct(tc, frames, &cmed, &cp99);
    double bytes = 2.0 * 12.0 * (double)(lf + lp), floor_us = 1e6 * bytes / bw;
    printf("harmonic %-4s %6d vertices %6d triangles: build %.3f s (CPU %.3f s; deformer set-up "
           "%.3f s, CPU %.3f s)\n  frame wall median %.0f us p99 %.0f us (%.0f frames/s); CPU median %.0f us "
           "p99 %.0f us (%.0f frames/s)\n  factor nnz %zu + %zu: %.1f MB read per frame, floor "
           "%.0f us (%.0f%% of the CPU median)\n",
           label, nv, info.nf, tbuild, tbuildc, tinit, tinitc, med, p99, 1e6 / med, cmed, cp99, 1e6 / cmed, lf,
           lp, bytes / 1e6, floor_us, 100 * floor_us / cmed);
    printf("  deformer alone, CPU median / p99: rotation %.0f / %.0f us, rotation+stretch %.0f / %.0f "
           "us (field factor nnz %zu, the same)\n", rmed, rp99, smed, sp99, lfs);
    free(map), free(in), free(V), free(t), free(tc);
    mdl_synth_destroy(s);
    mdl_model_destroy(m);
}

static void bench_steer(int frames)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    ASSERT_OK(mdl_example_create(40, &seq, &rig, err), err);
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    int *ti = calloc(20, sizeof *ti);
    ASSERT(ti);
    for (int i = 0; i < 20; i++)
        ti[i] = 2 * i;
    mdl_model *m = NULL;
    double t0 = now_s();
    ASSERT_OK(mdl_steer_train(seq, ti, 20, rig, NULL, &o, &m, err), err);
    double ttrain = now_s() - t0;
    mdl_synth *s = NULL;
    ASSERT_OK(mdl_synth_create(m, 0, &s, err), err);
    int nm = rig->nmarkers, nv = seq->nv;
    float *mk = calloc(3 * (size_t)nm, sizeof *mk), *V = calloc(3 * (size_t)nv, sizeof *V);
    double *t = calloc((size_t)frames, sizeof *t), *tc = calloc((size_t)frames, sizeof *tc);
    ASSERT(mk && V && t && tc);
    for (int f = 0; f < frames; f++) {
        int fr = 1 + 2 * (f % 19); /* held-out frames */
        for (int j = 0; j < nm; j++)
            memcpy(mk + 3 * j, seq->V + ((size_t)fr * nv + rig->markers[j].vertex) * 3, 3 * sizeof *mk);
        double a = now_s(), ac = cpu_s();
        ASSERT_OK(mdl_synth_markers(s, mk, NULL, V, NULL), "steer");
        t[f] = 1e6 * (now_s() - a);
        tc[f] = 1e6 * (cpu_s() - ac);
    }
    double med, p99, cmed, cp99;
    pct(t, frames, &med, &p99);
    pct(tc, frames, &cmed, &cp99);
    printf("steer    example %6d vertices %6d triangles: train %.3f s\n  frame wall median %.0f us "
           "p99 %.0f us (%.0f frames/s); CPU median %.0f us p99 %.0f us\n", nv, seq->nf, ttrain, med,
           p99, 1e6 / med, cmed, cp99);
    free(mk), free(V), free(t), free(tc), free(ti);
    mdl_synth_destroy(s);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(seq);
    mdl_rig_destroy(rig);
}

int main(int argc, char **argv)
{
    int frames = argc > 1 ? atoi(argv[1]) : 300;
    if (frames < 10)
        frames = 10;
    mdl_set_blas_threads(1);
    char err[MDL_ERR_LEN] = "";
    mdl_mesh *m0 = NULL;
    mdl_rig *rig = NULL;
    mdl_markers *rest = NULL, *mk = NULL;
    ASSERT_OK(mdl_mesh_read_obj(test_data("meshes/static-human/human_man.obj"), &m0, err), err);
    ASSERT_OK(mdl_rig_read(test_src("rigs/human-cmu-harmonic.json"), 0, &rig, err), err);
    const char *bvh = test_data("mocap/bvh/cmu/131_03.bvh");
    mdl_marker_opts mo = {0};
    mo.rest = 1;
    ASSERT_OK(mdl_markers_read(bvh, &mo, &rest, err), err);
    mo.rest = 0;
    ASSERT_OK(mdl_markers_read(bvh, &mo, &mk, err), err);
    double bw = bandwidth();
    printf("read bandwidth %.1f GB/s (sum over 256 MB, best of 3); %d frames per mesh\n", bw / 1e9,
           frames);
    mdl_mesh *m1 = subdivide(m0), *m2 = subdivide(m1);
    bench_steer(frames);
    bench_mesh("x1", m0, rig, rest, mk, frames, bw);
    bench_mesh("x4", m1, rig, rest, mk, frames, bw);
    bench_mesh("x16", m2, rig, rest, mk, frames, bw);
    mdl_mesh_destroy(m0);
    mdl_mesh_destroy(m1);
    mdl_mesh_destroy(m2);
    mdl_rig_destroy(rig);
    mdl_markers_destroy(rest);
    mdl_markers_destroy(mk);
    return 0;
}
