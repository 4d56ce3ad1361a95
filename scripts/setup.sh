#!/usr/bin/env bash
# README command 1: install what mesocap needs, build it (release preset), and
# run the main job on the simulated rig (scripts/demo.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release
bash scripts/demo.sh
