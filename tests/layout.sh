#!/usr/bin/env bash
# layout.sh - keeps the module layout of README.md honest (STYLE.md Sec. 1): every folder includes
# only the public headers of the others.
#   1. server/, drivers/ and clients/ include no model header but model.h;
#   2. server/ and clients/ include no driver header but drivers.h and depth.h;
#   3. model/core/ includes nothing from model/'s method and format folders (steer/, formats/,
#      harmonic/, skin/, variations/, example/): the core is what they stand on.
# The unit tests of internals (tests/) may include private headers and are not checked.
# An include is resolved as the compiler does for quotes: first beside the including file (a
# local header of the same name is that folder's own), then from a module's root ("core/util.h"
# under model/, "depth/v4l2.h" under drivers/), with any leading ../ and module name removed.
# Reads the tracked files (and untracked ones not ignored) through git grep; skips (77) outside
# a git checkout.
# Usage: tests/layout.sh [SOURCE_ROOT]
set -uo pipefail
root=${1:-${MESHSTEER_SRC:-.}}
cd "$root" || exit 1
if ! git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    echo "skip: $root is not a git checkout"
    exit 77
fi

# tracked and untracked (not ignored) files, as git grep --untracked sees them
exists() { [ -n "$(git ls-files --cached --others --exclude-standard -- "$1" 2>/dev/null)" ]; }

bad=0
# includes FOLDER...: "file:line:header" for every quoted #include in the C files of FOLDERs
includes() {
    local specs=() f
    for f in "$@"; do specs+=("$f/*.c" "$f/*.h"); done
    git grep --untracked -n -E '^[[:space:]]*#[[:space:]]*include[[:space:]]*"[^"]+"' -- "${specs[@]}" |
        sed -E 's/^([^:]+):([0-9]+):.*"([^"]+)".*$/\1:\2:\3/'
}
# strip PATH MODULE: the path without leading ../ and MODULE/
strip() {
    local rel=$1
    while [ "${rel#../}" != "$rel" ]; do rel=${rel#../}; done
    echo "${rel#"$2"/}"
}

# beside FILE INC: the path (from the root) of INC next to FILE, when that file exists
beside() {
    local p
    p=$(realpath -m --relative-to=. "$(dirname "$1")/$2")
    exists "$p" && echo "$p"
}

# check "FOLDER..." MODULE PUBLIC...: no file in FOLDERs includes a header of MODULE but PUBLIC
check() {
    local folders=$1 module=$2 file line inc rel near
    shift 2
    local public=" $* "
    while IFS=: read -r file line inc; do
        near=$(beside "$file" "$inc")
        if [ -n "$near" ]; then
            [ "${near#"$module"/}" = "$near" ] && continue # a header of another folder: its own
            rel=${near#"$module"/}
        else
            rel=$(strip "$inc" "$module")
        fi
        if exists "$module/$rel" && [[ "$public" != *" $rel "* ]]; then
            echo "$file:$line: includes \"$inc\", a private header of $module/ (public: $*)"
            bad=1
        fi
    done < <(includes $folders)
}

check "server drivers clients" model model.h
check "server clients" drivers drivers.h depth.h

# 3. the core stands below the methods and formats
while IFS=: read -r file line inc; do
    near=$(beside "$file" "$inc")
    if [ -n "$near" ]; then rel=${near#model/}; else rel=$(strip "$inc" model); fi
    case $rel in
    steer/* | formats/* | harmonic/* | skin/* | variations/* | example/*)
        echo "$file:$line: model/core includes \"$inc\" (the core must not depend on ${rel%%/*}/)"
        bad=1
        ;;
    esac
done < <(includes model/core)

if [ $bad -ne 0 ]; then
    echo "layout: includes across module boundaries (README.md, Layout; STYLE.md Sec. 1)" >&2
    exit 1
fi
echo "layout: ok"
