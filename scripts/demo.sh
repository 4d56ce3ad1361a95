#!/usr/bin/env bash
# The main job on the simulated rig, run by scripts/setup.sh after the build,
# the whole chain as on a real rig, without the simulator's truth: the `tiny`
# rig's calibration session (a ChArUco board on holder tilts at turntable
# angles, a mirror sphere and a white reference under each lamp) and the rig
# calibrated from it (its cameras resolve the sphere too coarsely for the
# lamps' positions: the calibration reports them and keeps the rig
# description's);
# a capture session of the `weave` scene (BTF images, laser-plane
# calibration frames, laser sweeps, with sensor noise); the MDF and the BTF
# processed with the estimated calibration; then, only to judge them, their
# error against the exact material of the same scene; and a frame of the
# depth-peeling renderer.
# The texture is 12 x 12 texels (1 mm): the tiny rig's 128 x 96 cameras see
# the 12 mm sample across about 28 pixels, 14 at the most oblique view, so a
# finer grid would hold detail no camera resolved.
# Output goes to out/demo/ (replaced on every run).
set -euo pipefail
cd "$(dirname "$0")/.."

mesocap=build/release/apps/mesocap
out=out/demo
texels=12
mkdir -p "$out"

echo "== calibration session and the rig's calibration: tiny rig =="
rm -rf "$out/calibration-session"
"$mesocap" -q simulate --plan calibration --scene weave --rig tiny --out "$out/calibration-session"
"$mesocap" calibrate --session "$out/calibration-session" --out "$out/calibration.json" --replace

echo "== capture session: weave scene, tiny rig =="
rm -rf "$out/weave-session"
"$mesocap" simulate --scene weave --rig tiny --seed 1 --out "$out/weave-session"
"$mesocap" info "$out/weave-session"

echo "== MDF and BTF with the estimated calibration =="
"$mesocap" process mdf --session "$out/weave-session" --calibration "$out/calibration.json" \
  --texture-size "$texels" --out "$out/weave-measured" --replace
"$mesocap" process btf --session "$out/weave-session" --calibration "$out/calibration.json" \
  --texture-size "$texels" --out "$out/weave-btf" --replace

echo "== their error against the exact material (ground truth: weave scene, tiny rig) =="
"$mesocap" -q groundtruth --scene weave --rig tiny --texture-size "$texels" --out "$out/weave-truth" --replace
echo "MDF (the sample square only: the rig cannot see behind the pocket's wall):"
"$mesocap" eval mdf --truth "$out/weave-truth" --estimate "$out/weave-measured" --inside-sample-only
echo "BTF (the tiny rig captures 32 of its 64 view and light pairs; the rest are interpolated; both apart below):"
"$mesocap" eval btf --truth "$out/weave-truth" --estimate "$out/weave-btf"

echo "== the paper's cylinder with a blocks material: BTF, MDF silhouettes and shadows (headless GL) =="
# sim: materials are built from ground truth and SVD-factored once, then cached.
MESOCAP_CACHE_DIR="$out/cache" "$mesocap" render render/scenes/cylinder.json --mode full --size 400x300 \
  --out "$out/cylinder.png" --replace
echo "demo: wrote $out/calibration.json, $out/weave-session, $out/weave-measured, $out/weave-btf," \
  "$out/weave-truth and $out/cylinder.png"
