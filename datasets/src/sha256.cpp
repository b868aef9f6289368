// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/sha256.hpp"

#include <openssl/evp.h>

#include <array>
#include <bit>
#include <fstream>
#include <stdexcept>

namespace imm::datasets {

void Sha256::Free::operator()(evp_md_ctx_st* context) const { EVP_MD_CTX_free(context); }

Sha256::Sha256() : context_(EVP_MD_CTX_new()) {
  if (!context_ || EVP_DigestInit_ex(context_.get(), EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("SHA-256: libcrypto could not start a digest");
  }
}

Sha256::~Sha256() = default;
Sha256::Sha256(Sha256&&) noexcept = default;
Sha256& Sha256::operator=(Sha256&&) noexcept = default;

void Sha256::update(const void* data, std::size_t size) {
  if (size == 0) return;
  if (EVP_DigestUpdate(context_.get(), data, size) != 1) {
    throw std::runtime_error("SHA-256: libcrypto's digest update failed");
  }
}

std::string Sha256::hex_digest() {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(context_.get(), digest.data(), &length) != 1 || length != 32) {
    throw std::runtime_error("SHA-256: libcrypto could not finish the digest");
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(2 * length);
  for (unsigned int i = 0; i < length; ++i) {
    hex.push_back(kHex[digest[i] >> 4U]);
    hex.push_back(kHex[digest[i] & 0xFU]);
  }
  return hex;
}

std::string sha256_hex(std::string_view text) {
  Sha256 hash;
  hash.update(text);
  return hash.hex_digest();
}

std::string file_sha256_hex(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot open to hash");
  Sha256 hash;
  std::array<char, 1 << 16> block{};
  while (in) {
    in.read(block.data(), block.size());
    hash.update(block.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw std::runtime_error(path.string() + ": read error while hashing");
  return hash.hex_digest();
}

void hash_matrix(Sha256& hash, const Eigen::MatrixXd& matrix) {
  static_assert(std::endian::native == std::endian::little, "digest assumes little-endian");
  const std::int64_t shape[2] = {matrix.rows(), matrix.cols()};
  hash.update(shape, sizeof shape);
  // Row-major, as stored in the data-set file, a chunk of a row per update.
  std::array<double, 256> chunk{};
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
    for (Eigen::Index j = 0; j < matrix.cols();) {
      std::size_t count = 0;
      for (; count < chunk.size() && j < matrix.cols(); ++count, ++j) chunk[count] = matrix(i, j);
      hash.update(chunk.data(), count * sizeof(double));
    }
  }
}

}  // namespace imm::datasets
