// Private (graybox::estimators::internal): equation-error identification as the problem files
// describe it (problem_file.h, EquationErrorSpec): states and their derivatives from filtered and
// differentiated measurements, decimation, and the NLP of the inverse or state-derivative form.
//
// Inverse form. For residual states c and inverse inputs j (as many), when the derivatives f_c
// are affine in u_j,
//     f_c(x, u, theta) = a(x, u_other, theta) + B(x, u_other, theta) u_j,
// the input that reproduces the measured derivatives is  g(x, u, xdot, theta) = B^-1 (xdot_c - a),
// and the residual is  r_k = w o (g_k(theta) - u_j,k).  For a mass driven by a force with friction
// (mechanics.mass) g = M qdd + F(qd): the inverse dynamic model and, when it is linear in theta,
// IDIM-LS. a and B are obtained symbolically (f at u_j = 0 and at the unit vectors); affinity is
// checked numerically on the data at the initial parameters.
// State-derivative form: g = f_c(x, u, theta), r_k = w o (g_k(theta) - xdot_c,k).
//
// Decimation (EquationErrorSpec::decimation). "parallel": when g is affine in the free
// parameters, g_k(theta) = Y_k theta + g0_k, the regressor columns Y, the offset g0 and the
// measured target are decimated alike at full rate (Gautier's parallel filtering; the EMPS
// benchmark's IDIM-LS recipe), and the fit is on the decimated rows. "signals": x, u and xdot are
// decimated first and g is evaluated on the decimated samples (any model). "auto" picks parallel
// when g is affine in the free parameters.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/expr/function.h"

namespace graybox::estimators::internal {

/// The states of a split from its measurements (N x nx): measured outputs low-pass filtered,
/// derivatives by central differences (EquationErrorSpec::differentiate), or both through the
/// ideal FFT low-pass with differentiation = "fft" (seed 000 eq. 8).
Eigen::MatrixXd StatesFromSpec(const estimators::Problem& problem,
                               const estimators::EquationErrorSpec& spec,
                               const estimators::Experiment& experiment);

/// The symbolic side of an equation-error fit.
struct EquationModel {
  std::vector<int> residual_states;   // state indices c
  std::vector<int> inverse_inputs;    // input indices j (inverse form; empty otherwise)
  std::vector<std::string> channels;  // residual channel names
  std::vector<std::string> units;
  /// Inputs "x", "u", "xdot" (the residual states' derivatives), "p" (all parameters); output
  /// "target" (the predicted input or derivative per channel).
  expr::Function predict;
  /// d target / d p (sparse nonzeros; output "jac").
  expr::Function jacobian;
  estimators::ParameterMap parameters;
  /// True when the fit decimates regressors (see the file comment).
  bool parallel = false;
};

/// The samples of one split as the fit sees them (after skip_samples and decimation).
struct EquationSamples {
  std::string split;
  Eigen::VectorXd time;
  Eigen::MatrixXd target;  // N' x nc, measured
  // "signals" decimation: the decimated signals.
  Eigen::MatrixXd x, u, xdot;  // N' x nx, nu, nc
  // "parallel" decimation: per channel i, regressors[i] (N' x n_free) = d g_i / d theta_free
  // and offset.col(i) = g_i - Y theta_free (at the initial parameters), decimated.
  std::vector<Eigen::MatrixXd> regressors;
  Eigen::MatrixXd offset;
};

/// Builds the symbolic model, checks affinity in the inverse inputs on `check_split` and decides
/// the decimation mode. Throws std::invalid_argument on a non-affine model or bad options.
EquationModel BuildEquationModel(const estimators::Problem& problem,
                                 const estimators::SplitData& check_split);

EquationSamples SampleSplit(const estimators::Problem& problem, const EquationModel& model,
                            const estimators::SplitData& split);

struct EquationErrorFit {
  estimators::Nlp nlp;
  Eigen::VectorXd weights;
  int num_samples = 0;
};

EquationErrorFit BuildEquationErrorFit(const estimators::Problem& problem,
                                       const EquationModel& model,
                                       const std::vector<EquationSamples>& samples);

/// The model's prediction of the target of `samples` with parameters p (NaN where not finite).
Eigen::MatrixXd PredictTarget(const EquationModel& model, const EquationSamples& samples,
                              const Eigen::VectorXd& p);

}  // namespace graybox::estimators::internal
