/* make_model_seed.c - writes a small model (the test tube of tests/model/tube.h) as the seed of
 * fuzz_model, so that the seed always matches the current file version. Usage: make_model_seed OUT */
#include "model/tube.h"
#include "model.h"

#include <stdio.h>

int main(int argc, char **argv)
{
    char err[MDL_ERR_LEN] = "";
    if (argc != 2) {
        fprintf(stderr, "usage: make_model_seed OUT\n");
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
    mdl_model *m;
    int rc = mdl_steer_train(s, frames, 12, rig, NULL, &o, &m, err);
    if (!rc)
        rc = mdl_model_save(m, argv[1], err);
    if (rc)
        fprintf(stderr, "make_model_seed: %s\n", err);
    mdl_model_destroy(m);
    mdl_meshseq_destroy(s);
    mdl_rig_destroy(rig);
    return rc ? 1 : 0;
}
