// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/headline.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "imm/datasets/sha256.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {
namespace {

const char* form_name(HeadlineMetric::Form form) {
  switch (form) {
    case HeadlineMetric::Form::kRatio:
      return "ratio";
    case HeadlineMetric::Form::kRootRatio:
      return "root_ratio";
    case HeadlineMetric::Form::kScanZeta:
      return "scan_zeta";
  }
  return "ratio";
}

double evaluate(const HeadlineMetric& m, const Eigen::VectorXd& w) {
  if (m.form == HeadlineMetric::Form::kScanZeta) {
    const Eigen::RowVectorXd e = w.transpose() * m.numerator, d = w.transpose() * m.denominator,
                             n = w.transpose() * m.counted;
    double sum = 0.0;
    int scans = 0;
    for (Eigen::Index k = 0; k < e.size(); ++k) {
      if (n(k) > 0.0 && d(k) > 0.0) {
        sum += std::sqrt(e(k) / d(k));
        ++scans;
      }
    }
    return scans > 0 ? sum / scans : std::numeric_limits<double>::quiet_NaN();
  }
  const double ratio = w.dot(m.numerator.col(0)) / w.dot(m.denominator.col(0));
  return m.form == HeadlineMetric::Form::kRootRatio ? std::sqrt(ratio) : ratio;
}

nlohmann::json matrix_json(const Eigen::MatrixXd& matrix) {
  if (matrix.cols() == 1) {
    return std::vector<double>(matrix.data(), matrix.data() + matrix.rows());
  }
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
    std::vector<double> row(static_cast<std::size_t>(matrix.cols()));
    for (Eigen::Index j = 0; j < matrix.cols(); ++j)
      row[static_cast<std::size_t>(j)] = matrix(i, j);
    rows.push_back(std::move(row));
  }
  return rows;
}

Eigen::MatrixXd matrix_from(const nlohmann::json& value, const std::string& where) {
  if (!value.is_array() || value.empty())
    throw std::runtime_error(where + ": not a non-empty array");
  const auto rows = static_cast<Eigen::Index>(value.size());
  const bool nested = value.front().is_array();
  const auto cols = nested ? static_cast<Eigen::Index>(value.front().size()) : Eigen::Index{1};
  if (cols < 1 || rows > 1000000 || cols > 1000000) throw std::runtime_error(where + ": bad shape");
  Eigen::MatrixXd matrix(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i) {
    const auto& row = value[static_cast<std::size_t>(i)];
    for (Eigen::Index j = 0; j < cols; ++j) {
      const auto& entry = nested ? (row.is_array() && row.size() == static_cast<std::size_t>(cols)
                                        ? row[static_cast<std::size_t>(j)]
                                        : throw std::runtime_error(where + ": ragged rows"))
                                 : row;
      if (!entry.is_number()) throw std::runtime_error(where + ": a value is not a number");
      matrix(i, j) = entry.get<double>();
      if (!std::isfinite(matrix(i, j))) throw std::runtime_error(where + ": a value is not finite");
    }
  }
  return matrix;
}

std::filesystem::path headline_file(const std::filesystem::path& path) {
  return std::filesystem::is_directory(path) ? path / "headline.json" : path;
}

}  // namespace

double HeadlineMetric::value() const { return evaluate(*this, Eigen::VectorXd::Ones(runs())); }

Statistic HeadlineMetric::statistic() const {
  return [metric = *this](const Eigen::VectorXd& w) { return evaluate(metric, w); };
}

HeadlineMetric mean_metric(std::string name, const Eigen::VectorXd& per_run) {
  return {std::move(name),
          HeadlineMetric::Form::kRatio,
          per_run,
          Eigen::VectorXd::Ones(per_run.size()),
          {}};
}

HeadlineMetric rms_metric(std::string name, const Eigen::VectorXd& sums,
                          const Eigen::VectorXd& counts) {
  return {std::move(name), HeadlineMetric::Form::kRootRatio, sums, counts, {}};
}

HeadlineMetric ratio_metric(std::string name, const Eigen::VectorXd& sums,
                            const Eigen::VectorXd& counts) {
  return {std::move(name), HeadlineMetric::Form::kRatio, sums, counts, {}};
}

HeadlineMetric in_case(HeadlineMetric metric, Eigen::Index offset, Eigen::Index runs) {
  if (metric.form == HeadlineMetric::Form::kScanZeta || metric.numerator.cols() != 1 ||
      offset < 0 || offset + metric.runs() > runs) {
    throw std::logic_error("in_case: a per-run ratio metric inside the runs");
  }
  auto place = [&](const Eigen::MatrixXd& terms) {
    Eigen::MatrixXd all = Eigen::MatrixXd::Zero(runs, 1);
    all.block(offset, 0, terms.rows(), 1) = terms;
    return all;
  };
  metric.numerator = place(metric.numerator);
  metric.denominator = place(metric.denominator);
  return metric;
}

void write_headline(const std::filesystem::path& out, const HeadlineRuns& runs,
                    const std::vector<HeadlineMetric>& metrics) {
  nlohmann::json document = {{"experiment", runs.experiment},
                             {"model", runs.model.string()},
                             {"model_sha256", datasets::file_sha256_hex(runs.model)},
                             {"regime", runs.regime},
                             {"regime_digest", runs.regime_digest},
                             {"seed", runs.seed},
                             {"runs", runs.runs},
                             {"metrics", nlohmann::json::array()}};
  for (const HeadlineMetric& m : metrics) {
    // The metric's own 95 % bootstrap interval over the runs (its Monte Carlo uncertainty).
    const Difference own = paired_difference(static_cast<int>(m.runs()), m.statistic(),
                                             [](const Eigen::VectorXd&) { return 0.0; });
    nlohmann::json entry = {{"name", m.name},
                            {"form", form_name(m.form)},
                            {"value", m.value()},
                            {"interval", {own.lower, own.upper}},
                            {"numerator", matrix_json(m.numerator)},
                            {"denominator", matrix_json(m.denominator)}};
    if (m.form == HeadlineMetric::Form::kScanZeta) entry["counted"] = matrix_json(m.counted);
    document["metrics"].push_back(std::move(entry));
  }
  trainer::write_json_atomically(out / "headline.json", document);
}

HeadlineFile read_headline(const std::filesystem::path& given) {
  const std::filesystem::path path = headline_file(given);
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(trainer::read_text_file(path));
  } catch (const nlohmann::json::exception& error) {
    throw std::runtime_error(path.string() + ": not JSON (" + error.what() + ")");
  }
  auto field = [&](const char* key) -> const nlohmann::json& {
    if (!document.is_object() || !document.contains(key)) {
      throw std::runtime_error(path.string() + ": missing field '" + key + "'");
    }
    return document.at(key);
  };
  HeadlineFile file;
  try {
    file.runs.experiment = field("experiment").get<std::string>();
    file.runs.model = field("model").get<std::string>();
    file.model_sha256 = field("model_sha256").get<std::string>();
    file.runs.regime = field("regime").get<std::string>();
    file.runs.regime_digest = field("regime_digest").get<std::string>();
    file.runs.seed = field("seed").get<std::uint64_t>();
    file.runs.runs = field("runs").get<int>();
    for (const auto& entry : field("metrics")) {
      HeadlineMetric m;
      m.name = entry.at("name").get<std::string>();
      const std::string where = path.string() + ": metrics." + m.name;
      const std::string form = entry.at("form").get<std::string>();
      if (form == "ratio") {
        m.form = HeadlineMetric::Form::kRatio;
      } else if (form == "root_ratio") {
        m.form = HeadlineMetric::Form::kRootRatio;
      } else if (form == "scan_zeta") {
        m.form = HeadlineMetric::Form::kScanZeta;
      } else {
        std::string message = where;
        message.append(".form: unknown form '").append(form).append("'");
        throw std::runtime_error(message);
      }
      m.numerator = matrix_from(entry.at("numerator"), where + ".numerator");
      m.denominator = matrix_from(entry.at("denominator"), where + ".denominator");
      if (m.form == HeadlineMetric::Form::kScanZeta) {
        m.counted = matrix_from(entry.at("counted"), where + ".counted");
      }
      const bool shapes =
          m.denominator.rows() == m.runs() && m.denominator.cols() == m.numerator.cols() &&
          (m.form != HeadlineMetric::Form::kScanZeta ||
           (m.counted.rows() == m.runs() && m.counted.cols() == m.numerator.cols()));
      if (!shapes || m.runs() != file.runs.runs) {
        throw std::runtime_error(
            where + ": the per-run terms do not match 'runs' = " + std::to_string(file.runs.runs));
      }
      file.metrics.push_back(std::move(m));
    }
  } catch (const nlohmann::json::exception& error) {
    throw std::runtime_error(path.string() + ": " + error.what());
  }
  return file;
}

MarginRule parse_margin(const std::string& text, bool relative) {
  MarginRule rule;
  const auto equals = text.rfind('=');
  const std::string value = equals == std::string::npos ? text : text.substr(equals + 1);
  if (equals != std::string::npos) rule.metric = text.substr(0, equals);
  double number = 0.0;
  std::size_t used = 0;
  try {
    number = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != value.size() || !std::isfinite(number) || number < 0.0) {
    throw std::runtime_error(std::string(relative ? "--relative-margin" : "--absolute-margin") +
                             " '" + text + "': expected [METRIC=]VALUE with a finite VALUE ≥ 0");
  }
  (relative ? rule.relative : rule.absolute) = number;
  return rule;
}

namespace {

// The margin of `metric` at values `a` and `b`: from the longest rule naming it, per field.
double margin_of(const std::string& metric, double a, double b,
                 const std::vector<MarginRule>& rules) {
  const MarginRule* relative = nullptr;
  const MarginRule* absolute = nullptr;
  auto longer = [](const MarginRule* so_far, const MarginRule& rule) {
    return so_far == nullptr || rule.metric.size() >= so_far->metric.size();
  };
  for (const MarginRule& rule : rules) {
    if (metric.find(rule.metric) == std::string::npos) continue;
    if (rule.relative && longer(relative, rule)) relative = &rule;
    if (rule.absolute && longer(absolute, rule)) absolute = &rule;
  }
  return std::max(
      relative != nullptr ? *relative->relative * std::max(std::abs(a), std::abs(b)) : 0.0,
      absolute != nullptr ? *absolute->absolute : 0.0);
}

}  // namespace

std::vector<Regression> compare_headlines(const HeadlineFile& candidate,
                                          const HeadlineFile& shipped,
                                          const std::vector<MarginRule>& margins) {
  const HeadlineRuns& a = candidate.runs;
  const HeadlineRuns& b = shipped.runs;
  auto differ = [&](const std::string& field, const std::string& x, const std::string& y) {
    throw std::runtime_error(
        "the candidate and the shipped model were not evaluated on the same "
        "runs: " +
        field + " '" + x + "' vs '" + y + "'");
  };
  if (a.experiment != b.experiment) differ("experiment", a.experiment, b.experiment);
  if (a.regime_digest != b.regime_digest) differ("regime_digest", a.regime_digest, b.regime_digest);
  if (a.seed != b.seed) differ("seed", std::to_string(a.seed), std::to_string(b.seed));
  if (a.runs != b.runs) differ("runs", std::to_string(a.runs), std::to_string(b.runs));
  std::vector<Regression> regressions;
  for (const HeadlineMetric& ours : candidate.metrics) {
    const auto theirs = std::find_if(shipped.metrics.begin(), shipped.metrics.end(),
                                     [&](const HeadlineMetric& m) { return m.name == ours.name; });
    if (theirs == shipped.metrics.end()) {
      throw std::runtime_error("the shipped model's evaluation has no metric '" + ours.name + "'");
    }
    Regression r;
    r.metric = ours.name;
    r.candidate = ours.value();
    r.shipped = theirs->value();
    r.difference = paired_difference(a.runs, ours.statistic(), theirs->statistic());
    r.margin = margin_of(r.metric, r.candidate, r.shipped, margins);
    regressions.push_back(std::move(r));
  }
  return regressions;
}

namespace {

int regression(const std::filesystem::path& candidate_path,
               const std::filesystem::path& shipped_path,
               const std::optional<std::filesystem::path>& out,
               const std::vector<MarginRule>& margins) {
  const HeadlineFile candidate = read_headline(candidate_path);
  const HeadlineFile shipped = read_headline(shipped_path);
  const std::vector<Regression> regressions = compare_headlines(candidate, shipped, margins);
  std::cout << "regression: " << candidate.runs.experiment << " on regime " << candidate.runs.regime
            << " (" << candidate.runs.runs << " runs, seed " << candidate.runs.seed
            << ")\n  candidate " << candidate.runs.model.string() << " ("
            << candidate.model_sha256.substr(0, 12) << ")\n  shipped   "
            << shipped.runs.model.string() << " (" << shipped.model_sha256.substr(0, 12) << ")\n\n";
  std::vector<std::vector<std::string>> rows;
  nlohmann::json document = {
      {"experiment", candidate.runs.experiment},    {"regime", candidate.runs.regime},
      {"candidate", candidate.runs.model.string()}, {"candidate_sha256", candidate.model_sha256},
      {"shipped", shipped.runs.model.string()},     {"shipped_sha256", shipped.model_sha256},
      {"metrics", nlohmann::json::array()}};
  std::vector<std::string> worse;
  for (const Regression& r : regressions) {
    const std::string verdict = r.worse() ? "worse" : r.better() ? "better" : "tie";
    rows.push_back({r.metric, cell(r.candidate, 6), cell(r.shipped, 6), r.difference.text(6),
                    cell(r.margin, 3), verdict});
    document["metrics"].push_back({{"name", r.metric},
                                   {"candidate", r.candidate},
                                   {"shipped", r.shipped},
                                   {"difference", r.difference.estimate},
                                   {"lower", r.difference.lower},
                                   {"upper", r.difference.upper},
                                   {"margin", r.margin},
                                   {"verdict", verdict}});
    if (r.worse()) worse.push_back(r.metric + " " + r.difference.text());
  }
  std::cout << markdown_table({"metric", "candidate", "shipped", "candidate − shipped [95 %]",
                               "margin", "verdict"},
                              rows)
            << '\n';
  document["held_back"] = !worse.empty();
  if (out) {
    std::filesystem::create_directories(*out);
    trainer::write_json_atomically(*out / "regression.json", document);
  }
  if (!worse.empty()) {
    std::cout << "Regression gate (not worse than the shipped model beyond the uncertainty and "
                 "the margin): FAILED\n";
    for (const auto& w : worse) std::cout << "  - worse: " << w << '\n';
    return support::exit_code::kRegression;
  }
  std::cout << "Regression gate (not worse than the shipped model beyond the uncertainty and the "
               "margin): passed\n";
  return 0;
}

}  // namespace

int run_regression(const RegressionOptions& options) {
  return regression(options.candidate, options.shipped, options.out, options.margins);
}

}  // namespace imm::evaluation
