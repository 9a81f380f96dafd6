// Fixed-step integration inside the expression graph, and simulation on doubles.
//
// Sampling convention (used by every formulation): samples k = 0..N-1 at t_k = k dt; the input
// u_k is held constant over [t_k, t_{k+1}) (zero-order hold) and the state advances by
//     x_{k+1} = Phi(x_k, u_k, p),
// where Phi is `substeps` classical fourth-order Runge-Kutta steps of size dt / substeps:
//     k1 = f(x, u, p),  k2 = f(x + h/2 k1, u, p),  k3 = f(x + h/2 k2, u, p),  k4 = f(x + h k3, u,
//     p), x+ = x + h/6 (k1 + 2 k2 + 2 k3 + k4).
// The output at sample k is y_k = h(x_k, u_k, p). Phi is built symbolically from the model's
// dynamics, so it carries exact first and second derivatives into the NLPs.
//
// Stiff models (StateSpaceModel::stiff) need step sizes far below the sample time with RK4; they
// are integrated by CVODES or formulated by collocation instead.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "graybox/expr/function.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

/// The symbolic RK4 map: `substeps` steps of dt/substeps with the input held. Throws
/// std::invalid_argument unless dt > 0 and substeps >= 1.
std::vector<expr::Expr> Rk4Step(const expr::Function& dynamics, const std::vector<expr::Expr>& x,
                                const std::vector<expr::Expr>& u, const std::vector<expr::Expr>& p,
                                double dt, int substeps);

/// Phi as a Function: inputs "x", "u", "p", output "x_next".
expr::Function MakeRk4StepFunction(const models::StateSpaceModel& model, double dt, int substeps);

/// A simulated trajectory: X (N x nx) the states at t_0 .. t_{N-1}, Y (N x ny) the outputs.
struct Trajectory {
  Eigen::MatrixXd x;
  Eigen::MatrixXd y;
  /// False when the simulation produced NaN/Inf; `failed_at` is the first bad sample.
  bool ok = true;
  int failed_at = -1;
};

/// Simulates from x0 with inputs U (N x nu, row k = u_k) and parameters p, by the RK4 map.
/// Allocation-light: compiles the step function once per call.
Trajectory SimulateRk4(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                       const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                       int substeps = 1);

}  // namespace graybox::estimators
