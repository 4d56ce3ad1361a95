#!/usr/bin/env bash
# README command 2: build and run the whole test suite with ctest.
# Usage: scripts/test.sh [release|debug|sanitize]   (default: release)
set -euo pipefail
cd "$(dirname "$0")/.."

preset="${1:-release}"
cmake --preset "$preset"
cmake --build --preset "$preset"
ctest --preset "$preset"
