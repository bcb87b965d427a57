#!/usr/bin/env bash
# Throughput of the in-memory cube kernels (unwarp, prefix sums, mip levels) on a
# 672 x 600 x 512 f32 cube, against a plain copy of the same bytes and against the numpy
# baselines tools/unwarp_numpy.py and tools/pyramid_numpy.py.
# Usage: tools/bench_cubeops.sh [threads (default 2)] [reps (default 3)]
set -euo pipefail
cd "$(dirname "$0")/.."
threads=${1:-2}
reps=${2:-3}
cargo build --quiet --release --example bench_cubeops
echo "date: $(date -u +%Y-%m-%dT%H:%MZ)"
echo "machine: $(uname -srm), $(nproc) cores,$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2), load $(cut -d' ' -f1-3 /proc/loadavg)"
target/release/examples/bench_cubeops --threads "$threads" --reps "$reps"
if ! python3 -c "import numpy" 2>/dev/null; then
    echo "numpy is missing (pip install numpy): numpy baselines skipped"
    exit 0
fi
echo "numpy $(python3 -c 'import numpy; print(numpy.__version__)') (single-threaded kernels)"
python3 tools/unwarp_numpy.py --selftest >/dev/null
python3 tools/pyramid_numpy.py --selftest >/dev/null
python3 tools/unwarp_numpy.py --reps "$reps"
python3 tools/pyramid_numpy.py --reps "$reps"
