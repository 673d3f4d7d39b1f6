#!/usr/bin/env bash
# test_cli.sh - the meshsteer command end to end: every command on the built-in example, the
# puppeteering path on real data (a human BVH steering the horse), and the exit statuses and
# messages for bad usage and bad input. Usage: test_cli.sh MESHSTEER SRC_DIR DATA_DIR
set -euo pipefail
ms=$1 src=$2 data=$3
source "$(dirname "$0")/lib.sh"

# usage: help is 0, no arguments / unknown command / missing options are 2 with a message
expect_status 0 "$ms" --help
grep -q "train" "$dir/out" || fail "--help does not list train"
expect_status 2 "$ms"
expect_status 2 "$ms" frobnicate
grep -q "unknown command" "$dir/err" || fail "no message for an unknown command"
for c in train synth eval inspect render bench example demo; do
    expect_status 0 "$ms" $c --help
done
expect_status 2 "$ms" train --mesh /nonexistent --rig x.json -o y.msm
grep -q "/nonexistent" "$dir/err" || fail "the error does not name the missing file"

# the built-in example through files: example -> train -> inspect -> eval -> synth -> render
expect_status 0 "$ms" example -o "$dir/ex" --frames 40
[ -f "$dir/ex/rig.json" ] && [ -f "$dir/ex/markers.csv" ] && [ -f "$dir/ex/mesh/0000.obj" ] ||
    fail "example did not write mesh, rig and markers"
expect_status 0 "$ms" train --mesh "$dir/ex/mesh" --rig "$dir/ex/rig.json" --frames 0:40:2 \
    -o "$dir/ex.msm" --report "$dir/report.json"
grep -q '"clusters"' "$dir/report.json" || fail "the report has no cluster count"
expect_status 0 "$ms" inspect "$dir/ex.msm"
grep -q "near-rigid clusters" "$dir/out" || fail "inspect does not describe the parts"
expect_status 0 "$ms" eval --model "$dir/ex.msm" --mesh "$dir/ex/mesh" --frames 1:40:2 --json
cp "$dir/out" "$dir/eval.json"
mean=$(json_num "$dir/eval.json" mean_err) base=$(json_num "$dir/eval.json" baseline_nn_mean_err)
awk -v a="$mean" -v b="$base" 'BEGIN { exit !(a > 0 && a < b) }' ||
    fail "example: model error $mean is not below the baseline $base"
# driven by the committed take of the same trot (recordings/example-trot.c3d, 240 frames)
expect_status 0 "$ms" synth --model "$dir/ex.msm" --markers "$src/recordings/example-trot.c3d" \
    -o "$dir/ex.pc2" --obj-dir "$dir/exobj" --json
[ "$(json_num "$dir/out" nonfinite)" = "0" ] || fail "synth produced non-finite values"
[ -f "$dir/exobj/0000.obj" ] || fail "synth --obj-dir wrote nothing"
expect_status 0 "$ms" render --mesh "$dir/ex.pc2" --rest "$dir/ex/mesh/0000.obj" --frames 0:40:10 \
    -o "$dir/sheet.png"
head -c 8 "$dir/sheet.png" | od -An -tx1 | grep -q "89 50 4e 47" || fail "render did not write a PNG"

# the same example trained with the kernel blend (docs/MODEL.md): inspect says the synthesis is
# the blend, eval beats the baseline on held-out frames, synth stays finite, bench runs it
expect_status 0 "$ms" train --mesh "$dir/ex/mesh" --rig "$dir/ex/rig.json" --frames 0:40:2 \
    --kernel-blend 0.7 -o "$dir/kb.msm"
expect_status 0 "$ms" inspect "$dir/kb.msm"
grep -q "synthesis is the kernel blend of the 20 training meshes, bandwidth 0.7" "$dir/out" ||
    { cat "$dir/out"; fail "inspect does not say the synthesis is the kernel blend"; }
expect_status 0 "$ms" eval --model "$dir/kb.msm" --mesh "$dir/ex/mesh" --frames 1:40:2 --json
cp "$dir/out" "$dir/kbeval.json"
mean=$(json_num "$dir/kbeval.json" mean_err) base=$(json_num "$dir/kbeval.json" baseline_nn_mean_err)
awk -v a="$mean" -v b="$base" 'BEGIN { exit !(a > 0 && a < b) }' ||
    fail "example, kernel blend: error $mean is not below the baseline $base"
[ "$(json_num "$dir/kbeval.json" nan_count)" = "0" ] || fail "kernel blend eval: NaN"
expect_status 0 "$ms" synth --model "$dir/kb.msm" --markers "$src/recordings/example-trot.c3d" \
    -o "$dir/kb.pc2" --json
[ "$(json_num "$dir/out" nonfinite)" = "0" ] || fail "kernel blend synth produced non-finite values"
[ "$(json_num "$dir/out" frames)" = "240" ] || fail "kernel blend synth: not 240 frames"
expect_status 0 "$ms" bench --mesh "$dir/ex/mesh" --rig "$dir/ex/rig.json" --frames 0:40:2 \
    --eval-frames 1:40:2 --train-runs 1 --synth-frames 50 --kernel-blend 0.7
grep -q "kernel blend of the 20 training meshes" "$dir/out" || fail "bench: no kernel blend"
expect_status 2 "$ms" bench --mesh "$dir/ex/mesh" --rig "$dir/ex/rig.json" --kernel-blend -2
grep -q -- "--kernel-blend" "$dir/err" || fail "bench: a bad --kernel-blend not named"

# a model refuses a corrupt file and a mesh of another topology
head -c 1000 "$dir/ex.msm" >"$dir/cut.msm"
expect_status 2 "$ms" inspect "$dir/cut.msm"
grep -q "cut.msm" "$dir/err" || fail "the error does not name the truncated model"

if [ -d "$data/meshes/horse-gallop" ]; then
    expect_status 2 "$ms" eval --model "$dir/ex.msm" --mesh "$data/meshes/horse-gallop" --frames 1 --json
    grep -q "topology" "$dir/err" || fail "a foreign mesh was not refused for its topology"
    # a harmonic model measured on its own sequence: eval says which mode ran and its oracle floor;
    # with --stretch the oracle (every triangle its own gradient, the same glue) rebuilds the frames
    # and the model's error falls below the rotation-only run's (docs/MODEL.md)
    expect_status 0 "$ms" train --kind harmonic --mesh "$data/meshes/horse-gallop" \
        --correspondences auto:50 -o "$dir/h50.msm"
    expect_status 0 "$ms" eval --model "$dir/h50.msm" --mesh "$data/meshes/horse-gallop" --frames 0:48:8 --json
    cp "$dir/out" "$dir/hrot.json"
    grep -q '"harmonic_mode":[[:space:]]*"rotation"' "$dir/hrot.json" || fail "eval: no rotation mode"
    expect_status 0 "$ms" eval --model "$dir/h50.msm" --mesh "$data/meshes/horse-gallop" --frames 0:48:8 \
        --stretch --json
    cp "$dir/out" "$dir/hstr.json"
    grep -q '"harmonic_mode":[[:space:]]*"rotation+stretch"' "$dir/hstr.json" || fail "eval --stretch: mode"
    le "$(json_num "$dir/hstr.json" oracle_mean_err)" 1e-6 || fail "eval --stretch: the oracle is not exact"
    le 0.001 "$(json_num "$dir/hrot.json" oracle_mean_err)" || fail "eval: the rotation oracle is exact?"
    le "$(json_num "$dir/hstr.json" mean_err)" "$(json_num "$dir/hrot.json" mean_err)" ||
        fail "eval --stretch: no lower than rotation-only"
    expect_status 0 "$ms" eval --model "$dir/ex.msm" --mesh "$dir/ex/mesh" --frames 1:40:8 --json
    ! grep -q harmonic_mode "$dir/out" || fail "a steering model's eval names a harmonic mode"
    # the paper's real use: a human recording steers the horse
    expect_status 0 "$ms" train --mesh "$data/meshes/horse-gallop" --rig "$src/rigs/horse-human.json" \
        --markers "$data/mocap/bvh/cmu/131_01.bvh" -o "$dir/puppet.msm"
    expect_status 0 "$ms" synth --model "$dir/puppet.msm" --markers "$data/mocap/bvh/cmu/131_03.bvh" \
        -o "$dir/hop.pc2" --json
    cp "$dir/out" "$dir/hop.json"
    cat "$dir/hop.json"
    [ "$(json_num "$dir/hop.json" nonfinite)" = "0" ] || fail "the hop has non-finite values"
    jo=$(json_num "$dir/hop.json" output_jitter) ji=$(json_num "$dir/hop.json" input_jitter)
    awk -v o="$jo" -v i="$ji" 'BEGIN { exit !(o < 2 * i) }' ||
        fail "the horse moves less smoothly (jitter $jo) than twice its input ($ji)"
    # a sane box: within 10 m, feet not far below the floor
    lo=$(grep '"bbox_min"' "$dir/hop.json" | grep -o '\[.*\]' | tr -d '[] \t')
    hi=$(grep '"bbox_max"' "$dir/hop.json" | grep -o '\[.*\]' | tr -d '[] \t')
    awk -v lo="$lo" -v hi="$hi" 'BEGIN { split(lo, a, ","); split(hi, b, ",");
        for (i = 1; i <= 3; i++) if (b[i] - a[i] > 10 || b[i] - a[i] <= 0) exit 1;
        exit !(a[2] > -0.5) }' || fail "the hop leaves a sane box: $lo .. $hi"
    expect_status 0 "$ms" render --mesh "$dir/hop.pc2" --rest "$data/meshes/horse-gallop/0001.obj" \
        --frames 0:1102:92 -o "${MESHSTEER_BUILD:-$dir}/hop-contact-sheet.png"
    # the BVH-trained puppet driven by the depth sources' marker set (head, lhand, rhand, lfoot,
    # rfoot, torso) through the README's label map: the samba dancer's rig vertices as markers
    if [ -f "$data/meshes/samba/samba.pc2" ]; then
        expect_status 0 "$ms" markers --mesh "$data/meshes/samba/samba.pc2" \
            --rest "$data/meshes/samba/rest.obj" --rig "$src/rigs/samba-depth.json" -o "$dir/depth.csv"
        head -1 "$dir/depth.csv" | grep -q "torso_x,.*lhand_x,.*rfoot_z" || fail "depth.csv header"
        # without a map the reference markers (Hips, Neck, LeftShoulder) are absent: refused
        expect_status 2 "$ms" synth --model "$dir/puppet.msm" --markers "$dir/depth.csv" -o "$dir/d.pc2"
        grep -q -- "--labels" "$dir/err" || fail "the unbound puppet's error does not mention --labels"
        grep -q "no marker 'Hips'" "$dir/err" || fail "the missing Hips are not named"
        expect_status 2 "$ms" synth --model "$dir/puppet.msm" --markers "$dir/depth.csv" \
            -o "$dir/d.pc2" --labels "Hips=torso,Neck=head,LeftShoulder"
        grep -q "entry 3 'LeftShoulder': expected MODEL=LABEL" "$dir/err" || fail "bad map message"
        expect_status 2 "$ms" synth --model "$dir/puppet.msm" --markers "$dir/depth.csv" \
            -o "$dir/d.pc2" --labels "Hips=torso,Hips=head"
        grep -q "already mapped by entry 1" "$dir/err" || fail "duplicate model label accepted"
        sed '1s/\([a-z]*\)_\([xyz]\)/cam\1_\2/g' "$dir/depth.csv" >"$dir/cam.csv" # camhead_x, ...
        expect_status 2 "$ms" synth --model "$dir/puppet.msm" --markers "$dir/cam.csv" -o "$dir/d.pc2"
        grep -q "none of the model's 8 markers is among the file's 6 markers.*--labels" "$dir/err" ||
            fail "a model with no marker in the file: the error does not mention --labels"
        map="Hips=torso,Neck=head,LeftToe_End=lfoot,RightToe_End=rfoot,LeftShoulder=lhand,Tail=torso"
        expect_status 0 "$ms" synth --model "$dir/puppet.msm" --markers "$dir/depth.csv" \
            -o "$dir/d.pc2" --labels "$map" --json
        cp "$dir/out" "$dir/d.json"
        grep -q "no marker 'Head_End'.*counts as missing" "$dir/err" ||
            fail "the unmapped Head_End is not reported missing"
        grep -q "warning: --labels: label map entry 6 'Tail=torso'" "$dir/err" ||
            fail "no warning for a map entry the model does not use"
        [ "$(json_num "$dir/d.json" frames)" = "175" ] || fail "depth-driven synth: frame count"
        [ "$(json_num "$dir/d.json" nonfinite)" = "0" ] || fail "depth-driven synth: non-finite"
        [ "$(json_num "$dir/d.json" frames_without_reference)" = "0" ] ||
            fail "depth-driven synth: frames without reference edge"
        lo=$(grep '"bbox_min"' "$dir/d.json" | grep -o '\[.*\]' | tr -d '[] \t')
        hi=$(grep '"bbox_max"' "$dir/d.json" | grep -o '\[.*\]' | tr -d '[] \t')
        awk -v lo="$lo" -v hi="$hi" 'BEGIN { split(lo, a, ","); split(hi, b, ",");
            for (i = 1; i <= 3; i++) if (b[i] - a[i] > 10 || b[i] - a[i] <= 0) exit 1;
            exit !(a[2] > -0.5 && b[2] < 3) }' || fail "the depth-driven horse leaves a sane box: $lo .. $hi"
        echo "depth labels -> puppet: box $lo .. $hi"
    fi
fi

# the harmonic kind's real use (issue 9): the static human driven by CMU BVH and the HDM05 ASF/AMC
# take, through the command line; contact sheets of the hop, the walk and the HDM05 take in the
# build directory. tests/model/harmonic/
# test_human.c checks feet, jitter and triangle areas frame by frame.
human="$data/meshes/static-human/human_man.obj"
if [ -f "$human" ] && [ -f "$data/mocap/bvh/cmu/131_03.bvh" ]; then
    for take in 131_03 131_01 hdm05-dg; do
        bvh="$data/mocap/bvh/cmu/$take.bvh" rig="$src/rigs/human-cmu-harmonic.json"
        if [ "$take" = hdm05-dg ]; then
            bvh="$data/mocap/asf_amc/hdm05/HDM_dg_06-03_03_120.amc" rig="$src/rigs/human-asf-harmonic.json"
            [ -f "$bvh" ] || continue
        fi
        expect_status 0 "$ms" train --kind harmonic --mesh "$human" --rig "$rig" \
            --template "$bvh" -o "$dir/human.msm"
        # without --fit-rest the file's joint rotations are not used (they would turn the T-posed
        # limbs about the template's hanging rest axes: docs/MODEL.md); its markers drive it
        expect_status 0 "$ms" synth --model "$dir/human.msm" --markers "$bvh" -o "$dir/human.pc2" --json
        cp "$dir/out" "$dir/human.json"
        [ "$(json_num "$dir/human.json" nonfinite)" = "0" ] || fail "human $take: non-finite values"
        jb=$(json_num "$dir/human.json" joint_bones)
        [ "$jb" = 0 ] || fail "human $take without --fit-rest: $jb bones driven by joint rotations"
        jo=$(json_num "$dir/human.json" output_jitter) ji=$(json_num "$dir/human.json" input_jitter)
        awk -v o="$jo" -v i="$ji" 'BEGIN { exit !(o < 2 * i) }' ||
            fail "human $take: jitter $jo is more than twice its input's ($ji)"
        # on the floor, not 1.2 m above it (the rest pose's root is at the origin, the frames'
        # at the hip height)
        lo=$(grep '"bbox_min"' "$dir/human.json" | grep -o '\[.*\]' | tr -d '[] \t')
        awk -v lo="$lo" 'BEGIN { split(lo, a, ","); exit !(a[2] > -0.15 && a[2] < 0.15) }' ||
            fail "human $take: lowest point $lo is not near the floor"
        echo "human $take: jitter $jo (input $ji), box from $lo"
        n=$(json_num "$dir/human.json" frames)
        expect_status 0 "$ms" render --mesh "$dir/human.pc2" --rest "$human" --frames "0:$n:$((n / 12))" \
            -o "${MESHSTEER_BUILD:-$dir}/human-$take-contact-sheet.png"
    done
    # the hop again with the template's rest pose fitted to the T-posed man (--fit-rest, opt-in:
    # docs/MODEL.md), for its contact sheet; test_human.c checks its feet
    bvh="$data/mocap/bvh/cmu/131_03.bvh"
    expect_status 0 "$ms" train --kind harmonic --mesh "$human" --rig "$src/rigs/human-cmu-harmonic.json" \
        --template "$bvh" --fit-rest -o "$dir/hf.msm"
    # with the fit the file's joint rotations drive the bones (twist included; the default), and
    # --no-joints leaves the markers alone
    expect_status 0 "$ms" synth --model "$dir/hf.msm" --markers "$bvh" -o "$dir/hf-markers.pc2" --json --no-joints
    [ "$(json_num "$dir/out" joint_bones)" = 0 ] || fail "human 131_03 --fit-rest --no-joints: joints used"
    expect_status 0 "$ms" synth --model "$dir/hf.msm" --markers "$bvh" -o "$dir/hf.pc2" --json
    [ "$(json_num "$dir/out" nonfinite)" = "0" ] || fail "human 131_03 --fit-rest: non-finite values"
    jb=$(json_num "$dir/out" joint_bones)
    [ "$jb" -gt 0 ] || fail "human 131_03 --fit-rest: no bone driven by the file's joint rotations"
    echo "human 131_03 --fit-rest: $jb bones by joint rotations"
    expect_status 0 "$ms" render --mesh "$dir/hf.pc2" --rest "$human" --frames "0:1102:92" \
        -o "${MESHSTEER_BUILD:-$dir}/human-131_03-fit-rest-contact-sheet.png"
    # hand-placed correspondences (--correspondences FILE, docs/FORMATS.md): one triangle each on
    # the left thigh and upper arm, completed by their cross-sections (normal to the bone: with the
    # rest fit the T-posed arm's bone lies along it, without it the hanging template arm cuts a
    # strip along the arm); the other bones stay automatic (8 each). The contact sheet colours
    # every bone's triangles.
    bvh="$data/mocap/bvh/cmu/131_03.bvh"
    expect_status 0 "$ms" train --kind harmonic --mesh "$human" --rig "$src/rigs/human-cmu-harmonic.json" \
        --template "$bvh" --fit-rest --correspondences "$src/tests/data/harmonic/human_corr.json" \
        -o "$dir/hc.msm"
    expect_status 0 "$ms" inspect "$dir/hc.msm"
    for b in "LeftHip -> LeftKnee" "LeftShoulder -> LeftElbow"; do
        n=$(grep "$b" "$dir/out" | sed -n 's/.*: \([0-9]*\) triangles/\1/p')
        [ -n "$n" ] && [ "$n" -gt 8 ] || fail "--correspondences FILE: $b has '$n' triangles, no cross-section"
        echo "correspondences file: $b: $n triangles"
    done
    grep -q "RightHip -> RightKnee, twist LeftHip, joint RightKnee: 8 triangles" "$dir/out" ||
        fail "--correspondences FILE: a bone the file does not name is not automatic"
    expect_status 2 "$ms" train --kind harmonic --mesh "$human" --rig "$src/rigs/human-cmu-harmonic.json" \
        --template "$bvh" --correspondences "$src/tests/data/harmonic/corr_bad_bone.json" -o "$dir/bad.msm"
    grep -q 'corr_bad_bone.json: correspondences\[0\].bone: \["LeftHip", "Nowhere"\] is no limb' "$dir/err" ||
        fail "--correspondences FILE: an unknown bone is not named: $(cat "$dir/err")"
    expect_status 0 "$ms" render --mesh "$human" --model "$dir/hc.msm" --frames 0 --cols 1 --size 640 \
        -o "${MESHSTEER_BUILD:-$dir}/human-correspondences.png"
    expect_status 2 "$ms" render --mesh "$human" --model "$dir/human.pc2" -o "$dir/x.png"
fi

# issue 4's acceptance: markers from the test camera's depth of the samba dancer (2.5 m, facing)
if [ -f "$data/meshes/samba/samba.pc2" ]; then
    expect_status 0 "$ms" depth-eval --mesh "$data/meshes/samba/samba.pc2" \
        --rest "$data/meshes/samba/rest.obj" --rig "$src/rigs/samba-depth.json" --json
    cp "$dir/out" "$dir/depth.json"
    cat "$dir/depth.json"
    [ "$(json_num "$dir/depth.json" frames)" = "175" ] || fail "depth-eval did not score 175 frames"
    grep -o '"within_10cm": {[^}]*}' "$dir/depth.json" >"$dir/within.json" ||
        fail "depth-eval printed no within_10cm"
    for k in head hand foot; do
        v=$(json_num "$dir/within.json" $k)
        awk -v v="$v" 'BEGIN { exit !(v ~ /^[0-9.]+$/ && v + 0 >= 0.9) }' ||
            fail "depth-eval: $k within 10 cm is '$v', below 0.9"
    done
fi
echo "cli: ok"
