#!/usr/bin/env bash
# run_viewer.sh - end-to-end test of the browser viewer: trains the example model, starts
# meshsteerd serving clients/web, runs viewer.mjs (playwright-core + Debian's chromium) against it,
# including a daemon restart on the same port to check that the viewer reconnects by itself.
# Usage: run_viewer.sh MESHSTEERD MAKE_MODEL SCREENSHOT.png        Exit 77 = skipped.
#        run_viewer.sh MESHSTEERD demo:MESHSTEER SCREENSHOT.png
#        run_viewer.sh MESHSTEERD harmonic:MESHSTEER SCREENSHOT.png
# The harmonic form (issue 9): the static human built as a harmonic model from the CMU rig and
# 131_03.bvh, streamed by meshsteerd replaying that BVH in a loop (skips without ../shared/data);
# viewer.mjs then checks frames, changing vertices and no NaN, and saves the screenshot.
# The demo form does what `scripts/run.sh demo` does: `meshsteer demo --out DIR --markers
# recordings/example-trot.c3d`, then meshsteerd
# on DIR/model.msm replaying DIR/trot.csv with no --web-root (the viewer it finds by itself).
set -euo pipefail
meshsteerd=$1 make_model=$2 shot=$3
. "$(dirname "$0")/browser.sh" # sets here and web, or skips

dir=$(mktemp -d "${MESHSTEER_BUILD:-/tmp}/e2e-XXXXXX")
cleanup() {
    [ -f "$dir/pid" ] && kill "$(cat "$dir/pid")" 2>/dev/null || true
    sleep 0.2
    rm -rf "$dir"
}
trap cleanup EXIT
webarg="--web-root \"$web\""
source_file=$dir/trot.csv
case "$make_model" in
harmonic:*)
    data=${MESHSTEER_DATA:-$here/../../../../shared/data}
    src=${MESHSTEER_SRC:-$here/../../..}
    source_file=$data/mocap/bvh/cmu/131_03.bvh
    [ -f "$source_file" ] && [ -f "$data/meshes/static-human/human_man.obj" ] ||
        { echo "skip: no static-human or 131_03.bvh in $data"; exit 77; }
    "${make_model#harmonic:}" train --kind harmonic --mesh "$data/meshes/static-human/human_man.obj" \
        --rig "$src/rigs/human-cmu-harmonic.json" --template "$source_file" -o "$dir/example.msm" \
        2>"$dir/train.txt"
    export MESHSTEER_KIND=harmonic
    ;;
demo:*)
    "${make_model#demo:}" demo --out "$dir" --markers "${MESHSTEER_SRC:-$here/../../..}/recordings/example-trot.c3d" \
        >"$dir/demo.txt"
    cp "$dir/model.msm" "$dir/example.msm"
    webarg=""
    ;;
*)
    "$make_model" "$dir" >/dev/null
    ;;
esac

# start.sh PORT: starts the daemon in the background, waits until it listens, prints the port
cat >"$dir/start.sh" <<EOS
#!/usr/bin/env bash
: >"$dir/log.\$\$"
"$meshsteerd" --model "$dir/example.msm" --source "replay:$source_file?loop=1" \
    --listen 127.0.0.1:\$1 $webarg 2>"$dir/log.\$\$" </dev/null >/dev/null &
echo \$! >"$dir/pid"
for i in \$(seq 100); do
    p=\$(sed -n 's|.*listening on http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$dir/log.\$\$")
    [ -n "\$p" ] && { echo "\$p"; exit 0; }
    sleep 0.1
done
cat "$dir/log.\$\$" >&2
exit 1
EOS
chmod +x "$dir/start.sh"
port=$("$dir/start.sh" 0)
# the restart keeps the port, as a systemd restart would
export MESHSTEER_RESTART_CMD="kill \$(cat '$dir/pid'); sleep 1; '$dir/start.sh' $port >/dev/null"
export MESHSTEER_WEB_DIR=$web
export MESHSTEER_MARKERS=$source_file  # what the source replays (the playback checks match it)
node "$here/viewer.mjs" "http://127.0.0.1:$port/" "$shot"
