// MakeProblem and MakeSplit: Problems and splits built in C++.
#include <stdexcept>

#include "graybox/estimators/fit/fit.h"
#include "problem/problem_file_internal.h"

namespace graybox::estimators {

Problem MakeProblem(const std::string& name, const models::Model& model, EstimationSpec estimation,
                    MetricsSpec metrics) {
  const std::vector<std::string> methods = {"multiple_shooting", "single_shooting", "collocation",
                                            "equation_error", "n_step"};
  bool known = false;
  for (const auto& m : methods) known = known || m == estimation.method;
  if (!known) {
    throw std::invalid_argument(
        "MakeProblem: EstimationSpec.method: expected one of "
        "multiple_shooting, single_shooting, collocation, "
        "equation_error, n_step, got '" +
        estimation.method + "'");
  }
  const bool least_squares = estimation.method == "equation_error" || estimation.method == "n_step";
  if (estimation.solver.empty()) estimation.solver = least_squares ? "ceres" : "ipopt";
  if (estimation.solver != "ipopt" && estimation.solver != "ceres") {
    throw std::invalid_argument(
        "MakeProblem: EstimationSpec.solver: expected 'ipopt' or "
        "'ceres', got '" +
        estimation.solver + "'");
  }
  if (estimation.method == "collocation" && estimation.solver != "ipopt") {
    throw std::invalid_argument(
        "MakeProblem: collocation has equality constraints: expected "
        "solver 'ipopt', got '" +
        estimation.solver + "'");
  }
  estimation.step.Validate();
  estimation.multiple_shooting.step = estimation.step;
  if (estimation.integrator.method == IntegrationMethod::kFixedStep) {
    estimation.integrator.fixed_step = estimation.step;
  }
  estimation.n_step.integrator = estimation.integrator;
  estimation.multiple_shooting.continuity_as_constraints = estimation.solver == "ipopt";
  estimation.multiple_shooting.Validate();
  estimation.ipopt.Validate();
  estimation.ceres.Validate();
  Problem problem;
  problem.path = "<code>";
  problem.directory = ".";
  problem.name = name;
  problem.model = model;
  problem.built = problem.model.Build();
  // The equation-error defaults a problem file infers (residual states, inverse input, which
  // states are derivatives of which), where equation error, node_guess = "data" or the N-step
  // loss need the states from data.
  const bool states_only = estimation.method != "equation_error";
  if (!states_only || estimation.node_guess == "data" || estimation.method == "n_step") {
    const internal::StateSourceDefect defect =
        internal::ResolveStateSources(problem.built, &estimation.equation_error, states_only);
    if (!defect.key.empty()) {
      throw std::invalid_argument("MakeProblem: EstimationSpec.equation_error." + defect.key +
                                  ": " + defect.message);
    }
  }
  problem.estimation = std::move(estimation);
  problem.metrics = std::move(metrics);
  MetricsSpec& ms = problem.metrics;
  if (ms.n_step_channel_indices.empty() && !ms.n_step_channels.empty()) {
    for (const std::string& name : ms.n_step_channels) {
      ms.n_step_channel_indices.push_back(problem.built.StateIndex(name));  // did-you-mean
    }
    ms.n_step_channels_given = true;
  } else if (ms.n_step_channel_indices.empty()) {
    internal::DefaultNStepChannels(problem.built, &ms);
  }
  return problem;
}

SplitData MakeSplit(const std::string& name, SplitRole role, Experiment experiment,
                    Eigen::VectorXd x0) {
  experiment.name = name;
  experiment.Validate();
  SplitData s;
  s.name = name;
  s.data_name = name;
  s.role = role;
  s.experiment = std::move(experiment);
  s.setup.x0 = std::move(x0);
  return s;
}

}  // namespace graybox::estimators
