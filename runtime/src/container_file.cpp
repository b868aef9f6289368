// SPDX-License-Identifier: Apache-2.0
#include "imm/io/container_file.hpp"

#include <fcntl.h>
#include <hdf5.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <system_error>
#include <utility>

#include "global_heap_text.hpp"

namespace imm::io {
namespace {

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
constexpr std::size_t kHeaderSize = kContainerHeaderBytes;
constexpr int kContainerVersion = 1;
constexpr std::string_view kMagic = "IMMTRAIN CONTAINER ";
constexpr std::string_view kHdf5Signature = "\x89HDF\r\n\x1a\n";
constexpr std::size_t kMaxRank = 8;
// Structural bounds of a container (the reader refuses a file beyond them before reading data):
// the shipped models hold a few dozen objects; data sets stack their runs into a few datasets.
constexpr std::size_t kMaxObjects = 10000;
constexpr std::size_t kMaxDepth = 16;
constexpr std::size_t kMaxLinksPerGroup = 4096;
constexpr std::size_t kMaxNameBytes = 256;
constexpr std::size_t kMaxAttributesPerObject = 256;

std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1U) : c >> 1U;
    table[i] = c;
  }
  return table;
}

std::string hex32(std::uint32_t value) {
  char buffer[9];
  std::snprintf(buffer, sizeof buffer, "%08x", value);
  return buffer;
}

std::string normalized(std::string_view object) { return field_path(object); }

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
std::string hdf5_cause() {
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
  return cause.empty() ? "HDF5 error" : cause;
}

/// Whether every component of `path` exists as a link (H5Lexists requires existing parents).
bool link_exists(hid_t file, const std::string& path) {
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

Handle open_object(hid_t file, const std::string& path) {
  return Handle(H5Oopen(file, path.c_str(), H5P_DEFAULT), H5Oclose);
}

struct FileDescriptor {
  int fd = -1;
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
};

std::string errno_text() { return std::system_category().message(errno); }

/// CRC-32 of the bytes [offset, offset + length) of an open file.
bool file_crc32(int fd, std::uint64_t offset, std::uint64_t length, std::uint32_t& crc) {
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

std::string header_text_without_crc(const Header& header) {
  std::ostringstream out;
  out << kMagic << header.version << '\n'
      << "format: " << header.format << '\n'
      << "payload-bytes: " << header.payload_bytes << '\n'
      << "payload-crc32: " << hex32(header.payload_crc) << '\n';
  return out.str();
}

/// CRC-32 of the whole user block with the 8 digits of the stated header CRC (at `digits`) read
/// as '0': every byte of the block, padding included, is covered.
std::uint32_t header_block_crc(const std::array<char, kHeaderSize>& block, std::size_t digits) {
  std::array<char, kHeaderSize> copy = block;
  std::fill_n(copy.begin() + static_cast<std::ptrdiff_t>(digits), 8, '0');
  return crc32(copy.data(), copy.size());
}

/// Parses and verifies the user block; returns an error text or an empty string.
std::string parse_header(const std::array<char, kHeaderSize>& block, Header& header) {
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

void write_attribute(hid_t object, const std::string& name, const Attribute& value,
                     const std::string& file, const std::string& field) {
  if (H5Aexists(object, name.c_str()) > 0) H5Adelete(object, name.c_str());
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle file_type;
  hid_t memory_type = -1;
  const void* data = nullptr;
  std::int64_t integer = 0;
  double real = 0.0;
  std::string text;
  const char* text_pointer = nullptr;
  if (const auto* i = std::get_if<std::int64_t>(&value)) {
    integer = *i;
    file_type = Handle(H5Tcopy(H5T_STD_I64LE), H5Tclose);
    memory_type = H5T_NATIVE_INT64;
    data = &integer;
  } else if (const auto* d = std::get_if<double>(&value)) {
    if (!std::isfinite(*d)) throw FileError(file, field, "refusing to write a non-finite value");
    real = *d;
    file_type = Handle(H5Tcopy(H5T_IEEE_F64LE), H5Tclose);
    memory_type = H5T_NATIVE_DOUBLE;
    data = &real;
  } else {
    // Variable-length UTF-8: h5py and other readers return it as text, not bytes.
    text = std::get<std::string>(value);
    file_type = Handle(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(file_type.get(), H5T_VARIABLE);
    H5Tset_cset(file_type.get(), H5T_CSET_UTF8);
    text_pointer = text.c_str();
    memory_type = file_type.get();
    data = &text_pointer;
  }
  Handle attribute(
      H5Acreate2(object, name.c_str(), file_type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
      H5Aclose);
  if (!attribute.valid() || H5Awrite(attribute.get(), memory_type, data) < 0) {
    throw FileError(file, field, "cannot write attribute: " + hdf5_cause());
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> table = make_crc_table();
  const auto* bytes = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ bytes[i]) & 0xFFU] ^ (crc >> 8U);
  return ~crc;
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

// --- Writer ----------------------------------------------------------------------------------

struct ContainerWriter::Impl {
  std::filesystem::path final_path;
  std::filesystem::path temp_path;  ///< ".<name>.tmp-<pid>-<n>" beside the target
  bool temp_exists = false;
  std::string format;
  Handle file;
  bool committed = false;

  [[nodiscard]] std::string name() const { return final_path.string(); }
};

namespace {

/// Removes what writers killed while writing left in `folder` (SIGKILL runs no destructor): hidden
/// temporaries ".<name>.tmp-<pid>" or ".<name>.tmp-<pid>-<n>" — the pattern of this writer and of
/// the trainer's atomic JSON writes — whose process no longer exists.
void remove_stale_temporaries(const std::filesystem::path& folder) {
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    const std::string name = entry.path().filename().string();
    const auto marker = name.rfind(".tmp-");
    if (name.empty() || name.front() != '.' || marker == std::string::npos || marker == 0) continue;
    const char* digits = name.c_str() + marker + 5;
    char* end = nullptr;
    const long pid = std::strtol(digits, &end, 10);
    if (end == digits || pid <= 0) continue;
    if (*end == '-') {
      const char* counter = end + 1;
      std::strtol(counter, &end, 10);
      if (end == counter) continue;
    }
    if (*end != '\0') continue;
    if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      std::error_code ignored;
      std::filesystem::remove(entry.path(), ignored);
    }
  }
}

}  // namespace

ContainerWriter::ContainerWriter(const std::filesystem::path& path, std::string_view format)
    : impl_(std::make_unique<Impl>()) {
  static std::atomic<unsigned> counter{0};
  const ErrorSilencer silencer;
  impl_->final_path = path;
  impl_->format = std::string(format);
  if (format.empty() || format.find_first_of(" \n") != std::string_view::npos) {
    throw FileError(path.string(), "", "invalid container format name");
  }
  std::filesystem::path folder = path.parent_path();
  if (folder.empty()) folder = ".";
  if (!std::filesystem::is_directory(folder)) {
    throw FileError(path.string(), "", "folder '" + folder.string() + "' does not exist");
  }
  remove_stale_temporaries(folder);
  impl_->temp_path = folder / ("." + path.filename().string() + ".tmp-" +
                               std::to_string(::getpid()) + "-" + std::to_string(counter++));
  // HDF5 needs a path to create its file (it resolves the name, so an unnamed O_TMPFILE behind
  // /proc/self/fd cannot serve), hence a hidden named file in the destination folder. A process
  // killed while it exists (SIGKILL runs no destructor) leaves it; the next writer in the same
  // folder removes it (remove_stale_temporaries above).
  impl_->temp_exists = true;

  Handle create_list(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  H5Pset_userblock(create_list.get(), kHeaderSize);
  Handle access_list(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_libver_bounds(access_list.get(), H5F_LIBVER_V18, H5F_LIBVER_LATEST);
  impl_->file = Handle(
      H5Fcreate(impl_->temp_path.c_str(), H5F_ACC_EXCL, create_list.get(), access_list.get()),
      H5Fclose);
  if (!impl_->file.valid()) {
    if (impl_->temp_exists) {
      std::error_code ignored;
      std::filesystem::remove(impl_->temp_path, ignored);
    }
    throw FileError(path.string(), "",
                    "cannot create '" + impl_->temp_path.string() + "': " + hdf5_cause());
  }
}

ContainerWriter::~ContainerWriter() {
  if (impl_ && !impl_->committed) {
    const ErrorSilencer silencer;
    impl_->file.reset();
    if (impl_->temp_exists) {
      std::error_code ignored;
      std::filesystem::remove(impl_->temp_path, ignored);
    }
  }
}

const std::filesystem::path& ContainerWriter::path() const { return impl_->final_path; }

void ContainerWriter::create_group(std::string_view group) {
  const ErrorSilencer silencer;
  const std::string name = normalized(group);
  if (link_exists(impl_->file.get(), name)) return;
  Handle link_list(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(link_list.get(), 1);
  Handle created(
      H5Gcreate2(impl_->file.get(), name.c_str(), link_list.get(), H5P_DEFAULT, H5P_DEFAULT),
      H5Gclose);
  if (!created.valid())
    throw FileError(impl_->name(), name, "cannot create group: " + hdf5_cause());
}

void ContainerWriter::write(std::string_view dataset, const Eigen::MatrixXd& matrix) {
  write(dataset, Array::from_matrix(matrix));
}

void ContainerWriter::write(std::string_view dataset, const Array& array) {
  const ErrorSilencer silencer;
  const std::string name = normalized(dataset);
  const std::string file = impl_->name();
  if (array.shape.empty() || array.shape.size() > kMaxRank) {
    throw FileError(file, name, "rank must be 1 to " + std::to_string(kMaxRank));
  }
  if (array.element_count() != array.values.size()) {
    throw FileError(file, name,
                    "shape holds " + std::to_string(array.element_count()) + " elements but " +
                        std::to_string(array.values.size()) + " values were given");
  }
  for (std::size_t i = 0; i < array.values.size(); ++i) {
    if (!std::isfinite(array.values[i])) {
      throw FileError(file, name,
                      "refusing to write non-finite value at flat index " + std::to_string(i));
    }
  }
  const int rank = static_cast<int>(array.shape.size());
  std::vector<hsize_t> dims(array.shape.begin(), array.shape.end());
  Handle space(H5Screate_simple(rank, dims.data(), nullptr), H5Sclose);
  Handle create_list(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (!array.values.empty()) {
    // One chunk per dataset up to 2²⁰ elements, then split along the leading dimensions.
    std::vector<hsize_t> chunk = dims;
    constexpr hsize_t kMaxChunkElements = hsize_t{1} << 20U;
    auto chunk_elements = [&] {
      hsize_t n = 1;
      for (hsize_t c : chunk) n *= c;
      return n;
    };
    for (std::size_t d = 0; d < chunk.size() && chunk_elements() > kMaxChunkElements; ++d) {
      while (chunk[d] > 1 && chunk_elements() > kMaxChunkElements) chunk[d] = (chunk[d] + 1) / 2;
    }
    H5Pset_chunk(create_list.get(), rank, chunk.data());
    H5Pset_fletcher32(create_list.get());
  }
  // A later write of the same dataset replaces the earlier one, as set_attribute does.
  if (link_exists(impl_->file.get(), name) &&
      H5Ldelete(impl_->file.get(), name.c_str(), H5P_DEFAULT) < 0) {
    throw FileError(file, name, "cannot replace dataset: " + hdf5_cause());
  }
  Handle link_list(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(link_list.get(), 1);
  Handle data(H5Dcreate2(impl_->file.get(), name.c_str(), H5T_IEEE_F64LE, space.get(),
                         link_list.get(), create_list.get(), H5P_DEFAULT),
              H5Dclose);
  if (!data.valid()) throw FileError(file, name, "cannot create dataset: " + hdf5_cause());
  if (!array.values.empty() && H5Dwrite(data.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL,
                                        H5P_DEFAULT, array.values.data()) < 0) {
    throw FileError(file, name, "cannot write dataset: " + hdf5_cause());
  }
}

void ContainerWriter::set_attribute(std::string_view object, std::string_view name,
                                    const Attribute& value) {
  const ErrorSilencer silencer;
  const std::string path = normalized(object);
  const std::string field = field_path(object, name);
  if (!link_exists(impl_->file.get(), path)) create_group(path);
  Handle handle = open_object(impl_->file.get(), path);
  if (!handle.valid()) throw FileError(impl_->name(), field, "cannot open object: " + hdf5_cause());
  write_attribute(handle.get(), std::string(name), value, impl_->name(), field);
}

void ContainerWriter::commit() {
  const ErrorSilencer silencer;
  const std::string file = impl_->name();
  if (impl_->committed) throw FileError(file, "", "container already committed");
  if (H5Fflush(impl_->file.get(), H5F_SCOPE_GLOBAL) < 0 || !impl_->file.close()) {
    throw FileError(file, "", "cannot finish HDF5 file: " + hdf5_cause());
  }

  seal_container(impl_->temp_path, impl_->format);

  std::error_code error;
  std::filesystem::rename(impl_->temp_path, impl_->final_path, error);
  if (error) throw FileError(file, "", "cannot rename temporary file: " + error.message());
  impl_->temp_exists = false;
  impl_->committed = true;
  std::filesystem::path folder = impl_->final_path.parent_path();
  if (folder.empty()) folder = ".";
  FileDescriptor directory{::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)};
  if (directory.fd >= 0) ::fsync(directory.fd);
}

// --- Reader ----------------------------------------------------------------------------------

struct ContainerReader::Impl {
  std::filesystem::path path;
  std::string format;
  Handle file;
  std::uint64_t file_bytes = 0;
  /// The descriptor the checksum was computed through: variable-length strings are read from it
  /// (see global_heap_text.hpp), never through HDF5's global heap code.
  FileDescriptor descriptor;
  detail::HeapFile heap;
  /// Every object of the file by its path, with a group's members sorted: built once at open by
  /// index_objects(), which refuses anything but a tree of groups and datasets joined by hard
  /// links. Later lookups never traverse the file's links again.
  struct Entry {
    ObjectKind kind = ObjectKind::kMissing;
    std::vector<std::string> children;
  };
  std::map<std::string, Entry, std::less<>> objects;

  [[nodiscard]] std::string name() const { return path.string(); }
  [[nodiscard]] const Entry* find(const std::string& object) const {
    const auto it = objects.find(object);
    return it == objects.end() ? nullptr : &it->second;
  }
  void index_objects();
};

/// Walks the file from the root, breadth-first, and builds `objects`. A hostile file could hold
/// a hard link back to an ancestor (a cycle a naive walk never leaves), a soft or external link
/// (to another object or another file), a second link to one object, a named datatype, or
/// millions of links; each is refused here, naming the link, so that every later walk is over a
/// finite tree.
void ContainerReader::Impl::index_objects() {
  const std::string file_name = name();
  H5O_info_t info{};
  if (H5Oget_info_by_name2(file.get(), "/", &info, H5O_INFO_BASIC | H5O_INFO_NUM_ATTRS,
                           H5P_DEFAULT) < 0) {
    throw FileError(file_name, "/", "cannot read the root group: " + hdf5_cause());
  }
  std::map<haddr_t, std::string> visited{{info.addr, "/"}};
  auto check_attributes = [&](const H5O_info_t& object, const std::string& object_path) {
    if (object.num_attrs > kMaxAttributesPerObject) {
      throw FileError(file_name, object_path,
                      std::to_string(object.num_attrs) + " attributes exceed the limit of " +
                          std::to_string(kMaxAttributesPerObject));
    }
  };
  check_attributes(info, "/");
  objects["/"].kind = ObjectKind::kGroup;
  std::vector<std::pair<std::string, std::size_t>> queue{{"/", 0}};
  for (std::size_t next = 0; next < queue.size(); ++next) {
    const auto [group_path, depth] = queue[next];
    Handle group(H5Gopen2(file.get(), group_path.c_str(), H5P_DEFAULT), H5Gclose);
    H5G_info_t group_info{};
    if (!group.valid() || H5Gget_info(group.get(), &group_info) < 0) {
      throw FileError(file_name, group_path, "cannot list group: " + hdf5_cause());
    }
    if (group_info.nlinks > kMaxLinksPerGroup) {
      throw FileError(file_name, group_path,
                      std::to_string(group_info.nlinks) + " members exceed the limit of " +
                          std::to_string(kMaxLinksPerGroup));
    }
    std::vector<std::string> children;
    for (hsize_t i = 0; i < group_info.nlinks; ++i) {
      const ssize_t length = H5Lget_name_by_idx(group.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i,
                                                nullptr, 0, H5P_DEFAULT);
      if (length <= 0 || static_cast<std::size_t>(length) > kMaxNameBytes) {
        throw FileError(file_name, group_path,
                        "member " + std::to_string(i) + " has no usable name (" +
                            (length < 0 ? hdf5_cause() : std::to_string(length) + " bytes") + ")");
      }
      std::string child(static_cast<std::size_t>(length) + 1, '\0');
      H5Lget_name_by_idx(group.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, child.data(),
                         child.size(), H5P_DEFAULT);
      child.resize(static_cast<std::size_t>(length));
      const std::string child_path = group_path == "/" ? "/" + child : group_path + "/" + child;
      if (child.find('\0') != std::string::npos || child == "." || child == "..") {
        throw FileError(file_name, child_path, "invalid member name");
      }
      H5L_info_t link{};
      if (H5Lget_info_by_idx(group.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, &link, H5P_DEFAULT) <
          0) {
        throw FileError(file_name, child_path, "cannot read link: " + hdf5_cause());
      }
      if (link.type != H5L_TYPE_HARD) {
        throw FileError(file_name, child_path,
                        link.type == H5L_TYPE_SOFT ? "a soft link (only hard links are allowed)"
                        : link.type == H5L_TYPE_EXTERNAL ? "an external link to another file"
                                                         : "a user-defined link");
      }
      H5O_info_t child_info{};
      if (H5Oget_info_by_idx2(group.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, &child_info,
                              H5O_INFO_BASIC | H5O_INFO_NUM_ATTRS, H5P_DEFAULT) < 0) {
        throw FileError(file_name, child_path, "cannot read object header: " + hdf5_cause());
      }
      if (const auto seen = visited.find(child_info.addr); seen != visited.end()) {
        throw FileError(file_name, child_path,
                        "links to '" + seen->second +
                            "' again (a link cycle or a shared object; a container is a tree)");
      }
      visited.emplace(child_info.addr, child_path);
      if (objects.size() >= kMaxObjects) {
        throw FileError(file_name, child_path,
                        "more than " + std::to_string(kMaxObjects) + " objects in the file");
      }
      check_attributes(child_info, child_path);
      Entry& entry = objects[child_path];
      if (child_info.type == H5O_TYPE_GROUP) {
        if (depth + 1 > kMaxDepth) {
          throw FileError(file_name, child_path,
                          "nested deeper than " + std::to_string(kMaxDepth) + " groups");
        }
        entry.kind = ObjectKind::kGroup;
        queue.emplace_back(child_path, depth + 1);
      } else if (child_info.type == H5O_TYPE_DATASET) {
        entry.kind = ObjectKind::kDataset;
      } else {
        throw FileError(file_name, child_path,
                        "unexpected object type (only groups and datasets are allowed)");
      }
      children.push_back(std::move(child));
    }
    std::sort(children.begin(), children.end());
    objects[group_path].children = std::move(children);
  }
}

ContainerReader::ContainerReader(const std::filesystem::path& path,
                                 std::string_view expected_format)
    : impl_(std::make_unique<Impl>()) {
  const ErrorSilencer silencer;
  impl_->path = path;
  const std::string file = path.string();

  FileDescriptor descriptor{::open(path.c_str(), O_RDONLY | O_CLOEXEC)};
  if (descriptor.fd < 0) throw FileError(file, "", "cannot open: " + errno_text());
  struct stat status {};
  if (::fstat(descriptor.fd, &status) != 0 || !S_ISREG(status.st_mode)) {
    throw FileError(file, "", "not a regular file");
  }
  impl_->file_bytes = static_cast<std::uint64_t>(status.st_size);
  std::array<char, kHeaderSize> block{};
  if (impl_->file_bytes < kHeaderSize ||
      ::pread(descriptor.fd, block.data(), block.size(), 0) != static_cast<ssize_t>(block.size())) {
    throw FileError(
        file, "",
        "truncated or not an immtrain container (" + std::to_string(impl_->file_bytes) + " bytes)");
  }
  Header header;
  if (const std::string problem = parse_header(block, header); !problem.empty()) {
    throw FileError(file, "", problem);
  }
  if (header.version > kContainerVersion || header.version < 1) {
    throw FileError(file, "",
                    "container version " + std::to_string(header.version) +
                        " is not supported by this reader (version " +
                        std::to_string(kContainerVersion) + ")");
  }
  if (header.payload_bytes != impl_->file_bytes - kHeaderSize) {
    throw FileError(file, "",
                    "truncated or extended: header says " +
                        std::to_string(header.payload_bytes + kHeaderSize) + " bytes, file has " +
                        std::to_string(impl_->file_bytes));
  }
  std::uint32_t crc = 0;
  if (!file_crc32(descriptor.fd, kHeaderSize, header.payload_bytes, crc)) {
    throw FileError(file, "", "cannot read: " + errno_text());
  }
  if (crc != header.payload_crc) {
    throw FileError(file, "",
                    "corrupt: payload checksum mismatch (stored " + hex32(header.payload_crc) +
                        ", computed " + hex32(crc) + ")");
  }
  impl_->format = header.format;
  if (!expected_format.empty() && header.format != expected_format) {
    throw FileError(file, "",
                    "holds a '" + header.format + "' container, expected '" +
                        std::string(expected_format) + "'");
  }
  // A strong close degree: closing the file closes whatever a failed HDF5 call left open in it,
  // so a refused file leaves no handle behind.
  Handle access_list(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(access_list.get(), H5F_CLOSE_STRONG);
  impl_->file = Handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY, access_list.get()), H5Fclose);
  if (!impl_->file.valid()) throw FileError(file, "", "cannot open as HDF5: " + hdf5_cause());
  Handle create_list(H5Fget_create_plist(impl_->file.get()), H5Pclose);
  hsize_t user_block = 0;
  std::size_t address_bytes = 0;
  std::size_t length_bytes = 0;
  if (!create_list.valid() || H5Pget_userblock(create_list.get(), &user_block) < 0 ||
      H5Pget_sizes(create_list.get(), &address_bytes, &length_bytes) < 0) {
    throw FileError(file, "", "cannot read the HDF5 superblock: " + hdf5_cause());
  }
  if (address_bytes != 8 || length_bytes != 8) {
    throw FileError(file, "",
                    "HDF5 addresses of " + std::to_string(address_bytes) + " and lengths of " +
                        std::to_string(length_bytes) + " bytes (a container uses 8 and 8)");
  }
  impl_->heap = {descriptor.fd, impl_->file_bytes, user_block};
  impl_->descriptor.fd = std::exchange(descriptor.fd, -1);
  impl_->index_objects();
}

ContainerReader::~ContainerReader() {
  if (impl_) {
    const ErrorSilencer silencer;
    impl_->file.reset();
  }
}

const std::filesystem::path& ContainerReader::path() const { return impl_->path; }

const std::string& ContainerReader::format() const { return impl_->format; }

ObjectKind ContainerReader::kind(std::string_view object) const {
  const Impl::Entry* entry = impl_->find(normalized(object));
  return entry == nullptr ? ObjectKind::kMissing : entry->kind;
}

std::vector<std::string> ContainerReader::children(std::string_view group) const {
  const std::string path = normalized(group);
  const Impl::Entry* entry = impl_->find(path);
  if (entry == nullptr || entry->kind != ObjectKind::kGroup) {
    throw FileError(impl_->name(), path, "missing group");
  }
  return entry->children;
}

std::vector<std::string> ContainerReader::objects() const {
  std::vector<std::string> paths;
  paths.reserve(impl_->objects.size());
  for (const auto& [path, entry] : impl_->objects) paths.push_back(path);
  return paths;
}

std::vector<std::size_t> ContainerReader::shape(std::string_view dataset) const {
  const ErrorSilencer silencer;
  const std::string path = normalized(dataset);
  if (kind(path) != ObjectKind::kDataset) throw FileError(impl_->name(), path, "missing dataset");
  Handle data(H5Dopen2(impl_->file.get(), path.c_str(), H5P_DEFAULT), H5Dclose);
  Handle space(H5Dget_space(data.get()), H5Sclose);
  const int rank = space.valid() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  if (rank < 1 || rank > static_cast<int>(kMaxRank)) {
    throw FileError(impl_->name(), path, "unsupported rank " + std::to_string(rank));
  }
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return {dims.begin(), dims.end()};
}

Array ContainerReader::read(std::string_view dataset) const {
  const ErrorSilencer silencer;
  const std::string path = normalized(dataset);
  const std::string file = impl_->name();
  Array array;
  array.shape = shape(path);
  // The allocation bound: a dataset may not declare more bytes of doubles than the whole file
  // holds. Containers store their data uncompressed, so a genuine dataset always fits; a hostile
  // header declaring a huge extent (or a sparse chunked dataset read as fill values) is refused
  // before anything is allocated.
  long double declared = sizeof(double);
  for (std::size_t extent : array.shape) declared *= static_cast<long double>(extent);
  if (declared > static_cast<long double>(impl_->file_bytes)) {
    char bytes[32];
    std::snprintf(bytes, sizeof bytes, "%.4Lg", declared);
    throw FileError(file, path,
                    std::string("declares ") + bytes + " bytes of data, more than the file's " +
                        std::to_string(impl_->file_bytes));
  }
  Handle data(H5Dopen2(impl_->file.get(), path.c_str(), H5P_DEFAULT), H5Dclose);
  Handle type(H5Dget_type(data.get()), H5Tclose);
  if (!type.valid() || H5Tget_class(type.get()) != H5T_FLOAT) {
    throw FileError(file, path, "expected floating-point data");
  }
  // HDF5 sizes its conversion and chunk buffers from the stored type and the chunk shape, not from
  // the extent: an IEEE single or double only, and chunks no larger than the file.
  const std::size_t type_bytes = H5Tget_size(type.get());
  if (type_bytes != 4 && type_bytes != 8) {
    throw FileError(file, path,
                    "floating-point data of " + std::to_string(type_bytes) +
                        " bytes per value (expected 4 or 8)");
  }
  Handle create_list(H5Dget_create_plist(data.get()), H5Pclose);
  if (create_list.valid() && H5Pget_layout(create_list.get()) == H5D_CHUNKED) {
    std::array<hsize_t, kMaxRank> chunk{};
    const int chunk_rank =
        H5Pget_chunk(create_list.get(), static_cast<int>(kMaxRank), chunk.data());
    long double chunk_bytes = static_cast<long double>(type_bytes);
    for (int d = 0; d < chunk_rank; ++d) chunk_bytes *= static_cast<long double>(chunk[d]);
    if (chunk_rank < 1 || chunk_rank > static_cast<int>(kMaxRank) ||
        chunk_bytes > static_cast<long double>(impl_->file_bytes)) {
      throw FileError(file, path, "declares chunks larger than the file");
    }
  }
  // The stored size (for chunks: the sum the chunk index records, which HDF5 allocates per chunk
  // before it checks the data) cannot exceed the file either.
  if (H5Dget_storage_size(data.get()) > impl_->file_bytes) {
    throw FileError(file, path, "declares more stored bytes than the file holds");
  }
  array.values.resize(array.element_count());
  if (!array.values.empty() && H5Dread(data.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                                       array.values.data()) < 0) {
    throw FileError(file, path, "cannot read data: " + hdf5_cause());
  }
  return array;
}

std::optional<Attribute> ContainerReader::attribute(std::string_view object,
                                                    std::string_view name) const {
  const ErrorSilencer silencer;
  const std::string path = normalized(object);
  const std::string field = field_path(object, name);
  const std::string file = impl_->name();
  if (kind(path) == ObjectKind::kMissing) return std::nullopt;
  const std::string attribute_name(name);
  if (attribute_name.empty() || attribute_name.size() > kMaxNameBytes) return std::nullopt;
  if (H5Aexists_by_name(impl_->file.get(), path.c_str(), attribute_name.c_str(), H5P_DEFAULT) <=
      0) {
    H5Eclear2(H5E_DEFAULT);
    return std::nullopt;
  }
  Handle handle(H5Aopen_by_name(impl_->file.get(), path.c_str(), attribute_name.c_str(),
                                H5P_DEFAULT, H5P_DEFAULT),
                H5Aclose);
  Handle space(H5Aget_space(handle.get()), H5Sclose);
  Handle type(H5Aget_type(handle.get()), H5Tclose);
  if (!handle.valid() || !space.valid() || !type.valid()) {
    throw FileError(file, field, "cannot open attribute: " + hdf5_cause());
  }
  if (H5Sget_simple_extent_npoints(space.get()) != 1) {
    throw FileError(file, field, "expected a scalar attribute");
  }
  switch (H5Tget_class(type.get())) {
    case H5T_INTEGER: {
      std::int64_t value = 0;
      if (H5Aread(handle.get(), H5T_NATIVE_INT64, &value) < 0) {
        throw FileError(file, field, "cannot read: " + hdf5_cause());
      }
      return Attribute{value};
    }
    case H5T_FLOAT: {
      double value = 0.0;
      if (H5Aread(handle.get(), H5T_NATIVE_DOUBLE, &value) < 0) {
        throw FileError(file, field, "cannot read: " + hdf5_cause());
      }
      return Attribute{value};
    }
    case H5T_STRING: {
      if (H5Tis_variable_str(type.get()) > 0) {
        // The stored reference, not followed by HDF5 (see global_heap_text.hpp).
        detail::DiskReference reference{};
        const Handle memory(detail::make_disk_reference_type(), H5Tclose);
        if (!memory.valid() || H5Aread(handle.get(), memory.get(), reference.data()) < 0) {
          throw FileError(file, field, "cannot read: " + hdf5_cause());
        }
        std::string value;
        std::string problem;
        if (!detail::read_global_heap_text(impl_->heap, reference, value, problem)) {
          throw FileError(file, field, problem);
        }
        return Attribute{value};
      }
      const std::size_t size = H5Tget_size(type.get());
      if (size == 0 || size > (std::size_t{1} << 24U)) {
        throw FileError(file, field, "implausible string size");
      }
      std::string value(size, '\0');
      if (H5Aread(handle.get(), type.get(), value.data()) < 0) {
        throw FileError(file, field, "cannot read: " + hdf5_cause());
      }
      value.resize(std::strlen(value.c_str()));
      return Attribute{value};
    }
    default:
      throw FileError(file, field, "unsupported attribute type");
  }
}

std::vector<std::string> ContainerReader::attribute_names(std::string_view object) const {
  const ErrorSilencer silencer;
  const std::string path = normalized(object);
  if (kind(path) == ObjectKind::kMissing) throw FileError(impl_->name(), path, "missing object");
  Handle handle = open_object(impl_->file.get(), path);
  if (!handle.valid()) throw FileError(impl_->name(), path, "cannot open: " + hdf5_cause());
  std::vector<std::string> names;
  hsize_t index = 0;
  H5Aiterate2(
      handle.get(), H5_INDEX_NAME, H5_ITER_INC, &index,
      [](hid_t, const char* name, const H5A_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
      },
      &names);
  return names;
}

}  // namespace imm::io
