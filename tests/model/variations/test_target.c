/* test_target.c - targeted frames of Zheng 2013 Sec. 3.4 (model/variations/target.c): on the
 * looping tube (period 20, 60 frames), walks with a start, an end and targets in between (each
 * reachable: the tube's transitions keep the phase) meet
 * every one exactly for 20 seeds, differ between seeds in between, and are the free walk when
 * there are no targets; a target no walk can meet (two frames apart but one step away) is -ENOENT,
 * an output frame targeted twice or a frame out of range -EINVAL; on horse-gallop with components
 * (skipped without ../shared/data) every component meets the targets. */
#include "model.h"
#include "test.h"
#include "looping.h"
#include "fit.h"

#include <errno.h>

static void check(const mdl_variations *v, const mdl_variations_target *t, int nt, int F, int nc,
                  int seeds)
{
    char err[MDL_ERR_LEN] = "";
    int nb = 0;
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    nb = st.bones;
    double *T = calloc((size_t)F * nb * 12, sizeof *T);
    int *src = calloc((size_t)F * nc, sizeof *src), *first = calloc((size_t)F * nc, sizeof *first);
    int differ = 0;
    for (int s = 0; s < seeds; s++) {
        ASSERT_OK(mdl_variations_walk_targets(v, 1000 + s, F, t, nt, T, NULL, src, err), err);
        for (int k = 0; k < nt; k++)
            for (int c = 0; c < nc; c++)
                ASSERT_INT_EQ_I(src[(size_t)nc * t[k].out + c], t[k].in, s * 1000 + k * 10 + c);
        if (s == 0)
            memcpy(first, src, (size_t)F * nc * sizeof *src);
        else
            differ += memcmp(first, src, (size_t)F * nc * sizeof *src) != 0;
    }
    printf("%d targets over %d frames met by %d seeds; %d of them differ from the first\n", nt, F,
           seeds, differ);
    ASSERT_INT_GE(differ, seeds / 2);
    free(T);
    free(src);
    free(first);
}

int main(void)
{
    mdl_set_blas_threads(1);
    char err[MDL_ERR_LEN] = "";
    const int N = 60, P = 20, F = 300;
    mdl_meshseq *s = NULL;
    mdl_model *m = lp_fit(N, P, 3, &s, err);
    ASSERT_OK(m ? 0 : -1, err);
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    o.min_segment = 2;
    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);

    /* the tube's transitions join frames whole periods apart, so a walk from 5 is at an input
     * frame = 5 + f (mod 20) at output frame f: these targets are reachable, a period's copy each */
    mdl_variations_target t[4] = {{5, 0}, {25, 100}, {15, 150}, {44, F - 1}};
    check(v, t, 4, F, 1, 20);
    /* given in any order */
    mdl_variations_target r[4] = {t[3], t[1], t[0], t[2]};
    check(v, r, 4, F, 1, 5);
    /* no targets: the free walk */
    {
        double *T1 = calloc((size_t)F * 36, sizeof *T1), *T2 = calloc((size_t)F * 36, sizeof *T2);
        ASSERT_OK(mdl_variations_walk_targets(v, 3, F, NULL, 0, T1, NULL, NULL, err), err);
        ASSERT_OK(mdl_variations_walk(v, 3, F, T2, NULL, NULL, err), err);
        ASSERT(!memcmp(T1, T2, (size_t)F * 36 * sizeof *T1));
        free(T1);
        free(T2);
    }
    /* impossible: from 5 to 6 in two steps (5 -> 6 is one; the transitions from 5 go to 26, 46) */
    double T[3 * 36];
    mdl_variations_target bad[2] = {{5, 0}, {6, 2}};
    ASSERT_INT_EQ(mdl_variations_walk_targets(v, 1, 3, bad, 2, T, NULL, NULL, err), -ENOENT);
    printf("impossible: %s\n", err);
    mdl_variations_target twice[2] = {{5, 1}, {6, 1}};
    ASSERT_INT_EQ(mdl_variations_walk_targets(v, 1, 3, twice, 2, T, NULL, NULL, err), -EINVAL);
    printf("twice: %s\n", err);
    mdl_variations_target range[1] = {{60, 1}};
    ASSERT_INT_EQ(mdl_variations_walk_targets(v, 1, 3, range, 1, T, NULL, NULL, err), -EINVAL);
    range[0] = (mdl_variations_target){3, 3};
    ASSERT_INT_EQ(mdl_variations_walk_targets(v, 1, 3, range, 1, T, NULL, NULL, err), -EINVAL);
    mdl_variations_destroy(v);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);

    /* horse-gallop with components: every component meets them */
    m = vt_fit_skin("meshes/horse-gallop", NULL, 22);
    mdl_variations_opts_default(&o);
    o.components = 0;
    ASSERT_OK(mdl_variations_build(m, &o, &v, err), err);
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    /* the body keeps the gallop's phase (period 24): in = 10 + out (mod 24) */
    mdl_variations_target h[3] = {{10, 0}, {42, 200}, {33, 335}};
    check(v, h, 3, 336, st.components, 6);
    mdl_variations_destroy(v);
    mdl_model_destroy(m);
    printf("target: ok\n");
    return 0;
}
