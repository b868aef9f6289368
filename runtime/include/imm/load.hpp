// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// One entry point from a model file to a running filter, for every model kind:
///
///   imm::Tracker tracker = imm::load_tracker("models/ga_fuzzy_imm.h5");
///   for (const Plot& plot : plots) tracker.process(plot.scan, plot.z);
///
/// The file says what it is (its model_kind) and carries every setting its filter was evaluated
/// with, so nothing from the training configuration is needed:
///   plain_imm            the plain IMM (Cartesian or polar plots, as the file says)
///   ga_fuzzy_imm         the GA-fuzzy IMM, per axis (Cartesian plots)
///   mlp_input_estimator  the input-estimation filter, per axis (Cartesian plots)
///   fcm_imm              the FCM-compensated IMM, per axis (Cartesian plots)
///   tsk_sensor           the FIMM through the learned sensor model (plots in the sensor's space)
///   wimm                 the weighted IMM with azimuth fusion (polar plots)
/// and every kind added by register_model_kind (model_kinds.hpp).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "imm/io/model_file.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/track_filter.hpp"
#include "imm/tracking/track_options.hpp"
#include "imm/tracking/tracker.hpp"

namespace imm {

/// A model file's filter and how to feed it.
struct IMM_RUNTIME_EXPORT LoadedFilter {
  std::unique_ptr<TrackFilter> filter;  ///< ready to initialize; state [x, vx, y, vy] or 6-state
  TrackOptions options;                 ///< the plots' space and noise, the track start
  io::Provenance provenance;            ///< model_kind, trainer version, regime, …
};

/// A model file read once, building as many fresh filters as wanted (one per track), all alike.
struct IMM_RUNTIME_EXPORT FilterMaker {
  std::function<std::unique_ptr<TrackFilter>()> make;  ///< a fresh filter, ready to initialize
  TrackOptions options;                                ///< the plots' space and noise, the start
  io::Provenance provenance;                           ///< model_kind, trainer version, regime, …
};

/// The model kinds load_filter reads: the names of model_kinds() (model_kinds.hpp).
[[nodiscard]] IMM_RUNTIME_EXPORT std::vector<std::string_view> loadable_model_kinds();

/// Reads a model file of any kind and builds its filter. Throws io::FileError naming the file and
/// the field: no such model file, not a model file, a kind this runtime does not know, a schema
/// version newer than it reads, or any invalid content.
[[nodiscard]] IMM_RUNTIME_EXPORT LoadedFilter load_filter(const std::filesystem::path& path,
                                                          std::int64_t max_gap = kDefaultMaxGap);

/// The same from a reader the caller has already opened (the file is read once).
[[nodiscard]] IMM_RUNTIME_EXPORT LoadedFilter load_filter(const io::ModelFileReader& reader,
                                                          std::int64_t max_gap = kDefaultMaxGap);

/// The same, read once for many tracks: `make()` builds each track's filter from the one spec.
/// Throws io::FileError as load_filter does.
[[nodiscard]] IMM_RUNTIME_EXPORT FilterMaker
load_filter_maker(const std::filesystem::path& path, std::int64_t max_gap = kDefaultMaxGap);
/// The same from a reader the caller has already opened.
[[nodiscard]] IMM_RUNTIME_EXPORT FilterMaker
load_filter_maker(const io::ModelFileReader& reader, std::int64_t max_gap = kDefaultMaxGap);

/// load_filter() wrapped in a Tracker: the track starts, predicts through gaps and rejects bad
/// plots as TrackOptions say.
[[nodiscard]] IMM_RUNTIME_EXPORT Tracker load_tracker(const std::filesystem::path& path,
                                                      std::int64_t max_gap = kDefaultMaxGap);

}  // namespace imm
