// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Editing the HDF5 payload of a container directly and resealing it: hostile content behind a
/// valid checksum (the container header format is public), for the drills against the readers.

#include <gtest/gtest.h>
#include <hdf5.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "imm/io/container_file.hpp"

namespace imm::testing {

/// Opens the file read-write, applies `edit`, closes and reseals it as a container of `format`.
inline void edit_and_reseal(const std::filesystem::path& path,
                            const std::function<void(hid_t)>& edit,
                            std::string_view format = "immtrain-model") {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0) << path;
  edit(file);
  ASSERT_GE(H5Fclose(file), 0) << path;
  io::seal_container(path, format);
}

/// "/a" + "b" → "/a/b"; "/" + "b" → "/b".
inline std::string child_path(const std::string& group, const std::string& name) {
  return group == "/" ? "/" + name : group + "/" + name;
}

/// Creates a dataset of `type` (a scalar when `dims` is empty), writing `data` when given;
/// `chunked` leaves an unwritten chunked dataset unallocated, whatever extent it declares.
inline void add_dataset(hid_t file, const std::string& path, hid_t type,
                        const std::vector<hsize_t>& dims, const void* data, bool chunked = false) {
  const hid_t space = dims.empty()
                          ? H5Screate(H5S_SCALAR)
                          : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t create = H5Pcreate(H5P_DATASET_CREATE);
  if (chunked) {
    const std::vector<hsize_t> chunk(dims.size(), 1);
    H5Pset_chunk(create, static_cast<int>(chunk.size()), chunk.data());
  }
  const hid_t dataset =
      H5Dcreate2(file, path.c_str(), type, space, H5P_DEFAULT, create, H5P_DEFAULT);
  if (data != nullptr) H5Dwrite(dataset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  H5Dclose(dataset);
  H5Pclose(create);
  H5Sclose(space);
}

/// Replaces a dataset by a float64 one of the given shape and values.
inline void replace_dataset(hid_t file, const std::string& path, const std::vector<hsize_t>& dims,
                            const std::vector<double>& values) {
  H5Ldelete(file, path.c_str(), H5P_DEFAULT);
  add_dataset(file, path, H5T_NATIVE_DOUBLE, dims, values.data());
}

/// Replaces (or adds) an attribute: a scalar of `type` from `value`, or a 1-D array of `count`.
inline void set_attribute(hid_t file, const std::string& object, const std::string& name,
                          hid_t type, const void* value, hsize_t count = 0) {
  const hid_t handle = H5Oopen(file, object.c_str(), H5P_DEFAULT);
  H5Adelete(handle, name.c_str());
  const hid_t space = count == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &count, nullptr);
  const hid_t attribute = H5Acreate2(handle, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attribute, type, value);
  H5Aclose(attribute);
  H5Sclose(space);
  H5Oclose(handle);
}

/// A fixed-length text attribute.
inline void set_text_attribute(hid_t file, const std::string& object, const std::string& name,
                               const std::string& text) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, std::max<std::size_t>(text.size(), 1));
  set_attribute(file, object, name, type, text.c_str());
  H5Tclose(type);
}

}  // namespace imm::testing
