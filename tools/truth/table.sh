#!/usr/bin/env bash
# The image-based renderer's error against the traced truth on the built-in cube scene
# (docs/truth.md): for each camera path of this folder, one capture with its truth frames
# (femto simulate --truth-path), the capture's camera-time cube taken to world time with the
# true calibration (femto unwarp), its render along the same path (femto render), and the
# comparison (femto compare), whose pooled line is printed. The capture is clean and the
# calibration exact, so the error is the renderer's own (and the unwarp's resampling).
#
#   tools/truth/table.sh OUT_DIR [FEMTO] [CAPTURE_SPP] [TRUTH_SPP] [PATHS...]
#
# FEMTO defaults to target/release/femto; CAPTURE_SPP to 64 (femto simulate's default) and
# TRUTH_SPP to 256. Error images land in OUT_DIR/NAME/errors. To tell the capture's noise
# from the renderer's bias, each path is also rendered from a second, independent capture
# at 4 x CAPTURE_SPP (seed 2) and compared with the same truth: the columns "@4x".
# MASK_SPREAD_BINS (environment) is passed to femto unwarp's --mask-spread-bins (default: its
# default, 4; inf keeps the mixed pixels).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${1:?usage: table.sh OUT_DIR [FEMTO] [CAPTURE_SPP] [TRUTH_SPP] [PATHS...]}"
femto="${2:-$here/../../target/release/femto}"
capture_spp="${3:-64}"
truth_spp="${4:-256}"
shift $(( $# < 4 ? $# : 4 ))
paths=("$@")
if [ ${#paths[@]} -eq 0 ]; then
    paths=(still orbit10 orbit30 dolly pass rotating)
fi
mkdir -p "$out"

# The capture DIR/capSUFFIX taken to world time with its true calibration and rendered along
# PATH_NAME into DIR/ibrSUFFIX.
render_capture() {
    local d="$1" suffix="$2" name="$3"
    "$femto" unwarp "$d/cap$suffix/truth_camera.h5" --calibration "$d/cap$suffix/calibration.toml" \
        --mesh "$d/cap$suffix/scene.glb" ${MASK_SPREAD_BINS:+--mask-spread-bins "$MASK_SPREAD_BINS"} \
        --out "$d/world$suffix.h5" > "$d/unwarp$suffix.txt" 2>&1
    "$femto" render --cube "$d/world$suffix.h5" --calibration "$d/cap$suffix/calibration.toml" \
        --mesh "$d/cap$suffix/scene.glb" --path "$here/$name.toml" --format exr \
        --out "$d/ibr$suffix" > "$d/render$suffix.txt" 2>&1
}
echo "unwarp --mask-spread-bins ${MASK_SPREAD_BINS:-default}; capture 160x120 x 768 bins of 4 ps at $capture_spp spp, truth 160x120 at $truth_spp spp, seed 1; $(nproc) cores"
printf '%-9s %8s %8s %7s %7s %7s %7s %8s %9s %8s\n' path lit_tru lit_ibr rel_L1 holes ghosts PSNR truth_s rel_L1@4x PSNR@4x
for name in "${paths[@]}"; do
    d="$out/$name"
    rm -rf "$d"
    mkdir -p "$d"
    "$femto" simulate --scene cube --size 160x120 --nt 768 --spp "$capture_spp" --seed 1 \
        --truth-path "$here/$name.toml" --truth-spp "$truth_spp" --out "$d/cap" > "$d/simulate.txt" 2>&1
    render_capture "$d" "" "$name"
    "$femto" compare --truth "$d/cap/truth" --render "$d/ibr" --out "$d/errors" > "$d/compare.txt"
    # The second capture, 4 x the paths, its own seed, no truth of its own.
    "$femto" simulate --scene cube --size 160x120 --nt 768 --spp $((4 * capture_spp)) --seed 2 \
        --out "$d/cap4" > "$d/simulate4.txt" 2>&1
    render_capture "$d" 4 "$name"
    "$femto" compare --truth "$d/cap/truth" --render "$d/ibr4" > "$d/compare4.txt"
    seconds=$(sed -n 's/.*truth: .* in \([0-9.]*\) s;.*/\1/p' "$d/simulate.txt")
    read -r _ lit_t lit_r l1 holes ghosts psnr < <(tail -n 1 "$d/compare.txt")
    read -r _ _ _ l1_4 _ _ psnr_4 < <(tail -n 1 "$d/compare4.txt")
    printf '%-9s %8s %8s %7s %7s %7s %7s %8s %9s %8s\n' "$name" "$lit_t" "$lit_r" "$l1" "$holes" \
        "$ghosts" "$psnr" "$seconds" "$l1_4" "$psnr_4"
done
