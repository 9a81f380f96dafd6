// Parameter uncertainty at a solution: Gauss-Newton covariance, 95% intervals, the unidentifiable
// parameter combinations, and a failure status that is never mistaken for an identifiability
// verdict.
//
// Model. The weighted residuals r (N entries; output residuals w_c (y_model - y_measured)) are
// white noise of variance sigma^2 (or sigma_c^2 per channel c) around a model that is exact:
// the simulated trajectory satisfies the model equations (multiple shooting's continuity,
// collocation's equations) exactly, whatever form a solver enforced them in. With the Jacobian
// J = dr/dtheta of the residuals with respect to the free parameters, after the nuisance
// variables (initial states, shooting nodes, collocation states) have been eliminated, i.e.
// G = dr/dtheta along the model's constraints with the nuisance variables re-optimised
// (the projection of J_theta orthogonal to the nuisance columns, or the constrained elimination
// in NlpCovariance), the information matrix is R = G^T G and
//     sigma^2 = |r|^2 / (N - n_eff),          Cov(theta) = sigma^2 R^-1,
// n_eff = number of free parameters plus nuisance variables minus exact constraints. (A
// continuity condition kept as a residual of weight w would instead model process noise of
// standard deviation sigma / w on every node, another model than the output error the fit
// assumes; its covariance tends to the constrained one as w grows, and at w = 100 the shooting
// nodes absorbed most of the information: EMPS closed loop, M 0.107 kg against 0.033.) With one
// noise variance per output channel (CovarianceOptions::row_channels) the covariance is the
// sandwich R^-1 G^T diag(sigma_c(row)^2) G R^-1, right also when the weights are not 1 / noise.
// Standard errors are sqrt(diag Cov) in the parameters' own units; 95% intervals are
// theta +- 1.96 std (normal approximation).
//
// Identifiability. R is scaled to unit diagonal, S = D^-1 R D^-1 with D = sqrt(diag R) (a
// parameter with zero information keeps D_ii = 1), and S = V diag(lambda) V^T. The eigenvectors
// whose eigenvalue is at most lambda_max / max_condition span the unidentifiable directions
// (null space): moving the parameters by D^-1 v along such a v changes the fit by less than a
// max_condition-th of the best-determined direction. Each direction is reported as a
// combination "0.71*a.p1 - 0.71*b.p2" of the scaled parameters (a basis reduced so that each
// direction involves as few parameters as possible, normalised to unit length, coefficients below
// null_space_coefficient dropped). A parameter with a coefficient of at least
// null_space_coefficient in the null space gets NaN as standard error and interval; every other
// parameter keeps its error, computed from the pseudo-inverse of R restricted to the
// identifiable directions (exact for a parameter orthogonal to the null space: its variance does
// not depend on how the unidentifiable combinations are fixed). condition_number is
// lambda_max / lambda_min of S (inf when singular); a warning names the combinations when it
// exceeds max_condition, another one each pair of parameters correlated above max_correlation.
// A parameter whose information the elimination of the nuisance variables reduces by a factor
// above max_condition (|G_i|^2 <= |J_theta_i|^2 / max_condition: it is confounded with an initial
// state or a node, e.g. a position offset with a free initial position) is given none (what is
// left is rounding) and named "1*p (confounded with the eliminated initial states / nodes)".
//
// Failure. When the covariance cannot be computed (a non-finite residual, Jacobian or sensitivity
// entry, J^T J overflowing, a failed simulation, a singular elimination of the nuisance
// variables), the report has ok = false and `failure` says why ("the covariance could not be
// computed because ..."); the standard errors are NaN and no identifiability warning is given,
// because none was established.
// Argument errors (sizes, options) throw std::invalid_argument; numerical failures never throw.
//
// Output-error covariance (SimulationCovariance): the Jacobian of the simulated weighted outputs
// with respect to the free parameters and (CovarianceOptions::free_initial_states) the initial
// states, from the integrator's forward sensitivities (for a fixed-step map Phi, integrators.h)
//     S_{k+1} = dPhi/dx S_k + [dPhi/dtheta, 0],   S_0 = [0, I],
//     dy_k/d(theta, x0) = dh/dx S_k + [dh/dtheta, 0],
// exact for the discretised model and linear in the number of samples. The initial states are
// nuisance parameters (marginalised).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

struct ParameterEstimate {
  std::string name;
  std::string unit;
  double value = 0.0;
  /// In the parameter's own unit. NaN when the parameter is part of an unidentifiable
  /// combination (UncertaintyReport::unidentifiable) or the covariance failed; 0 when fixed.
  double std_error = 0.0;
  double ci_low = 0.0;  // 95% interval (NaN with std_error)
  double ci_high = 0.0;
  bool free = true;

  /// The standard error as a percentage of |value|: 100 std_error / |value|. NaN (reported as
  /// "n/a" and JSON null) where it says nothing: a fixed parameter, an unknown standard error, or
  /// a value within kRelativeErrorFloor standard errors of zero (the ratio then only measures how
  /// close the estimate happens to be to zero: 4.19e17 % for an output weight of ~1e-17).
  double RelativeStdPercent() const;
};

/// ParameterEstimate::RelativeStdPercent is NaN when |value| < kRelativeErrorFloor std_error
/// (above 1000 %).
inline constexpr double kRelativeErrorFloor = 0.1;

/// CovarianceOptions::row_channels entry of a penalty (regularisation) row.
inline constexpr int kPenaltyRow = -2;

struct CovarianceOptions {
  /// Identifiability threshold on the unit-diagonal information S: eigen-directions with
  /// lambda <= lambda_max / max_condition are unidentifiable (null space), and a condition number
  /// above max_condition is warned about. > 1.
  double max_condition = 1e8;
  /// Pairs of identifiable parameters correlated above this are warned about. In (0, 1].
  double max_correlation = 0.95;
  /// Coefficients of a unit-length null-space direction below this count as zero: the parameter
  /// is not named in that combination and keeps a standard error. In [0, 1).
  double null_space_coefficient = 1e-3;

  /// The channel (0, 1, ...) of every residual row (CovarianceFromJacobian: every row;
  /// NlpCovariance: every row of Nlp::Residuals, where the entries of constraint_residual_rows
  /// are ignored and may be -1). When given, each channel gets its own noise variance
  /// sigma_c^2 = |r_c|^2 / N_c (with the pooled degrees-of-freedom correction N / (N - n_eff))
  /// and the covariance is the sandwich above, which stays right when the weights are not
  /// 1 / noise (the default 1 / std of each output over-weights a clean, small channel against a
  /// noisy one). Empty: one pooled variance. SimulationCovariance and the ShootingProblem
  /// overload of NlpCovariance fill it (row -> output channel) unless the caller sets it.
  /// An entry kPenaltyRow marks a penalty row (a regularisation term, a prior): it counts in
  /// the information G^T G (the curvature of the objective) but carries no measurement noise,
  /// so it is left out of the variance estimates and of the middle of the sandwich.
  std::vector<int> row_channels;
  /// Per channel (with row_channels; empty: all 1): the weight w_c > 0 its residuals carry,
  /// w_c (y_model - y_measured), so that UncertaintyReport::channels gives the noise sigma_c / w_c
  /// in the channel's own unit. SimulationCovariance and NlpCovariance(ShootingProblem) use the
  /// output weights when this is empty.
  Eigen::VectorXd channel_weights;
  /// Per channel, for the reports (empty: "channel 0", ... and no unit). SimulationCovariance
  /// takes the outputs' names and units from experiments[0] when these are empty.
  std::vector<std::string> channel_names;
  std::vector<std::string> channel_units;

  /// NlpCovariance only: rows of Nlp::Residuals that are equality constraints written as
  /// penalised residuals (multiple shooting's continuity in the Ceres form,
  /// continuity_as_constraints = false: ContinuityResidualRows(problem)). They are treated like
  /// the Nlp's equality constraints: exact (whatever weight they carry), eliminated with the
  /// nuisance variables, and left out of sigma^2 and of the residual count. Distinct, in
  /// [0, NumResiduals()).
  std::vector<int> constraint_residual_rows;

  /// SimulationCovariance only: true when the fit estimated the initial states (they are then
  /// nuisance parameters of the Jacobian); false when it kept them fixed at the given values
  /// (single shooting's default, fix_initial_state = true), so their columns are left out.
  bool free_initial_states = true;

  /// Throws std::invalid_argument naming the first invalid field (expected versus got).
  void Validate() const;
};

/// The noise of one residual channel, as the residuals estimate it.
struct ChannelNoise {
  std::string name;
  std::string unit;
  double weight = 1.0;          // w_c (CovarianceOptions::channel_weights)
  int num_residuals = 0;        // N_c
  double weighted_sigma = 0.0;  // sigma_c of the weighted residuals (dof-corrected)
  double sigma = 0.0;           // weighted_sigma / weight: the noise in the channel's own unit
};

struct UncertaintyReport {
  /// False when the covariance could not be computed; `failure` then says why, every standard
  /// error is NaN, and there are neither warnings nor unidentifiable combinations.
  bool ok = true;
  std::string failure;                        // "the covariance could not be computed because ..."
  std::vector<ParameterEstimate> parameters;  // every model parameter; fixed ones have 0 error
  /// Free parameters, in order of `free_indices`; rows and columns of unidentifiable parameters
  /// are NaN.
  Eigen::MatrixXd covariance;
  Eigen::MatrixXd correlation;
  std::vector<int> free_indices;
  double residual_variance = 0.0;  // pooled sigma^2 of the weighted residuals
  int num_residuals = 0;           // residuals that estimate the noise (not constraint rows)
  double condition_number = 0.0;   // of the unit-diagonal information matrix
  /// Per residual channel when CovarianceOptions::row_channels was given (else empty).
  std::vector<ChannelNoise> channels;
  /// The unidentifiable combinations, "0.71*a.p1 - 0.71*b.p2" (see the top of the file).
  std::vector<std::string> unidentifiable;
  /// The same as columns (free parameters x directions, unit length, unit-diagonal scaling).
  Eigen::MatrixXd null_space;
  std::vector<std::string> warnings;
  /// "4 free parameters, sigma 1.2e-03 over 49682 residuals (load.q 2.1e-06 m, nu 0.25 V),
  /// condition 26.0" or "covariance failed: the covariance could not be computed because ...".
  std::string BriefReport() const;
  /// The brief line, a table of value, standard error, relative error and 95% interval per
  /// parameter, the per-channel noise, the unidentifiable combinations, the warnings or the
  /// failure.
  std::string FullReport() const;
};

/// Covariance from a residual Jacobian (rows: residuals, columns: the free parameters followed by
/// nuisance variables, which are eliminated) and the residual vector. `parameters` holds every
/// model parameter with its estimated value; free_indices[i] is the parameter of column i.
/// n_eff = the column count. Non-finite entries give ok = false.
UncertaintyReport CovarianceFromJacobian(const Eigen::MatrixXd& jacobian,
                                         const Eigen::VectorXd& residuals,
                                         const std::vector<models::ModelParameter>& parameters,
                                         const std::vector<int>& free_indices,
                                         const CovarianceOptions& options = {});

/// The same from an information matrix already reduced to the free parameters (nf x nf, in the
/// parameters' own units) and the residual variance sigma^2 (row_channels do not apply).
UncertaintyReport CovarianceFromInformation(const Eigen::MatrixXd& information,
                                            double residual_variance, int num_residuals,
                                            const std::vector<models::ModelParameter>& parameters,
                                            const std::vector<int>& free_indices,
                                            const CovarianceOptions& options = {});

/// Gauss-Newton covariance of an Nlp's least-squares objective at w, whose first map.NumFree()
/// variables are the free parameters (scaled by map.scale: the errors come back in the
/// parameters' own units) and all others nuisance variables (shooting nodes, initial states,
/// collocation states). The Nlp's equality constraints (lbg = ubg) and the residual rows listed
/// in options.constraint_residual_rows are exact constraints: the nuisance variables are
/// eliminated along them by a sparse KKT system [[J_n^T J_n, A_n^T], [A_n, 0]] (cost linear in
/// the record length), so the covariance is that of the constrained optimum and does not depend
/// on whether a solver enforced the constraints (Ipopt) or penalised them with a large weight
/// (Ceres), nor on that weight. sigma^2 comes from the other residual rows only, with
/// n_eff = variables - exact constraints. Inequality constraints are ignored (taken as
/// inactive). Unlike SimulationCovariance it never simulates the whole record, so it stays
/// finite for models whose open-loop simulation drifts.
UncertaintyReport NlpCovariance(const Nlp& nlp, const Eigen::VectorXd& w, const ParameterMap& map,
                                const CovarianceOptions& options = {});

/// Multiple or single shooting: NlpCovariance of problem.nlp with the continuity residual rows of
/// the Ceres form as constraints (ContinuityResidualRows), and, unless the caller set them, one
/// noise variance per output channel (row_channels) with the problem's output weights
/// (channel_weights). The rows are told apart by their labels (Nlp::residual_labels): channel
/// j < ny (the formulations register the outputs first, in order) is output j, a
/// "continuity.<state>" channel is continuity, and any other channel (regularisation) shares one
/// extra noise variance, "other residuals". Give channel_names / channel_units for the report.
/// Throws std::invalid_argument when a residual row is unlabelled (see ContinuityResidualRows).
/// To treat a problem in the Ceres form through the generic overload instead, pass
/// options.constraint_residual_rows = ContinuityResidualRows(problem).
UncertaintyReport NlpCovariance(const ShootingProblem& problem, const Eigen::VectorXd& w,
                                const CovarianceOptions& options = {});

/// The rows of problem.nlp.Residuals() that are continuity conditions weighted as residuals
/// (BuildMultipleShooting with continuity_as_constraints = false: the last nx residuals of every
/// segment that is followed by another), ascending; empty when the continuity is a constraint or
/// for single shooting. They are the rows whose label (Nlp::residual_labels) names a channel
/// starting with "continuity.". Throws std::invalid_argument when a residual row carries no label
/// (channel -1), e.g. residuals added to problem.nlp without Nlp::LabelResidual: such a row
/// cannot be classified.
std::vector<int> ContinuityResidualRows(const ShootingProblem& problem);

/// Output-error covariance of a fitted StateSpaceModel: simulates every experiment from its
/// initial state with the parameter vector `p` by `integrator` (fixed-step or CVODES, bound to the
/// model and the experiments' sample time), forms the sensitivity Jacobian of the weighted
/// outputs output_weights[j] (y_j - y_measured_j) with respect to the free parameters and, with
/// options.free_initial_states, the initial states (the integrator's forward sensitivities), and
/// calls CovarianceFromJacobian with one noise variance per output channel (row_channels,
/// channel_weights = output_weights and the outputs' names and units, unless the caller sets
/// them). `initial_states[e]` is the (estimated or fixed) x0 of experiment e. A failed simulation
/// or a non-finite sensitivity (e.g. an explicit scheme on a very steep friction law: the state
/// stays bounded while its linearisation diverges) gives ok = false naming the experiment, the
/// sample and the parameter.
UncertaintyReport SimulationCovariance(const Integrator& integrator,
                                       const std::vector<Experiment>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights,
                                       const CovarianceOptions& options = {});

/// The same with FixedStepIntegrator(model, experiments[0].dt, step), e.g. the step options of
/// the multiple-shooting fit.
UncertaintyReport SimulationCovariance(const models::StateSpaceModel& model,
                                       const std::vector<Experiment>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights,
                                       const FixedStepOptions& step,
                                       const CovarianceOptions& options = {});

}  // namespace graybox::estimators
