#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Training from plots alone against training with truth, on the same tracks.
#
#   scripts/study-recorded.sh REGIME CONFIG KIND EXPERIMENT [OUT]
#   e.g. scripts/study-recorded.sh configs/regimes/agile_air.toml configs/ga_fuzzy_imm_tuned.toml \
#            ga ga-imm
#
# Exports the regime's training + validation tracks (as many as its [splits] name, drawn from its
# training stream) as recordings with their truth and imports them; writes two recorded regimes
# over that one set, truth = "training" (the trainer learns from the truth) and truth =
# "evaluation" (it learns from the plots alone; the manoeuvres' scale is estimated from them too);
# trains KIND with CONFIG for both; evaluates both with EXPERIMENT on the synthetic regime's test
# split, with truth; and compares them with `imm-eval regression` (candidate: without truth;
# shipped: with truth). The sensor (its kind and σ) is the regime's in both; with
# ESTIMATE_SIGMA=1 the run without truth learns σ from the plots too (sigma = "estimate": the
# synthetic regime accepts a model whose σ is within 10 % of its own).
set -eu
regime=$1 config=$2 kind=$3 experiment=$4
out=${5:-reports/study-recorded/$(basename "$regime" .toml)-$kind}
bin=${BUILD_DIR:-build}/bin
split_key() { sed -n "/^\[splits\]/,/^\[/s/^$1 *= *//p" "$regime" | head -1; }
training=$(split_key training)
validation=$(split_key validation)
sensor=$(sed -n '/^\[sensor\]/,/^\[/{/^\[/d;s/ *#.*//;/^ *$/d;p}' "$regime")
sensor_kind=$(sed -n '/^\[sensor\]/,/^\[/s/^kind *= *"\(.*\)".*/\1/p' "$regime" | head -1)
units=$(sed -n 's/^units *= *"\(.*\)"$/\1/p' "$regime" | head -1)
rm -rf "$out" && mkdir -p "$out"
"$bin/imm-data" export --regime "$regime" --split training --count $((training + validation)) \
  --out-dir "$out/recordings"
"$bin/imm-data" import --out "$out/set.h5" --units "$units" --sensor "${sensor_kind:-cartesian}" "$out"/recordings/*.csv
for truth in training evaluation; do
  plots_sensor=$sensor
  if [ "$truth" = evaluation ] && [ "${ESTIMATE_SIGMA:-0}" = 1 ]; then
    plots_sensor=$(printf 'kind = "%s"\nsigma = "estimate"' "${sensor_kind:-cartesian}")
  fi
  cat > "$out/$truth.toml" <<TOML
name = "$(basename "$regime" .toml)_recorded_$truth"
units = "$units"
[recorded]
set = "$out/set.h5"
truth = "$truth"
[sensor]
$plots_sensor
[splits]
training = $training
validation = $validation
test = 0
TOML
  "$bin/imm-train" "$kind" --config "$config" --regime "$out/$truth.toml" \
    --out "$out/$kind-$truth.h5" > "$out/train-$truth.log" 2>&1 || {
    status=$?; [ $status -eq 0 ] || [ $status -eq 7 ] || { cat "$out/train-$truth.log"; exit $status; }; }
  "$bin/imm-eval" "$experiment" --model "$out/$kind-$truth.h5" --regime "$regime" \
    --out "$out/eval-$truth" > "$out/eval-$truth.log" 2>&1 || true
done
"$bin/imm-eval" regression --candidate "$out/eval-evaluation" --shipped "$out/eval-training" \
  --out "$out/regression" | tee "$out/regression.txt"
