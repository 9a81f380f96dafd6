// N-step-ahead simulation error as an identification loss (seed 000 eq. 7 minimised directly).
//
// From the measured state x_k at every start k = k0, k0 + stride, ... <= N_e - 1 - N of
// every experiment e, the model is simulated N samples ahead with the measured inputs (held over
// each sample, integrators.h), and the prediction is compared with the measured states:
//     r_{e,k,j} = W (x_hat_{k+j|k}(theta) - x_{k+j})[channels],      j = 1 .. N,
//     minimise 1/2 sum_e sum_k sum_j |r_{e,k,j}|^2   over the free parameters theta.
// With the default weights W = diag(1 / sigma_c), sigma_c the standard deviation of measured
// state channel c over all experiments, the cost is (S N C / 2) eta_N^2 for S starts and C scored
// channels, so the minimiser of this loss is the minimiser of the N-step NRMS of metrics.h
// (NStepLossProblem::Nrms converts; for one experiment it equals NStepNrms exactly).
//
// Compared with multiple shooting, no state is a decision variable: every window restarts from
// the measurement, so the loss weighs the model's short-horizon predictions (the quantity an MPC
// uses) and never lets a drift accumulate over a long record. The windows overlap (a sample is
// scored by up to N windows).
//
// Each experiment is one residual block of the Nlp (nlp.h, AddResidualBlock) evaluated by the
// chosen Integrator with forward sensitivities, spread over `num_threads` threads, so the
// gradient is exact (to CVODES' tolerance) and nothing is unrolled. Its dense Jacobian has
// S_e N C rows and one column per free parameter: 14850 starts x 150 steps x 12 channels x 18
// parameters is 3.9 GB, so long records use a stride (stride 50 on that record: 77 MB).
// Ipopt sees the Gauss-Newton Hessian J^T J; Ceres uses the Jacobian directly.
//
//   NStepLossOptions options;
//   options.steps = 150;
//   options.stride = 25;
//   NStepLossProblem problem = BuildNStepLoss(model, experiments, options);  // experiments[e].x
//   measured SolverResult result = SolveWithCeres(problem.nlp); double eta =
//   problem.Nrms(result.cost);
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

struct NStepLossOptions {
  /// N, the prediction horizon in samples (>= 1).
  int steps = 150;
  /// Use every stride-th start (>= 1), from sample first_start (>= 0) on: starts first_start,
  /// first_start + stride, ... <= N_e - 1 - steps. Skipping the first samples keeps windows from
  /// starting where states derived from the data are poor (a velocity by a one-sided difference
  /// at the record's first sample).
  int stride = 1;
  int first_start = 0;
  /// Scored state columns (0-based, distinct); empty scores every state. Seed 000 scores the
  /// positions and velocities of all six joints.
  std::vector<int> channels;
  /// One weight per scored channel (>= 0), an entry 0 meaning the default; empty means the
  /// default for every channel: 1 / std of the scored measured-state channel over all experiments
  /// (the normalisation of eta_N).
  Eigen::VectorXd weights;
  /// The integrator of every window (RK4 with substeps, or CVODES for stiff models).
  IntegratorOptions integrator;
  /// Threads simulating the windows of one experiment (>= 1).
  int num_threads = 1;
  /// Throws std::invalid_argument explaining the first invalid field.
  void Validate() const;
};

struct NStepLossProblem {
  Nlp nlp;
  /// The free model parameters are the variables of the NLP (scaled, parameter_map.h).
  ParameterMap parameters;
  /// The scored channels and their weights.
  std::vector<int> channels;
  Eigen::VectorXd weights;
  /// starts[e]: the start samples of experiment e.
  std::vector<std::vector<int>> starts;
  /// Number of scored values, sum over experiments of starts x steps x channels.
  long num_scored = 0;

  /// Parameter values shared with the residual blocks (fixed values changed by SetFixedValue).
  std::shared_ptr<Eigen::VectorXd> shared_values;

  Eigen::VectorXd Parameters(const Eigen::VectorXd& w) const { return parameters.Values(w); }
  /// Changes the value of a fixed model parameter (its index in the model) without rebuilding.
  /// std::invalid_argument when the parameter is free or the value is not finite.
  void SetFixedValue(int parameter, double value);
  /// sqrt(2 cost / num_scored): the N-step NRMS of the loss's own weighting at objective `cost`.
  double Nrms(double cost) const;
};

/// Builds the NLP. `experiments[e].x` is the N_e x nx measured state trajectory of experiment e
/// (its inputs are experiments[e].u; experiments[e].y is not used). Throws std::invalid_argument,
/// naming the experiment or option, expected versus got: sizes, non-finite data, a record not
/// longer than N samples, a channel out of range, a zero standard deviation for a default weight,
/// infeasible parameter bounds, no free parameter. A failed window simulation at a trial point is
/// returned to the solver as a failed evaluation naming the experiment and start, never thrown.
NStepLossProblem BuildNStepLoss(const models::StateSpaceModel& model,
                                const std::vector<Experiment>& experiments,
                                const NStepLossOptions& options = {});

}  // namespace graybox::estimators
