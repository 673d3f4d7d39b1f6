#!/usr/bin/env bash
# test_rig.sh - `meshsteer rig` (issue 12): the rig proposed from the mesh alone names the right
# extremities on samba and horse-gallop (each within a few cm of the hand-made rig's vertex, in the
# same frame), left and right not swapped, the same from other frames, a rig that train reads and
# uses, and clear errors for a body without its extremities and for a wrong --up. A sequence's
# default is the medoid over up to 24 of its frames.
# Usage: test_rig.sh MESHSTEER SRC_DIR DATA_DIR
set -euo pipefail
ms=$1 src=$2 data=$3
source "$(dirname "$0")/lib.sh"

expect_status 0 "$ms" rig --help
grep -q -- "--body" "$dir/out" || fail "rig --help does not describe --body"
expect_status 0 "$ms" --help
grep -q "^  rig " "$dir/out" || fail "--help does not list rig"
expect_status 2 "$ms" rig --mesh x.obj
grep -q -- "-o" "$dir/err" || fail "rig without -o does not say what is missing"
expect_status 2 "$ms" rig --mesh x.obj -o "$dir/x.json" --body fish
grep -q "fish" "$dir/err" || fail "a bad --body is not named"
expect_status 2 "$ms" rig --mesh x.obj -o "$dir/x.json" --up w
grep -q "\-\-up w" "$dir/err" || fail "a bad --up is not named"

# a sphere has one geodesic extremity: no body to rig
awk 'BEGIN { n = 16; m = 32; pi = 3.14159265
  for (i = 0; i <= n; i++) for (j = 0; j < m; j++) { t = pi * i / n; p = 2 * pi * j / m
    printf "v %f %f %f\n", sin(t) * cos(p), cos(t), sin(t) * sin(p) }
  for (i = 0; i < n; i++) for (j = 0; j < m; j++) { a = i * m + j + 1; b = i * m + (j + 1) % m + 1
    c = a + m; d = b + m; printf "f %d %d %d\nf %d %d %d\n", a, c, b, b, c, d } }' >"$dir/sphere.obj"
expect_status 2 "$ms" rig --mesh "$dir/sphere.obj" -o "$dir/sphere.json" --body human
grep -q "found 1 geodesic extremities" "$dir/err" || fail "a sphere's missing extremities are not named"
[ ! -e "$dir/sphere.json" ] || fail "a failed proposal wrote a rig"

[ -d "$data/meshes/samba" ] && [ -d "$data/meshes/horse-gallop" ] || {
    echo "SKIP: no shared data"; exit 77; }

# positions of a rig's vertices in one frame (meshsteer markers: CSV header source_x,...)
pos() { # pos MESH_ARGS... RIG FRAME OUT
    local out=${*: -1} frame=${*: -2:1} rig=${*: -3:1}
    "$ms" markers "${@:1:$#-3}" --rig "$rig" --frames "$frame" -o "$out" 2>/dev/null
}
# dist A.csv NAME_A B.csv NAME_B: distance between two markers of two one-frame CSVs
dist() {
    paste -d'\n' "$1" "$3" | awk -F, -v na="$2" -v nb="$4" '
      NR == 1 { for (i = 1; i <= NF; i++) if ($i == na "_x") ia = i }
      NR == 2 { for (i = 1; i <= NF; i++) if ($i == nb "_x") ib = i }
      NR == 3 { split($0, a, ",") } NR == 4 { split($0, b, ",") }
      END { if (!ia || !ib) { print "missing"; exit }
            print sqrt((a[ia]-b[ib])^2 + (a[ia+1]-b[ib+1])^2 + (a[ia+2]-b[ib+2])^2) }'
}
near() { # near A.csv NAME_A B.csv NAME_B TOL WHAT
    local d; d=$(dist "$1" "$2" "$3" "$4")
    [ "$d" != missing ] && le "$d" "$5" || fail "$6: $2 is $d m from $4 (at most $5)"
    echo "$6: $2 $d m from $4"
}

# samba: a human, named as the hand-made seven-marker rig (which is in frame 0's coordinates)
S=(--mesh "$data/meshes/samba/samba.pc2" --rest "$data/meshes/samba/rest.obj")
expect_status 0 "$ms" rig "${S[@]}" -o "$dir/samba.json" --sheet "$dir/samba.png"
grep -q "a human" "$dir/err" || fail "samba was not taken for a human"
# a sequence's default: the medoid over up to 24 frames spread evenly (175 frames: every 8th)
grep -q "medoid over frames 0:175:8 (9971 vertices, 22 of 22 frames proposed)" "$dir/samba.json" ||
    fail "samba's default rig is not the medoid over 0:175:8"
head -c 8 "$dir/samba.png" | od -An -tx1 | grep -q "89 50 4e 47" || fail "--sheet wrote no PNG"
pos "${S[@]}" "$dir/samba.json" 0 "$dir/sp.csv"
pos "${S[@]}" "$src/rigs/samba-7.json" 0 "$dir/sh.csv"
for m in head lhand rhand lfoot rfoot neck; do near "$dir/sp.csv" $m "$dir/sh.csv" $m 0.06 samba; done
near "$dir/sp.csv" pelvis "$dir/sh.csv" pelvis 0.15 samba # lower on the belly than the hand rig's
# left/right: each hand and foot is nearer its own side's hand-made vertex than the other side's
for m in hand foot; do
    a=$(dist "$dir/sp.csv" l$m "$dir/sh.csv" l$m) b=$(dist "$dir/sp.csv" l$m "$dir/sh.csv" r$m)
    le "$a" "$b" || fail "samba: l$m is nearer the hand rig's r$m ($b m) than its l$m ($a m)"
done
# the same rig from frames 60 and 120 (measured where each vertex lies in frame 0)
for k in 60 120; do
    expect_status 0 "$ms" rig "${S[@]}" --frame $k -o "$dir/samba$k.json"
    pos "${S[@]}" "$dir/samba$k.json" 0 "$dir/sp$k.csv"
    for m in head lhand rhand lfoot rfoot; do
        near "$dir/sp$k.csv" $m "$dir/sp.csv" $m 0.06 "samba frame $k"
    done
done
# --frames: the medoid over several frames is the same rig (within a few cm in frame 0)
expect_status 2 "$ms" rig "${S[@]}" --frame 3 --frames 0:175:35 -o "$dir/x.json"
grep -q "not both" "$dir/err" || fail "--frame with --frames is not refused"
expect_status 0 "$ms" rig "${S[@]}" --frames 0:175:35 -o "$dir/sampled.json"
grep -q "medoid over frames 0:175:35" "$dir/sampled.json" || fail "--frames: the rig's comment does not say how it was made"
pos "${S[@]}" "$dir/sampled.json" 0 "$dir/spm.csv"
for m in head lhand rhand lfoot rfoot; do near "$dir/spm.csv" $m "$dir/sh.csv" $m 0.06 "samba medoid"; done
# a wrong up axis is refused, naming --up
expect_status 2 "$ms" rig "${S[@]}" --up z -o "$dir/bad.json"
grep -q -- "--up is wrong" "$dir/err" || fail "samba with --up z: no word of --up"

# horse-gallop: a quadruped (faces +Z, Y up, so its left is +X), named as rigs/horse.json
H=(--mesh "$data/meshes/horse-gallop")
expect_status 0 "$ms" rig "${H[@]}" -o "$dir/horse.json"
grep -q "a quadruped" "$dir/err" || fail "the horse was not taken for a quadruped"
pos "${H[@]}" "$dir/horse.json" 0 "$dir/hp.csv"
pos "${H[@]}" "$src/rigs/horse.json" 0 "$dir/hh.csv"
for m in lf_hoof rf_hoof lh_hoof rh_hoof tail; do near "$dir/hp.csv" $m "$dir/hh.csv" $m 0.1 horse; done
near "$dir/hp.csv" muzzle "$dir/hh.csv" head 0.1 horse
for m in f h; do
    a=$(dist "$dir/hp.csv" l${m}_hoof "$dir/hh.csv" l${m}_hoof)
    b=$(dist "$dir/hp.csv" l${m}_hoof "$dir/hh.csv" r${m}_hoof)
    le "$a" "$b" || fail "horse: l${m}_hoof is nearer the hand rig's r${m}_hoof than its own"
done
expect_status 0 "$ms" rig "${H[@]}" --frame 24 -o "$dir/horse24.json"
pos "${H[@]}" "$dir/horse24.json" 0 "$dir/hp24.csv"
for m in lf_hoof rf_hoof lh_hoof rh_hoof tail; do near "$dir/hp24.csv" $m "$dir/hp.csv" $m 0.1 "horse frame 24"; done
expect_status 2 "$ms" rig "${H[@]}" --up z --body quadruped -o "$dir/bad.json"
grep -q -- "--up is wrong" "$dir/err" || fail "the horse with --up z: no word of --up"

# pcow falls and rolls over: most of its frames are refused, so the default is its frame 0 alone
if [ -d "$data/meshes/pcow" ]; then
    expect_status 0 "$ms" rig --mesh "$data/meshes/pcow/pcow.pc2" --rest "$data/meshes/pcow/rest.obj" \
        -o "$dir/pcow.json"
    grep -q "of 23 frames could be proposed as a quadruped; the first refused: frame 18" "$dir/err" ||
        fail "pcow: the refused medoid is not explained with the sequence's frame number"
    grep -q "proposing from frame 0 alone" "$dir/err" || fail "pcow: no word of the fallback"
    grep -q "pcow.pc2, frame 0 (2904 vertices)" "$dir/pcow.json" || fail "pcow: not frame 0's rig"
fi

# the proposed rig is a rig: train reads and uses it, and the model beats the nearest frame
expect_status 0 "$ms" train "${H[@]}" --rig "$dir/horse.json" --frames 0:24:2 -o "$dir/horse.msm"
expect_status 0 "$ms" eval --model "$dir/horse.msm" "${H[@]}" --frames 1:24:2 --json
mean=$(json_num "$dir/out" mean_err) base=$(json_num "$dir/out" baseline_nn_mean_err)
echo "horse, proposed rig: mean_err $mean, baseline $base"
awk -v a="$mean" -v b="$base" 'BEGIN { exit !(a > 0 && a < 0.6 * b) }' ||
    fail "horse, proposed rig: mean_err $mean is not below 0.6 x the baseline $base"
echo "rig: all checks passed"
