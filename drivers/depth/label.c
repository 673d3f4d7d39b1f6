/* label.c - which geodesic extremum is the head, which a hand or foot, and which side.
 *
 * Each extremum e (tip position t, anchor a on its limb (geodesic.c), geodesic length
 * g) is described in the body frame at the centroid c: height h = (t - c).up, lateral offset
 * l_a = (a - c).right. `right` is the person's left, across the torso's surface (body_frame.c;
 * the camera's +X for a person facing the camera). The head is tested across the image instead:
 * l' = (t - c).x and l'_a = (a - c).x with x the camera's +X orthogonal to up (a head is above
 * the torso in the image however the person is turned; along a turned body's left its offset
 * mixes in the lean towards the camera). Costs (metres scaled to "units"; lower is better):
 *   head : |l'_a|/A + |l'|/0.15 + max(0, 0.3 - h)/0.1 + max(0, g - 1.0)/0.1
 *          + max(0, HEAD_APART - g)/0.05   (h > 0.1, not on the border)
 *          (A = HEAD_ASIDE, 0.08 m, while the person's silhouette reaches the image's top edge:
 *          the head may be above the image, and a shoulder or a raised arm's cut under it lies
 *          to the side; otherwise the head is in view and its anchor needs only to be told from
 *          an arm's, which passes its shoulder ARM_SIDE, 0.15 m, off the mid-plane: A = ARM_SIDE.
 *          A head whose anchor lies more than HEAD_ASIDE off is reported inferred, not valid
 *          (markers.c): where it is, is a guess. A leaning or side-bent person's neck lies off
 *          the centroid: pjump leaning towards the camera at +20 degrees, 3.2 m, 11-16 cm, and
 *          was left unlabelled. Over both grids: pjump's heads within 10 cm at 3.2 / 3.5 m,
 *          +35 degrees, 0.793 / 0.690 -> 0.891 / 0.819, 2.5 m +20 0.859 -> 0.922; valid heads
 *          with no head within 10 cm at 2.5 m, 0.115-0.176 -> 0.095-0.147, at 2.0 m 0.375-0.625
 *          -> 0.167-0.591, but up by 0.003-0.013 in six cells at 3.2-3.5 m; samba's heads +0.006
 *          to +0.012 in three cells, its valid wrong heads within 0.006; docs/PERFORMANCE.md)
 *          (HEAD_APART: the top of the head lies a shoulder's rise and a neck and head from the
 *          centroid and from every earlier extremum; an extremum nearer is a shoulder or a bump
 *          of the chest under a head out of view. Only for a person seen down to the floor: an
 *          upper body's centroid lies on the chest, nearer the head (test_markers' real Kinect
 *          frames at 1.2 m lost their heads). A tenth of a metre short costs 2 of MISS: at
 *          /0.1 the SMPL walk's shoulder, g = 0.59 m with its head cut by the image's side edge,
 *          paid 1.1 and was taken for the head, and the wrong label then held the head's own
 *          extremum off for seven frames (before the whole-body condition; with it, /0.1 keeps
 *          the walk but loses pjump's heads at +-35 degrees, 0.603 -> 0.589, held 0.690 ->
 *          0.650, docs/PERFORMANCE.md). Before this term, over samba's and pjump's grids
 *          (yaw -35..35, 2.0-3.5 m) and the four SMPL takes, 6 of the 285 heads labelled with
 *          g < 0.7 m were within 10 cm of the head; 249 were labelled with the head out of view)
 *   hand : max(0, -s l_a)/0.04 + max(0, -0.6 - h)/0.1 + max(0, R - g)/0.1 + max(0, 0.15 - m)/0.1
 *          (R = HAND_REACH: a shoulder and a forearm)
 *          (s = +1 left, -1 right; m = the highest point of its shortest path from the centroid
 *          above the centroid: an arm's path climbs to the shoulder - a leg's or a dress hem's not;
 *          the m term only for h < -0.3: a hand beside the chest needs no climb)
 *          + max(0, ARM_SIDE - w)/0.04 (w = how far its path from the centroid goes to either
 *          side of the mid-plane, path_lmax: an arm's passes its shoulder; without it the neck,
 *          with the head out of view or raised arms cut by the image's top edge, looked like a
 *          fine hand: near the mid-line, far from the centroid)
 *          + max(0, E - g0)/0.1 (g0: the geodesic from the centroid; E = 0.75 m, a shoulder and
 *          an upper arm, when the person is seen down to the floor, else 0: the bound under which
 *          markers.c reports a hand inferred. Without it a label that had slid onto a point of
 *          the hip kept it by the temporal term, reported inferred, while the hand's own extremum
 *          stayed unlabelled: pjump held at the default placement, frames 41-54, hands 0.856 ->
 *          0.924; the SMPL takes' hands 0.30-0.62 -> 0.39-0.89, docs/PERFORMANCE.md)
 *   foot : max(0, -s l_a)/0.04 + max(0, h + 0.75)/0.1 + max(0, 0.7 - g)/0.1 + max(0, m - 0.15)/0.1
 *          (h < -0.55, not on the border)
 *          (for an extremum standing on the floor - less than DRV__ANKLE_HEIGHT above it - g is
 *          its geodesic from the centroid alone, g0: the accumulative g is taken from the
 *          nearest extremum found before it, and for two feet together that is the other foot.
 *          samba turned to -20 degrees at 2.5 m, frames 79-84, the feet crossed: the left toe's
 *          extremum lay at its ground truth with g = 0.37 m and cost 3.3, and a bump on a shin
 *          (g = 0.91 m) took the label, 15-24 cm off. Above the floor g stays: a
 *          leg cut by the image's bottom edge has bumps along it, far from the centroid but
 *          near the cut found on it, and with g0 for every extremum they took the foot (pjump
 *          at 2.0 m, +20 degrees: bumps with g = 0.31-0.40 m; valid foot reports with no foot
 *          within 10 cm 0.156 -> 0.210, samba's feet at -35 degrees, 2.0 m, 0.412 -> 0.235).
 *          On the floor only, over both grids (own turns kept and held) feet within 10 cm rose
 *          in 38 of the 80 cells and fell in none: samba at -20 degrees 0.798 / 0.780 / 0.774
 *          -> 0.825 / 0.800 / 0.786 at 2.5 / 3.2 / 3.5 m; the SMPL hop 0.796 -> 0.802, lambada
 *          0.959 -> 0.962. Valid foot reports with no foot within 10 cm fell in 27 cells and
 *          rose in 16, by up to 0.03, 11 of them at +-35 degrees, where a heel is now labelled
 *          when its toe is no extremum (samba at +35 degrees, 3.5 m, frame 0: the right heel,
 *          19 cm from the toe, where no foot was reported before; 0.110 -> 0.139 there, -35
 *          degrees 0.128 -> 0.149; docs/PERFORMANCE.md)
 *   An extremum touching the image border is a cut through the body, not an extremity: it can
 *   not be a foot, and costs 2 more as a hand (a hand partly out of view). It can be the head
 *   only in the top row, when its geodesic from the centroid is at most HEAD_CUT_SLACK shorter
 *   than the person's head length measured on earlier frames with the head in view (markers.c;
 *   until it has been measured HEAD_APART for a person seen down to the floor, so that one whose
 *   head has not yet been seen whole - at 2.0 m, pjump's is above the image in 211 of 222
 *   frames - can still have one):
 *   the top of the head (pjump: of the neck) is then just above the image; a neck cut lower
 *   down, with the head well out of view, is not reported. Such a cut costs, as the head, the
 *   length missing above the image, max(0, head_len - g0)/0.1, in place of the 2 (which lost
 *   most heads at the top edge: pjump at 2.5 m, samba at 2.0 m); markers.c places the head on
 *   the cut's middle, that length higher. Any head
 *   candidate costs max(0, head_len - HEAD_CUT_SLACK - g0)/0.1 more (g0: its geodesic from the
 *   centroid): an extremum much shorter than the head is a shoulder under a head out of view;
 *   A hand from an arm loop (segment.c) costs 0 for its side's hand and a free hand on that
 *   side LOOP_PENALTY more, unless an extremum past the elbow (ARM_WHOLE from the centroid, its
 *   path climbing to the shoulder as an arm's does) lies within LOOP_FREE_HAND (a forearm and a
 *   hand) of it: the arm then only looks closed
 *   in the image - its hand in front of the chest, reached across a depth step - and the loop is
 *   dropped (pjump turned by -20 degrees, arms bent before the chest);
 *   + temporal term min(|t - p_prev|/r, 3) - 1 when the label had a position last frame (found
 *   or held: markers.c keeps a lost label's last output for hold_frames, 15), r = STEP_REACH,
 *   0.1 m, how far a marker moves in one frame. For the head lost n frames ago, r =
 *   STEP_REACH sqrt(n + 1), the spread of a random walk after n + 1 steps, and the term is
 *   not below 0 (an old position is no evidence for a candidate beside it), unless the person's
 *   silhouette reaches the image's top edge: there the head may be just above the image, and
 *   the old position is what keeps a raised arm's or a shoulder's cut from being taken for it.
 *   There the reach ages too, but a head found with it is reported inferred (head_sure 0), a
 *   guess for that frame: with r = 0.1 m there, pjump's neck coming back into view at 2.0 m as
 *   the performer lands (frames 21-23, 125-127, lost 3-8 frames) paid 0.8-1.3 for its last
 *   place and was left unlabelled. Over both grids, own turns kept and held, heads within 10 cm
 *   rose in 7 cells each and fell in none (pjump at 2.0 m, -20 / +20 degrees, 0.636 / 0.636 ->
 *   0.727 / 0.727, held 0.455 / 0.727 -> 0.636 / 0.909; facing 2.5 m 0.906 -> 0.938); valid
 *   heads with no head within 10 cm fell in 9 and 10 cells and rose in 8 and 6, by more than
 *   0.001 in 4 and 3 (-20 degrees, 2.0 / 2.5 m 0.300 / 0.060 -> 0.333 / 0.086; +35 degrees,
 *   2.0 m 0.450 -> 0.474; held facing at 2.0 m 0.250 -> 0.273, +35 degrees at 2.5 m 0.085 ->
 *   0.115); the SMPL takes unchanged but one head (lambada at -20 degrees, valid wrong 0.0119
 *   -> 0.0122). Reported valid, the heads so found raised the valid wrong ones in 11 cells of
 *   the kept grid (-20 degrees, 2.5 m 0.060 -> 0.120; +35 degrees, 2.0 m 0.450 -> 0.607;
 *   docs/PERFORMANCE.md, 2026-12-08).
 *   With r = 0.1 m for every age a head lost from view was held off its new place for up to
 *   15 frames (pjump turned by 20-35 degrees, its head turned out of view and back; at 2.0 m,
 *   the neck's top coming back into view as the performer crouches): pjump's heads within
 *   10 cm over -20..+20 degrees 0.824 -> 0.846, at +-35 0.603 -> 0.714, valid heads with no head
 *   within 10 cm 0.253 -> 0.249 and 0.232 -> 0.228; samba unchanged in every cell; the SMPL
 *   lambada at -20 degrees 0.928 -> 0.930 (docs/PERFORMANCE.md, 2026-12-06). Linear growth
 *   (a top speed) found a little more on pjump, but labelled a point 35-43 cm from lambada's
 *   head at -20 degrees, which then held the head off (0.928 -> 0.912); aged for every label,
 *   samba's feet at +-35 degrees fell 0.783 -> 0.774;
 * and leaving a label empty costs MISS. The assignment (each extremum used at most once) with the
 * least total cost is found exhaustively (at most 15^5 branches - 12 extrema, 2 arm-loop hands
 * or none per label - pruned by the best total so far; bench_depth: 0.27 ms a frame in all).
 * The confidence of a label is 1 - cost/MISS, clamped to [0, 1]. Sides: the hands' (feet's)
 * labels swapped - each pair's two costs exchanged, temporal terms included - must cost at least
 * SIDE_MARGIN more than the assignment found, otherwise the pair's side is uncertain (as a
 * Kinect skeleton marks a joint "inferred" rather than tracked). */
#include "depth_internal.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define MISS 2.5f
/* the temporal term's scale: how far a marker moves in a frame (0.1 m at 30 fps, 3 m/s) */
#define STEP_REACH 0.1f
#define FOOT_CUT 0.3f /* a foot whose tip reaches the bottom of the image */
#define ARM_LOW -0.3f   /* a hand this far below the centroid (hanging, next to a dress hem) ... */
#define ARM_CLIMB 0.15f /* ... has a path from the centroid that climbs at least this (shoulder) */
#define LEG_CLIMB 0.15f /* ... a foot's at most this */
#define HAND_REACH 0.65f /* a hand lies at least the centroid-to-shoulder geodesic (~0.45 m) and a
                           forearm (~0.25 m) from the centroid: a shoulder below a raised arm cut
                           by the image edge is no hand */
#define ARM_SIDE 0.15f /* metres: an arm's path from the centroid passes through its shoulder,
                         at least this far to the side of the body's mid-plane (half the
                         shoulders' breadth, 0.259 x height (Drillis & Contini), is 0.19 m at
                         1.5 m tall; a path over the shoulder may cut a little inside it); a
                         neck's path stays within a few cm of the mid-plane */
#define HEAD_CUT_SLACK 0.08f /* metres: how much shorter than the measured head length a cut
                                 may be and still be the head (the spread of the head's
                                 geodesic over frames in full view: pjump 0.82 - 0.95 m) */
#define HEAD_APART 0.7f /* metres of accumulative geodesic: the least a head's top lies from the
                           centroid and the extrema found before it. The top of the head is
                           about 0.45 of the body's height above the centre of mass (0.55 of the
                           height up), 0.72 m at 1.6 m; a shoulder's tip (0.82 of the height up,
                           0.13 to the side, Drillis & Contini) about 0.3 of it, 0.48 m */
#define HEAD_ASIDE 0.08f /* metres: the head's anchor (on the neck) this far off the mid-plane
                           costs 1 while the person's silhouette reaches the image's top edge
                           (the head may be above the image, a shoulder under it); one
                           farther is reported inferred (see the header) */
#define NL 5
#define MAXE (DRV_DEPTH_MAX_EXTREMA + 2)
#define LOOP_PENALTY 2.f /* a free hand on a side whose arm closes a loop */
#define LOOP_FREE_HAND 0.35f /* metres: a forearm (~0.25 m) and a hand (~0.1 m) */
#define ARM_WHOLE 0.9f /* metres from the centroid: the shoulder (~0.45 m), the upper arm (~0.3 m)
                          and more than half a forearm - past the elbow, which a loop's arm
                          also has as an extremum */
#define SIDE_MARGIN 1.f  /* a side is certain when swapping the pair costs at least this more */

static float dot3(const float *a, const float *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static float pos(float x)
{
    return x > 0 ? x : 0;
}

typedef struct search {
    float cost[NL][MAXE];
    int nex;
    int cur[NL], best[NL];
    float best_total;
    unsigned used;
} search;

/* What label l costs with extremum e (-1: left empty). */
static float label_cost(const search *s, int l, int e)
{
    return e < 0 ? MISS : fminf(s->cost[l][e], 1e6f);
}

static void dfs(search *s, int l, float total)
{
    if (total >= s->best_total)
        return;
    if (l == NL) {
        s->best_total = total;
        memcpy(s->best, s->cur, sizeof s->best);
        return;
    }
    for (int e = 0; e < s->nex; e++) {
        if ((s->used >> e) & 1u || s->cost[l][e] >= MISS)
            continue;
        s->used |= 1u << e;
        s->cur[l] = e;
        dfs(s, l + 1, total + s->cost[l][e]);
        s->used &= ~(1u << e);
    }
    s->cur[l] = -1;
    dfs(s, l + 1, total + MISS);
}

int drv__label_through_arm(const drv__extremum *x)
{
    return x->loop || x->path_hmax >= ARM_CLIMB || x->path_lmax >= ARM_SIDE;
}

void drv__label_assign(const drv__extremum *ex, int nex, const float centroid[3], const float up[3],
                       const float right[3], const drv__label_prev *prev, int label[5],
                       float conf[5], uint8_t side_sure[5], uint8_t *head_sure)
{
    search s;
    s.nex = nex < MAXE ? nex : MAXE;
    /* the head is tested across the image (the camera's +X orthogonal to up), not across the
       body: a head is above the torso in the image however the person is turned, while its
       offset along a turned body's left mixes in how far the person leans towards the camera */
    float across[3] = {1.f - up[0] * up[0], -up[0] * up[1], -up[0] * up[2]};
    const float an = sqrtf(dot3(across, across));
    for (int a = 0; a < 3; a++)
        across[a] /= an;
    /* a head's least geodesic, when the centroid is the whole body's (an upper body's lies on
       the chest, nearer the head) */
    const float apart = prev && prev->whole_body ? HEAD_APART : 0.f;
    /* an arm loop whose hand estimate has a free extremum of a whole arm's reach within a
       forearm and hand of it is an arm seen closed only in the image (the hand in front of the
       chest across a depth step, which the geodesic graph crosses): that extremum is the hand */
    uint8_t loop_off[MAXE] = {0};
    /* the head's anchor off the mid-plane: scale, and per extremum (HEAD_ASIDE) */
    const float aside = prev && !prev->top_touch ? ARM_SIDE : HEAD_ASIDE;
    float head_aside[MAXE] = {0};
    /* a head lost while the person reaches the image's top edge, looked for within the aged
       reach: a guess this frame (see the header) */
    uint8_t head_regained[MAXE] = {0};
    int loop_side[2] = {0, 0};
    for (int e = 0; e < s.nex; e++) {
        if (!ex[e].loop)
            continue;
        for (int f = 0; f < s.nex && !loop_off[e]; f++) {
            const drv__extremum *y = &ex[f];
            if (y->loop || y->border || y->geodesic0 < ARM_WHOLE || y->path_hmax < ARM_CLIMB)
                continue;
            float d[3] = {y->tip[0] - ex[e].tip[0], y->tip[1] - ex[e].tip[1],
                          y->tip[2] - ex[e].tip[2]};
            loop_off[e] = dot3(d, d) < LOOP_FREE_HAND * LOOP_FREE_HAND;
        }
        if (!loop_off[e])
            loop_side[ex[e].loop > 0 ? 0 : 1] = 1;
    }
    for (int e = 0; e < s.nex; e++) {
        const drv__extremum *x = &ex[e];
        float r[3] = {x->tip[0] - centroid[0], x->tip[1] - centroid[1], x->tip[2] - centroid[2]};
        float ra[3] = {x->anchor[0] - centroid[0], x->anchor[1] - centroid[1],
                       x->anchor[2] - centroid[2]};
        float h = dot3(r, up), la = dot3(ra, right), g = x->geodesic;
        /* the head: centred across the image or across the body, whichever is nearer */
        float hl = fminf(fabsf(dot3(r, across)), fabsf(dot3(r, right)));
        float hla = fminf(fabsf(dot3(ra, across)), fabsf(la));
        float b = x->border ? 2.f : 0.f;
        /* a head cut by the image's top edge: only when the cut lies within HEAD_CUT_SLACK of
           the person's measured head length (the head's top just above the image) */
        const float head_len = prev && prev->head_len > 0 ? prev->head_len : apart;
        const int head_cut =
            x->top_cut && head_len > 0 && x->geodesic0 >= head_len - HEAD_CUT_SLACK;
        const float short_head =
            head_len > 0 ? pos(head_len - HEAD_CUT_SLACK - x->geodesic0) / 0.1f : 0.f;
        /* standing on the floor: a foot's reach is taken from the centroid alone (see the
           header) */
        const int on_floor =
            prev && prev->centroid_floor > 0 && h + prev->centroid_floor < DRV__ANKLE_HEIGHT;
        head_aside[e] = hla;
        s.cost[0][e] = h > 0.1f && (!x->border || head_cut)
                           ? hla / aside + hl / 0.15f + pos(0.3f - h) / 0.1f +
                                 pos(g - 1.0f) / 0.1f + pos(apart - g) / 0.05f + short_head +
                                 (head_cut ? pos(head_len - x->geodesic0) / 0.1f : b)
                           : FLT_MAX;
        if (x->loop) { /* a hand on the hip, from an arm loop: that side's hand only */
            for (int k = 0; k < NL; k++)
                s.cost[k][e] = k == (x->loop > 0 ? 1 : 2) && !loop_off[e] ? 0.f : FLT_MAX;
            continue;
        }
        for (int side = 0; side < 2; side++) {
            float sg = side == 0 ? 1.f : -1.f;
            s.cost[1 + side][e] = pos(-sg * la) / 0.04f + pos(-0.6f - h) / 0.1f +
                                  pos(HAND_REACH - g) / 0.1f +
                                  (h < ARM_LOW ? pos(ARM_CLIMB - x->path_hmax) / 0.1f : 0.f) +
                                  pos(ARM_SIDE - x->path_lmax) / 0.04f + b +
                                  (prev ? pos(prev->elbow_reach0 - x->geodesic0) / 0.1f : 0.f);
            s.cost[3 + side][e] = h < -0.55f && x->border != 1
                                      ? pos(-sg * la) / 0.04f + pos(h + 0.75f) / 0.1f +
                                            pos(0.7f - (on_floor ? x->geodesic0 : g)) / 0.1f +
                                            pos(x->path_hmax - LEG_CLIMB) / 0.1f +
                                            (x->border ? FOOT_CUT : 0.f)
                                      : FLT_MAX;
        }
    }
    for (int e = 0; e < s.nex; e++) {
        const drv__extremum *x = &ex[e];
        for (int side = 0; side < 2 && !x->loop; side++)
            if (loop_side[side])
                s.cost[1 + side][e] += LOOP_PENALTY;
        if (prev) {
            for (int k = 0; k < NL; k++) {
                if (!prev->valid[k] || s.cost[k][e] == FLT_MAX)
                    continue;
                float d[3] = {x->tip[0] - prev->p[k][0], x->tip[1] - prev->p[k][1],
                              x->tip[2] - prev->p[k][2]};
                float dist = sqrtf(dot3(d, d)), reach = STEP_REACH;
                /* a head lost n frames ago: its position spread over sqrt(n + 1) steps, and no
                   credit for a candidate beside it unless the person reaches the image's top
                   edge, where a head found so is a guess (see the header) */
                const int lost = k == 0 && prev->missed[k] > 0;
                const int no_credit = lost && !prev->top_touch;
                if (lost)
                    reach *= sqrtf(1.f + prev->missed[k]);
                head_regained[e] |= lost && prev->top_touch;
                float term = fminf(dist / reach, 3.f) - 1.f;
                s.cost[k][e] += no_credit && term < 0 ? 0.f : term;
                if (s.cost[k][e] < 0)
                    s.cost[k][e] = 0;
            }
        }
    }
    s.used = 0;
    s.best_total = FLT_MAX;
    for (int k = 0; k < NL; k++)
        s.cur[k] = s.best[k] = -1;
    dfs(&s, 0, 0.f);
    for (int k = 0; k < NL; k++) {
        label[k] = s.best[k];
        conf[k] = 0;
        if (label[k] >= 0) {
            float c = 1.f - s.cost[k][label[k]] / MISS;
            conf[k] = c < 0 ? 0 : c > 1 ? 1 : c;
        }
    }
    /* the sides: how much more the best assignment with the pair's labels swapped costs */
    for (int k = 0; k < NL; k++)
        side_sure[k] = 1;
    *head_sure = s.best[0] < 0 ||
                 (head_aside[s.best[0]] <= HEAD_ASIDE && !head_regained[s.best[0]]);
    for (int pair = 1; pair <= 3; pair += 2) {
        const int a = s.best[pair], b = s.best[pair + 1];
        if (a < 0 && b < 0)
            continue;
        float now = label_cost(&s, pair, a) + label_cost(&s, pair + 1, b);
        float swapped = label_cost(&s, pair, b) + label_cost(&s, pair + 1, a);
        if (swapped - now < SIDE_MARGIN)
            side_sure[pair] = side_sure[pair + 1] = 0;
    }
}
