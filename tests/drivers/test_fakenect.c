/* test_fakenect.c - fakenect dump directories: writer -> parser round trip (within the Kinect's
 * disparity quantisation), the fakenect: source on a recording of real Kinect frames, and the
 * rejection of malformed index lines and PGMs. */
#include "depth/fakenect.h"
#include "model.h"
#include "kinect_frames.h"
#include "test.h"

#include <errno.h>
#include <math.h>
#include <unistd.h>

static const char *frames[] = {"depth-data-1038901490", "depth-data-1045879925",
                               "depth-data-1051883281"};

int main(void)
{
    char err[DRV_ERR_LEN] = "";
    /* index lines */
    double t;
    uint32_t ts;
    const char *good = "d-1294436498.391479-001441524.pgm\n";
    ASSERT_INT_EQ(drv_fakenect_parse_index_line(good, strlen(good), &t, &ts, err), 1);
    ASSERT_NEAR(t, 1294436498.391479, 1e-6);
    ASSERT_INT_EQ(ts, 1441524);
    ASSERT_INT_EQ(drv_fakenect_parse_index_line("r-1.5-7.ppm", 11, &t, &ts, err), 0);
    const char *bad[] = {"d-1.5-7.ppm", "x-1.5-7.pgm", "d--7.pgm", "d-1.5-.pgm", "d-1.5-99999999999.pgm",
                         "d-1.5-7", "d-nan-7.pgm", ""};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        ASSERT_INT_LT(drv_fakenect_parse_index_line(bad[i], strlen(bad[i]), &t, &ts, err), 0);
        ASSERT_INT_GT(strlen(err), 0);
    }
    /* the committed recording (recordings/depth-fakenect: the example creature trotting, seen
     * by the test camera, one frame a second; recordings/README.md) through the source: needs
     * nothing outside the repository */
    {
        drv_source rs = {0};
        rs.ops = &drv_fakenect_ops;
        char spec[4200];
        snprintf(spec, sizeof spec, "%s?loop=0", test_src("recordings/depth-fakenect"));
        ASSERT_OK(rs.ops->open(&rs, spec, err), err);
        ASSERT_INT_EQ(rs.count, 6);
        ASSERT_NEAR(rs.fps, 1, 1e-9); /* frames at 0, 1 and 2 s */
        ASSERT_OK(rs.ops->start(&rs, err), err);
        float rxyz[18];
        uint8_t rvalid[6];
        drv_frame rf = {.count = 6, .xyz = rxyz, .valid = rvalid};
        for (int k = 0; k < 3; k++) {
            int r = rs.ops->read(&rs, &rf, 3000, err);
            ASSERT_OK(r, err);
            ASSERT_INT_EQ(rf.seq, k);
            int nvalid = 0;
            for (int m = 0; m < 6; m++)
                if (rvalid[m]) {
                    nvalid++;
                    /* the creature stands 2.5 m in front of the camera, 1.7 m long */
                    ASSERT_LT(rxyz[3 * m + 2], -1.5f);
                    ASSERT_GT(rxyz[3 * m + 2], -3.5f);
                    ASSERT_LT(fabsf(rxyz[3 * m]), 1.2f);
                }
            printf("recording frame %d: %d of 6 markers found\n", k, nvalid);
            ASSERT_INT_GE(nvalid, 3);
        }
        ASSERT_INT_EQ(rs.ops->read(&rs, &rf, 3000, err), DRV_EEOF);
        rs.ops->stop(&rs);
        rs.ops->close(&rs);
    }

    /* PGM header checks */
    uint16_t *mm = malloc(640 * 480 * sizeof *mm), *back = malloc(640 * 480 * sizeof *back);
    const char *hdrs[] = {"P6 640 480 65535\n", "P5 320 240 65535\n", "P5 640 480 255\n", "P5 640 480",
                          "P5 640 480 65535\n\x01\x02"};
    for (size_t i = 0; i < sizeof hdrs / sizeof *hdrs; i++)
        ASSERT(drv_fakenect_parse_depth((const uint8_t *)hdrs[i], strlen(hdrs[i]), "x.pgm", mm, err) ==
               MDL_EFORMAT);

    /* write three real frames, read them back */
    char dir[4096];
    const char *build = getenv("MESHSTEER_BUILD");
    snprintf(dir, sizeof dir, "%s/tests/drivers/fakenect-rec-%d", build ? build : ".", (int)getpid());
    drv_fakenect_writer *w;
    ASSERT_OK(drv_fakenect_writer_open(dir, &w, err), err);
    for (int k = 0; k < 3; k++) {
        kinect_frame_load(frames[k], mm);
        ASSERT_OK(drv_fakenect_writer_depth(w, 100.0 + k / 30.0, (uint32_t)(k * 1000), mm, err), err);
        if (k == 0) {
            char path[4300];
            snprintf(path, sizeof path, "%s/d-%f-%u.pgm", dir, 100.0, 0u);
            FILE *f2 = fopen(path, "rb");
            ASSERT(f2);
            uint8_t *pgm = malloc(700000);
            size_t n = fread(pgm, 1, 700000, f2);
            fclose(f2);
            ASSERT_INT_EQ(n, 17 + 640 * 480 * 2);
            ASSERT(!memcmp(pgm, "P5 640 480 65535\n", 17));
            ASSERT_OK(drv_fakenect_parse_depth(pgm, n, path, back, err), err);
            for (int i = 0; i < 640 * 480; i++) {
                if (!mm[i]) {
                    ASSERT_INT_EQ(back[i], 0);
                    continue;
                }
                double z = mm[i] * 0.001, step = z * z * 0.0030711016 * 1000.0; /* mm per unit */
                ASSERT_NEAR_I(back[i], mm[i], 0.5 * step + 1.0, i);
            }
            free(pgm);
        }
    }
    ASSERT_OK(drv_fakenect_writer_close(w, err), err);
    drv_fakenect_writer *w2;
    ASSERT(drv_fakenect_writer_open(dir, &w2, err) == -EEXIST);

    /* the source */
    drv_source s = {0};
    s.ops = &drv_fakenect_ops;
    char arg[4200];
    snprintf(arg, sizeof arg, "%s?loop=0", dir);
    ASSERT_OK(s.ops->open(&s, arg, err), err);
    ASSERT_INT_EQ(s.count, 6);
    ASSERT(!strcmp(s.names[0], "head"));
    ASSERT_NEAR(s.fps, 30, 0.01);
    ASSERT_OK(s.ops->start(&s, err), err);
    float xyz[18];
    uint8_t valid[6];
    drv_frame fr = {.count = 6, .xyz = xyz, .valid = valid};
    for (int k = 0; k < 3; k++) {
        int r = s.ops->read(&s, &fr, 1000, err);
        ASSERT_OK(r, err);
        ASSERT_INT_EQ(fr.seq, k);
        ASSERT(valid[0] && valid[1] && valid[2]);
        ASSERT_GT(xyz[1], xyz[5 * 3 + 1] + 0.2f); /* head above torso */
        ASSERT_LT(xyz[2], -1.0f);
        ASSERT_GT(xyz[2], -1.6f);
    }
    ASSERT_INT_EQ(s.ops->read(&s, &fr, 1000, err), DRV_EEOF);
    s.ops->stop(&s);
    s.ops->close(&s);
    /* bad specs */
    drv_source s2 = {0};
    ASSERT(drv_fakenect_ops.open(&s2, "/nonexistent-dir", err) == -ENOENT);
    snprintf(arg, sizeof arg, "%s?speed=2", dir);
    ASSERT(drv_fakenect_ops.open(&s2, arg, err) == -EINVAL);
    snprintf(arg, sizeof arg, "%s", test_src("tests/data"));
    ASSERT(drv_fakenect_ops.open(&s2, arg, err) == -ENOENT); /* no INDEX.txt there */
    free(mm);
    free(back);
    return 0;
}
