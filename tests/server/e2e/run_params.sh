#!/usr/bin/env bash
# run_params.sh - the params encoding in a real browser: meshsteerd streams the example's steering
# model (then, when its replay ends, the skin beside it as the idle animation) and params.mjs
# checks in headless Chromium that the viewer's vertex shader, read back by transform feedback,
# gives the daemon's own float32 vertices within the int16 bound, for both kinds.
# Usage: run_params.sh MESHSTEERD MAKE_MODEL SCREENSHOT.png        Exit 77 = skipped.
set -euo pipefail
meshsteerd=$1 make_model=$2 shot=$3
. "$(dirname "$0")/browser.sh" # sets here and web, or skips
dir=$(mktemp -d "${MESHSTEER_BUILD:-/tmp}/e2e-params-XXXXXX")
pid=
cleanup() {
    [ -n "$pid" ] && kill "$pid" 2>/dev/null || true
    sleep 0.2
    rm -rf "$dir"
}
trap cleanup EXIT
"$make_model" "$dir" >/dev/null
# 240 tracked frames at a quarter speed (32 s), then the source ends and the skin takes over
"$meshsteerd" --model "$dir/two-kinds.msm" --source "replay:$dir/trot.csv?speed=0.25" \
    --listen 127.0.0.1:0 --web-root "$web" 2>"$dir/log" </dev/null >/dev/null &
pid=$!
port=
for _ in $(seq 100); do
    port=$(sed -n 's|.*listening on http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$dir/log")
    [ -n "$port" ] && break
    sleep 0.1
done
[ -n "$port" ] || { cat "$dir/log" >&2; exit 1; }
export MESHSTEER_WEB_DIR=$web
node "$here/params.mjs" "http://127.0.0.1:$port/?encoding=params" "$shot"
