/* make_model_seed.c - writes small models of the test tube (tests/model/tube.h) as the seeds of
 * fuzz_model, so that the seeds always match the current file version and hold every kind's chunk:
 * OUT a steering model with a skin of the same frames beside it (MESH, RIG, STER, SKIN, the skin
 * walking its transition graph: the SKIN chunk's variations trailer), OUT2 a harmonic model of
 * the tube's first frame (MESH, HARM). Usage: make_model_seed OUT OUT2 */
#include "model/tube.h"
#include "model.h"

#include <stdio.h>

int main(int argc, char **argv)
{
    char err[MDL_ERR_LEN] = "";
    if (argc != 3) {
        fprintf(stderr, "usage: make_model_seed OUT OUT2\n");
        return 2;
    }
    mdl_meshseq *s;
    mdl_rig *rig;
    tube_create(24, &s, &rig);
    int frames[12];
    for (int i = 0; i < 12; i++)
        frames[i] = 2 * i;
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    o.name = "fuzz-seed";
    mdl_model *m = NULL, *skin = NULL, *harm = NULL;
    int rc = mdl_steer_train(s, frames, 12, rig, NULL, &o, &m, err);
    mdl_skin_opts so;
    mdl_skin_opts_default(&so);
    so.bones = 3;
    so.iterations = 5;
    so.name = "fuzz-seed-skin";
    if (!rc)
        rc = mdl_skin_fit(s, frames, 12, &so, &skin, err);
    if (!rc)
        rc = mdl_model_merge(m, &skin, err);
    if (!rc) { /* any threshold: the seed needs a trailer, not good transitions */
        mdl_variations_opts vo;
        mdl_variations_opts_default(&vo);
        vo.threshold = 1e300;
        rc = mdl_variations_attach(m, &vo, 1, err);
    }
    if (!rc)
        rc = mdl_model_save(m, argv[1], err);
    mdl_harmonic_opts ho;
    mdl_harmonic_opts_default(&ho);
    ho.auto_k = 6;
    mdl_mesh first = {s->nv, s->nf, s->V, s->F};
    if (!rc)
        rc = mdl_harmonic_build(&first, NULL, NULL, &ho, &harm, err);
    if (!rc)
        rc = mdl_model_save(harm, argv[2], err);
    if (rc)
        fprintf(stderr, "make_model_seed: %s\n", err);
    mdl_model_destroy(m);
    mdl_model_destroy(skin);
    mdl_model_destroy(harm);
    mdl_meshseq_destroy(s);
    mdl_rig_destroy(rig);
    return rc ? 1 : 0;
}
