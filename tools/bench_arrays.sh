#!/usr/bin/env bash
# Benchmark of `femto ingest` on an array file: LCT's confocal capture data_s_u.mat
# (MATLAB v5, compressed, rect_data 64 x 64 x 2048 uint16) into a cube, REPS times with the
# file in the page cache (one untimed warm-up first). Prints the wall seconds of each run
# and the best; goal: under 1 s (release build).
#
# Usage: tools/bench_arrays.sh [REPS=5] [FILE=../shared/data/real/lct/data_s_u.mat]
set -euo pipefail
cd "$(dirname "$0")/.."
REPS=${1:-5}
FILE=${2:-../shared/data/real/lct/data_s_u.mat}
cargo build --release --bin femto
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
run() {
    target/release/femto ingest "$FILE" -o "$WORK/cube.h5" --dt-ps 4 --confocal \
        --wall-size-m 0.7 >/dev/null
}
run
best=
for i in $(seq 1 "$REPS"); do
    s=$(date +%s.%N)
    run
    e=$(date +%s.%N)
    t=$(echo "$e - $s" | bc -l)
    printf 'run %d: %.3f s\n' "$i" "$t"
    if [ -z "$best" ] || [ "$(echo "$t < $best" | bc -l)" = 1 ]; then best=$t; fi
done
printf 'best of %d: %.3f s (%s -> %s bytes)\n' "$REPS" "$best" "$FILE" "$(stat -c %s "$WORK/cube.h5")"
