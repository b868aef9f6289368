#include "imm/support/scenario_config.hpp"

#include <numbers>

#include "imm/core/invalid_parameter.hpp"

namespace imm::support {

datasets::ManeuverScenario scenario_from(const ConfigTable& table,
                                         const datasets::ManeuverScenario& defaults) {
  datasets::ManeuverScenario s = defaults;
  s.name = table.text_or("name", s.name);
  s.sample_period = table.real_or("sample_period", s.sample_period);
  s.steps = table.count_or("steps", s.steps);
  s.runs = table.count_or("runs", s.runs);
  const std::int64_t seed = table.integer_or("seed", static_cast<std::int64_t>(s.seed));
  if (seed < 0) table.fail("seed", "must be non-negative");
  s.seed = static_cast<std::uint64_t>(seed);
  if (table.has("initial_position")) s.initial_position = table.reals("initial_position", 2);
  if (table.has("initial_velocity")) s.initial_velocity = table.reals("initial_velocity", 2);
  s.process_noise_sigma = table.real_or("process_noise_sigma", s.process_noise_sigma);
  if (const auto measurement = table.table("measurement")) {
    if (measurement->has("kind")) {
      const std::string kind = measurement->text("kind");
      try {
        s.measurement.kind = measurement_kind_from(kind, measurement->path("kind"));
      } catch (const InvalidParameter&) {
        measurement->fail("kind",
                          "unknown measurement '" + kind + "' (expected cartesian or polar)");
      }
    }
    if (measurement->has("sigma")) s.measurement.sigma = measurement->reals("sigma", 2);
  }
  if (table.has("maneuvers")) {
    s.maneuvers.clear();
    for (const ConfigTable& m : table.tables("maneuvers")) {
      datasets::ManeuverSegment segment;
      segment.start = m.count("start");
      segment.end = m.count("end");
      segment.acceleration = m.reals("acceleration", 2);
      s.maneuvers.push_back(segment);
    }
  }
  if (table.has("turns")) {
    s.turns.clear();
    for (const ConfigTable& t : table.tables("turns")) {
      datasets::TurnSegment turn;
      turn.start = t.count("start");
      turn.end = t.count("end");
      turn.omega = t.real("omega_deg") * std::numbers::pi / 180.0;
      s.turns.push_back(turn);
    }
  }
  s.validate();
  return s;
}

datasets::ManeuverScenario load_scenario_config(const std::filesystem::path& path,
                                                const datasets::ManeuverScenario& defaults) {
  const auto document = ConfigDocument::load(path);
  return document->load_checked([&] { return scenario_from(document->root(), defaults); });
}

}  // namespace imm::support
