// SPDX-License-Identifier: Apache-2.0
#pragma once
// The batch gradient of an I-H1-H2-1 network with sigmoid hidden layers (the input estimator's
// 2-10-10-1) in one fused pass over the samples: blocks of kLanes samples, one per vector lane,
// go forward and back through the whole network in registers and L1 (no n × units matrices), the
// sigmoid by lane_exp (lane_math.hpp), and every lane accumulates its own share of the gradient;
// the lanes are summed in lane order at the end. So the result does not depend on the instruction
// set (AVX-512 or AVX2 chosen at run time, no FMA; with AVX-512 a linear output takes two blocks at
// a time, with the same bits) and differs from the matrix-product path by rounding only.

#include <Eigen/Core>
#include <vector>

#include "imm/models/learned/mlp.hpp"

namespace imm::trainer::mlp {

/// Whether `layers` is inputs-h1-h2-1 with sigmoid hidden layers.
[[nodiscard]] bool has_shape(const std::vector<MlpLayer>& layers, int inputs, int h1, int h2);

/// ∂E/∂(W, b) of E = mean ½ (a_L − t/scale)² over the rows of `inputs` (n × 2, column-major) for
/// a 2-10-10-1 network (has_shape(layers, 2, 10, 10)); `weights` and `biases` are resized.
void fused_gradients_2_10_10(const std::vector<MlpLayer>& layers, double output_scale,
                             const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                             std::vector<Eigen::MatrixXd>& weights,
                             std::vector<Eigen::VectorXd>& biases);

}  // namespace imm::trainer::mlp
