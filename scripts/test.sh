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
if [ "$preset" = sanitize ]; then
  # The preset's own filter leaves out the served, accuracy and browser
  # tests; a label filter given here would replace it, not add to it.
  ctest --preset sanitize
else
  ctest --preset "$preset" -LE served
  ctest --preset "$preset" -L served --repeat until-pass:2
fi
