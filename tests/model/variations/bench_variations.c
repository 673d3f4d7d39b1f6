/* bench_variations.c - Zheng 2013 synthesis speed (issue 11; a benchmark, not a timed test).
 * On samba's skin (40 bones, 4 influences; fitted here, untimed, or read from argv[1]), with the
 * default (linear) blend or, when argv[2] is "gradient", Sec. 3.3's:
 *   analysis   mdl_variations_build (transitions; with components auto also the bone graph and
 *              the components' graphs), median and p99 of 9 runs
 *   synthesis  1000 variations x 600 frames, bone motions only (mdl_variations_walk, no
 *              skinning), on 1 and 2 threads (variation k on thread k mod T; seeds fixed, so the
 *              output does not depend on T): wall and process CPU time, and median / p99 per
 *              variation of wall and thread CPU time (the machines are shared: CPU time is the
 *              steadier figure)
 *   baseline   in the same run, per variation: 600 frames copied from the fitted bone animation
 *              (the loop the skin plays without variations; the cost floor of writing the frames)
 * Targets (issue 11): 1000 x 600 in <= 10 s on 2 cores, analysis <= 5 s (Zheng's Table 1: 80.6 s
 * and 162.7 s on a quad-core i7; 1.4 - 9.7 min analysis). */
#include "model.h"
#include "test.h"
#include "fit.h"

#include <pthread.h>
#include <time.h>
#include <unistd.h>

#define COUNT 1000
#define FRAMES 600

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static double cpu(clockid_t id)
{
    struct timespec t;
    clock_gettime(id, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void med_p99(double *x, int n, double *med, double *p99)
{
    qsort(x, n, sizeof *x, cmp_d);
    *med = x[n / 2];
    *p99 = x[(int)(0.99 * (n - 1))];
}

typedef struct run {
    const mdl_variations *v;
    const double *Tfit;
    int nb, nfit, threads, worker, baseline;
    double *per; /* COUNT wall seconds */
    double *cpu; /* COUNT thread CPU seconds */
    double *T;   /* FRAMES x nb x 12 */
    int failed;
} run;

static void *worker(void *arg)
{
    run *r = arg;
    char err[MDL_ERR_LEN];
    for (int k = r->worker; k < COUNT; k += r->threads) {
        double t0 = now(), c0 = cpu(CLOCK_THREAD_CPUTIME_ID);
        if (r->baseline)
            for (int f = 0; f < FRAMES; f++)
                memcpy(r->T + (size_t)f * r->nb * 12, r->Tfit + (size_t)(f % r->nfit) * r->nb * 12,
                       (size_t)r->nb * 12 * sizeof *r->T);
        else if (mdl_variations_walk(r->v, 1 + k, FRAMES, r->T, NULL, NULL, err))
            r->failed = 1;
        r->per[k] = now() - t0;
        r->cpu[k] = cpu(CLOCK_THREAD_CPUTIME_ID) - c0;
    }
    return NULL;
}

/* wall seconds of COUNT variations on `threads` threads; per-variation times in per */
static double synth(const mdl_variations *v, const double *Tfit, int nb, int nfit, int threads,
                    int baseline, double *per, double *cpus, double *proc)
{
    pthread_t tid[8];
    run r[8];
    double t0 = now(), p0 = cpu(CLOCK_PROCESS_CPUTIME_ID);
    for (int w = 0; w < threads; w++) {
        r[w] = (run){v, Tfit, nb, nfit, threads, w, baseline, per, cpus,
                     calloc((size_t)FRAMES * nb * 12, sizeof(double)), 0};
        ASSERT_INT_EQ(pthread_create(&tid[w], NULL, worker, &r[w]), 0);
    }
    for (int w = 0; w < threads; w++) {
        pthread_join(tid[w], NULL);
        ASSERT_INT_EQ(r[w].failed, 0);
        free(r[w].T);
    }
    *proc = cpu(CLOCK_PROCESS_CPUTIME_ID) - p0;
    return now() - t0;
}

int main(int argc, char **argv)
{
    /* argv[2] "gradient": Sec. 3.3's blend instead of the default (linear) */
    int gradient = argc > 2 && !strcmp(argv[2], "gradient");
    mdl_set_blas_threads(1);
    char err[MDL_ERR_LEN] = "";
    mdl_model *m = NULL;
    if (argc > 1) {
        ASSERT_OK(mdl_model_load(argv[1], &m, err), err);
    } else {
        printf("fitting samba's skin (40 bones, serial, untimed) ...\n");
        fflush(stdout);
        m = vt_fit_skin("meshes/samba/samba.pc2", "meshes/samba/rest.obj", 40);
    }
    int nb, K, nfit;
    const int *bone;
    const double *w, *Tfit;
    ASSERT_OK(mdl_skin_get(m, &nb, &K, &nfit, &bone, &w, &Tfit), "no skin");
    printf("samba skin: %d bones, %d frames; %ld online CPUs\n", nb, nfit, sysconf(_SC_NPROCESSORS_ONLN));
    for (int comps = 1; comps >= 0; comps--) {
        mdl_variations_opts o;
        mdl_variations_opts_default(&o);
        o.components = comps;
        o.blend_linear = !gradient;
        double at[9];
        mdl_variations *v = NULL;
        for (int r = 0; r < 9; r++) {
            mdl_variations_destroy(v);
            v = NULL;
            double t0 = now();
            ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
            at[r] = now() - t0;
        }
        mdl_variations_stats st;
        mdl_variations_get_stats(v, &st);
        double amed, ap99;
        med_p99(at, 9, &amed, &ap99);
        printf("\ncomponents %s: %d components, %d transitions\n", comps ? "1" : "auto",
               st.components, st.transitions);
        printf("  analysis: median %.4f s, p99 %.4f s (target <= 5 s)\n", amed, ap99);
        double *per = calloc(COUNT, sizeof *per), *cpus = calloc(COUNT, sizeof *cpus);
        printf("  %-26s %7s %7s %11s %11s %11s %11s\n", "1000 x 600 frames", "wall s", "cpu s",
               "median ms", "p99 ms", "median cpu", "p99 cpu");
        for (int threads = 1; threads <= 2; threads++)
            for (int base = 1; base >= 0; base--) {
                double proc, wall = synth(v, Tfit, nb, nfit, threads, base, per, cpus, &proc);
                double med, p99, cmed, cp99;
                med_p99(per, COUNT, &med, &p99);
                med_p99(cpus, COUNT, &cmed, &cp99);
                char label[64];
                snprintf(label, sizeof label, "%s, %d thread%s", base ? "baseline (copy)" : "walks",
                         threads, threads > 1 ? "s" : "");
                printf("  %-26s %7.3f %7.3f %11.4f %11.4f %11.4f %11.4f%s\n", label, wall, proc,
                       1e3 * med, 1e3 * p99, 1e3 * cmed, 1e3 * cp99,
                       !base && threads == 2 ? "  (target: wall <= 10 s)" : "");
            }
        free(per);
        free(cpus);
        mdl_variations_destroy(v);
    }
    mdl_model_destroy(m);
    return 0;
}
