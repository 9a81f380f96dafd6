// Equation error: identification from the model equations evaluated on measured (and filtered,
// differentiated) signals, without simulation.
//
// Inverse-dynamics form (IDIM, seed 000 eq. 9; the EMPS benchmark's IDIM-LS): with joint
// positions, velocities and accelerations estimated from data and the measured drive torques,
//     r_k = w o (g(q_k, qd_k, qdd_k, theta) - tau_k),
// one residual vector per sample, minimised in the least-squares sense. When g is linear in theta
// (tau = Y(q, qd, qdd) theta, models/regressor.h) this is ordinary least squares and the solvers
// converge in one Gauss-Newton step; the covariance sigma^2 (J^T J)^-1 is then the IDIM-LS one.
//
// State-space form: with states and their derivatives estimated from data,
//     r_k = w o (f(x_k, u_k, theta) - xdot_k)   on selected state components.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/nlp.h"
#include "graybox/estimators/parameter_map.h"
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

/// State-space form: x (N x nx), u (N x nu), xdot (N x nx) per experiment; residuals on the state
/// components listed in `components` (e.g. the accelerations).
struct StateDerivativeData {
  Eigen::MatrixXd x, u, xdot;
};
EquationErrorProblem BuildStateEquationError(const models::StateSpaceModel& model,
                                             const std::vector<StateDerivativeData>& data,
                                             const std::vector<int>& components,
                                             Eigen::VectorXd weights = {});

}  // namespace graybox::estimators
