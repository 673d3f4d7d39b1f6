/* make_model.c - test fixture: trains a model on the built-in example creature and writes it with
 * the example's trot marker recording, so the daemon's integration tests need nothing outside the
 * repository. The trot is the committed take, recordings/example-trot.c3d (MESHSTEER_RECORDINGS,
 * compiled in; recordings/README.md), not generated again: trot.csv is that file in CSV, for the
 * tests that edit its columns or read it as text (the viewer's).
 * Usage: make_model OUT_DIR  ->  OUT_DIR/example.msm, OUT_DIR/trot.csv,
 * OUT_DIR/corrupt.msm (the model file cut in half, for the SIGHUP test), OUT_DIR/skin.msm (a skin
 * of the same example: a clock-driven kind), OUT_DIR/two-kinds.msm (the steering model with
 * that skin beside it, the daemon's idle animation) and OUT_DIR/two-kinds-walk.msm (the same, its
 * skin walking the example's transition graph: Zheng 2013's variations as the idle source), and
 * OUT_DIR/kblend.msm (the steering model of the same frames synthesising by the kernel blend of
 * its training meshes, model/steer/kblend.h: no params layout, the meshes in the file) and
 * OUT_DIR/kblend-skin.msm (that model with the skin beside it: an idle kind that has a params
 * layout under a primary kind that has none). */
#include "model.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: make_model OUT_DIR\n");
        return 2;
    }
    char err[MDL_ERR_LEN], path[4096];
    mdl_meshseq *seq = NULL;
    mdl_rig *rig = NULL;
    mdl_markers *mk = NULL;
    mdl_model *m = NULL;
    int frames = 120;
    if (mdl_example_create(frames, &seq, &rig, err) ||
        mdl_markers_read(MESHSTEER_RECORDINGS "/example-trot.c3d", NULL, &mk, err)) {
        fprintf(stderr, "make_model: %s\n", err);
        return 1;
    }
    /* model/modelfile.c (at the time of writing) saves the unused third reference slot as -1 and
     * then refuses it on load; an in-range value in the unused slot sidesteps that. */
    if (rig->nref == 2)
        rig->ref[2] = 0;
    int *idx = malloc(sizeof(int) * (size_t)frames);
    for (int i = 0; i < frames; i++)
        idx[i] = i;
    mdl_train_opts o;
    mdl_train_opts_default(&o);
    o.name = "example";
    o.clusters = 6; /* fixed: quicker than the automatic choice, and enough parts to colour */
    if (mdl_steer_train(seq, idx, frames, rig, NULL, &o, &m, err)) {
        fprintf(stderr, "make_model: train: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/example.msm", argv[1]);
    if (mdl_model_save(m, path, err)) {
        fprintf(stderr, "make_model: %s\n", err);
        return 1;
    }
    /* the kernel blend of the same frames (virtual markers, as above) */
    mdl_model *kb = NULL;
    o.name = "example-kblend";
    o.kblend = 0.7;
    snprintf(path, sizeof path, "%s/kblend.msm", argv[1]);
    if (mdl_steer_train(seq, idx, frames, rig, NULL, &o, &kb, err) || mdl_model_save(kb, path, err)) {
        fprintf(stderr, "make_model: kernel blend: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/example.msm", argv[1]);
    /* the corrupt copy: the first half of the file */
    FILE *f = fopen(path, "rb");
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n);
    if (fread(buf, 1, (size_t)n, f) != (size_t)n)
        return 1;
    fclose(f);
    snprintf(path, sizeof path, "%s/corrupt.msm", argv[1]);
    f = fopen(path, "wb");
    fwrite(buf, 1, (size_t)n / 2, f);
    fclose(f);
    free(buf);
    /* the skin of the same frames, alone and beside the steering model */
    mdl_skin_opts so;
    mdl_skin_opts_default(&so);
    so.bones = 8;
    so.iterations = 20;
    so.name = "example-skin";
    mdl_model *skin = NULL, *skin2 = NULL, *skin3 = NULL;
    if (mdl_skin_fit(seq, idx, frames, &so, &skin, err) ||
        mdl_skin_fit(seq, idx, frames, &so, &skin2, err) ||
        mdl_skin_fit(seq, idx, frames, &so, &skin3, err)) {
        fprintf(stderr, "make_model: skin: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/skin.msm", argv[1]);
    if (mdl_model_save(skin, path, err) || mdl_model_merge(m, &skin2, err)) {
        fprintf(stderr, "make_model: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/two-kinds.msm", argv[1]);
    if (mdl_model_save(m, path, err)) {
        fprintf(stderr, "make_model: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/kblend-skin.msm", argv[1]);
    if (mdl_model_merge(kb, &skin3, err) || mdl_model_save(kb, path, err)) {
        fprintf(stderr, "make_model: %s\n", err);
        return 1;
    }
    mdl_model_destroy(kb);
    snprintf(path, sizeof path, "%s/two-kinds-walk.msm", argv[1]);
    if (mdl_variations_attach(m, NULL, 7, err) || mdl_model_save(m, path, err)) {
        fprintf(stderr, "make_model: variations: %s\n", err);
        return 1;
    }
    mdl_model_destroy(skin);
    snprintf(path, sizeof path, "%s/trot.csv", argv[1]);
    if (mdl_markers_write_csv(path, mk, err)) {
        fprintf(stderr, "make_model: %s\n", err);
        return 1;
    }
    printf("%d vertices, %d markers, %d marker frames at %g fps\n", seq->nv, mk->count, mk->frames,
           mk->fps);
    free(idx);
    mdl_model_destroy(m);
    mdl_markers_destroy(mk);
    mdl_rig_destroy(rig);
    mdl_meshseq_destroy(seq);
    return 0;
}
