#!/usr/bin/env bash
# The main job on the simulated rig, run by scripts/setup.sh after the build:
# a capture session of the `weave` scene recorded on the `tiny` simulated rig
# (BTF images, laser-plane calibration frames, laser sweeps, with sensor
# noise), and the exact material package of the same scene (MDF, BTF,
# ambient term, true calibration); then the MDF measured from the session's
# laser scans, and its error table against the exact one; and a frame of the
# depth-peeling renderer.
# Output goes to out/demo/ (replaced on every run).
set -euo pipefail
cd "$(dirname "$0")/.."

mesocap=build/release/apps/mesocap
out=out/demo
mkdir -p "$out"

echo "== capture session: weave scene, tiny rig =="
rm -rf "$out/weave-session"
"$mesocap" simulate --scene weave --rig tiny --seed 1 --out "$out/weave-session"
"$mesocap" info "$out/weave-session"

echo "== ground truth: weave scene, tiny rig =="
"$mesocap" groundtruth --scene weave --rig tiny --texture-size 64 --out "$out/weave-truth" --replace
"$mesocap" info "$out/weave-truth"
echo "== MDF from the laser scans, and its error against the truth =="
"$mesocap" process mdf --session "$out/weave-session" --calibration "$out/weave-session/calibration.json" \
  --texture-size 64 --out "$out/weave-measured" --replace
"$mesocap" eval mdf --truth "$out/weave-truth" --estimate "$out/weave-measured"
echo "== the paper's cylinder with a blocks material: BTF, MDF silhouettes and shadows (headless GL) =="
# sim: materials are built from ground truth and SVD-factored once, then cached.
MESOCAP_CACHE_DIR="$out/cache" "$mesocap" render render/scenes/cylinder.json --mode full --size 400x300 \
  --out "$out/cylinder.png"
echo "demo: wrote $out/weave-session, $out/weave-truth, $out/weave-measured and $out/cylinder.png"
