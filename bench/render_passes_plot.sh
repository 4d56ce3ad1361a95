#!/usr/bin/env bash
# Frame time and error of the peeling renderer against the number of peel
# passes: `mesocap compare --passes N` on every shipped scene (N view passes
# and N light passes in full mode), the median frame time of full mode and
# its coverage and shadow-mask IoU against the CPU reference, with BTF only
# as the baseline. Writes WORK/render_passes.dat and
# docs/images/render_passes.png.
# Usage: bench/render_passes_plot.sh [--replot] [SIZE] [WORK]   (default 800x600,
# /tmp/mesocap-render-passes; --replot draws WORK/render_passes.dat again
# without measuring)
# Needs a release build and gnuplot (scripts/install-deps.sh installs it).
set -euo pipefail
cd "$(dirname "$0")/.."

replot=false
if [[ "${1:-}" == "--replot" ]]; then
  replot=true
  shift
fi
size="${1:-800x600}"
work="${2:-/tmp/mesocap-render-passes}"
mesocap=build/release/apps/mesocap
[[ -x "$mesocap" ]] || { echo "render_passes_plot: $mesocap not found; build the release preset first" >&2; exit 1; }
command -v gnuplot >/dev/null || { echo "render_passes_plot: gnuplot not found (scripts/install-deps.sh)" >&2; exit 1; }

mkdir -p "$work"
data="$work/render_passes.dat"
scenes=()
for path in render/scenes/*.json; do scenes+=("$(basename "$path" .json)"); done
if ! $replot; then
  echo "# scene passes btf_ms full_ms full_coverage_iou full_shadow_iou" > "$data.partial"
  for scene in "${scenes[@]}"; do
    for passes in 1 2 3 4 6 8; do
      # compare's table: mode, coverage IoU, shadow IoU, PSNR, frame ms, passes, ratio.
      "$mesocap" -q compare "render/scenes/$scene.json" --size "$size" --passes "$passes" --repeat 5 |
        awk -v scene="$scene" -v n="$passes" '$1 == "btf" { btf = $5 } $1 == "full" { full = $5; cov = $2; shadow = $3 }
          END { print scene, n, btf, full, cov, shadow }' >> "$data.partial"
    done
  done
  mv "$data.partial" "$data"
fi

mkdir -p docs/images
gnuplot <<GNUPLOT
set terminal pngcairo size 1500,500 font ",10" noenhanced
set output "docs/images/render_passes.png"
set multiplot layout 1,3 title "Peeling renderer against peel passes (full mode, ${size}, Mesa llvmpipe)"
set grid
set key top left font ",8"
set xlabel "peel passes (view and light)"
scenes = "${scenes[*]}"
series(s, col) = sprintf("< awk '\$1 == \"%s\"' ${data}", s)
set ylabel "frame time / BTF-only frame time"
set title "frame time"
plot for [s in scenes] series(s, 0) using 2:(\$4/\$3) with linespoints title s, 2.5 with lines dashtype 2 lc rgb "gray40" title "2.5"
set ylabel "IoU against the reference"
set key bottom right
set title "coverage (mesostructure silhouettes)"
plot for [s in scenes] series(s, 0) using 2:5 with linespoints title s
set title "macroscale shadow"
plot for [s in scenes] series(s, 0) using 2:6 with linespoints title s
unset multiplot
GNUPLOT
echo "render_passes_plot: $data, docs/images/render_passes.png"
