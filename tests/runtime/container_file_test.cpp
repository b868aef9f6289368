// SPDX-License-Identifier: Apache-2.0
#include "imm/io/container_file.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "testing/temp_dir.hpp"

namespace imm::io {
namespace {

TEST(Crc32, MatchesTheStandardCheckValue) {
  // The CRC-32 check value of "123456789" (IEEE 802.3 / zlib) is 0xCBF43926.
  EXPECT_EQ(crc32("123456789", 9), 0xCBF43926U);
  // Incremental use gives the same value.
  EXPECT_EQ(crc32("6789", 4, crc32("12345", 5)), 0xCBF43926U);
}

TEST(ContainerFile, RoundTripsArraysAndAttributes) {
  const testing::TempDir dir;
  const auto path = dir / "round.h5";
  Eigen::MatrixXd m(2, 3);
  m << 1, 2, 3, 4, 5, 6;
  Array cube;
  cube.shape = {2, 2, 2};
  cube.values = {1, 2, 3, 4, 5, 6, 7, 8};
  const std::string long_text(200'000, 'x');  // beyond HDF5's 64 KiB compact-attribute limit
  {
    ContainerWriter writer(path, "test-format");
    writer.write("/a/matrix", m);
    writer.write("b/cube", cube);
    writer.write("/empty", Array{{0}, {}});
    writer.set_attribute("/", "integer", std::int64_t{-42});
    writer.set_attribute("/a", "real", 2.5);
    writer.set_attribute("/a/matrix", "text", std::string("héllo"));
    writer.set_attribute("/", "empty_text", std::string());
    writer.set_attribute("/", "long_text", long_text);
    writer.commit();
  }
  const ContainerReader reader(path, "test-format");
  EXPECT_EQ(reader.kind("/a"), ObjectKind::kGroup);
  EXPECT_EQ(reader.kind("/a/matrix"), ObjectKind::kDataset);
  EXPECT_EQ(reader.kind("/nothing/here"), ObjectKind::kMissing);
  EXPECT_EQ(reader.children("/"), (std::vector<std::string>{"a", "b", "empty"}));
  const Array back = reader.read("/a/matrix");
  EXPECT_EQ(back.shape, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(back.values, (std::vector<double>{1, 2, 3, 4, 5, 6}));  // row-major
  EXPECT_EQ(reader.read("/b/cube").values, cube.values);
  EXPECT_TRUE(reader.read("/empty").values.empty());
  EXPECT_EQ(std::get<std::int64_t>(*reader.attribute("/", "integer")), -42);
  EXPECT_EQ(std::get<double>(*reader.attribute("/a", "real")), 2.5);
  EXPECT_EQ(std::get<std::string>(*reader.attribute("/a/matrix", "text")), "héllo");
  EXPECT_EQ(std::get<std::string>(*reader.attribute("/", "empty_text")), "");
  EXPECT_EQ(std::get<std::string>(*reader.attribute("/", "long_text")), long_text);
  EXPECT_FALSE(reader.attribute("/", "absent").has_value());
  EXPECT_FALSE(reader.attribute("/absent", "x").has_value());
}

TEST(ContainerFile, NothingAppearsUnderTheFinalNameBeforeCommit) {
  const testing::TempDir dir;
  const auto path = dir / "atomic.h5";
  {
    ContainerWriter writer(path, "test-format");
    writer.write("/x", Eigen::MatrixXd::Ones(2, 2));
    EXPECT_FALSE(std::filesystem::exists(path));
    // Destroyed without commit, like a trainer killed or failing mid-write.
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << "temporary file left behind";
}

TEST(ContainerFile, AnExistingFileIsReplacedOnlyAtCommit) {
  const testing::TempDir dir;
  const auto path = dir / "replace.h5";
  {
    ContainerWriter first(path, "test-format");
    first.set_attribute("/", "generation", std::int64_t{1});
    first.commit();
  }
  {
    ContainerWriter second(path, "test-format");
    second.set_attribute("/", "generation", std::int64_t{2});
    EXPECT_EQ(
        std::get<std::int64_t>(*ContainerReader(path, "test-format").attribute("/", "generation")),
        1);
    second.commit();
  }
  EXPECT_EQ(
      std::get<std::int64_t>(*ContainerReader(path, "test-format").attribute("/", "generation")),
      2);
}

TEST(ContainerFile, WriterRefusesNonFiniteValuesAndBadShapes) {
  const testing::TempDir dir;
  ContainerWriter writer(dir / "bad.h5", "test-format");
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(2, 2);
  m(1, 0) = std::nan("");
  EXPECT_THROW(writer.write("/m", m), FileError);
  EXPECT_THROW(writer.write("/v", Array{{3}, {1.0, 2.0}}), FileError);
  EXPECT_THROW(writer.set_attribute("/", "x", std::numeric_limits<double>::infinity()), FileError);
}

TEST(ContainerFile, WriterNamesAMissingFolder) {
  const testing::TempDir dir;
  try {
    ContainerWriter writer(dir / "no" / "such" / "file.h5", "test-format");
    FAIL() << "expected FileError";
  } catch (const FileError& error) {
    EXPECT_NE(std::string(error.what()).find("does not exist"), std::string::npos) << error.what();
  }
}

std::filesystem::path make_valid_container(const testing::TempDir& dir) {
  auto path = dir / "valid.h5";
  ContainerWriter writer(path, "test-format");
  writer.write("/data/values", Eigen::MatrixXd::Constant(20, 10, 3.25));
  writer.set_attribute("/", "note", std::string("a container for corruption drills"));
  writer.commit();
  return path;
}

std::string open_error(const std::filesystem::path& path, std::string_view format = "test-format") {
  try {
    const ContainerReader reader(path, format);
    (void)reader.read("/data/values");
  } catch (const FileError& error) {
    EXPECT_EQ(error.file(), path.string());
    return error.what();
  }
  return "";
}

TEST(ContainerFile, TruncatedFilesAreRefused) {
  const testing::TempDir dir;
  const auto path = make_valid_container(dir);
  const auto bytes = testing::read_bytes(path);
  for (std::size_t keep : {std::size_t{0}, std::size_t{10}, std::size_t{511}, std::size_t{512},
                           std::size_t{1000}, bytes.size() / 2, bytes.size() - 1}) {
    const auto truncated = dir / ("truncated-" + std::to_string(keep) + ".h5");
    testing::write_bytes(
        truncated,
        std::vector<char>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(keep)));
    EXPECT_NE(open_error(truncated), "") << "kept " << keep << " bytes";
  }
}

TEST(ContainerFile, EveryFlippedByteIsDetected) {
  const testing::TempDir dir;
  const auto path = make_valid_container(dir);
  const auto bytes = testing::read_bytes(path);
  const auto corrupt = dir / "corrupt.h5";
  // Every byte of the header text and a stride through the payload.
  std::vector<std::size_t> positions;
  for (std::size_t i = 0; i < 200; ++i) positions.push_back(i);
  for (std::size_t i = 512; i < bytes.size(); i += 7) positions.push_back(i);
  for (std::size_t position : positions) {
    auto damaged = bytes;
    damaged[position] = static_cast<char>(damaged[position] ^ 0x5A);
    testing::write_bytes(corrupt, damaged);
    EXPECT_NE(open_error(corrupt), "") << "flip at byte " << position;
  }
}

TEST(ContainerFile, ForeignFilesAreNamedAsSuch) {
  const testing::TempDir dir;
  const auto text = dir / "notes.h5";
  testing::write_text(text, std::string(600, 'a'));
  EXPECT_NE(open_error(text).find("not an immtrain container"), std::string::npos);
  const auto plain_hdf5 = dir / "plain.h5";
  std::vector<char> signature = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
  signature.resize(2048, '\0');
  testing::write_bytes(plain_hdf5, signature);
  EXPECT_NE(open_error(plain_hdf5).find("plain HDF5 file"), std::string::npos);
  EXPECT_NE(open_error(dir / "missing.h5").find("cannot open"), std::string::npos);
  EXPECT_NE(open_error(dir.path()), "");  // a folder
}

TEST(ContainerFile, AnotherFormatIsRefused) {
  const testing::TempDir dir;
  const auto path = make_valid_container(dir);
  EXPECT_NE(open_error(path, "immtrain-model").find("expected 'immtrain-model'"),
            std::string::npos);
}

}  // namespace
}  // namespace imm::io
