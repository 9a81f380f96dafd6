// Private to the problem-file parser (problem_file.cc: [problem], [model], entry points;
// problem_data.cc: [[data]] and the data loading; problem_estimation.cc: [estimation], [metrics];
// problem_diagnosis.cc: [diagnosis]; problem_equations.cc: equation blocks):
// the TOML section reader with located messages, and shared formatting helpers.
#pragma once

#include <toml++/toml.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "graybox/estimators/problem/problem_file.h"
#include "graybox/estimators/problem/toml_section.h"

namespace graybox::estimators::internal {

// The TOML reader (Section and its helpers) is public: graybox/estimators/problem/toml_section.h.
using namespace toml_io;  // NOLINT(google-build-using-namespace): the parser's own vocabulary

/// Sets each override's key in `root` (problem_overrides.cc; ParseProblem's contract).
void ApplyOverrides(const std::vector<ProblemOverride>& overrides, toml::table* root);
/// "key = value, key = value" for messages.
std::string OverridesText(const std::vector<ProblemOverride>& overrides);

/// The sections, each filling its part of `problem` (the model must be parsed first).
/// What ResolveStateSources could not settle: the key and why (empty key: nothing).
struct StateSourceDefect {
  std::string key;
  std::string message;
};
/// Fills what a problem leaves to defaults in `spec` for `m`: the residual states (every state
/// whose derivative is not simply another state), the inverse input (the only input for one
/// residual state, form "inverse"), and `differentiate` for every state that is not a measured
/// output but the derivative of another state (dq/dt = qd). `states_only`: only the state
/// sources matter (node_guess = "data", the N-step loss). Shared by the problem-file parser and
/// MakeProblem.
StateSourceDefect ResolveStateSources(const models::StateSpaceModel& m, EquationErrorSpec* spec,
                                      bool states_only);

/// The default states of the N-step NRMS ([metrics] n_step_channels left out): those with a
/// model output of the same name, else all.
void DefaultNStepChannels(const models::StateSpaceModel& m, MetricsSpec* spec);

void ParseModel(const Section& root, Problem* problem);
void ParseData(const Section& root, Problem* problem);
/// For every input mapped with hold = "foh" (the same in every [[data]]): a new model input
/// "<input>_foh_rate" (the forward difference, mapped in every record), a signal.first_order_hold
/// "<input>_foh" in series on the input (Model::InsertOnInput), the model built again.
void ApplyFirstOrderHolds(Problem* problem);
void ParseEstimation(const Section& root, Problem* problem);
void ParseMetrics(const Section& root, Problem* problem);
/// The block of a [[model.blocks]] entry of type "equations", from its `equations` table
/// (problem_equations.cc); its defects as ProblemFileError at their place.
std::shared_ptr<const models::Block> EquationBlock(const Section& block);
/// [diagnosis] (problem_diagnosis.cc).
void ParseDiagnosis(const Section& root, Problem* problem);

}  // namespace graybox::estimators::internal
