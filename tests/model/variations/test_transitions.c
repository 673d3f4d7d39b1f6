/* test_transitions.c - Zheng 2013 Sec. 3.2 (model/variations/transitions.c): on a looping
 * example that drifts rigidly (looping.h), the transitions found join frames a whole number of
 * periods apart, in both directions, each the cheapest from its frame, and the other valleys of D
 * below the paper's T_c cost over 100 times more (a threshold between the two keeps exactly the
 * periodic ones); D of eq. 5 is rigid-invariant (D(i, i + P) is tiny beside T_c although the tube
 * has moved and turned); half a period apart, where the joint angles differ, D is over 5 times
 * any neighbour's; every frame is alive; no transitions is an error for a walk; bad options are
 * refused. */
#include "model.h"
#include "test.h"
#include "looping.h"

#include <errno.h>

int main(void)
{
    mdl_set_blas_threads(1);
    char err[MDL_ERR_LEN] = "";
    const int N = 60, P = 20;
    mdl_meshseq *s = NULL;
    mdl_model *m = lp_fit(N, P, 3, &s, err);
    ASSERT_OK(m ? 0 : -1, err);
    mdl_skin_stats sst;
    mdl_skin_get_stats(m, &sst);
    printf("skin: 3 bones, rmse %.2e (%.4f %% of the diagonal)\n", sst.rmse, 100 * sst.rmse_over_diag);

    mdl_variations *v = NULL;
    ASSERT_OK(mdl_variations_build(m, NULL, &v, err), err);
    mdl_variations_stats st;
    mdl_variations_get_stats(v, &st);
    printf("variations: ref bone %d, rank %d, alpha %.3g, beta %.3g, max D(i,i-1) %.3g, T_c %.3g, "
           "%d transitions, %d alive frames\n", st.ref_bone, st.rank, st.alpha, st.beta,
           st.max_adjacent, st.tc, st.transitions, st.alive_frames);
    ASSERT_INT_EQ(st.bones, 3);
    ASSERT_INT_EQ(st.frames, N);
    ASSERT_NEAR(st.tc, st.max_adjacent / 40, 1e-12 * st.tc);
    ASSERT_INT_GE(st.rank, 1);
    ASSERT_INT_LE(st.rank, 12);
    ASSERT_INT_EQ(st.alive_frames, N);
    /* every frame i >= 1 with a partner j = i +- P, +- 2P in 2 .. N - 2 has that transition, and
     * it is the cheapest from i; the rest (other valleys of D(i, .) below the paper's loose T_c)
     * cost far more */
    int expected = 0, found = 0, others = 0;
    double worst_periodic = 0, cheapest_other = INFINITY;
    for (int i = 1; i < N; i++) {
        double best = INFINITY;
        int best_d = -1;
        for (int k = 0; k < st.transitions; k++) {
            int a, j;
            double c;
            ASSERT_OK(mdl_variations_transition(v, k, &a, &j, &c), "");
            if (a != i)
                continue;
            ASSERT_LT_I(c, st.tc, k);
            ASSERT_INT_GE_I(j, 2, k);
            ASSERT_INT_LE_I(j, N - 2, k);
            int d = abs(i - j) % P;
            if (c < best) {
                best = c;
                best_d = d;
            }
            if (d == 0) {
                found++;
                worst_periodic = fmax(worst_periodic, c);
            } else {
                others++;
                cheapest_other = fmin(cheapest_other, c);
            }
        }
        int partners = 0;
        for (int j = i - 2 * P; j <= i + 2 * P; j += P)
            partners += j != i && j >= 2 && j <= N - 2;
        expected += partners;
        if (partners)
            ASSERT_INT_EQ_I(best_d, 0, i);
    }
    printf("transitions a whole period apart: %d (%d expected, costliest %.3g); %d others, the "
           "cheapest %.3g\n", found, expected, worst_periodic, others, cheapest_other);
    ASSERT_INT_EQ(found, expected);
    ASSERT_GT(cheapest_other, 100 * worst_periodic);
    ASSERT_INT_GE(mdl_variations_transition(v, st.transitions, NULL, NULL, NULL), -ERANGE);
    ASSERT_INT_EQ(mdl_variations_transition(v, st.transitions, NULL, NULL, NULL), -ERANGE);
    /* rigid invariance: the drift does not show in D */
    for (int i = 1; i + P < N; i++)
        ASSERT_LT_I(mdl_variations_cost(v, i, i + P), 0.04 * st.max_adjacent, i);
    /* the printed T_c = 40 max D(i, i-1) admits every pair up to 6 frames apart (D grows about
     * as the square of the frame distance on a smooth motion: sqrt 40 > 6) */
    for (int i = 1; i + 6 < N; i++)
        for (int k = 1; k <= 6; k++)
            ASSERT_LT_I(mdl_variations_cost(v, i, i + k), 40 * st.max_adjacent, i * 10 + k);
    /* half a period apart: other joint angles, farther than any two neighbours */
    for (int i = 1; i + P / 2 < N; i++)
        ASSERT_GT_I(mdl_variations_cost(v, i, i + P / 2), 5 * st.max_adjacent, i);
    ASSERT(isnan(mdl_variations_cost(v, 0, 3)));

    /* T_c given: a threshold between the two groups keeps exactly the periodic ones */
    mdl_variations_opts o;
    mdl_variations_opts_default(&o);
    o.threshold = 10 * worst_periodic;
    mdl_variations *v2 = NULL;
    ASSERT_OK(mdl_variations_build(m, &o, &v2, err), err);
    mdl_variations_stats st2;
    mdl_variations_get_stats(v2, &st2);
    printf("T_c %.3g: %d transitions\n", st2.tc, st2.transitions);
    ASSERT_NEAR(st2.tc, o.threshold, 0);
    ASSERT_INT_EQ(st2.transitions, expected);
    ASSERT_INT_EQ(st2.alive_frames, N);
    mdl_variations_destroy(v2);
    /* a threshold below every cost: no transitions, no frame alive, and a walk says so */
    o.threshold = 1e-300;
    ASSERT_OK(mdl_variations_build(m, &o, &v2, err), err);
    mdl_variations_get_stats(v2, &st2);
    ASSERT_INT_EQ(st2.transitions, 0);
    ASSERT_INT_EQ(st2.alive_frames, 0);
    double T[12 * 3];
    ASSERT_INT_EQ(mdl_variations_walk(v2, 1, 1, T, NULL, NULL, err), -ENOENT);
    printf("no transitions: %s\n", err);
    mdl_variations_destroy(v2);
    /* bad options */
    mdl_variations_opts_default(&o);
    o.jump_prob = 2;
    v2 = (mdl_variations *)1;
    ASSERT_INT_EQ(mdl_variations_build(m, &o, &v2, err), -EINVAL);
    ASSERT(v2 == NULL);
    mdl_variations_destroy(NULL);

    mdl_variations_destroy(v);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
    printf("transitions: ok\n");
    return 0;
}
