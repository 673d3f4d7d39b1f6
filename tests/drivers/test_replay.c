/* test_replay.c - drivers/replay.c's joints block: replaying a skeleton file (a BVH written here,
 * and the HDM05 ASF/AMC take when ../shared/data has it) sets drv_source.joints and each frame's
 * joint_rot / joint_valid are the file's mdl_markers.rot of that frame, with the positions; a
 * caller that passes no joints block still gets its markers; a marker file without rotations (CSV)
 * sets no joints and leaves the block alone. Frames are read at speed 100 (paced, but fast). */
#include "drivers.h"
#include "model.h"
#include "test.h"

#include <unistd.h>

static const char bvh_text[] =
    "HIERARCHY\nROOT hip\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation "
    "Xrotation Yrotation\n JOINT knee\n {\n  OFFSET 0 -0.5 0\n  CHANNELS 3 Zrotation Xrotation "
    "Yrotation\n  End Site\n  {\n   OFFSET 0 -0.5 0\n  }\n }\n}\nMOTION\nFrames: 3\nFrame Time: 0.01\n"
    "0 1 0 0 0 0 0 0 0\n0 1 0 10 20 30 0 0 90\n0 1 0 0 0 0 45 0 0\n";

static void check_file(const char *path, const char *spec, int frames_to_read)
{
    char err[DRV_ERR_LEN] = "", merr[MDL_ERR_LEN] = "";
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_read(path, NULL, &m, merr), merr);
    ASSERT(m->rot);
    drv_source *s = NULL;
    ASSERT_OK(drv_source_open(spec, &s, err), err);
    ASSERT_INT_EQ(s->joints, 1);
    ASSERT_INT_EQ(s->count, m->count);
    ASSERT_OK(drv_source_start(s, err), err);
    int c = s->count;
    float *xyz = calloc(3 * (size_t)c, sizeof *xyz), *jr = calloc(4 * (size_t)c, sizeof *jr);
    uint8_t *v = calloc((size_t)c, 1), *jv = calloc((size_t)c, 1);
    ASSERT(xyz && jr && v && jv);
    for (int f = 0; f < frames_to_read; f++) {
        memset(jv, 0, (size_t)c);
        drv_frame fr = {.count = c, .xyz = xyz, .valid = v, .joint_rot = jr, .joint_valid = jv};
        int r;
        while ((r = drv_source_read(s, &fr, 200, err)) == DRV_ETIMEOUT)
            ;
        ASSERT_OK(r, err);
        ASSERT(memcmp(xyz, m->P + 3 * (size_t)f * c, 3 * (size_t)c * sizeof *xyz) == 0);
        ASSERT(memcmp(jr, m->rot + 4 * (size_t)f * c, 4 * (size_t)c * sizeof *jr) == 0);
        for (int i = 0; i < c; i++)
            ASSERT_INT_EQ(jv[i], m->valid[(size_t)f * c + i]);
    }
    /* no joints block: the markers alone */
    drv_frame fr = {.count = c, .xyz = xyz, .valid = v};
    int r;
    while ((r = drv_source_read(s, &fr, 200, err)) == DRV_ETIMEOUT)
        ;
    ASSERT_OK(r, err);
    ASSERT(memcmp(xyz, m->P + 3 * (size_t)frames_to_read * c, 3 * (size_t)c * sizeof *xyz) == 0);
    drv_source_stop(s);
    drv_source_close(s);
    free(xyz), free(jr), free(v), free(jv);
    mdl_markers_destroy(m);
}

int main(void)
{
    char dir[] = "/tmp/test_replay_XXXXXX", path[256], spec[300], err[DRV_ERR_LEN] = "",
         merr[MDL_ERR_LEN] = "";
    ASSERT(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/leg.bvh", dir);
    FILE *f = fopen(path, "w");
    ASSERT(f && fputs(bvh_text, f) >= 0 && fclose(f) == 0);
    snprintf(spec, sizeof spec, "replay:%s?speed=100", path);
    check_file(path, spec, 2);
    /* the same frames as CSV: no rotations, the block untouched */
    mdl_markers *m = NULL;
    ASSERT_OK(mdl_markers_read(path, NULL, &m, merr), merr);
    char csv[256];
    snprintf(csv, sizeof csv, "%s/leg.csv", dir);
    ASSERT_OK(mdl_markers_write_csv(csv, m, merr), merr);
    snprintf(spec, sizeof spec, "replay:%s?speed=100", csv);
    drv_source *s = NULL;
    ASSERT_OK(drv_source_open(spec, &s, err), err);
    ASSERT_INT_EQ(s->joints, 0);
    ASSERT_OK(drv_source_start(s, err), err);
    float xyz[9], jr[12] = {7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7};
    uint8_t v[3], jv[3] = {9, 9, 9};
    drv_frame fr = {.count = 3, .xyz = xyz, .valid = v, .joint_rot = jr, .joint_valid = jv};
    int r;
    while ((r = drv_source_read(s, &fr, 200, err)) == DRV_ETIMEOUT)
        ;
    ASSERT_OK(r, err);
    ASSERT(jr[0] == 7 && jr[11] == 7 && jv[0] == 9 && jv[2] == 9);
    drv_source_stop(s);
    drv_source_close(s);
    mdl_markers_destroy(m);
    /* joints=0: the skeleton file's markers alone */
    snprintf(spec, sizeof spec, "replay:%s?speed=100&joints=0", path);
    ASSERT_OK(drv_source_open(spec, &s, err), err);
    ASSERT_INT_EQ(s->joints, 0);
    drv_source_close(s);
    snprintf(spec, sizeof spec, "replay:%s?joints=2", path);
    ASSERT(drv_source_open(spec, &s, err) != 0 && strstr(err, "joints"));
    unlink(path), unlink(csv), rmdir(dir);
    /* a real ASF/AMC take */
    const char *amc = getenv("MESHSTEER_DATA") ? test_data("mocap/asf_amc/hdm05/HDM_dg_06-03_03_120.amc")
                                               : NULL;
    if (amc) {
        snprintf(spec, sizeof spec, "replay:%s?speed=100", amc);
        check_file(amc, spec, 5);
    }
    puts("replay: ok");
    return 0;
}
