#!/usr/bin/env bash
# The light arc and lamps of a rig's calibration on the user's path, over
# sensor-noise seeds: per seed `mesocap simulate --plan calibration` then
# `mesocap calibrate --session --json`, and the estimated lamps, arc axis and
# camera gains against the session's true calibration (the simulator's, which
# calibrate never reads). Prints one line per seed and the summary: largest
# lamp error, RMS of error / sigma per axis, axis direction error, gain error.
# Usage: bench/light_arc_seeds.sh [RIG] [SEEDS] [WORK_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
rig=${1:-small}
seeds=${2:-20}
work=${3:-$(mktemp -d)}
mesocap=build/release/apps/mesocap
mkdir -p "$work"
for seed in $(seq 1 "$seeds"); do
  session="$work/session-$seed"
  rm -rf "$session"
  start=$(date +%s.%N)
  "$mesocap" -q simulate --plan calibration --scene flat --rig "$rig" --seed "$seed" --out "$session"
  middle=$(date +%s.%N)
  "$mesocap" -q calibrate --session "$session" --out "$work/calibration-$seed.json" --replace --json \
    > "$work/report-$seed.json"
  end=$(date +%s.%N)
  python3 - "$session/calibration.json" "$work/report-$seed.json" "$seed" "$start" "$middle" "$end" <<'EOF'
import json, math, sys
truth = json.load(open(sys.argv[1]))
report = json.load(open(sys.argv[2]))
seed, t0, t1, t2 = sys.argv[3], float(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6])
arc = report["light_arc"]
worst, ratios = 0.0, []
for lamp, true_lamp in zip(report["lamps"], truth["lamps"]):
    error = [p - t for p, t in zip(lamp["position_mm"], true_lamp["position_mm"])]
    worst = max(worst, math.sqrt(sum(e * e for e in error)))
    ratios += [e / s for e, s in zip(error, lamp["std"]["position_mm"])]
d, td = arc["axis_direction"], truth["light_arc"]["axis_direction"]
axis_deg = math.degrees(math.acos(min(1.0, sum(a * b for a, b in zip(d, td)))))
gains = [c["gain"] / t["radiometry"]["signal_per_radiance_second"] - 1 for c, t in zip(report["cameras"], truth["cameras"])]
print(json.dumps({"seed": int(seed), "written": arc["written"], "worst_lamp_mm": round(worst, 3),
                  "error_over_sigma": [round(r, 2) for r in ratios], "axis_deg": round(axis_deg, 4),
                  "worst_gain_pct": round(100 * max(gains, key=abs), 3), "ray_residual_mm": round(arc["ray_residual_rms_mm"], 3),
                  "simulate_s": round(t1 - t0, 1), "calibrate_s": round(t2 - t1, 1)}))
EOF
done | tee "$work/seeds.jsonl"
python3 - "$work/seeds.jsonl" <<'EOF'
import json, math, sys
runs = [json.loads(line) for line in open(sys.argv[1])]
ratios = [r for run in runs for r in run["error_over_sigma"]]
by_axis = [[run["error_over_sigma"][k::3] for run in runs] for k in range(3)]
rms = lambda xs: math.sqrt(sum(x * x for x in xs) / len(xs))
print(f"{len(runs)} seeds: written {sum(r['written'] for r in runs)}; worst lamp error "
      f"{max(r['worst_lamp_mm'] for r in runs)} mm (median of the seeds' worst "
      f"{sorted(r['worst_lamp_mm'] for r in runs)[len(runs) // 2]} mm); error / sigma RMS x y z "
      + " ".join(f"{rms([v for run in axis for v in run]):.2f}" for axis in by_axis)
      + f" (all {rms(ratios):.2f}); axis error max {max(r['axis_deg'] for r in runs)} deg; "
      f"gain error max {max((abs(r['worst_gain_pct']) for r in runs))} %")
EOF
