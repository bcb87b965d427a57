#!/usr/bin/env bash
# Submit femto's cluster pipeline to Slurm with dependencies (docs/cluster.md):
#   simulate.sbatch  job array, one band of rows per task      (skipped with --capture)
#   merge.sbatch     afterok: the bands -> WORK/capture         (skipped with --capture)
#   chain.sbatch     afterok: ingest, calibrate, unwarp, pyramid -> WORK/world.h5
#   render.sbatch    afterok: job array, one frame range per task -> WORK/frames/part_*
#   encode.sbatch    afterok: the parts -> WORK/VIDEO
#
# usage: tools/slurm/submit.sh --work DIR [--bands N] [--parts N] [--sim "FLAGS"]
#            [--rows NY] [--capture DIR] [--render "FLAGS"] [--frames N] [--video FILE]
#            [--fps F] [--cpus N] [--femto PATH] [--wait] [-- SBATCH_FLAGS...]
#   --work     a folder every node sees (created; must be empty)
#   --bands    simulate tasks (default 4); --parts: render tasks (default 4)
#   --sim      femto simulate flags (default "--scene cube --size 64x48 --spp 64", the cube
#              scene at its own size), without --out/--rows
#   --rows     image rows (default: from --size WxH or --paper-size in --sim; needed when
#              --sim has neither: the scene's own image height)
#   --capture  start from this capture folder instead of simulating one
#   --render   femto render flags (default "--dolly 0.5"), without --out/--frames/--format
#   --frames   frames of the video (default 100); --video: default video.mp4; --fps: 30
#   --cpus     CPUs per task (--cpus-per-task, and the tasks' thread count; default 1)
#   --femto    the femto binary (default: `femto` on PATH), at the same path on every node
#   --wait     wait for the last job (sbatch --wait) and exit with its status, or 1 when
#              it was cancelled because a job before it failed (no video)
# Anything after -- goes to every sbatch (e.g. --partition=... --time=...).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
work="" bands=4 parts=4 sim="--scene cube --size 64x48 --spp 64" ny="" capture="" render="--dolly 0.5"
frames=100 video=video.mp4 fps=30 cpus=1 femto="" wait=""
while [ $# -gt 0 ]; do
    case $1 in
        --work) work=$2; shift 2 ;;
        --bands) bands=$2; shift 2 ;;
        --parts) parts=$2; shift 2 ;;
        --sim) sim=$2; shift 2 ;;
        --rows) ny=$2; shift 2 ;;
        --capture) capture=$2; shift 2 ;;
        --render) render=$2; shift 2 ;;
        --frames) frames=$2; shift 2 ;;
        --video) video=$2; shift 2 ;;
        --fps) fps=$2; shift 2 ;;
        --cpus) cpus=$2; shift 2 ;;
        --femto) femto=$2; shift 2 ;;
        --wait) wait="--wait"; shift ;;
        --) shift; break ;;
        *) echo "submit.sh: unknown option $1 (see the comment at the top)" >&2; exit 2 ;;
    esac
done
die() { echo "submit.sh: $*" >&2; exit 2; }
[ -n "$work" ] || die "--work DIR is required"
femto=$(command -v "${femto:-femto}") || die "--femto: no femto binary found"
femto=$(cd "$(dirname "$femto")" && pwd)/$(basename "$femto")
for n in bands parts frames cpus; do
    [[ ${!n} =~ ^[1-9][0-9]*$ ]] || die "--$n ${!n}: expected a whole number >= 1"
done
if [ -z "$ny" ]; then
    if [[ " $sim " =~ \ --paper-size\  ]]; then ny=600
    elif [[ " $sim " =~ \ --size[\ =][0-9]+x([0-9]+)\  ]]; then ny=${BASH_REMATCH[1]}
    elif [ -z "$capture" ]; then
        die "--rows NY is needed: --sim has no --size WxH or --paper-size (give one of them, or --rows with the scene's image height)"
    fi
fi
[ -n "$capture" ] || [ "$bands" -le "$ny" ] || die "--bands $bands: more bands than the $ny rows"
[ "$parts" -le "$frames" ] || die "--parts $parts: more parts than the $frames frames"
mkdir -p "$work"
work=$(cd "$work" && pwd)
[ -z "$(ls -A "$work")" ] || die "--work $work: not empty (a new run needs an empty folder)"
mkdir -p "$work/logs"
if [ -n "$capture" ]; then capture=$(cd "$capture" && pwd); fi

export FEMTO=$femto WORK=$work SIM_ARGS=$sim NY=$ny RENDER_ARGS=$render FRAMES=$frames
export VIDEO=$video FPS=$fps CAPTURE=${capture:-capture}
common=(--parsable --chdir="$work" --cpus-per-task="$cpus" --kill-on-invalid-dep=yes
    --output="$work/logs/%x-%j.out" "$@")
array=(--output="$work/logs/%x-%A_%a.out")
after=()
if [ -z "$capture" ]; then
    sim_job=$(sbatch "${common[@]}" "${array[@]}" --array="0-$((bands - 1))" \
        "$here/simulate.sbatch")
    merge_job=$(sbatch "${common[@]}" --dependency="afterok:$sim_job" "$here/merge.sbatch")
    after=(--dependency="afterok:$merge_job")
    echo "simulate: job $sim_job ($bands tasks); merge: job $merge_job"
fi
chain_job=$(sbatch "${common[@]}" "${after[@]}" "$here/chain.sbatch")
render_job=$(sbatch "${common[@]}" --dependency="afterok:$chain_job" \
    "${array[@]}" --array="0-$((parts - 1))" "$here/render.sbatch")
echo "chain: job $chain_job; render: job $render_job ($parts tasks)"
if [ -n "$wait" ]; then
    echo "encode: waiting for it (sbatch --wait)"
fi
status=0
encode_job=$(sbatch "${common[@]}" $wait --dependency="afterok:$render_job" \
    "$here/encode.sbatch") || status=$?
# sbatch --wait exits 0 for a job Slurm cancelled because a job it depends on failed
# (--kill-on-invalid-dep): no video then means a failed pipeline.
if [ -n "$wait" ] && [ "$status" = 0 ] && [ ! -s "$work/$video" ]; then
    echo "submit.sh: no $work/$video: a job failed or was cancelled (see $work/logs)" >&2
    status=1
fi
if [ "$status" = 0 ]; then
    echo "encode: job ${encode_job%%;*}${wait:+, exit status 0}; video: $work/$video"
else
    echo "encode: job ${encode_job%%;*}, exit status $status (no video)"
fi
exit "$status"
