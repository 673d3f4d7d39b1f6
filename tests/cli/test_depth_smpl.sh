#!/usr/bin/env bash
# test_depth_smpl.sh MESHSTEER SRC DATA - issue 12, "more performers without more captures": the
# static SMPL man (shared/data/meshes/static-human) animated by CMU and HDM05 mocap through a
# harmonic model (de Aguiar 2007, `train --kind harmonic --fit-rest`, driven by the files' joint
# rotations), rendered by the test camera and tracked by `meshsteer depth-eval` at the default
# placement (2.5 m, facing the camera). The sequences are made here, in the scratch directory, from
# the mocap: nothing generated is kept in the repository. Four takes, each at 30 fps (every 4th
# frame of the 120 Hz files):
#   hop  CMU 131_03.bvh "Start Hop Stop": hops on one leg and turns a full circle (276 frames)
#   walk CMU 131_01.bvh "Start Walk Stop" from its frame 480: walks, turns, waves (129 frames;
#        its first 480 frames are deep lunges in which the harmonic model sinks the front foot up
#        to 0.29 m below the floor - docs/MODEL.md - which would lower the scene's floor and lift
#        the head out of the camera's view)
#   run  HDM05 HDM_dg_06-03_03_120.amc (ASF/AMC): a jog diagonally across the room (51 frames)
#   lambada  CMU lambada.amc (ASF/AMC, gsimchoni's copy): a dance, swaying +-25 deg, a hand often
#        raised above the head and out of the image (545 frames)
# Asserts head, hand and foot within 10 cm, side_correct and side_wrong at what the tracker
# reaches today (docs/PERFORMANCE.md, "Depth -> markers on the SMPL man"), not lower; and that the
# rig's head, hands and feet are the vertices its rule names (rigs/static-human-depth.json).
# Skips (77) without the data. ~45 s of CPU (four takes, 1001 frames rendered and tracked, and
# lambada once more turned by -20 degrees).
set -euo pipefail
ms=$1 src=$2 data=$3
. "$(dirname "$0")/lib.sh"

human=$data/meshes/static-human/human_man.obj
cmu=$data/mocap/bvh/cmu hdm=$data/mocap/asf_amc/hdm05 lam=$data/mocap/asf_amc/cmu_via_gsimchoni
rig=$src/rigs/static-human-depth.json
for f in "$human" "$cmu/131_01.bvh" "$cmu/131_03.bvh" "$hdm/HDM_dg.asf" "$hdm/HDM_dg_06-03_03_120.amc" \
    "$lam/lambada.asf" "$lam/lambada.amc"; do
    [ -f "$f" ] || { echo "no $f: skipped"; exit 77; }
done

ge() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a ~ /^[0-9.]+$/ && a + 0 >= b) }'; }

# the rig's rule, re-derived from the OBJ (0-based vertex numbers): head the highest vertex; hands
# the farthest out along the T-posed arms (+X left, -X right); feet the front-most (+Z) vertex
# below 0.15 m on each side of the mid-line
want=$(awk '$1 == "v" { x = $2; y = $3; z = $4; i = n++
    if (n == 1 || y > hy) { hy = y; h = i }
    if (n == 1 || x > lx) { lx = x; lh = i }
    if (n == 1 || x < rx) { rx = x; rh = i }
    if (y < 0.15 && x > 0 && (lf == "" || z > lz)) { lz = z; lf = i }
    if (y < 0.15 && x < 0 && (rf == "" || z > rz)) { rz = z; rf = i } }
  END { printf "head=%d lhand=%d rhand=%d lfoot=%d rfoot=%d", h, lh, rh, lf, rf }' "$human")
for m in head lhand rhand lfoot rfoot; do
    v=$(tr -d ' \n' <"$rig" | grep -o "\"name\":\"$m\",\"vertex\":[0-9]*" | grep -o '[0-9]*$')
    case " $want " in *" $m=$v "*) ;; *) fail "rig $m is vertex '$v'; the rule gives $want" ;; esac
done
echo "rig: $want"

# the models: the CMU BVH skeleton (131_03's rest pose serves both BVH takes), HDM05's ASF and
# the lambada dancer's CMU ASF
expect_status 0 "$ms" train --kind harmonic --mesh "$human" --rig "$src/rigs/human-cmu-harmonic.json" \
    --template "$cmu/131_03.bvh" --fit-rest -o "$dir/cmu.msm"
expect_status 0 "$ms" train --kind harmonic --mesh "$human" --rig "$src/rigs/human-asf-harmonic.json" \
    --template "$hdm/HDM_dg_06-03_03_120.amc" --fit-rest -o "$dir/hdm.msm"
expect_status 0 "$ms" train --kind harmonic --mesh "$human" --rig "$src/rigs/human-asf-harmonic.json" \
    --template "$lam/lambada.amc" --fit-rest -o "$dir/lambada.msm"

# synth_take NAME MODEL MOCAP FRAMES NFRAMES: the take as a PC2, driven by the file's joint rotations
synth_take() {
    expect_status 0 "$ms" synth --model "$dir/$2.msm" --markers "$3" --frames "$4" -o "$dir/$1.pc2" --json
    local n jb
    n=$(json_num "$dir/out" frames) jb=$(json_num "$dir/out" joint_bones)
    [ "$n" = "$5" ] || fail "$1: synth made '$n' frames, expected $5"
    [ "$(json_num "$dir/out" nonfinite)" = 0 ] || fail "$1: non-finite vertices"
    [ "$jb" -gt 0 ] || fail "$1: no bone driven by the file's joint rotations"
}
synth_take hop cmu "$cmu/131_03.bvh" ::4 276
synth_take walk cmu "$cmu/131_01.bvh" 480::4 129
synth_take run hdm "$hdm/HDM_dg_06-03_03_120.amc" ::4 51
synth_take lambada lambada "$lam/lambada.amc" ::4 545

# check TAKE HEAD HAND FOOT SIDE SIDE_WRONG [YAW]: the default placement (or 2.5 m turned by
# YAW) and its bounds
check() {
    local t=$1 yaw=${7:-0}
    expect_status 0 "$ms" depth-eval --mesh "$dir/$t.pc2" --rest "$human" --rig "$rig" --yaw "$yaw" --json
    t=$t@$yaw
    cp "$dir/out" "$dir/$t.json"
    echo "$t: $(cat "$dir/$t.json")"
    grep -o '"within_10cm": {[^}]*}' "$dir/$t.json" >"$dir/within.json" ||
        fail "$t: depth-eval printed no within_10cm"
    local k v i=2
    for k in head hand foot; do
        v=$(json_num "$dir/within.json" $k)
        ge "$v" "${!i}" || fail "$t: $k within 10 cm is '$v', below ${!i}"
        i=$((i + 1))
    done
    v=$(json_num "$dir/$t.json" side_correct)
    ge "$v" "$5" || fail "$t: side_correct is '$v', below $5"
    v=$(json_num "$dir/$t.json" side_wrong)
    [[ $v =~ ^[0-9.]+$ ]] && le "$v" "$6" || fail "$t: side_wrong is '$v', above $6"
}

# measured (2026-12-02, docs/PERFORMANCE.md, with the per-person head length): hop 0.941 / 0.310 /
# 0.795, side 0.487, wrong 0.066; walk 0.984 / 0.348 / 0.855, side 0.588, wrong 0; run 0.980 /
# 0.186 / 0.922, side 0.554, wrong 0; lambada 0.995 / 0.523 / 0.958, side 0.739, wrong 0.002.
# Bounds: 0.03 below (the render noise moves a cell by up to ~0.03), side_wrong 0.03 above.
# Later the same day (label.c's ARM_SIDE: an arm's path passes its shoulder; the cut head costed
# by its missing length): hop 0.941 / 0.295 / 0.795, side 0.481, wrong 0.065; walk and run as
# before within 0.01; lambada 0.995 / 0.622 / 0.959, side 0.780, wrong 0.002, and turned by -20
# degrees 0.840 / 0.852 / 0.891, side 0.846 (hands 0.307 before: the neck, with the raised arm cut
# by the image's top edge, was labelled a hand). Then (markers.c: an arm loop's hand before the
# body when its forearm comes towards the camera) run's hands 0.186 -> 0.304, side 0.554 ->
# 0.613; the others as before.
# 2026-12-03, fourth session (label.c: a hand nearer the centroid than a shoulder and an upper arm
# costs what it lacks, so a label does not stay on a point of the hip while the hand's own
# extremum goes unlabelled): hands hop 0.304 -> 0.386, walk 0.348 -> 0.488, run 0.304 -> 0.402,
# lambada 0.622 -> 0.892 and at -20 degrees 0.852 -> 0.970; side 0.482 -> 0.522, 0.582 -> 0.627,
# 0.613 -> 0.662, 0.780 -> 0.890 and 0.846 -> 0.890; heads, feet and side_wrong as before.
# Then (head_axis.c: a head in full view placed on its axis, from its silhouette) heads hop 0.941
# -> 0.956, walk 0.984 -> 1.000, lambada at -20 degrees 0.840 -> 0.846, run and lambada as before.
# 2026-12-04 (markers.c: 12 extrema, not 9; label.c: a head at least HEAD_APART from the
# centroid): hands hop 0.386 -> 0.406, lambada 0.891 -> 0.927 (side 0.890 -> 0.905), at -20
# degrees 0.970 -> 0.975; heads, feet and the walk and run as before (the walk's head stays
# 1.000; the rule at /0.1 and for any person, not only one seen down to the floor, lost it in
# frames 4-10: 0.944).
# 2026-12-07 (label.c: a head off the centroid's line in full view, HEAD_ASIDE) heads hop 0.956 ->
# 0.970; (markers.c: a hand reported valid after a guess starts its filter over) hands hop 0.406 ->
# 0.440, run 0.402 -> 0.461, side 0.534 -> 0.545 and 0.662 -> 0.691; walk and lambada up by 0.004
# and 0.005. Then (segment.c: slits, a loop closed across an occluding edge, their hands reported
# inferred) hop's hands 0.440 -> 0.438: one of 552, at frame 236 the right hand 9.x -> 10.x cm
# after slit guesses in frames 225-230 (where it was missing before); the bound follows, 0.44 ->
# 0.43, stated as the cost of samba's hands at -20 degrees 0.731 -> 0.843 (test_depth.sh).
#     take head hand foot side side_wrong [yaw]
check hop  0.97 0.43 0.76 0.54 0.09
check walk 0.97 0.45 0.82 0.59 0.03
check run  0.95 0.46 0.89 0.69 0.03
check lambada 0.96 0.89 0.93 0.87 0.03
# A head whose top an arm raised before it cuts off from the face (head_crown.c, 2026-12-04):
# lambada at -20 degrees, heads 0.846 -> 0.928. A head lost n frames ago looked for within
# sqrt(n + 1) frames' steps of where it was (label.c, 2026-12-06): 0.928 -> 0.930.
check lambada 0.929 0.94 0.86 0.86 0.03 -20
# valid hand reports with no hand within 10 cm: the hands nearer the centroid than a shoulder and
# an upper arm are reported inferred (markers.c): walk 0.53 -> 0.30, lambada 0.20 -> 0.05, lambada
# at -20 degrees 0.17 -> 0.09 (2026-12-03). Bounds 0.03 over. Then (the elbow's cost, above) walk
# 0.27, lambada 0.04, lambada at -20 degrees 0.10. With 12 extrema (2026-12-04): walk 0.27,
# lambada 0.017, lambada at -20 degrees 0.087.
for tw in walk@0:0.30 lambada@0:0.05 lambada@-20:0.11; do
    t=${tw%:*} want=${tw##*:}
    grep -o '"confident_wrong": {[^}]*}' "$dir/$t.json" >"$dir/cw.json" || fail "$t: no confident_wrong"
    v=$(json_num "$dir/cw.json" hand)
    le "$v" "$want" || fail "$t: valid hand reports with no hand within 10 cm: '$v', above $want"
done
# valid head reports with no head within 10 cm at lambada -20: the face below the arm was the
# head, 0.115 of them, before the head's top beyond the arm was found (head_crown.c): 0.006
grep -o '"confident_wrong": {[^}]*}' "$dir/lambada@-20.json" >"$dir/cw.json" ||
    fail "lambada@-20: no confident_wrong"
v=$(json_num "$dir/cw.json" head)
le "$v" 0.03 || fail "lambada@-20: valid head reports with no head within 10 cm: '$v', above 0.03"
# the head's median error (metres): each row's rims pushed back by their depth inside the
# silhouette, the head's direction from the centroid (head_axis.c; 2026-12-07): hop 0.052 ->
# 0.032, run 0.078 -> 0.058, lambada 0.051 -> 0.027
for tw in hop@0:0.033 run@0:0.059 lambada@0:0.028; do
    t=${tw%:*} want=${tw##*:}
    grep -o '"error_m": {"head": {[^}]*}' "$dir/$t.json" >"$dir/hm.json" ||
        fail "$t: no error_m for the head"
    v=$(json_num "$dir/hm.json" median)
    le "$v" "$want" || fail "$t: the head's median error is '$v' m, above $want"
done
echo "depth smpl: ok"
