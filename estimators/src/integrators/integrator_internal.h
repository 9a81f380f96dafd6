// Helpers shared by the integrators (integrators.cc, cvodes/cvodes_integrator.cc). Private.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/function.h"
#include "graybox/expr/sparsity.h"

namespace graybox::estimators::internal {

/// A Function with the inputs "x", "u", "p" of `f` and two sparse outputs: "jac_x" = d out / d x
/// and "jac_p" = d out / d p, where out is f's output `output`. One tape, so the work the two
/// Jacobians share is done once.
expr::Function JacobiansXP(const expr::Function& f, const std::string& output);

/// out += A in, with A given by its CCS pattern and nonzero values (in: A.cols() x m).
void AddSparseProduct(const expr::Sparsity& a, const double* nz, const Eigen::MatrixXd& in,
                      Eigen::MatrixXd* out);

/// out.col(j) += A(:, columns[j]) for every j.
void AddSparseColumns(const expr::Sparsity& a, const double* nz, const std::vector<int>& columns,
                      Eigen::MatrixXd* out);

}  // namespace graybox::estimators::internal
