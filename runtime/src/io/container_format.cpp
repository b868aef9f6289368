// SPDX-License-Identifier: Apache-2.0
// The container's format: CRC-32 (zlib's), arrays, and sealing a file's header block.
#include "container_format.hpp"

#include <sys/stat.h>
#include <zlib.h>

namespace imm::io {

using namespace container;  // NOLINT(google-build-using-namespace): the format's own internals

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  // zlib's, the library HDF5 itself compresses with.
  return static_cast<std::uint32_t>(::crc32_z(crc, static_cast<const Bytef*>(data), size));
}

Array Array::from_matrix(const Eigen::MatrixXd& matrix) {
  Array array;
  array.shape = {static_cast<std::size_t>(matrix.rows()), static_cast<std::size_t>(matrix.cols())};
  array.values.resize(static_cast<std::size_t>(matrix.size()));
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      array.values.data(), matrix.rows(), matrix.cols()) = matrix;
  return array;
}

Array Array::from_vector(const Eigen::VectorXd& vector) {
  Array array;
  array.shape = {static_cast<std::size_t>(vector.size())};
  array.values.assign(vector.data(), vector.data() + vector.size());
  return array;
}

std::size_t Array::element_count() const {
  std::size_t count = 1;
  for (std::size_t extent : shape) count *= extent;
  return count;
}

// --- Sealing ---------------------------------------------------------------------------------

void seal_container(const std::filesystem::path& path, std::string_view format) {
  const std::string file = path.string();
  if (format.empty() || format.find_first_of(" \n") != std::string_view::npos) {
    throw FileError(file, "", "invalid container format name");
  }
  FileDescriptor descriptor{::open(path.c_str(), O_RDWR | O_CLOEXEC)};
  if (descriptor.fd < 0) throw FileError(file, "", "cannot open for sealing: " + errno_text());
  struct stat status {};
  if (::fstat(descriptor.fd, &status) != 0 ||
      static_cast<std::size_t>(status.st_size) < kHeaderSize) {
    throw FileError(file, "", "shorter than the container header");
  }
  Header header;
  header.version = kContainerVersion;
  header.format = std::string(format);
  header.payload_bytes = static_cast<std::uint64_t>(status.st_size) - kHeaderSize;
  if (!file_crc32(descriptor.fd, kHeaderSize, header.payload_bytes, header.payload_crc)) {
    throw FileError(file, "", "cannot read back: " + errno_text());
  }
  std::string text = header_text_without_crc(header) + "header-crc32: ";
  const std::size_t digits = text.size();
  text += "00000000\n";
  std::array<char, kHeaderSize> block{};
  std::copy(text.begin(), text.end(), block.begin());
  const std::string crc = hex32(header_block_crc(block, digits));
  std::copy(crc.begin(), crc.end(), block.begin() + static_cast<std::ptrdiff_t>(digits));
  if (::pwrite(descriptor.fd, block.data(), block.size(), 0) !=
          static_cast<ssize_t>(block.size()) ||
      ::fsync(descriptor.fd) != 0) {
    throw FileError(file, "", "cannot write header: " + errno_text());
  }
}

}  // namespace imm::io
