#!/usr/bin/env bash
# recordings.sh - makes the files of recordings/ (recordings/README.md says what each is) with
# our own code, from the built-in example; every file comes out with the same bytes each time.
#   scripts/recordings.sh [BUILD_DIR [OUT_DIR]]     defaults: build, recordings
# The .oni goes through OpenNI2 itself: its recorder, fed by the test-camera driver plugin
# (build/drivers/libMeshsteerTestCam.so.0). Debian's libOpenNI2 loads drivers only from
# "OpenNI2/Drivers" beside the libOpenNI2.so.0 it was loaded from, so the script stages a copy of
# the library with the plugin beside it in a scratch directory (as tests/drivers/test_openni2.c
# does) and runs `meshsteer record oni` with LD_LIBRARY_PATH pointing there.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
out=${2:-$root/recordings}
ms=$build/server/meshsteer
plugin=$build/drivers/libMeshsteerTestCam.so.0
[ -x "$ms" ] && [ -f "$plugin" ] || { echo "recordings.sh: build first (meson compile -C $build)" >&2; exit 2; }
mkdir -p "$out"
scratch=$(mktemp -d "${TMPDIR:-/tmp}/meshsteer-recordings-XXXXXX")
trap 'rm -rf "$scratch"' EXIT

# the example's trot marker take (what `meshsteer example` writes as markers.csv, 240 frames)
"$ms" record markers -o "$out/example-trot.c3d"
# the same take as an OSC capture: one bundle of /marker messages per frame, 30 per second
"$ms" record osc -o "$out/example-trot.osc"
# 3 s of the trot seen by the test camera, without its disparity noise (see the README):
# one frame a second as a fakenect dump, five a second through OpenNI2's recorder
rm -rf "$out/depth-fakenect"
"$ms" record depth -o "$out/depth-fakenect" --frames 90 --every 30 --noise 0
"$ms" record depth -o "$scratch/dump" --frames 90 --every 6 --noise 0

lib=$(ldd "$ms" | sed -n 's|.*libOpenNI2.so.0 => \(/[^ ]*\).*|\1|p')
[ -n "$lib" ] || { echo "recordings.sh: $ms is not linked with libOpenNI2.so.0" >&2; exit 2; }
mkdir -p "$scratch/stage/OpenNI2/Drivers"
cp "$lib" "$scratch/stage/"
cp "$plugin" "$scratch/stage/OpenNI2/Drivers/"
rm -f "$out/depth.oni"
LD_LIBRARY_PATH=$scratch/stage "$ms" record oni --dump "$scratch/dump" -o "$out/depth.oni"
