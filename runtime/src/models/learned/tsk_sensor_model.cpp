// SPDX-License-Identifier: Apache-2.0
#include "imm/models/learned/tsk_sensor_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"

namespace imm {
namespace {

constexpr double kCenterReach = 10.0;  // centers within this many box widths of the box
constexpr double kWidthRange = 1e-6;   // widths within [kWidthRange, 1/kWidthRange] box widths

}  // namespace

namespace {
constexpr std::array kTNormNames{EnumName<TNorm>{TNorm::kMin, "min"},
                                 EnumName<TNorm>{TNorm::kProduct, "product"}};
}  // namespace

std::string_view to_string(TNorm t_norm) { return name_of(kTNormNames, t_norm); }

TNorm t_norm_from(std::string_view name, const std::string& field) {
  return value_named(kTNormNames, name, field, "t-norm");
}

TskSensorModel::TskSensorModel(std::array<TskOutput, 2> outputs, TNorm t_norm,
                               const Eigen::Vector2d& input_lower,
                               const Eigen::Vector2d& input_upper, OutsideBox outside)
    : outputs_(std::move(outputs)),
      t_norm_(t_norm),
      outside_(outside),
      lower_(input_lower),
      upper_(input_upper) {
  if (!lower_.allFinite()) throw InvalidParameter("input_lower", "must be finite");
  if (!upper_.allFinite()) throw InvalidParameter("input_upper", "must be finite");
  if (!(lower_.array() < upper_.array()).all()) {
    throw InvalidParameter("input_upper", "must exceed input_lower in every input");
  }
  // Centers and widths in proportion to the box keep every log-weight finite for inputs in the
  // box (|x − m|/s ≤ 11 · 10⁶), so evaluation cannot produce 0/0 or ∞ − ∞.
  const Eigen::Array2d span = (upper_ - lower_).array();
  for (std::size_t i = 0; i < outputs_.size(); ++i) {
    const std::string field = "outputs[" + std::to_string(i) + "]";
    const TskOutput& out = outputs_[i];
    if (out.rules.empty() || out.rules.size() > kMaxRules) {
      throw InvalidParameter(field + ".rules", "need 1 to " + std::to_string(kMaxRules) + " rules");
    }
    limits::require_in(out.sigma, limits::kNoiseSigma, field + ".sigma");
    for (std::size_t r = 0; r < out.rules.size(); ++r) {
      const TskRule& rule = out.rules[r];
      const std::string rf = field + ".rules[" + std::to_string(r) + "]";
      if (!rule.center.allFinite() ||
          !(rule.center.array() >= lower_.array() - kCenterReach * span).all() ||
          !(rule.center.array() <= upper_.array() + kCenterReach * span).all()) {
        throw InvalidParameter(rf + ".center",
                               "must be finite and within 10 box widths of the "
                               "input box");
      }
      if (!rule.width.allFinite() || !(rule.width.array() >= kWidthRange * span).all() ||
          !(rule.width.array() <= span / kWidthRange).all()) {
        throw InvalidParameter(rf + ".width",
                               "must be within 10⁻⁶ … 10⁶ box widths (positive and finite)");
      }
      if (!rule.consequent.allFinite()) {
        throw InvalidParameter(rf + ".consequent", "must be finite");
      }
    }
  }
  // The consequents are hyperplanes: finite at the box's corners means finite in the box.
  for (std::size_t i = 0; i < outputs_.size(); ++i) {
    for (int corner = 0; corner < 5; ++corner) {
      const Eigen::Vector2d x = corner == 4 ? Eigen::Vector2d(0.5 * (lower_ + upper_))
                                            : Eigen::Vector2d((corner & 1) ? upper_(0) : lower_(0),
                                                              (corner & 2) ? upper_(1) : lower_(1));
      Eigen::Vector2d gradient;
      const double h = output(outputs_[i].rules, t_norm_, x, &gradient);
      if (!std::isfinite(h) || !gradient.allFinite()) {
        throw InvalidParameter("outputs[" + std::to_string(i) + "].rules",
                               "evaluate to a non-finite value in the input box");
      }
    }
  }
}

TskFiring TskSensorModel::fire(const std::vector<TskRule>& rules, TNorm t_norm,
                               const Eigen::Vector2d& input) {
  // log wʳ first, then the weights scaled by the largest (which becomes exp(0) = 1, so Σ w ≥ 1).
  TskFiring f;
  f.rules = std::min<std::size_t>(rules.size(), kMaxRules);
  std::array<double, kMaxRules> log_w{};
  double largest = -std::numeric_limits<double>::infinity();
  for (std::size_t r = 0; r < f.rules; ++r) {
    const TskRule& rule = rules[r];
    const Eigen::Array2d u = (input - rule.center).array() / rule.width.array();
    f.scaled[r] = u;
    const Eigen::Array2d log_a = -0.5 * u * u;
    if (t_norm == TNorm::kProduct) {
      log_w[r] = log_a.sum();
      f.active[r] = Eigen::Array2d::Ones();
    } else {
      const int s = log_a(1) < log_a(0) ? 1 : 0;  // the minimum; the first at a tie
      log_w[r] = log_a(s);
      f.active[r] = Eigen::Array2d::Zero();
      f.active[r](s) = 1.0;
    }
    largest = std::max(largest, log_w[r]);
  }
  double sum_w = 0.0, sum_wz = 0.0;
  for (std::size_t r = 0; r < f.rules; ++r) {
    f.share[r] = std::exp(log_w[r] - largest);
    const Eigen::Vector3d& a = rules[r].consequent;
    f.rule_output[r] = a(0) + a(1) * input(0) + a(2) * input(1);
    sum_w += f.share[r];
    sum_wz += f.share[r] * f.rule_output[r];
  }
  for (std::size_t r = 0; r < f.rules; ++r) f.share[r] /= sum_w;
  f.value = sum_wz / sum_w;
  return f;
}

double TskSensorModel::output(const std::vector<TskRule>& rules, TNorm t_norm,
                              const Eigen::Vector2d& input, Eigen::Vector2d* gradient) {
  const TskFiring f = fire(rules, t_norm, input);
  if (gradient) {
    // ∂h/∂x = Σ shareʳ [∂ log wʳ/∂x (zʳ − h) + a_xʳ], ∂ log A/∂x = −u/s, u = (x − m)/s.
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (std::size_t r = 0; r < f.rules; ++r) {
      const TskRule& rule = rules[r];
      const Eigen::Array2d d_log_w = f.active[r] * (-f.scaled[r] / rule.width.array());
      g += f.share[r] *
           (d_log_w.matrix() * (f.rule_output[r] - f.value) + rule.consequent.tail<2>());
    }
    *gradient = g;
  }
  return f.value;
}

TskEvaluation TskSensorModel::evaluate(const Eigen::Vector2d& input) const {
  TskEvaluation result;
  const Eigen::Vector2d x = input.cwiseMax(lower_).cwiseMin(upper_);
  const Eigen::Array2d inside =
      (input.array() >= lower_.array() && input.array() <= upper_.array()).cast<double>();
  result.clamped = (inside < 1.0).any();
  for (int i = 0; i < 2; ++i) {
    Eigen::Vector2d gradient;
    result.value(i) = output(outputs_[static_cast<std::size_t>(i)].rules, t_norm_, x, &gradient);
    result.jacobian.row(i) = gradient.transpose();
  }
  if (result.clamped) {
    if (outside_ == OutsideBox::kLinear) {
      result.value += result.jacobian * (input - x);
    } else {
      result.jacobian.array().rowwise() *= inside.transpose();
    }
  }
  return result;
}

Eigen::Matrix2d TskSensorModel::noise_covariance() const {
  return Eigen::Vector2d(outputs_[0].sigma * outputs_[0].sigma,
                         outputs_[1].sigma * outputs_[1].sigma)
      .asDiagonal();
}

}  // namespace imm
