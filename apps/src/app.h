// Private interface of the `graybox` command-line tool: the commands (fit, simulate, check) called
// by graybox/main.cc (the only translation unit that sees CLI11), and the pieces they share.
//
// Exit codes (also in docs/problem-format.md):
//   0  success
//   1  internal error (an output could not be written, an unexpected exception)
//   2  bad input: a problem-file, data or parameter-file defect, or a bad command line; the
//      message names the file, the field or line, and what was expected; nothing is written
//   3  the solver failed (or the simulation diverged); result.json is still written and its
//      "status" says why
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/covariance.h"
#include "graybox/estimators/metrics.h"
#include "graybox/estimators/problem_file.h"
#include "graybox/estimators/solvers.h"

namespace graybox::app {

inline constexpr int kExitSuccess = 0;
inline constexpr int kExitInternalError = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitSolverFailure = 3;

/// Options shared by the commands (filled by main.cc from the command line).
struct CommandOptions {
  std::string problem;   // path of the problem file
  std::string out;       // output directory
  std::string params;    // simulate: result.json or TOML parameter file
  bool verbose = false;  // solver iteration lines
  bool check_derivatives = false;
  std::string command_line;  // recorded in result.json
};

int RunFit(const CommandOptions& options);
int RunSimulate(const CommandOptions& options);
/// Parses the problem and reads its data without solving; prints a summary.
int RunCheck(const CommandOptions& options);

/// "v0.1.0-12-gabcdef-dirty" from `git describe --always --dirty` at configure time, or
/// "unknown".
const char* GitRevision();
const char* Version();

// ---- pieces shared by the commands -------------------------------------------------------------

/// The evaluation of one split: the measured outputs, the simulation from its initial state and
/// the metrics; for equation error also the fitted equation (predicted against measured
/// target after the preprocessing).
struct SplitEvaluation {
  std::string name;
  std::string data_name;
  estimators::SplitRole role = estimators::SplitRole::kEstimation;
  Eigen::VectorXd time;       // N
  Eigen::MatrixXd measured;   // N x ny
  Eigen::MatrixXd simulated;  // N x ny (NaN after a divergence)
  Eigen::VectorXd x0;
  bool simulation_ok = true;
  int failed_at = -1;
  estimators::MetricReport simulation;
  // Equation error only.
  bool has_equation = false;
  std::vector<std::string> equation_channels;
  std::vector<std::string> equation_units;
  Eigen::VectorXd equation_time;
  Eigen::MatrixXd equation_measured, equation_predicted;
  estimators::MetricReport equation;
  // N-step-ahead NRMS ([metrics] n_step > 0).
  bool has_n_step = false;
  estimators::NStepResult n_step;
};

/// Adds the N-step-ahead NRMS of a split ([metrics] n_step) from the states in its data.
void EvaluateNStep(const estimators::Problem& problem, const estimators::SplitData& split,
                   const Eigen::VectorXd& p, SplitEvaluation* e);

/// Simulates a split from x0 with parameters p and computes the output metrics.
SplitEvaluation EvaluateSimulation(const estimators::Problem& problem,
                                   const estimators::SplitData& split, const Eigen::VectorXd& p,
                                   const Eigen::VectorXd& x0);

/// One finite-difference check of the model's dynamics or output.
struct DerivativeCheckLine {
  std::string what;
  bool ok = true;
  double max_error = 0.0;
  std::string report;  // brief report
};
/// Checks xdot and y against x, u and p at (x0, u_0, p) of the first split; prints the brief
/// reports.
std::vector<DerivativeCheckLine> CheckModelDerivatives(const estimators::Problem& problem,
                                                       const estimators::SplitData& split,
                                                       const Eigen::VectorXd& p);

/// Parameter values from a result.json ("parameters": {name: {"value": v}}) or a TOML file of
/// "<instance>.<param>" = value (top level or in [parameters]); names checked against the model.
/// Throws estimators::ProblemFileError.
std::map<std::string, double> LoadParameterValues(const std::string& path,
                                                  const models::StateSpaceModel& model);

/// Writes `content` to `path` through a temporary file in the same folder and a rename, so a
/// reader never sees a half-written file. Throws std::runtime_error on I/O failure.
void WriteFileAtomically(const std::string& path, const std::string& content);

/// SVG plots of a split: measured against simulated outputs, and their residuals.
std::string PlotOutputs(const SplitEvaluation& e, const models::StateSpaceModel& model);
std::string PlotResiduals(const SplitEvaluation& e, const models::StateSpaceModel& model);
/// Equation error: measured against predicted target (e.g. the force) and the residual.
std::string PlotEquation(const SplitEvaluation& e);

}  // namespace graybox::app
