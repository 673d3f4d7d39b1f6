/* markers.c - the depth -> markers tracker: chains segmentation (segment.c), accumulative geodesic
 * extrema (geodesic.c), labelling with temporal consistency (label.c) and One Euro smoothing
 * (one_euro.c). See depth.h for the frames and units.
 *
 * Per frame: sample + gate -> floor plane -> nearest person -> geodesic source = the person's cell
 * nearest to its 3D centroid -> up to max_extrema extrema, plus hands estimated from arm loops
 * (segment.c) -> labels (body frame: up = the floor
 * normal when a floor was found, else the camera's +Y; right = the person's left, across the
 * torso's surface, body_frame.c) -> per-label filter. A hand or foot whose side label.c finds
 * uncertain is filtered as found but reported not valid (side_uncertain). A label not found keeps its last output for hold_frames frames (reported
 * invalid) so that it can be re-associated; after that its filter restarts. A hand reported
 * valid after a frame in which it was reported inferred (a guess: behind the body, short of the
 * elbow, not reached through an arm; below) restarts its filter from the new measurement too: the
 * One Euro filter's state still holds the guess, which pulled the first confident reports towards
 * it (pjump facing at 3.5 m, the left hand valid after guesses, frames 49-50, 81-82 and 99-100:
 * 20, 8, 21, 9, 32 and 35 cm off before, 6, 3, 4, 2, 6 and 3 cm after).
 * Over both grids, yaw -35..35 and 2.0-3.5 m, hands within 10 cm rose in 36 of 40 cells and fell
 * in none (pjump at 3.5 m, -35 degrees 0.548 -> 0.609; facing 0.796 -> 0.810), valid hands with
 * no hand within 10 cm fell in 36 and rose in one (+0.002); the SMPL takes' hands hop 0.406 ->
 * 0.440, run 0.402 -> 0.461. Heads and feet were tried too and are not restarted: heads lost up
 * to one of 11 at 2.0 m and valid wrong heads at 2.5 m rose 0.01-0.03; feet changed only at 2.0
 * m, where the valid wrong ones (legs cut by the image's bottom edge) rose (docs/PERFORMANCE.md).
 * The head's filter follows motion faster than the others' (oe_head_beta 32 s/m and
 * oe_head_dcutoff 2 Hz against oe_beta 8 and oe_dcutoff 1; the same min_cutoff at rest). One Euro
 * trades jitter at rest against lag in motion through the derivative it estimates (one_euro.c),
 * and the head's measurement is less noisy than a hand's or a foot's: a hand or foot is the mean
 * of a tip's few cells, the head an axis through every row of its silhouette (head_axis.c). Its
 * unfiltered frame-to-frame jitter at the default placement is about half theirs on samba (median
 * 9.3 mm against 17-24 mm for the hands and 12-14 mm for the feet), so its speed is trusted sooner.
 * With the hands' constants, pjump landing from a jump bent towards the camera (frames 120-126)
 * had its filtered head 1-5 cm behind its measurement, which is 9-10 cm from the truth there (the
 * neck's flat cut, head_axis.c): unfiltered, its heads at the default placement were 0.922 within
 * 10 cm, filtered 0.844. Filtered faster: 0.906, and pjump's heads rose in 13 of the 20 cells of
 * its grid (yaw -35..35, 2.0-3.5 m; fell in two at 2.0 m, one head of 11 each); samba's moved by
 * one head in two cells; samba's head jitter, median 3.4 -> 4.4 mm (its hands' 12-13 mm);
 * docs/PERFORMANCE.md, "The head's filter follows motion faster".
 * The person's head length (centroid-to-head geodesic) is measured on the frames with the head
 * in full view (no extremum on the image's top edge: else a shoulder under a head out of view may
 * be labelled), so that a head cut a little short by the image's top edge is still found
 * (label.c); such a head is
 * placed on the middle of the cut (the head's axis; the extremum is wherever the cut's farthest
 * cell happens to be, 12-26 cm to the side in 19 of 48 such heads on pjump) and raised by the
 * length missing above the image (head_above_cut); when that cut is wider than a head is long, it
 * runs below the head (shoulders, chest, raised arms) and the head is reported inferred
 * (HEAD_CUT_WIDTH). A head in full view is placed at its top on its
 * axis, found from its silhouette (head_axis.c), or, when an arm in front of it hides part of that,
 * half a head (head_offset) behind its visible top (behind the top beyond the arm, when the arm
 * cuts the head's top off from the face: head_crown.c). The torso marker is the centroid. A
 * hand whose extremum ends at an occluding edge (geodesic.c, hidden ends) is placed at the
 * estimated hidden end. That estimate carries the limb on by a hand's length, which is right when
 * only the hand is hidden (samba's hands on the far hip, the forearm in view), and a guess when the
 * visible arm ends at or above the elbow: the forearm and hand behind the nearer surface could then
 * be anywhere within their reach. How far the visible arm goes is measured along the hand's path
 * from its highest point (the shoulder, for an arm that hangs; geodesic.c below_top): shorter than
 * the upper arm (ELBOW_REACH), or longer than a whole arm (ARM_REACH: the highest point is not a
 * shoulder), and the hand is reported inferred (drv_depth_result.inferred), not valid; so is a hand
 * not reached through an arm, its path from the centroid neither climbing to a shoulder nor passing
 * one (drv__label_through_arm; samba at -20 degrees: 1 of 26 such hands within 10 cm). Measured on
 * samba and pjump at 2.5 m, yaw -35..35 (249 hands at hidden ends): within 10 cm in 6 of 176 with
 * the visible arm under 0.3 m and 4 of 24 over 0.55 m, against 36 of 49 between; of the valid
 * hand reports, those with no hand within 10 cm fell in every cell of the grid (samba at -35
 * degrees, 2.5 m: 0.35 -> 0.23; pjump at 2.5 m facing 0.13 -> 0.10; docs/PERFORMANCE.md), hands
 * within 10 cm did not change (they count inferred hands) and side_correct fell by less than 0.01.
 * A hand reached through its arm lies at least the centroid-to-shoulder geodesic (~0.45 m) and an
 * upper arm (ELBOW_REACH) from the centroid; an extremum nearer than that (SHOULDER_GEODESIC +
 * ELBOW_REACH = 0.75 m; arm loops aside, whose hands have no geodesic) is an elbow or a shoulder,
 * the hand hidden, or a hand brought against the body and reached across the contact: it is
 * reported inferred too, when the person is seen down to the floor (FEET_IN_VIEW): the centroid of
 * an upper body seen to the waist lies on the chest, nearer the shoulders (the hand held out
 * towards the camera in tests/drivers/test_markers.c's depth-data-1399145206 was inferred without
 * that guard). Of the valid hand reports over samba and pjump at 2.5 m, yaw -35..35,
 * those nearer than 0.75 m were within 10 cm of their hand in 12 of 136 (3,181 reports not from
 * arm loops); with the rule the valid-but-wrong hands fell in 37 of the grid's 40 cells (samba at
 * -35 degrees, 3.5 m 0.34 -> 0.21; pjump at 2.0 m, +20 degrees 0.25 -> 0.12) and held in three,
 * fell on the SMPL takes too (walk 0.53 -> 0.30, lambada 0.20 -> 0.05), hands within 10 cm did not
 * move and side_correct fell by at most 0.015 (pjump facing at 2.0 m; at 2.5 m 0.961 -> 0.955).
 * A hand from an arm loop (segment.c) is a point on the visible surface a hand's length past where
 * the forearm meets the hip in the image (or, for a forearm coming towards the camera, the far end
 * of the forearm's own surface from the elbow); where the hand really is follows from the forearm's
 * depth along the loop's rim, elbow to contact (segment.c fits a line to it). A forearm that lies
 * across the body (its depth level, or coming towards the camera less steeply than 45 degrees:
 * slope above -DRV__LOOP_TOWARD) rests its hand on the hip, against the side or back of it: the
 * hand is moved LOOP_BEHIND = 8 cm back along the viewing ray, a little less than half a hip's
 * depth (~0.2 m; samba, hands on the hips/back: hand within 10 cm at yaw +20 0.83 -> 0.98, facing
 * 0.91 -> 0.93; its forearm slopes are -0.73 .. +0.29 at 2.5 m). A forearm that comes towards the
 * camera more steeply than that points at the camera, and its hand is held in front of the body,
 * not on it: the surface seen behind the hand's place is the belly, so the hand is put at the
 * forearm's depth at the contact instead (when nearer) - pjump, hands before the belly at yaw -20
 * (slopes -1.0 .. -4.1 at 3.2 m), was placed 12-23 cm too far, hands within 10 cm at 3.2 / 3.5 m
 * 0.70 / 0.62 -> 0.75 / 0.69; the SMPL man running 0.19 -> 0.30 facing at 2.5 m; no cell of samba,
 * pjump or the SMPL takes fell. The sign of the slope alone does not tell: samba's level forearms
 * (slope -0.7 .. 0) then lose their push, hands at yaw +20 0.97 -> 0.87. Extrapolating the
 * forearm's line on by a hand's length (5 or 10 cm along it) or putting the hand at the contact
 * itself overshoots (pjump -20, 3.5 m: 0.66, 0.64, 0.63).
 * A hand from a slit (segment.c: the loop closed across an occluding edge, the forearm in front of
 * the torso) is placed the same way and reported inferred: the hand is not told from the hip it
 * rests on. Over both grids, own turns kept: hands within 10 cm at yaw -20 on samba (at down to
 * -58 degrees, a hand on the near hip) 0.740 / 0.731 / 0.697 / 0.694 -> 0.814 / 0.843 / 0.794 /
 * 0.729 at 2.0 / 2.5 / 3.2 / 3.5 m (max_jump at 3.5 m: 11 cm; not examined further),
 * at -35 degrees up 0.003-0.09; pjump within 0.003 in every cell; confident_wrong and side_correct
 * unchanged at -20..+20 degrees and on the SMPL takes (the hop's hands 0.440 -> 0.438, one of
 * 552), moved by at most 0.01 and 0.0015 at +-35; facing held, one cell's hands moved (pjump at
 * 3.2 m facing 0.908 -> 0.906). Reported valid, the slit hands raised the SMPL walk's valid wrong
 * hands 0.261 -> 0.432.
 * A foot is the end of a leg in view. A leg that the image's bottom edge cuts (its extremum in the
 * grid's bottom row, or the leg going on down to it from there: reaches_bottom) higher above the
 * floor than an ankle (DRV__ANKLE_HEIGHT) is cut through the shin: the foot is below the image and
 * the point labelled is a guess, reported inferred. label.c still lets such a cut be a foot
 * (FOOT_CUT), because a foot standing at the image's bottom edge is cut through itself, and is
 * found there: over both grids (2.0-3.2 m, yaw -35..35), cut tips within 4 cm of the floor were
 * within 10 cm of their foot in 99 % (samba) and 100 % (pjump), 6-8 cm up in 51 % and 83 %, 10-12
 * cm up in 0 and 56 %. At 2.0 m the bottom edge cuts both performers' legs 4-27 cm above the floor,
 * and valid foot reports with no foot within 10 cm fell in all 20 cells of that distance (samba
 * facing 0.68 -> 0.29, pjump facing 0.57 -> 0.29, pjump at +20 degrees 0.54 -> 0.16), at 2.5-3.5 m
 * they moved in one cell, by 0.0001; feet within 10 cm (which count inferred feet) did not change
 * anywhere, and side_correct fell by at most 0.010 (pjump at 2.0 m, feet in view cut at their
 * ankles). Without a floor plane there is no height to go by, and a cut foot stays valid as
 * before.
 * A foot standing on the floor (its tip lower than DRV__ANKLE_HEIGHT) whose tip ends at an
 * occluding edge (geodesic.c's hidden end: a surface 8 cm nearer within two grid cells) goes on
 * behind that surface: a foot behind the other shin or foot. How far is not seen; that it reaches
 * under the surface hiding it is. The foot is moved along the floor (the offset's part along the
 * floor's normal dropped) to the mean of the hiding cells next to its tip, each brought along its
 * viewing ray to the tip's depth (foot_behind): a cell or two, no constant of its own. samba
 * turned -20 degrees (at down to -58 from frame ~130, her right foot behind her left shin, its
 * visible end 11-25 cm from the toe): feet within 10 cm 0.825 / 0.800 / 0.786 -> 0.933 / 0.837 /
 * 0.803 at 2.5 / 3.2 / 3.5 m, valid foot reports with no foot within 10 cm 0.142 -> 0.049 at 2.5
 * m; at -35 degrees 0.412 / 0.850 / 0.851 / 0.809 -> 0.824 / 0.863 / 0.860 / 0.814 (2.0-3.5 m);
 * one foot fewer in three cells (samba facing at 2.5 m, +20 degrees at 3.5 m, pjump facing at 3.5
 * m); the SMPL takes within a foot (lambada facing 0.9615 -> 0.9633, at -20 degrees 0.8917 ->
 * 0.8908). The moved foot is what the filter and the next frame's temporal term (label.c) see:
 * moved in the report only, the label slid off the hidden foot more often (-20 degrees 0.885 /
 * 0.826 / 0.791). The cost: where the two feet's sides are a near tie, the other outcome - samba
 * with her turns undone, +35 degrees, 2.5 m, frames 87-101 (side_wrong 0 -> 0.021).
 * Tried and not kept (docs/PERFORMANCE.md): a fixed 4 cm towards the same surface gives
 * the same; 7 / 10 / 13 cm gain at -20 degrees, 3.5 m (0.829 / 0.829 / 0.811) but lose at 2.0 m
 * (1.000 -> 0.933 / 0.867 / 0.533) and facing (3.5 m: 0.911 -> 0.914 / 0.903 / 0.877); the hand's
 * rule, the limb's last direction carried on (made level, 7 cm), is the shin's direction for a
 * foot: 0.786 -> 0.749 at 3.5 m; a foot held where it stood while it stays on the floor within a
 * foot's length of it: samba's feet slide along the floor as she dances, 0.936 -> 0.601 facing. */
#include "depth_internal.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LOOP_BEHIND 0.08f /* metres, see the header */
/* A hand at a hidden end is a guess unless its visible arm, from its path's highest point (the
 * shoulder), reaches past the elbow and no farther than a whole arm (see the header). Segment
 * lengths after Drillis & Contini, at 1.6 m tall: upper arm 0.186 x height, upper arm + forearm +
 * hand 0.44 x height. */
#define ELBOW_REACH 0.30f
#define ARM_REACH 0.70f
/* The geodesic from the centroid to a shoulder (label.c HAND_REACH): a hand reached through its
 * arm lies at least this and an upper arm (ELBOW_REACH) from the centroid; nearer, the extremum is
 * an elbow or a shoulder, or a hand brought against the body, and is reported inferred; label.c
 * costs a hand candidate that falls short of the same bound by what it lacks (elbow_reach0). */
#define SHOULDER_GEODESIC 0.45f
/* metres above the floor: a person seen this low is seen down to the shins, and the centroid of
 * what is in view is the whole body's within a few cm (the feet and lower shins are ~3 % of the
 * body's mass) */
#define FEET_IN_VIEW 0.3f
/* The geodesic graph joins neighbouring cells whose depths differ by less than max_jump, or by
 * less than this many of the Kinect's depth steps at the person's depth, whichever is more (the
 * steps grow with the square of the depth: 1.9 cm at 2.5 m, 3.8 cm at 3.5 m; max_jump = 8 cm was
 * chosen at 2.5 m), at most half of seg_jump. */
#define MAX_JUMP_STEPS 3.f
/* The person's head length - the geodesic from the centroid to the head's top - is averaged
 * over the frames where the head is found in full view (exponentially, this much of the new one
 * per frame); label.c lets a limb cut by the image's top edge be the head when it is about as
 * long (the top of the head just above the image). */
#define HEAD_LEN_ALPHA 0.1f
/* metres: a head cut by the image's top edge whose cut is wider than this across the image is cut
 * below the head - through the shoulders, the chest or both raised arms - and the head above the
 * image is a guess, reported inferred. No horizontal section of a head is wider, seen from any
 * side, than the head is long: a head's length (depth_internal.h) */
#define HEAD_CUT_WIDTH DRV__HEAD_REACH

const char *const drv_depth_label_names[DRV_DEPTH_NLABELS] = {"head",  "lhand", "rhand",
                                                              "lfoot", "rfoot", "torso"};

struct drv_depth_tracker {
    drv_depth_opts o;
    drv__grid g;
    drv__geodesic ge;
    uint64_t rng;
    drv__extremum ex[DRV_DEPTH_MAX_EXTREMA + 2]; /* geodesic extrema, then arm-loop hands */
    drv_one_euro f[DRV_DEPTH_NLABELS][3];
    float out[DRV_DEPTH_NLABELS][3]; /* last output */
    int missed[DRV_DEPTH_NLABELS];   /* frames since last found; > hold_frames = unknown */
    uint8_t hand_guessed[2];         /* the last hand found on each side was reported inferred */
    float person_z;                  /* the person's mean depth in the last frame that had one */
    drv__body_frame bf;              /* which way the person faces */
    float head_len;                  /* centroid-to-head geodesic (metres), 0 = not measured */
};

void drv_depth_opts_default(drv_depth_opts *o)
{
    memset(o, 0, sizeof *o);
    drv_intrinsics_kinect1(&o->k);
    o->step = 4;
    o->cell_m = 0.0172f; /* step 4 at 2.5 m with the Kinect v1's fx */
    o->step_min = 2;
    o->step_max = 12;
    o->z_min = 0.4f;
    o->z_max = 4.0f;
    o->max_jump = 0.08f;
    o->seg_jump = 0.25f;
    o->jump_penalty = 0.5f;
    o->attach_jump = 0.5f;
    o->attach_frac = 0.1f;
    o->floor = 1;
    o->floor_iters = 48;
    o->floor_tol = 0.025f;
    o->floor_max_tilt = 35.f;
    o->min_area = 0.04f;
    /* 12, not 9: a hand seen in separate patches (a forearm across a depth step) takes two or
       three extrema (pjump frame 46: three at its left hand, within 10 pixels), and with 9 the
       other hand's or a foot's was sometimes not among them. docs/PERFORMANCE.md, "Twelve
       extrema and a head apart": pjump's hands at 3.2 m, -20 degrees 0.76 -> 0.82;
       bench_depth +0.02 ms */
    o->max_extrema = 12;
    o->min_extent = 0.12f;
    o->tip_radius = 0.04f;
    o->head_offset = 0.07f;
    o->smooth = 1;
    o->oe_min_cutoff = 1.5;
    o->oe_beta = 8.0;
    o->oe_dcutoff = 1.0;
    o->oe_head_beta = 32.0;
    o->oe_head_dcutoff = 2.0;
    o->hold_frames = 15;
    o->seed = 0x6d657368u;
}

int drv_depth_tracker_create(const drv_depth_opts *o, drv_depth_tracker **out, char *err)
{
    *out = NULL;
    if (!(o->k.fx > 0) || !(o->k.fy > 0) || !(o->z_max > o->z_min) || !(o->max_jump > 0) || o->seg_jump < o->max_jump || o->jump_penalty < 0 ||
        o->max_extrema < 1 || o->max_extrema > DRV_DEPTH_MAX_EXTREMA || !(o->floor_tol > 0) ||
        o->floor_iters < 0 || o->hold_frames < 0 || !(o->oe_min_cutoff > 0) || o->oe_beta < 0 ||
        !(o->oe_dcutoff > 0) || o->oe_head_beta < 0 || !(o->oe_head_dcutoff > 0)) {
        if (err)
            snprintf(err, DRV_ERR_LEN,
                     "depth tracker: bad options (fx %g, fy %g, depth gate %g..%g m, max_jump %g, "
                     "max_extrema %d of at most %d)",
                     o->k.fx, o->k.fy, o->z_min, o->z_max, o->max_jump, o->max_extrema,
                     DRV_DEPTH_MAX_EXTREMA);
        return -EINVAL;
    }
    drv_depth_tracker *t = calloc(1, sizeof *t);
    if (!t) {
        if (err)
            snprintf(err, DRV_ERR_LEN, "depth tracker: out of memory");
        return -ENOMEM;
    }
    t->o = *o;
    int r = drv__grid_init(&t->g, o, err);
    if (r == 0)
        r = drv__geodesic_init(&t->ge, o, t->g.nmax, err);
    if (r) {
        drv_depth_tracker_destroy(t);
        return r;
    }
    for (int l = 0; l < DRV_DEPTH_NLABELS; l++)
        for (int a = 0; a < 3; a++)
            drv_one_euro_init(&t->f[l][a], o->oe_min_cutoff,
                              l == DRV_DEPTH_HEAD ? o->oe_head_beta : o->oe_beta,
                              l == DRV_DEPTH_HEAD ? o->oe_head_dcutoff : o->oe_dcutoff);
    drv_depth_tracker_reset(t);
    *out = t;
    return 0;
}

void drv_depth_tracker_destroy(drv_depth_tracker *t)
{
    if (!t)
        return;
    drv__grid_fini(&t->g);
    drv__geodesic_fini(&t->ge);
    free(t);
}

void drv_depth_tracker_reset(drv_depth_tracker *t)
{
    t->rng = t->o.seed ? t->o.seed : 1;
    t->person_z = 0;
    t->head_len = 0;
    drv__body_frame_reset(&t->bf);
    drv__grid_set_step(&t->g, &t->o, t->o.step);
    for (int l = 0; l < DRV_DEPTH_NLABELS; l++) {
        t->missed[l] = INT32_MAX / 2;
        for (int a = 0; a < 3; a++)
            drv_one_euro_reset(&t->f[l][a]);
    }
    memset(t->out, 0, sizeof t->out);
    memset(t->hand_guessed, 0, sizeof t->hand_guessed);
}

void drv_depth_tracker_grid(const drv_depth_tracker *t, int *step, int *gw, int *gh,
                            const uint8_t **person)
{
    *step = t->g.step;
    *gw = t->g.gw;
    *gh = t->g.gh;
    *person = t->g.person;
}

float drv__depth_max_jump(const drv_depth_opts *o, float z)
{
    if (!(z > 0))
        return o->max_jump;
    const double d = drv_kinect1_m_to_disparity(z);
    const float q = (float)(drv_kinect1_disparity_to_m(d + 1.0) - z); /* one raw disparity step */
    const float j = fmaxf(o->max_jump, MAX_JUMP_STEPS * q);
    return fminf(j, 0.5f * o->seg_jump);
}

/* Puts a measurement (or its absence) for label l through the filter and the hold logic. */
static void emit(drv_depth_tracker *t, int l, const float *meas, uint64_t t_us, drv_depth_result *r)
{
    if (meas) {
        if (t->missed[l] > t->o.hold_frames)
            for (int a = 0; a < 3; a++)
                drv_one_euro_reset(&t->f[l][a]);
        for (int a = 0; a < 3; a++) {
            r->raw[l][a] = meas[a];
            t->out[l][a] = t->o.smooth ? (float)drv_one_euro_filter(&t->f[l][a], meas[a], t_us)
                                       : meas[a];
        }
        t->missed[l] = 0;
        r->valid[l] = 1;
    } else {
        if (t->missed[l] <= t->o.hold_frames)
            t->missed[l]++;
        r->valid[l] = 0;
        r->conf[l] = 0;
        memcpy(r->raw[l], t->out[l], sizeof r->raw[l]);
    }
    memcpy(r->xyz[l], t->out[l], sizeof r->xyz[l]);
}

/* The run of person cells in the grid's top row that holds cell c (in that row): [*lo, *hi]. */
static void top_run(const drv__grid *g, int c, int *lo, int *hi)
{
    *lo = *hi = c;
    while (*lo > 0 && g->person[*lo - 1])
        (*lo)--;
    while (*hi + 1 < g->gw && g->person[*hi + 1])
        (*hi)++;
}

/* A head (or neck) cut by the image's top edge (label.c): the extremum is the farthest cell of
 * the cut, which may lie anywhere along it. The head's axis passes through the middle of the
 * cut: the mean of the cut's run of person cells [lo, hi] (top_run); its top lies the missing
 * length of the person's head geodesic (t->head_len less the cut's) above. */
static void head_above_cut(const drv_depth_tracker *t, const drv__extremum *x, int lo, int hi,
                           const float up[3], float p[3])
{
    const drv__grid *g = &t->g;
    double m[3] = {0, 0, 0};
    for (int c = lo; c <= hi; c++)
        for (int a = 0; a < 3; a++)
            m[a] += g->P[3 * c + a];
    const float miss = fmaxf(0.f, t->head_len - x->geodesic0);
    for (int a = 0; a < 3; a++)
        p[a] = (float)(m[a] / (hi - lo + 1)) + miss * up[a];
}

/* 1 when the limb ending at cell c goes on to the grid's bottom row: c is in it, or the column of
 * person cells below c reaches it without a depth step over jump (the extremum of a leg cut by the
 * image's bottom edge may lie a row or two above it). */
static int reaches_bottom(const drv__grid *g, int c, float jump)
{
    while (c / g->gw < g->gh - 1) {
        const int d = c + g->gw; /* the cell below */
        if (!g->person[d] || fabsf(g->z[d] - g->z[c]) > jump)
            return 0;
        c = d;
    }
    return 1;
}

/* Metres above the floor plane f (unit normal, offset) of point p. */
static float floor_height(const float f[4], const float p[3])
{
    return f[0] * p[0] + f[1] * p[1] + f[2] * p[2] + f[3];
}

/* A foot on the floor whose tip ends at an occluding edge goes on behind the nearer surface: it
 * is moved along the floor to under that surface's middle next to it (see the header). */
static void foot_behind(const float floor[4], const drv__extremum *x, float p[3])
{
    const float d[3] = {x->occluder[0] - p[0], x->occluder[1] - p[1], x->occluder[2] - p[2]};
    const float up = d[0] * floor[0] + d[1] * floor[1] + d[2] * floor[2];
    for (int a = 0; a < 3; a++)
        p[a] += d[a] - up * floor[a];
}

int drv_depth_tracker_process(drv_depth_tracker *t, const uint16_t *depth_mm, uint64_t t_us,
                              drv_depth_result *r)
{
    drv__grid *g = &t->g;
    memset(r, 0, sizeof *r);
    for (int i = 0; i < DRV_DEPTH_MAX_EXTREMA; i++)
        r->extremum_label[i] = -1;
    drv__grid_set_step(g, &t->o, drv__grid_choose_step(&t->o, g->step, t->person_z));
    drv__segment_sample(g, &t->o, depth_mm);
    float up[3] = {0, 1, 0};
    if (t->o.floor && drv__segment_floor(g, &t->o, &t->rng, r->floor)) {
        r->floor_found = 1;
        memcpy(up, r->floor, sizeof up);
    }
    if (!drv__segment_person(g, &t->o)) {
        for (int l = 0; l < DRV_DEPTH_NLABELS; l++)
            emit(t, l, NULL, t_us, r);
        return 0;
    }
    r->person_cells = g->ncells;
    r->person_depth = g->mean_z;
    t->person_z = g->mean_z;
    /* the geodesic source: the person's cell nearest to the centroid */
    int src = -1;
    float bd = FLT_MAX;
    for (int k = 0; k < g->ncells; k++) {
        const float *p = g->P + 3 * g->cells[k];
        float dx = p[0] - g->centroid[0], dy = p[1] - g->centroid[1], dz = p[2] - g->centroid[2];
        float d = dx * dx + dy * dy + dz * dz;
        if (d < bd) {
            bd = d;
            src = g->cells[k];
        }
    }
    /* body frame: up, and the person's left from the torso's surface (body_frame.c) */
    float right[3];
    drv__body_frame_update(&t->bf, g, up, right);
    memcpy(r->left, right, sizeof r->left);
    /* the graph's depth tolerance follows the sensor's depth resolution at the person */
    drv_depth_opts go = t->o;
    go.max_jump = drv__depth_max_jump(&t->o, g->mean_z);
    int nex = drv__geodesic_extrema(&t->ge, g, &go, src, up, right, t->ex, t->o.max_extrema);
    for (int i = 0; i < nex; i++)
        t->ex[i].loop = 0;
    /* the options' max_jump, not the graph's: a slit's step does not grow with distance
       (segment.c) */
    nex += drv__segment_arm_loops(g, &t->o, up, right, t->ex + nex, 2);
    r->nextrema = nex < DRV_DEPTH_MAX_EXTREMA ? nex : DRV_DEPTH_MAX_EXTREMA;
    for (int i = 0; i < r->nextrema; i++) {
        memcpy(r->extrema[i], t->ex[i].tip, sizeof r->extrema[i]);
        r->geodesic[i] = t->ex[i].geodesic;
        drv__grid_pixel(g, t->ex[i].cell, &r->extremum_px[i][0], &r->extremum_px[i][1]);
    }
    drv__label_prev prev;
    for (int l = 0; l < 5; l++) {
        prev.valid[l] = t->missed[l] <= t->o.hold_frames;
        prev.missed[l] = (uint8_t)(t->missed[l] < 255 ? t->missed[l] : 255);
        memcpy(prev.p[l], t->out[l], sizeof prev.p[l]);
    }
    prev.head_len = t->head_len;
    prev.top_touch = 0; /* a cell of the person in the grid's top row */
    for (int x = 0; x < g->gw && !prev.top_touch; x++)
        prev.top_touch = g->person[x];
    int top_cut = 0; /* the person is cut by the image's top edge: the head may be out of view */
    for (int i = 0; i < nex; i++)
        top_cut |= t->ex[i].top_cut;
    /* the centroid is the whole body's when the person is seen down to the floor (an upper body's
       lies on the chest, nearer the shoulders than SHOULDER_GEODESIC) */
    int whole_body = 0;
    for (int k = 0; k < g->ncells && r->floor_found && !whole_body; k++) {
        const float *P = g->P + 3 * (size_t)g->cells[k];
        whole_body = floor_height(r->floor, P) < FEET_IN_VIEW;
    }
    prev.elbow_reach0 = whole_body ? SHOULDER_GEODESIC + ELBOW_REACH : 0.f;
    prev.whole_body = (uint8_t)whole_body;
    prev.centroid_floor = r->floor_found ? floor_height(r->floor, g->centroid) : 0.f;
    int label[5];
    float conf[5];
    uint8_t side_sure[5], head_sure;
    drv__label_assign(t->ex, nex, g->centroid, up, right, &prev, label, conf, side_sure,
                      &head_sure);
    for (int l = 0; l < 5; l++) {
        const int hand = l == DRV_DEPTH_LHAND || l == DRV_DEPTH_RHAND;
        const int foot = l == DRV_DEPTH_LFOOT || l == DRV_DEPTH_RFOOT;
        if (label[l] >= 0) {
            if (label[l] < DRV_DEPTH_MAX_EXTREMA)
                r->extremum_label[label[l]] = l;
            float p[3];
            memcpy(p, t->ex[label[l]].tip, sizeof p);
            if (hand && t->ex[label[l]].hidden_end)
                memcpy(p, t->ex[label[l]].hidden, sizeof p);
            if (foot && t->ex[label[l]].hidden_end && r->floor_found &&
                floor_height(r->floor, p) < DRV__ANKLE_HEIGHT)
                foot_behind(r->floor, &t->ex[label[l]], p);
            if (hand && t->ex[label[l]].loop) {
                const drv__extremum *x = &t->ex[label[l]];
                if (x->loop_rim && x->loop_slope <= -DRV__LOOP_TOWARD) { /* before the body */
                    if (x->loop_z < -p[2])
                        for (int a = 0; a < 3; a++)
                            p[a] *= x->loop_z / -p[2];
                } else { /* against the side or back of the hip */
                    float n = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                    for (int a = 0; a < 3 && n > 0; a++)
                        p[a] *= 1.f + LOOP_BEHIND / n;
                }
            }
            if (l == DRV_DEPTH_HEAD && !t->ex[label[l]].border && !top_cut) { /* in full view */
                const float gh = t->ex[label[l]].geodesic0;
                t->head_len = t->head_len > 0 ? t->head_len + HEAD_LEN_ALPHA * (gh - t->head_len) : gh;
            }
            float cut_width = 0; /* of a head cut by the image's top edge, across the image */
            if (l == DRV_DEPTH_HEAD && t->ex[label[l]].top_cut) {
                int lo, hi;
                top_run(g, t->ex[label[l]].cell, &lo, &hi);
                cut_width = g->P[3 * hi] - g->P[3 * lo];
                if (t->head_len > 0)
                    head_above_cut(t, &t->ex[label[l]], lo, hi, up, p);
            }
            const int crown = l == DRV_DEPTH_HEAD && !t->ex[label[l]].top_cut
                                  ? drv__head_crown(t->ex, nex, label, label[l], up)
                                  : -1;
            if (crown >= 0)
                memcpy(p, t->ex[crown].tip, sizeof p); /* the top, beyond an arm (head_crown.c) */
            if (l == DRV_DEPTH_HEAD && crown < 0 && !t->ex[label[l]].top_cut &&
                drv__head_on_axis(g, &t->ge, &t->o, &t->ex[label[l]], p)) {
                /* the top of the head on its axis, from its silhouette (head_axis.c) */
            } else if (l == DRV_DEPTH_HEAD) { /* no silhouette to go by: half a head behind */
                float n = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                for (int a = 0; a < 3 && n > 0; a++)
                    p[a] *= 1.f + t->o.head_offset / n;
            }
            emit(t, l, p, t_us, r);
            r->conf[l] = conf[l];
            if (!side_sure[l]) { /* found, but which side is a guess: not published */
                r->valid[l] = 0;
                r->side_uncertain[l] = 1;
            }
            const drv__extremum *x = &t->ex[label[l]];
            const int arm_hidden =
                x->hidden_end && (x->below_top < ELBOW_REACH || x->below_top > ARM_REACH);
            const int short_of_elbow =
                !x->loop && whole_body && x->geodesic0 < SHOULDER_GEODESIC + ELBOW_REACH;
            const int slit = x->loop && x->loop_slit; /* a hand from a slit: a guess */
            if (hand && (arm_hidden || short_of_elbow || slit || !drv__label_through_arm(x))) {
                r->valid[l] = 0; /* the hand is not in view: a guess, see the header */
                r->inferred[l] = 1;
            }
            if (l == DRV_DEPTH_HEAD && !head_sure) {
                r->valid[l] = 0; /* anchor far off the mid-plane, or regained: label.c */
                r->inferred[l] = 1;
            }
            if (l == DRV_DEPTH_HEAD && cut_width > HEAD_CUT_WIDTH) {
                r->valid[l] = 0; /* cut below the head: the head is above the image */
                r->inferred[l] = 1;
            }
            if (foot && r->floor_found && floor_height(r->floor, x->tip) > DRV__ANKLE_HEIGHT &&
                reaches_bottom(g, x->cell, go.max_jump)) {
                r->valid[l] = 0; /* cut through the shin: the foot is below the image */
                r->inferred[l] = 1;
            }
        } else {
            emit(t, l, NULL, t_us, r);
        }
    }
    /* a hand reported valid after a guess: its filter starts over from this measurement (see the
       header) */
    for (int l = DRV_DEPTH_LHAND; l <= DRV_DEPTH_RHAND; l++) {
        if (label[l] < 0)
            continue;
        uint8_t *guessed = &t->hand_guessed[l - DRV_DEPTH_LHAND];
        if (r->valid[l] && *guessed && t->o.smooth) {
            for (int a = 0; a < 3; a++) {
                drv_one_euro_reset(&t->f[l][a]);
                t->out[l][a] = (float)drv_one_euro_filter(&t->f[l][a], r->raw[l][a], t_us);
            }
            memcpy(r->xyz[l], t->out[l], sizeof r->xyz[l]);
        }
        *guessed = r->inferred[l];
    }
    emit(t, DRV_DEPTH_TORSO, g->centroid, t_us, r);
    r->conf[DRV_DEPTH_TORSO] = 1;
    return 0;
}
