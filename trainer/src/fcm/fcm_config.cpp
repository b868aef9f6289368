// SPDX-License-Identifier: Apache-2.0
// The FCM-IMM trainer's config: loaded, defaulted from the regime, checked.
#include <cmath>
#include <utility>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "imm/trainer/regime_checks.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::fcm {
namespace {

std::pair<double, double> range(const support::ConfigTable& t, std::string_view key,
                                std::pair<double, double> fallback) {
  if (!t.has(key)) return fallback;
  const Eigen::VectorXd r = t.reals(key, 2);
  return {r(0), r(1)};
}

// The config's own keys (config_on has read its regime and seed).
void fill(const support::ConfigTable& root, FcmTrainingConfig& c) {
  const double a = acceleration_scale(c.regime);
  FcmImmSpec& s = c.filter;
  s.sample_period = c.regime.sample_period;
  s.measurement_sigma = c.regime.sensor.noise.sigma(0);
  int modes = 3;
  double stay = 0.95;
  s.process_noise.clear();
  if (const auto f = root.table("filter")) {
    modes = f->count_or("modes", modes);
    if (modes < 1 || modes > 8) f->fail("modes", "must be in [1, 8]");
    if (f->is_array("process_noise")) {
      const Eigen::VectorXd q = f->reals("process_noise", modes);
      s.process_noise.assign(q.data(), q.data() + q.size());
    } else if (f->has("process_noise") && f->text("process_noise") != "auto") {
      f->fail("process_noise", "expected \"auto\" or a list of variances");
    }
    stay = f->real_or("stay", stay);
    if (!(stay > 0.0 && stay <= 1.0)) f->fail("stay", "must be in (0, 1]");
    c.initial_first_probability =
        f->real_or("initial_first_probability", c.initial_first_probability);
    if (!(c.initial_first_probability >= 0.0 && c.initial_first_probability <= 1.0)) {
      f->fail("initial_first_probability", "must be in [0, 1]");
    }
    if (f->has("membership_scale")) {
      s.scale = membership_scale_from(f->text("membership_scale"), f->path("membership_scale"));
    }
    s.compensate_lowest = f->boolean_or("compensate_lowest", s.compensate_lowest);
    s.window = f->count_or("window", s.window);
    s.clustering.fuzzifier = f->real_or("fuzzifier", s.clustering.fuzzifier);
    s.clustering.tolerance = f->real_or("tolerance", s.clustering.tolerance);
    s.clustering.max_iterations = f->count_or("max_iterations", s.clustering.max_iterations);
    s.separation = f->real_or("separation", s.separation);
    s.compensation_gain = f->real_or("compensation_gain", s.compensation_gain);
  }
  if (s.process_noise.empty()) {
    // Starting values log-spaced from 10⁻⁴ a² to 0.7 a² (the fit starts from the tuned IMM).
    for (int j = 0; j < modes; ++j) {
      const double f = modes == 1 ? 1.0 : static_cast<double>(j) / (modes - 1);
      s.process_noise.push_back(a * a * std::pow(10.0, -4.0 + f * (4.0 + std::log10(0.7))));
    }
  }
  s.transition = FcmImmSpec::switching_transition(modes, stay);
  AxisImmSettings settings;
  settings.initial_first_probability = c.initial_first_probability;
  s.initial_probabilities = settings.initial_probabilities(modes);
  c.tuning.set_automatic_log_q(c.regime);
  if (const auto u = root.table("tuning")) {
    FcmTuning& g = c.tuning;
    if (u->has("windows")) {
      const Eigen::VectorXd w = u->reals("windows");
      g.windows.clear();
      for (double v : w) {
        // Checked before the conversion: a double outside int's range does not convert (the
        // spec's validate() then checks the window range).
        if (v != std::floor(v) || std::abs(v) > 1e6) {
          u->fail("windows", "must be integers in [-1e6, 1e6]");
        }
        g.windows.push_back(static_cast<int>(v));
      }
    }
    if (u->is_array("log10_q")) {
      std::tie(g.min_log_q, g.max_log_q) = range(*u, "log10_q", {g.min_log_q, g.max_log_q});
    } else if (u->has("log10_q") && u->text("log10_q") != "auto") {
      u->fail("log10_q", "expected \"auto\" or [min, max]");
    }
    std::tie(g.min_stay, g.max_stay) = range(*u, "stay", {g.min_stay, g.max_stay});
    std::tie(g.min_gain, g.max_gain) = range(*u, "compensation_gain", {g.min_gain, g.max_gain});
    std::tie(g.min_fuzzifier, g.max_fuzzifier) =
        range(*u, "fuzzifier", {g.min_fuzzifier, g.max_fuzzifier});
    std::tie(g.min_separation, g.max_separation) =
        range(*u, "separation", {g.min_separation, g.max_separation});
    g.max_evaluations = u->count_or("max_evaluations", g.max_evaluations);
  }
  if (const auto g = root.table("gate")) {
    c.max_validation_ratio = g->real_or("max_validation_ratio", c.max_validation_ratio);
  }
  c.validate();
}

}  // namespace

void FcmTuning::set_automatic_log_q(const datasets::Regime& regime) {
  const double a = acceleration_scale(regime);
  min_log_q = std::log10(1e-7 * a * a);
  max_log_q = std::log10(9.0 * a * a);
}

void FcmTrainingConfig::validate() const {
  require_per_axis_sensor(regime, "the FCM-IMM");
  try {
    filter.validate();
  } catch (const InvalidParameter& error) {
    // The spec's field names, in the config's vocabulary.
    std::string key = error.field();
    if (key.rfind("clustering.", 0) == 0) key = key.substr(std::string("clustering.").size());
    if (key.rfind("process_noise", 0) == 0) key = "process_noise";
    if (key == "transition") key = "stay";
    if (key == "initial_probabilities") key = "initial_first_probability";
    throw InvalidParameter("filter." + key, error.message());
  }
  const FcmTuning& g = tuning;
  require(!g.windows.empty() && g.windows.size() <= 16, "tuning.windows", "need 1 to 16 windows");
  for (int w : g.windows) {
    require(w >= 3 && w <= SlidingFuzzyCMeans::kMaxWindow, "tuning.windows",
            "every window must be in [3, " + std::to_string(SlidingFuzzyCMeans::kMaxWindow) + "]");
  }
  // q = 10^x must stay a variance in range (imm/core/physical_limits.hpp).
  require(g.min_log_q >= -30.0 && g.max_log_q <= 18.0 && g.min_log_q < g.max_log_q,
          "tuning.log10_q", "must be [min, max] within [-30, 18], min < max");
  require(g.min_stay > 0.0 && g.max_stay <= 1.0 && g.min_stay < g.max_stay, "tuning.stay",
          "must be [min, max] within (0, 1]");
  require(g.min_gain >= 0.0 && g.max_gain <= 1.0 && g.min_gain <= g.max_gain,
          "tuning.compensation_gain", "must be [min, max] within [0, 1]");
  require(g.min_fuzzifier >= 1.01 && g.max_fuzzifier >= g.min_fuzzifier && g.max_fuzzifier <= 100.0,
          "tuning.fuzzifier", "must be [min, max] with 1.01 ≤ min ≤ max ≤ 100");
  require(g.min_separation >= 0.0 && g.max_separation >= g.min_separation &&
              g.max_separation <= limits::kFactor.max,
          "tuning.separation", "must be [min, max] with 0 ≤ min ≤ max ≤ 10⁶");
  require(g.max_evaluations >= 0 && g.max_evaluations <= 100000, "tuning.max_evaluations",
          "must be in [0, 100000]");
  require(max_validation_ratio > 0.0 && std::isfinite(max_validation_ratio),
          "gate.max_validation_ratio", "must be positive");
}

FcmTrainingConfig fcm_config_from_text(const std::string& text, const std::string& name,
                                       const datasets::Regime& regime) {
  const auto document = support::ConfigDocument::parse(text, name);
  FcmTrainingConfig config = document->load_checked([&] {
    if (document->root().has("regime")) (void)document->root().text("regime");  // recorded apart
    return config_on<FcmTrainingConfig>(document->root(), regime, fill);
  });
  config.text = text;
  config.name = name;
  return config;
}

FcmTrainingConfig model_training_config(const std::string& text, const std::string& name,
                                        const datasets::Regime& regime, const FcmImmSpec& spec,
                                        std::string& note) {
  try {
    return fcm_config_from_text(text, name, regime);
  } catch (const std::exception& error) {
    note = std::string("its recorded training config does not load here (") + error.what() +
           "); the baselines are searched from its own settings";
  }
  FcmTrainingConfig config;
  config.regime = regime;
  config.filter = spec;
  config.initial_first_probability = spec.initial_probabilities(0);
  config.tuning.set_automatic_log_q(config.regime);
  return config;
}

FcmTrainingConfig load_fcm_config(const std::filesystem::path& path,
                                  const std::optional<std::filesystem::path>& regime) {
  return load_training_config<FcmTrainingConfig>(path, fill, regime);
}

}  // namespace imm::trainer::fcm
