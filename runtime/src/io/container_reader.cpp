// SPDX-License-Identifier: Apache-2.0
// ContainerReader: a container checked whole at open (header, checksums, a finite tree of
// groups and datasets), then read by path.
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <map>
#include <utility>

#include "container_format.hpp"
#include "global_heap_text.hpp"
#include "imm/core/invalid_parameter.hpp"

namespace imm::io {

using namespace container;  // NOLINT(google-build-using-namespace): the format's own internals

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
      std::string child_path = group_path == "/" ? std::string() : group_path;
      child_path.append("/").append(child);
      if (child.find('\0') != std::string::npos || child == "." || child == ".." ||
          !usable_name(child)) {
        throw FileError(file_name, group_path,
                        "member name '" + escaped_name(child) +
                            "' is not a name (1 to 256 bytes, no control characters)");
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
                    "holds a '" + printable(header.format) + "' container, expected '" +
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
    // Every chunk as the index records it: HDF5's Fletcher-32 filter reads the checksum from the
    // chunk's last 4 bytes without checking that the chunk has them (a chunk recorded as shorter
    // reads before its buffer), and no chunk can hold more than the file.
    const Handle space(H5Dget_space(data.get()), H5Sclose);
    hsize_t chunks = 0;
    if (!space.valid() || H5Dget_num_chunks(data.get(), space.get(), &chunks) < 0) {
      throw FileError(file, path, "cannot index its chunks: " + hdf5_cause());
    }
    for (hsize_t i = 0; i < chunks; ++i) {
      std::array<hsize_t, kMaxRank> offset{};
      unsigned filter_mask = 0;
      haddr_t address = 0;
      hsize_t stored = 0;
      if (H5Dget_chunk_info(data.get(), space.get(), i, offset.data(), &filter_mask, &address,
                            &stored) < 0) {
        throw FileError(file, path, "cannot read chunk " + std::to_string(i) + "'s index entry");
      }
      if (stored < 4 || stored > impl_->file_bytes) {
        throw FileError(file, path,
                        "chunk " + std::to_string(i) + " is recorded as " + std::to_string(stored) +
                            " bytes (at least its 4-byte checksum, at "
                            "most the file)");
      }
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
  // A walk that fails, or finds fewer attributes than the object header counts (a corrupt
  // attribute index), is an error: a reader that silently drops attributes would let --verify
  // say "ok" about a file that does not read whole.
  const herr_t walked = H5Aiterate2(
      handle.get(), H5_INDEX_NAME, H5_ITER_INC, &index,
      [](hid_t, const char* name, const H5A_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
      },
      &names);
  if (walked < 0) {
    throw FileError(impl_->name(), path, "cannot list the attributes: " + hdf5_cause());
  }
  H5O_info_t info{};
  if (H5Oget_info2(handle.get(), &info, H5O_INFO_NUM_ATTRS) < 0) {
    throw FileError(impl_->name(), path, "cannot read the object header: " + hdf5_cause());
  }
  if (info.num_attrs != names.size()) {
    throw FileError(impl_->name(), path,
                    "the attribute index lists " + std::to_string(names.size()) + " of " +
                        std::to_string(info.num_attrs) + " attributes");
  }
  for (const std::string& name : names) {
    if (!usable_name(name)) {
      throw FileError(impl_->name(), path,
                      "attribute name '" + escaped_name(name) +
                          "' is not a name (1 to 256 bytes, no control characters)");
    }
  }
  return names;
}

}  // namespace imm::io
