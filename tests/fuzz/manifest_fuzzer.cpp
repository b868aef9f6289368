// SPDX-License-Identifier: Apache-2.0
// Fuzz target: a hostile registry — the manifest's text is the input, in a models folder that
// holds a shipped model with its archive copy, a folder that is a symbolic link out of the models
// folder, and a lock and archive as a clone leaves them. Every command's path runs on it: open,
// repair, and a rollback of every entry. The tokens SHA_A and SHA_M in the input stand for the
// SHA-256 of the fixture's model and metrics file, so that mutations reach the repair and
// rollback paths instead of stopping at "the archive has no copy".
//
// Findings: a crash, a hang, a sanitizer report; an exception other than std::runtime_error (or
// std::filesystem::filesystem_error) or an unusable message; anything written outside the models
// folder (through the link, or over the fixture beside it); the manifest overwritten by something
// that is not a manifest.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_support.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/pipeline/registry.hpp"

namespace {

namespace fs = std::filesystem;

struct Sandbox {
  fs::path root, models, outside, model, metrics;
  std::string model_sha, metrics_sha;
};

void write_file(const fs::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) imm::fuzz::finding("cannot write " + path.string());
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

const Sandbox& sandbox() {
  static const imm::fuzz::ScratchFile anchor("anchor");
  static const Sandbox box = [] {
    Sandbox s;
    s.root = anchor.path().parent_path() / "registry";
    s.models = s.root / "models";
    s.outside = s.root / "outside";
    fs::create_directories(s.models);
    fs::create_directories(s.outside);
    s.model = s.root / "fixture.h5";
    write_file(s.model, read_file(fs::path(IMM_SOURCE_DIR) / "models" / "cv3_imm.h5"));
    s.metrics = s.root / "fixture.metrics.json";
    write_file(s.metrics, "{\"fixture\": true}\n");
    s.model_sha = imm::datasets::file_sha256_hex(s.model);
    s.metrics_sha = imm::datasets::file_sha256_hex(s.metrics);
    return s;
  }();
  return box;
}

// The models folder as the input finds it: the fixture shipped as a.h5 and archived, a link
// `models/out -> outside`, and nothing else (whatever the last input made is removed).
void reset(const Sandbox& s) {
  std::error_code error;
  fs::remove_all(s.models, error);
  fs::remove_all(s.outside, error);
  fs::create_directories(s.models / ".registry" / "archive");
  fs::create_directories(s.outside);
  // (Copied through read/write: libFuzzer's timer signal interrupts copy_file's sendfile.)
  const std::string model = read_file(s.model), metrics = read_file(s.metrics);
  write_file(s.models / "a.h5", model);
  write_file(s.models / "a.metrics.json", metrics);
  write_file(s.models / ".registry" / "archive" / (s.model_sha + ".h5"), model);
  write_file(s.models / ".registry" / "archive" / (s.metrics_sha + ".metrics.json"), metrics);
  fs::create_directory_symlink(s.outside, s.models / "out");
}

std::string substituted(std::string text, const Sandbox& s) {
  for (const auto& [token, value] : {std::pair{std::string_view("SHA_A"), &s.model_sha},
                                     std::pair{std::string_view("SHA_M"), &s.metrics_sha}}) {
    for (auto at = text.find(token); at != std::string::npos; at = text.find(token, at)) {
      text.replace(at, token.size(), *value);
      at += value->size();
    }
  }
  return text;
}

template <class Step>
void expecting_refusals(std::string_view step, Step&& run) {
  try {
    run();
  } catch (const std::filesystem::filesystem_error& error) {
    imm::fuzz::expect_usable_message(error.what(), step);
  } catch (const std::runtime_error& error) {
    imm::fuzz::expect_usable_message(error.what(), step);
  } catch (const std::exception& error) {
    imm::fuzz::finding(std::string(step) + ": not a runtime_error: " + error.what());
  }
}

}  // namespace

// NOLINTNEXTLINE(readability-identifier-naming): the entry point libFuzzer calls
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using imm::pipeline::Registry;
  const Sandbox& s = sandbox();
  reset(s);
  const std::string text = substituted(std::string(reinterpret_cast<const char*>(data), size), s);
  write_file(s.models / "manifest.json", text);
  std::vector<std::string> names;
  expecting_refusals("open", [&] {
    Registry registry(s.models);
    for (const auto& e : registry.entries()) names.push_back(e.name);
  });
  expecting_refusals("repair", [&] { (void)Registry(s.models).repair(); });
  for (const std::string& name : names) {
    expecting_refusals("rollback", [&] { (void)Registry(s.models).rollback(name); });
  }
  // Nothing outside the models folder changed: the link's target is empty, the fixture intact.
  if (!fs::is_empty(s.outside)) imm::fuzz::finding("a file was written through models/out");
  if (imm::datasets::file_sha256_hex(s.model) != s.model_sha) {
    imm::fuzz::finding("the fixture beside the models folder changed");
  }
  // The manifest is the input or a manifest the registry wrote (which it reads back).
  const std::string after = read_file(s.models / "manifest.json");
  if (after != text) {
    try {
      (void)imm::pipeline::parse_manifest(after, "manifest.json");
    } catch (const std::exception& error) {
      imm::fuzz::finding(std::string("the registry wrote a manifest it refuses: ") + error.what());
    }
  }
  return 0;
}
