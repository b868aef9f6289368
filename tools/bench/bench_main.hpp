// SPDX-License-Identifier: Apache-2.0
#pragma once
// The benchmarks' main: Google Benchmark's, with --lane_isa.

#include <benchmark/benchmark.h>

#include <cstdio>
#include <string_view>
#include <vector>

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
    const std::string_view isa = arg.substr(kFlag.size());
    if (isa == "avx512") {
      imm::cap_lane_isa(imm::LaneIsa::kAvx512);
    } else if (isa == "avx2") {
      imm::cap_lane_isa(imm::LaneIsa::kAvx2);
    } else if (isa == "baseline") {
      imm::cap_lane_isa(imm::LaneIsa::kBaseline);
    } else {
      std::fprintf(stderr, "--lane_isa: '%.*s' is not avx512, avx2 or baseline\n",
                   static_cast<int>(isa.size()), isa.data());
      return 2;
    }
  }
  int count = static_cast<int>(kept.size());
  const imm::LaneIsa running = imm::lane_isa();
  benchmark::AddCustomContext("lane_isa", running == imm::LaneIsa::kAvx512 ? "avx512"
                                          : running == imm::LaneIsa::kAvx2 ? "avx2"
                                                                           : "baseline");
  benchmark::Initialize(&count, kept.data());
  if (benchmark::ReportUnrecognizedArguments(count, kept.data())) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace imm::bench
