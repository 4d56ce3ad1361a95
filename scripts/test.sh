#!/usr/bin/env bash
# README command 2: build and run the test suite with ctest.
# Usage: scripts/test.sh [release|debug|sanitize|quick]   (default: release)
#
#   release, debug: every test but those labelled `served` and `browser`,
#     then those (served GigE Vision cameras in network namespaces of their
#     own; the status page in headless Chromium), once each, three at a
#     time (they mostly wait on the network): a test that needs a second try
#     is a failing test;
#   sanitize: the sanitize tier under ASan and UBSan (the preset's filter);
#   quick: the inner loop on the release build (ctest --preset quick).
# docs/DEVELOPING.md says what each tier holds and how long it takes.
set -euo pipefail
cd "$(dirname "$0")/.."

tier="${1:-release}"
preset="$tier"
[ "$tier" = quick ] && preset=release
cmake --preset "$preset"
cmake --build --preset "$preset"
case "$tier" in
  sanitize | quick)
    ctest --preset "$tier"
    ;;
  *)
    ctest --preset "$preset" -LE 'served|browser'
    ctest --preset "$preset" -L 'served|browser' --parallel 3
    ;;
esac
