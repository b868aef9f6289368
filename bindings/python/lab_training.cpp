// SPDX-License-Identifier: Apache-2.0
// train(kind, …): one training exactly as its imm-train subcommand runs it — the same parser and
// the same code (pipeline/training_commands.hpp, as a sweep's job), in this process — so a model
// trained here with a seed has the same parameters as `imm-train <kind> --seed` gives. The
// training's log lines also go to a Python callback while it runs, and Ctrl-C stops it at the
// next line.
#include "lab_training.hpp"

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "imm/pipeline/training_commands.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/kind_aliases.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

// Thrown from the sink to stop a training; not a std::exception, so that spdlog rethrows it
// (SPDLOG_LOGGER_CATCH) and no handler of the trainer's mistakes it for a failure of its own.
struct Stop {};

// During a training from Python, at every log line (with the GIL): hands the line to the progress
// callable, if any, and handles the signals Python has pending — Ctrl-C's KeyboardInterrupt. A
// callable that raises, or a pending KeyboardInterrupt, stops the training at that line (Stop
// unwinds it; every model file is written whole or not at all) and is raised when it has stopped.
class ProgressSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  explicit ProgressSink(py::function callback) : callback_(std::move(callback)) {}
  ProgressSink(const ProgressSink&) = delete;
  ProgressSink& operator=(const ProgressSink&) = delete;
  ~ProgressSink() override {
    const py::gil_scoped_acquire gil;
    callback_ = py::function();
  }

  // The Python exception that stopped the training, if one did.
  void rethrow() {
    if (error_) std::rethrow_exception(error_);
  }

 protected:
  void sink_it_(const spdlog::details::log_msg& message) override {
    if (error_) {
      if (std::uncaught_exceptions() == 0) throw Stop{};
      return;
    }
    const std::string level(spdlog::level::to_string_view(message.level).data(),
                            spdlog::level::to_string_view(message.level).size());
    const std::string text(message.payload.data(), message.payload.size());
    const py::gil_scoped_acquire gil;
    try {
      if (callback_) callback_(level, text);
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    } catch (py::error_already_set&) {
      error_ = std::current_exception();
    }
    // Not while an exception unwinds the stack (a second one would terminate): the next line
    // stops it then.
    if (error_ && std::uncaught_exceptions() == 0) throw Stop{};
  }
  void flush_() override {}

 private:
  py::function callback_;
  std::exception_ptr error_;
};

// The sink on the default logger while it lives, and an error handler that does not report the
// Stop spdlog rethrows; the default logger's usual report afterwards.
class ProgressScope {
 public:
  explicit ProgressScope(std::shared_ptr<ProgressSink> sink) : sink_(std::move(sink)) {
    spdlog::default_logger()->sinks().push_back(sink_);
    spdlog::default_logger()->set_error_handler([](const std::string& message) {
      if (message != "Rethrowing unknown exception in logger") report(message);
    });
  }
  ~ProgressScope() {
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
    spdlog::default_logger()->set_error_handler(report);
  }
  ProgressScope(const ProgressScope&) = delete;
  ProgressScope& operator=(const ProgressScope&) = delete;

 private:
  static void report(const std::string& message) {
    std::fprintf(stderr, "[*** LOG ERROR ***] %s\n", message.c_str());
  }
  std::shared_ptr<ProgressSink> sink_;
};

// At most `bytes` bytes of `text`, not cutting a UTF-8 character.
std::string head(const std::string& text, std::size_t bytes) {
  if (text.size() <= bytes) return text;
  while (bytes > 0 && (static_cast<unsigned char>(text[bytes]) & 0xC0U) == 0x80U) --bytes;
  return text.substr(0, bytes);
}

py::dict train(const std::string& kind, const std::optional<fs::path>& config,
               const std::optional<fs::path>& regime, std::optional<std::uint64_t> seed,
               const std::optional<fs::path>& out, std::optional<int> threads,
               const std::optional<py::object>& progress) {
  imm::pipeline::SweepJob job;
  job.name = "immtrain.train('" + kind + "')";
  job.kind = kind;
  job.arguments = {kind};
  const auto add = [&](const char* option, const std::string& value) {
    job.arguments.emplace_back(option);
    job.arguments.push_back(value);
  };
  if (config) add("--config", config->string());
  if (regime) add("--regime", regime->string());
  if (seed) add("--seed", std::to_string(*seed));
  if (out) add("--out", out->string());
  if (threads) add("--threads", std::to_string(*threads));
  CLI::App app{"imm-train"};
  const imm::pipeline::TrainingCommands training(app);
  imm::support::alias_model_kinds(app);
  try {
    imm::pipeline::parse_job(app, job);
  } catch (const CLI::ParseError& error) {
    // What imm-train says: "unknown command 'gaa'; did you mean 'ga'?" (CLI11's own words were
    // "A subcommand is required").
    std::vector<const char*> argv = {"imm-train"};
    for (const std::string& argument : job.arguments) argv.push_back(argument.c_str());
    throw py::value_error("train('" + kind + "'): " +
                          imm::support::detail::usage_message(app, static_cast<int>(argv.size()),
                                                              argv.data(), error));
  }
  const std::optional<fs::path> model = training.chosen_out();
  if (!model) throw py::value_error("train: '" + kind + "' is no training of imm-train");
  // progress=True: a tqdm bar of the log lines, the last one beside it (a print of each line
  // where tqdm is not installed).
  py::object bar = py::none();
  py::function callback;
  if (progress && py::isinstance<py::bool_>(*progress)) {
    if (progress->cast<bool>()) {
      try {
        bar = py::module_::import("tqdm").attr("tqdm")(py::arg("desc") = "train " + kind,
                                                       py::arg("unit") = " lines");
        callback = py::cpp_function([bar](const std::string& /*level*/, const std::string& text) {
          bar.attr("set_postfix_str")(head(text, 70), py::arg("refresh") = false);
          bar.attr("update")(1);
        });
      } catch (py::error_already_set& error) {
        if (!error.matches(PyExc_ImportError)) throw;
        callback = py::module_::import("builtins").attr("print").cast<py::function>();
      }
    }
  } else if (progress) {
    callback = progress->cast<py::function>();
  }
  const auto sink = std::make_shared<ProgressSink>(callback);
  int code = 0;
  bool stopped = false;
  {
    const ProgressScope scope(sink);
    const py::gil_scoped_release release;
    try {
      code = training.run();
    } catch (const Stop&) {
      stopped = true;
    }
  }
  if (!bar.is_none()) bar.attr("close")();
  sink->rethrow();
  if (stopped) throw std::logic_error("train: stopped without a Python exception");
  py::dict result;
  result["exit_code"] = code;
  const bool written = fs::exists(*model);
  result["model"] = written ? py::cast(*model) : py::none();
  fs::path metrics = *model;
  metrics.replace_extension(".metrics.json");
  if (written && fs::exists(metrics)) {
    std::ifstream in(metrics);
    result["metrics"] = py::module_::import("json").attr("loads")(
        std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()));
  } else {
    result["metrics"] = py::none();
  }
  return result;
}

}  // namespace

void add_training(py::module_& m) {
  m.def(
      "train", &train, py::arg("kind"), py::kw_only(), py::arg("config") = py::none(),
      py::arg("regime") = py::none(), py::arg("seed") = py::none(), py::arg("out") = py::none(),
      py::arg("threads") = py::none(), py::arg("progress") = py::none(),
      "Trains one model exactly as `imm-train <kind>` does (ga, mlp, wimm, fcm, tsk, baseline, "
      "schedule, or the kind's own name), with its defaults for what is not given: config, "
      "regime (replaces the config's), seed, out (the model file), threads (ga). progress(level, "
      "message) receives every log line while it trains (the GIL is released otherwise); "
      "progress=True shows a tqdm bar of them where tqdm is installed. Ctrl-C (or a callback that "
      "raises) stops it at the next log line, and no model file is written. "
      "Returns the model file (None when a quality gate kept it from being written), the exit "
      "code imm-train would give and the training metrics it wrote beside the model");
}
