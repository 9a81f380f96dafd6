// Multiple shooting: simulation-error identification of a StateSpaceModel as a structured NLP.
//
// For each experiment, the samples are cut into segments of `segment_length` samples. The state
// at the start of every segment, s_j, is a decision variable, as are the free model parameters
// theta (scaled: the optimizer sees theta_i / scale_i). Inside segment j, starting at sample k_j,
//     x_{k_j} = s_j,   x_{k+1} = Phi(x_k, u_k, theta)      (integrators.h: fixed step, input held)
//     r_k     = w o (h(x_k, u_k, theta) - y_k)                   (weighted output error)
// and the continuity condition  Phi(x_{k_j + L - 1}, ...) - s_{j+1} = 0  joins the segments,
// either as equality constraints (Ipopt) or as residuals weighted by `continuity_weight` (Ceres).
// The objective is 1/2 sum_k |r_k|^2 over every sample of every experiment. With segment_length
// equal to the record length this is single shooting; with 1 every sample is a node.
//
// Each segment is one NLP element (nlp.h): the simulation over L samples is unrolled
// symbolically once, so the element's exact Jacobian and Hessian come from libexpr and the NLP is
// assembled in time linear in the number of samples. Phi is MakeStepFunction(model, dt, step):
// explicit RK4 by default, or an implicit scheme (backward_euler, trapezoidal, radau_iia) for
// stiff models, whose Newton-iterated step is an explicit graph like RK4's, so the element's
// derivatives stay exact (they are larger: they differentiate the dynamics' Jacobian too).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/formulations/experiment_setup.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

struct MultipleShootingOptions {
  int segment_length = 20;  // samples per segment (>= 1)
  /// The one-step map Phi (scheme, substeps per sample, Newton iterations), also used to simulate
  /// the initial node guess.
  FixedStepOptions step;
  /// True: continuity as equality constraints (Ipopt). False: as weighted residuals (Ceres).
  bool continuity_as_constraints = true;
  /// Weight of the continuity residuals when they are residuals (relative to output residuals).
  double continuity_weight = 100.0;
  /// Weights w per output channel; empty means 1 / std(y_channel) over all experiments.
  Eigen::VectorXd output_weights;
  /// Keep the initial state of every experiment at x0 (not a decision variable).
  bool fix_initial_state = false;
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// The NLP plus the map between decision variables and model quantities.
struct ShootingProblem {
  Nlp nlp;
  /// The free model parameters are the first variables of the NLP.
  ParameterMap parameters;
  /// For each experiment, the variable index of each segment start state (segments x nx); -1 for
  /// a fixed initial state.
  std::vector<Eigen::MatrixXi> node_variables;
  /// The weights used per output channel.
  Eigen::VectorXd output_weights;

  /// Parameter values shared with residual blocks that evaluate the model themselves (single
  /// shooting); null when every value sits in element data (multiple shooting).
  std::shared_ptr<Eigen::VectorXd> shared_values;
  /// The element groups whose data rows 0 .. NumFixed()-1 hold the fixed parameter values
  /// (groups added later, e.g. regularisation, are not among them).
  std::vector<std::size_t> fixed_value_groups;

  /// The full model parameter vector encoded by the decision vector w.
  Eigen::VectorXd Parameters(const Eigen::VectorXd& w) const { return parameters.Values(w); }
  /// Changes the value of a fixed model parameter (its index in the model) without rebuilding:
  /// the fixed values are element data rows 0 .. NumFixed()-1 (multiple shooting) or the shared
  /// values of the residual blocks (single shooting). std::invalid_argument when the parameter
  /// is free (set the initial point instead) or the value is not finite.
  void SetFixedValue(int parameter, double value);
  /// The initial state of experiment e encoded by w.
  Eigen::VectorXd InitialState(const Eigen::VectorXd& w, int e) const;
};

/// Builds the NLP. Throws std::invalid_argument for inconsistent sizes (naming the experiment,
/// expected versus got), non-finite data, infeasible parameter bounds, or no free parameter.
/// `experiments` need a uniform sample time, the same for all; `setups` holds one entry per
/// experiment (initial state, optional node guess).
ShootingProblem BuildMultipleShooting(const models::StateSpaceModel& model,
                                      const std::vector<Experiment>& experiments,
                                      const std::vector<ExperimentSetup>& setups,
                                      const MultipleShootingOptions& options = {});

}  // namespace graybox::estimators
