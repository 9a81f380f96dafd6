// Finite-difference checks of derivative Functions, for users, tests and the command line.
//
// Central differences D(h) with step h_j = relative_step * max(1, |x_j|) and D(h/2), combined by
// Richardson extrapolation, fd = D(h/2) + (D(h/2) - D(h)) / 3, whose truncation error is O(h^4)
// instead of O(h^2). With the default relative_step = cbrt(machine epsilon) ~ 6e-6 truncation and
// rounding stay ~1e-10 relative for well-scaled functions, and steep ones (a tanh(1000 v) friction
// law, whose third derivative is large) are still resolved.
//
// The error of entry (i, j) is scale-free:
//     e_ij = |a_ij - fd_ij| / (max(|a_ij|, |fd_ij|, row_floor * s_i) + n_ij / tolerance),
//     s_i  = max_j max(|a_ij|, |fd_ij|)   (every analytic entry of the row, differenced or not),
//     n_ij = noise_factor * eps * max|f_i(x +- h_j)| / (h_j / 2)
//            + uncertainty_factor * |D(h/2) - D(h)|,
// and the check passes when every e_ij <= tolerance. So a function measured in kg/s is checked as
// strictly as one in N; entries many orders below the largest of their row are measured against a
// fraction of it; and n_ij, what the finite differences themselves cannot resolve (their rounding
// noise, and the spread between the two steps, which bounds what Richardson leaves and exposes
// rounding that the values' magnitude hides, as in a residual formed by cancellation), never
// fails a check: an analytic derivative is reported wrong only where the finite differences agree
// with each other and not with it.
// Entries outside the analytic sparsity pattern are checked too: a finite difference that is
// clearly nonzero where the pattern claims a structural zero fails.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "graybox/expr/function.h"

namespace graybox::expr {

struct DerivativeCheckOptions {
  /// Step relative to max(1, |x_j|).
  double relative_step = 6.0554544523933395e-06;  // cbrt(2^-52)
  /// Allowed e_ij (see above).
  double tolerance = 1e-6;
  /// Fraction of the row's largest derivative below which errors are measured against it.
  double row_floor = 1e-4;
  /// Multiple of eps |f| / h accepted as finite-difference rounding noise.
  double noise_factor = 1000.0;
  /// Multiple of the spread |D(h/2) - D(h)| accepted as finite-difference uncertainty.
  double uncertainty_factor = 1.0;
  /// Number of worst entries listed in the full report.
  int max_reported = 10;
};

struct DerivativeCheckEntry {
  int row = 0;
  int col = 0;
  double analytic = 0.0;
  double finite_difference = 0.0;
  double error = 0.0;  // e_ij, see the file comment
};

struct DerivativeCheckResult {
  bool ok = true;
  double max_error = 0.0;
  int rows = 0;
  int cols = 0;
  int entries_checked = 0;
  std::vector<DerivativeCheckEntry> worst;  // sorted, largest error first
  /// One line: "derivative check of <what>: OK, max error 3.1e-10 over 12 entries".
  std::string BriefReport() const;
  /// The brief line, then the worst entries with analytic and finite-difference values.
  std::string FullReport() const;
  std::string what;
};

/// Checks Jacobian(output, input) of `f` at `point` (one vector per input of f) against central
/// differences of f itself. Throws std::invalid_argument for unknown names or wrong sizes.
DerivativeCheckResult CheckJacobian(const Function& f, const std::string& output,
                                    const std::string& input,
                                    const std::vector<Eigen::VectorXd>& point,
                                    const DerivativeCheckOptions& options = {});

/// Checks Hessian(output, input) of a one-entry output against central differences of its exact
/// gradient.
DerivativeCheckResult CheckHessian(const Function& f, const std::string& output,
                                   const std::string& input,
                                   const std::vector<Eigen::VectorXd>& point,
                                   const DerivativeCheckOptions& options = {});

/// Checks an arbitrary sparse derivative Function `df` (output `df_output` holding the nonzeros of
/// d f_output / d f_input in its sparsity) against central differences of `f`. The building block
/// of the two checks above, for derivative Functions built by other means.
DerivativeCheckResult CheckDerivative(const Function& f, const std::string& output,
                                      const std::string& input, const Function& df,
                                      const std::string& df_output,
                                      const std::vector<Eigen::VectorXd>& point,
                                      const DerivativeCheckOptions& options = {});

/// A vector function evaluated by user code: fills `value` and returns false on a numerical
/// failure.
using VectorFunction = std::function<bool(const Eigen::VectorXd& x, Eigen::VectorXd* value)>;

/// The same check for a Jacobian computed by any means (assembled NLP derivatives, simulation
/// sensitivities): `analytic` (m x n) against central differences of `f` at x, on the given
/// columns (all when empty; a subset keeps the cost at 2 |columns| evaluations of f for wide
/// problems). Entries outside the sparse pattern of `analytic` are checked against 0. Throws
/// std::invalid_argument on sizes or columns out of range, std::runtime_error (naming the column)
/// when f fails at a step.
DerivativeCheckResult CheckJacobianValues(const std::string& what, const VectorFunction& f,
                                          const Eigen::VectorXd& x,
                                          const Eigen::SparseMatrix<double>& analytic,
                                          const std::vector<int>& columns = {},
                                          const DerivativeCheckOptions& options = {});

}  // namespace graybox::expr
