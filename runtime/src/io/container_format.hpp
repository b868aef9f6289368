// SPDX-License-Identifier: Apache-2.0
#pragma once
// The container's internals, shared by its writer, its reader and its sealing
// (container_format.cpp, container_writer.cpp, container_reader.cpp): the header block, CRCs
// of files, and owning HDF5 handles. Not installed.

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/schema_reader.hpp"

namespace imm::io::container {

// ---------------------------------------------------------------------------------------------
// Header format (the HDF5 user block):
//   IMMTRAIN CONTAINER <version>\n
//   format: <format>\n
//   payload-bytes: <bytes after the user block>\n
//   payload-crc32: <8 hex digits>\n
//   header-crc32: <8 hex digits>\n
//   NUL padding to 512 bytes
// The header CRC covers all 512 bytes, its own digits read as '0'.
// ---------------------------------------------------------------------------------------------
inline constexpr std::size_t kHeaderSize = kContainerHeaderBytes;
inline constexpr int kContainerVersion = 1;
inline constexpr std::string_view kMagic = "IMMTRAIN CONTAINER ";
inline constexpr std::string_view kHdf5Signature = "\x89HDF\r\n\x1a\n";
inline constexpr std::size_t kMaxRank = 8;
// Structural bounds of a container (the reader refuses a file beyond them before reading data):
// the shipped models hold a few dozen objects; data sets stack their runs into a few datasets.
inline constexpr std::size_t kMaxObjects = 10000;
inline constexpr std::size_t kMaxDepth = 16;
inline constexpr std::size_t kMaxLinksPerGroup = 4096;
inline constexpr std::size_t kMaxNameBytes = 256;

/// Whether a name (of a member or an attribute) is one a schema can hold: 1 to kMaxNameBytes bytes,
/// no control byte (a newline or an ESC would reach every message that names the field).
inline bool usable_name(std::string_view name) {
  return !name.empty() && name.size() <= kMaxNameBytes &&
         std::none_of(name.begin(), name.end(), [](char c) {
           const auto u = static_cast<unsigned char>(c);
           return u < 0x20 || u == 0x7f;
         });
}

/// A name for a message: its control bytes as \\xNN, at most 64 bytes of it.
inline std::string escaped_name(std::string_view name) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (const char c : name.substr(0, 64)) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) {
      out.append("\\x").push_back(kHex[u >> 4U]);
      out.push_back(kHex[u & 0xfU]);
    } else {
      out.push_back(c);
    }
  }
  if (name.size() > 64) out += "… (" + std::to_string(name.size()) + " bytes)";
  return out;
}
inline constexpr std::size_t kMaxAttributesPerObject = 256;

inline std::string hex32(std::uint32_t value) {
  char buffer[9];
  std::snprintf(buffer, sizeof buffer, "%08x", value);
  return buffer;
}

inline std::string normalized(std::string_view object) { return field_path(object); }

/// Owns an HDF5 identifier.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& other) noexcept : id_(other.id_), closer_(other.closer_) { other.id_ = -1; }
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      reset();
      id_ = other.id_;
      closer_ = other.closer_;
      other.id_ = -1;
    }
    return *this;
  }
  ~Handle() { reset(); }

  [[nodiscard]] hid_t get() const { return id_; }
  [[nodiscard]] bool valid() const { return id_ >= 0; }
  /// Closes now and reports whether the close succeeded.
  bool close() {
    const bool ok = id_ < 0 || closer_ == nullptr || closer_(id_) >= 0;
    id_ = -1;
    return ok;
  }
  void reset() { close(); }

 private:
  hid_t id_ = -1;
  Closer closer_ = nullptr;
};

/// Silences HDF5's automatic error printing while in scope (restoring the caller's handler), so
/// that failures surface as one FileError, not a stack dump on stderr.
class ErrorSilencer {
 public:
  ErrorSilencer() {
    H5Eget_auto2(H5E_DEFAULT, &old_function_, &old_data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~ErrorSilencer() { H5Eset_auto2(H5E_DEFAULT, old_function_, old_data_); }
  ErrorSilencer(const ErrorSilencer&) = delete;
  ErrorSilencer& operator=(const ErrorSilencer&) = delete;

 private:
  H5E_auto2_t old_function_ = nullptr;
  void* old_data_ = nullptr;
};

/// The innermost description on HDF5's error stack (the most specific cause), then clears it.
inline std::string hdf5_cause() {
  std::string cause;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned /*n*/, const H5E_error2_t* error, void* data) -> herr_t {
        if (error->desc != nullptr && error->desc[0] != '\0') {
          *static_cast<std::string*>(data) = error->desc;
        }
        return 0;
      },
      &cause);
  H5Eclear2(H5E_DEFAULT);
  // One line: HDF5's descriptions of a failed write carry a ctime() date and its newline.
  for (char& c : cause) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return cause.empty() ? "HDF5 error" : cause;
}

/// Whether every component of `path` exists as a link (H5Lexists requires existing parents).
inline bool link_exists(hid_t file, const std::string& path) {
  if (path == "/") return true;
  std::size_t position = 1;
  while (true) {
    const std::size_t next = path.find('/', position);
    const std::string prefix = path.substr(0, next);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (next == std::string::npos) return true;
    position = next + 1;
  }
}

inline Handle open_object(hid_t file, const std::string& path) {
  return Handle(H5Oopen(file, path.c_str(), H5P_DEFAULT), H5Oclose);
}

struct FileDescriptor {
  int fd = -1;
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
};

inline std::string errno_text() { return std::system_category().message(errno); }

/// CRC-32 of the bytes [offset, offset + length) of an open file.
inline bool file_crc32(int fd, std::uint64_t offset, std::uint64_t length, std::uint32_t& crc) {
  std::vector<char> buffer(1 << 16);
  crc = 0;
  while (length > 0) {
    const std::size_t want =
        static_cast<std::size_t>(std::min<std::uint64_t>(length, buffer.size()));
    const ssize_t got = ::pread(fd, buffer.data(), want, static_cast<off_t>(offset));
    if (got <= 0) return false;
    crc = crc32(buffer.data(), static_cast<std::size_t>(got), crc);
    offset += static_cast<std::uint64_t>(got);
    length -= static_cast<std::uint64_t>(got);
  }
  return true;
}

struct Header {
  int version = 0;
  std::string format;
  std::uint64_t payload_bytes = 0;
  std::uint32_t payload_crc = 0;
};

inline std::string header_text_without_crc(const Header& header) {
  std::ostringstream out;
  out << kMagic << header.version << '\n'
      << "format: " << header.format << '\n'
      << "payload-bytes: " << header.payload_bytes << '\n'
      << "payload-crc32: " << hex32(header.payload_crc) << '\n';
  return out.str();
}

/// CRC-32 of the whole user block with the 8 digits of the stated header CRC (at `digits`) read
/// as '0': every byte of the block, padding included, is covered.
inline std::uint32_t header_block_crc(const std::array<char, kHeaderSize>& block,
                                      std::size_t digits) {
  std::array<char, kHeaderSize> copy = block;
  std::fill_n(copy.begin() + static_cast<std::ptrdiff_t>(digits), 8, '0');
  return crc32(copy.data(), copy.size());
}

/// Parses and verifies the user block; returns an error text or an empty string.
inline std::string parse_header(const std::array<char, kHeaderSize>& block, Header& header) {
  const std::string_view text(block.data(), block.size());
  if (text.substr(0, kMagic.size()) != kMagic) {
    if (text.substr(0, kHdf5Signature.size()) == kHdf5Signature) {
      return "a plain HDF5 file, not an immtrain container (no immtrain header)";
    }
    return "not an immtrain container (unrecognized header)";
  }
  constexpr std::string_view kCrcKey = "header-crc32: ";
  const std::size_t crc_line = text.find(kCrcKey);
  if (crc_line == std::string_view::npos || crc_line + kCrcKey.size() + 8 > text.size()) {
    return "corrupt container header (no header checksum)";
  }
  const std::size_t digits = crc_line + kCrcKey.size();
  const std::string stated_crc(text.substr(digits, 8));
  if (hex32(header_block_crc(block, digits)) != stated_crc) {
    return "corrupt container header (header checksum mismatch)";
  }
  std::istringstream lines{std::string(text.substr(0, crc_line))};
  std::string magic_word, container_word, key, crc_text;
  lines >> magic_word >> container_word >> header.version;
  lines >> key >> header.format;
  if (key != "format:") return "corrupt container header (format)";
  lines >> key >> header.payload_bytes;
  if (key != "payload-bytes:") return "corrupt container header (payload-bytes)";
  lines >> key >> crc_text;
  if (key != "payload-crc32:" || crc_text.size() != 8 || !lines) {
    return "corrupt container header (payload-crc32)";
  }
  header.payload_crc = static_cast<std::uint32_t>(std::stoul(crc_text, nullptr, 16));
  return {};
}

}  // namespace imm::io::container
