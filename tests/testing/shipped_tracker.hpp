// SPDX-License-Identifier: Apache-2.0
#pragma once
// What `imm-eval rank --ship` writes: the winner's model file with its covariance calibration
// (/calibration, fitted on the regime's training split) and its envelope refitted to the
// calibrated NIS; every other object and attribute is the winner's.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "imm/io/container_file.hpp"
#include "imm/io/model_file.hpp"

namespace imm::testing {

inline void expect_winner_with_calibration(const std::filesystem::path& shipped,
                                           const std::filesystem::path& winner) {
  const io::ContainerReader s(shipped, io::kModelFormat), w(winner, io::kModelFormat);
  for (const std::string& object : w.objects()) {
    if (object.starts_with("/envelope") || object.starts_with("/calibration")) continue;
    ASSERT_EQ(s.kind(object), w.kind(object)) << object;
    if (w.kind(object) == io::ObjectKind::kDataset) {
      EXPECT_EQ(s.read(object).values, w.read(object).values) << object;
    }
    for (const std::string& name : w.attribute_names(object)) {
      EXPECT_EQ(s.attribute(object, name), w.attribute(object, name)) << object << "@" << name;
    }
  }
  EXPECT_EQ(s.kind("/calibration"), io::ObjectKind::kGroup) << shipped;
}

}  // namespace imm::testing
