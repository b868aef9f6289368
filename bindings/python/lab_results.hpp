// SPDX-License-Identifier: Apache-2.0
#pragma once
// The experiments' results (imm/evaluation/experiments.hpp) as Python dicts of numbers, lists and
// numpy arrays; a data set's tracks as numpy arrays.

#include <pybind11/pybind11.h>

#include <optional>

#include "imm/datasets/track.hpp"
#include "imm/evaluation/experiments.hpp"

/// truth (tracks × scans × 6), plots (tracks × scans × 2), times (scans), maneuvering
/// (tracks × scans), case (tracks), and the set's regime, split, seed, sample_period, has_truth.
pybind11::dict track_arrays(const imm::datasets::TrackSet& set);

/// ValueError "runs: must be ≥ 1 (got N)" for a count of tracks below one.
void require_runs(const std::optional<int>& runs);

/// Each result as a dict: what every experiment shares (experiment, model, regime, runs, seed,
/// filters, failures, findings, exit_code, …) and its own tables.
pybind11::dict to_dict(const imm::evaluation::PlainImmResult& r);
pybind11::dict to_dict(const imm::evaluation::GaImmResult& r);
pybind11::dict to_dict(const imm::evaluation::WimmResult& r);
pybind11::dict to_dict(const imm::evaluation::FcmImmResult& r);
pybind11::dict to_dict(const imm::evaluation::FimmResult& r);
pybind11::dict to_dict(const imm::evaluation::InputEstimatorResult& r);
pybind11::dict to_dict(const imm::evaluation::RankResult& r);
/// The conditions of the multi-target experiment, a dict each.
pybind11::list to_list(const imm::evaluation::MultiTargetConditions& r);
