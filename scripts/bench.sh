#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# `make bench`: runs the benchmarks (5 repetitions, medians; the trainer's on one thread) and
# writes their medians to reports/bench/latest.json beside the previous run's, flagging any
# benchmark more than 10 % slower; the last nightly's stage wall times (reports/nightly/nights.jsonl)
# go beside them, and the machine (CPU model, clock, threads, BLAS). Usage: scripts/bench.sh
# BUILD_DIR [FILTER]
set -euo pipefail
build=${1:-build}
filter=${2:-.}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
common=(--benchmark_repetitions=5 --benchmark_report_aggregates_only=true
        --benchmark_filter="$filter" --benchmark_out_format=json)
"$build/bin/imm-bench" "${common[@]}" --benchmark_out="$work/runtime.json"
OMP_NUM_THREADS=1 "$build/bin/imm-train-bench" "${common[@]}" --benchmark_out="$work/trainer.json"
# A FILTER that matches only one program's benchmarks leaves the other's output empty.
outputs=()
for output in "$work/runtime.json" "$work/trainer.json"; do
  if [[ -s "$output" ]]; then outputs+=("$output"); fi
done
if [[ ${#outputs[@]} -eq 0 ]]; then
  echo "bench: no benchmark matches '$filter'" >&2
  exit 1
fi
# The last nightly's wall time per stage beside them (the trainings' cost), when there was one.
nightly=()
if [[ -s reports/nightly/nights.jsonl ]]; then nightly=(--nightly reports/nightly/nights.jsonl); fi
"$build/bin/imm-bench-report" --out reports/bench/latest.json "${nightly[@]}" \
  --threads imm-bench=1 --threads imm-train-bench=1 "${outputs[@]}"
