#!/usr/bin/env bash
# Compile-time cost of `metriplectic!` on a large system: tests/large_system.rs
# declares a 6-state system with entropy degree 8 (3002 entropy monomials) and
# metric degree 4 (210 metric monomials per entry, 4410 θ).
#
# Measures, after touching the file so that only it is rebuilt:
#   * `cargo check` of the test (macro expansion + type checking, no codegen),
#   * `cargo build` of the test, debug (the workspace's test profile) and release,
#   * the machine code generated for the system (sum of symbol sizes of `Chain`),
#   * with --expand (needs a nightly toolchain; builds in its own target dir,
#     a few minutes the first time): the size of the expanded source.
#
# Debug builds are incremental (the workspace default), so a touch re-runs
# the macro but rustc may reuse cached results of later passes; for a
# from-scratch compile of the test crate run
# `CARGO_INCREMENTAL=0 scripts/compile_time.sh` (this rebuilds the workspace
# crates once, untimed, and again on the next normal build).
#
# Usage: scripts/compile_time.sh [--expand]
# Each timed command is run once untimed first, so dependencies and other
# changes in the checkout are not counted; a timed run that rebuilds more
# than the test is reported as an error.
set -euo pipefail
cd "$(dirname "$0")/.."

TEST=large_system
FILE=tests/$TEST.rs

LOG=$(mktemp)
trap 'rm -f "$LOG"' EXIT

seconds() {
    # Runs "$@" once to absorb any other change in the checkout, then again
    # after touching the file; prints the wall seconds of the second run.
    # Stops with cargo's output if a command failed or if cargo rebuilt more
    # than the test (then the time would not be the macro's).
    "$@" >"$LOG" 2>&1 || { echo "failed: $*" >&2; cat "$LOG" >&2; exit 1; }
    touch "$FILE"
    local start end
    start=$(date +%s.%N)
    "$@" >"$LOG" 2>&1 || { echo "failed: $*" >&2; cat "$LOG" >&2; exit 1; }
    end=$(date +%s.%N)
    if [[ $(grep -cE '^ *(Compiling|Checking) ' "$LOG") != 1 ]] ||
        ! grep -qE '^ *(Compiling|Checking) metriplectic v' "$LOG"; then
        echo "cargo rebuilt more than the test (someone changed the sources?): $*" >&2
        cat "$LOG" >&2
        exit 1
    fi
    echo "$end - $start" | bc
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "rustc:   $(rustc --version); CARGO_INCREMENTAL=${CARGO_INCREMENTAL:-default}"
echo "load:    $(cut -d' ' -f1-3 /proc/loadavg) (other builds on the machine inflate the times)"
echo

check=$(seconds cargo check --tests --test "$TEST") || exit 1
debug=$(seconds cargo build --tests --test "$TEST") || exit 1
release=$(seconds cargo build --release --tests --test "$TEST") || exit 1

echo "| step | seconds |"
echo "|---|---|"
echo "| cargo check (expansion + type check) | $check |"
echo "| cargo build, test profile (debug, opt-level 1) | $debug |"
echo "| cargo build --release | $release |"
echo

binary_size() {
    # Sum of the sizes of the generated system's functions in a test binary.
    local binary
    binary=$(ls -t target/"$1"/deps/"$TEST"-* | grep -v '\.d$' | head -1)
    local total=0 size
    while read -r size; do
        total=$((total + 16#$size))
    done < <(nm -S -C --size-sort "$binary" | grep -E 'Chain' | awk '{ print $2 }')
    echo "$total"
}
echo "machine code of Chain's functions: debug $(binary_size debug) bytes, release $(binary_size release) bytes"

if [[ "${1:-}" == "--expand" ]]; then
    out=target/bench-data/large_system.expanded.rs
    mkdir -p target/bench-data
    start=$(date +%s.%N)
    cargo +nightly rustc --profile=check --test "$TEST" --target-dir wip/expand-target \
        -- -Zunpretty=expanded >"$out" 2>/dev/null
    end=$(date +%s.%N)
    echo "expanded source: $(wc -c <"$out") bytes, $(wc -l <"$out") lines ($out; nightly run took $(echo "$end - $start" | bc) s including its dependency build)"
fi
