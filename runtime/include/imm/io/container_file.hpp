// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The checked HDF5 container behind model files and data-set files.
///
/// On disk a container is an HDF5 file with a 512-byte user block in front. The user block holds
/// a small text header: the container version, the format name ("immtrain-model",
/// "immtrain-dataset"), the payload length and its CRC-32, and a CRC-32 of the header itself.
/// The reader verifies all of it before the HDF5 library parses a single byte, so a truncated
/// file or a flipped bit anywhere is reported as such instead of reaching the HDF5 parser.
/// Inside, every dataset is chunked with the Fletcher-32 filter, so the data keep their own
/// checksum even when the HDF5 payload is extracted (h5dump and h5py read the file unchanged).
///
/// Writes are atomic: the writer builds the file under a temporary name in the destination folder
/// and renames it over the final name only in commit(), after flushing to disk. A writer destroyed
/// without commit() (an exception, a kill between stages) removes its temporary file.
///
/// No HDF5 type appears in this header.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "imm/io/file_error.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// A scalar attribute: integer, real or text.
using Attribute = std::variant<std::int64_t, double, std::string>;

/// An N-dimensional array of doubles in row-major order.
struct IMM_RUNTIME_EXPORT Array {
  /// Extent per dimension.
  std::vector<std::size_t> shape;
  /// The values, row-major.
  std::vector<double> values;

  /// A rank-2 array of a matrix.
  [[nodiscard]] static Array from_matrix(const Eigen::MatrixXd& matrix);
  /// A rank-1 array of a vector.
  [[nodiscard]] static Array from_vector(const Eigen::VectorXd& vector);
  /// The number of dimensions.
  [[nodiscard]] std::size_t rank() const { return shape.size(); }
  /// The product of the extents.
  [[nodiscard]] std::size_t element_count() const;
};

/// What a path names in a container.
enum class ObjectKind { kMissing, kGroup, kDataset };

/// Writes a container atomically (see the file comment).
class IMM_RUNTIME_EXPORT ContainerWriter {
 public:
  /// Starts a container of the given format that will appear at `path` on commit().
  /// Throws FileError when the folder does not exist or is not writable.
  ContainerWriter(const std::filesystem::path& path, std::string_view format);
  ~ContainerWriter();
  ContainerWriter(const ContainerWriter&) = delete;
  ContainerWriter& operator=(const ContainerWriter&) = delete;

  /// What a dataset may hold besides finite values.
  enum class Values {
    kFinite,           ///< finite only
    kFiniteOrMissing,  ///< NaN marks a missing value (a recording's gaps); ±∞ is refused
  };
  /// Writes a dataset (intermediate groups are created; an existing one is replaced).
  /// Non-finite values are refused, except NaN where `values` allows missing ones.
  void write(std::string_view dataset, const Array& array, Values values = Values::kFinite);
  /// Writes a matrix as a rank-2 dataset.
  void write(std::string_view dataset, const Eigen::MatrixXd& matrix);

  /// Creates a group (and its parents) if it does not exist yet.
  void create_group(std::string_view group);

  /// Sets a scalar attribute on a group or dataset ("/" is the root).
  void set_attribute(std::string_view object, std::string_view name, const Attribute& value);

  /// Closes, checksums, flushes and renames the file to its final name.
  void commit();

  /// The final path of the file.
  [[nodiscard]] const std::filesystem::path& path() const;

 private:
  struct IMM_RUNTIME_NO_EXPORT Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reads and verifies a container (see the file comment).
class IMM_RUNTIME_EXPORT ContainerReader {
 public:
  /// Opens and verifies a container. Throws FileError (naming the file) when the file is missing,
  /// truncated, corrupt, not an immtrain container, or of another format than `expected_format`
  /// (an empty `expected_format` accepts any). The HDF5 part must be a tree of groups and datasets
  /// joined by hard links, within fixed bounds (objects, depth, members per group, attributes per
  /// object): a link cycle, a soft or external link, a second link to one object or a named
  /// datatype is refused here, naming the link, so no later walk can loop or leave the file.
  ContainerReader(const std::filesystem::path& path, std::string_view expected_format);
  ~ContainerReader();
  ContainerReader(const ContainerReader&) = delete;
  ContainerReader& operator=(const ContainerReader&) = delete;

  /// The file's path.
  [[nodiscard]] const std::filesystem::path& path() const;
  /// The format named in the header ("immtrain-model", "immtrain-dataset").
  [[nodiscard]] const std::string& format() const;
  /// Whether `object` is a group, a dataset or missing.
  [[nodiscard]] ObjectKind kind(std::string_view object) const;
  /// Names of a group's members, sorted.
  [[nodiscard]] std::vector<std::string> children(std::string_view group) const;
  /// Paths of every object in the file ("/" first), sorted.
  [[nodiscard]] std::vector<std::string> objects() const;
  /// The extents of a dataset.
  [[nodiscard]] std::vector<std::size_t> shape(std::string_view dataset) const;
  /// Reads a floating-point dataset. Throws FileError naming the dataset on a checksum mismatch,
  /// a non-float type or a missing dataset.
  [[nodiscard]] Array read(std::string_view dataset) const;
  /// A scalar attribute of an object, or nothing when it is absent. Throws FileError naming the
  /// attribute when it is not a scalar integer, real or text.
  [[nodiscard]] std::optional<Attribute> attribute(std::string_view object,
                                                   std::string_view name) const;
  /// The names of an object's attributes.
  [[nodiscard]] std::vector<std::string> attribute_names(std::string_view object) const;

 private:
  struct IMM_RUNTIME_NO_EXPORT Impl;
  std::unique_ptr<Impl> impl_;
};

/// For a program's main, before anything else touches HDF5: the library then skips its own
/// shutdown at exit. After a write that failed (a full disk, a file-size limit) HDF5 1.10 cannot
/// close the file it was writing, and its shutdown at exit crashes on it or loops ("infinite loop
/// closing library" on stderr) — after the program has reported the failure in one line. A reader
/// has nothing to flush; a writer's temporary is removed by the next writer in its folder. Every
/// imm-* tool calls it; a library that embeds the runtime need not.
IMM_RUNTIME_EXPORT void skip_hdf5_shutdown_at_exit();

/// Size of the user block an HDF5 file needs to become a container.
inline constexpr std::size_t kContainerHeaderBytes = 512;

/// Turns a closed HDF5 file that was created with a kContainerHeaderBytes user block into a
/// container of `format` by writing the checksummed header, and flushes it to disk. ContainerWriter
/// does this in commit(); it is public for tools that build the HDF5 part with other means (and
/// for fault drills that need a correctly sealed file with hostile content).
IMM_RUNTIME_EXPORT void seal_container(const std::filesystem::path& path, std::string_view format);

/// CRC-32 (IEEE 802.3, as zlib) of a byte range, continuing from `crc` (0 to start).
[[nodiscard]] IMM_RUNTIME_EXPORT std::uint32_t crc32(const void* data, std::size_t size,
                                                     std::uint32_t crc = 0);

}  // namespace imm::io
