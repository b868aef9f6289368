// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The optimization problem of seed 000 §3.1: find a fuzzy rule table (parameters and number of
/// rules) for one maneuver level. pagmo-style, the problem only knows genomes, bounds and fitness;
/// the genetic algorithm (genetic_algorithm.hpp) knows nothing of fuzzy tables.
///
/// Genetic coding (seed 000 Fig. 2): per rule slot l < max_rules a real parameter string
/// (c1, σ1, c2, σ2, √w) and one bit of the binary rule-count string (slot active or not). The
/// consequent is coded as the standard deviation √w, whose range eq. (15) gives:
/// 0.5 (a_M + √q) ≤ √w ≤ a_M + √q. Centers span the observed ranges of r and Δr, spreads a
/// configured range.
///
/// Fitness (eq. 16): λ/(error + 1) + (1 − λ)/(rules + 1), with error (eq. 17) √(ē_p² + ē_v²) / σ_z
/// of position and velocity estimates over the training trajectories, taken from one of:
/// - kSingleFilter (the seed's literal fitness): the single fuzzy-noise KF with the candidate
///   table (the runtime's FuzzyNoiseFilter, the very step the IMM runs);
/// - kImm: the per-axis GA-fuzzy IMM the table will serve (the runtime's build_ga_fuzzy_axis_imm),
///   with the candidate in its slot beside the other levels' tables. The single-filter fitness
///   rewards whatever one filter needs alone — for a filter that must also follow maneuvers, a
///   large constant q — whereas the IMM needs each table to be good at its own regime and to lose
///   the likelihood contest elsewhere. This fitness measures that directly. Eq. (17) prints sums
///   over the trajectories; we
/// use the means per scan (ē_p = Σ|p − p̂| / N, likewise ē_v), which leaves the optimum unchanged
/// but keeps "error + 1" on the scale λ was chosen for, independent of how many trajectories the
/// config asks for. The seed's errors are in km against σ_z = 0.5 km (0.1–1 km); we divide by
/// σ_z, so that λ weighs the same in any unit and for any sensor (ours: the seed's λ then weighs
/// the error twice as much as on its own scale).

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/trainer/ga/imm_fitness_batch.hpp"
#include "imm/trainer/training_set.hpp"

namespace imm::trainer::ga {

inline constexpr int kGenesPerRule = 5;  // c1, σ1, c2, σ2, √w

struct Genome {
  std::vector<double> genes;         ///< max_rules × 5, slot-major
  std::vector<std::uint8_t> active;  ///< max_rules bits
  [[nodiscard]] int rule_count() const;
};

struct Evaluation {
  double fitness = 0.0;
  double error = 0.0;           ///< eq. (17), per-scan means (kZeta: ζ_p + ζ_v)
  double position_error = 0.0;  ///< ē_p (kZeta: ζ_p)
  double velocity_error = 0.0;  ///< ē_v (kZeta: ζ_v)
  int rules = 0;
};

/// What the genetic algorithm needs of a problem (pagmo style): gene bounds, the number of rule
/// slots, and a thread-safe evaluation of a genome.
class GenomeProblem {
 public:
  virtual ~GenomeProblem() = default;
  [[nodiscard]] virtual int max_rules() const = 0;
  [[nodiscard]] virtual const std::vector<double>& lower() const = 0;
  [[nodiscard]] virtual const std::vector<double>& upper() const = 0;
  /// Must be a pure function of the genome (called concurrently).
  [[nodiscard]] virtual Evaluation evaluate(const Genome& genome) const = 0;
  /// What evaluate() reads of a genome, as values: genomes with bitwise-equal keys must have equal
  /// evaluations, so the GA evaluates one of them and copies the result (its cache). False (the
  /// default): every genome is evaluated.
  virtual bool phenotype(const Genome& /*genome*/, std::vector<double>& /*key*/) const {
    return false;
  }
};

enum class FitnessKind { kSingleFilter, kImm };

[[nodiscard]] std::string_view to_string(FitnessKind kind);

/// The error term of eq. (16):
/// - kEquation17: the seed's √(ē_p² + ē_v²)/σ_z (mean absolute errors, see above);
/// - kZeta: ζ_p + ζ_v, seed 000's normalized errors (§4) of the IMM over the trajectories — what
///   the evaluation compares filters by and the tuned baselines are tuned on (kImm only). With
///   tuned levels, the GA and the baseline it starts from then optimize the same number, so the
///   table the GA keeps is better than the baseline in the very figure it is judged by.
enum class ErrorKind { kEquation17, kZeta };

[[nodiscard]] std::string_view to_string(ErrorKind kind);

struct ProblemOptions {
  FitnessKind fitness = FitnessKind::kImm;
  ErrorKind error = ErrorKind::kEquation17;
  double lambda = 0.95;
  int max_rules = 50;
  /// What the tables read: the seed's residuals, or normalized innovations (then the centers
  /// span the observed normalized values and the spreads are dimensionless: × 1, not × σ_z).
  FuzzyAntecedents antecedents = FuzzyAntecedents::kResidual;
  double sigma_min = 0.1, sigma_max = 10.0;  ///< membership spreads, × input_scale()
  double error_scale = 0.5;                  ///< σ_z: the unit of the error and the spreads

  /// The unit of the antecedents' spreads: σ_z for residuals, 1 for normalized innovations.
  [[nodiscard]] double input_scale() const {
    return antecedents == FuzzyAntecedents::kResidual ? error_scale : 1.0;
  }
  double maneuver_level = 0.01;        ///< a_M
  double process_noise_sigma = 0.001;  ///< √q of eq. (15)
  double consequent_low = 0.5;         ///< √w bounds as multiples of a_M + √q (eq. 15)
  double consequent_high = 1.0;
  /// kImm: score genomes with the lane-batched IMM (imm_fitness_batch.hpp), where it supports the
  /// spec; false: with the runtime's ImmEstimator, one trajectory at a time (to the bit what the
  /// shipped filter computes, several times slower). Tables and levels are scored by
  /// evaluate_table and evaluate_imm with the runtime filter either way.
  bool batched = true;
};

/// The IMM around a candidate table (kImm): every level's table, the candidate's slot, settings.
struct ImmContext {
  AxisImmSettings settings;
  std::vector<FuzzyLevel> levels;  ///< the slot's entry is replaced by the candidate
  std::size_t slot = 0;
};

class FuzzyTableProblem final : public GenomeProblem {
 public:
  /// Computes the observed ranges of r and Δr on `training` with a constant-q KF at the upper
  /// end of eq. (15).
  FuzzyTableProblem(TrainingSet training, const ProblemOptions& options, ImmContext context = {});

  [[nodiscard]] Evaluation evaluate(const Genome& genome) const override;
  /// The active slots' genes in slot order: all that decode() reads.
  bool phenotype(const Genome& genome, std::vector<double>& key) const override;
  /// Error and fitness of a decoded table on any set (validation).
  [[nodiscard]] Evaluation evaluate_table(const FuzzyRuleTable& table,
                                          const TrainingSet& set) const;
  [[nodiscard]] FuzzyRuleTable decode(const Genome& genome) const;
  /// The genome of a one-rule table with consequent √w = `sqrt_w` (clamped into its range): a
  /// constant q = w, i.e. a constant-q Kalman mode. Its rule sits at the origin of (r, Δr) with
  /// the widest spreads; the inactive slots hold their ranges' midpoints.
  [[nodiscard]] Genome constant_genome(double sqrt_w) const;

  [[nodiscard]] int max_rules() const override { return options_.max_rules; }
  [[nodiscard]] int gene_count() const { return options_.max_rules * kGenesPerRule; }
  [[nodiscard]] const std::vector<double>& lower() const override { return lower_; }
  [[nodiscard]] const std::vector<double>& upper() const override { return upper_; }
  [[nodiscard]] const TrainingSet& training() const { return training_; }
  [[nodiscard]] const ProblemOptions& options() const { return options_; }
  /// Observed ranges [r_min, r_max], [Δr_min, Δr_max] of the antecedents (normalized ones when
  /// the tables read normalized innovations).
  [[nodiscard]] std::array<double, 4> residual_ranges() const { return ranges_; }

 private:
  TrainingSet training_;
  ProblemOptions options_;
  ImmContext context_;
  std::array<double, 4> ranges_{};
  std::vector<double> lower_, upper_;
  /// The training set's lanes: kImm, batched, and an IMM the batch supports.
  std::shared_ptr<const ImmFitnessBatch> batch_;

  /// The IMM of the context with `table` in the candidate's slot (kImm).
  [[nodiscard]] GaFuzzyImmSpec imm_with(FuzzyRuleTable table) const;
};

/// Error and fitness (eq. 16–17 with `options`' λ and σ_z) of a whole GA-fuzzy IMM on a set: what
/// the kImm fitness scores a candidate by, for any spec (the joint refinement of the levels).
/// `rules` is the rule count eq. (16) charges.
[[nodiscard]] Evaluation evaluate_imm(const GaFuzzyImmSpec& spec, const TrainingSet& set,
                                      const ProblemOptions& options, int rules);

}  // namespace imm::trainer::ga
