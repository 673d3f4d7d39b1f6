/* bone_colours.h - colours that show a skin's bones (issue 10; `meshsteer render --skin`): each
 * bone its own colour, each vertex the weight blend of its bones' colours. */
#ifndef MESHSTEER_SERVER_BONE_COLOURS_H
#define MESHSTEER_SERVER_BONE_COLOURS_H

#include <stdint.h>

/* Bone j's colour (RGB in [0, 1]): hues a golden ratio of the circle apart, so neighbouring
 * indices differ and any number of bones gets distinct hues; saturation 0.75, value 0.95. */
void srv_bone_colour(int j, float rgb[3]);

/* out (nv x 3, 8 bits): vertex i's colour is sum over its K slots of w[i K + k] times the colour
 * of bone[i K + k] (weights that sum to one give a colour of the same brightness). */
void srv_skin_vertex_colours(int nv, int K, const int *bone, const double *w, uint8_t *out);

#endif
