#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs every fuzz target of a libFuzzer build for a bounded time each (`make fuzz SECONDS=N`).
#   scripts/fuzz.sh BUILD_DIR SECONDS_PER_TARGET [TARGET ...]
# Each target starts from its seeds (the shipped models, the configs, tests/fuzz/seeds/) and its
# kept findings (tests/fuzz/regressions/<target>/) and grows a working corpus in
# BUILD_DIR/fuzz-corpus/<target>/. A finding (crash, hang, leak, sanitizer report, or a target's
# own check) leaves its input in BUILD_DIR/fuzz-findings/<target>/ and fails the run: copy it into
# tests/fuzz/regressions/<target>/ with the fix so ctest replays it from then on.
# Prints, per target, the executions, the time and the executions per second. The targets run
# side by side, FUZZ_JOBS at a time (default: one per core).
set -euo pipefail
cd "$(dirname "$0")/.."

build_dir=${1:?usage: scripts/fuzz.sh BUILD_DIR SECONDS [TARGET ...]}
budget=${2:?usage: scripts/fuzz.sh BUILD_DIR SECONDS [TARGET ...]}
shift 2
targets=("$@")
if [[ ${#targets[@]} -eq 0 ]]; then
  targets=(container_fuzzer model_file_fuzzer dataset_file_fuzzer config_fuzzer csv_fuzzer
    manifest_fuzzer)
fi

if ! grep -q '^IMM_FUZZERS:BOOL=ON' "$build_dir/CMakeCache.txt" 2>/dev/null; then
  echo "fuzz: $build_dir is not a libFuzzer build (Clang with IMM_FUZZERS=ON); only the replay" \
       "tests run there (ctest -L fuzz)" >&2
  exit 1
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# Leaks inside HDF5 itself on malformed files (see the file); our handles are checked per input.
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/lsan.supp:print_suppressions=0}
jobs=${FUZZ_JOBS:-$(nproc)}

# One target: its run, then one line of results into BUILD_DIR/fuzz-logs/<target>.result.
fuzz_one() {
  local target=$1
  local binary="$build_dir/fuzz/$target"
  local corpus="$build_dir/fuzz-corpus/$target"
  local findings="$build_dir/fuzz-findings/$target/"
  local log="$build_dir/fuzz-logs/$target.log"
  mkdir -p "$corpus" "$findings" "$(dirname "$log")"
  local seeds=()
  while IFS= read -r line; do [[ -n "$line" && -e "$line" ]] && seeds+=("$line"); done \
    < <(cat "$build_dir/fuzz/$target.seeds" "$build_dir/fuzz/$target.regressions")
  local start
  start=$(date +%s.%N)
  local status=0
  "$binary" -max_total_time="$budget" -max_len=65536 -timeout=20 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$findings" "$corpus" "${seeds[@]}" > "$log" 2>&1 \
    || status=$?
  local seconds runs rate result=ok
  seconds=$(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN { printf "%.0f", e - s }')
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  runs=${runs:-0}
  rate=$(awk -v r="$runs" -v s="$seconds" 'BEGIN { printf "%.0f", (s > 0 ? r / s : 0) }')
  [[ $status -eq 0 ]] || result="FINDING (exit $status): see $log and $findings"
  printf '%-22s %12s %8s %10s %s\n' "$target" "$runs" "$seconds" "$rate" "$result" \
    > "$build_dir/fuzz-logs/$target.result"
}

# The targets run side by side, FUZZ_JOBS at a time (one per core by default): each is one
# single-threaded process with its own corpus, so a target's time budget stays its own.
mkdir -p "$build_dir/fuzz-logs"
running=0
for target in "${targets[@]}"; do
  rm -f "$build_dir/fuzz-logs/$target.result"
  fuzz_one "$target" &
  running=$((running + 1))
  if [[ $running -ge $jobs ]]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait || true

failed=()
printf '%-22s %12s %8s %10s %s\n' target executions seconds exec/s result
for target in "${targets[@]}"; do
  result_file="$build_dir/fuzz-logs/$target.result"
  if [[ ! -f "$result_file" ]]; then
    echo "$target: no result (the run itself failed)"
    failed+=("$target")
    continue
  fi
  cat "$result_file"
  grep -q ' ok$' "$result_file" || failed+=("$target")
done
if [[ ${#failed[@]} -gt 0 ]]; then
  echo "fuzz: findings in ${failed[*]}" >&2
  for target in "${failed[@]}"; do
    echo "--- $target:" >&2
    # The report, an assertion or an uncaught exception, and the project's and toml++'s frames.
    grep -E 'FUZZ FINDING|ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error|SUMMARY|Assertion|terminate called|what\(\)| in (imm|toml)::' \
      "$build_dir/fuzz-logs/$target.log" | head -30 >&2 || true
  done
  exit 1
fi
