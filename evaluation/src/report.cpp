// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "imm/evaluation/monte_carlo.hpp"
#include "imm/support/process.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::evaluation {

namespace {
// Display width of UTF-8 text: code points, not bytes ("ζ_p" is three columns wide).
std::size_t display_width(const std::string& text) {
  std::size_t width = 0;
  for (unsigned char c : text) width += (c & 0xC0U) != 0x80U ? 1 : 0;
  return width;
}
}  // namespace

std::string markdown_table(const std::vector<std::string>& header,
                           const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> width(header.size());
  for (std::size_t j = 0; j < header.size(); ++j) width[j] = display_width(header[j]);
  for (const auto& row : rows) {
    for (std::size_t j = 0; j < row.size() && j < width.size(); ++j) {
      width[j] = std::max(width[j], display_width(row[j]));
    }
  }
  auto line = [&](const std::vector<std::string>& cells) {
    std::string text = "|";
    for (std::size_t j = 0; j < width.size(); ++j) {
      const std::string& c = j < cells.size() ? cells[j] : std::string();
      text += " " + c + std::string(width[j] - std::min(width[j], display_width(c)), ' ') + " |";
    }
    return text + "\n";
  };
  std::string table = line(header);
  std::string rule = "|";
  for (std::size_t w : width) rule += std::string(w + 2, '-') + "|";
  table += rule + "\n";
  for (const auto& row : rows) table += line(row);
  return table;
}

std::string cell(double value, int decimals) {
  if (!std::isfinite(value)) return "–";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

void write_series_csv(const std::filesystem::path& path, const std::vector<std::string>& names,
                      const Eigen::MatrixXd& columns) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path.string() + ": cannot write");
  out << "k";
  for (const auto& name : names) out << ',' << name;
  out << '\n';
  char buffer[32];
  for (Eigen::Index k = 0; k < columns.rows(); ++k) {
    out << k;
    for (Eigen::Index j = 0; j < columns.cols(); ++j) {
      out << ',';
      if (std::isfinite(columns(k, j))) {
        std::snprintf(buffer, sizeof buffer, "%.8g", columns(k, j));
        out << buffer;
      }
    }
    out << '\n';
  }
  if (!out.flush()) throw std::runtime_error(path.string() + ": write failed");
}

namespace {

// The medians of the positive values of the named CSV columns (NaN: no positive value).
std::vector<double> column_medians(const std::filesystem::path& csv,
                                   const std::vector<std::string>& names) {
  std::ifstream in(csv);
  std::string line;
  std::vector<double> medians(names.size(), std::numeric_limits<double>::quiet_NaN());
  if (!std::getline(in, line)) return medians;
  std::vector<std::string> header;
  {
    std::stringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) header.push_back(cell);
  }
  std::vector<std::vector<double>> values(names.size());
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::size_t column = 0;
    for (std::string cell; std::getline(row, cell, ','); ++column) {
      if (column >= header.size() || cell.empty()) continue;
      for (std::size_t i = 0; i < names.size(); ++i) {
        if (header[column] != names[i]) continue;
        const double v = std::strtod(cell.c_str(), nullptr);
        if (v > 0.0 && std::isfinite(v)) values[i].push_back(v);
      }
    }
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    auto& v = values[i];
    if (v.empty()) continue;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    medians[i] = v[v.size() / 2];
  }
  return medians;
}

std::string& caption_text() {
  static std::string caption;
  return caption;
}

}  // namespace

const std::string& plot_caption() { return caption_text(); }
void set_plot_caption(std::string caption) { caption_text() = std::move(caption); }

bool plot_series(const PlotSpec& spec) {
  const std::filesystem::path folder =
      spec.png.parent_path().empty() ? std::filesystem::path(".") : spec.png.parent_path();
  const auto script_path = folder / (spec.png.stem().string() + ".gp");
  const std::string csv = spec.csv.lexically_relative(folder).generic_string();
  // One series dominating (a diverging baseline) would flatten the others: log scale then.
  bool logarithmic = false;
  if (spec.x_series.empty()) {
    double low = std::numeric_limits<double>::infinity(), high = 0.0;
    bool all_positive = true;
    for (double m : column_medians(spec.csv, spec.series)) {
      if (!(m > 0.0)) all_positive = false;
      low = std::min(low, m), high = std::max(high, m);
    }
    logarithmic = all_positive && spec.series.size() > 1 && high > 30.0 * low;
  }
  {
    std::ofstream script(script_path);
    std::string title = spec.title;
    if (!plot_caption().empty()) title += "\\n" + plot_caption();
    script << "# Run inside this folder: gnuplot " << script_path.filename().string() << "\n"
           << "set terminal pngcairo size 900,500 noenhanced\n"
           << "set output '" << spec.png.filename().string() << "'\n"
           << "set datafile separator ','\n"
           << "set datafile missing ''\n"
           << "set key outside right\n"
           << "set grid\n"
           << "set title \"" << title << "\"\n"
           << "set xlabel '" << spec.x_label << "'\n"
           << "set ylabel '" << spec.y_label << (logarithmic ? " (log scale)" : "") << "'\n"
           << (logarithmic ? "set logscale y\n" : "") << "plot ";
    for (std::size_t i = 0; i < spec.series.size(); ++i) {
      const std::string x = i < spec.x_series.size() ? spec.x_series[i] : "k";
      const std::string& style = i < spec.styles.size() ? spec.styles[i] : spec.style;
      const std::string n = std::to_string(i + 1);
      std::string drawn = style;
      if (style == "lines") {
        drawn.append(" lw 2 dashtype ").append(n);
      } else if (style != "dots") {
        drawn.append(" ps 0.6 pointtype ").append(n);
      }
      script << (i == 0 ? "" : ", ") << "'" << csv << "' using '" << x << "':'" << spec.series[i]
             << "' with " << drawn << " title '" << spec.series[i] << "'";
    }
    script << "\n";
  }
  // Under mpirun only the root's report is kept: the other ranks draw nothing.
  if (!trainer::Ranks::world().root()) return true;
  int status = 1;
  try {
    const std::string cd = "cd '" + folder.string() + "'";
    status = support::run_process("gnuplot", {"-e", cd, script_path.filename().string()});
  } catch (const std::exception&) {
    status = 127;
  }
  if (status != 0) {
    std::error_code ignored;
    std::filesystem::remove(spec.png, ignored);
    return false;
  }
  return true;
}

std::string scientific(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", value);
  return buffer;
}

std::string comma_list(const std::vector<double>& values) {
  std::ostringstream out;
  for (std::size_t i = 0; i < values.size(); ++i) out << (i ? ", " : "") << values[i];
  return out.str();
}

bool write_error_series(const std::vector<FilterOutcome>& filters, int steps,
                        const std::filesystem::path& out) {
  std::vector<std::string> names;
  Eigen::MatrixXd pe(steps, static_cast<Eigen::Index>(filters.size()));
  Eigen::MatrixXd ve(steps, static_cast<Eigen::Index>(filters.size()));
  for (std::size_t i = 0; i < filters.size(); ++i) {
    names.push_back(filters[i].name);
    pe.col(static_cast<Eigen::Index>(i)) = filters[i].position_error;
    ve.col(static_cast<Eigen::Index>(i)) = filters[i].velocity_error;
  }
  write_series_csv(out / "normalized_position_error.csv", names, pe);
  write_series_csv(out / "normalized_velocity_error.csv", names, ve);
  bool plotted = plot_series({out / "normalized_position_error.png",
                              "Normalized position error P_e(k) (seed 000 Fig. 4-1)", "scan k",
                              "P_e", out / "normalized_position_error.csv", names});
  plotted &= plot_series({out / "normalized_velocity_error.png",
                          "Normalized velocity error V_e(k) (seed 000 Fig. 4-2)", "scan k", "V_e",
                          out / "normalized_velocity_error.csv", names});
  return plotted;
}

bool write_mode_probabilities(const FilterOutcome& filter, const std::filesystem::path& out,
                              const std::string& stem) {
  const auto csv = out / (stem + ".csv");
  write_series_csv(csv, filter.mode_names, filter.mean_mode_probabilities);
  return plot_series({out / (stem + ".png"), "Mean mode probabilities of " + filter.name, "scan k",
                      "probability", csv, filter.mode_names});
}

}  // namespace imm::evaluation
