// SPDX-License-Identifier: Apache-2.0
#pragma once
/// SHA-256 (FIPS 180-4), for the dataset digests recorded in model files.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace imm::datasets {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t size);
  void update(std::string_view text) { update(text.data(), text.size()); }
  /// Finishes and returns the lowercase hex digest; the object is then spent.
  [[nodiscard]] std::string hex_digest();

 private:
  void compress(const unsigned char* block);

  std::array<std::uint32_t, 8> state_{};
  std::array<unsigned char, 64> buffer_{};
  std::size_t buffered_ = 0;
  std::uint64_t total_bytes_ = 0;
};

[[nodiscard]] std::string sha256_hex(std::string_view text);
/// The digest of a whole file's bytes; throws std::runtime_error naming the file.
[[nodiscard]] std::string file_sha256_hex(const std::filesystem::path& path);

/// Feeds a matrix: its shape (two int64), then its values row-major as little-endian doubles.
void hash_matrix(Sha256& hash, const Eigen::MatrixXd& matrix);

}  // namespace imm::datasets
