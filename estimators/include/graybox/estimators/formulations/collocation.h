// Direct collocation: simulation-error identification with the states at every sample and at
// collocation points inside every sample interval as decision variables, solved by Ipopt with the
// exact sparse Jacobian and Hessian.
//
// On interval k, [t_k, t_k + h] with h = dt, the state is the polynomial of degree d through
// x_k (at tau_0 = 0) and the collocation states X_k1 .. X_kd at tau_1 .. tau_d in (0, 1]:
//     x(t_k + tau h) = sum_{r=0..d} L_r(tau) X_kr,   X_k0 = x_k,
// with Lagrange basis L_r. The collocation conditions (the model holds at every point) and the
// continuity condition are equality constraints,
//     sum_r L_r'(tau_j) X_kr = h f(X_kj, u_k, theta),   j = 1..d,
//     x_{k+1} = sum_r L_r(1) X_kr,
// the input is held over the interval, and the objective is 1/2 sum_k |w o (h(x_k, u_k, theta) -
// y_k)|^2. Points:
//   kLegendre: roots of the shifted Legendre polynomial P_d(2 tau - 1) (Gauss; order 2d).
//   kRadau:    Radau IIA points, roots of P_d(2 tau - 1) - P_{d-1}(2 tau - 1), tau_d = 1 (order
//              2d - 1, L-stable: the choice for stiff models).
// The points are computed as polynomial roots (Eigen's PolynomialSolver), not tabulated.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/formulations/experiment_setup.h"
#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

enum class CollocationScheme { kLegendre, kRadau };

struct CollocationOptions {
  CollocationScheme scheme = CollocationScheme::kRadau;
  int degree = 3;  // collocation points per interval (1..9)
  /// Weights per output channel; empty means 1 / std(y_channel).
  Eigen::VectorXd output_weights;
  void Validate() const;
};

/// The collocation points tau_1 .. tau_d in (0, 1], ascending.
Eigen::VectorXd CollocationPoints(CollocationScheme scheme, int degree);

struct CollocationProblem {
  Nlp nlp;
  ParameterMap parameters;
  /// For each experiment, the variable index of x_k (N x nx).
  std::vector<Eigen::MatrixXi> state_variables;
  Eigen::VectorXd output_weights;
  /// The element groups whose data rows 0 .. NumFixed()-1 hold the fixed parameter values.
  std::vector<std::size_t> fixed_value_groups;
  Eigen::VectorXd Parameters(const Eigen::VectorXd& w) const { return parameters.Values(w); }
  /// Changes the value of a fixed model parameter (its index in the model) without rebuilding
  /// (fixed values are rows 0 .. NumFixed()-1 of the element data). std::invalid_argument when
  /// the parameter is free or the value is not finite.
  void SetFixedValue(int parameter, double value);
};

/// Builds the NLP; states are initialised from each experiment's state_guess, or by simulation
/// from x0 (RK4 with 4 substeps; the L-stable Radau IIA map for a stiff model, where RK4 at that
/// step would overflow). Throws std::invalid_argument on bad sizes, non-finite data or a
/// diverging initial simulation.
CollocationProblem BuildCollocation(const models::StateSpaceModel& model,
                                    const std::vector<Experiment>& experiments,
                                    const std::vector<ExperimentSetup>& setups,
                                    const CollocationOptions& options = {});

}  // namespace graybox::estimators
