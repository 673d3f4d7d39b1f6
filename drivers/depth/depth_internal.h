/* depth_internal.h - the stages of depth -> markers, shared inside drivers/depth/ and by its tests.
 * Each stage lives in its own file (segment.c, geodesic.c, label.c, one_euro.c); markers.c chains
 * them. All arrays are sized once by drv__grid_init / drv__geodesic_init. */
#ifndef MESHSTEER_DRIVERS_DEPTH_INTERNAL_H
#define MESHSTEER_DRIVERS_DEPTH_INTERNAL_H

#include "../depth.h"

/* ------------------------------------------------------------------ the downsampled grid (segment.c) */

typedef struct drv__extremum drv__extremum;

typedef struct drv__grid {
    int gw, gh, n, step; /* this frame's grid: step x step pixel cells, gw x gh of them */
    int nmax;            /* cells allocated: the grid at the smallest step */
    float *P;        /* n x 3: the cell's sample point, Y-up camera frame, metres */
    float *z;        /* n: depth along the axis (metres); 0 = no reading or gated out */
    uint8_t *probe;  /* n: which of the cell's four probes the sample came from (drv__grid_pixel) */
    int32_t *comp;   /* n: connected component id, -1 = background */
    uint8_t *person; /* n: 1 = the tracked person */
    int *stack;      /* n: flood-fill scratch */
    int *cells;      /* n: the person's cells, ncells of them */
    int ncells;
    float *c_area;   /* n: per component: area (m^2), */
    float *c_sumz;   /*    sum of depths, */
    int *c_count;    /*    cells, */
    int *c_first;    /*    its first and last cell (the smallest and largest index) */
    int *c_last;
    int32_t *hole;   /* n: cells enclosed by the person: hole id (>= 0); else -1, -2 (outside)
                        or -3 (a person cell that closes holes); drv__segment_arm_loops */
    int *hole_cells; /* n: scratch, the cells of the hole being measured */
    float centroid[3]; /* mean of the person's cells */
    float mean_z;
} drv__grid;

int drv__grid_init(drv__grid *g, const drv_depth_opts *o, char *err);
void drv__grid_fini(drv__grid *g);
/* The step used when cell_m > 0 for a person at depth z (metres) while `step` is in use. */
int drv__grid_choose_step(const drv_depth_opts *o, int step, float z);
/* The pixel (u, v) the sample of a cell came from. */
void drv__grid_pixel(const drv__grid *g, int cell, int *u, int *v);
/* Makes g a grid of step x step cells (within the allocated size). */
void drv__grid_set_step(drv__grid *g, const drv_depth_opts *o, int step);

/* Samples the depth image into the grid: per cell the nearest valid reading among four probes,
 * gated to [z_min, z_max]. */
void drv__segment_sample(drv__grid *g, const drv_depth_opts *o, const uint16_t *depth_mm);
/* RANSAC floor plane over the grid's points (normal within floor_max_tilt of +Y). On success writes
 * plane (n.p + d = 0, n pointing up), clears the cells on or below the floor and returns 1. */
int drv__segment_floor(drv__grid *g, const drv_depth_opts *o, uint64_t *rng, float plane[4]);
/* Connected components (8-neighbour, |dz| < seg_jump); picks the nearest component whose area is at
 * least min_area and a quarter of the largest one. Fills person/cells/centroid; returns ncells. */
int drv__segment_person(drv__grid *g, const drv_depth_opts *o);

/* Hands closing a loop with the torso (hands on the hips): the background the person encloses
 * (4-connected non-person cells that do not reach the image border) forms holes; a hole of arm-loop
 * size beside the torso, between hip and chest height, yields a hand candidate; on a side without
 * one, so does a slit, a loop closed across an occluding edge (max_jump; see segment.c).
 * up/right: body frame as in drv__label_assign. Appends at most `max` candidates to ex (loop =
 * +1 / -1 for a hole on the camera's +X / -X side) and returns how many. */
int drv__segment_arm_loops(drv__grid *g, const drv_depth_opts *o, const float up[3],
                           const float right[3], drv__extremum *ex, int max);

/* xorshift64* in [0, 1) */
double drv__rand01(uint64_t *s);

/* ------------------------------------------------------------------ geodesic extrema (geodesic.c) */

/* metres above the floor: the ankle's height, 0.039 of the body's height (Drillis & Contini),
 * 0.068 m at 1.75 m. A leg that the image's bottom edge cuts higher than this is cut through the
 * shin, not the foot (markers.c); an extremum lower than this stands on the floor (label.c) */
#define DRV__ANKLE_HEIGHT 0.07f

/* An arm loop's forearm whose depth falls faster than this across the image (depth per metre,
 * tan 45 degrees) towards the contact comes towards the camera: its hand is held in front of the
 * body, not rested on it (segment.c places it, markers.c gives it its depth) */
#define DRV__LOOP_TOWARD 1.f

struct drv__extremum {
    int cell;
    float geodesic;   /* metres from the nearest earlier source when found */
    float geodesic0;  /* metres from the centroid alone (the first pass) */
    float tip[3];     /* mean of the cells within tip_radius of it */
    float anchor[3];  /* a point on the limb, ANCHOR_BACK back from the tip along its path
                         from the source (geodesic.c): tells the side when tips cross */
    int border;       /* in the grid's outermost row or column: a limb cut by the image's edge,
                         not an extremity: 1 at the top or a side, 2 at the bottom only (a foot
                         standing below the view) */
    int top_cut;      /* in the grid's top row, not in its first or last column: a limb that
                         goes on above the image (label.c: a head cut a little short) */
    int loop;         /* 0: a geodesic extremum; +1 / -1: a hand estimated from an arm loop on the
                         camera's +X / -X side (drv__segment_arm_loops) */
    int loop_rim;     /* then: the forearm's rim cells its depth line was fitted on (0 = no
                         line: too few), */
    float loop_slope; /*   the line's depth change per metre across the image from the elbow
                           to the contact (< 0: the forearm comes towards the camera; at most
                           -DRV__LOOP_TOWARD: its hand is held in front of the body), */
    float loop_z;     /*   and its depth at the contact (metres along the axis), */
    int loop_slit;    /*   1 when the loop is closed by an occluding edge (the forearm in front
                           of the torso), not by background */
    float path_hmax;  /* the highest point (metres above the source, along `up`) of its shortest
                         path from the source: an arm's path climbs to the shoulder, a leg's not */
    float path_lmax;  /* the farthest its shortest path from the source goes to either side
                         (metres along `right`): an arm's passes through its shoulder, a neck's
                         stays near the body's mid-plane */
    float below_top;  /* metres along its first-pass path from the path's highest point (along
                         `up`) to the tip: a hanging arm's visible length from its shoulder */
    int hidden_end;   /* the limb ends at an occluding edge: a nearer surface lies next to its tip,
                         so the limb goes on behind it (a hand behind the hip) */
    float hidden[3];  /* then: the tip carried on behind the edge along the limb's direction */
    float occluder[3]; /* then: the mean of the nearer surface's cells next to the tip, each moved
                          along its viewing ray to the tip cell's depth: where, in the image, the
                          limb goes on behind it (a foot behind the other shin, markers.c) */
};

typedef struct drv__geodesic {
    int n;
    float *dist;   /* n, in dist_mem after a margin of pad cells (FLT_MAX) */
    float *dist_mem;
    int pad;
    int *parent;   /* n */
    /* the queue: Dial's buckets of width q (geodesic.c), a ring of nb lists linked through
       next/prev; bucket[i] is the first cell of ring slot i or -1 */
    int *next, *prev; /* n */
    int *slot;        /* n: a queued cell's ring slot, -1 = not queued */
    int *bucket;      /* nb */
    uint64_t *full;   /* nb / 64 (at least 1): bit i set = bucket[i] is not empty */
    int nb;           /* a power of two */
    long cur;         /* the bucket (absolute: floor(dist / q)) being emptied */
    float iq;         /* 1 / q */
    float *w;         /* n x 8: this frame's edge weights to the 8 neighbours (NBR order of
                         geodesic.c), FLT_MAX = no edge */
    float *bw;        /* n x 2: weights of the bridges up and down the column (FLT_MAX = none), */
    int *bt;          /*        and the cells they reach (the cell itself when none) */
    float *h;      /* n: height of a person cell above the source along `up` */
    float *hmax;   /* n: highest h along the cell's shortest path from the source (first pass) */
    float *dist0;  /* n: the first pass's distances from the source alone, */
    int *parent0;  /*    and its shortest-path tree (anchors are taken on it) */
    int hn;        /* cells queued */
} drv__geodesic;

int drv__geodesic_init(drv__geodesic *ge, const drv_depth_opts *o, int n, char *err);
void drv__geodesic_fini(drv__geodesic *ge);
/* The bucket width of the geodesic queue: below the shortest edge between cells nearer than
 * z_near (metres). */
float drv__geodesic_quantum(const drv_depth_opts *o, int step, float z_near);
/* Accumulative geodesic extrema on the person's cells of g, starting from `source` (a person cell).
 * Returns the number found (<= max), in the order found. */
int drv__geodesic_extrema(drv__geodesic *ge, const drv__grid *g, const drv_depth_opts *o,
                          int source, const float up[3], const float right[3], drv__extremum *ex,
                          int max);

/* metres: a head's length, ~0.13 of the body's height from chin to crown (Drillis & Contini),
 * 0.21 m at 1.6 m. head_axis.c takes the head's cells within it of the head's extremum;
 * head_crown.c, the head's top beyond an arm within it of the head's tip. */
#define DRV__HEAD_REACH 0.2f

/* The extremum among ex[0..nex) that is the top of the head labelled ex[head], cut off from it by
 * an arm in front of the head (head_crown.c), or -1. label: the extremum of each label, -1 = none;
 * up: the body frame's up. */
int drv__head_crown(const drv__extremum *ex, int nex, const int label[5], int head,
                    const float up[3]);

/* The top of the head found at extremum x, on the head's axis, from its silhouette in g
 * (head_axis.c). Returns 0, p untouched, when no grid row across the head is two cells wide or an
 * occluder hides part of its silhouette. */
int drv__head_on_axis(const drv__grid *g, const drv__geodesic *ge, const drv_depth_opts *o,
                      const drv__extremum *x, float p[3]);

/* The geodesic graph's max_jump for a person at depth z (markers.c): at least MAX_JUMP_STEPS of
 * the sensor's depth steps there. */
float drv__depth_max_jump(const drv_depth_opts *o, float z);

/* ------------------------------------------------------------------ body frame (body_frame.c) */

typedef struct drv__body_frame {
    float theta; /* radians: the person's left axis, from the camera's +X towards the camera */
    int init;    /* a fit has been taken since the reset */
} drv__body_frame;

void drv__body_frame_reset(drv__body_frame *bf);
/* The person's left (unit, orthogonal to up) from the torso's depth surface of g, smoothed over
 * frames; returns 1 when this frame's torso gave it, 0 when the last one is kept. */
int drv__body_frame_update(drv__body_frame *bf, const drv__grid *g, const float up[3],
                           float left[3]);

/* ------------------------------------------------------------------ labelling (label.c) */

typedef struct drv__label_prev {
    float p[5][3];     /* head, lhand, rhand, lfoot, rfoot, as last output */
    uint8_t valid[5];
    uint8_t missed[5]; /* frames since the label was last found (0: found in the previous one) */
    uint8_t top_touch; /* the person's silhouette reaches the image's top edge (markers.c) */
    float elbow_reach0; /* metres from the centroid: a hand nearer is an elbow (markers.c; 0 for
                           a person not seen down to the floor) */
    float head_len;    /* the person's centroid-to-head-top geodesic, measured on earlier frames
                          with the head in full view (markers.c); 0 = not yet measured */
    uint8_t whole_body; /* the person is seen down to the floor, so the centroid is the whole
                           body's (markers.c); label.c's HEAD_APART holds only then */
    float centroid_floor; /* metres from the floor up to the centroid (markers.c), 0 when no
                             floor was found: an extremum's height above the floor is its height
                             above the centroid plus this (`up` is the floor's normal then) */
} drv__label_prev;

/* Assigns extrema to head/lhand/rhand/lfoot/rfoot. `up` and `right` are unit vectors of the body
 * frame (camera frame Y-up; right = the person's left, body_frame.c: the camera's +X for a person
 * facing the camera). label[i] receives the extremum index per label or -1; conf[i] in 0..1;
 * side_sure[i] 0 when the hands' (feet's) sides are not certain: the best assignment with the two
 * swapped costs less than SIDE_MARGIN more (label.c); *head_sure 0 when the head's anchor lies
 * more than HEAD_ASIDE off the mid-plane, or when the head, lost while the person reaches the
 * image's top edge, was found within its aged reach (label.c): where it is, is a guess. */
void drv__label_assign(const drv__extremum *ex, int nex, const float centroid[3], const float up[3],
                       const float right[3], const drv__label_prev *prev, int label[5],
                       float conf[5], uint8_t side_sure[5], uint8_t *head_sure);
/* 1 when a hand's path from the centroid climbs to a shoulder or passes one (ARM_CLIMB, ARM_SIDE
 * in label.c): it was reached through an arm. An arm-loop hand (segment.c) counts as reached. */
int drv__label_through_arm(const drv__extremum *x);

/* ------------------------------------------------------------------ One Euro filter (one_euro.c) */

typedef struct drv_one_euro {
    double min_cutoff, beta, dcutoff;
    int init;
    double x, dx;     /* filtered value and derivative */
    uint64_t t_us;    /* time of the last sample */
} drv_one_euro;

void drv_one_euro_init(drv_one_euro *f, double min_cutoff, double beta, double dcutoff);
void drv_one_euro_reset(drv_one_euro *f);
double drv_one_euro_filter(drv_one_euro *f, double x, uint64_t t_us);

#endif
