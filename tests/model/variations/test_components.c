/* test_components.c - Zheng 2013 Sec. 4 (model/variations/components.c, walk.c, merge.c).
 * On the looping tube (looping.h, 3 bones in a chain: 2 blocks), a block without transitions of
 * its own is fused back (one component), and components 1 gives the skin's own graph. On
 * horse-gallop (22 bones, K = 4; skipped without ../shared/data), the paper's Fig. 10: with one
 * component every transition joins corresponding frames of the two cycles (24 apart: no
 * variation), with components auto the tail (the bone carrying the tail tip, the vertex farthest
 * back) is in a component of its own, the anchor's walks only ever jump 24 frames (the body
 * gallops as the input does), the stepping walker (the idle source's) gives the batch walk's
 * frames, the tail's bones sit relative to its cut node exactly as its own walk put them, and
 * the tail's walks differ between 4 variations: different
 * transition sequences and different tail-tip trajectories relative to the body. And --ground
 * (blend.c) keeps the reference bone at its input frame's height and tilt away from a blend
 * window, which eq. 7 alone does not. */
#include "model.h"
#include "test.h"
#include "looping.h"
#include "variations/variations.h"
#include "fit.h"

#include <errno.h>

static double max_abs_diff(const double *a, const double *b, size_t n)
{
    double m = 0;
    for (size_t k = 0; k < n; k++)
        m = fmax(m, fabs(a[k] - b[k]));
    return m;
}

static void tube(void)
{
    char err[MDL_ERR_LEN] = "";
    const int N = 60, P = 20;
    mdl_meshseq *s = NULL;
    mdl_model *m = lp_fit(N, P, 3, &s, err);
    ASSERT_OK(m ? 0 : -1, err);
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    ASSERT_INT_EQ(o.components, 1);
    o.components = 0;
    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    /* the tube's bone graph is a chain with one cut node, but one of its two blocks finds no
     * transition of its own (its walk could not go on), so it is fused back: one component */
    const mdl__bone_graph *bg = v->bg;
    printf("tube: bone graph d02 %.3g d12 %.3g d01 %.3g, T_e %.3g; %d components\n", bg->d[2],
           bg->d[5], bg->d[1], bg->te, st.components);
    ASSERT_INT_EQ(bg->nblocks, 2);
    ASSERT_INT_EQ(st.components, 1);
    ASSERT_INT_EQ(st.transitions, st.single_transitions);
    mdl_variations_component c0;
    mdl_variations_destroy(v);
    /* one component: the skin's own graph */
    o.components = 1;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
    mdl_variations_get_stats(v, &st);
    ASSERT_INT_EQ(st.components, 1);
    ASSERT_INT_EQ(st.transitions, st.single_transitions);
    ASSERT_OK(mdl_variations_get_component(v, 0, &c0), "");
    ASSERT_INT_EQ(mdl_variations_get_component(v, 1, &c0), -ERANGE);
    ASSERT_OK(mdl_variations_get_component(v, 0, &c0), "");
    ASSERT(c0.bones == NULL);
    ASSERT_INT_EQ(c0.nbones, 3);
    o.components = 2;
    mdl_variations_destroy(v);
    ASSERT_INT_EQ(mdl_variations_build(m, &o, &v, err), -EINVAL);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
}

static void horse(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_model *m = vt_fit_skin("meshes/horse-gallop", NULL, 22);
    mdl_skin_stats sk;
    mdl_skin_get_stats(m, &sk);
    int N = sk.frames, half = N / 2;
    ASSERT_INT_EQ(N, 48);

    /* one component: corresponding frames only */
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    printf("horse, one component: %d transitions (T_c %.4g = max D(i, i-1) %.4g / 40)\n",
           st.transitions, st.tc, st.max_adjacent);
    ASSERT_INT_GE(st.transitions, 2 * (half - 2));
    for (int k = 0; k < st.transitions; k++) {
        int a, b;
        mdl_variations_transition(v, k, &a, &b, NULL);
        ASSERT_INT_EQ_I(abs(a - b), half, k);
    }
    mdl_variations_destroy(v);

    /* --ground: away from a transition's blend window, the reference bone has exactly its input
     * frame's height and tilt (the second row of R: a turn about y leaves it); eq. 7 alone does
     * not keep them */
    {
        int nb0, K0, nf0;
        const int *bone0;
        const double *w0, *Tfit;
        mdl_skin_get(m, &nb0, &K0, &nf0, &bone0, &w0, &Tfit);
        const int F = 336;
        double dev[2] = {0, 0};
        double *T = calloc((size_t)F * nb0 * 12, sizeof *T);
        int *src = calloc(F, sizeof *src), checked = 0;
        for (int g = 0; g < 2; g++) {
            mdl_variations_opts og;
            mdl_variations_opts_default(&og);
            og.ground = g;
            og.tc_factor = 0.2; /* more transitions than corresponding frames: tilts differ */
            mdl_variations *vg = NULL;
            ASSERT_OK(mdl_variations_build(m, &og, &vg, err), err);
            mdl_variations_stats sg;
            mdl_variations_get_stats(vg, &sg);
            ASSERT_OK(mdl_variations_walk(vg, 5, F, T, NULL, src, err), err);
            int since = og.blend;
            for (int f = 0; f < F; f++) {
                if (f > 0 && src[f] != src[f - 1] + 1)
                    since = 0;
                else if (f > 0)
                    since++;
                if (since < og.blend)
                    continue;
                const double *Tr = T + 12 * ((size_t)f * nb0 + sg.ref_bone);
                const double *Ti = Tfit + 12 * ((size_t)src[f] * nb0 + sg.ref_bone);
                double d = fabs(Tr[10] - Ti[10]);
                for (int c = 0; c < 3; c++)
                    d = fmax(d, fabs(Tr[3 + c] - Ti[3 + c]));
                dev[g] = fmax(dev[g], d);
                checked += g;
            }
            mdl_variations_destroy(vg);
        }
        printf("horse --ground: reference bone height and tilt off their input frame's by %.3g "
               "(%d frames checked); %.3g without\n", dev[1], checked, dev[0]);
        ASSERT_INT_GT(checked, 100);
        ASSERT_LT(dev[1], 1e-9);
        ASSERT_GT(dev[0], 1e-3);
        free(T);
        free(src);
    }

    /* components: the tail apart */
    o.components = 0;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
    mdl_variations_get_stats(v, &st);
    int nb, K, nf;
    const int *bone;
    const double *w, *Tf;
    mdl_skin_get(m, &nb, &K, &nf, &bone, &w, &Tf);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int tip = 0;
    for (int i = 1; i < info.nv; i++)
        if (info.rest[3 * i + 2] < info.rest[3 * tip + 2])
            tip = i;
    int tipbone = bone[(size_t)K * tip];
    for (int k = 1; k < K; k++)
        if (w[(size_t)K * tip + k] > w[(size_t)K * tip])
            tipbone = bone[(size_t)K * tip + k];
    int tailc = -1;
    printf("horse, components auto: %d components, %d transitions; the tail tip (vertex %d) on "
           "bone %d\n", st.components, st.transitions, tip, tipbone);
    ASSERT_INT_GE(st.components, 2);
    for (int c = 0; c < st.components; c++) {
        mdl_variations_component k;
        mdl_variations_get_component(v, c, &k);
        printf("  component %d: cut %d, parent %d, %d transitions, bones", c, k.cut, k.parent,
               k.transitions);
        for (int b = 0; b < k.nbones; b++) {
            printf(" %d", k.bones[b]);
            if (k.bones[b] == tipbone && k.cut != tipbone)
                tailc = c;
        }
        printf("\n");
    }
    ASSERT_INT_GT(tailc, 0); /* not the anchor */
    const int F = 336, V = 4;
    double *T = calloc((size_t)V * F * nb * 12, sizeof *T);
    int *src = calloc((size_t)V * F * st.components, sizeof *src);
    for (int k = 0; k < V; k++)
        ASSERT_OK(mdl_variations_walk(v, 100 + k, F, T + (size_t)k * F * nb * 12, NULL,
                                      src + (size_t)k * F * st.components, err), err);
    /* the stepping walker (the idle source's) gives the batch walk's frames */
    {
        mdl__vwalk w;
        double *T2 = calloc((size_t)nb * 12, sizeof *T2);
        ASSERT_OK(mdl__vwalk_init(&w, v, 100, err), err);
        for (int f = 0; f < F; f++) {
            int in = mdl__vwalk_step(&w, T2);
            ASSERT_INT_EQ_I(in, src[(size_t)st.components * f], f);
            ASSERT_LE_I(max_abs_diff(T2, T + (size_t)nb * 12 * f, (size_t)nb * 12), 1e-12, f);
        }
        mdl__vwalk_fini(&w);
        free(T2);
        /* the tail's bones sit relative to its cut node as its own walk put them */
        const mdl__vcomp *tc = &v->comp[tailc];
        mdl__vwalk w1;
        ASSERT_OK(mdl__vwalk_init(&w1, tc->g, 1, err), err);
        mdl__vwalk_reset_at(&w1, mdl__vwalk_comp_seed(100, tailc), src[tailc]);
        double *Tc = calloc((size_t)tc->nb * 12, sizeof *Tc);
        for (int f = 0; f < F; f++) {
            mdl__vwalk_step(&w1, Tc);
            for (int b = 0; b < tc->nb; b++) {
                double want[12], got[12];
                vt_relative(Tc + 12 * tc->cut_local, Tc + 12 * b, want);
                vt_relative(T + (size_t)nb * 12 * f + 12 * tc->cut, T + (size_t)nb * 12 * f + 12 * tc->bones[b], got);
                ASSERT_LE_I(max_abs_diff(want, got, 12), 1e-9, f);
            }
        }
        free(Tc);
        mdl__vwalk_fini(&w1);
    }
    /* the body gallops: the anchor continues or jumps half a period */
    int nc = st.components, tail_jumps = 0;
    for (int k = 0; k < V; k++)
        for (int f = 1; f < F; f++) {
            const int *s0 = src + ((size_t)k * F + f - 1) * nc, *s1 = s0 + nc;
            int d = s1[0] - (s0[0] + 1);
            ASSERT_INT_EQ_I(d == 0 || abs(d) == half, 1, k * F + f);
            tail_jumps += s1[tailc] != s0[tailc] + 1 && abs(s1[tailc] - (s0[tailc] + 1)) != half;
        }
    /* the tail: different transition sequences, and different tip paths relative to the body
     * (the tip vertex in the frame of the skin's reference bone) */
    double *tipk = calloc((size_t)V * F * 3, sizeof *tipk);
    for (int k = 0; k < V; k++)
        for (int f = 0; f < F; f++) {
            const double *Tk = T + ((size_t)k * F + f) * nb * 12;
            double p[3] = {0, 0, 0};
            const float *r = info.rest + 3 * (size_t)tip;
            for (int s2 = 0; s2 < K; s2++) {
                const double *M = Tk + 12 * bone[(size_t)K * tip + s2];
                for (int a = 0; a < 3; a++)
                    p[a] += w[(size_t)K * tip + s2] *
                            (M[3 * a] * r[0] + M[3 * a + 1] * r[1] + M[3 * a + 2] * r[2] + M[9 + a]);
            }
            const double *Rr = Tk + 12 * st.ref_bone;
            double d[3] = {p[0] - Rr[9], p[1] - Rr[10], p[2] - Rr[11]};
            for (int a = 0; a < 3; a++)
                tipk[((size_t)k * F + f) * 3 + a] = Rr[a] * d[0] + Rr[3 + a] * d[1] + Rr[6 + a] * d[2];
        }
    double least = INFINITY;
    int same_sequences = 0;
    for (int a = 0; a < V; a++)
        for (int b = a + 1; b < V; b++) {
            double dist = 0;
            int same = 1;
            for (int f = 0; f < F; f++) {
                same &= src[((size_t)a * F + f) * nc + tailc] == src[((size_t)b * F + f) * nc + tailc];
                for (int c = 0; c < 3; c++) {
                    double x = tipk[((size_t)a * F + f) * 3 + c] - tipk[((size_t)b * F + f) * 3 + c];
                    dist += x * x;
                }
            }
            same_sequences += same;
            least = fmin(least, sqrt(dist / F));
        }
    printf("horse: %d tail transitions other than corresponding frames in 4 x %d frames; the "
           "least RMS distance between two variations' tail tips (body frame) %.4f\n",
           tail_jumps, F, least);
    ASSERT_INT_EQ(same_sequences, 0);
    ASSERT_INT_GT(tail_jumps, 0);
    ASSERT_GT(least, 0.01);
    free(tipk);
    free(T);
    free(src);
    mdl_variations_destroy(v);
    mdl_model_destroy(m);
}

int main(void)
{
    mdl_set_blas_threads(1);
    tube();
    horse();
    printf("components: ok\n");
    return 0;
}
