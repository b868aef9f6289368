// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/envelope.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/math/chi_square.hpp"

namespace imm {

void EnvelopeSettings::validate() const {
  if (window < 1 || window > kMaxWindow) {
    throw InvalidParameter("envelope.window", "must be in [1, " + std::to_string(kMaxWindow) +
                                                  "], got " + std::to_string(window));
  }
  // The bounds' χ² quantiles at significance / 2 and 1 − significance / 2 must be computable:
  // a significance below kMinSignificance (1e-10) is no test anyone runs, and 5e-324 / 2 is 0.
  if (!(significance >= kMinSignificance && significance < 1.0)) {
    throw InvalidParameter("envelope.significance", "must be in [1e-10, 1)");
  }
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    throw InvalidParameter("envelope.scale", "must be a finite number > 0");
  }
  if (!(dof == 0.0 || (dof >= kMinDof && dof <= kMaxDof))) {
    throw InvalidParameter("envelope.dof", "must be 0 (the window's m · window) or in [0.01, 1e6]");
  }
}

EnvelopeMonitor::EnvelopeMonitor(const EnvelopeSettings& settings, int measurement_dimension)
    : settings_(settings) {
  settings_.validate();
  if (measurement_dimension < 1) {
    throw InvalidParameter("envelope.measurement_dimension", "must be at least 1");
  }
  const double dof = settings_.dof > 0.0
                         ? settings_.dof
                         : static_cast<double>(measurement_dimension) * settings_.window;
  lower_ = settings_.scale * chi_square_quantile(settings_.significance / 2.0, dof);
  upper_ = settings_.scale * chi_square_quantile(1.0 - settings_.significance / 2.0, dof);
}

bool EnvelopeMonitor::add(double nis) noexcept {
  if (!(nis >= 0.0) || !std::isfinite(nis)) return outside_;
  const int window = settings_.window;
  if (filled_ == window) sum_ -= ring_[static_cast<std::size_t>(head_)];
  ring_[static_cast<std::size_t>(head_)] = nis;
  sum_ += nis;
  head_ = (head_ + 1) % window;
  filled_ = filled_ < window ? filled_ + 1 : window;
  // The running sum is recomputed from the ring once per window, so rounding never accumulates.
  if (++since_sum_ >= window) {
    since_sum_ = 0;
    sum_ = 0.0;
    for (int i = 0; i < filled_; ++i) sum_ += ring_[static_cast<std::size_t>(i)];
  }
  outside_ = filled_ == window && (sum_ > upper_ || sum_ < lower_);
  return outside_;
}

double EnvelopeMonitor::mean() const noexcept {
  return filled_ == 0 ? std::numeric_limits<double>::quiet_NaN() : sum_ / filled_;
}

void EnvelopeMonitor::reset() noexcept {
  head_ = 0;
  filled_ = 0;
  since_sum_ = 0;
  sum_ = 0.0;
  outside_ = false;
}

}  // namespace imm
