// CvodesIntegrator: variable-step, variable-order BDF (SUNDIALS CVODES) with Newton iteration, for
// stiff models such as the pneumatic arm, with analytic forward sensitivities.
//
//   CvodesOptions options;                     // plain struct, documented defaults
//   options.linear_solver = CvodesOptions::LinearSolver::kKlu;
//   CvodesIntegrator integrator(model, /*dt=*/0.01, options);
//   SensitivityTrajectory t = integrator.SimulateWithSensitivities(x0, u, p);
//   if (!t.ok) std::cerr << t.summary.BriefReport() << "\n";   // back off, do not abort
//
// Sampling convention: as integrators.h (u_k held over [t_k, t_{k+1}), outputs y_k = h(x_k, u_k,
// p) at the samples). x_k are CVODES's solution at t_k (its dense output when a step passed t_k).
//
// Input discontinuities. A held input that changes at t_k makes f jump there, and BDF's history
// (the Nordsieck array of past derivatives) is invalid across the jump. The integrator therefore
// integrates up to t_k exactly (CVodeSetStopTime) and restarts with CVodeReInit (and
// CVodeSensReInit) at every sample where the input row differs from the previous one, and only
// there: over runs of equal inputs (or for models without inputs) it integrates continuously and
// interpolates the samples. Cost of one restart: the order drops to 1, the first step size is
// estimated again (a few extra f evaluations unless initial_step is set), and the Newton matrix
// I - gamma J is re-evaluated and factorised, so a restart costs at least one Jacobian, one
// factorisation and a handful of small steps while the order builds up; with an input that
// changes at every sample, that is the floor of the cost per sample.
//
// Newton matrix. The Jacobian df/dx comes from libexpr (Function::Jacobian's sparse pattern):
// scattered into a dense matrix, or copied into a CSC matrix for KLU, whose pattern (df/dx's
// pattern plus the diagonal, which I - gamma J needs) is mapped once at construction. KLU is for
// larger models with sparse coupling; at the pneumatic arm's 4 states both cost the same.
//
// Sensitivities with respect to chosen parameters and x0 (see integrators.h) solve
// dS_i/dt = f_x S_i + f_p(:, i) with the right-hand side supplied analytically from libexpr's
// sparse Jacobians of f (one evaluation of f_x and f_p per state value, shared by all columns).
// Their error is controlled with the states' tolerances scaled by the parameter scales
// (ModelParameter::scale; 1 for the initial states), i.e. CVodeSensEEtolerances.
//
// Failures. NaN/Inf in f, f_x or the sensitivity right-hand side is reported to CVODES as a
// recoverable error (it retries with a smaller step); when CVODES gives up, as for too much work,
// error test or convergence failures, the simulation stops and ends in summary.status with the
// sample index and CVODES's message. Nothing is thrown from inside a callback, nothing is printed.
//
// SUNDIALS headers are not included here; the backend lives in estimators/src/cvodes/.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include <Eigen/Core>

#include "graybox/estimators/integrators/integrators.h"

namespace graybox::estimators {

namespace internal {
struct CvodesFunctions;  // compiled libexpr Functions and patterns (defined in the backend)
}  // namespace internal

struct CvodesOptions {
  enum class LinearSolver {
    kDense,  // SUNDIALS dense LU
    kKlu,    // SuiteSparse KLU on the CSC pattern of I - gamma df/dx
  };
  enum class SensitivityMethod {
    kStaggered,     // CV_STAGGERED: states corrected first, then all sensitivities
    kSimultaneous,  // CV_SIMULTANEOUS: one Newton iteration on states and sensitivities
  };

  LinearSolver linear_solver = LinearSolver::kDense;
  /// Relative tolerance on every state (CVodeSStolerances / CVodeSVtolerances). > 0.
  double relative_tolerance = 1e-6;
  /// Absolute tolerance, in each state's unit, used for every state unless
  /// absolute_tolerances is set. > 0.
  double absolute_tolerance = 1e-8;
  /// Per-state absolute tolerances (size nx, all > 0); empty to use absolute_tolerance.
  Eigen::VectorXd absolute_tolerances;
  /// Maximum internal steps per sample interval (CVodeSetMaxNumSteps). >= 1.
  long max_steps = 5000;
  /// Maximum BDF order (CVodeSetMaxOrd), 1..5.
  int max_order = 5;
  /// First step size after every (re)initialisation [s]; 0 lets CVODES estimate it. >= 0.
  double initial_step = 0.0;
  SensitivityMethod sensitivity_method = SensitivityMethod::kStaggered;
  /// Include the sensitivities in the local error test (CVodeSetSensErrCon). Without it they are
  /// only as accurate as the Newton iterations make them.
  bool sensitivity_error_control = true;
  /// Other CVODES settings by name, each calling CVodeSet<Name>: "max_step" [s], "min_step" [s],
  /// "max_nonlin_iters", "max_conv_fails", "max_err_test_fails", "max_hnil_warns",
  /// "nonlin_conv_coef", "stab_lim_det" (0/1), "jac_eval_frequency", "lsetup_frequency",
  /// "sens_max_nonlin_iters". Integer settings need integral values. An unknown name is rejected
  /// by Validate() with a did-you-mean suggestion.
  std::map<std::string, double> pass_through;

  /// Throws std::invalid_argument explaining the first invalid field ("expected ..., got ...").
  void Validate() const;
};

class CvodesIntegrator final : public Integrator {
 public:
  /// Compiles df/dx (and maps its pattern for KLU). Throws std::invalid_argument for invalid
  /// options, dt <= 0, or absolute_tolerances not of size nx.
  CvodesIntegrator(const models::StateSpaceModel& model, double dt,
                   const CvodesOptions& options = {});
  ~CvodesIntegrator() override;
  const CvodesOptions& options() const { return options_; }
  /// "cvodes bdf (dense)" or "cvodes bdf (klu)".
  std::string Name() const override;

 private:
  void IntegrateStates(const StateRequest& request) const override;
  const expr::Function& SensitivityJacobians() const;

  CvodesOptions options_;
  std::unique_ptr<internal::CvodesFunctions> functions_;
  // d f / d (x, p) for the sensitivity right-hand side, built on the first call that needs it.
  mutable std::once_flag sensitivity_once_;
};

/// CvodesIntegrator(model, dt, options).Simulate(x0, u, p).
Trajectory SimulateCvodes(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                          const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                          const CvodesOptions& options = {});

}  // namespace graybox::estimators
