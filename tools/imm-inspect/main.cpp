// SPDX-License-Identifier: Apache-2.0
// imm-inspect: prints what a model (or data-set) file holds — kind, schema version, provenance and
// every parameter as readable tables, or as JSON with --json. Known model kinds are also fully
// validated by their runtime reader, so a file imm-inspect accepts is a file the runtime loads.
//
//   imm-inspect models/cv3_imm.h5 [--json] [--full] [--config] [--regime]
//
// Exit codes: 0 readable and valid, 1 usage, 2 corrupt, foreign or invalid file (one line on
// stderr naming the file and the field).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/load.hpp"
#include "imm/model_kinds.hpp"
#include "imm/pipeline/registry.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/exit_codes.hpp"

namespace {

using imm::io::Array;
using imm::io::Attribute;
using imm::io::ContainerReader;
using imm::io::ObjectKind;
using nlohmann::json;

constexpr std::size_t kRowsShown = 12;

std::string number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  return buffer;
}

std::string attribute_text(const Attribute& value) {
  if (const auto* i = std::get_if<std::int64_t>(&value)) return std::to_string(*i);
  if (const auto* d = std::get_if<double>(&value)) return number(*d);
  return std::get<std::string>(value);
}

json attribute_json(const Attribute& value) {
  if (const auto* i = std::get_if<std::int64_t>(&value)) return *i;
  if (const auto* d = std::get_if<double>(&value)) return *d;
  return std::get<std::string>(value);
}

std::vector<std::string> split_columns(const std::string& text) {
  std::vector<std::string> columns;
  std::stringstream stream(text);
  std::string column;
  while (std::getline(stream, column, ',')) columns.push_back(column);
  return columns;
}

std::string join_path(const std::string& group, const std::string& name) {
  return group == "/" ? "/" + name : group + "/" + name;
}

// Rank 1 prints as one column, rank 2 as rows × columns.
void print_table(std::ostream& out, const Array& array, std::vector<std::string> columns,
                 bool full) {
  const std::size_t rows = array.shape[0];
  const std::size_t cols = array.rank() == 1 ? 1 : array.shape[1];
  if (array.rank() == 1 && columns.empty()) columns = {"value"};
  const std::size_t width = 12;
  out << "    " << std::string(6, ' ');
  for (std::size_t j = 0; j < cols; ++j) {
    std::string header = j < columns.size() ? columns[j] : "[" + std::to_string(j) + "]";
    out << std::string(width > header.size() ? width - header.size() : 1, ' ') << header;
  }
  out << '\n';
  const std::size_t shown = full ? rows : std::min(rows, kRowsShown);
  for (std::size_t i = 0; i < shown; ++i) {
    const std::string label = std::to_string(i);
    out << "    " << std::string(6 - std::min<std::size_t>(6, label.size()), ' ') << label;
    for (std::size_t j = 0; j < cols; ++j) {
      const std::string cell = number(array.values[i * cols + j]);
      out << std::string(width > cell.size() ? width - cell.size() : 1, ' ') << cell;
    }
    out << '\n';
  }
  if (shown < rows) out << "    … " << rows - shown << " more rows (--full shows all)\n";
}

struct Inspector {
  const ContainerReader& file;
  bool full = false;

  void text(std::ostream& out, const std::string& group) const {
    for (const std::string& name : file.children(group)) {
      const std::string path = join_path(group, name);
      const ObjectKind kind = file.kind(path);
      std::string attributes;
      std::vector<std::string> columns;
      // Schema 2: a group's units name each real attribute ("name=unit,…"), a dataset's are one
      // unit or one per column. Printed beside the values ("sample_period=2 s").
      std::map<std::string, std::string> attribute_units;
      std::vector<std::string> column_units;
      const auto units = file.attribute(path, "units");
      if (units && std::holds_alternative<std::string>(*units)) {
        for (const std::string& entry : split_columns(std::get<std::string>(*units))) {
          const auto equals = entry.find('=');
          if (equals != std::string::npos) {
            attribute_units[entry.substr(0, equals)] = entry.substr(equals + 1);
          } else {
            column_units.push_back(entry);
          }
        }
      }
      for (const std::string& attribute : file.attribute_names(path)) {
        const Attribute value = *file.attribute(path, attribute);
        if (attribute == "columns") {
          columns = split_columns(std::get<std::string>(value));
        } else if (attribute == "units" && kind == ObjectKind::kGroup && !attribute_units.empty()) {
          continue;  // shown with each value
        } else {
          attributes += "  " + attribute + "=" + attribute_text(value);
          const auto unit = attribute_units.find(attribute);
          if (unit != attribute_units.end() && unit->second != "1")
            attributes += " " + unit->second;
        }
      }
      // (A covariance's units are its variables': entry (i, j) is in unitᵢ·unitⱼ, not a column's.)
      const bool covariance = file.attribute(path, "quantity").has_value();
      if (!covariance && column_units.size() > 1 && column_units.size() == columns.size()) {
        for (std::size_t c = 0; c < columns.size(); ++c) {
          if (column_units[c] != "1") columns[c] += " (" + column_units[c] + ")";
        }
      }
      if (kind == ObjectKind::kGroup) {
        out << path << attributes << '\n';
        text(out, path);
        continue;
      }
      const Array array = file.read(path);
      std::string shape;
      for (std::size_t extent : array.shape)
        shape += (shape.empty() ? "" : "x") + std::to_string(extent);
      out << path << "  [" << shape << "]" << attributes << '\n';
      if (array.rank() <= 2 && !array.values.empty()) {
        print_table(out, array, columns, full);
      } else if (!array.values.empty()) {
        double lo = array.values[0], hi = array.values[0], sum = 0.0;
        for (double v : array.values) lo = std::min(lo, v), hi = std::max(hi, v), sum += v;
        out << "    min " << number(lo) << ", max " << number(hi) << ", mean "
            << number(sum / static_cast<double>(array.values.size())) << '\n';
      }
    }
  }

  void to_json(json& objects, const std::string& group) const {
    for (const std::string& name : file.children(group)) {
      const std::string path = join_path(group, name);
      json object;
      json attributes = json::object();
      for (const std::string& attribute : file.attribute_names(path)) {
        attributes[attribute] = attribute_json(*file.attribute(path, attribute));
      }
      object["attributes"] = attributes;
      if (file.kind(path) == ObjectKind::kGroup) {
        object["type"] = "group";
        objects[path] = object;
        to_json(objects, path);
        continue;
      }
      const Array array = file.read(path);
      object["type"] = "dataset";
      object["shape"] = array.shape;
      object["values"] = array.values;  // row-major
      objects[path] = object;
    }
  }
};

// A manifest's metric for a table cell: a headline metric's value and interval, else its JSON text
// (a tracker's ranking, rule and reason), one line, its control bytes escaped.
std::string metric_cell(const json& value) {
  if (value.is_object() && value.contains("value") && value.at("value").is_number()) {
    std::ostringstream text;
    text << value.at("value").get<double>();
    const json* interval = value.contains("interval") ? &value.at("interval") : nullptr;
    if (interval != nullptr && interval->is_array() && interval->size() == 2 &&
        (*interval)[0].is_number() && (*interval)[1].is_number()) {
      text << " [" << (*interval)[0].get<double>() << ", " << (*interval)[1].get<double>() << "]";
    }
    return text.str();
  }
  const std::string text = value.is_string() ? value.get<std::string>() : value.dump();
  return imm::pipeline::quoted_for_message(text, 240);
}

// models/manifest.json (imm/pipeline/registry.hpp) as tables: what is shipped, and its metrics.
// The manifest is read as the registry reads it (bounded, every field checked); a refusal names
// the field. Every shipped file is checked against its entry's SHA-256: one that is missing or
// differs is listed at the end, and the exit code is then 2.
int print_manifest(const std::string& path) {
  using imm::pipeline::quoted_for_message;
  std::vector<imm::pipeline::RegistryEntry> entries;
  try {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open");
    std::string text(imm::pipeline::kMaxManifestBytes + 1, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<std::size_t>(in.gcount()));
    entries = imm::pipeline::parse_manifest(text, path);
  } catch (const std::exception& error) {
    std::cerr << "imm-inspect: " << error.what() << '\n';
    return 2;
  }
  std::cout << "| name | kind | regime | file | sha256 | schema | trainer | trained | promoted | "
               "earlier | learned part |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& e : entries) {
    std::cout << "| " << e.name << " | " << e.kind << " | " << e.regime_name << " | " << e.file
              << " | " << e.sha256.substr(0, 12) << " | " << e.schema_version << " | "
              << e.trainer_version << " | " << e.trained_utc << " | "
              << (e.promoted_utc.empty() ? "–" : e.promoted_utc) << " | " << e.history.size()
              << " | " << (e.learned_part.empty() ? "–" : e.learned_part) << " |\n";
  }
  std::cout << "\n| name | metric | value [95 %] | vs the model it replaced [95 %] "
               "|\n|---|---|---|---|\n";
  for (const auto& e : entries) {
    for (const auto& [metric, value] : e.metrics.items()) {
      const bool headline = value.is_object() && value.contains("versus_previous") &&
                            value.at("versus_previous").is_string();
      std::cout << "| " << e.name << " | " << quoted_for_message(metric, 120) << " | "
                << metric_cell(value) << " | "
                << (headline ? quoted_for_message(value.at("versus_previous").get<std::string>())
                             : std::string("–"))
                << " |\n";
    }
  }
  bool header = false;
  for (const auto& e : entries) {
    if (e.promotion_reason.empty()) continue;
    if (!header) std::cout << "\nPromoted by hand, past the nightly's gates:\n";
    header = true;
    std::cout << "- " << e.name << ": " << quoted_for_message(e.promotion_reason, 400) << '\n';
  }
  header = false;
  for (const auto& e : entries) {
    if (e.rejected.empty()) continue;
    if (!header) {
      std::cout << "\nRolled back (not promoted again until --force or imm-train promote):\n";
    }
    header = true;
    for (const auto& r : e.rejected) {
      std::cout << "- " << e.name << ": " << r.sha256.substr(0, 12) << ", trained " << r.trained_utc
                << ", rolled back " << (r.rolled_back_utc.empty() ? "–" : r.rolled_back_utc)
                << '\n';
    }
  }
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  int unlike = 0;
  for (const auto& e : entries) {
    const std::string state = imm::pipeline::shipped_file_problem(folder / e.file, e.sha256);
    if (state.empty()) continue;
    if (unlike++ == 0) {
      std::cout << "\nShipped files that are not the manifest's (the nightly and `imm-train "
                   "promote` restore each from the registry's archive where it holds a copy):\n";
    }
    std::cout << "- " << e.name << ": " << (folder / e.file).string() << ' ' << state << '\n';
  }
  if (unlike > 0) {
    std::cerr << "imm-inspect: " << path << ": " << unlike
              << " shipped file(s) not the manifest's (listed at the end)\n";
    return imm::support::exit_code::kBadInput;
  }
  return 0;
}

int run(int argc, char** argv) {
  imm::io::skip_hdf5_shutdown_at_exit();  // before any HDF5 call (container_file.hpp)
  CLI::App app{"Print what an immtrain model or data-set file holds."};
  imm::support::standard_options(app, "imm-inspect");
  std::string path;
  bool as_json = false, full = false, show_config = false;
  app.add_option("file", path, "model or data-set file (with --manifest: models/manifest.json)")
      ->required();
  bool show_manifest = false;
  app.add_flag("--manifest", show_manifest, "print a model registry's manifest as tables");
  app.add_flag("--json", as_json, "machine-readable output");
  app.add_flag("--full", full, "print every row of every table");
  app.add_flag("--config", show_config, "print the full config text the file was made from");
  bool verify = false;
  app.add_flag("--verify", verify,
               "check the file (checksum, every field, and for models the filter it builds) and "
               "print one line: exit 0 when intact, 2 otherwise");
  bool show_regime = false;
  app.add_flag("--regime", show_regime,
               "print the full text of the regime a model was trained for");
  if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;
  if (show_manifest) return print_manifest(path);

  try {
    const ContainerReader file(path, "");
    std::string kind;
    std::int64_t schema_version = 0;
    if (file.format() == imm::io::kModelFormat) {
      const imm::io::ModelFileReader model(path);  // validates format, version and provenance
      kind = model.provenance().model_kind;
      schema_version = model.schema_version();
      const imm::ModelKind* known = imm::find_model_kind(kind);
      if (known != nullptr && known->name == kind) {
        known->validate(model);
        if (verify) (void)imm::load_filter(model);  // and the filter it builds
      }
    } else if (file.format() == imm::datasets::kDatasetFormat) {
      const auto stored_kind = file.attribute("/", "dataset_kind");
      kind = stored_kind && std::holds_alternative<std::string>(*stored_kind)
                 ? std::get<std::string>(*stored_kind)
                 : std::string();
      // Each reader validates its kind and recomputes the digest.
      if (kind == "range_sensor") {
        (void)imm::datasets::read_range_sensor_dataset(path);
      } else {
        (void)imm::datasets::read_track_set(path);
      }
      schema_version = std::get<std::int64_t>(*file.attribute("/", "schema_version"));
    } else {
      throw imm::io::FileError(path, "", "unknown container format '" + file.format() + "'");
    }
    const imm::ModelKind* known = imm::find_model_kind(kind);
    const bool validated =
        file.format() != imm::io::kModelFormat || (known != nullptr && known->name == kind);
    if (verify) {
      std::cout << path << ": ok (" << file.format() << ", schema " << schema_version << ", "
                << (kind.empty() ? "-" : kind)
                << (validated ? "" : ", contents not validated: unknown to this build")
                << ", sha256 " << imm::datasets::file_sha256_hex(path).substr(0, 16) << ")\n";
      return 0;
    }

    const Inspector inspector{file, full};
    if (as_json) {
      json document;
      document["file"] = path;
      document["format"] = file.format();
      document["schema_version"] = schema_version;
      document["kind"] = kind;
      document["validated"] = validated;
      json root = json::object();
      for (const std::string& attribute : file.attribute_names("/")) {
        root[attribute] = attribute_json(*file.attribute("/", attribute));
      }
      document["attributes"] = root;
      json objects = json::object();
      inspector.to_json(objects, "/");
      document["objects"] = objects;
      std::cout << document.dump(2) << '\n';
      return 0;
    }

    std::cout << "file             " << path << '\n'
              << "format           " << file.format() << " (schema " << schema_version << ")\n"
              << "kind             " << kind
              << (validated ? "" : "  (not validated: unknown to this build)") << '\n';
    std::string config, regime;
    for (const std::string& attribute : file.attribute_names("/")) {
      if (attribute == "format" || attribute == "schema_version" || attribute == "model_kind" ||
          attribute == "dataset_kind") {
        continue;
      }
      const Attribute value = *file.attribute("/", attribute);
      if (attribute == "config_toml") {
        config = std::get<std::string>(value);
        const auto lines = std::count(config.begin(), config.end(), '\n');
        std::cout << "config_toml      "
                  << (config.empty() ? "(none)"
                                     : std::to_string(lines) + " lines" +
                                           (show_config ? "" : " (--config prints it)"))
                  << '\n';
        continue;
      }
      if (attribute == "regime_toml") {
        regime = std::get<std::string>(value);
        const auto lines = std::count(regime.begin(), regime.end(), '\n');
        std::cout << "regime_toml      " << std::to_string(lines) << " lines"
                  << (show_regime ? "" : " (--regime prints it)") << '\n';
        continue;
      }
      std::string text = attribute_text(value);
      if (text.empty()) text = "-";
      std::cout << attribute << std::string(attribute.size() < 17 ? 17 - attribute.size() : 1, ' ')
                << text << '\n';
    }
    if (show_config && !config.empty())
      std::cout << "\n--- config ---\n" << config << "--- end ---\n";
    if (show_regime && !regime.empty())
      std::cout << "\n--- regime ---\n" << regime << "--- end ---\n";
    std::cout << '\n';
    inspector.text(std::cout, "/");
  } catch (const std::exception& error) {
    // One line, as for every bad input; a changed payload gets the way to re-seal it deliberately.
    std::cerr << "imm-inspect: " << error.what();
    if (std::string_view(error.what()).find("payload checksum mismatch") !=
        std::string_view::npos) {
      std::cerr << " (if the content was edited on purpose, `imm-train seal " << path
                << "` checks it and re-seals it)";
    }
    std::cerr << '\n';
    return imm::support::exit_code::kBadInput;
  } catch (...) {
    std::cerr << "imm-inspect: unexpected error\n";
    return imm::support::exit_code::kBadInput;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return imm::support::with_output_written("imm-inspect", run(argc, argv));
}
