#!/usr/bin/env bash
# test_recordings.sh - recordings/ is what its command makes: scripts/recordings.sh (the
# commands of recordings/README.md) run again into a scratch directory gives every committed
# file byte for byte (the .oni included: OpenNI2's recorder stores the test camera's device
# timestamps, not the wall clock). Then `meshsteer osc-play` sends the committed OSC capture to
# liblo's oscdump, which must receive every message, and `meshsteer record` refuses bad usage.
# Usage: test_recordings.sh MESHSTEER SRC_DIR BUILD_DIR
set -euo pipefail
ms=$1 src=$2 build=$3
source "$(dirname "$0")/lib.sh"

"$src/scripts/recordings.sh" "$build" "$dir/rec" >"$dir/make.log" 2>&1 ||
    { cat "$dir/make.log" >&2; fail "scripts/recordings.sh failed"; }
( cd "$src/recordings" && find . -type f ! -name README.md | sort ) >"$dir/committed"
( cd "$dir/rec" && find . -type f | sort ) >"$dir/made"
diff "$dir/committed" "$dir/made" >&2 || fail "the command makes other files than recordings/ holds"
while read -r f; do
    cmp "$src/recordings/$f" "$dir/rec/$f" || fail "recordings/$f differs from what its command makes"
done <"$dir/committed"
echo "recordings: $(wc -l <"$dir/committed") files made again, byte for byte equal:"
( cd "$src/recordings" && du -b -c $(cat "$dir/committed") | tail -1 )

# the OSC capture through osc-play to liblo's oscdump (every message, in order)
command -v oscdump >/dev/null || fail "oscdump is missing (liblo-tools is in scripts/run.sh's PACKAGES)"
port=$(( 30000 + $$ % 20000 ))
oscdump -L "$port" >"$dir/dump.txt" 2>"$dir/dump.err" &
dump=$!
trap 'kill $dump 2>/dev/null || true; rm -rf "$dir"' EXIT
sleep 0.5
expect_status 0 "$ms" osc-play "$src/recordings/example-trot.osc" "127.0.0.1:$port" --speed 8
grep -q "240 datagrams sent" "$dir/out" || fail "osc-play: $(cat "$dir/out")"
for i in $(seq 50); do
    [ "$(grep -c ' /marker sfff ' "$dir/dump.txt" || true)" -ge 1920 ] && break
    sleep 0.1
done
kill $dump 2>/dev/null || true
n=$(grep -c ' /marker sfff ' "$dir/dump.txt" || true)
[ "$n" -eq 1920 ] || fail "oscdump received $n /marker messages, expected 240 x 8"
head -1 "$dir/dump.txt" | grep -q ' /marker sfff "lf_foot" ' || fail "first message: $(head -1 "$dir/dump.txt")"
echo "osc-play: oscdump received all $n /marker messages"

# bad usage
expect_status 0 "$ms" record --help
expect_status 2 "$ms" record
expect_status 2 "$ms" record sounds -o "$dir/x"
grep -q "unknown recording" "$dir/err" || fail "no message for an unknown recording"
expect_status 2 "$ms" record markers -o "$dir/x.bvh"
expect_status 2 "$ms" record depth -o "$dir/rec/depth-fakenect" --frames 3 --every 1
grep -q "INDEX.txt" "$dir/err" || fail "an existing dump is not named: $(cat "$dir/err")"
expect_status 2 "$ms" record oni -o "$dir/y.oni"
expect_status 2 "$ms" osc-play "$dir/rec/example-trot.c3d" 127.0.0.1:9
grep -q "not an OSC capture" "$dir/err" || fail "osc-play took a C3D: $(cat "$dir/err")"
expect_status 2 "$ms" osc-play "$src/recordings/example-trot.osc" nohostport
echo "ok"
