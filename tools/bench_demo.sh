#!/usr/bin/env bash
# Wall time, CPU time and peak memory of the README's first command, `femto demo`, and of
# `femto demo --quick`, with the release build, after the build (the figures the README and
# `femto demo --help` point to: benches/demo_results.md keeps each run with its date, commit,
# machine and load). Each run writes into a fresh folder under WORKDIR.
#
# Usage: tools/bench_demo.sh [REPS=1] [WORKDIR=target/bench_demo]
set -euo pipefail
cd "$(dirname "$0")/.."
REPS=${1:-1}
WORK=${2:-target/bench_demo}
cargo build --quiet --release --bin femto
FEMTO=target/release/femto
mkdir -p "$WORK"
echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git rev-parse --short HEAD)"
echo "machine: $(uname -srm), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
printf '%-16s %8s %8s %8s %10s\n' command wall_s cpu_s peak_gb load_before
for flags in "--quick" ""; do
    for _ in $(seq "$REPS"); do
        out="$WORK/demo"
        rm -rf "$out"
        load=$(cut -d' ' -f1 /proc/loadavg)
        # shellcheck disable=SC2086
        /usr/bin/time -f "%e %U %S %M" -o "$WORK/time.txt" "$FEMTO" demo $flags --out "$out" >/dev/null 2>"$WORK/stderr.txt"
        awk -v name="demo ${flags:-(full)}" -v load="$load" \
            '{ printf "%-16s %8.1f %8.1f %8.2f %10s\n", name, $1, $2 + $3, $4 / 1048576, load }' \
            "$WORK/time.txt"
    done
done
