// SPDX-License-Identifier: Apache-2.0
#include "imm/io/container_file.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "imm/io/temporary_files.hpp"
#include "testing/temp_dir.hpp"

namespace imm::io {
namespace {

TEST(Crc32, MatchesTheStandardCheckValue) {
  // The CRC-32 check value of "123456789" (IEEE 802.3 / zlib) is 0xCBF43926.
  EXPECT_EQ(crc32("123456789", 9), 0xCBF43926U);
  // Incremental use gives the same value.
  EXPECT_EQ(crc32("6789", 4, crc32("12345", 5)), 0xCBF43926U);
  // Longer than one 8-byte step, with a tail: zlib's crc32 of these 43 bytes.
  const std::string fox = "The quick brown fox jumps over the lazy dog";
  EXPECT_EQ(crc32(fox.data(), fox.size()), 0x414FA339U);
}

// Eight bytes a step and one byte a step give the same CRC, whatever the length, the alignment
// and the split into calls.
TEST(Crc32, EveryLengthOffsetAndSplitGivesTheBytewiseCrc) {
  std::vector<unsigned char> bytes(300);
  std::uint32_t state = 12345;
  for (auto& b : bytes) {
    state = state * 1103515245U + 12345U;
    b = static_cast<unsigned char>(state >> 16U);
  }
  auto bytewise = [](const unsigned char* p, std::size_t n) {
    std::uint32_t crc = 0xFFFFFFFFU;
    for (std::size_t i = 0; i < n; ++i) {
      crc ^= p[i];
      for (int k = 0; k < 8; ++k) crc = (crc & 1U) ? 0xEDB88320U ^ (crc >> 1U) : crc >> 1U;
    }
    return ~crc;
  };
  for (std::size_t offset = 0; offset < 8; ++offset) {
    for (std::size_t n = 0; n + offset <= bytes.size(); n += 7) {
      const unsigned char* p = bytes.data() + offset;
      ASSERT_EQ(crc32(p, n), bytewise(p, n)) << offset << " " << n;
      const std::size_t cut = n / 3;
      ASSERT_EQ(crc32(p + cut, n - cut, crc32(p, cut)), bytewise(p, n)) << offset << " " << n;
    }
  }
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

// The same content written a second later gives the same bytes (no object times): a model file
// rewritten with nothing new keeps its SHA-256.
TEST(ContainerFile, TheSameContentGivesTheSameBytes) {
  const testing::TempDir dir;
  const auto write = [&](const std::filesystem::path& path) {
    ContainerWriter writer(path, "test-format");
    writer.create_group("/group/inner");
    writer.write("/group/inner/x", Eigen::MatrixXd::Ones(3, 2));
    writer.write("/implicit/y", Array::from_vector(Eigen::VectorXd::LinSpaced(4, 0.0, 1.0)));
    writer.set_attribute("/group", "name", std::string("g"));
    writer.set_attribute("/", "value", 2.5);
    writer.commit();
  };
  write(dir / "a.h5");
  ::sleep(2);  // object times have a resolution of one second
  write(dir / "b.h5");
  const auto bytes = [](const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(dir / "a.h5"), bytes(dir / "b.h5"));
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
  // HDF5's signature, then zeros: 2 KB, written in place (growing the vector after its first
  // eight bytes trips a false -Warray-bounds in GCC 12's memmove).
  std::vector<char> signature(2048, '\0');
  constexpr std::array<char, 8> kHdf5Signature = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
  std::copy(kHdf5Signature.begin(), kHdf5Signature.end(), signature.begin());
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

// --- Variable-length text in a hostile file -------------------------------------------------
// The global heap collection and the reference to a string inside it are edited byte by byte
// (the layouts are HDF5's published file format) and the file resealed: each corruption HDF5
// 1.10's own reader turns into an overflow, an out-of-bounds read or an endless loop must be one
// FileError naming the attribute.

struct HeapText {
  std::vector<char> bytes;
  std::size_t object = 0;      ///< offset of the text's heap object header
  std::size_t collection = 0;  ///< offset of its collection ("GCOL")
  std::size_t reference =
      0;  ///< offset of the attribute's stored reference (length, address, index)
};

std::uint64_t get_le(const std::vector<char>& bytes, std::size_t at, std::size_t count) {
  std::uint64_t value = 0;
  for (std::size_t i = count; i-- > 0;) {
    value = (value << 8U) | static_cast<unsigned char>(bytes[at + i]);
  }
  return value;
}

void put_le(std::vector<char>& bytes, std::size_t at, std::size_t count, std::uint64_t value) {
  for (std::size_t i = 0; i < count; ++i)
    bytes[at + i] = static_cast<char>((value >> (8 * i)) & 0xFFU);
}

constexpr std::string_view kText = "the regime's name: agile air, units km";

/// A container whose root holds one variable-length UTF-8 attribute, written by HDF5 with its
/// earliest object-header version (no metadata checksum, so the reference can be edited too).
HeapText make_heap_text(const std::filesystem::path& path) {
  {
    const hid_t create_list = H5Pcreate(H5P_FILE_CREATE);
    H5Pset_userblock(create_list, kContainerHeaderBytes);
    const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, create_list, H5P_DEFAULT);
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, H5T_VARIABLE);
    H5Tset_cset(type, H5T_CSET_UTF8);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t attribute = H5Acreate2(file, "label", type, space, H5P_DEFAULT, H5P_DEFAULT);
    const std::string text(kText);
    const char* characters = text.c_str();
    H5Awrite(attribute, type, &characters);
    for (hid_t id : {attribute, space, type}) H5Idec_ref(id);
    H5Fclose(file);
    H5Pclose(create_list);
    seal_container(path, "test-format");
  }
  HeapText found{testing::read_bytes(path)};
  const std::string_view all(found.bytes.data(), found.bytes.size());
  const std::size_t text = all.find(kText);
  const std::size_t collection = all.find("GCOL");
  if (text == std::string_view::npos || collection == std::string_view::npos) return found;
  found.object = text - 16;
  found.collection = collection;
  // The reference: length (4) = the text's size, address (8) = the collection's relative to the
  // user block, index (4) = the object's.
  std::vector<char> pattern(16);
  put_le(pattern, 0, 4, kText.size());
  put_le(pattern, 4, 8, collection - kContainerHeaderBytes);
  put_le(pattern, 12, 4, get_le(found.bytes, found.object, 2));
  found.reference = all.find(std::string_view(pattern.data(), pattern.size()));
  return found;
}

std::string reseal_and_read(const std::filesystem::path& path, const std::vector<char>& bytes) {
  testing::write_bytes(path, bytes);
  seal_container(path, "test-format");
  try {
    const ContainerReader reader(path, "test-format");
    const auto label = reader.attribute("/", "label");
    return "read '" + (label ? std::get<std::string>(*label) : std::string("(none)")) + "'";
  } catch (const FileError& error) {
    return error.what();
  }
}

TEST(ContainerFile, VariableLengthTextIsReadFromItsHeapObjectWithinBounds) {
  const testing::TempDir dir;
  const auto path = dir / "text.h5";
  const HeapText file = make_heap_text(path);
  ASSERT_NE(file.object, 0U);
  ASSERT_NE(file.reference, std::string::npos) << "the stored reference was not found";
  EXPECT_EQ(get_le(file.bytes, file.object + 8, 8), kText.size());
  EXPECT_EQ(reseal_and_read(path, file.bytes), "read '" + std::string(kText) + "'");

  struct Case {
    const char* what;
    std::size_t at;
    std::size_t count;
    std::uint64_t value;
    const char* expected;
  };
  const std::size_t free_space = file.object + 16 + ((kText.size() + 7) / 8) * 8;
  const std::vector<Case> cases = {
      // HDF5 copies the object's size into a buffer sized by the reference: an overflow.
      {"object larger than the reference says", file.object + 8, 8, kText.size() + 64,
       "names a heap object of"},
      {"object larger than its collection", file.object + 8, 8, std::uint64_t{1} << 40U,
       "overruns its collection"},
      {"reference longer than the object", file.reference, 4, 4096, "names a heap object of"},
      // HDF5 indexes its object table with this without a bound.
      {"reference to an index the collection lacks", file.reference + 12, 4, 4000,
       "which its collection lacks"},
      {"reference to the free space", file.reference + 12, 4, 0, "heap object 0"},
      {"reference past the file", file.reference + 4, 8, std::uint64_t{1} << 50U,
       "outside the file"},
      {"reference to no collection", file.reference + 4, 8, file.object - kContainerHeaderBytes,
       "no global heap collection"},
      // A free-space object of size 0 first: HDF5 never advances past it.
      {"free space of size 0 first", file.object, 2, 0, "which its collection lacks"},
      {"collection larger than the file", file.collection + 8, 8, file.bytes.size(),
       "does not fit the file"},
      {"collection smaller than its header", file.collection + 8, 8, 4, "does not fit the file"},
      {"free space overrunning the collection", free_space + 8, 8, std::uint64_t{1} << 32U,
       "read '"},
  };
  for (const Case& c : cases) {
    auto bytes = file.bytes;
    put_le(bytes, c.at, c.count, c.value);
    const std::string outcome = reseal_and_read(path, bytes);
    EXPECT_NE(outcome.find(c.expected), std::string::npos) << c.what << ": " << outcome;
    if (std::string_view(c.expected) != "read '") {
      EXPECT_NE(outcome.find("/@label"), std::string::npos) << c.what << ": " << outcome;
    }
  }
  // A NUL inside the characters would cut the text short where a C reader meets it.
  auto bytes = file.bytes;
  bytes[file.object + 16 + 3] = '\0';
  EXPECT_NE(reseal_and_read(path, bytes).find("NUL"), std::string::npos);
}

// A corrupt attribute index: the root's twelve attributes are stored densely (a fractal heap and a
// version-2 B-tree indexing their names), and a byte of the B-tree's leaf is flipped. Listing the
// attributes must then fail naming the object — never return the ones it could walk, which let
// `imm-inspect --verify` say "ok" about a file whose provenance does not read.
TEST(ContainerFile, ACorruptAttributeIndexIsAnErrorNotFewerAttributes) {
  const testing::TempDir dir;
  const auto path = dir / "dense.h5";
  {
    const hid_t create_list = H5Pcreate(H5P_FILE_CREATE);
    H5Pset_userblock(create_list, kContainerHeaderBytes);
    const hid_t access_list = H5Pcreate(H5P_FILE_ACCESS);
    H5Pset_libver_bounds(access_list, H5F_LIBVER_V18, H5F_LIBVER_LATEST);
    const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, create_list, access_list);
    const hid_t space = H5Screate(H5S_SCALAR);
    for (int i = 0; i < 12; ++i) {
      const std::string name = "attribute_" + std::to_string(i);
      const hid_t attribute =
          H5Acreate2(file, name.c_str(), H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
      const double value = i;
      H5Awrite(attribute, H5T_NATIVE_DOUBLE, &value);
      H5Aclose(attribute);
    }
    H5Sclose(space);
    H5Fclose(file);
    H5Pclose(access_list);
    H5Pclose(create_list);
    seal_container(path, "test-format");
  }
  EXPECT_EQ(ContainerReader(path, "test-format").attribute_names("/").size(), 12u);
  std::vector<char> bytes = testing::read_bytes(path);
  const std::size_t leaf = std::string_view(bytes.data(), bytes.size()).find("BTLF");
  ASSERT_NE(leaf, std::string_view::npos);
  bytes[leaf + 8] = static_cast<char>(bytes[leaf + 8] ^ 0x5A);  // a record of the name index
  testing::write_bytes(path, bytes);
  seal_container(path, "test-format");
  try {
    const ContainerReader reader(path, "test-format");
    const auto names = reader.attribute_names("/");
    FAIL() << "listed " << names.size() << " attributes from a corrupt index";
  } catch (const FileError& error) {
    EXPECT_EQ(error.field(), "/") << error.what();
  }
}

// Temporaries carry their host: a writer removes a temporary only when this host wrote it and its
// process is gone — never another node's in-flight file in a shared folder, whose process ID means
// nothing here, and never a live writer's.
TEST(Temporaries, OnlyThisHostsDeadWritersAreRemoved) {
  const testing::TempDir dir;
  const auto mine = temporary_beside(dir / "m.h5", 3u);
  EXPECT_EQ(mine.filename().string(),
            ".m.h5.tmp-" + std::to_string(::getpid()) + "-3@" + this_host());
  const auto writer = temporary_writer(mine.filename().string());
  ASSERT_TRUE(writer.has_value());
  EXPECT_EQ(writer->pid, ::getpid());
  EXPECT_EQ(writer->host, this_host());
  EXPECT_EQ(temporary_writer(".a@b.h5.tmp-12@node-7.example")->host, "node-7.example");
  EXPECT_EQ(temporary_writer(".m.h5.tmp-12")->host, this_host());  // from before hosts
  for (const char* name : {"m.h5", ".m.h5", ".m.h5.tmp-", ".m.h5.tmp-x@h", ".m.h5.tmp-12-@h",
                           ".m.h5.tmp-12@", ".m.h5.tmp-0@h"}) {
    EXPECT_FALSE(temporary_writer(name).has_value()) << name;
  }

  const pid_t child = ::fork();  // a process ID that is surely dead once reaped
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ASSERT_EQ(::waitpid(child, nullptr, 0), child);
  const std::string dead = std::to_string(child);
  const std::vector<std::string> removed = {".a.h5.tmp-" + dead + "-0@" + this_host(),
                                            ".b.h5.tmp-" + dead};
  const std::vector<std::string> kept = {".c.h5.tmp-" + dead + "-0@another-node",
                                         mine.filename().string()};
  for (const auto& name : removed) testing::write_text(dir / name, "partial");
  for (const auto& name : kept) testing::write_text(dir / name, "in flight");
  ContainerWriter w(dir / "new.h5", "immtrain-model");
  w.write("/x", Eigen::MatrixXd::Ones(1, 1));
  w.commit();
  for (const auto& name : removed) EXPECT_FALSE(std::filesystem::exists(dir / name)) << name;
  for (const auto& name : kept) EXPECT_TRUE(std::filesystem::exists(dir / name)) << name;
}

}  // namespace
}  // namespace imm::io
