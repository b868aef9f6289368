// SPDX-License-Identifier: Apache-2.0
#pragma once
// The benchmarks' main: Google Benchmark's, with --lane_isa.

#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/math/lane_isa.hpp"

namespace imm::bench {

// --lane_isa=avx512|avx2|baseline caps the instruction set of the pack kernels (the TrackBank, the
// GA-fuzzy bank, the GA fitness batch; imm/math/lane_isa.hpp), so that one machine measures the
// narrower ones; the context of every report names the one that ran.
inline int main_with_lane_isa(int argc, char** argv) {
  std::vector<char*> kept;
  for (int i = 0; i < argc; ++i) {
    const std::string_view arg = argv[i];
    constexpr std::string_view kFlag = "--lane_isa=";
    if (!arg.starts_with(kFlag)) {
      kept.push_back(argv[i]);
      continue;
    }
    try {
      imm::cap_lane_isa(imm::value_named(imm::kLaneIsaNames, arg.substr(kFlag.size()), "--lane_isa",
                                         "instruction set"));
    } catch (const imm::InvalidParameter& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 2;
    }
  }
  int count = static_cast<int>(kept.size());
  benchmark::AddCustomContext("lane_isa", std::string(imm::to_string(imm::lane_isa())));
  benchmark::Initialize(&count, kept.data());
  if (benchmark::ReportUnrecognizedArguments(count, kept.data())) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace imm::bench
