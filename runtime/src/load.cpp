// SPDX-License-Identifier: Apache-2.0
#include "imm/load.hpp"

#include <system_error>

#include "imm/core/invalid_parameter.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"

namespace imm {
namespace {

// The spec read once, shared by every filter the maker builds.
template <class Spec, class Make>
void build(FilterMaker& loaded, Spec spec, std::int64_t max_gap, Make make) {
  loaded.options = spec.track_options(max_gap);
  auto shared = std::make_shared<const Spec>(std::move(spec));
  loaded.make = [shared = std::move(shared), make = std::move(make)] { return make(*shared); };
}

FilterMaker load(const io::ModelFileReader& reader, std::int64_t max_gap) {
  FilterMaker loaded;
  loaded.provenance = reader.provenance();
  const std::string& kind = loaded.provenance.model_kind;
  if (kind == io::kPlainImmKind) {
    build(loaded, io::read_plain_imm(reader), max_gap, make_plain_imm_filter);
  } else if (kind == io::kGaFuzzyImmKind) {
    build(loaded, io::read_ga_fuzzy_imm(reader), max_gap, make_ga_fuzzy_imm_filter);
  } else if (kind == io::kMlpInputEstimatorKind) {
    build(loaded, io::read_mlp_input_estimator(reader), max_gap, make_mlp_input_estimator_filter);
  } else if (kind == io::kFcmImmKind) {
    build(loaded, io::read_fcm_imm(reader), max_gap, make_fcm_imm_filter);
  } else if (kind == io::kWimmKind) {
    build(loaded, io::read_wimm(reader), max_gap,
          [](const WimmSpec& spec) { return std::make_unique<WimmFilter>(spec); });
  } else if (kind == io::kTskSensorKind) {
    auto sensor = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(reader));
    const std::optional<FimmSpec> fimm = io::read_fimm_settings(reader);
    if (!fimm) {
      reader.fail("/fimm",
                  "missing: the file predates stored FIMM settings (retrain it with imm-train tsk; "
                  "until then build FimmFilter with the [fimm] settings of its training config)");
    }
    build(loaded, *fimm, max_gap,
          [sensor](const FimmSpec& spec) { return std::make_unique<FimmFilter>(spec, sensor); });
  } else {
    std::string known;
    for (std::string_view k : loadable_model_kinds())
      known += (known.empty() ? "" : ", ") + std::string(k);
    reader.fail("/@model_kind",
                "unknown model kind '" + kind + "' (this runtime reads " + known + ")");
  }
  loaded.options.envelope = reader.envelope();
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

const std::vector<std::string_view>& loadable_model_kinds() {
  static const std::vector<std::string_view> kinds = {
      io::kPlainImmKind, io::kGaFuzzyImmKind, io::kMlpInputEstimatorKind,
      io::kFcmImmKind,   io::kTskSensorKind,  io::kWimmKind};
  return kinds;
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

}  // namespace imm
