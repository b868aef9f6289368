// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Every model kind described once. A ModelKind says what a model file of that kind is called
/// (its model_kind attribute and the older or shorter names still accepted), how its contents are
/// checked, how its filter is built and how a bank of many tracks is opened. load_filter,
/// load_tracker, imm-inspect, imm-track and the Python module find a kind here and nowhere else,
/// so a new kind is one register_model_kind call beside its own reader and filter:
///
///   imm::register_model_kind({
///       .name = "my_kind",
///       .aliases = {"mine"},
///       .summary = "what it is, in one line",
///       .validate = [](const imm::io::ModelFileReader& r) { (void)read_my_kind(r); },
///       .load = [](const imm::io::ModelFileReader& r, std::int64_t max_gap) { … },
///   });
///
/// The six kinds of this runtime are registered before the first lookup. Lookups and
/// registrations may come from any thread.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/io/model_file.hpp"
#include "imm/load.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

struct CovarianceCalibration;

/// The calls every track bank has (TrackBank, PlainImmTrackBank, GaFuzzyTrackBank, …) behind one
/// interface, for code that opens a bank of whatever kind a model file holds. One virtual call
/// per bank step; the step itself is the bank's own.
class IMM_RUNTIME_EXPORT AnyTrackBank {
 public:
  virtual ~AnyTrackBank() = default;
  /// The number of tracks it holds.
  [[nodiscard]] virtual std::size_t capacity() const = 0;
  /// The state dimension of an estimate (4 or 6, the mixing dimension of a plain IMM).
  [[nodiscard]] virtual int state_dimension() const = 0;
  /// Starts (or restarts) a track. Throws InvalidParameter("mean" / "covariance") for a wrong
  /// size, and what the bank's own initialize throws.
  virtual void initialize(std::size_t track, const Eigen::VectorXd& mean,
                          const Eigen::MatrixXd& covariance) = 0;
  /// One cycle of tracks 0 … plots.size() − 1 (the bank's step).
  virtual void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) = 0;
  /// Whether track `track` has been initialized.
  [[nodiscard]] virtual bool initialized(std::size_t track) const = 0;
  /// The combined estimate of a track: mean and covariance of state_dimension().
  virtual void estimate(std::size_t track, Eigen::VectorXd& mean,
                        Eigen::MatrixXd& covariance) const = 0;
  /// μ_j of a track.
  [[nodiscard]] virtual ModeVector mode_probabilities(std::size_t track) const = 0;
  /// The gating matrix of tracks 0 … out.rows() − 1 against `plots`, as
  /// TrackBank::candidate_log_likelihoods, where the kind's bank answers it; std::logic_error
  /// otherwise.
  virtual void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                         Eigen::Ref<Eigen::MatrixXd> out);
  /// Makes the following cycles of every track span `interval` s, where the kind's bank predicts
  /// over any interval (TrackBank::set_interval); false, and nothing changed, otherwise (a model of
  /// one sample period: step with unusable plots for the periods between).
  virtual bool set_interval(double /*interval*/) { return false; }

  /// Whether the kind's bank states each step's NIS and gates each track at its own gate (the two
  /// calls below), what a covariance calibration needs (CalibratedTrackBank).
  [[nodiscard]] virtual bool states_step_nis() const { return false; }
  /// step(), with each stepped track's normalized innovation squared into nis[t]: the NIS
  /// last_step_nis gives the one-track filter after the same step (TrackBank::step with `nis`),
  /// NaN where status[t] is not kOk. std::logic_error where the kind's bank does not state it.
  virtual void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                    std::span<double> nis);
  /// The gating matrix with track t gated at gate × gate_scale[t] (TrackBank's overload);
  /// std::logic_error where the kind's bank does not gate per track.
  virtual void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                         std::span<const double> gate_scale,
                                         Eigen::Ref<Eigen::MatrixXd> out);
  /// The covariance calibration the bank applies (CalibratedTrackBank), or null: the model's own
  /// covariances.
  [[nodiscard]] virtual const CovarianceCalibration* calibration() const { return nullptr; }
};

/// A concrete bank behind AnyTrackBank.
template <class Bank>
class TrackBankAdapter final : public AnyTrackBank {
 public:
  /// The bank built from `arguments`.
  template <class... Arguments>
  explicit TrackBankAdapter(Arguments&&... arguments)
      : bank_(std::forward<Arguments>(arguments)...) {}

  [[nodiscard]] std::size_t capacity() const override { return bank_.capacity(); }
  [[nodiscard]] int state_dimension() const override { return kDim; }
  void initialize(std::size_t track, const Eigen::VectorXd& mean,
                  const Eigen::MatrixXd& covariance) override {
    check_sizes(mean, covariance);
    State state;
    state.mean = mean;
    state.covariance = covariance;
    bank_.initialize(track, state);
  }
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) override {
    bank_.step(plots, status);
  }
  [[nodiscard]] bool initialized(std::size_t track) const override {
    return bank_.initialized(track);
  }
  void estimate(std::size_t track, Eigen::VectorXd& mean,
                Eigen::MatrixXd& covariance) const override {
    const State e = bank_.estimate(track);
    mean = e.mean;
    covariance = e.covariance;
  }
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const override {
    return bank_.mode_probabilities(track);
  }
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 Eigen::Ref<Eigen::MatrixXd> out) override {
    if constexpr (requires { bank_.candidate_log_likelihoods(plots, gate, out); }) {
      bank_.candidate_log_likelihoods(plots, gate, out);
    } else {
      AnyTrackBank::candidate_log_likelihoods(plots, gate, out);
    }
  }
  bool set_interval(double interval) override {
    if constexpr (requires { bank_.set_interval(interval); }) {
      return bank_.set_interval(interval);
    } else {
      return false;
    }
  }
  [[nodiscard]] bool states_step_nis() const override { return kStatesNis; }
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
            std::span<double> nis) override {
    if constexpr (kStatesNis) {
      bank_.step(plots, status, nis);
    } else {
      AnyTrackBank::step(plots, status, nis);
    }
  }
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 std::span<const double> gate_scale,
                                 Eigen::Ref<Eigen::MatrixXd> out) override {
    if constexpr (kStatesNis) {
      bank_.candidate_log_likelihoods(plots, gate, gate_scale, out);
    } else {
      AnyTrackBank::candidate_log_likelihoods(plots, gate, gate_scale, out);
    }
  }
  /// The bank itself.
  [[nodiscard]] Bank& bank() { return bank_; }

 private:
  using State = decltype(std::declval<const Bank&>().estimate(0));
  static constexpr int kDim = decltype(State::mean)::RowsAtCompileTime;
  static constexpr bool kStatesNis =
      requires(Bank & b, std::span<const Eigen::Vector2d> z, std::span<StepStatus> s,
               std::span<double> n, std::span<const double> g, Eigen::Ref<Eigen::MatrixXd> o) {
    b.step(z, s, n);
    b.candidate_log_likelihoods(z, 1.0, g, o);
  };
  static void check_sizes(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance);

  Bank bank_;
};

/// One model kind (see the file comment).
struct IMM_RUNTIME_EXPORT ModelKind {
  /// The model_kind attribute of its files, e.g. "ga_fuzzy_imm".
  std::string name{};
  /// Other names it is known by (command names, older spellings), e.g. "ga", "ga-imm".
  std::vector<std::string> aliases{};
  /// One line for listings.
  std::string summary{};
  /// Reads and checks a file's contents without building a filter; throws io::FileError naming
  /// the field.
  std::function<void(const io::ModelFileReader&)> validate{};
  /// Reads a file of this kind once and returns what builds its filters (load_filter_maker).
  std::function<FilterMaker(const io::ModelFileReader&, std::int64_t max_gap)> load{};
  /// Opens a bank of `capacity` tracks of the file's filter; empty when the kind has no bank.
  std::function<std::unique_ptr<AnyTrackBank>(const io::ModelFileReader&, std::size_t capacity)>
      open_bank{};

  /// Whether `name_or_alias` is its name or one of its aliases.
  [[nodiscard]] bool answers_to(std::string_view name_or_alias) const;
};

/// Adds a kind. Throws InvalidParameter naming the field: an empty name ("name"), no `validate`
/// or `load` function, or a name or alias another kind already answers to ("aliases[i]").
IMM_RUNTIME_EXPORT void register_model_kind(ModelKind kind);

/// The kind answering to `name_or_alias`, or nullptr. The pointer stays valid for the program.
[[nodiscard]] IMM_RUNTIME_EXPORT const ModelKind* find_model_kind(std::string_view name_or_alias);

/// The kind answering to `name_or_alias`; throws InvalidParameter(field) listing the known names.
[[nodiscard]] IMM_RUNTIME_EXPORT const ModelKind& model_kind(std::string_view name_or_alias,
                                                             const std::string& field);

/// Every registered kind, in registration order (the six of this runtime first).
[[nodiscard]] IMM_RUNTIME_EXPORT std::vector<const ModelKind*> model_kinds();

/// Opens a bank of `capacity` tracks for the model file at `path`, of whatever kind it is. Where
/// the file carries a covariance calibration and the kind's bank states its steps' NIS (every
/// bank of this runtime), the bank is a CalibratedTrackBank (calibrated_track_bank.hpp): it gates
/// and states its covariances as load_filter's calibrated filters do. A bank that states no NIS
/// (a kind registered elsewhere) runs the model as trained, calibration() null. Throws io::FileError naming the file and field as load_filter does,
/// InvalidParameter("path") for a kind without a bank.
[[nodiscard]] IMM_RUNTIME_EXPORT std::unique_ptr<AnyTrackBank> open_track_bank(
    const std::filesystem::path& path, std::size_t capacity);

template <class Bank>
void TrackBankAdapter<Bank>::check_sizes(const Eigen::VectorXd& mean,
                                         const Eigen::MatrixXd& covariance) {
  const std::string n = std::to_string(kDim);
  if (mean.size() != kDim) throw InvalidParameter("mean", "expected " + n + " entries");
  if (covariance.rows() != kDim || covariance.cols() != kDim) {
    throw InvalidParameter("covariance", "expected " + n + "×" + n);
  }
}

}  // namespace imm
