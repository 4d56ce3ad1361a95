#!/usr/bin/env bash
# Rate against distortion of every BTF representation `compress` chooses
# from (paper, per_texel, clustered at 8/32/128 clusters, per_view; rgb and ycbcr) on
# the exact BTFs of weave, blocks, grass, brick and pipes (`groundtruth` on
# the small rig, its default 64 x 64 texels): -20 log10(relative RMS error),
# i.e. PSNR with the BTF's own RMS as the peak, against bytes per texel of
# the float32 factors. Writes WORK/rate_distortion.csv and
# docs/images/rate_distortion.png.
# Usage: bench/rate_distortion_plot.sh [--replot] [WORK]   (default
# /tmp/mesocap-rate-distortion; ground truths already in WORK/<scene> are
# reused; --replot draws WORK/rate_distortion.csv again without measuring)
# Needs a release build and gnuplot (scripts/install-deps.sh installs it).
set -euo pipefail
cd "$(dirname "$0")/.."

replot=false
if [[ "${1:-}" == "--replot" ]]; then
  replot=true
  shift
fi
work="${1:-/tmp/mesocap-rate-distortion}"
mesocap=build/release/apps/mesocap
bench=build/release/bench/mesocap_btf_rate_distortion_bench
scenes=(weave blocks grass brick pipes)
for tool in "$mesocap" "$bench"; do
  [[ -x "$tool" ]] || { echo "rate_distortion_plot: $tool not found; build the release preset first" >&2; exit 1; }
done
command -v gnuplot >/dev/null || { echo "rate_distortion_plot: gnuplot not found (scripts/install-deps.sh)" >&2; exit 1; }

if ! $replot; then
  mkdir -p "$work"
  packages=()
  for scene in "${scenes[@]}"; do
    [[ -f "$work/$scene/manifest.json" ]] || "$mesocap" -q groundtruth --scene "$scene" --rig small --out "$work/$scene"
    packages+=("$work/$scene")
  done
  "$bench" "${packages[@]}" > "$work/rate_distortion.csv.partial"
  mv "$work/rate_distortion.csv.partial" "$work/rate_distortion.csv"
fi

# One data file per scene and representation, for gnuplot's loops.
rm -rf "$work/series" && mkdir -p "$work/series"
awk -F, -v dir="$work/series" 'NR > 1 {
  name = $2; gsub(/[\/()]/, "_", name)
  print $5, $7 > (dir "/" $1 "__" name ".dat")
}' "$work/rate_distortion.csv"
representations=$(awk -F, 'NR > 1 { print $2 }' "$work/rate_distortion.csv" | awk '!seen[$0]++' | tr '\n' ' ')

mkdir -p docs/images
gnuplot <<GNUPLOT
set terminal pngcairo size 1500,900 font ",10" noenhanced
set output "docs/images/rate_distortion.png"
set multiplot layout 2,3 title "BTF representations: error against size (small rig, exact BTFs, 64 x 64 texels)"
set logscale x
set xlabel "bytes per texel (float32 factors)"
set ylabel "-20 log10(relative RMS error), dB"
set grid
set key top left font ",8"
# The paper layout at rank 4 (the issue's reference size).
set arrow 1 from 2304, graph 0 to 2304, graph 1 nohead dashtype 2 lc rgb "gray40"
reps = "${representations}"
dash(i) = i > 6 ? 2 : 1
file(s, r) = sprintf("%s/series/%s__%s.dat", "${work}", s, system(sprintf("echo '%s' | tr '/()' '___'", r)))
do for [s in "${scenes[*]}"] {
  set title s
  # Colour by layout, solid for rgb and dashed for ycbcr (the CSV lists the
  # six layouts in rgb, then in ycbcr).
  plot for [i = 1:words(reps)] file(s, word(reps, i)) using 1:2 with linespoints pointsize 0.6 \
    lc ((i - 1) % 6 + 1) dashtype dash(i) title (word(reps, i))
}
unset multiplot
GNUPLOT
echo "rate_distortion_plot: $work/rate_distortion.csv, docs/images/rate_distortion.png"
