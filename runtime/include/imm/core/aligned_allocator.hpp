// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// An allocator whose blocks start on an `Alignment`-byte boundary, for the banks' lane storage:
/// a 64-byte vector load at a 64-byte boundary reads one cache line, elsewhere two.
/// (Eigen::aligned_allocator aligns to EIGEN_MAX_ALIGN_BYTES, which is 16 in a library compiled
/// for the baseline instruction set.)

#include <cstddef>
#include <new>

namespace imm {

/// std::allocator with every block aligned to `Alignment` bytes (a power of two).
template <class T, std::size_t Alignment = 64>
struct AlignedAllocator {
  static_assert(Alignment >= alignof(T) && (Alignment & (Alignment - 1)) == 0,
                "the alignment is a power of two, at least the type's");
  /// What it allocates.
  using value_type = T;
  /// The same allocator for another type (the standard's allocator requirements).
  template <class U>
  struct rebind {  // NOLINT(readability-identifier-naming): the requirements' name
    /// The allocator of U.
    using other = AlignedAllocator<U, Alignment>;
  };

  /// Stateless.
  AlignedAllocator() = default;
  /// From the allocator of another type (stateless: nothing to copy).
  template <class U>
  explicit AlignedAllocator(const AlignedAllocator<U, Alignment>& /*other*/) noexcept {}

  /// Room for `n` T at an `Alignment`-byte boundary; std::bad_alloc when there is none.
  [[nodiscard]] T* allocate(std::size_t n) {
    return static_cast<T*>(::operator new (n * sizeof(T), std::align_val_t{Alignment}));
  }
  /// Returns what allocate() gave.
  void deallocate(T* p, std::size_t /*n*/) noexcept {
    ::operator delete (p, std::align_val_t{Alignment});
  }

  /// Any two are interchangeable.
  template <class U>
  bool operator==(const AlignedAllocator<U, Alignment>& /*other*/) const noexcept {
    return true;
  }
};

}  // namespace imm
