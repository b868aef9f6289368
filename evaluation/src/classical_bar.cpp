// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/classical_bar.hpp"

#include <array>
#include <iostream>
#include <sstream>

#include "imm/datasets/track.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/trainer/classical/classical_imm.hpp"

namespace imm::evaluation {

namespace {

// "modes cv,ct, q cv 0.02 ct 10 (ω 1.9e-05 rad²/s⁴) (m/s²)², stay 0.992"
std::string describe_spec(const PlainImmSpec& spec, const std::string& length) {
  std::ostringstream text;
  text.precision(4);
  text << "modes ";
  for (std::size_t j = 0; j < spec.modes.size(); ++j) {
    text << (j > 0 ? "," : "") << to_string(spec.modes[j].motion);
  }
  text << ", q";
  for (const ModeSpec& m : spec.modes) {
    text << ' ' << m.name << ' ' << m.process_noise;
    if (m.motion == MotionKind::kCoordinatedTurn) text << " (ω " << m.turn_noise << " rad²/s⁴)";
  }
  text << " (" << length << "/s²)², stay " << spec.transition(0, 0);
  return text.str();
}

// The bar from a file: a classical plain_imm model of `own`.
ClassicalBar read_classical_bar(const datasets::Regime& own, const std::filesystem::path& file) {
  const io::ModelFileReader reader(file, io::kPlainImmKind);
  const io::Provenance& provenance = reader.provenance();
  const auto flag = provenance.training_metrics.find("classical_baseline");
  if (flag == provenance.training_metrics.end() || flag->second != 1.0) {
    throw std::runtime_error("--classical " + file.string() +
                             ": not a classical IMM written by imm-train baseline");
  }
  if (provenance.regime_digest != own.digest) {
    throw std::runtime_error("--classical " + file.string() + ": tuned for regime " +
                             provenance.regime_name + " (digest " +
                             provenance.regime_digest.substr(0, 12) + "), not the model's " +
                             own.name + " (" + own.digest.substr(0, 12) + ")");
  }
  ClassicalBar bar;
  bar.spec = io::read_plain_imm(file);
  bar.parameters = describe_spec(bar.spec, std::string(datasets::to_string(own.units))) + " (" +
                   file.string() + ")";
  for (const char* criterion : {"zeta_p_plus_zeta_v", "excess_nll"}) {
    if (const auto it = provenance.training_metrics.find(criterion);
        it != provenance.training_metrics.end()) {
      bar.training_objective = it->second;
    }
  }
  return bar;
}

}  // namespace

std::optional<ClassicalBar> tune_classical_bar(const datasets::Regime& own,
                                               const std::optional<std::filesystem::path>& file) {
  if (own.sensor.kind != datasets::SensorKind::kCartesian &&
      own.sensor.kind != datasets::SensorKind::kPolar) {
    return std::nullopt;
  }
  if (file) return read_classical_bar(own, *file);
  trainer::classical::ClassicalImmConfig config;  // configs/classical_imm.toml's search
  config.regime = own;
  const datasets::TrackSet training =
      datasets::draw_split(own, datasets::Split::kTraining, own.splits.seed);
  const trainer::classical::TunedClassicalImm tuned =
      trainer::classical::tune_classical_imm(config, training);
  return ClassicalBar{tuned.spec,
                      describe_spec(tuned.spec, std::string(datasets::to_string(own.units))) +
                          " (" + std::to_string(tuned.evaluations) +
                          " evaluations on the training split)",
                      tuned.score.objective};
}

std::optional<BarComparison> compare_with_bar(
    const std::string& learned_name, const FilterFactory& learned, const TrackOptions& options,
    const datasets::Regime& own, const datasets::TrackSet& data, const Eigen::Vector2d& sensor,
    const std::optional<std::filesystem::path>& file) {
  const std::optional<ClassicalBar> bar = tune_classical_bar(own, file);
  if (!bar) return std::nullopt;
  BarComparison c;
  c.parameters = bar->parameters;
  c.length = std::string(datasets::to_string(own.units));
  c.outcomes.push_back(run_monte_carlo(learned_name, learned, options, data, {}, sensor));
  c.outcomes.push_back(run_monte_carlo(
      std::string(kClassicalBarName), [&] { return make_plain_imm_filter(bar->spec); },
      bar->spec.track_options(), data, {}, sensor));
  const int runs = static_cast<int>(data.tracks.size());
  const FilterOutcome& ours = c.outcomes[0];
  const FilterOutcome& theirs = c.outcomes[1];
  const std::vector<HeadlineMetric> ours_metrics =
      data.has_truth ? ours.zeta_headline() : ours.plot_headline();
  const std::vector<HeadlineMetric> bar_metrics =
      data.has_truth ? theirs.zeta_headline() : theirs.plot_headline();
  const std::size_t second = data.has_truth ? 1 : 2;
  c.criteria = data.has_truth ? std::array<std::string, 2>{"ζ_p", "ζ_v"}
                              : std::array<std::string, 2>{"predictive NLL", "innovation RMS"};
  c.values = {{{ours_metrics[0].value(), ours_metrics[second].value()},
               {bar_metrics[0].value(), bar_metrics[second].value()}}};
  c.differences = {
      paired_difference(runs, ours_metrics[0].statistic(), bar_metrics[0].statistic()),
      paired_difference(runs, ours_metrics[second].statistic(), bar_metrics[second].statistic())};
  c.verdict = std::string(verdict(c.differences));
  const std::array<HeadlineMetric, 2> in_maneuvers{ours.maneuver_position_rmse(),
                                                   theirs.maneuver_position_rmse()};
  c.maneuver_rmse = {in_maneuvers[0].value(), in_maneuvers[1].value()};
  if (data.has_truth && std::isfinite(in_maneuvers[1].value())) {
    c.maneuvers = paired_difference(runs, in_maneuvers[0].statistic(), in_maneuvers[1].statistic());
  }
  std::ostringstream line;
  line << learned_name << " " << c.verdict << " " << kClassicalBarName << " (" << c.criteria[0]
       << " " << c.differences[0].text() << ", " << c.criteria[1] << " " << c.differences[1].text()
       << (c.maneuvers ? ", position RMSE in manoeuvres " + c.maneuvers->text(2) + " " + c.length
                       : "")
       << ")";
  c.summary = line.str();
  return c;
}

nlohmann::json BarComparison::json() const {
  nlohmann::json json = {{"bar", parameters}, {"verdict", verdict}};
  for (std::size_t i = 0; i < 2; ++i) {
    const FilterOutcome& f = outcomes[i];
    json["filters"][f.name] = {{"criteria", {values[i][0], values[i][1]}},
                               {"position_rmse", f.position_rmse},
                               {"position_nees", f.position_consistency.average},
                               {"nis", f.nis_consistency.average}};
  }
  json["differences"] = {
      {criteria[0], {differences[0].estimate, differences[0].lower, differences[0].upper}},
      {criteria[1], {differences[1].estimate, differences[1].lower, differences[1].upper}}};
  return json;
}

void print_bar_comparison(const BarComparison& c) {
  std::vector<std::vector<std::string>> rows;
  for (std::size_t i = 0; i < 2; ++i) {
    const FilterOutcome& f = c.outcomes[i];
    rows.push_back({f.name, cell(c.values[i][0]), cell(c.values[i][1]),
                    f.has_truth ? cell(f.position_rmse) : "–",
                    c.maneuvers ? cell(c.maneuver_rmse[i]) : "–",
                    cell(f.position_consistency.average, 2), cell(f.nis_consistency.average, 2)});
  }
  std::cout << "\nAgainst " << kClassicalBarName << " (the classical bar: " << c.parameters
            << "), on the same 2-D test tracks:\n\n"
            << markdown_table(
                   {"filter", c.criteria[0], c.criteria[1], "position RMSE (" + c.length + ")",
                    "in manoeuvres (" + c.length + ")", "position NEES", "NIS"},
                   rows)
            << '\n'
            << c.summary << '\n';
}

nlohmann::json compare_with_classical_bar(
    const std::string& learned_name, const FilterFactory& learned, const TrackOptions& options,
    const datasets::Regime& own, const datasets::TrackSet& data, const Eigen::Vector2d& sensor,
    std::vector<std::string>& findings, const std::optional<std::filesystem::path>& file) {
  const std::optional<BarComparison> c =
      compare_with_bar(learned_name, learned, options, own, data, sensor, file);
  if (!c) return nullptr;
  print_bar_comparison(*c);
  if (c->verdict != "beats") findings.push_back(c->summary);
  return c->json();
}

}  // namespace imm::evaluation
