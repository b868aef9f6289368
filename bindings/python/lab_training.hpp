// SPDX-License-Identifier: Apache-2.0
#pragma once
// train(kind, …) of immtrain_lab: an imm-train training run in this process.

#include <pybind11/pybind11.h>

/// train(…) on module `m`.
void add_training(pybind11::module_& m);
