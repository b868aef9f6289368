// SPDX-License-Identifier: Apache-2.0
// Variable-length strings of a file that may be hostile, read without HDF5's global heap code.
//
// HDF5 1.10 keeps the characters of a variable-length string in a "global heap collection" and
// stores, in the attribute, a reference: (length: u32, collection address, object index: u32).
// Its own reader trusts that reference and the collection: it sizes the destination by the
// reference's length but copies the heap object's size into it, indexes the object table without
// a bound, and loops forever on a free-space object of size 0 (all found by fuzzing a sealed model
// file). So the container reader never lets HDF5 follow the reference: it reads the reference's
// bytes through a conversion that copies them untouched (`make_disk_reference_type()`), and
// `read_global_heap_text` finds the characters itself, every offset bounded by the file.
#pragma once

#include <hdf5.h>

#include <array>
#include <cstdint>
#include <string>

namespace imm::io::detail {

/// Bytes of the on-disk reference of one variable-length string when addresses and lengths are
/// 8 bytes (the only layout the container reader accepts): length 4, address 8, index 4.
inline constexpr std::size_t kDiskReferenceBytes = 16;

/// The raw bytes of one variable-length string reference, as stored in the file.
using DiskReference = std::array<std::uint8_t, kDiskReferenceBytes>;

/// A new opaque 16-byte memory type (the caller closes it) into which `H5Aread` copies a
/// variable-length string attribute's stored reference without following it: a conversion
/// registered once, process-wide, for this type only (its tag names it; every other conversion is
/// left to HDF5). H5I_INVALID_HID when HDF5 refused the registration.
hid_t make_disk_reference_type();

/// Where a file's global heap lives and how far it may reach.
struct HeapFile {
  int fd = -1;                   ///< open descriptor of the whole file
  std::uint64_t file_bytes = 0;  ///< the file's size: no read goes past it
  std::uint64_t base = 0;        ///< the HDF5 base address (the user block's size)
};

/// The longest text a reference may name (the same bound as a fixed-length string's).
inline constexpr std::uint32_t kMaxTextBytes = 1U << 24U;

/// The characters `reference` names, read from the collection at its address with every offset
/// checked against the collection and the file; on a malformed reference or collection, returns
/// false and says why in `problem` (nothing is allocated beyond the file's own size).
bool read_global_heap_text(const HeapFile& heap, const DiskReference& reference, std::string& text,
                           std::string& problem);

}  // namespace imm::io::detail
