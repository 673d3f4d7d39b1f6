/* bench_depth.c - depth -> markers time per 640x480 frame (median, p99) on the 12 real Kinect
 * frames, one core. Usage: bench_depth [passes] [step]. Run by `meson test --benchmark`. */
#include "depth/depth.h"
#include "kinect_frames.h"
#include "test.h"

#include <time.h>

static const char *frames[] = {"depth-data-1028894671", "depth-data-1038901490",
                               "depth-data-1045879925", "depth-data-1051883281",
                               "depth-data-1058893191", "depth-data-1064898470",
                               "depth-data-1070905432", "depth-data-1078881076",
                               "depth-data-1166565565", "depth-data-1234568668",
                               "depth-data-1399145206", "depth-data-82823944"};
#define NF (int)(sizeof frames / sizeof *frames)

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int passes = argc > 1 ? atoi(argv[1]) : 200;
    char err[DRV_ERR_LEN] = "";
    drv_depth_opts o;
    drv_depth_opts_default(&o);
    if (argc > 2)
        o.step = atoi(argv[2]);
    uint16_t *d = malloc((size_t)NF * 640 * 480 * sizeof *d);
    for (int i = 0; i < NF; i++)
        kinect_frame_load(frames[i], d + (size_t)i * 640 * 480);
    drv_depth_tracker *t;
    ASSERT_OK(drv_depth_tracker_create(&o, &t, err), err);
    int n = passes * NF;
    double *ms = malloc((size_t)n * sizeof *ms);
    drv_depth_result r;
    for (int p = 0; p < passes; p++)
        for (int i = 0; i < NF; i++) {
            struct timespec a, c;
            clock_gettime(CLOCK_MONOTONIC, &a);
            drv_depth_tracker_process(t, d + (size_t)i * 640 * 480, (uint64_t)(p * NF + i) * 33333, &r);
            clock_gettime(CLOCK_MONOTONIC, &c);
            ms[p * NF + i] = (c.tv_sec - a.tv_sec) * 1e3 + (c.tv_nsec - a.tv_nsec) * 1e-6;
        }
    qsort(ms, (size_t)n, sizeof *ms, cmp);
    printf("depth->markers 640x480, step %d (%dx%d cells), %d frames: median %.3f ms, p99 %.3f ms\n",
           o.step, 640 / o.step, 480 / o.step, n, ms[n / 2], ms[(int)(0.99 * (n - 1))]);
    free(ms);
    free(d);
    drv_depth_tracker_destroy(t);
    return 0;
}
