/* test_harmonic_file.c - the harmonic kind end to end on a tube (harmonic_file.c, harmonic_synth.c):
 * built from a rig of two bones with twist markers and a template rest pose, saved and loaded (the
 * HARM chunk round trip is byte-exact), described; driven by markers moved rigidly (rotation +
 * translation) it moves the mesh rigidly (1e-4 m: float markers and output); a bent elbow gives a
 * finite, bent mesh; the per-frame path allocates nothing (mallinfo2, plain build); an auto:K model
 * round-trips too and refuses marker input; its eval on a sequence whose second frame stretches the
 * tube affinely (x 1.3 along it, 0.8 across): without --stretch even the oracle (every triangle its
 * own rotation) errs > 0.01 of the diagonal; with it the oracle is exact (1e-6) and the model and
 * baseline within 1 % of the rotation-only error (not exact: a patch's least-squares gradient
 * weighs in the fourth-vertex normal, harmonic_eval.c); the result says which mode ran. */
#include "model.h"
#include "core/rigid.h"
#include "test.h"
#include "htube.h"

#include <errno.h>
#include <malloc.h>
#include <string.h>
#include <unistd.h>

static const char rig_json[] =
    "{\"markers\": [{\"name\": \"root\", \"vertex\": 0}, {\"name\": \"elbow\", \"vertex\": 0},"
    " {\"name\": \"tip\", \"vertex\": 0}, {\"name\": \"side\", \"vertex\": 0}],"
    " \"reference\": [\"root\", \"elbow\"],"
    " \"limbs\": [[\"root\", \"elbow\", \"side\"], [\"elbow\", \"tip\", \"side\"]]}";

static size_t file_bytes(const char *p, uint8_t **buf)
{
    FILE *f = fopen(p, "rb");
    ASSERT(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    *buf = malloc((size_t)n);
    ASSERT(fread(*buf, 1, (size_t)n, f) == (size_t)n);
    fclose(f);
    return (size_t)n;
}

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_mesh *m = htube_create(31, 12);
    mdl_rig *rig = NULL;
    ASSERT_OK(mdl_rig_parse(rig_json, sizeof rig_json - 1, "rig", m->nv, &rig, err), err);
    mdl_markers *tr = NULL;
    ASSERT_OK(mdl_markers_create(1, 4, 30, &tr, err), err);
    const float P0[12] = {0, 0.9f, 0, 1, 1, 0, 2, 1, 0, 0.5f, 1.1f, 0};
    const char *names[4] = {"root", "elbow", "tip", "side"};
    memcpy(tr->P, P0, sizeof P0);
    for (int i = 0; i < 4; i++) {
        free(tr->names[i]);
        tr->names[i] = strdup(names[i]);
        tr->valid[i] = 1;
    }
    mdl_harmonic_opts o;
    mdl_harmonic_opts_default(&o);
    o.name = "tube";
    mdl_model *model = NULL;
    ASSERT_OK(mdl_harmonic_build(m, rig, tr, &o, &model, err), err);
    mdl_model_info info;
    mdl_model_get_info(model, &info);
    ASSERT_INT_EQ(info.kind, MDL_KIND_HARMONIC);
    ASSERT_INT_EQ(info.nmarkers, 4);
    ASSERT_INT_EQ(info.inputs, MDL_INPUT_MARKERS);
    char path[64], path2[64];
    snprintf(path, sizeof path, "/tmp/test_harmonic_%d.msm", (int)getpid());
    snprintf(path2, sizeof path2, "/tmp/test_harmonic_%d_2.msm", (int)getpid());
    ASSERT_OK(mdl_model_save(model, path, err), err);
    mdl_model *back = NULL;
    ASSERT_OK(mdl_model_load(path, &back, err), err);
    ASSERT_OK(mdl_model_save(back, path2, err), err);
    uint8_t *b1, *b2;
    size_t n1 = file_bytes(path, &b1), n2 = file_bytes(path2, &b2);
    ASSERT_INT_EQ(n1, n2);
    ASSERT(memcmp(b1, b2, n1) == 0);
    /* a corrupt chunk is refused, never read out of bounds: truncate at every 97th byte */
    for (size_t cut = 8; cut < n1; cut += 97) {
        mdl_model *bad = NULL;
        ASSERT(mdl_model_parse(b1, cut, "cut", &bad, err) != 0);
        ASSERT(bad == NULL);
    }
    free(b1), free(b2);
    unlink(path), unlink(path2);
    char desc[8192];
    mdl_model_describe(back, desc, sizeof desc);
    ASSERT(strstr(desc, "harmonic") && strstr(desc, "twist side"));

    mdl_synth *s = NULL;
    ASSERT_OK(mdl_synth_create(back, 0, &s, err), err);
    float *V = calloc(3 * (size_t)m->nv, sizeof *V), mk[12];
    /* rigid: rotate all markers about an arbitrary axis, and translate */
    double q[4] = {0.9, 0.2, 0.3, -0.25}, R[9], t[3] = {0.3, -0.2, 0.5};
    double qn = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int c = 0; c < 4; c++)
        q[c] /= qn;
    mdl__quat_to_mat(q, R);
    for (int i = 0; i < 4; i++)
        for (int c = 0; c < 3; c++)
            mk[3 * i + c] = (float)(R[3 * c] * P0[3 * i] + R[3 * c + 1] * P0[3 * i + 1] +
                                    R[3 * c + 2] * P0[3 * i + 2] + t[c]);
    ASSERT_OK(mdl_synth_markers(s, mk, NULL, V, NULL), "synth");
    for (int v = 0; v < m->nv; v++)
        for (int c = 0; c < 3; c++) {
            const float *x = m->V + 3 * v;
            double y = R[3 * c] * x[0] + R[3 * c + 1] * x[1] + R[3 * c + 2] * x[2] + t[c];
            ASSERT_NEAR_I(V[3 * v + c], y, 1e-4, 3 * v + c);
        }
    /* bend the elbow by 90 deg about z: the tip goes up */
    float bent[12] = {0, 0.9f, 0, 1, 1, 0, 1, 2, 0, 0.5f, 1.1f, 0};
    struct mallinfo2 before = mallinfo2();
    for (int it = 0; it < 10; it++)
        ASSERT_OK(mdl_synth_markers(s, it % 2 ? bent : mk, NULL, V, NULL), "synth");
    struct mallinfo2 after = mallinfo2();
    ASSERT_INT_EQ(after.uordblks, before.uordblks);
    ASSERT_INT_EQ(after.hblkhd, before.hblkhd);
    ASSERT_OK(mdl_synth_markers(s, bent, NULL, V, NULL), "synth");
    float ymax = -1e9f;
    for (int i = 0; i < 3 * m->nv; i++)
        ASSERT(isfinite(V[i]));
    for (int v = 0; v < m->nv; v++)
        ymax = fmaxf(ymax, V[3 * v + 1]);
    printf("bent elbow: highest vertex y = %.3f (tip marker at 2.0)\n", ymax);
    ASSERT(ymax > 1.7f);
    /* the root marker missing from the start: -EAGAIN */
    mdl_synth_reset(s);
    uint8_t valid[4] = {0, 1, 1, 1};
    ASSERT_INT_EQ(mdl_synth_markers(s, mk, valid, V, NULL), -EAGAIN);
    mdl_synth_destroy(s);
    mdl_model_destroy(back);
    mdl_model_destroy(model);

    /* a skeleton template (joint rotations, mdl_markers.rot): the elbow hangs from the root, the
     * tip from the elbow; both bones are driven by their joints (MDL_INPUT_JOINTS), which survive
     * the file; a rigid turn given as markers + joint rotations moves the mesh rigidly; a bone
     * whose joint is invalid takes the direction path; the joints path allocates nothing */
    tr->rot = calloc(4 * 4, sizeof *tr->rot);
    tr->parent = calloc(4, sizeof *tr->parent);
    ASSERT(tr->rot && tr->parent);
    const int par[4] = {-1, 0, 1, 0};
    for (int i = 0; i < 4; i++)
        tr->rot[4 * i] = 1, tr->parent[i] = par[i];
    mdl_model *jm = NULL, *jback = NULL;
    /* without the rest fit the joints are not used (harmonic_file.c: they would turn the target's
     * limbs about the template's rest axes) */
    ASSERT_OK(mdl_harmonic_build(m, rig, tr, &o, &jm, err), err);
    mdl_model_get_info(jm, &info);
    ASSERT_INT_EQ(info.inputs, MDL_INPUT_MARKERS);
    mdl_model_destroy(jm);
    jm = NULL;
    o.fit_rest = 1;
    ASSERT_OK(mdl_harmonic_build(m, rig, tr, &o, &jm, err), err);
    mdl_model_get_info(jm, &info);
    ASSERT_INT_EQ(info.inputs, MDL_INPUT_MARKERS | MDL_INPUT_JOINTS);
    ASSERT_OK(mdl_model_save(jm, path, err), err);
    ASSERT_OK(mdl_model_load(path, &jback, err), err);
    unlink(path);
    mdl_model_describe(jback, desc, sizeof desc);
    ASSERT(strstr(desc, "elbow, twist side, joint elbow") && strstr(desc, "tip, twist side, joint tip"));
    mdl_synth *js = NULL;
    ASSERT_OK(mdl_synth_create(jback, 0, &js, err), err);
    ASSERT_INT_EQ(mdl_synth_inputs(js), MDL_INPUT_MARKERS | MDL_INPUT_JOINTS);
    float jr[16];
    for (int i = 0; i < 4; i++)
        for (int c = 0; c < 4; c++)
            jr[4 * i + c] = (float)q[c];
    uint8_t jvalid[4] = {1, 1, 1, 1};
    mdl_synth_input jin = {.markers = mk, .njoints = 4, .joint_rot = jr, .joint_valid = jvalid};
    mdl_synth_info jinfo;
    ASSERT_OK(mdl_synth_frame(js, &jin, V, &jinfo), "synth joints");
    ASSERT_INT_EQ(jinfo.joints_used, 2);
    printf("joints: largest arc onto the markers %.2e rad\n", jinfo.joint_arc_max);
    ASSERT_LE(jinfo.joint_arc_max, 1e-5);
    for (int v = 0; v < m->nv; v++)
        for (int c = 0; c < 3; c++) {
            const float *x = m->V + 3 * v;
            double y = R[3 * c] * x[0] + R[3 * c + 1] * x[1] + R[3 * c + 2] * x[2] + t[c];
            ASSERT_NEAR_I(V[3 * v + c], y, 1e-4, 3 * v + c);
        }
    jvalid[2] = 0;
    ASSERT_OK(mdl_synth_frame(js, &jin, V, &jinfo), "synth joints");
    ASSERT_INT_EQ(jinfo.joints_used, 1);
    jvalid[2] = 1;
    {
        struct mallinfo2 before = mallinfo2();
        for (int it = 0; it < 10; it++) {
            jvalid[1] = (uint8_t)(it % 3 != 0);
            ASSERT_OK(mdl_synth_frame(js, &jin, V, &jinfo), "synth joints");
        }
        struct mallinfo2 after = mallinfo2();
        ASSERT_INT_EQ(after.uordblks, before.uordblks);
        ASSERT_INT_EQ(after.hblkhd, before.hblkhd);
    }
    mdl_synth_destroy(js);
    mdl_model_destroy(jback);
    mdl_model_destroy(jm);

    /* auto:K */
    o.auto_k = 30;
    ASSERT_OK(mdl_harmonic_build(m, NULL, NULL, &o, &model, err), err);
    mdl_model_get_info(model, &info);
    ASSERT_INT_EQ(info.nmarkers, 0);
    ASSERT_OK(mdl_model_save(model, path, err), err);
    ASSERT_OK(mdl_model_load(path, &back, err), err);
    unlink(path);
    ASSERT_OK(mdl_synth_create(back, 0, &s, err), err);
    ASSERT_INT_EQ(mdl_synth_markers(s, mk, NULL, V, NULL), -EINVAL);
    mdl_synth_destroy(s);
    /* eval: rest, then an affine stretch (a constant F, which R U fields represent exactly) */
    {
        mdl_meshseq seq = {m->nv, m->nf, 2, 0, calloc(6 * (size_t)m->nv, sizeof(float)), m->F};
        for (int v = 0; v < m->nv; v++) {
            const float *p = m->V + 3 * v;
            float *a = seq.V + 3 * v, *b = seq.V + 3 * ((size_t)m->nv + v);
            a[0] = p[0], a[1] = p[1], a[2] = p[2];
            b[0] = 1.3f * p[0];
            b[1] = 0.8f * p[1];
            b[2] = 0.8f * p[2];
        }
        int fr[2] = {0, 1};
        mdl_eval_opts eo = {0, 0, 1, 0};
        mdl_eval_result er;
        ASSERT_OK(mdl_eval_run(back, &seq, fr, 2, &eo, &er, err), err);
        double rot_mean = er.mean_err;
        ASSERT(er.mode && !strcmp(er.mode, "rotation"));
        printf("eval rotation: mean %.3g baseline %.3g oracle %.3g\n", er.mean_err,
               er.baseline_nn_mean_err, er.oracle_mean_err);
        ASSERT(er.oracle_mean_err > 0.01 && er.mean_err > 0.01);
        mdl_eval_result_fini(&er);
        eo.harmonic_stretch = 1;
        ASSERT_OK(mdl_eval_run(back, &seq, fr, 2, &eo, &er, err), err);
        ASSERT(er.mode && !strcmp(er.mode, "rotation+stretch"));
        printf("eval rotation+stretch: mean %.3g baseline %.3g oracle %.3g\n", er.mean_err,
               er.baseline_nn_mean_err, er.oracle_mean_err);
        ASSERT(er.oracle_mean_err < 1e-6);
        ASSERT(er.mean_err < 0.01 * rot_mean && er.baseline_nn_mean_err < 0.01 * rot_mean);
        ASSERT_INT_EQ(er.nan_count, 0);
        mdl_eval_result_fini(&er);
        free(seq.V);
    }
    mdl_model_destroy(back);
    mdl_model_destroy(model);
    /* no rig and no auto:K: refused */
    o.auto_k = 0;
    ASSERT(mdl_harmonic_build(m, NULL, NULL, &o, &model, err) == -EINVAL);
    free(V);
    mdl_markers_destroy(tr);
    mdl_rig_destroy(rig);
    mdl_mesh_destroy(m);
    puts("harmonic_file: ok");
    return 0;
}
