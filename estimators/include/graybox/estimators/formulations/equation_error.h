// Equation error for inverse-dynamics models: identification from the model equations evaluated
// on measured (and filtered, differentiated) signals, without simulation.
//
// Which implementation serves which model type:
//   - state-space models (models::Model / StateSpaceModel, xdot = f(x, u, p)) go through the fit
//     pipeline, estimators::Fit with method "equation_error" (fit/fit.h; EquationErrorSpec in
//     problem/problem_file.h says how states and derivatives come from the measured outputs and
//     whether the residuals are state derivatives or inverse inputs);
//   - inverse-dynamics models (models::InverseDynamicsModel, tau = g(q, qd, qdd, p)) go through
//     BuildInverseDynamicsEquationError below, on q, qd, qdd and tau the caller prepares.
//
// Inverse-dynamics form (IDIM, seed 000 eq. 9; the EMPS benchmark's IDIM-LS): with joint
// positions, velocities and accelerations estimated from data and the measured drive torques,
//     r_k = w o (g(q_k, qd_k, qdd_k, theta) - tau_k),
// one residual vector per sample, minimised in the least-squares sense. When g is linear in theta
// (tau = Y(q, qd, qdd) theta, models/regressor.h) this is ordinary least squares and the solvers
// converge in one Gauss-Newton step; the covariance sigma^2 (J^T J)^-1 is then the IDIM-LS one.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"
#include "graybox/expr/function.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

/// Samples for the inverse-dynamics form: every matrix N x n_joints (row k = sample k).
struct InverseDynamicsData {
  Eigen::MatrixXd q, qd, qdd, tau;
};

struct EquationErrorProblem {
  Nlp nlp;
  ParameterMap parameters;
  Eigen::VectorXd weights;  // per residual channel
  Eigen::VectorXd Parameters(const Eigen::VectorXd& w) const { return parameters.Values(w); }
};

/// `inverse_dynamics` has inputs "q", "qd", "qdd" (n_joints each) and "p" (all model parameters,
/// described by `parameters`) and output "tau" (n_joints). `weights` per joint; empty means
/// 1 / std(tau_j). Throws std::invalid_argument on size mismatches or non-finite data.
EquationErrorProblem BuildInverseDynamicsEquationError(
    const expr::Function& inverse_dynamics, const std::vector<models::ModelParameter>& parameters,
    const std::vector<InverseDynamicsData>& data, Eigen::VectorXd weights = {});

}  // namespace graybox::estimators
