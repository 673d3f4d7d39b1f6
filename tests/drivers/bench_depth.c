/* bench_depth.c - depth -> markers time per 640x480 frame (median, p99) on the 12 real Kinect
 * frames, one core: the default tracker (grid sized by the person's distance) against the fixed
 * 4-pixel grid in the same run. Usage: bench_depth [passes]. Run by `meson test --benchmark`. */
#include "depth.h"
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

/* Times the tracker on every frame, `passes` times over; prints median and p99. */
static void run(const char *name, const drv_depth_opts *o, const uint16_t *d, int passes)
{
    char err[DRV_ERR_LEN] = "";
    drv_depth_tracker *t;
    ASSERT_OK(drv_depth_tracker_create(o, &t, err), err);
    int n = passes * NF;
    double *ms = malloc((size_t)n * sizeof *ms);
    long cells = 0;
    drv_depth_result r;
    for (int p = 0; p < passes; p++)
        for (int i = 0; i < NF; i++) {
            struct timespec a, c;
            clock_gettime(CLOCK_MONOTONIC, &a);
            drv_depth_tracker_process(t, d + (size_t)i * 640 * 480, (uint64_t)(p * NF + i) * 33333, &r);
            clock_gettime(CLOCK_MONOTONIC, &c);
            ms[p * NF + i] = (c.tv_sec - a.tv_sec) * 1e3 + (c.tv_nsec - a.tv_nsec) * 1e-6;
            cells += r.person_cells;
        }
    qsort(ms, (size_t)n, sizeof *ms, cmp);
    printf("%-34s %d frames, %5ld person cells: median %.3f ms, p99 %.3f ms\n", name, n,
           cells / n, ms[n / 2], ms[(int)(0.99 * (n - 1))]);
    free(ms);
    drv_depth_tracker_destroy(t);
}

int main(int argc, char **argv)
{
    int passes = argc > 1 ? atoi(argv[1]) : 200;
    uint16_t *d = malloc((size_t)NF * 640 * 480 * sizeof *d);
    for (int i = 0; i < NF; i++)
        kinect_frame_load(frames[i], d + (size_t)i * 640 * 480);
    printf("depth->markers, 640x480 Kinect v1 frames (the 12 real ones), one core:\n");
    drv_depth_opts o;
    drv_depth_opts_default(&o);
    run("grid sized by distance (default)", &o, d, passes);
    o.cell_m = 0; /* the baseline: the fixed 4-pixel grid */
    run("fixed 4-pixel grid (baseline)", &o, d, passes);
    free(d);
    return 0;
}
