#!/usr/bin/env bash
# run_gltf_three.sh - the glTF export read back by a real reader (issue 10): gltf_fixture writes a
# skin of the built-in example creature as skin.glb (loop closed) and once.glb (--gltf-once), and
# our reconstruction of frames 0, N/2, N-1 as expected.bin; gltf_three.mjs loads the .glb with three.js's GLTFLoader in headless chromium
# (playwright-core) and compares its skinned vertices with ours.
# Usage: run_gltf_three.sh GLTF_FIXTURE        Exit 77 = skipped (no node, chromium or npm ci).
set -euo pipefail
fixture=$1
here=$(cd "$(dirname "$0")" && pwd)
web=${MESHSTEER_SRC:-$here/../../..}/clients/web
command -v node >/dev/null || { echo "skip: node not installed"; exit 77; }
[ -x "${CHROMIUM:-/usr/bin/chromium}" ] || { echo "skip: chromium not installed"; exit 77; }
[ -f "$web/node_modules/three/examples/jsm/loaders/GLTFLoader.js" ] && [ -d "$web/node_modules/playwright-core" ] ||
    { echo "skip: run 'npm ci' in clients/web (scripts/run.sh does)"; exit 77; }

dir=$(mktemp -d "${MESHSTEER_BUILD:-/tmp}/gltf-XXXXXX")
trap 'rm -rf "$dir"' EXIT
"$fixture" "$dir"
MESHSTEER_WEB_DIR=$web node "$here/gltf_three.mjs" "$dir"
