// SPDX-License-Identifier: Apache-2.0
// The registry against the people and files around it: promotions decided on the manifest as it
// is under the lock, a fresh clone's first rollback, manifests and folders written by someone
// hostile (a registry can arrive by `git pull`), and what failed or killed commands leave behind.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <future>
#include <string>

#include "imm/datasets/sha256.hpp"
#include "imm/io/temporary_files.hpp"
#include "imm/pipeline/registry.hpp"
#include "imm/trainer/model_files/freeze.hpp"
#include "imm/trainer/provenance.hpp"
#include "testing/temp_dir.hpp"

namespace imm::pipeline {
namespace {

namespace fs = std::filesystem;
using testing::slurp_text;
using testing::write_text;

// Three model files of the same plain IMM under three config texts (different bytes), each with a
// metrics file beside it.
struct Models {
  fs::path a, b, c;
};
Models write_models(const testing::TempDir& dir) {
  Models m{dir / "a.h5", dir / "b.h5", dir / "c.h5"};
  const std::string text = trainer::read_text_file("configs/track/cv3_imm.toml");
  for (const auto& [path, comment] :
       {std::pair{m.a, "# a\n"}, std::pair{m.b, "# b\n"}, std::pair{m.c, "# c\n"}}) {
    const fs::path config = dir / (path.stem().string() + ".toml");
    write_text(config, comment + text);
    (void)trainer::freeze_plain_imm({config, path, {}});
    write_text(trainer::metrics_path(path), "{\"model\": \"" + path.stem().string() + "\"}\n");
  }
  return m;
}

// The registry's folder of a test: `models` in its temporary folder, created.
fs::path models_folder(const testing::TempDir& dir) {
  const fs::path models = dir / "models";
  fs::create_directories(models);
  return models;
}

RegistryEntry entry_of(const fs::path& file, const fs::path& models, const std::string& name) {
  RegistryEntry e = describe_model(file, models, name);
  e.file = name + ".h5";
  return e;
}

void promote(Registry& registry, const fs::path& file, const std::string& name,
             const PromotionTerms& terms = {}) {
  registry.promote(entry_of(file, registry.folder(), name), file, trainer::metrics_path(file),
                   terms);
}

// The message of what `f` throws ("" when it does not).
template <typename F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const std::exception& error) {
    return error.what();
  }
  return "";
}

// One manifest entry as JSON: a valid one, with `fields` (JSON members) added after its own.
std::string entry_json(const std::string& name, const std::string& file,
                       const std::string& fields = "", const std::string& kind = "\"plain_imm\"",
                       const std::string& schema = "2") {
  return R"({"name": )" + name + R"(, "kind": )" + kind +
         R"(, "regime": {"name": "", "digest": ""}, "file": )" + file + R"(, "sha256": ")" +
         std::string(64, 'a') + R"(", "schema_version": )" + schema +
         R"(, "trainer_version": "v", "config_digest": "", "trained_utc": "")" +
         (fields.empty() ? "" : ", " + fields) + "}";
}
std::string manifest_of(const std::string& entries) {
  return R"({"manifest_version": 1, "models": [)" + entries + "]}";
}
std::string manifest_with(const std::string& fields) {
  return manifest_of(entry_json("\"a\"", "\"a.h5\"", fields));
}

// A promotion decides on the manifest as it is under the lock: a candidate compared with a model
// that is no longer shipped (a rollback or a promotion by hand meanwhile) is refused, and so is a
// candidate that was rolled back meanwhile; the registry is unchanged by either refusal.
TEST(RegistryTerms, APromotionIsDecidedOnTheManifestAsItIsThen) {
  const testing::TempDir dir;
  const fs::path models = models_folder(dir);
  const Models m = write_models(dir);
  Registry setup(models);
  promote(setup, m.a, "x");
  promote(setup, m.b, "x");
  const std::string compared = Registry(models).find("x")->sha256;  // b, what a night compares

  Registry night(models);
  (void)Registry(models).rollback("x");  // a person rolls b back: a is shipped again
  const std::string manifest = slurp_text(models / "manifest.json");
  try {
    promote(night, m.c, "x", {compared, true});
    FAIL() << "promoted over a model it was not compared with";
  } catch (const PromotionRefused& refused) {
    EXPECT_EQ(refused.why(), PromotionRefused::Why::kShippedModelChanged);
  }
  EXPECT_EQ(slurp_text(models / "manifest.json"), manifest);
  EXPECT_EQ(datasets::file_sha256_hex(models / "x.h5"), datasets::file_sha256_hex(m.a));

  // Compared with a (shipped now), the rolled-back b is refused as such; c is promoted.
  const std::string now = Registry(models).find("x")->sha256;
  try {
    promote(night, m.b, "x", {now, true});
    FAIL() << "a rolled-back model was promoted again";
  } catch (const PromotionRefused& refused) {
    EXPECT_EQ(refused.why(), PromotionRefused::Why::kRolledBack);
    ASSERT_TRUE(refused.rejected().has_value());
    EXPECT_EQ(refused.rejected()->sha256, compared);
  }
  EXPECT_EQ(slurp_text(models / "manifest.json"), manifest);
  promote(night, m.c, "x", {now, true});
  const Registry after(models);
  EXPECT_EQ(after.find("x")->sha256, datasets::file_sha256_hex(m.c));
  // The rejection record survives the promotion of another model.
  ASSERT_EQ(after.find("x")->rejected.size(), 1U);
  EXPECT_EQ(after.find("x")->rejected.front().sha256, compared);

  // A first promotion compared with nothing is refused when a person shipped one meanwhile.
  Registry(models).promote(entry_of(m.a, models, "y"), m.a);
  EXPECT_THROW(promote(night, m.b, "y", {std::string(), true}), PromotionRefused);
}

// A fresh clone has the manifest and the shipped files but no archive. Its first promotion
// archives everything a rollback needs (the replaced model's metrics file included), so the
// rollback succeeds; a rollback whose archive copy is damaged is refused before the manifest
// changes, and every command still works after it.
TEST(RegistryWedge, AFreshClonesFirstRollbackFindsEveryFileItNeeds) {
  const testing::TempDir dir;
  const fs::path models = models_folder(dir);
  const Models m = write_models(dir);
  {
    Registry registry(models);
    promote(registry, m.a, "x");
  }
  fs::remove_all(models / ".registry");  // the clone: what git carries
  {
    Registry registry(models);
    promote(registry, m.b, "x");  // imm-train promote … --name x
    const RegistryEntry restored = registry.rollback("x");
    EXPECT_EQ(restored.sha256, datasets::file_sha256_hex(m.a));
  }
  EXPECT_EQ(slurp_text(models / "x.h5"), slurp_text(m.a));
  EXPECT_EQ(slurp_text(models / "x.metrics.json"), slurp_text(trainer::metrics_path(m.a)));

  // The archive copy of the model a rollback would restore, damaged.
  Registry registry(models);
  promote(registry, m.c, "x");
  const std::string manifest = slurp_text(models / "manifest.json");
  write_text(registry.archive_path(datasets::file_sha256_hex(m.a)), "damaged");
  const std::string refused = refusal([&] { (void)registry.rollback("x"); });
  EXPECT_NE(refused.find("the manifest is left as it was"), std::string::npos) << refused;
  EXPECT_EQ(slurp_text(models / "manifest.json"), manifest);
  EXPECT_TRUE(Registry(models).repair().empty());  // not wedged
  promote(registry, m.b, "x");
}

// A manifest is validated before use: an entry's file is never the registry's own files or
// another entry's (the repair would overwrite the manifest with a model), and every field is of
// its type, the refusal naming the key, on one line, without a 10 kB value in it.
TEST(RegistryHostile, AManifestEntryIsConfinedToItsOwnFiles) {
  const testing::TempDir dir;
  const fs::path models = models_folder(dir);
  const auto refused_with = [&](const std::string& text, const std::string& field) {
    write_text(models / "manifest.json", text);
    const std::string what = refusal([&] { (void)Registry(models).repair(); });
    EXPECT_NE(what.find(field), std::string::npos) << text << "\n" << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    EXPECT_LT(what.size(), 600U) << what;
    EXPECT_EQ(slurp_text(models / "manifest.json"), text);  // nothing overwritten
  };
  for (const std::string file : {"manifest.json", ".registry/lock", ".registry/archive/x.h5",
                                 "a.metrics.json", "sub/../../x.h5", "/etc/x.h5", "a\\nb.h5", ""}) {
    refused_with(manifest_of(entry_json("\"a\"", "\"" + file + "\"")), "models[0].file");
  }
  // Two entries, one file; an entry whose file is another's metrics file cannot be (".h5" only).
  refused_with(
      manifest_of(entry_json("\"a\"", "\"a.h5\"") + ", " + entry_json("\"b\"", "\"a.h5\"")),
      "models[1].file");
  // Types, named by their key.
  refused_with(manifest_of(entry_json("5", "\"a.h5\"")),
               "models[0].name: expected a string, found a number");
  refused_with(manifest_of(entry_json("\"a\"", "\"a.h5\"", "", "[]")),
               "models[0].kind: expected a string, found an array");
  refused_with(manifest_of(entry_json("\"a\"", "\"a.h5\"", "", "\"plain_imm\"", "2.5")),
               "models[0].schema_version");
  refused_with(manifest_with("\"metrics\": [1]"), "models[0].metrics: expected an object");
  refused_with(manifest_with("\"history\": {}"), "models[0].history: expected an array");
  refused_with(manifest_of(entry_json("\"" + std::string(10000, 'n') + "\"", "\"a.h5\"")),
               "models[0].name");
  refused_with(manifest_of(entry_json("\"a\\nb\"", "\"a.h5\"")), "models[0].name");
  refused_with(manifest_of(entry_json("\"a\"", "\"a.h5\"", "", "\"a\\u001b[31m\"")),
               "models[0].kind");
}

// A shipped folder or the lock replaced by a symbolic link: the registry refuses to read or write
// through it, and nothing outside the models folder changes.
TEST(RegistryHostile, NothingIsWrittenThroughASymbolicLink) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  const auto elsewhere = dir / "elsewhere";
  fs::create_directories(models / "tracker_regime");
  fs::create_directories(elsewhere);
  const Models m = write_models(dir);
  {
    Registry registry(models);
    RegistryEntry e = describe_model(m.a, models, "tracker_regime");
    e.file = "tracker_regime/tracker.h5";
    registry.promote(e, m.a);
  }
  fs::remove_all(models / "tracker_regime");
  fs::create_directory_symlink(elsewhere, models / "tracker_regime");
  const std::string refused = refusal([&] { (void)Registry(models).repair(); });
  EXPECT_NE(refused.find("symbolic link"), std::string::npos) << refused;
  EXPECT_TRUE(fs::is_empty(elsewhere));

  fs::remove(models / "tracker_regime");
  fs::remove(models / ".registry" / "lock");
  write_text(elsewhere / "target", "untouched");
  fs::create_symlink(elsewhere / "target", models / ".registry" / "lock");
  EXPECT_NE(refusal([&] { (void)Registry(models).repair(); }), "");
  EXPECT_EQ(slurp_text(elsewhere / "target"), "untouched");
  fs::remove(models / ".registry" / "lock");
  // The manifest itself, a link: refused, not followed.
  fs::rename(models / "manifest.json", elsewhere / "manifest.json");
  fs::create_symlink(elsewhere / "manifest.json", models / "manifest.json");
  EXPECT_NE(refusal([&] { (void)Registry(models); }).find("symbolic link"), std::string::npos);
}

// A manifest's text in a message or a table: printable UTF-8 as it is (a tracker's reason says ζ_p
// and —, once printed as \xce\xb6 and \xe2\x80\x94), and escaped what could mislead a terminal or
// is not UTF-8: escapes, a right-to-left override, a C1 control, an overlong '/', a surrogate, a
// sequence cut short; a cut at the limit never splits a character.
TEST(RegistryHostile, MessagesShowPrintableUtf8AndEscapeWhatCouldMisleadATerminal) {
  EXPECT_EQ(quoted_for_message("ζ_p +0.0138 — 3 °/s"), "'ζ_p +0.0138 — 3 °/s'");
  EXPECT_EQ(quoted_for_message("\x1b[31mred"), "'\\x1b[31mred'");
  EXPECT_EQ(quoted_for_message(std::string("a\xe2\x80\xae") + "b"),
            "'a\\xe2\\x80\\xaeb'");                                         // U+202E
  EXPECT_EQ(quoted_for_message("\xc2\x85"), "'\\xc2\\x85'");                // U+0085
  EXPECT_EQ(quoted_for_message("\xc0\xaf"), "'\\xc0\\xaf'");                // overlong '/'
  EXPECT_EQ(quoted_for_message("\xed\xa0\x80"), "'\\xed\\xa0\\x80'");       // U+D800
  EXPECT_EQ(quoted_for_message("x\xce"), "'x\\xce'");                       // cut short
  EXPECT_EQ(quoted_for_message("\xf0\x9f\x9b\xb0"), "'\xf0\x9f\x9b\xb0'");  // U+1F6F0
  EXPECT_EQ(quoted_for_message("aζb", 2), "'a' (4 bytes in all)");
  EXPECT_EQ(quoted_for_message("aζb", 3), "'aζ' (4 bytes in all)");
  EXPECT_EQ(quoted_for_message("a\\b\n"), "'a\\x5cb\\n'");
}

// Bounded size and depth: a manifest nested 300 000 deep, a history chain 30 000 deep, one of
// more than 16 MiB, and a FIFO in its place are each refused at once (no stack overflow, no hang).
TEST(RegistryHostile, AManifestIsBoundedInSizeAndDepthAndIsARegularFile) {
  const testing::TempDir dir;
  const fs::path models = models_folder(dir);
  const auto refused_with = [&](const std::string& text, const std::string& what) {
    write_text(models / "manifest.json", text);
    const auto start = std::chrono::steady_clock::now();
    const std::string message = refusal([&] { (void)Registry(models); });
    EXPECT_NE(message.find(what), std::string::npos) << message.substr(0, 300);
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
  };
  const std::size_t deep = 300000;
  refused_with(manifest_with("\"metrics\": {\"m\": " + std::string(deep, '[') +
                             std::string(deep, ']') + "}"),
               "nested");
  // {"history": [ … {} … ]} nested 30 000 deep, written from both ends (building it inside out
  // copies the growing string at every level: gigabytes of copies, 59 s under the sanitizers).
  std::string chain;
  for (int i = 0; i < 30000; ++i) chain += "{\"history\": [";
  chain += "{}";
  for (int i = 0; i < 30000; ++i) chain += "]}";
  refused_with(manifest_with("\"history\": [" + chain + "]"), "nested");
  refused_with(manifest_with("\"promotion_reason\": \"" + std::string(17U << 20U, 'x') + "\""),
               "bytes");
  // Brackets that are not JSON (a model file copied over the manifest) are not called nesting.
  refused_with(std::string(100, '[') + "\x01\x02" + std::string(100, ']'), "not JSON");
  refused_with(slurp_text("models/cv3_imm.h5"), "not JSON");
  fs::remove(models / "manifest.json");
  ASSERT_EQ(::mkfifo((models / "manifest.json").c_str(), 0644), 0);
  auto opened =
      std::async(std::launch::async, [&] { return refusal([&] { (void)Registry(models); }); });
  ASSERT_EQ(opened.wait_for(std::chrono::seconds(20)), std::future_status::ready)
      << "hangs on a FIFO";
  EXPECT_NE(opened.get().find("not a regular file"), std::string::npos);
  fs::remove(models / "manifest.json");
}

// What failed or killed commands leave: a promotion that fails removes its temporaries, and a dead
// writer's temporaries (a kill -9) are removed by the next change of the registry.
TEST(RegistryLeftovers, TemporariesOfFailedAndKilledCommandsAreRemoved) {
  const testing::TempDir dir;
  const fs::path models = models_folder(dir);
  const Models m = write_models(dir);
  Registry registry(models);
  promote(registry, m.a, "x");
  // A dead process's temporaries: fork a child that exits at once, and name files after it.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  const std::string stale = ".x.h5.tmp-" + std::to_string(child) + "@" + io::this_host();
  write_text(models / stale, "partial");
  write_text(models / ".registry" / "archive" /
                 (".y.h5.tmp-" + std::to_string(child) + "@" + io::this_host()),
             "partial");
  // A promotion that fails (its manifest's temporary blocked by a folder) leaves none of its own.
  const auto blocker = io::temporary_beside(models / "manifest.json");
  fs::create_directories(blocker);
  EXPECT_ANY_THROW(promote(registry, m.b, "x"));
  fs::remove(blocker);
  std::size_t temporaries = 0;
  for (const auto& f : fs::recursive_directory_iterator(models)) {
    if (io::temporary_writer(f.path().filename().string())) ++temporaries;
  }
  EXPECT_EQ(temporaries, 0U) << "left by the failed promotion or by the dead writer";
}

}  // namespace
}  // namespace imm::pipeline
