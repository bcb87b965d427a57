#!/usr/bin/env bash
# The image-based renderer's error against the traced truth on the built-in cube scene
# (docs/truth.md): for each camera path of this folder, one capture with its truth frames
# (femto simulate --truth-path), the render of the capture's world-time cube along the same
# path (femto render), and the comparison (femto compare), whose pooled line is printed.
#
#   tools/truth/table.sh OUT_DIR [FEMTO] [CAPTURE_SPP] [TRUTH_SPP] [PATHS...]
#
# FEMTO defaults to target/release/femto; CAPTURE_SPP to 64 (femto simulate's default) and
# TRUTH_SPP to 256. Error images land in OUT_DIR/NAME/errors.
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
echo "capture 160x120 at $capture_spp spp, truth 160x120 at $truth_spp spp, seed 1; $(nproc) cores"
printf '%-9s %8s %8s %7s %7s %7s %7s %8s\n' path lit_tru lit_ibr rel_L1 holes ghosts PSNR truth_s
for name in "${paths[@]}"; do
    d="$out/$name"
    rm -rf "$d"
    mkdir -p "$d"
    "$femto" simulate --scene cube --size 160x120 --spp "$capture_spp" --seed 1 \
        --truth-path "$here/$name.toml" --truth-spp "$truth_spp" --out "$d/cap" > "$d/simulate.txt" 2>&1
    "$femto" render --cube "$d/cap/truth_world.h5" --calibration "$d/cap/calibration.toml" \
        --mesh "$d/cap/scene.glb" --path "$here/$name.toml" --format exr --out "$d/ibr" \
        > "$d/render.txt" 2>&1
    "$femto" compare --truth "$d/cap/truth" --render "$d/ibr" --out "$d/errors" > "$d/compare.txt"
    seconds=$(sed -n 's/.*truth: .* in \([0-9.]*\) s;.*/\1/p' "$d/simulate.txt")
    read -r _ lit_t lit_r l1 holes ghosts psnr < <(tail -n 1 "$d/compare.txt")
    printf '%-9s %8s %8s %7s %7s %7s %7s %8s\n' "$name" "$lit_t" "$lit_r" "$l1" "$holes" "$ghosts" "$psnr" "$seconds"
done
