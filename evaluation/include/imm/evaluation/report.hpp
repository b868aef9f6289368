// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Report pieces shared by the experiments: Markdown tables on stdout, CSV time series, and PNG
/// line plots through gnuplot.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace imm::evaluation {

/// A Markdown table: header and rows of cells.
[[nodiscard]] std::string markdown_table(const std::vector<std::string>& header,
                                         const std::vector<std::vector<std::string>>& rows);

/// Fixed-precision cell text ("0.6089").
[[nodiscard]] std::string cell(double value, int decimals = 4);

/// Writes a CSV: a column "k" (0 … rows − 1) then one column per name. NaN cells are empty.
void write_series_csv(const std::filesystem::path& path, const std::vector<std::string>& names,
                      const Eigen::MatrixXd& columns);

struct PlotSpec {
  std::filesystem::path png;
  std::string title;
  std::string x_label = "scan k";
  std::string y_label;
  std::filesystem::path csv;        ///< written by write_series_csv
  std::vector<std::string> series;  ///< column names of the CSV to draw
  /// x column per series (empty: every series against "k"), for x–y plots such as trajectories.
  std::vector<std::string> x_series = {};
  std::string style = "lines";           ///< gnuplot style: lines | points | dots
  std::vector<std::string> styles = {};  ///< per series (empty or shorter: `style`)
};

/// Draws the series with gnuplot (pngcairo or png terminal). Returns false, leaving no PNG,
/// when gnuplot is missing or fails; the caller reports it. The plot names the runs, the seed and
/// the model (plot_caption()); every series gets its own dash pattern or point type, and the y
/// axis turns logarithmic when one series dominates the others (medians 30× apart), so that no
/// curve is flattened out of sight. The script (<png stem>.gp, beside the PNG) names its files
/// relative to its folder, so a report folder can be moved and the script rerun inside it.
bool plot_series(const PlotSpec& spec);

/// The line under every plot's title: "<runs> runs, seed <seed>, model <file> (<trainer version>)"
/// of the last write_metrics() (evaluation_report.hpp); empty before it.
[[nodiscard]] const std::string& plot_caption();
void set_plot_caption(std::string caption);

/// "%.3g" text ("8.16e+03").
[[nodiscard]] std::string scientific(double value);
/// "a, b, c" of the values in the stream's default format.
[[nodiscard]] std::string comma_list(const std::vector<double>& values);

struct FilterOutcome;
/// P_e(k), V_e(k) of every filter as CSV and PNG (seed 000 Fig. 4); returns whether plots worked.
bool write_error_series(const std::vector<FilterOutcome>& filters, int steps,
                        const std::filesystem::path& out);
/// A filter's mean mode probabilities per scan as `stem`.csv and .png.
bool write_mode_probabilities(const FilterOutcome& filter, const std::filesystem::path& out,
                              const std::string& stem);

}  // namespace imm::evaluation
