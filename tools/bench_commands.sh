#!/usr/bin/env bash
# Wall time, CPU time, peak memory and output size of `femto unwarp` and `femto pyramid` on a
# cube of the seed's size (672 x 600 pixels, 512 bins of 1.71 ps), files in the page cache.
#
# The cube is made once, as a user would: `femto simulate --paper-size --realistic` (1 spp,
# 2 bounces: photon noise, dark noise and the other flaws make it dense, like real data), then
# `femto ingest` with no corrections (the dark offset and its noise stay: every bin holds a
# noisy value, the worst case for compression). unwarp casts the capture's own calibration
# through its scene.glb; pyramid runs into a side file and in place (on a copy of the cube);
# each at the compressions a user would pick.
# The in-memory kernels alone are timed by tools/bench_cubeops.sh.
#
# Usage: tools/bench_commands.sh [REPS=2] [WORKDIR=target/bench_commands]
set -euo pipefail
cd "$(dirname "$0")/.."
REPS=${1:-2}
WORK=${2:-target/bench_commands}
cargo build --quiet --release --bin femto
FEMTO=target/release/femto
mkdir -p "$WORK"
CAP="$WORK/capture"
CUBE="$WORK/camera.h5"
if [ ! -f "$CUBE" ]; then
    rm -rf "$CAP"
    "$FEMTO" simulate --paper-size --realistic --spp 1 --bounces 2 --out "$CAP" >/dev/null
    "$FEMTO" ingest "$CAP" --out "$CUBE" >/dev/null
fi
echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git rev-parse --short HEAD)"
echo "machine: $(uname -srm), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "cube: $CUBE, $(du -m "$CUBE" | cut -f1) MB on disk"

# run NAME OUTPUT COMMAND...: time COMMAND REPS times; OUTPUT is removed before each run, or,
# when it is the in-place copy, made afresh from the cube.
run() {
    local name=$1 out=$2
    shift 2
    for _ in $(seq "$REPS"); do
        rm -f "$out"
        if [ "$out" = "$WORK/inplace.h5" ]; then cp "$CUBE" "$out"; fi
        /usr/bin/time -f "%e %U %S %M" -o "$WORK/time.txt" "$@" >/dev/null
        read -r wall user sys rss <"$WORK/time.txt"
        printf "%-32s %6.2f s wall %6.2f CPU s %7.0f MB RSS %7.1f MB written\n" "$name" "$wall" \
            "$(echo "$user + $sys" | bc)" "$(echo "$rss / 1024" | bc)" "$(echo "$(stat -c %s "$out") / 1000000" | bc -l)"
    done
}

for c in 1 4 none; do
    run "unwarp --compression $c" "$WORK/world.h5" "$FEMTO" unwarp "$CUBE" --calibration "$CAP/calibration.toml" \
        --mesh "$CAP/scene.glb" --compression "$c" --out "$WORK/world.h5"
done
for c in none 1; do
    run "pyramid side --compression $c" "$WORK/pyramid.h5" "$FEMTO" pyramid "$CUBE" --compression "$c" \
        --side-file "$WORK/pyramid.h5"
    run "pyramid in place, $c" "$WORK/inplace.h5" "$FEMTO" pyramid "$WORK/inplace.h5" --compression "$c"
done
