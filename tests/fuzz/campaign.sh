#!/usr/bin/env bash
# campaign.sh - a libFuzzer campaign over every fuzz target, seeded from the repository's test
# inputs and ../shared/data.
#
#   tests/fuzz/campaign.sh SECONDS [TARGET...]
#
# SECONDS per target (CI: 20). Without TARGETs, every fuzz_* program of the fuzz build runs in turn.
# The fuzz build is build-fuzz/ (BUILD=dir to use another), configured on first use as
#   CC=clang meson setup build-fuzz -Dfuzz=true
# which instruments the libraries too (-fsanitize=fuzzer-no-link) and builds them with ASan and
# UBSan (meson.build). Per target:
#   build-fuzz/fuzz/corpus/TARGET/   the corpus libFuzzer grows (kept between runs)
#   build-fuzz/fuzz/seeds/TARGET/    the seeds: tests/data, tests/server/data and files of the
#                                    target's format in ../shared/data (at most 24, < 1 MB each)
#   build-fuzz/fuzz/found/TARGET/    crash-*, leak-*, timeout-*, oom-* inputs. A found input is
#                                    kept, with its fix, as a regression seed: in
#                                    tests/fuzz/found/TARGET/ (later campaigns start from it) and
#                                    in the target's seed list in the meson.build that registers
#                                    it (every test run feeds it to the target)
#   build-fuzz/fuzz/TARGET.log       libFuzzer's output
# Exit status: 0 when no target found anything, 1 otherwise (the targets that did are listed),
# 2 on bad usage. MAX_LEN (bytes, default 65536) bounds the inputs libFuzzer makes up.
set -euo pipefail
cd "$(dirname "$0")/../.."

secs=${1:-}
if ! [[ "$secs" =~ ^[0-9]+$ ]] || [ "$secs" -eq 0 ]; then
    echo "usage: tests/fuzz/campaign.sh SECONDS [TARGET...]" >&2
    exit 2
fi
shift
build=${BUILD:-build-fuzz}
data=${MESHSTEER_DATA:-../shared/data}
max_len=${MAX_LEN:-65536}

if [ ! -f "$build/build.ninja" ]; then
    CC=clang meson setup "$build" -Dfuzz=true
fi
# only the fuzz targets (and the model seed), named as meson compile takes them: SUBDIR/NAME
fuzz_outputs() {
    meson introspect "$build" --targets | python3 -c '
import json, os, sys
src = os.getcwd()
for t in json.load(sys.stdin):
    if t["name"].startswith("fuzz_") or t["name"] == "model_seed":
        print(os.path.relpath(os.path.dirname(t["defined_in"]), src) + "/" + t["name"])'
}
mapfile -t outputs < <(fuzz_outputs)
meson compile -C "$build" -j 2 "${outputs[@]}" >/dev/null

# the seeds of a target: TARGET -> files
seeds_of() {
    local t=$1
    local -a local_seeds=() globs=()
    case "$t" in
    obj) local_seeds=(tests/data/poly.obj); globs=('*.obj') ;;
    pc2) local_seeds=(tests/data/tiny.pc2); globs=('*.pc2') ;;
    rig) local_seeds=(tests/data/rig_quadruped.json rigs/*.json) ;;
    corr) local_seeds=(tests/data/harmonic/corr_*.json) ;;
    c3d) globs=('*.c3d') ;;
    trc) globs=('*.trc') ;;
    bvh) local_seeds=(tests/data/markers/*.bvh); globs=('*.bvh') ;;
    csv) local_seeds=(tests/data/markers/*.csv); globs=('*.csv') ;;
    model) local_seeds=("$build/tests/fuzz/seed.msm" "$build/tests/fuzz/seed-harmonic.msm"
                        tests/data/model_v1.msm) ;;
    fakenect) local_seeds=(tests/data/fakenect_INDEX.txt tests/data/fakenect_truncated.pgm
                        recordings/depth-fakenect/INDEX.txt)
              globs=('INDEX.txt' '*.pgm') ;;
    control) local_seeds=(tests/server/data/control_*.json) ;;
    daemon_config) local_seeds=(tests/server/data/meshsteerd.conf server/meshsteerd.conf.example) ;;
    labels) local_seeds=(tests/server/data/labels_*.txt) ;;
    wsframe) local_seeds=(tests/server/data/ws_stream.bin) ;;
    wire_guard) local_seeds=(tests/server/data/guard_upgrade.bin tests/server/data/guard_requests.bin) ;;
    osc_capture) local_seeds=(recordings/example-trot.osc) ;;
    params) local_seeds=(tests/server/data/params_model.bin) ;;
    esac
    for f in "${local_seeds[@]}"; do [ -f "$f" ] && echo "$f"; done
    if [ -d "$data" ]; then
        for g in "${globs[@]}"; do
            find "$data" -type f -name "$g" -size -1024k 2>/dev/null | sort | head -n 24
        done
    fi
    # inputs found by earlier campaigns and kept as regression seeds
    if [ -d "tests/fuzz/found/$t" ]; then
        find "tests/fuzz/found/$t" -type f | sort
    fi
}

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    while IFS= read -r exe; do
        targets+=("$(basename "$exe" | sed 's/^fuzz_//')")
    done < <(find "$build/tests" -type f -perm -u+x -name 'fuzz_*' | sort)
fi
[ ${#targets[@]} -gt 0 ] || { echo "no fuzz targets in $build (configured with -Dfuzz=true?)" >&2; exit 2; }

out=$build/fuzz
failed=()
for t in "${targets[@]}"; do
    exe=$(find "$build/tests" -type f -perm -u+x -name "fuzz_$t" | head -n 1)
    [ -n "$exe" ] || { echo "no target fuzz_$t in $build" >&2; exit 2; }
    mkdir -p "$out/corpus/$t" "$out/seeds/$t" "$out/found/$t"
    n=0
    while IFS= read -r f; do
        cp "$f" "$out/seeds/$t/$n-$(basename "$f")"
        n=$((n + 1))
    done < <(seeds_of "$t")
    # the campaign's own time bounds each input too (-timeout), and memory (-rss_limit_mb)
    set +e
    ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
        "$exe" -max_total_time="$secs" -max_len="$max_len" -timeout=10 -rss_limit_mb=2048 \
        -print_final_stats=1 -artifact_prefix="$out/found/$t/" \
        "$out/corpus/$t" "$out/seeds/$t" >"$out/$t.log" 2>&1
    rc=$?
    set -e
    cov=$(grep -o 'cov: [0-9]*' "$out/$t.log" | tail -n 1 || true)
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$out/$t.log" | grep -o '[0-9]*$' || true)
    if [ $rc -ne 0 ] || [ -n "$(ls -A "$out/found/$t")" ]; then
        echo "fuzz_$t: FOUND something (exit $rc): $out/found/$t, log $out/$t.log"
        failed+=("$t")
    else
        echo "fuzz_$t: ${secs} s, $n seeds, ${runs:-?} runs, ${cov:-cov: ?}, nothing found"
    fi
done
if [ ${#failed[@]} -gt 0 ]; then
    echo "found inputs in: ${failed[*]}" >&2
    exit 1
fi
