// SPDX-License-Identifier: Apache-2.0
#include "imm/load.hpp"

#include <system_error>

#include "imm/calibrated_track_bank.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/model_kinds.hpp"
#include "imm/tracking/calibrated_filter.hpp"

namespace imm {
namespace {

// The kind a file says it is: its model_kind exactly (an alias is a name for commands, not for
// files).
const ModelKind& kind_of(const io::ModelFileReader& reader) {
  const std::string& name = reader.provenance().model_kind;
  const ModelKind* kind = find_model_kind(name);
  if (kind == nullptr || kind->name != name) {
    std::string known;
    for (const ModelKind* k : model_kinds()) known += (known.empty() ? "" : ", ") + k->name;
    reader.fail("/@model_kind",
                "unknown model kind '" + printable(name) + "' (this runtime reads " + known + ")");
  }
  return *kind;
}

FilterMaker load(const io::ModelFileReader& reader, std::int64_t max_gap) {
  FilterMaker loaded = kind_of(reader).load(reader, max_gap);
  loaded.provenance = reader.provenance();
  loaded.options.envelope = reader.envelope();
  // A file with a covariance calibration (calibrated_filter.hpp) builds calibrated filters.
  if (auto calibration = read_calibration(reader)) {
    loaded.make = [make = std::move(loaded.make), calibration = std::move(calibration)] {
      return std::unique_ptr<TrackFilter>(std::make_unique<CalibratedFilter>(make(), calibration));
    };
  }
  return loaded;
}

// The reader of a model file that must exist (a missing one named as such, not as an HDF5 error).
io::ModelFileReader open_model(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) {
    throw io::FileError(path.string(), "", "no such model file");
  }
  return io::ModelFileReader(path);
}

}  // namespace

std::vector<std::string_view> loadable_model_kinds() {
  std::vector<std::string_view> names;
  for (const ModelKind* kind : model_kinds()) names.emplace_back(kind->name);
  return names;
}

LoadedFilter load_filter(const std::filesystem::path& path, std::int64_t max_gap) {
  return load_filter(open_model(path), max_gap);
}

FilterMaker load_filter_maker(const io::ModelFileReader& reader, std::int64_t max_gap) {
  try {
    FilterMaker maker = load(reader, max_gap);
    maker.make();  // a spec its filter refuses is refused here, naming the field
    return maker;
  } catch (const InvalidParameter& invalid) {
    reader.fail(invalid.field(), invalid.what());
  }
}

FilterMaker load_filter_maker(const std::filesystem::path& path, std::int64_t max_gap) {
  return load_filter_maker(open_model(path), max_gap);
}

LoadedFilter load_filter(const io::ModelFileReader& reader, std::int64_t max_gap) {
  try {
    FilterMaker maker = load(reader, max_gap);
    return {maker.make(), std::move(maker.options), std::move(maker.provenance)};
  } catch (const InvalidParameter& invalid) {
    reader.fail(invalid.field(), invalid.what());
  }
}

Tracker load_tracker(const std::filesystem::path& path, std::int64_t max_gap) {
  LoadedFilter loaded = load_filter(path, max_gap);
  return Tracker(std::move(loaded.filter), std::move(loaded.options));
}

std::unique_ptr<AnyTrackBank> open_track_bank(const std::filesystem::path& path,
                                              std::size_t capacity) {
  const io::ModelFileReader reader = open_model(path);
  const ModelKind& kind = kind_of(reader);
  if (!kind.open_bank) {
    throw InvalidParameter("path", path.string() + " is a " + kind.name +
                                       " model, a kind this runtime has no bank for");
  }
  try {
    std::unique_ptr<AnyTrackBank> bank = kind.open_bank(reader, capacity);
    // As load_filter: a file's covariance calibration, where the kind's bank states what it needs.
    if (bank->states_step_nis()) {
      if (auto calibration = read_calibration(reader)) {
        bank = std::make_unique<CalibratedTrackBank>(std::move(bank), std::move(calibration));
      }
    }
    return bank;
  } catch (const InvalidParameter& invalid) {
    if (invalid.field() == "capacity") throw;
    reader.fail(invalid.field(), invalid.what());
  }
}

}  // namespace imm
