// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The GA's IMM fitness (evaluate_imm) as a batch: every one-axis trajectory of a training set is
/// a lane of a structure-of-arrays GA-fuzzy IMM (fuzzy-noise CV modes, the 1-D position plot), and
/// a genome's evaluation steps all of them scan by scan, a block of lanes at a time, in loops over
/// lanes that the compiler vectorizes (AVX-512 or AVX2 chosen at run time, no FMA, so every
/// instruction set and thread count gives the same bits).
///
/// It computes what the runtime's ImmEstimator<2, 1> of build_ga_fuzzy_axis_imm computes: the
/// same mixing, fuzzy inference and Joseph update, in the same order. Two things differ, both
/// within rounding: exp is lane_exp (lane_math.hpp, within 2 ulp of libm's), and the mode
/// probabilities are kept linear and normalized every scan, μ_j ∝ c_j N(r_j; 0, S_j) with each
/// likelihood's exponent taken relative to the largest — the runtime's log-space posterior without
/// its logarithms (n exponentials per scan instead of 2n exponentials and 2n + 1 logarithms). The
/// figures agree with evaluate_imm's to 10⁻¹² relative (tested); the GA ranks genomes by them,
/// and the trainer scores the tables it keeps with the runtime filter itself (evaluate_table,
/// evaluate_imm), so the figures a model ships with are the runtime's.
///
/// Memory: the plots and truth are laid out once per set; an evaluation uses a per-thread
/// workspace that grows to the largest spec and then allocates nothing.

#include <vector>

#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/trainer/training_set.hpp"

namespace imm::trainer::ga {

/// What one run of a GA-fuzzy IMM over a set gives: the sums eq. (17) needs and seed 000's ζ.
struct ImmRunErrors {
  bool failed = false;                ///< a step failed on some trajectory
  double position_abs_sum = 0.0;      ///< Σ |p − p̂| over every trajectory's scans 2 …
  double velocity_abs_sum = 0.0;      ///< Σ |v − v̂|
  long count = 0;                     ///< the scans summed
  double zeta_p = 0.0, zeta_v = 0.0;  ///< as NormalizedErrors gives them
  /// −1/N Σ log p(z | Z^(k−1)) over the same scans: the plots' predictive NLL per plot, which
  /// needs no truth (what axis_zetas gives for a plots_only set, to lane_log's rounding). Summed
  /// only for a plots_only set (0 otherwise).
  double predictive_nll = 0.0;
};

class ImmFitnessBatch {
 public:
  /// Lays out `set` scan-major in blocks of trajectories: of 8 (two AVX2 vectors: two independent
  /// chains per loop), the last of 4 when 4 or fewer remain; where the AVX-512 clones run, of 24
  /// (three vectors) while more than 16 remain, then 16, 8 or 4, since a block is bound by the
  /// latency of its scan-to-scan chain. A short trajectory's missing scans and the last block's
  /// empty lanes are masked out of every sum; the sums run in trajectory order, so the figures do
  /// not depend on the widths. `wide_blocks` chooses the layout (the CPU's by default).
  explicit ImmFitnessBatch(const TrainingSet& set, bool wide_blocks = wide_vector_clones());

  /// The GA-fuzzy IMM of `spec` over every trajectory, two-point started from scans 0 and 1 (as
  /// evaluate_imm does), with lane arithmetic (see the file comment). Thread-safe. Throws
  /// std::invalid_argument for a spec supports() refuses.
  [[nodiscard]] ImmRunErrors run(const GaFuzzyImmSpec& spec) const;

  /// Whether the batch can run `spec`: 1 to 8 levels and every transition probability positive
  /// (so the linear-space mode prediction, whose log the batch takes, is never zero).
  [[nodiscard]] static bool supports(const GaFuzzyImmSpec& spec);

 private:
  std::vector<int> widths_;      ///< lanes per block, in order
  int scans_ = 0;                ///< the longest trajectory's
  double start_variance_ = 1.0;  ///< the two-point start's plot variance (the set's)
  bool plots_only_ = false;      ///< the set has no truth: the run sums the predictive NLL
  // Per block [scan][lane]: plots, truth, the lane's mask (1 where the scan exists).
  std::vector<double> measurement_, position_, velocity_, mask_;
};

}  // namespace imm::trainer::ga
