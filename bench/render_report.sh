#!/usr/bin/env bash
# Speed against error of the depth-peeling renderer (the paper's Table 2): `mesocap compare` on every shipped scene with its
# sim: material (ground truth factored at rank 8, built and cached on first
# use). Per mode: coverage IoU (silhouettes) and shadow-mask IoU against the
# CPU reference, PSNR, the median frame time of --repeat frames (shadow map +
# view, glFinish-bracketed), peel passes (view/light), and the ratio to BTF
# only measured in the same run.
# Usage: bench/render_report.sh [SIZE] [REPEAT]   (default 800x600, 7)
# Needs a release build (cmake --preset release && cmake --build --preset release).
set -euo pipefail
cd "$(dirname "$0")/.."

size="${1:-800x600}"
repeat="${2:-7}"
mesocap=build/release/apps/mesocap
[[ -x "$mesocap" ]] || { echo "render_report: $mesocap not found; build the release preset first" >&2; exit 1; }
for scene in render/scenes/*.json; do
  "$mesocap" -q compare "$scene" --size "$size" --repeat "$repeat"
  echo
done
