// SPDX-License-Identifier: Apache-2.0
#include "imm/pipeline/registry.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "imm/datasets/sha256.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/temporary_files.hpp"
#include "imm/pipeline/promote.hpp"
#include "imm/trainer/model_files/freeze.hpp"
#include "imm/trainer/provenance.hpp"
#include "testing/temp_dir.hpp"

namespace imm::pipeline {
namespace {
using trainer::freeze_plain_imm;
using trainer::read_text_file;

std::string bytes_of(const std::filesystem::path& path) { return testing::slurp_text(path); }

// Two model files of the same plain IMM under two config texts: dir/first.h5, dir/second.h5
// (different bytes, the same filter).
struct TwoModels {
  std::filesystem::path first, second;
};
TwoModels write_two_models(const testing::TempDir& dir) {
  TwoModels m{dir / "first.h5", dir / "second.h5"};
  (void)freeze_plain_imm({"configs/track/cv3_imm.toml", m.first, {}});
  testing::write_text(dir / "cv3.toml", "# another text, the same filter\n" +
                                            read_text_file("configs/track/cv3_imm.toml"));
  (void)freeze_plain_imm({dir / "cv3.toml", m.second, {}});
  return m;
}

// The registry entry of `file` shipped as `name`, at <name>.h5.
RegistryEntry entry_of(const std::filesystem::path& file, const testing::TempDir& dir,
                       const std::string& name) {
  RegistryEntry e = describe_model(file, dir.path(), name);
  e.file = name + ".h5";
  return e;
}

// A process killed between the manifest's rename (the commit point) and the shipped file's
// rename leaves the new manifest beside the old file; the next registry operation (every nightly
// starts with repair()) makes the file the manifest's, byte for byte, from the archive.
TEST(Registry, RepairMakesTheShippedFilesTheManifests) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  const auto [first, second] = write_two_models(dir);
  ASSERT_NE(bytes_of(first), bytes_of(second));
  std::filesystem::create_directories(models);
  {
    Registry registry(models);
    registry.promote(entry_of(first, dir, "cv3"), first);
    registry.promote(entry_of(second, dir, "cv3"), second);
    EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(second));
    ASSERT_EQ(registry.find("cv3")->history.size(), 1u);
  }
  // The crash: the manifest names the second model, the old bytes are still shipped.
  std::filesystem::copy_file(first, models / "cv3.h5",
                             std::filesystem::copy_options::overwrite_existing);
  Registry registry(models);
  EXPECT_EQ(registry.repair(), std::vector<std::string>{"cv3.h5"});
  EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(second));
  EXPECT_TRUE(registry.repair().empty());
  // Rollback restores the first byte for byte, and the manifest says so after a reload.
  (void)registry.rollback("cv3");
  EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(first));
  EXPECT_EQ(Registry(models).find("cv3")->sha256, datasets::file_sha256_hex(first));
}

// A promotion whose manifest cannot be written (here: a folder where its temporary goes, as a full
// disk would) fails and leaves the registry's entries and files as they were; the next promotion
// does not commit the failed one.
TEST(Registry, AFailedPromotionIsNotCommittedByTheNextOne) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  std::filesystem::create_directories(models);
  const auto [first, second] = write_two_models(dir);
  Registry registry(models);
  registry.promote(entry_of(first, dir, "a"), first);
  const std::string manifest = bytes_of(models / "manifest.json");

  const auto blocker = io::temporary_beside(models / "manifest.json");
  std::filesystem::create_directories(blocker);
  EXPECT_ANY_THROW(registry.promote(entry_of(second, dir, "b"), second));
  EXPECT_EQ(registry.find("b"), nullptr);
  EXPECT_EQ(registry.entries().size(), 1u);
  EXPECT_EQ(bytes_of(models / "manifest.json"), manifest);
  EXPECT_FALSE(std::filesystem::exists(models / "b.h5"));

  std::filesystem::remove(blocker);
  registry.promote(entry_of(second, dir, "c"), second);
  const Registry reloaded(models);
  EXPECT_EQ(reloaded.find("b"), nullptr);
  ASSERT_NE(reloaded.find("c"), nullptr);
  EXPECT_NE(reloaded.find("a"), nullptr);
}

// What is shipped is checked first: an archive copy that no longer matches its digest (a write cut
// short by a power loss) is never "restored" into models/ by a repair.
TEST(Registry, ADamagedArchiveCopyIsNeverShipped) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  std::filesystem::create_directories(models);
  const auto model = dir / "cv3_source.h5";
  (void)freeze_plain_imm({"configs/track/cv3_imm.toml", model, {}});
  Registry registry(models);
  registry.promote(entry_of(model, dir, "cv3"), model);
  const std::string sha256 = registry.find("cv3")->sha256;
  const auto archived = models / ".registry" / "archive" / (sha256 + ".h5");
  ASSERT_TRUE(std::filesystem::exists(archived));
  testing::write_text(archived, "");              // the archive copy, emptied
  testing::write_text(models / "cv3.h5", "old");  // and the shipped file is not the manifest's
  try {
    (void)Registry(models).repair();
    ADD_FAILURE() << "repaired from a damaged archive copy";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("does not match its sha256"), std::string::npos)
        << error.what();
  }
  EXPECT_EQ(bytes_of(models / "cv3.h5"), "old");
}

// Every change of the manifest re-reads it under the registry's lock: a command that opened the
// registry before another one changed it (a nightly before a rollback or a promotion by hand)
// keeps that change when it writes; and while another process holds the lock, a promotion waits.
TEST(Registry, EveryChangeReadsTheManifestUnderTheLock) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  std::filesystem::create_directories(models);
  // (Plain variables: the waiting thread's lambda captures them.)
  const TwoModels two = write_two_models(dir);
  const std::filesystem::path first = two.first, second = two.second;
  {
    Registry setup(models);
    setup.promote(entry_of(first, dir, "a"), first);
    setup.promote(entry_of(second, dir, "a"), second);  // "a" has a history now
  }
  Registry night(models);  // opened before the others' changes
  Registry(models).promote(entry_of(first, dir, "by_hand"), first);
  (void)Registry(models).rollback("a");
  night.promote(entry_of(second, dir, "tonight"), second);
  const Registry after(models);
  ASSERT_NE(after.find("by_hand"), nullptr);
  ASSERT_NE(after.find("tonight"), nullptr);
  EXPECT_EQ(after.find("a")->sha256, datasets::file_sha256_hex(first));  // the rollback stands
  EXPECT_EQ(bytes_of(models / "a.h5"), bytes_of(first));

  // Another process's lock (here: this process's own open file description) makes it wait.
  const int held = ::open((models / ".registry" / "lock").c_str(), O_RDWR | O_CLOEXEC);
  ASSERT_GE(held, 0);
  ASSERT_EQ(::flock(held, LOCK_EX), 0);
  std::atomic<bool> done{false};
  std::thread waiting([&] {
    Registry(models).promote(entry_of(first, dir, "waited"), first);
    done = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_FALSE(done.load()) << "promoted while another process held the registry's lock";
  EXPECT_EQ(Registry(models).find("waited"), nullptr);
  ::flock(held, LOCK_UN);
  ::close(held);
  waiting.join();
  EXPECT_TRUE(done.load());
  EXPECT_NE(Registry(models).find("waited"), nullptr);
}

// The plain IMM of configs/track/cv3_imm.toml written with the given trainer version.
void write_cv3_stamped(const std::filesystem::path& out, const std::string& trainer_version,
                       const testing::TempDir& dir) {
  const auto frozen = dir / "frozen.h5";
  (void)freeze_plain_imm({"configs/track/cv3_imm.toml", frozen, {}});
  const io::ModelFileReader reader(frozen);
  io::Provenance provenance = reader.provenance();
  provenance.trainer_version = trainer_version;
  io::ModelFileWriter writer(out, provenance);
  io::write_plain_imm(writer, io::read_plain_imm(reader));
  writer.commit();
}

// imm-train promote: a deliberate promotion past the gates ships the file with its reason in the
// manifest; a file from uncommitted code, an empty reason or a file that does not read are refused
// and leave the registry as it was.
TEST(Registry, PromotionByHandRecordsItsReasonAndRefusesUncommittedCode) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  std::filesystem::create_directories(models);
  const auto clean = dir / "clean.h5", dirty = dir / "dirty.h5";
  write_cv3_stamped(clean, "f92683f", dir);
  write_cv3_stamped(dirty, "f92683f-dirty", dir);

  const auto refused = [&](const PromoteOptions& options, const std::string& expected) {
    try {
      (void)promote_by_hand(options);
      ADD_FAILURE() << "promoted " << options.file;
    } catch (const std::exception& error) {
      EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
    }
    EXPECT_FALSE(std::filesystem::exists(models / "cv3.h5"));
  };
  refused({dirty, "cv3", "schema 2", models}, "uncommitted code");
  refused({clean, "cv3", "  ", models}, "--reason");
  testing::write_text(dir / "broken.h5", "not a model");
  refused({dir / "broken.h5", "cv3", "schema 2", models}, "broken.h5");

  const RegistryEntry entry = promote_by_hand({clean, "cv3", "schema 2 rewrite", models});
  EXPECT_EQ(entry.file, "cv3.h5");
  EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(clean));
  const Registry reloaded(models);
  ASSERT_NE(reloaded.find("cv3"), nullptr);
  EXPECT_EQ(reloaded.find("cv3")->promotion_reason, "schema 2 rewrite");
  EXPECT_EQ(reloaded.find("cv3")->trainer_version, "f92683f");
}

TEST(Registry, AHostileManifestIsRefusedNamingTheField) {
  const testing::TempDir dir;
  testing::write_text(dir / "manifest.json",
                      R"({"manifest_version": 1, "models": [{"name": "a", "kind": "plain_imm",
                      "regime": {"name": "", "digest": ""}, "file": "../../etc/passwd",
                      "sha256": "x", "schema_version": 1, "trainer_version": "v",
                      "config_digest": "", "trained_utc": ""}]})");
  try {
    Registry registry(dir.path());
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("models[0].file"), std::string::npos) << error.what();
  }
}

// Names and digests lead to files: a name must stay one path component and a digest hex, in the
// manifest (its history too), in `promote --name` and in a nightly plan; each is refused naming
// the field, and nothing is written outside the registry.
TEST(Registry, NamesAndDigestsThatCouldLeaveTheRegistryAreRefused) {
  const testing::TempDir dir;
  const auto manifest = [&](const std::string& name, const std::string& sha256) {
    return R"({"manifest_version": 1, "models": [{"name": ")" + name +
           R"(", "kind": "plain_imm", "regime": {"name": "", "digest": ""}, "file": "a.h5",
           "sha256": ")" +
           sha256 +
           R"(", "schema_version": 2, "trainer_version": "v", "config_digest": "",
           "trained_utc": ""}]})";
  };
  const std::string good(64, 'a');
  const auto refused = [&](const std::string& text, const std::string& field) {
    testing::write_text(dir / "manifest.json", text);
    try {
      Registry registry(dir.path());
      ADD_FAILURE() << text;
    } catch (const std::runtime_error& error) {
      EXPECT_NE(std::string(error.what()).find(field), std::string::npos) << error.what();
    }
  };
  for (const std::string name : {"../x", "/elsewhere/x", "a/b", ".hidden", "", "a name"}) {
    refused(manifest(name, good), "models[0].name");
  }
  refused(manifest("a", std::string(60, 'a') + "/../"), "models[0].sha256");
  refused(manifest("a", std::string(64, 'g')), "models[0].sha256");
  refused(manifest("a", std::string(64, 'A')), "models[0].sha256");
  testing::write_text(dir / "manifest.json", manifest("a", good));
  EXPECT_NO_THROW(Registry registry(dir.path()));

  const auto models = dir / "models";
  std::filesystem::create_directories(models);
  const auto clean = dir / "clean.h5";
  write_cv3_stamped(clean, "f92683f", dir);
  for (const std::string name : {"../escaped", "/tmp/escaped", "sub/escaped"}) {
    try {
      (void)promote_by_hand({clean, name, "by hand", models});
      ADD_FAILURE() << name;
    } catch (const std::exception& error) {
      EXPECT_NE(std::string(error.what()).find("--name"), std::string::npos) << error.what();
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "escaped.h5"));
  EXPECT_FALSE(std::filesystem::exists(models / "sub"));
  EXPECT_FALSE(std::filesystem::exists(models / "manifest.json"));
}

// A rollback records the model it rejects; the same model again (the file, or a retraining that
// differs only in its date) is found as that rejection until a promotion of it ends the record.
TEST(Registry, ARollbackRecordsTheRejectedModel) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  const auto [first, second] = write_two_models(dir);
  std::filesystem::create_directories(models);
  Registry registry(models);
  registry.promote(entry_of(first, dir, "cv3"), first);
  registry.promote(entry_of(second, dir, "cv3"), second);
  EXPECT_FALSE(registry.rejection("cv3", second, "").has_value());
  (void)registry.rollback("cv3");
  const Registry reloaded(models);
  const RegistryEntry& shipped = *reloaded.find("cv3");
  ASSERT_EQ(shipped.rejected.size(), 1u);
  EXPECT_EQ(shipped.rejected[0].sha256, datasets::file_sha256_hex(second));
  EXPECT_FALSE(shipped.rejected[0].rolled_back_utc.empty());
  EXPECT_TRUE(registry.rejection("cv3", second, "").has_value());
  // A retraining of the rejected model: other bytes (its date, to the second), the same model.
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  (void)freeze_plain_imm({dir / "cv3.toml", dir / "again.h5", {}});
  ASSERT_NE(datasets::file_sha256_hex(dir / "again.h5"), datasets::file_sha256_hex(second));
  EXPECT_TRUE(registry.rejection("cv3", dir / "again.h5", "").has_value());
  EXPECT_FALSE(registry.rejection("cv3", first, "").has_value());
  registry.promote(entry_of(dir / "again.h5", dir, "cv3"), dir / "again.h5");
  EXPECT_TRUE(registry.find("cv3")->rejected.empty());
}

// kill -9 at seeded random moments of promotions and rollbacks (each in a child process, as a
// person's `imm-train promote` / `rollback` would run): the manifest always parses, and after the
// next command's repair every shipped file and metrics file is the manifest's, byte for byte.
TEST(Registry, KillNineDuringPromoteAndRollbackLeavesTheOldOrTheNewState) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  const auto [first, second] = write_two_models(dir);
  testing::write_text(dir / "second.metrics.json", "{\"model\": \"second\"}\n");
  std::filesystem::create_directories(models);
  Registry(models).promote(entry_of(first, dir, "cv3"), first);
  std::uint64_t state = 2026;
  int killed = 0;
  for (int round = 0; round < 30; ++round) {
    const bool promote = round % 2 == 0;
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        Registry registry(models);
        (void)registry.repair();
        if (promote) {
          registry.promote(entry_of(round % 4 == 0 ? second : first, dir, "cv3"),
                           round % 4 == 0 ? second : first, dir / "second.metrics.json");
        } else if (!registry.find("cv3")->history.empty()) {
          (void)registry.rollback("cv3");
        }
      } catch (...) {
        ::_exit(1);
      }
      ::_exit(0);
    }
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    ::usleep(static_cast<useconds_t>((state >> 33) % 20000));  // 0 … 20 ms
    ::kill(child, SIGKILL);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    killed += WIFSIGNALED(status) ? 1 : 0;
    ASSERT_TRUE(WIFSIGNALED(status) || WEXITSTATUS(status) == 0) << "round " << round;
    Registry registry(models);  // the manifest parses
    (void)registry.repair();
    for (const RegistryEntry& e : registry.entries()) {
      EXPECT_EQ(datasets::file_sha256_hex(models / e.file), e.sha256) << "round " << round;
      const auto metrics = trainer::metrics_path(models / e.file);
      if (e.metrics_sha256 == "none") {
        EXPECT_FALSE(std::filesystem::exists(metrics));
      }
      if (e.metrics_sha256.size() == 64) {
        EXPECT_EQ(datasets::file_sha256_hex(metrics), e.metrics_sha256) << "round " << round;
      }
    }
  }
  EXPECT_GT(killed, 0);
}

// A shipped file the manifest does not know (it could not be adopted) is archived before a
// promotion replaces it: nothing shipped is ever lost.
TEST(Registry, AnUnrecordedShippedFileIsArchivedBeforeItIsReplaced) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  const auto [first, second] = write_two_models(dir);
  std::filesystem::create_directories(models);
  std::filesystem::copy_file(first, models / "cv3.h5");
  Registry registry(models);
  registry.promote(entry_of(second, dir, "cv3"), second);
  EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(second));
  EXPECT_EQ(bytes_of(registry.archive_path(datasets::file_sha256_hex(first))), bytes_of(first));
}

// The manifest says whether each model's learned part is on, switched off by its fit (the file is
// its tuned baseline), or absent from its kind — and a manifest written before it was recorded
// gets it from the shipped files at the next repair.
TEST(Registry, TheManifestSaysWhetherTheLearnedPartIsOn) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  std::filesystem::create_directories(models);
  const std::vector<std::pair<std::string, std::string>> shipped = {
      {"ga_fuzzy_imm_agile_air", "on"},
      {"ga_fuzzy_imm_ground_vehicle", "off"},
      {"cv3_imm", "none"}};
  {
    Registry registry(models);
    for (const auto& [name, part] : shipped) {
      const auto file = std::filesystem::path("models") / (name + ".h5");
      registry.promote(entry_of(file, dir, name), file);
      EXPECT_EQ(registry.find(name)->learned_part, part) << name;
    }
  }
  auto manifest = nlohmann::json::parse(read_text_file(models / "manifest.json"));
  for (auto& e : manifest["models"]) e.erase("learned_part");
  testing::write_text(models / "manifest.json", manifest.dump(2));
  EXPECT_EQ(Registry(models).find("cv3_imm")->learned_part, "");
  Registry registry(models);
  (void)registry.repair();
  for (const auto& [name, part] : shipped) {
    EXPECT_EQ(Registry(models).find(name)->learned_part, part) << name;
  }
}

// A model's metrics file ships with it or not at all: a model promoted without one does not keep
// the metrics of the model it replaced, a rollback brings the old ones back, and repair restores
// a lost or changed one from the archive.
TEST(Registry, AMetricsFileShipsWithItsModelOnly) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  const auto [first, second] = write_two_models(dir);
  std::filesystem::create_directories(models);
  testing::write_text(dir / "first.metrics.json", "{\"model\": \"first\"}\n");
  const auto beside = models / "cv3.metrics.json";
  Registry registry(models);
  registry.promote(entry_of(first, dir, "cv3"), first, dir / "first.metrics.json");
  EXPECT_EQ(bytes_of(beside), "{\"model\": \"first\"}\n");
  registry.promote(entry_of(second, dir, "cv3"), second);
  EXPECT_FALSE(std::filesystem::exists(beside));
  EXPECT_EQ(registry.find("cv3")->metrics_sha256, "none");
  (void)registry.rollback("cv3");
  EXPECT_EQ(bytes_of(beside), "{\"model\": \"first\"}\n");
  testing::write_text(beside, "{\"model\": \"edited\"}\n");
  EXPECT_EQ(registry.repair(), std::vector<std::string>{"cv3.h5"});
  EXPECT_EQ(bytes_of(beside), "{\"model\": \"first\"}\n");
}

// Two trainings of one definition that differ only by rounding, their build and their clock are
// the same model (the nightly keeps the shipped file for such a candidate); anything else is a
// difference, named.
TEST(Registry, ModelDifferenceIgnoresRoundingBuildAndClockOnly) {
  const testing::TempDir dir;
  struct Variant {
    double scale = 1.0;  // of the parameters
    std::string created = "2026-11-01T00:00:00Z", version = "1.0.0", config = "seed = 1";
    double seconds = 12.5, objective = 0.25;
    bool extra = false;  // an attribute the base file lacks
  };
  auto write = [&](const std::string& name, const Variant& v) {
    const auto path = dir / name;
    io::ContainerWriter w(path, io::kModelFormat);
    Eigen::MatrixXd weights(2, 2);
    weights << 1.0, -2.0, 1e-9, 4.0;  // a tiny entry compares at its dataset's scale
    w.write("/layer/weights", Eigen::MatrixXd(weights * v.scale));
    w.set_attribute("/", "created_utc", v.created);
    w.set_attribute("/", "trainer_version", v.version);
    w.set_attribute("/", "config_toml", v.config);
    w.set_attribute("/layer", "wall_seconds", v.seconds);
    w.set_attribute("/layer", "objective", v.objective);
    if (v.extra) w.set_attribute("/layer", "extra", std::int64_t{1});
    w.commit();
    return path;
  };
  const auto base = write("base.h5", {});
  Variant clock;
  clock.created = "2026-11-25T03:00:00Z", clock.version = "1.0.1-dirty", clock.seconds = 99.0;
  EXPECT_EQ(model_difference(base, write("clock.h5", clock)).what, "");
  Variant rounded;
  rounded.scale = 1.0 + 1e-9, rounded.objective = 0.25 * (1.0 + 1e-9);
  EXPECT_EQ(model_difference(base, write("rounded.h5", rounded)).what, "");

  Variant moved;
  moved.scale = 1.0 + 1e-4;
  EXPECT_NE(model_difference(base, write("moved.h5", moved)).what.find("/layer/weights[0]"),
            std::string::npos);
  Variant config;
  config.config = "seed = 2";
  EXPECT_NE(model_difference(base, write("config.h5", config)).what.find("/@config_toml"),
            std::string::npos);
  Variant objective;
  objective.objective = 0.26;
  EXPECT_NE(model_difference(base, write("objective.h5", objective)).what.find("/layer@objective"),
            std::string::npos);
  EXPECT_EQ(model_difference(base, write("objective2.h5", objective)).kind,
            ModelDifference::Kind::kValues);
  Variant extra;
  extra.extra = true;
  const ModelDifference structure = model_difference(base, write("extra.h5", extra));
  EXPECT_EQ(structure.kind, ModelDifference::Kind::kStructure);
  EXPECT_NE(structure.what.find("/layer has other attributes"), std::string::npos);
}

}  // namespace
}  // namespace imm::pipeline
