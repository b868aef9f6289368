// SPDX-License-Identifier: Apache-2.0
// The registry of model kinds (imm/model_kinds.hpp): a new kind is one register_model_kind call
// beside its own writer, reader and filter — shown with an α-β tracker written here — after which
// load_filter, load_tracker, load_filter_maker and loadable_model_kinds know it; the six kinds of
// the runtime answer to their command names; a name or alias already taken, or a kind without a
// reader, is refused naming the field; open_track_bank opens every shipped model's bank behind
// one interface, equal to that kind's bank stepped directly, and refusing the starts its
// one-track filter refuses.

#include "imm/model_kinds.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "imm/io/file_error.hpp"
#include "imm/io/model_file.hpp"
#include "imm/load.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/tracking/track_filter.hpp"
#include "testing/refused_field.hpp"
#include "testing/shipped_models.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

// ---- The new kind's own files: an α-β tracker per axis, state [x, vx, y, vy] ----

struct AlphaBetaSpec {
  double alpha = 0.0, beta = 0.0, sample_period = 0.0, sigma = 0.0;
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap) const {
    return two_point_track_options(sample_period, MeasurementKind::kCartesian,
                                   Eigen::Matrix2d::Identity() * sigma * sigma, max_gap);
  }
};

// Fixed gains K = [α, β/T] per axis; the covariance follows the gains exactly (Joseph form holds
// for any gain): P⁻ = F P Fᵀ, P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ.
class AlphaBetaFilter final : public TrackFilter {
 public:
  explicit AlphaBetaFilter(const AlphaBetaSpec& spec) : spec_(spec) {
    const double T = spec.sample_period;
    F_ << 1, T, 0, 0, 0, 1, 0, 0, 0, 0, 1, T, 0, 0, 0, 1;
    K_.setZero();
    K_(0, 0) = K_(2, 1) = spec.alpha;
    K_(1, 0) = K_(3, 1) = spec.beta / T;
    H_.setZero();
    H_(0, 0) = H_(1, 2) = 1.0;
    R_ = Eigen::Matrix2d::Identity() * spec.sigma * spec.sigma;
  }
  [[nodiscard]] int state_dimension() const override { return 4; }
  [[nodiscard]] int mode_count() const override { return 1; }
  [[nodiscard]] std::string mode_name(int /*j*/) const override { return "alpha_beta"; }
  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) override {
    x_ = mean;
    P_ = covariance;
  }
  StepStatus step(const Eigen::Vector2d& z) override {
    if (!z.allFinite()) return StepStatus::kInvalidMeasurement;
    const Eigen::Vector4d predicted = F_ * x_;
    const Eigen::Matrix4d P = F_ * P_ * F_.transpose();
    nu_ = z - H_ * predicted;
    S_ = H_ * P * H_.transpose() + R_;
    const Eigen::Matrix4d A = Eigen::Matrix4d::Identity() - K_ * H_;
    x_ = predicted + K_ * nu_;
    P_ = A * P * A.transpose() + K_ * R_ * K_.transpose();
    stepped_ = true;
    return StepStatus::kOk;
  }
  StepStatus predict_only() override {
    x_ = F_ * x_;
    P_ = F_ * P_ * F_.transpose();
    stepped_ = false;
    return StepStatus::kOk;
  }
  void state(Eigen::Ref<Eigen::VectorXd> mean,
             Eigen::Ref<Eigen::VectorXd> variance) const override {
    mean = x_;
    variance = P_.diagonal();
  }
  void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const override { covariance = P_; }
  [[nodiscard]] ModeVector mode_probabilities() const override { return ModeVector::Ones(1); }
  bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const override {
    if (!stepped_) return false;
    nu = nu_;
    S = S_;
    return true;
  }

 private:
  AlphaBetaSpec spec_;
  Eigen::Matrix4d F_, P_;
  Eigen::Matrix<double, 4, 2> K_;
  Eigen::Matrix<double, 2, 4> H_;
  Eigen::Matrix2d R_, S_;
  Eigen::Vector4d x_;
  Eigen::Vector2d nu_;
  bool stepped_ = false;
};

constexpr const char* kAlphaBeta = "alpha_beta";

void write_alpha_beta(const std::filesystem::path& path, const AlphaBetaSpec& spec) {
  io::Provenance provenance;
  provenance.model_kind = kAlphaBeta;
  provenance.trainer_version = "test";
  io::ModelFileWriter writer(path, provenance);
  writer.container().create_group("/alpha_beta");
  writer.set_quantity("/alpha_beta", "alpha", spec.alpha, "1");
  writer.set_quantity("/alpha_beta", "beta", spec.beta, "1");
  writer.set_quantity("/alpha_beta", "sample_period", spec.sample_period, "s");
  writer.set_quantity("/alpha_beta", "measurement_sigma", spec.sigma, "m");
  writer.commit();
}

AlphaBetaSpec read_alpha_beta(const io::ModelFileReader& reader) {
  AlphaBetaSpec spec{reader.real("/alpha_beta", "alpha", io::ValueRule::kPositive),
                     reader.real("/alpha_beta", "beta", io::ValueRule::kPositive),
                     reader.real("/alpha_beta", "sample_period", io::ValueRule::kPositive),
                     reader.real("/alpha_beta", "measurement_sigma", io::ValueRule::kPositive)};
  if (spec.alpha >= 1.0) reader.fail("/alpha_beta@alpha", "must be below 1");
  return spec;
}

// ---- The one registration the kind needs ----

void register_alpha_beta() {
  static const bool registered = [] {
    register_model_kind({
        .name = kAlphaBeta,
        .aliases = {"ab"},
        .summary = "an α-β tracker per axis (a kind added by a test)",
        .validate = [](const io::ModelFileReader& r) { (void)read_alpha_beta(r); },
        .load =
            [](const io::ModelFileReader& r, std::int64_t max_gap) {
              const AlphaBetaSpec spec = read_alpha_beta(r);
              FilterMaker maker;
              maker.options = spec.track_options(max_gap);
              maker.make = [spec] { return std::make_unique<AlphaBetaFilter>(spec); };
              return maker;
            },
        .open_bank = {},
    });
    return true;
  }();
  (void)registered;
}

TEST(ModelKinds, AKindAddedByOneRegistrationLoadsAndTracksThroughLoadTracker) {
  register_alpha_beta();
  const testing::TempDir dir;
  const auto path = dir.path() / "ab.h5";
  const AlphaBetaSpec spec{0.5, 0.2, 0.5, 10.0};
  write_alpha_beta(path, spec);

  const auto kinds = loadable_model_kinds();
  EXPECT_NE(std::find(kinds.begin(), kinds.end(), std::string_view(kAlphaBeta)), kinds.end());
  ASSERT_NE(find_model_kind("ab"), nullptr);
  EXPECT_EQ(find_model_kind("ab")->name, kAlphaBeta);

  // A target at constant velocity, exact plots: the two-point start is exact, and the α-β
  // tracker (unbiased for constant velocity) stays on the line to rounding.
  Tracker tracker = load_tracker(path);
  EXPECT_EQ(load_filter(path).options.sample_period, 0.5);
  for (std::int64_t k = 0; k < 20; ++k) {
    const double t = 0.5 * static_cast<double>(k);
    (void)tracker.process(k, Eigen::Vector2d(100.0 + 30.0 * t, -50.0 + 4.0 * t));
  }
  Eigen::VectorXd mean(4), variance(4);
  tracker.state(mean, variance);
  const double t = 0.5 * 19;
  EXPECT_NEAR(mean(0), 100.0 + 30.0 * t, 1e-9);
  EXPECT_NEAR(mean(1), 30.0, 1e-9);
  EXPECT_NEAR(mean(2), -50.0 + 4.0 * t, 1e-9);
  EXPECT_NEAR(mean(3), 4.0, 1e-9);
  EXPECT_TRUE((variance.array() > 0.0).all());

  // Its reader's refusals reach the caller as FileError naming the field.
  const auto bad = dir.path() / "bad.h5";
  write_alpha_beta(bad, {1.5, 0.2, 0.5, 10.0});
  try {
    (void)load_filter(bad);
    ADD_FAILURE() << "an α of 1.5 was accepted";
  } catch (const io::FileError& error) {
    EXPECT_NE(std::string(error.what()).find("alpha"), std::string::npos) << error.what();
  }
  // A kind without a bank says so.
  try {
    (void)open_track_bank(path, 4);
    ADD_FAILURE() << "a kind without a bank opened one";
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "path");
  }
}

TEST(ModelKinds, TheRuntimesKindsAnswerToTheirCommandNames) {
  const std::pair<const char*, const char*> names[] = {{"ga", "ga_fuzzy_imm"},
                                                       {"ga-imm", "ga_fuzzy_imm"},
                                                       {"mlp", "mlp_input_estimator"},
                                                       {"input-estimator", "mlp_input_estimator"},
                                                       {"fcm", "fcm_imm"},
                                                       {"tsk", "tsk_sensor"},
                                                       {"fimm", "tsk_sensor"},
                                                       {"plain-imm", "plain_imm"},
                                                       {"wimm", "wimm"},
                                                       {"plain_imm", "plain_imm"}};
  for (const auto& [alias, kind] : names) {
    const ModelKind* found = find_model_kind(alias);
    ASSERT_NE(found, nullptr) << alias;
    EXPECT_EQ(found->name, kind) << alias;
  }
  EXPECT_EQ(find_model_kind("no_such_kind"), nullptr);
  try {
    (void)model_kind("no_such_kind", "kind");
    ADD_FAILURE();
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "kind");
    EXPECT_NE(std::string(error.what()).find("ga_fuzzy_imm"), std::string::npos);
  }
}

TEST(ModelKinds, ATakenNameOrAliasAndAKindWithoutAReaderAreRefusedByField) {
  const auto refused = [](ModelKind kind, const std::string& field) {
    try {
      register_model_kind(std::move(kind));
      ADD_FAILURE() << "registered";
    } catch (const InvalidParameter& error) {
      EXPECT_EQ(error.field(), field) << error.what();
    }
  };
  const auto validate = [](const io::ModelFileReader&) {};
  const auto load = [](const io::ModelFileReader&, std::int64_t) { return FilterMaker{}; };
  refused({.name = "", .validate = validate, .load = load}, "name");
  refused({.name = "wimm", .validate = validate, .load = load}, "name");
  refused({.name = "fresh_kind", .aliases = {"x", "ga"}, .validate = validate, .load = load},
          "aliases[1]");
  refused({.name = "fresh_kind", .load = load}, "validate");
  refused({.name = "fresh_kind", .validate = validate}, "load");
  EXPECT_EQ(find_model_kind("fresh_kind"), nullptr);  // nothing half-registered
}

// open_track_bank: every shipped model's bank behind AnyTrackBank. Three tracks stepped together
// equal a bank of one stepped alone (a track does not depend on its neighbours), and two tracks
// fed alike stay alike.
TEST(ModelKinds, EveryShippedModelOpensABankBehindOneInterface) {
  int opened = 0;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    const std::unique_ptr<AnyTrackBank> bank = open_track_bank(path, 3);
    ASSERT_EQ(bank->capacity(), 3U);
    const int n = bank->state_dimension();
    ASSERT_TRUE(n == 4 || n == 6 || n == 5 || n == 7);
    const FilterMaker maker = load_filter_maker(path);
    // A start near the plots' space: a two-point-like mean with a broad covariance.
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
    const bool polar = maker.options.measurement_kind == MeasurementKind::kPolar;
    const int per_axis = n >= 6 ? 3 : 2;
    mean(0) = polar ? 20000.0 : 100.0;
    mean(per_axis) = polar ? 15000.0 : 50.0;
    const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n) * 100.0;
    for (std::size_t t = 0; t < 3; ++t) bank->initialize(t, mean, P);
    EXPECT_THROW(bank->initialize(0, Eigen::VectorXd::Zero(n + 1), P), InvalidParameter);
    const std::unique_ptr<AnyTrackBank> alone = open_track_bank(path, 1);
    alone->initialize(0, mean, P);
    std::vector<Eigen::Vector2d> plots(3);
    std::vector<StepStatus> status(3), status_alone(1);
    Eigen::Vector2d z = maker.options.measurement_kind == MeasurementKind::kPolar
                            ? Eigen::Vector2d(25000.0, 0.6)
                            : Eigen::Vector2d(100.0, 50.0);
    for (int k = 0; k < 5; ++k) {
      plots = {z, z * 1.001, z};
      bank->step(plots, status);
      alone->step(std::span(plots).first(1), status_alone);
      EXPECT_EQ(status[0], status_alone[0]);
    }
    Eigen::VectorXd m0, m2, ma;
    Eigen::MatrixXd c0, c2, ca;
    bank->estimate(0, m0, c0);
    bank->estimate(2, m2, c2);
    alone->estimate(0, ma, ca);
    EXPECT_TRUE(m0.allFinite());
    EXPECT_EQ(m0, ma);  // a track does not depend on its neighbours
    EXPECT_EQ(c0, ca);
    EXPECT_EQ(m0, m2);  // two tracks fed alike are alike
    // μ of one IMM sums to 1; an axis-wise filter reports both axes' μ (each summing to 1).
    const double mu = bank->mode_probabilities(0).sum();
    EXPECT_TRUE(std::abs(mu - 1.0) < 1e-9 || std::abs(mu - 2.0) < 1e-9) << mu;
    ++opened;
  }
  EXPECT_GE(opened, 6);
}

// Every shipped model's bank starts a track only from what its one-track filter starts from: a
// start the filter refuses (a NaN mean, an infinite, asymmetric or negative variance) is refused
// with the filter's field, and neither a running track nor one never started changes.
TEST(ModelKinds, EveryShippedModelsBankRefusesTheStartsItsFilterRefuses) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  int checked = 0;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    const std::unique_ptr<AnyTrackBank> bank = open_track_bank(path, 2);
    const int n = bank->state_dimension();
    const Eigen::VectorXd mean = Eigen::VectorXd::Constant(n, 1.0);
    const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n) * 100.0;
    bank->initialize(0, mean, P);
    Eigen::VectorXd running_mean;
    Eigen::MatrixXd running_covariance;
    bank->estimate(0, running_mean, running_covariance);
    const ModeVector running_mu = bank->mode_probabilities(0);
    struct Start {
      const char* what;
      Eigen::VectorXd mean;
      Eigen::MatrixXd covariance;
    };
    std::vector<Start> starts(4, Start{"", mean, P});
    starts[0].what = "a NaN mean";
    starts[0].mean(n - 1) = kNaN;
    starts[1].what = "an infinite variance";
    starts[1].covariance(1, 1) = kInf;
    starts[2].what = "an asymmetric covariance";
    starts[2].covariance(0, 1) = 2.0;
    starts[3].what = "a negative variance";
    starts[3].covariance(n - 1, n - 1) = -1.0;
    for (const Start& start : starts) {
      SCOPED_TRACE(start.what);
      const std::unique_ptr<TrackFilter> filter = load_filter(path).filter;
      const std::string field =
          testing::refused_field_of([&] { filter->initialize(start.mean, start.covariance); });
      ASSERT_FALSE(field.empty()) << "the one-track filter starts from it";
      for (const std::size_t track : {std::size_t{0}, std::size_t{1}}) {
        EXPECT_EQ(testing::refused_field_of(
                      [&] { bank->initialize(track, start.mean, start.covariance); }),
                  field)
            << "track " << track;
      }
      Eigen::VectorXd m;
      Eigen::MatrixXd c;
      bank->estimate(0, m, c);
      EXPECT_EQ(m, running_mean);
      EXPECT_EQ(c, running_covariance);
      EXPECT_EQ(bank->mode_probabilities(0), running_mu);
      EXPECT_FALSE(bank->initialized(1));
    }
    ++checked;
  }
  EXPECT_GE(checked, 18);
}

// A step that states its NIS through the bank of the model at `path` (false: it states none): for
// every count of stepped tracks from 1 to past two blocks, one NIS per stepped track (finite where
// the step succeeded) and nothing written past them.
bool expect_one_nis_per_stepped_track(const std::filesystem::path& path) {
  constexpr std::size_t kCapacity = 19;
  constexpr double kUntouched = -12345.0;
  const std::unique_ptr<AnyTrackBank> bank = open_track_bank(path, kCapacity);
  if (!bank->states_step_nis()) return false;
  const int n = bank->state_dimension();
  const bool polar = load_filter_maker(path).options.measurement_kind == MeasurementKind::kPolar;
  const int per_axis = n >= 6 ? 3 : 2;
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
  mean(0) = polar ? 20000.0 : 100.0;
  mean(per_axis) = polar ? 15000.0 : 50.0;
  const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n) * 100.0;
  for (std::size_t t = 0; t < kCapacity; ++t) bank->initialize(t, mean, P);
  const Eigen::Vector2d z = polar ? Eigen::Vector2d(25000.0, 0.6) : Eigen::Vector2d(101.0, 49.0);
  for (std::size_t count = 1; count <= kCapacity; ++count) {
    std::vector<Eigen::Vector2d> plots(count, z);
    std::vector<StepStatus> status(count);
    std::vector<double> nis(count + 16, kUntouched);
    bank->step(plots, status, std::span<double>(nis.data(), count));
    for (std::size_t t = 0; t < count; ++t) {
      EXPECT_EQ(status[t], StepStatus::kOk) << count << " tracks, track " << t;
      EXPECT_TRUE(std::isfinite(nis[t]) && nis[t] >= 0.0) << count << " tracks, track " << t;
    }
    for (std::size_t i = count; i < nis.size(); ++i) {
      EXPECT_EQ(nis[i], kUntouched) << count << " tracks: entry " << i << " written";
    }
  }
  return true;
}

// Every shipped model's bank under each instruction set (the widest steps wide blocks, the others
// narrow ones, whose last half may hold no track).
TEST(ModelKinds, EveryShippedModelsBankStatesOneNisPerSteppedTrackAndWritesNothingPast) {
  int checked = 0;
  for (const LaneIsa isa : {LaneIsa::kAvx512, LaneIsa::kAvx2, LaneIsa::kBaseline}) {
    cap_lane_isa(isa);
    for (const auto& path : testing::shipped_models()) {
      SCOPED_TRACE(path.string() + ", instruction sets up to " +
                   std::to_string(static_cast<int>(isa)));
      checked += expect_one_nis_per_stepped_track(path) ? 1 : 0;
      if (HasFailure()) break;
    }
  }
  cap_lane_isa(LaneIsa::kAvx512);
  EXPECT_GE(checked, 18);
}

}  // namespace
}  // namespace imm
