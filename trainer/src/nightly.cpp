// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/nightly.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <stdexcept>

#include "imm/support/config.hpp"

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

NightlyStage make_stage(std::string kind, std::string name, std::string executable) {
  NightlyStage stage;
  stage.kind = std::move(kind);
  stage.name = std::move(name);
  stage.executable = std::move(executable);
  return stage;
}

NightlyPlan plan_from(const support::ConfigTable& root) {
  NightlyPlan plan;
  plan.registry = root.text_or("registry", "models");
  plan.allow_dirty_trainer = root.boolean_or("allow_dirty_trainer", false);
  for (const auto& entry : root.tables("data")) {
    const std::string out = entry.text("out");
    NightlyStage stage = make_stage("data", entry.text("name"), "imm-data");
    stage.arguments = {entry.text("command"), "--regime", entry.text("regime"), "--out", out};
    stage.out = out;
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
  const auto models = root.tables("models");
  for (std::size_t i = 0; i < models.size(); ++i) {
    const auto& entry = models[i];
    NightlyStage stage = make_stage("model", entry.text("name"), "imm-train");
    const std::string out = entry.text("out");
    stage.arguments = {entry.text("command"), "--config", entry.text("config"), "--out", out};
    stage.out = out;
    stage.out_argument = 4;
    const auto relative = std::filesystem::path(out).lexically_relative(plan.registry);
    if (relative.empty() || relative.begin()->string() == ".." || relative.is_absolute()) {
      entry.fail("out", "the model must be written inside the registry folder '" +
                            plan.registry.string() + "'");
    }
    for (const auto& other : plan.stages) {
      if (other.kind == "model" && other.name == stage.name) {
        entry.fail("name", "a second model stage named '" + stage.name + "'");
      }
    }
    add_folder_of(stage, out);
    add_optional_text(entry, "regime", "--regime", stage);
    add_optional(entry, "seed", "--seed", stage);
    add_passthrough(entry, stage);
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("tracks")) {
    const std::string out = entry.text("out");
    NightlyStage stage = make_stage("track", out, "imm-track");
    stage.arguments = {"--filter",       entry.text("filter"),
                       "--measurements", entry.text("measurements"),
                       "--out",          out};
    stage.out = out;
    add_folder_of(stage, out);
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("evaluations")) {
    NightlyStage stage = make_stage("evaluation", entry.text("experiment"), "imm-eval");
    const std::string out = entry.text("out");
    stage.model = entry.text("model");
    const auto linked = std::find_if(plan.stages.begin(), plan.stages.end(), [&](const auto& s) {
      return s.kind == "model" && s.name == stage.model;
    });
    if (linked == plan.stages.end()) {
      entry.fail("model", "names no [[models]] stage ('" + stage.model + "')");
    }
    stage.name = stage.name + " " + stage.model;
    stage.out = out;
    stage.arguments = {entry.text("experiment"),
                       "--models",
                       entry.text_or("models", plan.registry.string()),
                       "--out",
                       out,
                       "--model",
                       linked->out.string()};
    stage.out_argument = 4;
    stage.model_argument = 6;
    add_folder_of(stage, out, true);
    stage.has_regime = entry.has("regime");
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

std::vector<const NightlyStage*> NightlyPlan::evaluations_of(const std::string& model) const {
  std::vector<const NightlyStage*> found;
  for (const auto& stage : stages) {
    if (stage.kind == "evaluation" && stage.model == model) found.push_back(&stage);
  }
  return found;
}

NightlyPlan load_nightly_plan(const std::filesystem::path& path) {
  const auto document = support::ConfigDocument::load(path);
  return document->load_checked([&] { return plan_from(document->root()); });
}

int run_process(const std::filesystem::path& executable, const std::vector<std::string>& arguments,
                const std::optional<std::filesystem::path>& log) {
  std::vector<std::string> storage;
  storage.push_back(executable.string());
  storage.insert(storage.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  argv.reserve(storage.size() + 1);
  for (auto& argument : storage) argv.push_back(argument.data());
  argv.push_back(nullptr);
  std::string out_path, err_path;
  if (log) {
    out_path = log->string() + ".out";
    err_path = log->string() + ".err";
  }
  // A bare name is looked up in PATH, a path is used as given.
  const bool search_path = storage[0].find('/') == std::string::npos;
  // fork + exec rather than posix_spawn: the child asks to be killed with its parent, so a nightly
  // killed with -9 leaves no trainer or evaluation running on behind it.
  int exec_status[2];
  if (::pipe2(exec_status, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(exec_status[0]);
    ::close(exec_status[1]);
    throw std::runtime_error("cannot start " + storage[0] + ": fork failed");
  }
  if (pid == 0) {  // the child: async-signal-safe calls only
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    if (log) {
      const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      if (out < 0 || err < 0 || ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0) ::_exit(127);
    }
    if (search_path) {
      ::execvp(argv[0], argv.data());
    } else {
      ::execv(argv[0], argv.data());
    }
    const int error = errno;
    (void)!::write(exec_status[1], &error, sizeof error);
    ::_exit(127);
  }
  ::close(exec_status[1]);
  int exec_error = 0;
  ssize_t got = 0;
  do {
    got = ::read(exec_status[0], &exec_error, sizeof exec_error);
  } while (got < 0 && errno == EINTR);
  ::close(exec_status[0]);
  if (got == static_cast<ssize_t>(sizeof exec_error)) {
    int ignored = 0;
    while (waitpid(pid, &ignored, 0) < 0 && errno == EINTR) {
    }
    throw std::runtime_error("cannot start " + storage[0] + ": " + std::strerror(exec_error));
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
