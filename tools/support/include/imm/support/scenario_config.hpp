#pragma once
/// The TOML form of a maneuver scenario (configs/data/*.toml). Keys mirror ManeuverScenario:
///
///   name = "seed000";  sample_period = 1.0;  steps = 160;  runs = 100;  seed = 1
///   initial_position = [x, y];  initial_velocity = [vx, vy];  process_noise_sigma = σ_w
///   [measurement]  kind = "cartesian" | "polar";  sigma = [σ₁, σ₂]   (polar: [σ_r, σ_θ rad])
///   [[maneuvers]]  start = 40;  end = 60;  acceleration = [ax, ay]
///   [[turns]]      start = 100;  end = 112;  omega_deg = 3.82   (coordinated turn, °/s)
/// Keys left out take the values of `defaults`.

#include <filesystem>

#include "imm/datasets/maneuver_scenario.hpp"
#include "imm/support/config.hpp"

namespace imm::support {

[[nodiscard]] datasets::ManeuverScenario scenario_from(const ConfigTable& table,
                                                       const datasets::ManeuverScenario& defaults);

[[nodiscard]] datasets::ManeuverScenario load_scenario_config(
    const std::filesystem::path& path, const datasets::ManeuverScenario& defaults);

}  // namespace imm::support
