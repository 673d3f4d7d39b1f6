#!/usr/bin/env bash
# test_depth.sh MESHSTEER SRC DATA - issue 12's acceptance of the depth tracker, on the two captured
# humans (samba, pjump) rendered by the test camera: `meshsteer depth-eval` at the default placement
# (2.5 m, facing the camera) and at one turned placement per sequence (two for pjump: its hands
# at -20 degrees were the grid's worst cell at 2.5 m), samba at 2.0 m facing, where her head
# is at the image's top edge, and samba at -20 degrees with her own turns undone (--hold-facing:
# the torso at -20 degrees in every frame) and kept (2.5 and 3.5 m: a hand on the near hip, found
# across an occluding edge), pjump at -35 degrees (its head lost and found again) and at -20
# degrees, 3.5 m (hands held before the belly), and that her own turn is measured. Asserts head, hand
# and foot within 10 cm, side_correct, and that markers reported with a certain side are (almost)
# never the other side's. Thresholds are what the tracker reaches (docs/PERFORMANCE.md, the grid), not lower.
# Skips (77) without the data.
set -euo pipefail
ms=$1 src=$2 data=$3
. "$(dirname "$0")/lib.sh"

for s in samba pjump; do
    [ -f "$data/meshes/$s/$s.pc2" ] || { echo "no $data/meshes/$s: skipped"; exit 77; }
done

ge() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a ~ /^[0-9.]+$/ && a + 0 >= b) }'; }

# check SEQ YAW FRAMES HEAD HAND FOOT SIDE SIDE_WRONG [DISTANCE]: one placement (2.5 m unless
# DISTANCE) and its minima; with hold=1, the performer's own turns undone (--hold-facing)
hold=
check() {
    local s=$1 yaw=$2 frames=$3 dist=${9:-2.5}
    expect_status 0 "$ms" depth-eval --mesh "$data/meshes/$s/$s.pc2" --rest "$data/meshes/$s/rest.obj" \
        --rig "$src/rigs/$s-depth.json" --yaw "$yaw" --distance "$dist" --frames "$frames" --json \
        ${hold:+--hold-facing}
    local name="$s yaw $yaw at $dist m${hold:+, facing held}" js="$dir/$s-$yaw-$dist${hold:+-held}.json"
    cp "$dir/out" "$js"
    echo "$name: $(cat "$js")"
    grep -o '"within_10cm": {[^}]*}' "$js" >"$dir/within.json" ||
        fail "$name: depth-eval printed no within_10cm"
    local k want v i=4
    for k in head hand foot; do
        want=${!i}; i=$((i + 1))
        [ "$want" = - ] && continue # none in view (feet at 2.0 m)
        v=$(json_num "$dir/within.json" $k)
        ge "$v" "$want" || fail "$name: $k within 10 cm is '$v', below $want"
    done
    v=$(json_num "$js" side_correct)
    ge "$v" "$7" || fail "$name: side_correct is '$v', below $7"
    v=$(json_num "$js" side_wrong)
    le "$v" "$8" || fail "$name: side_wrong is '$v', above $8"
}

# pjump's heads (the neck's top) at 2.5 m and samba's at 2.0 m are mostly at the image's top edge:
# 0.62 / 0.69 / 0.60 (pjump, yaw 0 / 20 / -20) and 0.14 (samba at 2.0 m, 3 of 21) before the cut
# head was costed by its missing length and placed on the cut's middle (label.c, markers.c);
# measured now 0.80 / 0.78 / 0.78 and 0.95. pjump's hands at -20 degrees, held before the belly
# and found from arm loops: 0.83 -> 0.86 once such a hand is placed at its forearm's depth
# rather than behind the hip (markers.c). pjump's at +20 degrees 0.859 -> 0.885 (side 0.931 ->
# 0.943) once a hand short of the elbow costs what it lacks (label.c). pjump's heads 0.797 / 0.781
# / 0.785 -> 0.875 / 0.812 / 0.831 once a head in full view is placed on its axis from its
# silhouette rather than half a head behind its visible top (head_axis.c; 2026-12-03). With 12
# extrema and a head at least HEAD_APART from the centroid (label.c, 2026-12-04): pjump at +20
# degrees 0.812 / 0.885 / side 0.943 -> 0.859 / 0.917 / 0.958, samba's feet at +20 0.84 -> 0.88.
# With the head's anchor let lie up to ARM_SIDE off the mid-plane while the silhouette is clear of
# the image's top edge (label.c, HEAD_ASIDE; 2026-12-07): pjump at +20 degrees head 0.859 -> 0.922.
# A hand reported valid after a guess (inferred) has its filter started over from the new
# measurement (markers.c; 2026-12-07): pjump at +20 degrees hands 0.917 -> 0.938, side 0.958 ->
# 0.965; at -35 degrees 0.707 -> 0.736, side 0.860 -> 0.874; at +35 degrees, 3.2 m 0.799 -> 0.820.
# The head on its axis takes its direction from the centroid, not from its anchor, and each
# row's rims are pushed back by their depth inside the silhouette (head_axis.c; 2026-12-07):
# the median head error over samba's grid 5.5-8.2 -> 2.4-4.3 cm, pjump's 4.2-7.1 -> 3.6-6.9 cm,
# heads within 10 cm up in 20 of the 40 cells - but pjump at +20 degrees 0.922 -> 0.875 (three
# of 64 frames, 124-127: the performer lands bent forward, the neck's flat cut facing the
# camera, its centre 6 cm below and 7 cm nearer than a head's top would be; the filter's lag on
# the landing adds 1-3 cm). That bound is lowered to what is reached; the median head errors
# below (0.075 and 0.042 m before) hold the gain.
# The head's filter follows motion faster than the hands' and feet's (oe_head_beta 32 s/m,
# oe_head_dcutoff 2 Hz; markers.c; 2026-12-07): the landing's lag is gone, pjump's heads facing
# 0.844 -> 0.906 (the issue's 0.9), at +20 degrees 0.875 -> 0.938, at -20 0.862 -> 0.908, and its
# head's median error at +20 degrees 0.037 -> 0.030 m.
# An arm loop's hand held before the belly (the forearm coming towards the camera) is the far end
# of the forearm's own surface from the elbow, not a hand's length on from the hole's lowest cell
# (segment.c, hand_in_front; 2026-12-07): pjump at -20 degrees hands 0.874 -> 0.887, side 0.935
# -> 0.941.
# A head lost while the silhouette reaches the image's top edge is looked for within its aged
# reach, and reported inferred when found so (label.c; 2026-12-08): pjump facing, heads 0.906 ->
# 0.938.
#      seq   yaw frames  head hand foot side  side_wrong [distance]
check samba 0   :       0.95 0.9  0.9  0.9   0.02
check pjump 0   :       0.93 0.9  0.95 0.94  0.02
check samba 20  :       0.95 0.95 0.85 0.9   0.02
check pjump 20  :       0.93 0.93 0.95 0.96  0.02
check pjump -20 :       0.90 0.88 0.95 0.94  0.02
check samba 0   :       0.9  0.9  -    0.9   0.02  2.0
# the head's median error (metres) at two of those placements
head_median() { # head_median JSON MAX NAME
    grep -o '"error_m": {"head": {[^}]*}' "$1" >"$dir/hm.json" || fail "$3: no error_m for the head"
    local v
    v=$(json_num "$dir/hm.json" median)
    le "$v" "$2" || fail "$3: the head's median error is '$v' m, above $2"
}
head_median "$dir/samba-0-2.5.json" 0.039 "samba facing at 2.5 m"
head_median "$dir/pjump-20-2.5.json" 0.030 "pjump at +20 degrees"
# pjump turned -35 degrees at 2.5 m: its head, lost from view (under the image's top edge or
# turned away) and back elsewhere, was held off by its stale position for up to 15 frames. A
# head lost n frames ago is now looked for within sqrt(n + 1) frames' steps of where it was
# (label.c, the temporal term), while the person's silhouette is clear of the image's top edge:
# heads 0.507 -> 0.746, valid heads with no head within 10 cm 0.282 -> 0.266 (2026-12-06).
# A head whose cut by the image's top edge is wider than a head is long (HEAD_CUT_WIDTH: the cut
# runs through the shoulders, the chest or the raised arms) is reported inferred (markers.c):
# 0.266 -> 0.167 here, and 0.705 -> 0.438 at 2.0 m facing, where the top edge cuts pjump's
# chest while the performer jumps with the arms up (2026-12-06). A head whose anchor lies more
# than HEAD_ASIDE (0.08 m) off the mid-plane is reported inferred (label.c, markers.c): 0.167 ->
# 0.109 here, 0.438 -> 0.333 at 2.0 m facing; heads here 0.746 -> 0.761 (2026-12-07). With the
# head's faster filter (markers.c): heads here 0.791 -> 0.806, valid wrong ones 0.074 -> 0.018;
# at 2.0 m facing 0.333 -> 0.250 (2026-12-07). A head lost while the silhouette reaches the top
# edge is looked for within its aged reach too, and reported inferred when found so (label.c):
# heads here 0.806 -> 0.866; at 2.0 m facing valid wrong heads 0.250 -> 0.143 (2026-12-08).
check pjump -35 :       0.86 0.73 0.95 0.87  0.02
grep -o '"confident_wrong": {[^}]*}' "$dir/pjump--35-2.5.json" >"$dir/cw35.json" ||
    fail "pjump at -35: no confident_wrong"
v=$(json_num "$dir/cw35.json" head)
le "$v" 0.02 || fail "pjump at -35: valid head reports with no head within 10 cm: '$v', above 0.02"
check pjump 0   :       0.70 0.89 0.95 0.90  0.02  2.0
grep -o '"confident_wrong": {[^}]*}' "$dir/pjump-0-2.0.json" >"$dir/cwp2.json" ||
    fail "pjump at 2.0 m: no confident_wrong"
v=$(json_num "$dir/cwp2.json" head)
le "$v" 0.15 || fail "pjump at 2.0 m: valid head reports with no head within 10 cm: '$v', above 0.15"
# pjump turned +35 degrees at 3.2 m, in full view: its neck, leaning towards the camera and
# turned, lies more than 8 cm to the side of the centroid in much of the take (at +20 degrees,
# frames 117-126, 11-16 cm); at HEAD_ASIDE for every head it was left unlabelled, at ARM_SIDE with
# the silhouette clear of the top edge it is found: heads 0.793 -> 0.891 (label.c, 2026-12-07).
check pjump 35  :       0.92 0.82 0.99 0.90  0.02  3.2
# pjump turned -20 degrees at 3.5 m, hands before the belly in frames 164-196: the walk from the
# hole's lowest cell went on into the belly, the hand reported valid 10-12 cm off; found on the
# forearm's surface (segment.c, hand_in_front) hands 0.778 -> 0.820, valid hand reports with no
# hand within 10 cm 0.168 -> 0.123 (2026-12-07).
check pjump -20 :       0.95 0.82 0.99 0.90  0.02  3.5
grep -o '"confident_wrong": {[^}]*}' "$dir/pjump--20-3.5.json" >"$dir/cwp35.json" ||
    fail "pjump at -20, 3.5 m: no confident_wrong"
v=$(json_num "$dir/cwp35.json" hand)
le "$v" 0.13 ||
    fail "pjump at -20, 3.5 m: valid hand reports with no hand within 10 cm: '$v', above 0.13"
# At 2.0 m the image's bottom edge cuts samba's legs 4-27 cm above the floor: no foot is in view,
# but the cut legs were reported as valid feet, 0.68 of them with no foot within 10 cm. A leg cut
# above the ankle is now reported inferred (markers.c, ANKLE_HEIGHT): measured 0.29.
grep -o '"confident_wrong": {[^}]*}' "$dir/samba-0-2.0.json" >"$dir/cw2.json" ||
    fail "samba at 2.0 m: no confident_wrong"
v=$(json_num "$dir/cw2.json" foot)
le "$v" 0.35 || fail "samba at 2.0 m: valid foot reports with no foot within 10 cm: '$v', above 0.35"
# Her head there is at the image's top edge; shoulders and the top of the chest were labelled the
# head in the frames where it is above the image (0.155 of the valid heads with no head within
# 10 cm). A head lies at least HEAD_APART (0.7 m of geodesic) from the centroid (label.c): 0.
v=$(json_num "$dir/cw2.json" head)
le "$v" 0.03 || fail "samba at 2.0 m: valid head reports with no head within 10 cm: '$v', above 0.03"

# samba turned -35 degrees: her right hand is behind her back in 59 frames. Where the visible arm
# ends at a nearer surface at or above the elbow, the hand is reported inferred, not valid
# (markers.c): before, every such hand was reported valid and hand reports that were valid but
# wrong (no hand within 10 cm) were 0.35 of the valid ones; then 0.23, and 0.66 of the hidden
# hands are reported inferred. A hand nearer the centroid than a shoulder and an upper arm
# (0.75 m) is reported inferred too (markers.c): 0.23 -> 0.15. Feet 0.78 -> 0.85 (side 0.655 ->
# 0.686) with 12 extrema (2026-12-04). A foot on the floor whose tip ends behind a nearer surface
# is moved along the floor under it (markers.c, foot_behind; 2026-12-08): feet 0.850 -> 0.863.
check samba -35 :       0.95 0.55 0.85 0.65  0.05
js=$dir/samba--35-2.5
grep -o '"confident_wrong": {[^}]*}' "$js.json" >"$js.cw" || fail "samba -35: no confident_wrong"
grep -o '"hidden_hands": {[^}]*}' "$js.json" >"$js.hh" || fail "samba -35: no hidden_hands"
v=$(json_num "$js.cw" hand)
le "$v" 0.18 || fail "samba -35: valid hand reports with no hand within 10 cm: '$v', above 0.18"
v=$(json_num "$js.hh" inferred)
ge "$v" 0.6 || fail "samba -35: hidden hands reported inferred: '$v', below 0.6"

# samba turned -20 degrees with her own turns kept: from frame ~130 she is at -58 degrees, her left
# hand on her hip and its forearm in front of her side, the arm and the torso closing a loop across
# an occluding edge instead of around background (segment.c, slits). Hands 0.731 -> 0.843 with the
# slits (reported inferred, so side_correct and confident_wrong do not change: 0.759, 0.093).
# Her feet, crossed in frames 79-84: the left toe's accumulative geodesic was taken from the
# other foot (0.37 m) and it could not be a foot; a foot standing on the floor is costed by its
# geodesic from the centroid (label.c; 2026-12-07): feet 0.798 -> 0.825, side 0.759 -> 0.770.
# Turned further, her right foot stands behind her left shin (frames 130-174): its visible end is
# the heel's side, 11-25 cm from the toe. A foot on the floor whose tip ends at such an occluding
# edge is moved along the floor to under the nearer surface (markers.c, foot_behind; 2026-12-08):
# feet 0.825 -> 0.933, side 0.770 -> 0.819, valid foot reports with no foot within 10 cm 0.142 ->
# 0.049.
check samba -20 :       0.95 0.84 0.92 0.81  0.02
grep -o '"confident_wrong": {[^}]*}' "$dir/samba--20-2.5.json" >"$dir/cw20.json" ||
    fail "samba -20: no confident_wrong"
v=$(json_num "$dir/cw20.json" hand)
le "$v" 0.1 || fail "samba -20: valid hand reports with no hand within 10 cm: '$v', above 0.1"
v=$(json_num "$dir/cw20.json" foot)
le "$v" 0.06 || fail "samba -20: valid foot reports with no foot within 10 cm: '$v', above 0.06"
# At 3.5 m the geodesic graph's max_jump is 0.105 m (three of the sensor's depth steps there) and
# the forearm's edge against her hip steps less: her slits broke into pieces shorter than
# LOOP_SLIT. The slit pass reads the options' max_jump (0.08 m) instead (segment.c): hands 0.729
# -> 0.809 (3.2 m 0.794 -> 0.817); valid wrong hands unchanged (0.108). Feet on the floor costed
# by their geodesic from the centroid (label.c): 0.774 -> 0.786, side 0.726 -> 0.734. A foot moved
# under the surface that hides its tip (markers.c, foot_behind): 0.786 -> 0.803, the issue's 0.8.
check samba -20 :       0.99 0.80 0.80 0.73  0.02  3.5
grep -o '"confident_wrong": {[^}]*}' "$dir/samba--20-3.5.json" >"$dir/cw20f.json" ||
    fail "samba -20 at 3.5 m: no confident_wrong"
v=$(json_num "$dir/cw20f.json" hand)
le "$v" 0.11 || fail "samba -20 at 3.5 m: valid hand reports with no hand within 10 cm: '$v', above 0.11"

# The yaw turns the first frame; samba turns by up to 38 degrees on her own towards her last
# frames (the torso's turn, averaged over 1 s), so the -20 degree row above sees her at down to
# -58 in its last third (hands 0.731 there before the slits, 0.843 after). With her own turns
# undone (--hold-facing) the torso is at -20 degrees in every frame: measured 0.977 / 0.989 /
# 0.896, side 0.944 (2026-12-03).
hold=1
check samba -20 :       0.95 0.95 0.86 0.91  0.02
v=$(tr -d ' \n' <"$dir/samba--20-2.5-held.json" | grep -o '"own_turn_deg":\[[-0-9.]*' | grep -o '[-0-9.]*$')
[[ $v =~ ^-?[0-9.]+$ ]] && le "$v" -30 || fail "samba's own turn: the torso's least turn is '$v' degrees, not below -30"
echo "depth: ok"
