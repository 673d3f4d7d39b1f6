/* make_osc_seeds.c - the fuzz_osc seeds, serialised by liblo: OUTDIR/markers.osc (a bundle of six
 * /marker messages), vmc.osc (a VMC frame: root, bones, a blend shape, OK), loose.osc (one
 * /marker message of doubles). */
#include <lo/lo.h>
#include <stdio.h>
#include <stdlib.h>

static int put(const char *dir, const char *name, const void *b, size_t n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(b, 1, n, f) != n || fclose(f)) {
        fprintf(stderr, "make_osc_seeds: cannot write %s\n", path);
        return 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: make_osc_seeds OUTDIR\n");
        return 2;
    }
    const char *names[] = {"head", "lhand", "rhand", "lfoot", "rfoot", "torso"};
    lo_bundle b = lo_bundle_new(LO_TT_IMMEDIATE);
    for (int i = 0; i < 6; i++) {
        lo_message m = lo_message_new();
        lo_message_add_string(m, names[i]);
        lo_message_add_float(m, 0.1f * (float)i);
        lo_message_add_float(m, 1.0f);
        lo_message_add_float(m, -0.5f);
        lo_bundle_add_message(b, "/marker", m);
    }
    size_t n;
    void *s = lo_bundle_serialise(b, NULL, &n);
    int bad = put(argv[1], "markers.osc", s, n);
    free(s);
    lo_bundle_free_recursive(b);

    b = lo_bundle_new(LO_TT_IMMEDIATE);
    lo_message m = lo_message_new();
    lo_message_add_string(m, "root");
    for (int k = 0; k < 7; k++)
        lo_message_add_float(m, k == 6 ? 1.0f : 0.0f);
    lo_bundle_add_message(b, "/VMC/Ext/Root/Pos", m);
    const char *bones[] = {"Hips", "Spine", "Chest", "LeftShoulder", "LeftUpperArm", "LeftHand",
                           "RightUpperLeg", "RightLowerLeg", "RightFoot"};
    for (int i = 0; i < 9; i++) {
        m = lo_message_new();
        lo_message_add_string(m, bones[i]);
        lo_message_add_float(m, 0.0f);
        lo_message_add_float(m, 0.2f);
        lo_message_add_float(m, 0.0f);
        lo_message_add_float(m, 0.0f);
        lo_message_add_float(m, 0.38268343f);
        lo_message_add_float(m, 0.0f);
        lo_message_add_float(m, 0.92387953f);
        lo_bundle_add_message(b, "/VMC/Ext/Bone/Pos", m);
    }
    m = lo_message_new();
    lo_message_add_string(m, "Joy");
    lo_message_add_float(m, 0.5f);
    lo_bundle_add_message(b, "/VMC/Ext/Blend/Val", m);
    m = lo_message_new();
    lo_message_add_int32(m, 1);
    lo_bundle_add_message(b, "/VMC/Ext/OK", m);
    s = lo_bundle_serialise(b, NULL, &n);
    bad |= put(argv[1], "vmc.osc", s, n);
    free(s);
    lo_bundle_free_recursive(b);

    m = lo_message_new();
    lo_message_add_string(m, "lhand");
    lo_message_add_double(m, 0.25);
    lo_message_add_double(m, 1.5);
    lo_message_add_double(m, 0.0);
    s = lo_message_serialise(m, "/marker", NULL, &n);
    bad |= put(argv[1], "loose.osc", s, n);
    free(s);
    lo_message_free(m);
    return bad;
}
