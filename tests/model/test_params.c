/* test_params.c - the compact form of synthesis (model.h, mdl_synth_params_layout /
 * mdl_synth_params; kind.c, steer/synth.c, skin/play.c): the layout's formula, evaluated here from
 * the layout and the parameters alone, gives the vertices mdl_synth_frame wrote (steer: the built-in
 * example's model driven by its trot; skin: its fitted loop), -EAGAIN before the first frame, and
 * no allocation per frame. */
#include "model.h"
#include "test.h"
#include "quat.h"

#include <errno.h>
#include <malloc.h>

/* V_v = sum_s w (R(q_i) (mean_e + sum_a lam_a mode_a[e]) + t_i), in double */
static double reconstruct_max_err(const mdl_params_layout *L, const float *prm, const float *V,
                                  int nv)
{
    int *at = calloc((size_t)L->ninst + 1, sizeof *at);
    ASSERT(at);
    for (int i = 0, o = 0; i < L->ninst; i++) {
        at[i] = o;
        o += 7 + L->nmodes[L->inst_part[i]];
        ASSERT_INT_LE_I(o, L->nparams, i);
    }
    double worst = 0;
    for (int v = 0; v < nv; v++) {
        double x[3] = {0, 0, 0};
        for (int s = 0; s < L->slots; s++) {
            size_t k = (size_t)v * L->slots + s;
            if (L->slot_w[k] == 0)
                continue;
            int i = L->slot_inst[k], e = L->slot_entry[k];
            ASSERT(i >= 0 && i < L->ninst);
            int p = L->inst_part[i], n = L->part_off[p + 1] - L->part_off[p], j = e - L->part_off[p];
            ASSERT(j >= 0 && j < n);
            const float *pr = prm + at[i];
            double y[3];
            for (int c = 0; c < 3; c++) {
                y[c] = L->mean[3 * (size_t)e + c];
                for (int a = 0; a < L->nmodes[p]; a++)
                    y[c] += pr[7 + a] * L->modes[L->mode_off[p] + ((size_t)a * n + j) * 3 + c];
            }
            double R[9];
            test_quat_matrix(pr, R);
            for (int r = 0; r < 3; r++)
                x[r] += L->slot_w[k] * (R[3 * r] * y[0] + R[3 * r + 1] * y[1] + R[3 * r + 2] * y[2] + pr[4 + r]);
        }
        for (int c = 0; c < 3; c++) {
            double d = fabs(x[c] - V[3 * (size_t)v + c]);
            worst = d > worst ? d : worst;
        }
    }
    free(at);
    return worst;
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *seq;
    mdl_rig *rig;
    ASSERT_OK(mdl_example_create(40, &seq, &rig, err), err);
    int frames[20];
    for (int i = 0; i < 20; i++)
        frames[i] = 2 * i;
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    mdl_model *m;
    ASSERT_OK(mdl_steer_train(seq, frames, 20, rig, NULL, &o, &m, err), err);
    mdl_markers *trot;
    ASSERT_OK(mdl_example_markers(rig, 12, 1.3, &trot, NULL, err), err);

    mdl_synth *s;
    ASSERT_OK(mdl_synth_create(m, 0, &s, err), err);
    mdl_params_layout L;
    ASSERT_INT_EQ(mdl_synth_params_layout(s, &L), 0);
    ASSERT_INT_EQ(L.kind, MDL_KIND_STEER);
    ASSERT_INT_GT(L.ninst, 1);
    ASSERT_INT_GE(L.slots, 2); /* the example's parts overlap (Sec. 4.5) */
    float *prm = calloc((size_t)L.nparams, sizeof *prm), *V = calloc((size_t)seq->nv * 3, sizeof *V);
    ASSERT(prm && V);
    ASSERT_INT_EQ(mdl_synth_params(s, prm), -EAGAIN); /* no frame yet */
    /* the per-frame path (frame, then its parameters) allocates nothing: the heap in use is the
     * same after 4 frames (meaningful without ASan, whose allocator mallinfo2 does not see) */
    struct mallinfo2 before = mallinfo2();
    for (int f = 0; f < 4; f++) {
        ASSERT_OK(mdl_synth_markers(s, trot->P + (size_t)f * trot->count * 3, NULL, V, NULL), err);
        ASSERT_INT_EQ(mdl_synth_params(s, prm), 0);
    }
    struct mallinfo2 after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    ASSERT_INT_EQ(after.hblkhd, before.hblkhd);
    double diag = 2.0;
    for (int f = 0; f < trot->frames; f++) {
        ASSERT_OK(mdl_synth_markers(s, trot->P + (size_t)f * trot->count * 3, NULL, V, NULL), err);
        ASSERT_INT_EQ(mdl_synth_params(s, prm), 0);
        double e = reconstruct_max_err(&L, prm, V, seq->nv);
        printf("steer frame %d: %d pieces, %d floats, max |V - formula| = %.3g m\n", f, L.ninst,
               L.nparams, e);
        ASSERT_LT(e, 2e-6 * diag); /* float rounding only: nothing follows the blend */
    }
    /* a wrong parameter makes the formula disagree: the check can fail */
    prm[4] += 0.01f;
    ASSERT_GT(reconstruct_max_err(&L, prm, V, seq->nv), 0.005);
    mdl_synth_destroy(s);
    free(prm);

    mdl_skin_opts so;
    mdl_skin_opts_default(&so);
    so.bones = 8;
    so.iterations = 10;
    mdl_model *sk;
    ASSERT_OK(mdl_skin_fit(seq, frames, 20, &so, &sk, err), err);
    ASSERT_OK(mdl_synth_create(sk, 0, &s, err), err);
    ASSERT_INT_EQ(mdl_synth_params_layout(s, &L), 0);
    ASSERT_INT_EQ(L.kind, MDL_KIND_SKIN);
    ASSERT_INT_EQ(L.ninst, 8);
    ASSERT_INT_EQ(L.nparams, 7 * 8);
    prm = calloc((size_t)L.nparams, sizeof *prm);
    ASSERT(prm);
    for (int f = 0; f < 5; f++) {
        mdl_synth_input in = {.t = 0.37 * f};
        ASSERT_INT_EQ(mdl_synth_frame(s, &in, V, NULL), 0);
        ASSERT_INT_EQ(mdl_synth_params(s, prm), 0);
        double e = reconstruct_max_err(&L, prm, V, seq->nv);
        printf("skin t=%.2f: max |V - formula| = %.3g m\n", in.t, e);
        ASSERT_LT(e, 2e-6 * diag);
    }
    mdl_synth_destroy(s);
    free(prm);
    free(V);
    mdl_model_destroy(sk);
    mdl_markers_destroy(trot);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(seq);
    mdl_rig_destroy(rig);
    printf("ok\n");
    return 0;
}
