#!/usr/bin/env bash
# The main job on the simulated rig, run by scripts/setup.sh after the build:
# the exact material package of the `weave` scene on the `small` rig (MDF,
# BTF, ambient term, true calibration), then a summary of it. Output goes to
# out/demo/ (replaced on every run).
set -euo pipefail
cd "$(dirname "$0")/.."

mesocap=build/release/apps/mesocap
out=out/demo
mkdir -p "$out"

echo "== ground truth: weave scene, small rig =="
"$mesocap" groundtruth --scene weave --rig small --texture-size 64 --out "$out/weave-truth" --replace
"$mesocap" info "$out/weave-truth"
echo "demo: wrote $out/weave-truth"
