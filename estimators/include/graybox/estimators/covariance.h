// Parameter uncertainty at a solution: Gauss-Newton covariance, 95% intervals, and warnings for
// poorly identifiable parameters.
//
// For weighted residuals r(theta) (N_r entries) with Jacobian J = dr/dtheta at the estimate,
//     sigma^2 = |r|^2 / (N_r - n_theta),     Cov(theta) = sigma^2 (J^T J)^-1,
// the standard errors are sqrt(diag Cov) and the 95% intervals theta +- 1.96 std (normal
// approximation). For simulation-error (output-error) estimates the Jacobian is that of the
// simulated outputs with respect to the free parameters AND the free initial states; the
// parameter block of the inverse information matrix is reported (the initial states are nuisance
// parameters). It is computed by forward sensitivities of the integrator (for a fixed-step map
// Phi, integrators.h),
//     S_{k+1} = dPhi/dx S_k + [dPhi/dtheta, 0],   S_0 = [0, I],
//     dy_k/d(theta, x0) = dh/dx S_k + [dh/dtheta, 0],
// which is exact for the discretised model and linear in the number of samples.
//
// Warnings: the information matrix scaled to unit diagonal has a condition number above
// `max_condition` (some combination of parameters is barely determined by the data), or two
// parameters correlate with |rho| above `max_correlation` (only their combination is identified).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/integrators.h"
#include "graybox/estimators/multiple_shooting.h"
#include "graybox/estimators/nlp.h"
#include "graybox/estimators/parameter_map.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

struct ParameterEstimate {
  std::string name;
  std::string unit;
  double value = 0.0;
  double std_error = 0.0;  // NaN when not identifiable (singular information)
  double ci_low = 0.0;     // 95% interval
  double ci_high = 0.0;
  bool free = true;
};

struct CovarianceOptions {
  double max_condition = 1e8;
  double max_correlation = 0.95;
  /// CovarianceFromJacobian only: the channel (0, 1, ...) of every residual row. When given, each
  /// channel gets its own noise variance sigma_c^2 = |r_c|^2 / N_c (with the pooled
  /// degrees-of-freedom correction) and the covariance is the sandwich
  ///   A^-1 J^T diag(sigma_c(row)^2) J A^-1,  A = J^T J,
  /// which stays right when the weights are not 1 / noise (the default 1 / std of each output
  /// over-weights a clean, small channel against a noisy one). Empty: one pooled variance.
  std::vector<int> row_channels;
};

struct UncertaintyReport {
  std::vector<ParameterEstimate> parameters;  // every model parameter; fixed ones have 0 error
  Eigen::MatrixXd covariance;                 // free parameters, in order of `free_indices`
  Eigen::MatrixXd correlation;
  std::vector<int> free_indices;
  double residual_variance = 0.0;  // sigma^2 of the weighted residuals
  int num_residuals = 0;
  double condition_number = 0.0;  // of the unit-diagonal information matrix
  std::vector<std::string> warnings;
  /// "3 free parameters, sigma 1.2e-03 over 24841 residuals, condition 26.0"
  std::string BriefReport() const;
  /// The brief line, a table of value, standard error, relative error and 95% interval per
  /// parameter, and the warnings.
  std::string FullReport() const;
};

/// Covariance from a residual Jacobian (rows: residuals, columns: the free parameters followed by
/// nuisance variables whose block is marginalised) and the residual vector. `parameters` holds
/// every model parameter with its estimated value; free_indices[i] is the parameter of column i.
UncertaintyReport CovarianceFromJacobian(const Eigen::MatrixXd& jacobian,
                                         const Eigen::VectorXd& residuals,
                                         const std::vector<models::ModelParameter>& parameters,
                                         const std::vector<int>& free_indices,
                                         const CovarianceOptions& options = {});

/// The same from an information matrix already reduced to the free parameters (nf x nf, in the
/// parameters' own units) and the residual variance sigma^2.
UncertaintyReport CovarianceFromInformation(const Eigen::MatrixXd& information,
                                            double residual_variance, int num_residuals,
                                            const std::vector<models::ModelParameter>& parameters,
                                            const std::vector<int>& free_indices,
                                            const CovarianceOptions& options = {});

/// Gauss-Newton covariance of an Nlp's least-squares objective at w, whose first
/// map.NumFree() variables are the free parameters (scaled by map.scale) and all others nuisance
/// variables (shooting nodes, collocation states) marginalised by a sparse Schur complement, so
/// the cost stays linear in the record length. With constraint_weight > 0 the constraints c = 0
/// enter as residuals constraint_weight * c (multiple shooting's continuity, as the Ceres form
/// penalises it); with 0 they are ignored. Unlike SimulationCovariance it never simulates the
/// whole record, so it stays finite for models whose open-loop simulation drifts (robots driven
/// by measured torques). Throws std::runtime_error when an evaluation fails.
UncertaintyReport NlpCovariance(const Nlp& nlp, const Eigen::VectorXd& w, const ParameterMap& map,
                                double constraint_weight, const CovarianceOptions& options = {});

/// Output-error covariance of a fitted StateSpaceModel: simulates every experiment from its
/// initial state with the parameter vector `p` by `integrator` (fixed-step or CVODES, bound to the
/// model and the experiments' sample time), forms the sensitivity Jacobian of the weighted
/// outputs with respect to the free parameters and initial states (the integrator's forward
/// sensitivities), and calls CovarianceFromJacobian with one noise variance per output channel
/// (CovarianceOptions::row_channels, unless the caller sets them). `initial_states[e]` is the
/// estimated x0 of experiment e. A failed simulation throws std::runtime_error naming the
/// experiment.
UncertaintyReport SimulationCovariance(const Integrator& integrator,
                                       const std::vector<ExperimentData>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights,
                                       const CovarianceOptions& options = {});

/// The same with FixedStepIntegrator(model, experiments[0].dt, step), e.g. the step options of
/// the multiple-shooting fit.
UncertaintyReport SimulationCovariance(const models::StateSpaceModel& model,
                                       const std::vector<ExperimentData>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights,
                                       const FixedStepOptions& step,
                                       const CovarianceOptions& options = {});

}  // namespace graybox::estimators
