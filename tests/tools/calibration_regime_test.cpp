// SPDX-License-Identifier: Apache-2.0
// The covariance calibration fitted on a real regime's training split (agile_air's tuned CV/CA/CT
// IMM, refitted from the model beneath the calibration its file carries): stored and read back
// whole, applied by load_filter, not by the banks; on the regime's test split (tracks the fit
// never saw) the per-scan NIS and NEES averages lie inside their 95 % χ² bounds on at least 90 % of
// the scans, where the model alone has fewer; a file whose calibration is invalid is refused naming
// the field.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/load.hpp"
#include "imm/math/chi_square.hpp"
#include "imm/model_kinds.hpp"
#include "imm/trainer/model_files/calibration.hpp"
#include "imm/trainer/normalized_errors.hpp"
#include "testing/refused_field.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

constexpr const char* kModel = "models/classical_imm_agile_air.h5";

struct Shares {
  double nis = 0.0, nees = 0.0;  // shares of scans whose run average is inside the bounds
};

// The share of scans whose average over the test runs lies in the two-sided 95 % χ²(2·runs)/runs
// bounds, for the NIS and the position NEES of `model`'s trackers.
Shares consistency_on_test_split(const std::filesystem::path& model, bool raw) {
  const io::ModelFileReader reader(model);
  const datasets::Regime regime =
      datasets::parse_regime(reader.provenance().regime_toml, reader.provenance().regime_name)
          .regime;
  const int runs = 100;
  // raw: the model's own filter, without the calibration its file carries.
  const FilterMaker maker =
      raw ? model_kind(reader.provenance().model_kind, "model_kind").load(reader, kDefaultMaxGap)
          : load_filter_maker(reader);
  std::vector<double> nis, nees;
  std::vector<int> nis_count, nees_count;
  for (int i = 0; i < runs; ++i) {
    const datasets::Track track = datasets::draw_track(regime, datasets::Split::kTest, i, 1);
    Tracker tracker(maker.make(), maker.options);
    const auto scans = static_cast<std::size_t>(track.plots.rows());
    nis.resize(scans, 0.0), nees.resize(scans, 0.0);
    nis_count.resize(scans, 0), nees_count.resize(scans, 0);
    for (std::size_t k = 0; k < scans; ++k) {
      const bool started = tracker.initialized();
      const auto r = tracker.process(static_cast<std::int64_t>(k),
                                     track.plots.row(static_cast<Eigen::Index>(k)).transpose());
      if (!started || r.event != TrackEvent::kUpdated) continue;
      const auto c = trainer::step_consistency(
          tracker.filter(), datasets::position_at(track, static_cast<Eigen::Index>(k)));
      nis[k] += c.nis, ++nis_count[k];
      nees[k] += c.position_nees, ++nees_count[k];
    }
  }
  const double low = chi_square_quantile(0.025, 2.0 * runs) / runs;
  const double high = chi_square_quantile(0.975, 2.0 * runs) / runs;
  const auto share = [&](const std::vector<double>& sum, const std::vector<int>& count) {
    int scans = 0, inside = 0;
    for (std::size_t k = 0; k < sum.size(); ++k) {
      if (count[k] != runs) continue;
      ++scans;
      const double average = sum[k] / runs;
      inside += average >= low && average <= high ? 1 : 0;
    }
    return static_cast<double>(inside) / scans;
  };
  return {share(nis, nis_count), share(nees, nees_count)};
}

TEST(CovarianceCalibration, FittedOnTheTrainingSplitMakesTheTestSplitConsistent) {
  const testing::TempDir dir;
  const std::filesystem::path copy = dir.path() / "calibrated.h5";
  std::filesystem::copy_file(kModel, copy);
  const trainer::CalibrationFit fit = trainer::fit_calibration(copy);
  std::cout << trainer::describe(fit) << '\n';
  ASSERT_TRUE(fit.fitted);
  EXPECT_NEAR(fit.nis_after, 2.0, 0.05);
  EXPECT_NEAR(fit.nees_after, 2.0, 0.05);
  trainer::store_calibration(copy, fit.calibration);

  // Read back whole and applied by load_filter.
  const LoadedFilter loaded = load_filter(copy);
  const auto* calibrated = dynamic_cast<const CalibratedFilter*>(loaded.filter.get());
  ASSERT_NE(calibrated, nullptr);
  const CovarianceCalibration& read = calibrated->calibration();
  EXPECT_EQ(read.start_innovation, fit.calibration.start_innovation);
  EXPECT_EQ(read.start_state, fit.calibration.start_state);
  EXPECT_EQ(read.edges, fit.calibration.edges);
  EXPECT_EQ(read.level_innovation, fit.calibration.level_innovation);
  EXPECT_EQ(read.level_state, fit.calibration.level_state);
  EXPECT_EQ(read.memory, fit.calibration.memory);
  // A bank runs the model as trained (its covariances uncalibrated).
  EXPECT_NO_THROW((void)open_track_bank(copy, 4));

  // Fitting again reads the model beneath the calibration: the same tables.
  const trainer::CalibrationFit again = trainer::fit_calibration(copy);
  EXPECT_EQ(again.calibration.start_innovation, fit.calibration.start_innovation);
  EXPECT_EQ(again.calibration.level_state, fit.calibration.level_state);

  const Shares raw = consistency_on_test_split(kModel, true);
  const Shares shipped = consistency_on_test_split(copy, false);
  std::cout << "scans inside on the test split: NIS " << raw.nis << " → " << shipped.nis
            << ", position NEES " << raw.nees << " → " << shipped.nees << '\n';
  EXPECT_LT(raw.nis, 0.9);
  EXPECT_GE(shipped.nis, 0.9);
  EXPECT_GE(shipped.nees, 0.9);
}

// A copy of the model with a calibration group whose start_innovation[0] is `first`, stated as
// schema `version`.
void write_with_calibration(const std::filesystem::path& file, double first, std::int64_t version) {
  io::ContainerReader in(kModel, io::kModelFormat);
  io::ContainerWriter out(file, io::kModelFormat);
  for (const std::string& object : in.objects()) {
    if (object.starts_with("/calibration")) continue;  // the model's own: replaced below
    if (object != "/" && in.kind(object) == io::ObjectKind::kGroup) out.create_group(object);
    if (in.kind(object) == io::ObjectKind::kDataset) out.write(object, in.read(object));
    for (const std::string& name : in.attribute_names(object)) {
      out.set_attribute(object, name, *in.attribute(object, name));
    }
  }
  out.set_attribute("/", "schema_version", version);
  out.create_group("/calibration");
  out.set_attribute("/calibration", "memory", 0.7);
  out.set_attribute("/calibration", "nis_cap", 50.0);
  out.set_attribute("/calibration", "units", std::string("memory=1,nis_cap=1"));
  for (const auto& [name, value] :
       {std::pair{"start_innovation", first}, std::pair{"start_state", 1.0},
        std::pair{"level_innovation", 1.0}, std::pair{"level_state", 1.0}}) {
    const std::string dataset = std::string("/calibration/") + name;
    out.write(dataset, io::Array::from_vector(Eigen::VectorXd::Constant(1, value)));
    out.set_attribute(dataset, "units", std::string("1"));
  }
  out.commit();
}

// What load_filter throws for `file`, or "read".
std::string refusal(const std::filesystem::path& file) {
  try {
    (void)load_filter(file);
  } catch (const io::FileError& error) {
    return error.what();
  }
  return "read";
}

TEST(CovarianceCalibration, AnInvalidOneInAFileIsRefusedNamingTheField) {
  const testing::TempDir dir;
  write_with_calibration(dir.path() / "hostile.h5", -1.0, kCalibrationSchemaVersion);
  EXPECT_NE(refusal(dir.path() / "hostile.h5").find("/calibration/start_innovation[0]"),
            std::string::npos)
      << refusal(dir.path() / "hostile.h5");
  // A file of an older schema that holds the group is refused naming it: a reader of that
  // version would ignore it and state uncalibrated covariances.
  write_with_calibration(dir.path() / "older.h5", 1.0, kCalibrationSchemaVersion - 1);
  EXPECT_NE(refusal(dir.path() / "older.h5").find("field '/calibration': a version-4 group"),
            std::string::npos)
      << refusal(dir.path() / "older.h5");
  write_with_calibration(dir.path() / "valid.h5", 1.0, kCalibrationSchemaVersion);
  EXPECT_EQ(refusal(dir.path() / "valid.h5"), "read");
}

// Settings are checked before anything is read or drawn: a count of tracks past what a split holds
// (10⁸ would run for hours, its samples past memory), tables of no entries (an empty clamp range)
// and the calibration's own limits are refused naming the field.
TEST(CovarianceCalibration, InvalidSettingsAreRefusedNamingTheFieldBeforeAnyTrackIsRun) {
  const auto field_of = [](auto change) {
    trainer::CalibrationSettings settings;
    change(settings);
    // A file that does not exist: a check after reading would say so instead.
    return testing::refused_field_of(
        [&] { (void)trainer::fit_calibration("/nonexistent/model.h5", settings); });
  };
  using Settings = trainer::CalibrationSettings;
  EXPECT_EQ(field_of([](Settings& s) { s.tracks = datasets::kMaxSplitTracks + 1; }), "tracks");
  EXPECT_EQ(field_of([](Settings& s) { s.tracks = -1; }), "tracks");
  EXPECT_EQ(field_of([](Settings& s) { s.start_entries = 0; }), "start_entries");
  EXPECT_EQ(field_of([](Settings& s) { s.level_bins = 0; }), "level_bins");
  EXPECT_EQ(field_of([](Settings& s) { s.level_bins = CovarianceCalibration::kMaxEntries + 1; }),
            "level_bins");
  EXPECT_EQ(field_of([](Settings& s) { s.memory = 1.0; }), "memory");
  EXPECT_EQ(field_of([](Settings& s) { s.nis_cap = std::nan(""); }), "nis_cap");
  EXPECT_EQ(field_of([](Settings& s) { s.min_samples = 0; }), "min_samples");
  // Valid settings reach the file, which is then what is refused.
  EXPECT_THROW((void)trainer::fit_calibration("/nonexistent/model.h5", Settings{}), io::FileError);
  EXPECT_NO_THROW(Settings{}.validate());
}

}  // namespace
}  // namespace imm
