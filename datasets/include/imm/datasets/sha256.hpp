// SPDX-License-Identifier: Apache-2.0
#pragma once
/// SHA-256 (FIPS 180-4), for the dataset digests recorded in model files.

#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

// OpenSSL's digest context (EVP_MD_CTX), kept out of this header.
struct evp_md_ctx_st;

namespace imm::datasets {

/// SHA-256 by OpenSSL's libcrypto (its EVP digest interface). Movable, not copyable.
class Sha256 {
 public:
  /// Throws std::runtime_error when libcrypto cannot start a digest.
  Sha256();
  ~Sha256();
  Sha256(Sha256&&) noexcept;
  Sha256& operator=(Sha256&&) noexcept;
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void update(const void* data, std::size_t size);
  void update(std::string_view text) { update(text.data(), text.size()); }
  /// Finishes and returns the lowercase hex digest; the object is then spent.
  [[nodiscard]] std::string hex_digest();

 private:
  struct Free {
    void operator()(evp_md_ctx_st* context) const;
  };
  std::unique_ptr<evp_md_ctx_st, Free> context_;
};

[[nodiscard]] std::string sha256_hex(std::string_view text);
/// The digest of a whole file's bytes; throws std::runtime_error naming the file.
[[nodiscard]] std::string file_sha256_hex(const std::filesystem::path& path);

/// Feeds a matrix: its shape (two int64), then its values row-major as little-endian doubles.
void hash_matrix(Sha256& hash, const Eigen::MatrixXd& matrix);

}  // namespace imm::datasets
