#!/usr/bin/env bash
# The main job on the simulated rig, run by scripts/setup.sh after the build:
# the whole chain as on a real rig, without the simulator's truth, on the
# `small` rig (four 400 x 300 cameras, four lamps on a light arc, three laser
# mounts):
# - the rig's calibration session (a ChArUco board on holder tilts at
#   turntable angles, a mirror sphere and a white reference under each lamp,
#   laser plates) and the rig calibrated from it;
# - a capture session of the `weave` scene (BTF images, laser-plane
#   calibration frames, laser sweeps, with sensor noise);
# - the MDF and the BTF processed with the estimated calibration into one
#   material, which then renders on a torus (headless GL);
# - then, only to judge them, their error against the exact material.
# The texture is 28 x 28 texels (0.46 mm): the most oblique camera sees a
# texel across about one pixel there, so no texel holds detail no camera
# resolved.
# Output goes to out/demo/ (replaced on every run).
set -euo pipefail
cd "$(dirname "$0")/.."

mesocap=build/release/apps/mesocap
out=out/demo
rig=small
texels=28
mkdir -p "$out"

echo "== calibration session and the rig's calibration: $rig rig =="
rm -rf "$out/calibration-session"
"$mesocap" -q simulate --plan calibration --scene weave --rig "$rig" --out "$out/calibration-session"
"$mesocap" calibrate --session "$out/calibration-session" --out "$out/calibration.json" --replace

echo "== capture session: weave scene, $rig rig =="
rm -rf "$out/weave-session"
"$mesocap" -q simulate --scene weave --rig "$rig" --seed 1 --out "$out/weave-session"
"$mesocap" info "$out/weave-session"

echo "== the material: MDF and BTF with the estimated calibration =="
"$mesocap" process mdf --session "$out/weave-session" --calibration "$out/calibration.json" \
  --texture-size "$texels" --out "$out/weave-mdf" --replace
"$mesocap" process btf --session "$out/weave-session" --calibration "$out/calibration.json" \
  --texture-size "$texels" --mdf "$out/weave-mdf" --out "$out/weave-material" --replace

echo "== the material on a torus: BTF, MDF silhouettes and shadows (headless GL) =="
cat > "$out/weave_torus.json" <<'SCENE'
{
  "format": "mesocap.scene",
  "version": 1,
  "camera": {"position": [0, -120, 75], "look_at": [0, 0, -4], "up": [0, 0, 1], "fov_y_deg": 38},
  "light": {"position": [80, -60, 170], "intensity": 60000, "ambient": 0.15},
  "objects": [
    {"name": "torus", "shape": "torus", "major_radius": 26, "minor_radius": 10, "segments": 160, "tube_segments": 64,
     "tiles": [6, 2], "material": "weave-material", "rotate_deg": [20, 0, 0]},
    {"name": "floor", "shape": "box", "min": [-70, -70, -36], "max": [70, 70, -30], "albedo": [0.6, 0.6, 0.6]}
  ]
}
SCENE
"$mesocap" render "$out/weave_torus.json" --mode full --size 400x300 --out "$out/weave_torus.png" --replace

echo "== its error against the exact material (ground truth: weave scene, $rig rig) =="
"$mesocap" -q groundtruth --scene weave --rig "$rig" --texture-size "$texels" --out "$out/weave-truth" --replace
echo "MDF (the sample square only: the rig cannot see behind the pocket's wall):"
"$mesocap" eval mdf --truth "$out/weave-truth" --estimate "$out/weave-material" --inside-sample-only
echo "BTF (captured pairs, those interpolated from a view's captured lights, and views finer than a pixel apart):"
"$mesocap" eval btf --truth "$out/weave-truth" --estimate "$out/weave-material"
echo "demo: wrote $out/calibration.json, $out/weave-session, $out/weave-material, $out/weave_torus.png" \
  "and $out/weave-truth"
