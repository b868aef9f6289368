// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Places a mode's N-dimensional state inside the IMM's NX-dimensional mixing space. IMM modes may
/// have different state dimensions (CV with 4 states beside Singer with 6, seed 004); the IMM
/// mixes and combines in the larger space, where a mode's missing components are zero with zero
/// (co)variance ("zero padding"), and each mode takes back its own components.

#include <array>
#include <stdexcept>
#include <string>

#include "imm/estimation/gaussian_state.hpp"

namespace imm {

/// How a mode's N states sit in the NX-state mixing space: an index per mode state (see the file
/// comment).
template <int N, int NX>
class StateEmbedding {
  static_assert(N <= NX, "a mode cannot have more states than the mixing space");

 public:
  /// Identity embedding (N == NX).
  StateEmbedding() : identity_(true) {
    static_assert(N == NX, "a lower-dimensional mode needs explicit indices");
    for (int i = 0; i < N; ++i) indices_[static_cast<std::size_t>(i)] = i;
  }

  /// `indices[i]` is the mixing-space component that holds the mode's component i.
  explicit StateEmbedding(const std::array<int, N>& indices) : indices_(indices) {
    std::array<bool, NX> used{};
    for (int index : indices_) {
      if (index < 0 || index >= NX || used[static_cast<std::size_t>(index)]) {
        throw std::invalid_argument("state embedding index " + std::to_string(index) +
                                    " is out of range or repeated (mixing dimension " +
                                    std::to_string(NX) + ")");
      }
      used[static_cast<std::size_t>(index)] = true;
    }
    identity_ = N == NX;
    for (int i = 0; i < N; ++i) identity_ = identity_ && index(i) == i;
  }

  /// Mode → mixing space, zero-padded.
  void embed(const GaussianState<N>& state, Vector<NX>& mean, SquareMatrix<NX>& covariance) const {
    if constexpr (N == NX) {
      if (identity_) {
        mean = state.mean;
        covariance = state.covariance;
        return;
      }
    }
    mean.setZero();
    covariance.setZero();
    for (int i = 0; i < N; ++i) {
      const int a = index(i);
      mean(a) = state.mean(i);
      for (int j = 0; j < N; ++j) covariance(a, index(j)) = state.covariance(i, j);
    }
  }

  /// Mixing space → mode: the mode's own components and their covariance block.
  [[nodiscard]] GaussianState<N> project(const GaussianState<NX>& state) const {
    if constexpr (N == NX) {
      if (identity_) return state;
    }
    GaussianState<N> projected;
    for (int i = 0; i < N; ++i) {
      const int a = index(i);
      projected.mean(i) = state.mean(a);
      for (int j = 0; j < N; ++j) projected.covariance(i, j) = state.covariance(a, index(j));
    }
    return projected;
  }

  /// The mixing-space index of mode state i.
  [[nodiscard]] int index(int i) const { return indices_[static_cast<std::size_t>(i)]; }

 private:
  std::array<int, N> indices_{};
  bool identity_ = false;
};

}  // namespace imm
