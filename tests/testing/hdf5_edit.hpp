// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Editing the HDF5 payload of a container directly and resealing it: hostile content behind a
/// valid checksum (the container header format is public), for the drills against the readers.

#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cstring>
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

/// A text attribute of an object (fixed or variable length); "" when there is none.
inline std::string read_text_attribute(hid_t file, const std::string& object,
                                       const std::string& name) {
  if (H5Aexists_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT) <= 0) return {};
  const hid_t attribute =
      H5Aopen_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  const hid_t type = H5Aget_type(attribute);
  std::string text;
  if (H5Tget_class(type) == H5T_STRING) {
    if (H5Tis_variable_str(type) > 0) {
      char* raw = nullptr;
      H5Aread(attribute, type, &raw);
      text = raw != nullptr ? raw : "";
      H5free_memory(raw);
    } else {
      text.assign(H5Tget_size(type), '\0');
      H5Aread(attribute, type, text.data());
      text.resize(std::strlen(text.c_str()));
    }
  }
  H5Tclose(type);
  H5Aclose(attribute);
  return text;
}

/// A fixed-length text attribute.
inline void set_text_attribute(hid_t file, const std::string& object, const std::string& name,
                               const std::string& text);

/// Replaces a dataset by a float64 one of the given shape and values. The replacement keeps the
/// old dataset's description (schema version 2: units, columns, quantity), adapted to the new
/// shape (generic column names c0, c1, …, and one unit for all when the count no longer fits), so
/// that the readers' value rules — not the missing description — are what a drill meets.
inline void replace_dataset(hid_t file, const std::string& path, const std::vector<hsize_t>& dims,
                            const std::vector<double>& values) {
  std::string units = read_text_attribute(file, path, "units");
  std::string columns = read_text_attribute(file, path, "columns");
  const std::string quantity = read_text_attribute(file, path, "quantity");
  H5Ldelete(file, path.c_str(), H5P_DEFAULT);
  add_dataset(file, path, H5T_NATIVE_DOUBLE, dims, values.data());
  const auto count = [](const std::string& list) {
    return static_cast<hsize_t>(std::count(list.begin(), list.end(), ',') + 1);
  };
  if (dims.size() == 2 && !columns.empty() && count(columns) != dims[1]) {
    columns.clear();
    for (hsize_t c = 0; c < dims[1]; ++c) columns += (c == 0 ? "c" : ",c") + std::to_string(c);
  }
  const hsize_t entries = dims.size() == 2 ? dims[1] : (dims.empty() ? 1 : dims[0]);
  if (!units.empty() && count(units) != 1 && count(units) != entries) {
    units = units.substr(0, units.find(','));
  }
  if (!units.empty()) set_text_attribute(file, path, "units", units);
  if (dims.size() == 2 && !columns.empty()) set_text_attribute(file, path, "columns", columns);
  if (!quantity.empty()) set_text_attribute(file, path, "quantity", quantity);
}

/// Replaces (or adds) an attribute: a scalar of `type` from `value`, or a 1-D array of `count`.
inline void set_attribute(hid_t file, const std::string& object, const std::string& name,
                          hid_t type, const void* value, hsize_t count = 0) {
  const hid_t handle = H5Oopen(file, object.c_str(), H5P_DEFAULT);
  if (H5Aexists(handle, name.c_str()) > 0) H5Adelete(handle, name.c_str());
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
