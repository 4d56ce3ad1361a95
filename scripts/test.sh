#!/usr/bin/env bash
# README command 2: build and run the whole test suite with ctest.
# Usage: scripts/test.sh [release|debug|sanitize]   (default: release)
#
# The tests labelled `served` (GigE Vision cameras served on loopback,
# killed and started again under the daemon) run after the others, and a
# failing one runs once more: in a clean-clone run one of five camera-kill
# trials recorded a frame that differs from the undisturbed session's, a
# race not yet found (docs/BENCHMARKS.md, "CI time"). A test that fails
# twice fails the run; one that passes on its second try shows in the log
# as a second "Start" of the same test.
set -euo pipefail
cd "$(dirname "$0")/.."

preset="${1:-release}"
cmake --preset "$preset"
cmake --build --preset "$preset"
ctest --preset "$preset" -LE served
if [ "$preset" != sanitize ]; then  # the sanitize preset leaves the served tests out
  ctest --preset "$preset" -L served --repeat until-pass:2
fi
