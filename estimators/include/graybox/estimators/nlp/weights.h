// Default residual weights: one over the standard deviation of each measured channel, so channels
// of different units contribute comparably to a least-squares fit.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace graybox::estimators {

/// Column j of the result is 1 / std of column j over the rows of all `blocks` stacked
/// (population standard deviation), or 1 for a constant column. Every block must have the same
/// number of columns (std::invalid_argument otherwise).
Eigen::VectorXd InverseStdWeights(const std::vector<const Eigen::MatrixXd*>& blocks);

}  // namespace graybox::estimators
