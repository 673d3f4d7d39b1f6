/* fakenect.h - libfreenect "fakenect" dump directories: writer (from the test camera) and the
 * `fakenect:DIR[?loop=1]` marker source (fakenect.c).
 *
 * Format (what libfreenect's `record` tool writes and fakenect replays): DIR/INDEX.txt lists one
 * file name per line, "d-<time>-<timestamp>.pgm" for depth ("r-..ppm" video and "a-..dump"
 * accelerometer are skipped), <time> the host time in seconds (printf %f), <timestamp> the
 * device's 32-bit frame counter. A depth file is "P5 640 480 65535\n" followed by 640x480 raw
 * 11-bit disparities, 16 bits each in the recording host's byte order (little-endian here),
 * 2047 = no reading. Depth in mm = 1000 / (3.3309495 - 0.0030711 d) (depth.h).
 *
 * The source reads frame after frame paced by the recorded times, runs depth -> markers on each
 * and yields the markers head, lhand, rhand, lfoot, rfoot, torso (depth.h frame, metres). */
#ifndef MESHSTEER_DRIVERS_DEPTH_FAKENECT_H
#define MESHSTEER_DRIVERS_DEPTH_FAKENECT_H

#include "../depth.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The writer (drv_fakenect_writer_open/_depth/_close) is declared in ../depth.h. */

/* Parses one INDEX.txt line; returns 1 for a depth entry (time and timestamp set), 0 for another
 * kind of entry, a negative error for a malformed line. */
int drv_fakenect_parse_index_line(const char *line, size_t len, double *t, uint32_t *timestamp,
                                  char *err);
/* Parses a depth PGM (640x480, maxval 65535, little-endian raw disparities) into millimetres. */
int drv_fakenect_parse_depth(const uint8_t *buf, size_t len, const char *name, uint16_t *mm,
                             char *err);

/* The source kind "fakenect" for the registry of drivers.h. */
extern const drv_source_ops drv_fakenect_ops;

#ifdef __cplusplus
}
#endif
#endif
