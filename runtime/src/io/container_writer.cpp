// SPDX-License-Identifier: Apache-2.0
// ContainerWriter: a container written to a temporary beside its target, sealed, renamed.
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <utility>
#include <variant>

#include "container_format.hpp"
#include "imm/io/temporary_files.hpp"

namespace imm::io {

using namespace container;  // NOLINT(google-build-using-namespace): the format's own internals

namespace {

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

void skip_hdf5_shutdown_at_exit() { (void)H5dont_atexit(); }

// --- Writer ----------------------------------------------------------------------------------

struct ContainerWriter::Impl {
  std::filesystem::path final_path;
  std::filesystem::path temp_path;  ///< ".<name>.tmp-<pid>-<n>@<host>" beside the target
  bool temp_exists = false;
  std::string format;
  Handle file;
  bool committed = false;

  [[nodiscard]] std::string name() const { return final_path.string(); }
};

namespace {

/// Removes what writers killed while writing left in `folder` (SIGKILL runs no destructor): the
/// temporaries of this host whose process no longer exists (imm/io/temporary_files.hpp).
void remove_stale_temporaries(const std::filesystem::path& folder) {
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    if (is_stale_temporary(entry.path().filename().string())) {
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
  impl_->temp_path = folder / temporary_beside(path, counter++).filename();
  // HDF5 needs a path to create its file (it resolves the name, so an unnamed O_TMPFILE behind
  // /proc/self/fd cannot serve), hence a hidden named file in the destination folder. A process
  // killed while it exists (SIGKILL runs no destructor) leaves it; the next writer in the same
  // folder removes it (remove_stale_temporaries above).
  impl_->temp_exists = true;

  Handle create_list(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  H5Pset_userblock(create_list.get(), kHeaderSize);
  // No object times (HDF5 records them by default): the same content gives the same bytes, so a
  // file rewritten with nothing new keeps its SHA-256 (the registry's "unchanged").
  H5Pset_obj_track_times(create_list.get(), 0);
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
  // Each missing ancestor in turn, every one without object times (see the constructor).
  Handle group_list(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_obj_track_times(group_list.get(), 0);
  for (std::size_t end = name.find('/', 1);; end = name.find('/', end + 1)) {
    const std::string prefix = name.substr(0, end);
    if (!link_exists(impl_->file.get(), prefix)) {
      Handle created(
          H5Gcreate2(impl_->file.get(), prefix.c_str(), H5P_DEFAULT, group_list.get(), H5P_DEFAULT),
          H5Gclose);
      if (!created.valid()) {
        throw FileError(impl_->name(), prefix, "cannot create group: " + hdf5_cause());
      }
    }
    if (end == std::string::npos) break;
  }
}

void ContainerWriter::write(std::string_view dataset, const Eigen::MatrixXd& matrix) {
  write(dataset, Array::from_matrix(matrix));
}

void ContainerWriter::write(std::string_view dataset, const Array& array, Values values) {
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
  const bool missing = values == Values::kFiniteOrMissing;
  for (std::size_t i = 0; i < array.values.size(); ++i) {
    if (!std::isfinite(array.values[i]) && !(missing && std::isnan(array.values[i]))) {
      throw FileError(file, name,
                      "refusing to write non-finite value at flat index " + std::to_string(i));
    }
  }
  const int rank = static_cast<int>(array.shape.size());
  std::vector<hsize_t> dims(array.shape.begin(), array.shape.end());
  Handle space(H5Screate_simple(rank, dims.data(), nullptr), H5Sclose);
  Handle create_list(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_obj_track_times(create_list.get(), 0);
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
  if (const std::size_t slash = name.rfind('/'); slash > 0 && slash != std::string::npos) {
    create_group(name.substr(0, slash));
  }
  // A later write of the same dataset replaces the earlier one, as set_attribute does.
  if (link_exists(impl_->file.get(), name) &&
      H5Ldelete(impl_->file.get(), name.c_str(), H5P_DEFAULT) < 0) {
    throw FileError(file, name, "cannot replace dataset: " + hdf5_cause());
  }
  Handle data(H5Dcreate2(impl_->file.get(), name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
                         create_list.get(), H5P_DEFAULT),
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

}  // namespace imm::io
