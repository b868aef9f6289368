// SPDX-License-Identifier: Apache-2.0
#pragma once
// The experiments of immtrain_lab: evaluate(experiment, …) and rank(…).

#include <pybind11/pybind11.h>

/// evaluate(…) and rank(…) on module `m`.
void add_experiments(pybind11::module_& m);
