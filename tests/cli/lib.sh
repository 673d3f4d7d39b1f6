# lib.sh - what the command-line test scripts share (sourced by tests/cli/test_*.sh): a scratch
# directory removed at exit, fail, expect_status, json_num and le.
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
expect_status() { # expect_status N command...: runs it with output in $dir/out and $dir/err
    local want=$1; shift
    set +e
    "$@" >"$dir/out" 2>"$dir/err"
    local got=$?
    set -e
    [ "$got" -eq "$want" ] || { cat "$dir/err" >&2; fail "$* exited $got, expected $want"; }
}
json_num() { # json_num FILE KEY -> the number after "KEY":
    sed -n "s/.*\"$2\":[[:space:]]*\\([-0-9.e+]*\\).*/\\1/p" "$1" | head -1
}
le() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a <= b) }'; } # a <= b, as numbers
