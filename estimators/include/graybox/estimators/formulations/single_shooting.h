// Single shooting by an Integrator: simulation-error identification without unrolling.
//
// For each experiment e the whole record is simulated from its initial state x0_e,
//     x_0 = x0_e,   x_{k+1} = Phi(x_k, u_k, theta)     (a fixed-step scheme, or CVODES BDF)
//     r_k = w o (h(x_k, u_k, theta) - y_k),                k = 0 .. N_e - 1,
// and the objective is 1/2 sum_e sum_k |r_k|^2. The decision variables are the free model
// parameters (scaled as in parameter_map.h) and, unless fixed, each experiment's x0.
//
// Unlike BuildMultipleShooting with one segment, nothing is unrolled symbolically: each
// experiment is one residual block of the Nlp (nlp.h, AddResidualBlock) evaluated by the chosen
// Integrator (integrator_factory.h) with its forward sensitivities, so d r / d (theta, x0) is
// exact (to the integrator's tolerance for CVODES) and the cost of building the problem does not
// grow with the record. This is the formulation for stiff models (pneumatic chambers: CVODES) and
// for long records. Its Hessian for Ipopt is the Gauss-Newton matrix J^T J (nlp.h); Ceres uses the
// Jacobian directly.
//
//   SingleShootingOptions options;
//   options.integrator.method = IntegrationMethod::kCvodes;
//   ShootingProblem problem = BuildSingleShooting(model, experiments, options);
//   SolverResult result = SolveWithCeres(problem.nlp);
//   Eigen::VectorXd theta = problem.Parameters(result.w);
#pragma once

#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

struct SingleShootingOptions {
  /// A fixed-step scheme (integrator.fixed_step: RK4 by default, implicit schemes for stiff
  /// models) or CVODES (tolerances in integrator.cvodes).
  IntegratorOptions integrator;
  /// Weights w per output channel; empty means 1 / std(y_channel) over all experiments.
  Eigen::VectorXd output_weights;
  /// Keep the initial state of every experiment at its x0 (not a decision variable).
  bool fix_initial_state = true;
  /// Throws std::invalid_argument explaining the first invalid field.
  void Validate() const;
};

/// Builds the NLP (least squares only: solvable by SolveWithCeres and SolveWithIpopt). The
/// result's node_variables hold one row per experiment (its x0 variables, -1 when fixed).
/// Throws std::invalid_argument for inconsistent sizes (naming the experiment, expected versus
/// got), non-finite data, infeasible parameter bounds, or no free parameter. A failed simulation
/// at a trial point is returned to the solver as a failed evaluation, never thrown.
ShootingProblem BuildSingleShooting(const models::StateSpaceModel& model,
                                    const std::vector<Experiment>& experiments,
                                    const std::vector<ExperimentSetup>& setups,
                                    const SingleShootingOptions& options = {});

}  // namespace graybox::estimators
