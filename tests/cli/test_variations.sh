#!/usr/bin/env bash
# test_variations.sh - `meshsteer variations` end to end (Zheng 2013, model/variations/): usage,
# a model without a skin refused, on the built-in example's skin N PC2 files of F frames that are
# the same for the same seed and differ across seeds, with no frame-to-frame vertex jump above 3x
# the example's own, and the blend (linear, the default, and gradient) lowers the acceleration at
# transitions; --blend N (the old window option) refused naming --blend-frames; --add-to makes a
# model's skin walk; then on horse-gallop (a 22-bone skin; skipped when absent) 4 x 336 frames
# with the same bound, one component joining only corresponding frames, components auto walking
# the tail apart (contact sheets of 4 variations: $MESHSTEER_SHEETS or the scratch directory),
# targeted frames, --threads, the bone file; then samba's --ground, targets and smoothness, and
# --avoid: a box where the dancer's hand passes in a walk is intersected by no output frame once
# avoided (checked by PC2_BOX_HITS, tests/cli/pc2_box_hits.c, which shares no code with model/).
# Usage: test_variations.sh MESHSTEER SRC DATA PC2_BOX_HITS
set -euo pipefail
ms=$1 src=$2 data=$3 boxhits=$4
source "$(dirname "$0")/lib.sh"
# PC2: 32-byte header, then frames x points x 3 float32
pc2_size() { echo $((32 + $1 * $2 * 12)); }

expect_status 0 "$ms" variations --help
grep -q -- "--count" "$dir/out" || fail "variations --help does not list --count"
expect_status 2 "$ms" variations --model x.msm --count 2 -o "$dir/v"
grep -q -- "--frames" "$dir/err" || fail "no message for a missing --frames"
expect_status 2 "$ms" variations --model x.msm --count 2 --frames 10 --jump-prob 2 -o "$dir/v"
expect_status 2 "$ms" variations --model /nonexistent.msm --count 2 --frames 10 -o "$dir/v"
grep -q "/nonexistent" "$dir/err" || fail "the error does not name the missing file"

expect_status 0 "$ms" example -o "$dir/ex" --frames 90
expect_status 0 "$ms" train --mesh "$dir/ex/mesh" --rig "$dir/ex/rig.json" --frames 0:30:2 -o "$dir/steer.msm"
expect_status 2 "$ms" variations --model "$dir/steer.msm" --count 1 --frames 3 -o "$dir/v"
grep -q "holds no skin" "$dir/err" || fail "a model without a skin is not refused"

expect_status 0 "$ms" skin --mesh "$dir/ex/mesh" --bones 8 --threads 1 -o "$dir/skin.msm"
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 1 --frames 3 --start 90 -o "$dir/v"
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 3 --frames 100 --seed 5 -o "$dir/a" --json
cp "$dir/out" "$dir/a.json"
n=$(json_num "$dir/a.json" transitions)
[ "$n" -gt 0 ] || fail "no transitions on the example's walk"
tc=$(json_num "$dir/a.json" tc) madj=$(json_num "$dir/a.json" max_adjacent)
awk -v t="$tc" -v m="$madj" 'BEGIN { exit !(t * 40 > 0.9999 * m && t * 40 < 1.0001 * m) }' || fail "T_c $tc is not $madj / 40"
ratio=$(json_num "$dir/a.json" max_jump_ratio)
echo "example: $n transitions, T_c $tc, worst jump $ratio x the example's"
le "$ratio" 3 || fail "a jump of $ratio x the example's"
nv=$(grep -c '^v ' "$dir/ex/mesh/$(ls "$dir/ex/mesh" | head -1)")
for k in 000 001 002; do
    f="$dir/a/variation_$k.pc2"
    [ "$(stat -c %s "$f")" = "$(pc2_size 100 "$nv")" ] || fail "$f is not 100 frames of $nv vertices"
done
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 2 --frames 100 --seed 5 -o "$dir/b"
# the linear blend smooths the transitions: with the same walks (same seeds) under the printed
# loose T_c (40 x max D(i, i-1)), the largest vertex acceleration near a transition is lower than
# with no blend
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 3 --frames 100 --seed 5 --tc-factor 40 --blend gradient -o "$dir/c8" --json
acc8=$(json_num "$dir/out" transition_max_accel)
grep -q '"blend":[[:space:]]*"gradient"' "$dir/out" || fail "--json does not say the gradient blend ran"
[ "$(json_num "$dir/out" key_vertices)" -gt 0 ] || fail "the gradient blend has no key vertices"
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 3 --frames 100 --seed 5 --tc-factor 40 --blend linear -o "$dir/c8l" --json
accl=$(json_num "$dir/out" transition_max_accel)
grep -q '"blend":[[:space:]]*"linear"' "$dir/out" || fail "--json does not say the linear blend ran"
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 3 --frames 100 --seed 5 --tc-factor 40 --blend-frames 0 -o "$dir/c" --json
acc0=$(json_num "$dir/out" transition_max_accel)
grep -q '"blend":[[:space:]]*"none"' "$dir/out" || fail "--json does not say no blend ran"
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 1 --frames 10 --blend 8 -o "$dir/c"
grep -q -- "--blend-frames" "$dir/err" || fail "--blend 8 is not refused naming --blend-frames"
awk -v a="$accl" -v b="$acc0" 'BEGIN { exit !(a < b) }' || fail "the linear blend does not smooth: $accl vs $acc0"
echo "example (T_c 40 x max D(i, i-1)): largest acceleration near a transition $acc8 gradient-blended, $accl linear, $acc0 not" \
     "(the example's 99th percentile $(json_num "$dir/a.json" example_p99_accel), largest $(json_num "$dir/a.json" example_max_accel));" \
     "at the default T_c $(json_num "$dir/a.json" transition_max_accel)"
awk -v a="$acc8" -v b="$acc0" 'BEGIN { exit !(a < b) }' || fail "the blend does not smooth: $acc8 vs $acc0"
cmp -s "$dir/a/variation_000.pc2" "$dir/b/variation_000.pc2" || fail "seed 5 gave two animations"
cmp -s "$dir/a/variation_001.pc2" "$dir/b/variation_001.pc2" || fail "seed 6 gave two animations"
! cmp -s "$dir/a/variation_000.pc2" "$dir/a/variation_001.pc2" || fail "seeds 5 and 6 gave one animation"
! cmp -s "$dir/a/variation_001.pc2" "$dir/a/variation_002.pc2" || fail "seeds 6 and 7 gave one animation"

# the bone file: header, then per variation seed, bones x 12 float32 per frame, components int32
# per frame; identical for any --threads; --pc2 0 writes no meshes
bsize() { echo $((28 + $1 * (8 + $2 * $3 * 48 + $2 * $4 * 4))); }
[ "$(stat -c %s "$dir/a/variations.bones")" = "$(bsize 3 100 8 "$(json_num "$dir/a.json" component_count)")" ] \
    || fail "variations.bones is not 3 x 100 frames of 8 bones"
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 9 --frames 100 --seed 5 --threads 1 --pc2 0 -o "$dir/t1"
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 9 --frames 100 --seed 5 --threads 2 --pc2 0 -o "$dir/t2"
cmp -s "$dir/t1/variations.bones" "$dir/t2/variations.bones" || fail "--threads 1 and 2 differ"
cmp -s <(head -c "$(stat -c %s "$dir/b/variations.bones")" "$dir/t1/variations.bones" | tail -c +29 | head -c 1000) \
       <(tail -c +29 "$dir/b/variations.bones" | head -c 1000) || fail "the first variation depends on --count"
! ls "$dir/t1"/*.pc2 >/dev/null 2>&1 || fail "--pc2 0 wrote meshes"
# --gltf: the variations written as PC2 as animations of one skinned mesh (three.js reads them in
# gltf_three); assimp, the second reader, sees the two; --pc2 0 leaves none to animate
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 3 --frames 100 --seed 5 --pc2 2 --gltf -o "$dir/g" --json
grep -q "\"gltf\":[[:space:]]*\"$dir/g/variations.glb\"" "$dir/out" || fail "--json does not name the glb"
[ -s "$dir/g/variations.glb" ] || fail "--gltf wrote no variations.glb"
if command -v assimp >/dev/null; then
    assimp info "$dir/g/variations.glb" >"$dir/assimp.txt" 2>&1 || { cat "$dir/assimp.txt"; fail "assimp cannot read variations.glb"; }
    for want in "Bones: *8" "Animations: *2"; do
        grep -q "$want" "$dir/assimp.txt" || { cat "$dir/assimp.txt"; fail "assimp: no '$want' in variations.glb"; }
    done
    echo "assimp reads variations.glb: 8 bones, 2 animations"
fi
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 2 --frames 10 --pc2 0 --gltf -o "$dir/g0"
grep -q -- "--pc2 0" "$dir/err" || fail "--gltf with --pc2 0 is not refused with a reason"
# targeted frames: --start, --end and --target met exactly in every variation (the example
# loops every 75 frames and its transitions keep that phase: input = 10 + output mod 75)
expect_status 0 "$ms" variations --model "$dir/skin.msm" --count 6 --frames 120 --start 10 --end 54 \
    --target 70:60 -o "$dir/tg" --json
[ "$(json_num "$dir/out" targets)" = 3 ] || fail "targets: $(json_num "$dir/out" targets), not 3"
[ "$(json_num "$dir/out" targets_met)" = 6 ] || fail "targets met by $(json_num "$dir/out" targets_met) of 6"
echo "example (period 75): --start 10 --end 54 --target 70:60 met by 6 of 6 variations"
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 1 --frames 3 --start 10 --end 40 -o "$dir/tg"
grep -q "no walk meets the targets" "$dir/err" || fail "an impossible target is not refused"
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 1 --frames 3 --target 3x -o "$dir/tg"
# --avoid: a missing file, a file without triangles and an obstacle that every frame meets are
# refused, naming the file
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 1 --frames 3 --avoid "$dir/none.obj" -o "$dir/av"
grep -q "none.obj" "$dir/err" || fail "--avoid: the error does not name the missing file"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\n' > "$dir/points.obj"
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 1 --frames 3 --avoid "$dir/points.obj" -o "$dir/av"
grep -q "points.obj: no faces" "$dir/err" || fail "--avoid: an obstacle without triangles is not refused"
# box OBJ: box CX CY CZ HALF (an axis-aligned cube, 12 triangles)
box() {
    awk -v x="$1" -v y="$2" -v z="$3" -v h="$4" 'BEGIN {
        for (k = 0; k < 8; k++)
            printf "v %.6f %.6f %.6f\n", x + (k % 2 ? h : -h), y + (int(k / 2) % 2 ? h : -h), z + (int(k / 4) ? h : -h)
        print "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6" }'
}
# a plane through every frame of the example's mesh (its bounding box's middle, wider than it)
read -r cx cy cz < <(awk '/^v / { for (c = 2; c <= 4; c++) { if (!n || $c < lo[c]) lo[c] = $c; if (!n || $c > hi[c]) hi[c] = $c }; n++ }
    END { print (lo[2] + hi[2]) / 2, (lo[3] + hi[3]) / 2, (lo[4] + hi[4]) / 2 }' "$dir/ex/mesh/$(ls "$dir/ex/mesh" | head -1)")
printf 'v -100 %s -100\nv 100 %s -100\nv 0 %s 100\nf 1 2 3\n' "$cy" "$cy" "$cy" > "$dir/wall.obj"
expect_status 2 "$ms" variations --model "$dir/skin.msm" --count 1 --frames 3 --avoid "$dir/wall.obj" -o "$dir/av"
grep -q "wall.obj.*every frame collides" "$dir/err" || { cat "$dir/err"; fail "--avoid: an obstacle every frame meets is not refused"; }

# --add-to: the skin beside a steering model walks (the daemon's idle source); a steering model
# alone is refused
expect_status 2 "$ms" variations --add-to "$dir/steer.msm"
grep -q "holds no skin" "$dir/err" || fail "--add-to a model without a skin is not refused"
expect_status 0 "$ms" skin --mesh "$dir/ex/mesh" --bones 8 --threads 1 --add-to "$dir/steer.msm" -o "$dir/both.msm"
expect_status 0 "$ms" inspect "$dir/both.msm"
grep -q "the fitted frames, looping" "$dir/out" || { cat "$dir/out"; fail "a new skin does not loop"; }
expect_status 0 "$ms" variations --add-to "$dir/both.msm" --seed 9 --json
[ "$(json_num "$dir/out" transitions)" -gt 0 ] || fail "--add-to --json: no transitions"
expect_status 0 "$ms" inspect "$dir/both.msm"
grep -q "steer (primary), skin" "$dir/out" || { cat "$dir/out"; fail "inspect does not list both kinds"; }
grep -q "endless random walk.*seed 9, components auto, blend linear" "$dir/out" || { cat "$dir/out"; fail "the skin does not walk (components auto, the linear blend by default)"; }
expect_status 0 "$ms" variations --add-to "$dir/both.msm" --seed 9 --components 1 --ground
expect_status 0 "$ms" inspect "$dir/both.msm"
grep -q "endless random walk.*seed 9, components 1, ground, blend linear" "$dir/out" || { cat "$dir/out"; fail "--add-to did not keep --components 1 --ground"; }
expect_status 0 "$ms" variations --add-to "$dir/both.msm" --seed 9 --blend gradient
expect_status 0 "$ms" inspect "$dir/both.msm"
grep -q "endless random walk.*seed 9, components auto, blend gradient" "$dir/out" || { cat "$dir/out"; fail "--add-to did not keep --blend gradient"; }

horse=$data/meshes/horse-gallop
if [ ! -d "$horse" ]; then echo "skip: $horse not found (real-data part)"; exit 0; fi
expect_status 0 "$ms" skin --mesh "$horse" --bones 22 --threads 1 -o "$dir/horse.msm"
# one component: only corresponding frames of the two cycles (24 apart) are joined
expect_status 0 "$ms" variations --model "$dir/horse.msm" --components 1 --count 4 --frames 336 -o "$dir/h1" --json
awk '/"from"/ { f = $2 + 0 } /"to"/ { t = $2 + 0; d = f - t; if (d != 24 && d != -24) bad++ } END { exit bad > 0 }' \
    "$dir/out" || fail "horse, one component: a transition between frames not 24 apart"
[ "$(json_num "$dir/out" component_count)" = 1 ] || fail "--components 1 gave several"
echo "horse, one component: $(json_num "$dir/out" transitions) transitions, all between corresponding frames"
# components auto: the bone graph's blocks walk apart (the tail among them)
expect_status 0 "$ms" variations --model "$dir/horse.msm" --count 4 --frames 336 -o "$dir/h" --json
cp "$dir/out" "$dir/h.json"
nc=$(json_num "$dir/h.json" component_count)
[ "$nc" -ge 2 ] || fail "horse: $nc components"
ratio=$(json_num "$dir/h.json" max_jump_ratio)
echo "horse: $nc components, $(json_num "$dir/h.json" transitions) transitions" \
     "($(json_num "$dir/h.json" single_transitions) as one), 4 x 336 frames in" \
     "$(json_num "$dir/h.json" synth_s) s, worst jump $ratio x the example's"
tr -d '\n\t' < "$dir/h.json" | grep -o '"bones":\[[0-9, ]*\],"cut":-\?[0-9]*' | sed 's/^/  component: /'
le "$ratio" 3 || fail "horse: a jump of $ratio x the example's"
# the four variations differ (the merged walks), and a contact sheet of each is kept
for k in 001 002 003; do
    ! cmp -s "$dir/h/variation_000.pc2" "$dir/h/variation_$k.pc2" || fail "horse: variations 0 and $k are one"
done
sheets=${MESHSTEER_SHEETS:-$dir}
mkdir -p "$sheets"
for k in 000 001 002 003; do
    expect_status 0 "$ms" render --mesh "$dir/h/variation_$k.pc2" --rest "$horse/0001.obj" \
        --frames 0:336:42 --cols 8 --size 160 -o "$sheets/horse_variation_$k.png"
done
echo "horse: contact sheets of 4 variations (8 frames each, 42 apart) in $sheets"
# samba (40 bones; its transitions let a 600-frame walk from frame 20 end only at frames 140-170):
# --ground keeps the lowest vertex of every frame within 2 cm of the example's
# range of it, --start/--end are met exactly, and the transitions are smooth (the largest vertex
# acceleration within 3 frames of one <= 1.5 x the example's 99th percentile)
samba=$data/meshes/samba
if [ ! -d "$samba" ]; then echo "skip: $samba not found"; echo "variations_cli: ok"; exit 0; fi
expect_status 0 "$ms" skin --mesh "$samba/samba.pc2" --rest "$samba/rest.obj" --bones 40 -o "$dir/samba.msm"
expect_status 0 "$ms" variations --model "$dir/samba.msm" --count 4 --frames 600 -o "$dir/s0" --json
drift=$(json_num "$dir/out" floor_excursion)
# --avoid (the issue's done-when): a box of 8 cm where the dancer's hand (the vertex that travels
# furthest in the example) is at output frame 300 of the first walk; without --avoid the same
# walks meet it, with it no output frame of any variation does (pc2_box_hits: the solid box
# against every triangle of every frame), and the bone file is the same on 1 and 2 threads
read -r hand < <(python3 - "$samba/samba.pc2" <<'PY'
import struct, sys
b = open(sys.argv[1], 'rb').read()
n, frames = struct.unpack_from('<i', b, 16)[0], struct.unpack_from('<i', b, 28)[0]
a = struct.unpack_from('<%df' % (3 * n * frames), b, 32)
path = [0.0] * n
for f in range(1, frames):
    for i in range(n):
        o, p = 3 * (f * n + i), 3 * ((f - 1) * n + i)
        path[i] += ((a[o] - a[p]) ** 2 + (a[o + 1] - a[p + 1]) ** 2 + (a[o + 2] - a[p + 2]) ** 2) ** 0.5
print(max(range(n), key=lambda i: path[i]))
PY
)
read -r hx hy hz < <(python3 - "$dir/s0/variation_000.pc2" "$hand" <<'PY'
import struct, sys
b = open(sys.argv[1], 'rb').read()
n, i, f = struct.unpack_from('<i', b, 16)[0], int(sys.argv[2]), 300
print(*struct.unpack_from('<3f', b, 32 + 12 * (f * n + i)))
PY
)
box "$hx" "$hy" "$hz" 0.04 > "$dir/hand_box.obj"
bounds=$(awk -v x="$hx" -v y="$hy" -v z="$hz" 'BEGIN { h = 0.04; print x - h, y - h, z - h, x + h, y + h, z + h }')
hits0=0
for k in 000 001 002 003; do
    "$boxhits" "$dir/s0/variation_$k.pc2" "$samba/rest.obj" $bounds > "$dir/hits" || fail "pc2_box_hits failed"
    hits0=$((hits0 + $(awk '{ print $4 }' "$dir/hits")))
done
[ "$hits0" -gt 0 ] || fail "samba: the box at the hand (vertex $hand) meets no frame without --avoid"
rm -rf "$dir/s0"
expect_status 0 "$ms" variations --model "$dir/samba.msm" --count 4 --frames 600 --avoid "$dir/hand_box.obj" -o "$dir/sa" --json
cp "$dir/out" "$dir/sa.json"
hits1=0
for k in 000 001 002 003; do
    "$boxhits" "$dir/sa/variation_$k.pc2" "$samba/rest.obj" $bounds > "$dir/hits" || fail "pc2_box_hits failed"
    hits1=$((hits1 + $(awk '{ print $4 }' "$dir/hits")))
done
echo "samba --avoid: a box of 8 cm at the hand (vertex $hand) of walk 0's output frame 300:" \
     "$hits0 of 2400 output frames meet it without --avoid, $hits1 with it;" \
     "$(json_num "$dir/sa.json" colliding_input_count) fitted frames collide, $(json_num "$dir/sa.json" alive_frames) of 175 alive," \
     "$(json_num "$dir/sa.json" collision_redrawn) walks redrawn; $(json_num "$dir/sa.json" synth_s) s"
[ "$hits1" = 0 ] || fail "samba --avoid: $hits1 output frames meet the box"
[ "$(json_num "$dir/sa.json" triangles)" = 12 ] || fail "samba --avoid: --json does not report the box's 12 triangles"
grep -q '"colliding_input_frames"' "$dir/sa.json" || fail "samba --avoid: no colliding_input_frames in --json"
rm -rf "$dir/sa"
expect_status 0 "$ms" variations --model "$dir/samba.msm" --count 4 --frames 600 --avoid "$dir/hand_box.obj" --threads 1 --pc2 0 -o "$dir/sa1"
expect_status 0 "$ms" variations --model "$dir/samba.msm" --count 4 --frames 600 --avoid "$dir/hand_box.obj" --threads 2 --pc2 0 -o "$dir/sa2"
cmp -s "$dir/sa1/variations.bones" "$dir/sa2/variations.bones" || fail "samba --avoid: --threads 1 and 2 differ"
rm -rf "$dir/sa1" "$dir/sa2"
expect_status 0 "$ms" variations --model "$dir/samba.msm" --count 4 --frames 600 --ground \
    --start 20 --end 150 --blend gradient -o "$dir/s" --json
cp "$dir/out" "$dir/s.json"
fe=$(json_num "$dir/s.json" floor_excursion) acc=$(json_num "$dir/s.json" transition_accel_ratio)
grep -q '"blend":[[:space:]]*"gradient"' "$dir/s.json" || fail "samba: the gradient blend did not run"
expect_status 0 "$ms" variations --model "$dir/samba.msm" --count 4 --frames 600 --ground \
    --start 20 --end 150 --blend linear --pc2 4 -o "$dir/sl" --json
accl=$(json_num "$dir/out" transition_accel_ratio)
rm -rf "$dir/sl"
echo "samba: $(json_num "$dir/s.json" transitions) transitions, $(json_num "$dir/s.json" component_count)" \
     "component(s); lowest vertex outside the example's range by $fe m with --ground ($drift without);" \
     "transition acceleration $acc x the example's p99 with the gradient blend ($accl linear); targets met by $(json_num "$dir/s.json" targets_met) of 4;" \
     "analysis $(json_num "$dir/s.json" analysis_s) s"
le "$fe" 0.02 || fail "samba --ground: the lowest vertex leaves the floor by $fe m"
le "$acc" 1.5 || fail "samba: transition acceleration $acc x the example's 99th percentile"
[ "$(json_num "$dir/s.json" targets_met)" = 4 ] || fail "samba: --start/--end not met"
rm -rf "$dir/s"
echo "variations_cli: ok"
