// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/track_filter.hpp"

#include "initial_state_check.hpp"

namespace imm {

void require_initial_state(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                           int dimension) {
  detail::check_initial_state(mean, covariance, dimension);
}

}  // namespace imm
