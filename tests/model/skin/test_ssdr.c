/* test_ssdr.c - SSDR (model/skin/ssdr*.c, mdl_skin_fit): a mesh animated by known bones and
 * weights is recovered; weights are non-negative, sum to 1 and have at most K non-zeros; the
 * output is identical for 1 and 2 threads; 64 bones on a 5,000-vertex, 57-frame sequence
 * terminates with exactly 64 bones; the model file round trip and the clock synthesis. */
#include "cli.h"
#include "model.h"
#include "core/rigid.h"
#include "test.h"
#include "tube_mesh.h"

#include <errno.h>
#include <stdint.h>
#include <time.h>

/* a cylinder along x, `rings` x `around` vertices, length len, radius 0.15 */
static mdl_meshseq *cylinder(int rings, int around, double len, int frames)
{
    mdl_meshseq *s = test_tube_mesh(rings, around, frames);
    if (!s)
        return NULL;
    for (int r = 0; r < rings; r++)
        for (int a = 0; a < around; a++) {
            float *p = s->V + 3 * ((size_t)r * around + a);
            double th = 2 * M_PI * a / around;
            p[0] = (float)(len * r / (rings - 1));
            p[1] = (float)(0.15 * cos(th));
            p[2] = (float)(0.15 * sin(th));
        }
    return s;
}

static uint64_t rng = 12345;
static double urand(void)
{
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* the true weights: bone floor(x) of nb along [0, nb], linear blends of width 0.4 at the joints */
static void true_weights(double x, int nb, double *w)
{
    for (int j = 0; j < nb; j++)
        w[j] = 0;
    for (int j = 1; j < nb; j++)
        if (fabs(x - j) < 0.2) {
            double a = (x - j + 0.2) / 0.4;
            w[j - 1] = 1 - a;
            w[j] = a;
            return;
        }
    int j = (int)x;
    w[j < 0 ? 0 : j >= nb ? nb - 1 : j] = 1;
}

/* animates frames 1.. of s (frame 0 is the rest) by random rigid bones; T: frames x nb x 12 */
static void animate(mdl_meshseq *s, int nb)
{
    double *T = calloc((size_t)s->frames * nb * 12, sizeof *T), w[16];
    for (int f = 0; f < s->frames; f++)
        for (int j = 0; j < nb; j++) {
            double *M = T + 12 * ((size_t)f * nb + j), q[4];
            double ax[3] = {urand() - 0.5, urand() - 0.5, urand() - 0.5}, n = 0;
            for (int c = 0; c < 3; c++)
                n += ax[c] * ax[c];
            n = sqrt(n);
            double ang = f ? 0.6 * (urand() - 0.5) : 0;
            q[0] = cos(ang / 2);
            for (int c = 0; c < 3; c++)
                q[1 + c] = sin(ang / 2) * ax[c] / n;
            mdl__quat_to_mat(q, M);
            for (int c = 0; c < 3; c++)
                M[9 + c] = f ? 0.3 * (urand() - 0.5) : 0;
        }
    for (int f = 1; f < s->frames; f++)
        for (int i = 0; i < s->nv; i++) {
            const float *p = s->V + 3 * (size_t)i;
            true_weights(p[0], nb, w);
            double o[3] = {0, 0, 0};
            for (int j = 0; j < nb; j++) {
                const double *M = T + 12 * ((size_t)f * nb + j);
                for (int c = 0; c < 3; c++)
                    o[c] += w[j] * (M[3 * c] * p[0] + M[3 * c + 1] * p[1] + M[3 * c + 2] * p[2] + M[9 + c]);
            }
            for (int c = 0; c < 3; c++)
                s->V[3 * ((size_t)f * s->nv + i) + c] = (float)o[c];
        }
    free(T);
}

static void check_weights(const mdl_model *m, int nv)
{
    int nb, K, nfr;
    const int *bone;
    const double *w, *T;
    ASSERT_INT_EQ(mdl_skin_get(m, &nb, &K, &nfr, &bone, &w, &T), 0);
    for (int i = 0; i < nv; i++) {
        double sum = 0;
        int nz = 0;
        for (int q = 0; q < K; q++) {
            double x = w[(size_t)K * i + q];
            if (!(x >= 0)) {
                fprintf(stderr, "vertex %d slot %d: weight %g < 0\n", i, q, x);
                exit(1);
            }
            ASSERT(bone[(size_t)K * i + q] >= 0 && bone[(size_t)K * i + q] < nb);
            sum += x;
            nz += x != 0;
        }
        ASSERT_NEAR_I(sum, 1.0, 1e-6, i);
        ASSERT(nz <= K);
    }
}

static void test_recovery(void)
{
    int nb = 4;
    mdl_meshseq *s = cylinder(81, 16, nb, 12);
    animate(s, nb);
    int frames[12];
    for (int f = 0; f < 12; f++)
        frames[f] = f;
    mdl_skin_opts o;
    mdl_skin_opts_default(&o);
    o.bones = nb;
    o.max_influences = 2;
    o.iterations = 300;
    o.tolerance = 0;
    o.patience = 1000;
    mdl_model *m = NULL;
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_skin_fit(s, frames, 12, &o, &m, err), err);
    mdl_skin_stats st;
    ASSERT_INT_EQ(mdl_skin_get_stats(m, &st), 0);
    printf("recovery: rmse %.3g (%.3g of the diagonal), %d iterations\n", st.rmse,
           st.rmse_over_diag, st.iterations);
    ASSERT(st.rmse_over_diag < 1e-5);
    check_weights(m, s->nv);
    /* the weights, up to a permutation of the bones: match each fitted bone to the true bone of
     * the vertex it dominates */
    int K;
    const int *bone;
    const double *w;
    ASSERT_INT_EQ(mdl_skin_get(m, NULL, &K, NULL, &bone, &w, NULL), 0);
    int perm[8];
    for (int j = 0; j < nb; j++)
        perm[j] = -1;
    double wt[8];
    for (int i = 0; i < s->nv; i++) {
        true_weights(s->V[3 * i], nb, wt);
        for (int j = 0; j < nb; j++)
            if (wt[j] == 1)
                perm[bone[(size_t)K * i]] = j;
    }
    for (int j = 0; j < nb; j++)
        ASSERT(perm[j] >= 0);
    double worst = 0;
    for (int i = 0; i < s->nv; i++) {
        true_weights(s->V[3 * i], nb, wt);
        double got[8] = {0};
        for (int q = 0; q < K; q++)
            got[perm[bone[(size_t)K * i + q]]] += w[(size_t)K * i + q];
        for (int j = 0; j < nb; j++) {
            ASSERT_NEAR_I(got[j], wt[j], 1e-3, i);
            worst = fmax(worst, fabs(got[j] - wt[j]));
        }
    }
    printf("recovery: weights within %.3g of the truth\n", worst);

    /* file round trip and the clock synthesis: frame 0 at t = 0, frame 1 at t = 1/fps */
    const char *path = "test_ssdr_skin.msm";
    ASSERT_OK(mdl_model_save(m, path, err), err);
    mdl_model *m2 = NULL;
    ASSERT_OK(mdl_model_load(path, &m2, err), err);
    remove(path);
    mdl_model_info info;
    mdl_model_get_info(m2, &info);
    ASSERT_INT_EQ(info.kind, MDL_KIND_SKIN);
    ASSERT_INT_EQ(info.inputs, MDL_INPUT_CLOCK);
    ASSERT_INT_EQ(info.nclusters, nb);
    mdl_synth *sy = NULL;
    ASSERT_OK(mdl_synth_create(m2, 0, &sy, err), err);
    float *V = calloc(3 * (size_t)s->nv, sizeof *V);
    for (int f = 0; f < 3; f++) {
        mdl_synth_input in = {.t = f / s->fps};
        ASSERT_INT_EQ(mdl_synth_frame(sy, &in, V, NULL), 0);
        for (int i = 0; i < 3 * s->nv; i++)
            ASSERT_NEAR_I(V[i], s->V[3 * (size_t)f * s->nv + i], 1e-4, i);
    }
    mdl_synth_destroy(sy);
    /* eval on the fitted frames reproduces the fit */
    mdl_eval_result r;
    ASSERT_OK(mdl_eval_run(m2, s, frames, 12, NULL, &r, err), err);
    printf("eval: rmse %.3g\n", r.rmse);
    ASSERT(r.rmse_over_diag < 1e-5);
    mdl_eval_result_fini(&r);
    free(V);
    mdl_model_destroy(m2);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
}

static void test_threads_identical(void)
{
    /* a bending cylinder, blends everywhere: 1 and 2 workers give the same bytes */
    mdl_meshseq *s = cylinder(60, 12, 3, 20);
    animate(s, 3);
    int frames[20];
    for (int f = 0; f < 20; f++)
        frames[f] = f;
    mdl_skin_opts o;
    mdl_skin_opts_default(&o);
    o.bones = 7;
    o.max_influences = 3;
    o.smooth = 1e-3;
    mdl_model *a = NULL, *b = NULL;
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_skin_fit(s, frames, 20, &o, &a, err), err);
    cli_pool pool = {.threads = 2}; /* the command line's parallel-for (server/cli_parallel.c) */
    o.workers = 2;
    o.parallel = cli_parallel_for;
    o.parallel_ud = &pool;
    ASSERT_OK(mdl_skin_fit(s, frames, 20, &o, &b, err), err);
    int nb, K, nf;
    const int *ba, *bb;
    const double *wa, *wb, *Ta, *Tb;
    ASSERT_INT_EQ(mdl_skin_get(a, &nb, &K, &nf, &ba, &wa, &Ta), 0);
    ASSERT_INT_EQ(mdl_skin_get(b, NULL, NULL, NULL, &bb, &wb, &Tb), 0);
    ASSERT_INT_EQ(nb, 7);
    check_weights(a, s->nv);
    ASSERT_INT_EQ(memcmp(ba, bb, (size_t)s->nv * K * sizeof *ba), 0);
    ASSERT_INT_EQ(memcmp(wa, wb, (size_t)s->nv * K * sizeof *wa), 0);
    ASSERT_INT_EQ(memcmp(Ta, Tb, (size_t)nf * nb * 12 * sizeof *Ta), 0);
    mdl_skin_stats sa, sb;
    mdl_skin_get_stats(a, &sa);
    mdl_skin_get_stats(b, &sb);
    ASSERT_INT_EQ(sa.iterations, sb.iterations);
    ASSERT(sa.rmse == sb.rmse);
    printf("threads: identical (rmse %.6g, %d iterations)\n", sa.rmse, sa.iterations);
    mdl_model_destroy(a);
    mdl_model_destroy(b);
    mdl_meshseq_destroy(s);
}

static void test_many_bones_terminate(void)
{
    /* 5,000 vertices, 57 frames, 64 bones: ends, with exactly 64 bones */
    mdl_meshseq *s = cylinder(250, 20, 8, 57);
    animate(s, 8);
    ASSERT_INT_EQ(s->nv, 5000);
    int frames[57];
    for (int f = 0; f < 57; f++)
        frames[f] = f;
    mdl_skin_opts o;
    mdl_skin_opts_default(&o);
    o.bones = 64;
    mdl_model *m = NULL;
    char err[MDL_ERR_LEN] = "";
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    ASSERT_OK(mdl_skin_fit(s, frames, 57, &o, &m, err), err);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    mdl_skin_stats st;
    mdl_skin_get_stats(m, &st);
    ASSERT_INT_EQ(st.bones, 64);
    ASSERT(st.iterations <= o.iterations);
    check_weights(m, s->nv);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int used[64] = {0}, nused = 0;
    for (int i = 0; i < s->nv; i++)
        used[info.part[i]] = 1;
    for (int j = 0; j < 64; j++)
        nused += used[j];
    printf("64 bones: %d dominate some vertex, rmse %.3g, %d iterations, %.2f s\n", nused, st.rmse,
           st.iterations, (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec));
    mdl_model_destroy(m);
    /* a mesh too small for its bones is refused, not looped on */
    o.bones = 2000;
    ASSERT_INT_EQ(mdl_skin_fit(s, frames, 57, &o, &m, err), -EDOM);
    printf("2000 bones on 5000 vertices: %s\n", err);
    mdl_meshseq_destroy(s);
}

static void test_horse(void)
{
    const char *dir = getenv("MESHSTEER_DATA") ? NULL : NULL;
    (void)dir;
    char err[MDL_ERR_LEN] = "";
    const char *p = test_data("meshes/horse-gallop");
    mdl_meshseq *s = NULL;
    ASSERT_OK(mdl_meshseq_read(p, NULL, &s, err), err);
    int *idx = NULL, n = 0;
    ASSERT_OK(mdl_parse_frames("0:48:4", s->frames, &idx, &n, err), err);
    mdl_skin_opts o;
    mdl_skin_opts_default(&o);
    o.bones = 22;
    mdl_model *m = NULL;
    ASSERT_OK(mdl_skin_fit(s, idx, n, &o, &m, err), err);
    mdl_skin_stats st;
    mdl_skin_get_stats(m, &st);
    printf("horse 0:48:4, 22 bones: rmse %.5f (%.4f %%), %d iterations, %.2f s\n", st.rmse,
           100 * st.rmse_over_diag, st.iterations, st.seconds);
    check_weights(m, s->nv);
    ASSERT(st.rmse <= 0.0058);
    free(idx);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
}

int main(void)
{
    mdl_set_blas_threads(1);
    test_recovery();
    test_threads_identical();
    test_many_bones_terminate();
    test_horse();
    return 0;
}
