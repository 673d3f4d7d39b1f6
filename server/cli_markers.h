/* cli_markers.h - marker-file options shared by the commands that read marker files. */
#ifndef MESHSTEER_CLI_MARKERS_H
#define MESHSTEER_CLI_MARKERS_H

#include "model.h"

/* Parses "x", "y", "z", "-x", "-y", "-z" or "auto" into MDL_UP_*; -1 on error. */
int cli_parse_up(const char *s);

/* The shared marker options: opt "marker-scale" or "marker-up" with its argument into *mo.
 * Prints a usage error naming the command and returns -1 on a bad value. */
int cli_marker_option(const char *cmd, const char *opt, const char *arg, mdl_marker_opts *mo);

/* Help text for --marker-scale and --marker-up. */
#define CLI_MARKER_OPTS_HELP                                                                       \
    "  --marker-scale S   metres per unit of the marker file (default: from the file, or a\n"       \
    "                     guess from the skeleton height for BVH)\n"                                \
    "  --marker-up AXIS   the file's up axis: x, y, z, -x, -y, -z (default: the format's own)\n"

#endif
