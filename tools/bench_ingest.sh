#!/usr/bin/env bash
# Benchmark of `femto ingest` (issue: "ingest 600 scanlines of 672 x 512 16-bit PNG").
#
# Generates N scanlines with examples/bench_ingest_capture.rs (release), then times, each
# REPS times with the files in the page cache (one untimed warm-up read first):
#   - decode only: `femto ingest --decode-only` (the same parallel reader, no output);
#   - femto ingest at the default compression (shuffle + deflate level 1, miniz_oxide), and
#     with --compression 4 (femto's usual level, h5py's gzip default, what the script writes;
#     libdeflate) and none (no filter);
#   - the plain Python script tools/ingest_baseline.py (numpy + imageio + h5py);
#   - femto ingest of the first N/4 scanlines, to show that peak memory does not grow
#     with the number of scanlines.
# and checks that femto's cube equals the script's. Wall seconds, MB/s of PNG data read, CPU
# seconds, peak RSS (from /usr/bin/time -v) and the size of the file written go to stdout and
# to tools/bench_ingest_results.md (inserted after its header: newest entry first).
# Every femto run passes --no-jitter: jitter removal (the default since issue 15) adds a
# second pass over the scanlines; these figures measure the one-pass assembly.
#
# Usage: tools/bench_ingest.sh [N=600] [REPS=3] [WORKDIR=target/bench_ingest]
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-600}
REPS=${2:-3}
WORK=${3:-target/bench_ingest}
NX=672
NT=512
CAPS="$WORK/caps_${N}x${NX}x${NT}"
RESULTS=tools/bench_ingest_results.md

cargo build --release --bin femto --example bench_ingest_capture
FEMTO=target/release/femto
python3 -c "import numpy, imageio, h5py" 2>/dev/null || pip install numpy imageio h5py

mkdir -p "$WORK"
if [ ! -f "$CAPS/scan_$(printf %04d $((N - 1))).png" ]; then
    target/release/examples/bench_ingest_capture "$CAPS" "$N" "$NX" "$NT"
fi
PATTERN="$CAPS/scan_%04d.png"
BYTES=$(cat "$CAPS"/scan_*.png | wc -c)
QUARTER=$((N / 4))
QBYTES=$(for y in $(seq 0 $((QUARTER - 1))); do printf "$PATTERN\n" "$y"; done | xargs cat | wc -c)
AXIS=(--dt-ps 1.9 --t0-ps 0)

# Warm the page cache so every run reads the same way.
"$FEMTO" ingest "$PATTERN" --rows "$N" "${AXIS[@]}" --decode-only > /dev/null

# run LABEL BYTES CMD...: time CMD REPS times; print "LABEL wall_s MB/s cpu_s rss_MB out_MB"
# per run (CPU seconds, user + system, are disturbed less than wall time by other load; out_MB
# is the size of the file written under $WORK, if any).
run() {
    local label=$1 bytes=$2
    shift 2
    for r in $(seq 1 "$REPS"); do
        rm -f "$WORK"/out_*.h5
        # Untimed: write out what earlier runs left dirty, so no run pays for another's
        # output (each run writes up to 825 MB; femto and h5py close files without fsync).
        sync
        /usr/bin/time -v "$@" > "$WORK/$label.out" 2> "$WORK/$label.time"
        local wall rss
        wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, p, ":"); s = 0;
            for (i = 1; i <= n; i++) s = s * 60 + p[i]; print s}' "$WORK/$label.time")
        rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.1f", $2 / 1024}' "$WORK/$label.time")
        cpu=$(awk -F': ' '/(User|System) time \(seconds\)/ {s += $2} END {printf "%.2f", s}' "$WORK/$label.time")
        local out_mb=-
        for f in "$WORK"/out_*.h5; do
            [ -f "$f" ] && out_mb=$(stat -c %s "$f" | awk '{printf "%.1f", $1 / 1e6}')
        done
        printf "%-24s %8.2f s %8.1f MB/s %8.2f s CPU %8.1f MB RSS %8s MB out\n" "$label" "$wall" \
            "$(echo "$bytes / 1000000 / $wall" | bc -l)" "$cpu" "$rss" "$out_mb"
    done
}

{
    echo "## $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)), load $(cut -d' ' -f1-3 /proc/loadavg)"
    echo
    echo "commit $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src || echo ' (plus uncommitted changes)'); command: tools/bench_ingest.sh $N $REPS"
    echo
    echo "$N scanlines of $NX x $NT 16-bit PNG, $(echo "$BYTES / 1000000" | bc -l | xargs printf %.1f) MB; $REPS runs each"
    echo
    echo '```'
    run decode_only "$BYTES" "$FEMTO" ingest "$PATTERN" --rows "$N" "${AXIS[@]}" --decode-only
    run femto_deflate4 "$BYTES" "$FEMTO" ingest "$PATTERN" --rows "$N" "${AXIS[@]}" --no-jitter -o "$WORK/out_femto.h5" --compression 4
    cp "$WORK/out_femto.h5" "$WORK/kept_femto.h5" 2>/dev/null || true
    run femto_deflate1_default "$BYTES" "$FEMTO" ingest "$PATTERN" --rows "$N" "${AXIS[@]}" --no-jitter -o "$WORK/out_femto.h5"
    run femto_uncompressed "$BYTES" "$FEMTO" ingest "$PATTERN" --rows "$N" "${AXIS[@]}" --no-jitter -o "$WORK/out_femto.h5" --compression none
    run femto_deflate1_quarter "$QBYTES" "$FEMTO" ingest "$PATTERN" --rows "$QUARTER" "${AXIS[@]}" --no-jitter -o "$WORK/out_femto.h5"
    run python_baseline "$BYTES" python3 tools/ingest_baseline.py "$PATTERN" "$N" "$WORK/out_python.h5" 1.9 0 1
    echo '```'
    echo
} | tee "$WORK/results.txt"

# The two cubes must hold the same values.
python3 - "$WORK/kept_femto.h5" "$WORK/out_python.h5" <<'PY' | tee -a "$WORK/results.txt"
import sys, h5py, numpy as np
a, b = (h5py.File(p, "r")["cube"] for p in sys.argv[1:3])
same = a.shape == b.shape and all(np.array_equal(a[y], b[y]) for y in range(a.shape[0]))
print(f"femto and python cubes {'identical' if same else 'DIFFER'}: {a.shape}")
PY
echo >> "$WORK/results.txt"
# Newest first: the entry goes before the first "## " heading (after the file's header).
python3 - "$RESULTS" "$WORK/results.txt" <<'PY'
import sys
results, entry = sys.argv[1], open(sys.argv[2]).read()
lines = open(results).read().splitlines(keepends=True)
at = next((i for i, l in enumerate(lines) if l.startswith("## ")), len(lines))
open(results, "w").write("".join(lines[:at]) + entry + "".join(lines[at:]))
PY
