// SPDX-License-Identifier: Apache-2.0
// The registry of model kinds and the six kinds of this runtime.
#include "imm/model_kinds.hpp"

#include <algorithm>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>

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
#include "imm/tracking/fcm_imm_track_bank.hpp"
#include "imm/tracking/fimm_track_bank.hpp"
#include "imm/tracking/ga_fuzzy_track_bank.hpp"
#include "imm/tracking/input_estimator_track_bank.hpp"
#include "imm/tracking/plain_imm_track_bank.hpp"
#include "imm/tracking/track_bank.hpp"
#include "imm/tracking/wimm_track_bank.hpp"

namespace imm {
namespace {

// The spec read once, shared by every filter the maker builds.
template <class Spec, class Make>
FilterMaker build(Spec spec, std::int64_t max_gap, Make make) {
  FilterMaker loaded;
  loaded.options = spec.track_options(max_gap);
  auto shared = std::make_shared<const Spec>(std::move(spec));
  loaded.make = [shared = std::move(shared), make = std::move(make)] { return make(*shared); };
  return loaded;
}

template <class Bank, class... Arguments>
std::unique_ptr<AnyTrackBank> bank_of(Arguments&&... arguments) {
  return std::make_unique<TrackBankAdapter<Bank>>(std::forward<Arguments>(arguments)...);
}

// A plain IMM: TrackBank's vectorized kernel for CV modes with Cartesian plots, the general bank
// of its mixing dimension otherwise (CA, Singer and turn modes, scheduled noise, polar plots).
std::unique_ptr<AnyTrackBank> plain_imm_bank(const PlainImmSpec& spec, std::size_t capacity) {
  const bool cv_cartesian =
      spec.measurement.kind == MeasurementKind::kCartesian &&
      std::all_of(spec.modes.begin(), spec.modes.end(), [](const ModeSpec& m) {
        return m.motion == MotionKind::kConstantVelocity && !m.noise_schedule;
      });
  if (cv_cartesian) return bank_of<TrackBank>(spec, capacity);
  switch (spec.mixing_dimension()) {
    case 4:
      return bank_of<PlainImmTrackBank<4>>(spec, capacity);
    case 5:
      return bank_of<PlainImmTrackBank<5>>(spec, capacity);
    case 6:
      return bank_of<PlainImmTrackBank<6>>(spec, capacity);
    default:
      return bank_of<PlainImmTrackBank<7>>(spec, capacity);
  }
}

FimmSpec stored_fimm_settings(const io::ModelFileReader& reader) {
  std::optional<FimmSpec> fimm = io::read_fimm_settings(reader);
  if (!fimm) {
    reader.fail("/fimm",
                "missing: the file predates stored FIMM settings (retrain it with imm-train tsk; "
                "until then build FimmFilter with the [fimm] settings of its training config)");
  }
  return *std::move(fimm);
}

// A kind whose file holds one spec: `read` it from the file, `make` a filter of it, `open` a
// bank of it (spec, capacity).
template <class Read, class Make, class Open>
ModelKind spec_kind(std::string_view name, const std::vector<std::string>& aliases,
                    std::string_view summary, Read read, Make make, Open open) {
  return {
      .name = std::string(name),
      .aliases = aliases,
      .summary = std::string(summary),
      .validate = [read](const io::ModelFileReader& r) { (void)read(r); },
      .load = [read, make](const io::ModelFileReader& r,
                           std::int64_t max_gap) { return build(read(r), max_gap, make); },
      .open_bank = [read, open](const io::ModelFileReader& r,
                                std::size_t capacity) { return open(read(r), capacity); },
  };
}

// open for spec_kind: a Bank(spec, capacity).
template <class Bank, class Spec>
std::unique_ptr<AnyTrackBank> open_bank_of(const Spec& spec, std::size_t capacity) {
  return bank_of<Bank>(spec, capacity);
}

std::vector<ModelKind> built_in_kinds() {
  std::vector<ModelKind> kinds;
  kinds.push_back(spec_kind(
      io::kPlainImmKind, {"plain-imm", "plain"},
      "the plain IMM: CV, CA, Singer and turn modes, Cartesian or polar plots",
      [](const io::ModelFileReader& r) { return io::read_plain_imm(r); }, make_plain_imm_filter,
      plain_imm_bank));
  kinds.push_back(spec_kind(
      io::kGaFuzzyImmKind, {"ga", "ga-imm", "ga-fuzzy-imm"},
      "the GA-fuzzy IMM of seed 000, per axis (Cartesian plots)",
      [](const io::ModelFileReader& r) { return io::read_ga_fuzzy_imm(r); },
      make_ga_fuzzy_imm_filter, open_bank_of<GaFuzzyTrackBank, GaFuzzyImmSpec>));
  kinds.push_back(spec_kind(
      io::kMlpInputEstimatorKind, {"mlp", "input-estimator", "mlp-input-estimator"},
      "the neural input estimator of seed 001, per axis (Cartesian plots)",
      [](const io::ModelFileReader& r) { return io::read_mlp_input_estimator(r); },
      make_mlp_input_estimator_filter,
      open_bank_of<InputEstimatorTrackBank, MlpInputEstimatorModel>));
  kinds.push_back(spec_kind(
      io::kFcmImmKind, {"fcm", "fcm-imm"},
      "the FCM-compensated IMM of seed 003, per axis (Cartesian plots)",
      [](const io::ModelFileReader& r) { return io::read_fcm_imm(r); }, make_fcm_imm_filter,
      open_bank_of<FcmImmTrackBank, FcmImmSpec>));
  // The TSK sensor model's file holds the sensor model and the FIMM settings beside it.
  kinds.push_back({
      .name = std::string(io::kTskSensorKind),
      .aliases = {"tsk", "fimm", "tsk-sensor"},
      .summary = "the FIMM of seed 002 through its learned TSK sensor model",
      .validate = [](const io::ModelFileReader& r) { (void)io::read_tsk_sensor(r); },
      .load =
          [](const io::ModelFileReader& r, std::int64_t max_gap) {
            auto sensor = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(r));
            return build(stored_fimm_settings(r), max_gap, [sensor](const FimmSpec& spec) {
              return std::make_unique<FimmFilter>(spec, sensor);
            });
          },
      .open_bank =
          [](const io::ModelFileReader& r, std::size_t capacity) {
            auto sensor = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(r));
            return bank_of<FimmTrackBank>(stored_fimm_settings(r), std::move(sensor), capacity);
          },
  });
  kinds.push_back(spec_kind(
      io::kWimmKind, {}, "the weighted IMM of seed 004 with azimuth fusion (polar plots)",
      [](const io::ModelFileReader& r) { return io::read_wimm(r); },
      [](const WimmSpec& spec) { return std::make_unique<WimmFilter>(spec); },
      open_bank_of<WimmTrackBank, WimmSpec>));
  return kinds;
}

class Registry {
 public:
  Registry() {
    for (ModelKind& kind : built_in_kinds()) add(std::move(kind));
  }

  void add(ModelKind kind) {
    const std::scoped_lock lock(mutex_);
    if (kind.name.empty()) throw InvalidParameter("name", "a model kind needs a name");
    if (!kind.validate) throw InvalidParameter("validate", "'" + kind.name + "' has none");
    if (!kind.load) throw InvalidParameter("load", "'" + kind.name + "' has none");
    if (const ModelKind* other = find_locked(kind.name)) {
      throw InvalidParameter("name", "'" + kind.name + "' is taken by " + other->name);
    }
    for (std::size_t i = 0; i < kind.aliases.size(); ++i) {
      const std::string& alias = kind.aliases[i];
      const ModelKind* other = find_locked(alias);
      if (alias.empty() || alias == kind.name || other != nullptr) {
        throw InvalidParameter("aliases[" + std::to_string(i) + "]",
                               "'" + alias + "' is " +
                                   (other != nullptr ? "taken by " + other->name
                                                     : std::string("empty or the kind's name")));
      }
    }
    kinds_.push_back(std::move(kind));
  }

  const ModelKind* find(std::string_view name_or_alias) const {
    const std::scoped_lock lock(mutex_);
    return find_locked(name_or_alias);
  }

  std::vector<const ModelKind*> all() const {
    const std::scoped_lock lock(mutex_);
    std::vector<const ModelKind*> out;
    out.reserve(kinds_.size());
    for (const ModelKind& kind : kinds_) out.push_back(&kind);
    return out;
  }

 private:
  const ModelKind* find_locked(std::string_view name_or_alias) const {
    for (const ModelKind& kind : kinds_) {
      if (kind.answers_to(name_or_alias)) return &kind;
    }
    return nullptr;
  }

  mutable std::mutex mutex_;
  std::deque<ModelKind> kinds_;  // a deque: pointers to its elements survive push_back
};

Registry& registry() {
  static Registry instance;
  return instance;
}

}  // namespace

void AnyTrackBank::candidate_log_likelihoods(
    std::span<const Eigen::Vector2d> /*plots*/, double /*gate*/,
    Eigen::Ref<Eigen::MatrixXd> /*out*/) {  // NOLINT(performance-unnecessary-value-param)
  throw std::logic_error(
      "candidate_log_likelihoods: this kind's bank does not score candidate plots (every bank "
      "of this runtime's kinds does, but a wIMM's that fuses the azimuth or converts the "
      "plot)");
}

void AnyTrackBank::step(std::span<const Eigen::Vector2d> /*plots*/,
                        std::span<StepStatus> /*status*/, std::span<double> /*nis*/) {
  throw std::logic_error(
      "step with NIS: this kind's bank does not state its steps' NIS (states_step_nis() is "
      "false)");
}

void AnyTrackBank::candidate_log_likelihoods(
    std::span<const Eigen::Vector2d> /*plots*/, double /*gate*/,
    std::span<const double> /*gate_scale*/,
    Eigen::Ref<Eigen::MatrixXd> /*out*/) {  // NOLINT(performance-unnecessary-value-param)
  throw std::logic_error(
      "candidate_log_likelihoods with a gate per track: this kind's bank does not gate per track "
      "(states_step_nis() is false)");
}

bool ModelKind::answers_to(std::string_view name_or_alias) const {
  return name == name_or_alias ||
         std::find(aliases.begin(), aliases.end(), name_or_alias) != aliases.end();
}

void register_model_kind(ModelKind kind) { registry().add(std::move(kind)); }

const ModelKind* find_model_kind(std::string_view name_or_alias) {
  return registry().find(name_or_alias);
}

const ModelKind& model_kind(std::string_view name_or_alias, const std::string& field) {
  if (const ModelKind* kind = find_model_kind(name_or_alias)) return *kind;
  std::string known;
  for (const ModelKind* kind : model_kinds()) known += (known.empty() ? "" : ", ") + kind->name;
  throw InvalidParameter(field, "unknown model kind '" + printable(name_or_alias) +
                                    "' (this runtime knows " + known + ")");
}

std::vector<const ModelKind*> model_kinds() { return registry().all(); }

}  // namespace imm
