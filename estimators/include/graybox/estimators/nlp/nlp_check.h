// Finite-difference checks of an assembled Nlp's derivatives: what the solvers will use, checked
// as they will see it (scaled variables, every element group and residual block scattered into
// the global matrices).
//
// At a point w, with central differences of the NLP's own evaluations (expr/derivative_check.h:
// step, scale-free error measure, noise floor, tolerance):
//   - d r / d w, the residual Jacobian (Ceres, covariance), against differences of Residuals;
//   - d g / d w, the constraint Jacobian (Ipopt), against differences of Constraints;
//   - the gradient of the objective, against differences of Objective;
//   - the lower triangle of the Hessian of the Lagrangian (Ipopt, exact Hessian), with sigma = 1
//     and multipliers lambda drawn from N(0, 1) with `seed`, against differences of the exact
//     gradient of the Lagrangian grad f + J_g^T lambda. Skipped when the NLP has residual blocks
//     (simulations by an Integrator): their Hessian is the Gauss-Newton J^T J by design, not the
//     exact second derivative.
// Wide NLPs are checked on a subset of columns: the first `leading_columns` variables (the free
// parameters come first in every formulation) and up to `sampled_columns` more, evenly spaced,
// so a check costs a fixed number of NLP evaluations whatever the number of shooting nodes.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/nlp/nlp.h"
#include "graybox/expr/derivative_check.h"

namespace graybox::estimators {

struct NlpDerivativeCheckOptions {
  /// Always checked: variables 0 .. leading_columns - 1 (the model parameters).
  int leading_columns = 64;
  /// Further variables, evenly spaced over the rest.
  int sampled_columns = 16;
  /// Seed of the multipliers of the Hessian check.
  unsigned seed = 1;
  /// The entry-wise check (expr/derivative_check.h). Its tolerance defaults to 1e-5 here, ten
  /// times the libexpr default: NLP entries are compositions of many steps (a shooting segment
  /// unrolls L RK4 steps), whose finite differences carry the higher-order truncation of every
  /// step; on the EMPS closed loop (steep tanh(1000 v) friction, 20-step segments) correct
  /// derivatives measure up to 1.4e-6. A wrong derivative errs by far more.
  expr::DerivativeCheckOptions check = [] {
    expr::DerivativeCheckOptions o;
    o.tolerance = 1e-5;
    return o;
  }();
};

/// The checks that apply to `nlp` (see above), in the order listed. Throws std::invalid_argument
/// when w has the wrong size, std::runtime_error when an evaluation fails at w or at a step.
std::vector<expr::DerivativeCheckResult> CheckNlpDerivatives(
    const Nlp& nlp, const Eigen::VectorXd& w, const NlpDerivativeCheckOptions& options = {});

}  // namespace graybox::estimators
