#include "imm/trainer/nightly.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "imm/support/config.hpp"

extern char** environ;

namespace imm::trainer {
namespace {

void add_folder_of(NightlyStage& stage, const std::string& path, bool path_is_folder = false) {
  std::filesystem::path folder =
      path_is_folder ? std::filesystem::path(path) : std::filesystem::path(path).parent_path();
  if (!folder.empty()) stage.output_folders.push_back(folder);
}

void add_optional(const support::ConfigTable& table, std::string_view key, const char* flag,
                  NightlyStage& stage) {
  if (table.has(key)) {
    stage.arguments.emplace_back(flag);
    stage.arguments.push_back(std::to_string(table.integer(key)));
  }
}

void add_optional_text(const support::ConfigTable& table, std::string_view key, const char* flag,
                       NightlyStage& stage) {
  if (table.has(key)) {
    stage.arguments.emplace_back(flag);
    stage.arguments.push_back(table.text(key));
  }
}

void add_passthrough(const support::ConfigTable& table, NightlyStage& stage) {
  if (table.has("arguments")) {
    for (auto& argument : table.texts("arguments")) stage.arguments.push_back(std::move(argument));
  }
}

NightlyPlan plan_from(const support::ConfigTable& root) {
  NightlyPlan plan;
  for (const auto& entry : root.tables("data")) {
    const std::string out = entry.text("out");
    NightlyStage stage{"data", entry.text("name"), "imm-data", {}, {}};
    stage.arguments = {entry.text("command"), "--regime", entry.text("regime"), "--out", out};
    add_folder_of(stage, out);
    add_optional_text(entry, "split", "--split", stage);
    if (entry.has("csv")) {
      const std::string csv = entry.text("csv");
      stage.arguments.insert(stage.arguments.end(), {"--csv", csv});
      add_folder_of(stage, csv);
    }
    add_optional(entry, "count", "--count", stage);
    add_optional(entry, "seed", "--seed", stage);
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("models")) {
    NightlyStage stage{"model", entry.text("name"), "imm-train", {}, {}};
    const std::string out = entry.text("out");
    stage.arguments = {entry.text("command"), "--config", entry.text("config"), "--out", out};
    add_folder_of(stage, out);
    add_optional_text(entry, "regime", "--regime", stage);
    add_optional(entry, "seed", "--seed", stage);
    add_passthrough(entry, stage);
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("tracks")) {
    const std::string out = entry.text("out");
    NightlyStage stage{"track", out, "imm-track", {}, {}};
    stage.arguments = {"--filter",       entry.text("filter"),
                       "--measurements", entry.text("measurements"),
                       "--out",          out};
    add_folder_of(stage, out);
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("evaluations")) {
    NightlyStage stage{"evaluation", entry.text("experiment"), "imm-eval", {}, {}};
    const std::string out = entry.text("out");
    stage.arguments = {stage.name, "--models", entry.text("models"), "--out", out};
    add_folder_of(stage, out, true);
    add_optional_text(entry, "model", "--model", stage);
    add_optional_text(entry, "regime", "--regime", stage);
    add_optional(entry, "runs", "--runs", stage);
    add_optional(entry, "seed", "--seed", stage);
    add_passthrough(entry, stage);
    plan.stages.push_back(std::move(stage));
  }
  if (plan.stages.empty()) root.fail("models", "the plan lists no stages");
  return plan;
}

}  // namespace

NightlyPlan load_nightly_plan(const std::filesystem::path& path) {
  const auto document = support::ConfigDocument::load(path);
  return document->load_checked([&] { return plan_from(document->root()); });
}

std::vector<StageResult> run_nightly(const NightlyPlan& plan,
                                     const std::function<int(const NightlyStage&)>& run,
                                     const NightlyObserver& observer) {
  std::vector<StageResult> results;
  for (std::size_t i = 0; i < plan.stages.size(); ++i) {
    const NightlyStage& stage = plan.stages[i];
    if (observer.on_start) observer.on_start(stage, i, plan.stages.size());
    for (const auto& folder : stage.output_folders) std::filesystem::create_directories(folder);
    const auto start = std::chrono::steady_clock::now();
    StageResult result;
    result.stage = &stage;
    result.exit_code = run(stage);
    result.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    results.push_back(result);
    if (observer.on_finish) observer.on_finish(result);
    if (result.exit_code != 0) break;
  }
  return results;
}

int run_process(const std::filesystem::path& executable,
                const std::vector<std::string>& arguments) {
  std::vector<std::string> storage;
  storage.push_back(executable.string());
  storage.insert(storage.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  argv.reserve(storage.size() + 1);
  for (auto& argument : storage) argv.push_back(argument.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  // A bare name is looked up in PATH, a path is used as given.
  const bool search_path = storage[0].find('/') == std::string::npos;
  const int error =
      search_path ? posix_spawnp(&pid, storage[0].c_str(), nullptr, nullptr, argv.data(), environ)
                  : posix_spawn(&pid, storage[0].c_str(), nullptr, nullptr, argv.data(), environ);
  if (error != 0) {
    throw std::runtime_error("cannot start " + storage[0] + ": " + std::strerror(error));
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("waitpid failed for " + storage[0]);
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

std::filesystem::path executable_folder() {
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) return std::filesystem::current_path();
  return self.parent_path();
}

}  // namespace imm::trainer
