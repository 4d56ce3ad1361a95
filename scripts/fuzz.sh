#!/usr/bin/env bash
# Fuzzes every reader for a bounded time (docs/FUZZING.md): builds the fuzz
# preset (clang, libFuzzer, ASan + UBSan), writes the seed corpus with
# make_seed_corpus from the release build, replays fuzz/regressions/, then
# runs each fuzzer for SECONDS, as many at once as there are cores. Fails
# when any fuzzer finds a crash, a leak, undefined behaviour or an exception
# other than mesocap's; the reproducer is under build/fuzz/findings/<fuzzer>/.
# Usage: scripts/fuzz.sh [SECONDS]   (per fuzzer; default 30)
set -euo pipefail
cd "$(dirname "$0")/.."

seconds="${1:-30}"
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz
[[ -f build/release/build.ninja ]] || cmake --preset release >/dev/null
cmake --build build/release --target make_seed_corpus

root=build/fuzz
build/release/fuzz/make_seed_corpus "$root/seed_corpus"
rm -rf "$root/findings" "$root/logs"
mkdir -p "$root/findings" "$root/logs"

# Full stacks on malloc, so that the LSan suppressions of third-party leaks
# (named by an OpenImageIO frame below libstdc++) match.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1:fast_unwind_on_malloc=0"
export LSAN_OPTIONS="suppressions=$PWD/tests/sanitizer/lsan.supp"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export root seconds

# One fuzzer: the regressions once, then the bounded run. New inputs go to
# build/fuzz/corpus/<name>, which later runs start from.
fuzz_one() {
  local name=$1 binary="$root/fuzz/${1}_fuzzer"
  local log="$root/logs/$name.log" findings="$root/findings/$name/"
  mkdir -p "$root/corpus/$name" "$findings"
  if [[ -d "fuzz/regressions/$name" ]] &&
     ! "$binary" "fuzz/regressions/$name"/* >"$log" 2>&1; then
    echo "fuzz: $name fails on a regression input ($log)"; return 1
  fi
  # The memory limits leave room for OpenEXR, which allocates a header
  # attribute's declared length before reading it (docs/FUZZING.md, "Known in
  # third-party code").
  if "$binary" -max_total_time="$seconds" -malloc_limit_mb=2048 -rss_limit_mb=3072 -timeout=10 \
       -print_final_stats=1 \
       -artifact_prefix="$findings" "$root/corpus/$name" "$root/seed_corpus/$name" >>"$log" 2>&1; then
    echo "fuzz: $name ok: $(grep -E '^stat::(number_of_executed_units|average_exec_per_sec)' "$log" |
      sed 's/^stat::\([a-z_]*\): */\1 /' | tr '\n' ' ')$(grep -o 'cov: [0-9]*' "$log" | tail -1)"
  else
    echo "fuzz: $name FAILED; the input is in $findings, the report in $log"
    tail -n 40 "$log"
    return 1
  fi
}
export -f fuzz_one

start=$(date +%s)
ls "$root/fuzz" | sed -n 's/_fuzzer$//p' |
  xargs -P "$(nproc)" -I{} bash -c 'fuzz_one {}' && status=0 || status=1
echo "fuzz: fuzzers ran for $(( $(date +%s) - start )) s"
exit $status
