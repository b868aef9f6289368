#include "imm/trainer/freeze.hpp"

#include <chrono>

#include "imm/io/plain_imm_file.hpp"
#include "imm/support/plain_imm_config.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::trainer {

FreezeSummary freeze_plain_imm(const FreezeOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const PlainImmSpec spec = support::load_plain_imm_config(options.config);
  ensure_parent_folder(options.out);
  io::ModelFileWriter writer(options.out, make_provenance(std::string(io::kPlainImmKind),
                                                          read_text_file(options.config), 0, ""));
  io::write_plain_imm(writer, spec);
  writer.commit();

  FreezeSummary summary;
  summary.modes = static_cast<int>(spec.modes.size());
  summary.state_dimension = spec.mixing_dimension();
  summary.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  nlohmann::json metrics;
  metrics["model_kind"] = io::kPlainImmKind;
  metrics["model"] = options.out.string();
  metrics["config"] = options.config.string();
  metrics["modes"] = summary.modes;
  metrics["state_dimension"] = summary.state_dimension;
  metrics["wall_seconds"] = summary.wall_seconds;
  write_json_atomically(metrics_path(options.out), metrics);
  return summary;
}

}  // namespace imm::trainer
