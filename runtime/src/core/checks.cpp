// SPDX-License-Identifier: Apache-2.0
#include "imm/core/checks.hpp"

#include <cmath>
#include <sstream>

#include "imm/core/invalid_parameter.hpp"

namespace imm {

namespace {
constexpr double kSumTolerance = 1e-9;

std::string entry(const char* name, int i, int j = -1) {
  std::ostringstream out;
  out << name << '[' << i << ']';
  if (j >= 0) out << '[' << j << ']';
  return out.str();
}
}  // namespace

void validate_mode_probabilities(const Eigen::MatrixXd& transition,
                                 const Eigen::VectorXd& initial_probabilities, int modes) {
  if (transition.rows() != modes || transition.cols() != modes) {
    throw InvalidParameter("transition", "must be " + std::to_string(modes) + "x" +
                                             std::to_string(modes) + " for " +
                                             std::to_string(modes) + " modes, got " +
                                             std::to_string(transition.rows()) + "x" +
                                             std::to_string(transition.cols()));
  }
  if (initial_probabilities.size() != modes) {
    throw InvalidParameter("initial_probabilities",
                           "must have " + std::to_string(modes) + " entries, got " +
                               std::to_string(initial_probabilities.size()));
  }
  for (int i = 0; i < modes; ++i) {
    double row_sum = 0.0;
    for (int j = 0; j < modes; ++j) {
      const double p = transition(i, j);
      if (!std::isfinite(p) || p < 0.0 || p > 1.0) {
        throw InvalidParameter("transition", entry("transition", i, j) + " = " + std::to_string(p) +
                                                 " is not a probability");
      }
      row_sum += p;
    }
    if (std::abs(row_sum - 1.0) > kSumTolerance) {
      throw InvalidParameter("transition", "row " + std::to_string(i) + " sums to " +
                                               std::to_string(row_sum) + ", not 1");
    }
  }
  double sum = 0.0;
  for (int i = 0; i < modes; ++i) {
    const double p = initial_probabilities(i);
    if (!std::isfinite(p) || p < 0.0 || p > 1.0) {
      throw InvalidParameter(
          "initial_probabilities",
          entry("initial_probabilities", i) + " = " + std::to_string(p) + " is not a probability");
    }
    sum += p;
  }
  if (std::abs(sum - 1.0) > kSumTolerance) {
    throw InvalidParameter("initial_probabilities", "sum to " + std::to_string(sum) + ", not 1");
  }
}

}  // namespace imm
