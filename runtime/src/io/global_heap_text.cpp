// SPDX-License-Identifier: Apache-2.0
#include "global_heap_text.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <mutex>
#include <string_view>
#include <vector>

namespace imm::io::detail {
namespace {

constexpr char kReferenceTag[] = "immtrain: variable-length string reference, not followed";

/// A global heap collection: "GCOL", version 1, 3 reserved bytes, its size (8 bytes, including
/// this header); then objects, each with a header of index (2), reference count (2), reserved (4)
/// and size (8), its data padded to a multiple of 8; index 0 is the free space that ends it.
constexpr std::size_t kCollectionHeaderBytes = 16;
constexpr std::size_t kObjectHeaderBytes = 16;

/// Identity conversion from a variable-length string's stored reference to `kReferenceTag`'s
/// opaque type: the attribute's bytes already are the reference, and staying in place is all
/// there is to do. Declines (so HDF5 looks further) for any other pair of types.
herr_t keep_reference(hid_t source, hid_t destination, H5T_cdata_t* data, std::size_t /*count*/,
                      std::size_t /*buffer_stride*/, std::size_t /*background_stride*/,
                      void* /*buffer*/, void* /*background*/, hid_t /*transfer_list*/) {
  switch (data->command) {
    case H5T_CONV_INIT: {
      if (H5Tis_variable_str(source) <= 0 || H5Tget_class(destination) != H5T_OPAQUE ||
          H5Tget_size(source) != kDiskReferenceBytes ||
          H5Tget_size(destination) != kDiskReferenceBytes) {
        return -1;
      }
      char* tag = H5Tget_tag(destination);
      const bool ours = tag != nullptr && std::string_view(tag) == kReferenceTag;
      H5free_memory(tag);
      if (!ours) return -1;
      data->need_bkg = H5T_BKG_NO;
      return 0;
    }
    case H5T_CONV_CONV:
    case H5T_CONV_FREE:
      return 0;
  }
  return -1;
}

std::uint64_t little_endian(const std::uint8_t* bytes, std::size_t count) {
  std::uint64_t value = 0;
  for (std::size_t i = count; i-- > 0;) value = (value << 8U) | bytes[i];
  return value;
}

bool read_at(int fd, std::uint64_t offset, std::uint8_t* into, std::size_t count) {
  std::size_t done = 0;
  while (done < count) {
    const ssize_t got = ::pread(fd, into + done, count - done, static_cast<off_t>(offset + done));
    if (got <= 0) return false;
    done += static_cast<std::size_t>(got);
  }
  return true;
}

}  // namespace

hid_t make_disk_reference_type() {
  static const bool registered = [] {
    const hid_t string = H5Tcopy(H5T_C_S1);
    H5Tset_size(string, H5T_VARIABLE);
    const hid_t opaque = H5Tcreate(H5T_OPAQUE, kDiskReferenceBytes);
    const bool done = H5Tregister(H5T_PERS_SOFT, "immtrain_keep_vlen_reference", string, opaque,
                                  keep_reference) >= 0;
    H5Tclose(opaque);
    H5Tclose(string);
    return done;
  }();
  if (!registered) return H5I_INVALID_HID;
  const hid_t type = H5Tcreate(H5T_OPAQUE, kDiskReferenceBytes);
  H5Tset_tag(type, kReferenceTag);
  return type;
}

bool read_global_heap_text(const HeapFile& heap, const DiskReference& reference, std::string& text,
                           std::string& problem) {
  const auto length = static_cast<std::uint32_t>(little_endian(reference.data(), 4));
  const std::uint64_t address = little_endian(reference.data() + 4, 8);
  const auto index = static_cast<std::uint32_t>(little_endian(reference.data() + 12, 4));
  text.clear();
  if (length == 0) return true;  // an empty string names no heap object
  if (length > kMaxTextBytes) {
    problem = "implausible string size " + std::to_string(length);
    return false;
  }
  if (index == 0 || index > 0xFFFFU) {
    problem = "string names heap object " + std::to_string(index) + " (valid: 1 to 65535)";
    return false;
  }
  if (address >= heap.file_bytes || heap.base >= heap.file_bytes - address ||
      heap.file_bytes - (heap.base + address) < kCollectionHeaderBytes) {
    problem = "string's heap collection lies outside the file";
    return false;
  }
  const std::uint64_t start = heap.base + address;
  std::uint8_t header[kCollectionHeaderBytes];
  if (!read_at(heap.fd, start, header, sizeof header)) {
    problem = "cannot read the string's heap collection";
    return false;
  }
  if (std::memcmp(header, "GCOL", 4) != 0 || header[4] != 1) {
    problem = "string's heap address holds no global heap collection";
    return false;
  }
  const std::uint64_t size = little_endian(header + 8, 8);
  if (size < kCollectionHeaderBytes || size > heap.file_bytes - start) {
    problem = "heap collection of " + std::to_string(size) + " bytes does not fit the file";
    return false;
  }
  std::vector<std::uint8_t> collection(static_cast<std::size_t>(size));
  if (!read_at(heap.fd, start, collection.data(), collection.size())) {
    problem = "cannot read the string's heap collection";
    return false;
  }
  // Every step moves forward by at least one object header, so the walk ends.
  std::size_t at = kCollectionHeaderBytes;
  while (collection.size() - at >= kObjectHeaderBytes) {
    const std::uint8_t* object = collection.data() + at;
    const auto object_index = static_cast<std::uint32_t>(little_endian(object, 2));
    const std::uint64_t object_size = little_endian(object + 8, 8);
    if (object_index == 0) break;  // the free space: no object follows
    const std::size_t room = collection.size() - at - kObjectHeaderBytes;
    if (object_size > room) {
      problem = "heap object " + std::to_string(object_index) + " of " +
                std::to_string(object_size) + " bytes overruns its collection";
      return false;
    }
    if (object_index == index) {
      if (object_size != length) {
        problem = "string of " + std::to_string(length) + " bytes names a heap object of " +
                  std::to_string(object_size);
        return false;
      }
      const auto* characters = reinterpret_cast<const char*>(object + kObjectHeaderBytes);
      if (std::memchr(characters, '\0', length) != nullptr) {
        problem = "text holds a NUL character";
        return false;
      }
      text.assign(characters, length);
      return true;
    }
    const std::uint64_t padded = (object_size + 7U) & ~std::uint64_t{7U};
    at += kObjectHeaderBytes + static_cast<std::size_t>(std::min<std::uint64_t>(padded, room));
  }
  problem = "string names heap object " + std::to_string(index) + ", which its collection lacks";
  return false;
}

}  // namespace imm::io::detail
