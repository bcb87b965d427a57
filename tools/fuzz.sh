#!/usr/bin/env bash
# The longer fuzz run (issue 16): every target of tests/fuzz/ with CASES mutated inputs each
# (FEMTO_FUZZ_CASES), generator seed SEED (FEMTO_FUZZ_SEED), one target at a time, in the
# release profile (PROFILE=dev for the dev profile, whose overflow checks turn a silent
# wrap-around into a failure). Prints per target: executions, executions per second,
# failures (panics, allocations above the bound, slow cases, refusals of a valid seed), and
# the share refused; failing inputs are kept under target/<profile>/../tmp/fuzz/<target>/.
# The CI run is the plain `cargo test --test fuzz` (a few hundred cases per target).
#
# Usage: [PROFILE=dev] [SKIP=target] tools/fuzz.sh [CASES=100000] [SEED=16] [FILTER (a target
# name, e.g. img)]. A hang ends the whole run (exit 3, the case file named); SKIP leaves a
# target with a known, unfixed hang out.
set -euo pipefail
cd "$(dirname "$0")/.."
CASES=${1:-100000}
SEED=${2:-16}
FILTER=${3:-}
PROFILE=${PROFILE:-release}
flag=()
[ "$PROFILE" = release ] && flag=(--release)
log=$(mktemp)
trap 'rm -f "$log"' EXIT
echo "fuzz: $CASES cases per target, seed $SEED, $PROFILE profile, $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores"
start=$(date +%s)
set +e
FEMTO_FUZZ_CASES=$CASES FEMTO_FUZZ_SEED=$SEED cargo test "${flag[@]}" --test fuzz -- \
    --test-threads=1 --nocapture --skip regressions --skip mutations --skip base64 ${SKIP:+--skip $SKIP} $FILTER \
    2>&1 | tee "$log" | grep -a --line-buffered -oE 'fuzz [a-z0-9_]+ .*|^test .*FAILED|panicked.*|refused;.*|hang.*'
status=${PIPESTATUS[0]}
set -e
echo "fuzz: $(( $(date +%s) - start )) s in all, exit $status"
grep -a -oE 'fuzz [a-z0-9_]+ +[0-9]+ executions.*' "$log" | awk '{n += $3; f += $6} END {printf "fuzz: %d executions, %d failures\n", n, f}'
exit "$status"
