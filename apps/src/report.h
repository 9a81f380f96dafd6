// Private: what a command writes to DIR (result.json / simulation.json, SVG plots, CSV traces),
// gathered in one struct and serialised in one translation unit (nlohmann_json).
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "app.h"

namespace graybox::app {

struct RunReport {
  std::string command;  // "fit" or "simulate"
  std::string command_line;
  const estimators::Problem* problem = nullptr;
  /// "success", "solver_failure" or "simulation_failure".
  std::string status = "success";
  int exit_code = kExitSuccess;
  std::string message;
  unsigned seed = 0;
  /// Fit: the library's result (solver, parameters, covariance, initial states, timings).
  bool has_fit = false;
  estimators::FitResult fit;
  // Simulate.
  std::string parameter_file;
  // Both: parameter values before and after, the split evaluations, checks and timings.
  Eigen::VectorXd initial_parameters;
  Eigen::VectorXd parameters;
  std::vector<estimators::SplitEvaluation> evaluations;
  std::vector<estimators::DerivativeCheckLine> derivative_checks;
  std::vector<std::pair<std::string, double>> seconds;  // phase -> wall time
};

/// The JSON document (pretty-printed, NaN as null).
std::string ReportJson(const RunReport& report);
/// The measured and simulated outputs of a split as CSV (time, then measured and simulated per
/// output).
std::string TraceCsv(const estimators::SplitEvaluation& e, const models::StateSpaceModel& model);

/// Writes the JSON as `json_name`, the plots in DIR/plots and the traces in DIR/traces, each
/// atomically. Creates DIR when needed. Returns the paths written.
/// Refuses (std::invalid_argument, exit 2) split names that WriteOutputs' file names would not
/// keep apart ("a/b" and "a_b" both become "a_b_outputs.svg") or that hold control characters,
/// naming both splits. Call it before solving.
void CheckSplitFileNames(const std::vector<estimators::SplitData>& splits);

std::vector<std::string> WriteOutputs(const std::string& dir, const std::string& json_name,
                                      const RunReport& report);

}  // namespace graybox::app
