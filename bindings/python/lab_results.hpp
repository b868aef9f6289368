// SPDX-License-Identifier: Apache-2.0
#pragma once
// The experiments of immtrain_lab (imm/evaluation/experiments.hpp) and their results as Python
// dicts of numbers, lists and numpy arrays; a data set's tracks as numpy arrays.

#include <pybind11/pybind11.h>

#include "imm/datasets/track.hpp"

/// truth (tracks × scans × 6), plots (tracks × scans × 2), times (scans), maneuvering
/// (tracks × scans), case (tracks), and the set's regime, split, seed, sample_period, has_truth.
pybind11::dict track_arrays(const imm::datasets::TrackSet& set);

/// evaluate(experiment, …) and rank(…) on module `m`.
void add_experiments(pybind11::module_& m);
