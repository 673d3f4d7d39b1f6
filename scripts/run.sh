#!/usr/bin/env bash
# run.sh - the two commands of the README.
#   scripts/run.sh demo   set everything up, then run the main job on the built-in example
#   scripts/run.sh test   set everything up, then run every test
# "Set up" = install missing Debian packages (as root; otherwise print the apt-get line and stop),
# configure meson into build/ and compile.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(build-essential meson ninja-build pkg-config clang libclang-rt-14-dev
          libopenblas-dev liblapacke-dev libcjson-dev libpng-dev
          libwebsockets-dev libsystemd-dev libopenni2-dev libusb-1.0-0-dev libsuitesparse-dev
          liblo-dev liblo-tools chromium valgrind assimp-utils libnats-dev nats-server esbuild)

setup_packages() {
    local missing=()
    for p in "${PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
    done
    # Node.js and npm (for the viewer's three.js) may come from elsewhere than Debian; only when
    # the commands are missing do we ask for Debian's.
    command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1 || missing+=(nodejs npm)
    [ ${#missing[@]} -eq 0 ] && return 0
    if [ "$(id -u)" -ne 0 ]; then
        echo "meshsteer needs these Debian packages; run as root:" >&2
        echo "  apt-get update && apt-get install -y ${missing[*]}" >&2
        exit 2
    fi
    echo "installing: ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null || apt-get update
    apt-get install -y -qq "${missing[@]}" >/dev/null
}

# ---- the daemon: the browser viewer's npm packages (three.js; @nats-io/nats-core for ?nats=,
# bundled for the browser by Debian's esbuild in the package's postinstall; playwright-core for
# its test). Installed from the committed package-lock.json into clients/web/node_modules (not
# committed).
setup_web() {
    local web=clients/web
    [ -f "$web/node_modules/three/build/three.module.js" ] &&
        [ -f "$web/node_modules/.meshsteer/nats-core.js" ] &&
        [ -d "$web/node_modules/playwright-core" ] && return 0
    command -v npm >/dev/null || { echo "npm is missing (apt-get install npm)" >&2; exit 2; }
    (cd "$web" && npm ci --no-audit --no-fund)
}

setup_build() {
    local dir=$1; shift
    if [ ! -f "$dir/build.ninja" ]; then
        meson setup "$dir" "$@"
    fi
    meson compile -C "$dir"
}

cmd=${1:-}
case "$cmd" in
demo)
    setup_packages
    setup_web
    setup_build build
    # train on the built-in example and print the quality report, then stream its trot: the
    # committed take (recordings/README.md), whose first 60 frames demo writes as trot.csv
    build/server/meshsteer demo --out build/demo --markers recordings/example-trot.c3d
    port=${MESHSTEER_PORT:-8080}
    echo
    echo "meshsteerd: open http://127.0.0.1:$port/ in a browser (Ctrl-C stops)"
    exec build/server/meshsteerd --model build/demo/model.msm \
        --source "replay:build/demo/trot.csv?loop=1" --listen "127.0.0.1:$port"
    ;;
test)
    setup_packages
    setup_web
    werror=()
    [ "${CI:-}" = "true" ] && werror=(-Dwerror=true)
    setup_build build "${werror[@]}"
    meson test -C build --print-errorlogs --num-processes 2
    # Once more under AddressSanitizer and UndefinedBehaviorSanitizer: every unit test and fuzz
    # target (the daemon integration tests assert timing and memory, which ASan distorts).
    setup_build build-asan -Db_sanitize=address,undefined -Db_lundef=false "${werror[@]}"
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
        meson test -C build-asan --print-errorlogs --num-processes 2 \
            --suite model --suite drivers --suite server-unit
    # The daemon's integration tests under ASan/UBSan too, and once under ThreadSanitizer: the
    # daemon runs several times slower there, so MESHSTEER_SANITIZED relaxes only their timing
    # checks (tests/server/test_daemon.c). OpenBLAS and OpenNI2 are not instrumented: see
    # tests/server/tsan.supp.
    MESHSTEER_SANITIZED=1 ASAN_OPTIONS=detect_leaks=1 \
        UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
        meson test -C build-asan --print-errorlogs --num-processes 2 --timeout-multiplier 3 \
            --suite server --no-suite server-unit
    export OPENBLAS_NUM_THREADS=1
    export TSAN_OPTIONS="suppressions=$PWD/tests/server/tsan.supp halt_on_error=1"
    setup_build build-tsan -Db_sanitize=thread -Db_lundef=false "${werror[@]}"
    MESHSTEER_SANITIZED=1 meson test -C build-tsan --print-errorlogs --num-processes 2 \
        --timeout-multiplier 3 --suite server
    ;;
*)
    echo "usage: scripts/run.sh demo|test" >&2
    exit 2
    ;;
esac
