// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The hostile-HDF5 drill shared by the model-file and data-set-file tests: every mutation of a
/// container's payload that a reader must survive — link cycles (hard and soft), external links,
/// second links to one object, named datatypes, wrong object types at every path, huge declared
/// extents, wrong attribute types and absurd attribute values. Apply each with edit_and_reseal.

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "imm/io/container_file.hpp"
#include "testing/hdf5_edit.hpp"

namespace imm::testing {

struct Layout {
  std::vector<std::string> groups, datasets;
  std::vector<std::pair<std::string, std::string>> attributes;  // object, name
};

/// The groups, datasets and attributes of a container.
inline Layout layout_of(const std::filesystem::path& path) {
  const io::ContainerReader reader(path, "");
  Layout layout;
  for (const std::string& object : reader.objects()) {
    (reader.kind(object) == io::ObjectKind::kGroup ? layout.groups : layout.datasets)
        .push_back(object);
    for (const std::string& name : reader.attribute_names(object)) {
      layout.attributes.emplace_back(object, name);
    }
  }
  return layout;
}

struct Mutation {
  std::string name;
  std::function<void(hid_t)> apply;
  bool structural = false;  ///< breaks the tree of hard links: must always be refused
};

/// Every mutation of the drill for a file of this layout.
inline std::vector<Mutation> mutations_of(const Layout& layout) {
  std::vector<Mutation> drills;
  for (const std::string& group : layout.groups) {
    drills.push_back({"hard link to the root in " + group,
                      [group](hid_t f) {
                        H5Lcreate_hard(f, "/", f, child_path(group, "loop").c_str(), H5P_DEFAULT,
                                       H5P_DEFAULT);
                      },
                      true});
    drills.push_back({"hard link to itself in " + group,
                      [group](hid_t f) {
                        H5Lcreate_hard(f, group.c_str(), f, child_path(group, "self").c_str(),
                                       H5P_DEFAULT, H5P_DEFAULT);
                      },
                      true});
    drills.push_back({"soft link to the root in " + group,
                      [group](hid_t f) {
                        H5Lcreate_soft("/", f, child_path(group, "loop").c_str(), H5P_DEFAULT,
                                       H5P_DEFAULT);
                      },
                      true});
    drills.push_back({"soft link cycle in " + group,
                      [group](hid_t f) {
                        H5Lcreate_soft(child_path(group, "b").c_str(), f,
                                       child_path(group, "a").c_str(), H5P_DEFAULT, H5P_DEFAULT);
                        H5Lcreate_soft(child_path(group, "a").c_str(), f,
                                       child_path(group, "b").c_str(), H5P_DEFAULT, H5P_DEFAULT);
                      },
                      true});
    drills.push_back({"external link in " + group,
                      [group](hid_t f) {
                        H5Lcreate_external("/etc/hostname", "/", f,
                                           child_path(group, "ext").c_str(), H5P_DEFAULT,
                                           H5P_DEFAULT);
                      },
                      true});
    drills.push_back({"named datatype in " + group,
                      [group](hid_t f) {
                        const hid_t type = H5Tcopy(H5T_NATIVE_DOUBLE);
                        H5Tcommit2(f, child_path(group, "type").c_str(), type, H5P_DEFAULT,
                                   H5P_DEFAULT, H5P_DEFAULT);
                        H5Tclose(type);
                      },
                      true});
    if (group != "/") {
      drills.push_back({"dataset instead of group " + group, [group](hid_t f) {
                          H5Ldelete(f, group.c_str(), H5P_DEFAULT);
                          const double value = 1.0;
                          add_dataset(f, group, H5T_NATIVE_DOUBLE, {1}, &value);
                        }});
    }
  }
  for (const std::string& dataset : layout.datasets) {
    const auto replace = [dataset](std::function<void(hid_t)> add) {
      return [dataset, add](hid_t f) {
        H5Ldelete(f, dataset.c_str(), H5P_DEFAULT);
        add(f);
      };
    };
    drills.push_back({"group instead of dataset " + dataset, replace([dataset](hid_t f) {
                        H5Gclose(
                            H5Gcreate2(f, dataset.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
                      })});
    drills.push_back({"integers in " + dataset, replace([dataset](hid_t f) {
                        const std::vector<int> values(6, 1);
                        add_dataset(f, dataset, H5T_NATIVE_INT, {2, 3}, values.data());
                      })});
    drills.push_back({"text in " + dataset, replace([dataset](hid_t f) {
                        const hid_t type = H5Tcopy(H5T_C_S1);
                        H5Tset_size(type, 4);
                        add_dataset(f, dataset, type, {2}, "abcdefgh");
                        H5Tclose(type);
                      })});
    drills.push_back({"scalar " + dataset, replace([dataset](hid_t f) {
                        const double value = 1.0;
                        add_dataset(f, dataset, H5T_NATIVE_DOUBLE, {}, &value);
                      })});
    drills.push_back({"empty " + dataset, replace([dataset](hid_t f) {
                        add_dataset(f, dataset, H5T_NATIVE_DOUBLE, {0, 5}, nullptr);
                      })});
    drills.push_back(
        {"huge declared " + dataset, replace([dataset](hid_t f) {
           add_dataset(f, dataset, H5T_NATIVE_DOUBLE, {hsize_t{1} << 40U, 5}, nullptr, true);
         })});
    if (const std::string& first = layout.datasets.front(); dataset != first) {
      drills.push_back({"second link to " + first + " as " + dataset,
                        [dataset, first](hid_t f) {
                          H5Ldelete(f, dataset.c_str(), H5P_DEFAULT);
                          H5Lcreate_hard(f, first.c_str(), f, dataset.c_str(), H5P_DEFAULT,
                                         H5P_DEFAULT);
                        },
                        true});
    }
  }
  for (const auto& attribute : layout.attributes) {
    // Named copies: lambdas capture them (a structured binding is not capturable before C++20's
    // P1091, which Clang 14 lacks).
    const std::string object = attribute.first;
    const std::string name = attribute.second;
    const std::string where = object + "@" + name;
    drills.push_back({"number for " + where, [object, name](hid_t f) {
                        const double value = 0.5;
                        set_attribute(f, object, name, H5T_NATIVE_DOUBLE, &value);
                      }});
    drills.push_back({"text for " + where, [object, name](hid_t f) {
                        testing::set_text_attribute(f, object, name, "abc");
                      }});
    drills.push_back({"array for " + where, [object, name](hid_t f) {
                        const double values[2] = {1.0, 2.0};
                        set_attribute(f, object, name, H5T_NATIVE_DOUBLE, values, 2);
                      }});
    // (The smallest subnormal and counts written as reals: HostileModelFile.EveryNumberIs…)
    for (const double value : {0.0, -1.0, 1e-320, 1e308, std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::infinity()}) {
      drills.push_back(
          {"value " + std::to_string(value) + " for " + where, [object, name, value](hid_t f) {
             set_attribute(f, object, name, H5T_NATIVE_DOUBLE, &value);
           }});
    }
    drills.push_back({"integer -1 for " + where, [object, name](hid_t f) {
                        const std::int64_t value = -1;
                        set_attribute(f, object, name, H5T_NATIVE_INT64, &value);
                      }});
    drills.push_back({"integer 2^62 for " + where, [object, name](hid_t f) {
                        const std::int64_t value = std::int64_t{1} << 62U;
                        set_attribute(f, object, name, H5T_NATIVE_INT64, &value);
                      }});
  }
  return drills;
}

}  // namespace imm::testing
