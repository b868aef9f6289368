// SPDX-License-Identifier: Apache-2.0
#pragma once
// immtrain.Filter (filter_binding.cpp), added to the module by immtrain_module.cpp.

#include <pybind11/pybind11.h>

/// Adds the Filter class to `m`.
void add_filter_binding(pybind11::module_& m);
