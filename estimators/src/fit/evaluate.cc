// Simulate, EvaluateSplit, CheckModelDerivatives, StatesFromData.
#include <cmath>
#include <stdexcept>

#include "fit/equation_error_fit.h"
#include "graybox/estimators/analysis/n_step.h"
#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/expr/derivative_check.h"
#include "graybox/util/matrix_rows.h"

namespace graybox::estimators {

Eigen::MatrixXd StatesFromData(const Problem& problem, const Experiment& experiment) {
  return internal::StatesFromSpec(problem, problem.estimation.equation_error, experiment);
}

namespace {

// Adds the N-step-ahead NRMS of a split ([metrics] n_step) from the states in its data.
void EvaluateNStep(const Problem& problem, const SplitData& split, const Eigen::VectorXd& p,
                   SplitEvaluation* e) {
  const int steps = problem.metrics.n_step;
  if (steps <= 0) return;
  const Experiment& ex = split.experiment;
  if (ex.NumSamples() <= steps) {
    throw std::invalid_argument("split '" + split.name +
                                "': [metrics] n_step = " + std::to_string(steps) +
                                " needs more than " + std::to_string(steps) + " samples, got " +
                                std::to_string(ex.NumSamples()));
  }
  const Eigen::MatrixXd x = StatesFromData(problem, ex);
  NStepSimulationOptions options;
  options.scoring.steps = steps;
  options.scoring.stride = problem.metrics.n_step_stride;
  options.scoring.channels = problem.metrics.n_step_channel_indices;  // default: measured states
  options.step = problem.estimation.step;
  e->n_step = NStepNrmsSimulated(problem.built, x, ex.u, p, ex.dt, options);
  e->has_n_step = true;
}

}  // namespace

SplitEvaluation EvaluateSplit(const Problem& problem, const SplitData& split,
                              const Eigen::VectorXd& values, const Eigen::VectorXd& x0) {
  const models::StateSpaceModel& m = problem.built;
  if (values.size() != m.NumParameters() || !values.allFinite()) {
    throw std::invalid_argument("EvaluateSplit: expected " + std::to_string(m.NumParameters()) +
                                " finite parameter values, got " + std::to_string(values.size()));
  }
  if (x0.size() != m.NumStates()) {
    throw std::invalid_argument("EvaluateSplit: split '" + split.name + "': expected x0 of size " +
                                std::to_string(m.NumStates()) + ", got " +
                                std::to_string(x0.size()));
  }
  const Experiment& e = split.experiment;
  SplitEvaluation ev;
  ev.name = split.name;
  ev.data_name = split.data_name;
  ev.role = split.role;
  ev.time = e.Time();
  ev.measured = e.y;
  ev.x0 = x0;
  const Trajectory traj =
      MakeIntegrator(m, e.dt, problem.estimation.integrator)->Simulate(x0, e.u, values);
  ev.simulated = traj.y;
  ev.states = traj.x;
  ev.inputs = e.u;
  ev.simulation_ok = traj.ok;
  ev.failed_at = traj.failed_at;
  if (!traj.ok && traj.failed_at >= 0) {
    ev.simulated.bottomRows(ev.simulated.rows() - traj.failed_at).setConstant(std::nan(""));
    ev.states.bottomRows(ev.states.rows() - traj.failed_at).setConstant(std::nan(""));
  }
  ev.simulation = ComputeMetrics(e, ev.simulated);
  EvaluateNStep(problem, split, values, &ev);
  return ev;
}

Eigen::VectorXd InitialStateOf(const SplitData& split,
                               const std::map<std::string, Eigen::VectorXd>& estimated) {
  const auto own = estimated.find(split.name);
  if (own != estimated.end()) return own->second;
  Eigen::VectorXd x0 = split.setup.x0;
  for (const auto& [state, from] : split.x0_from_split) {
    const auto it = estimated.find(from);
    if (it != estimated.end() && state < it->second.size() && state < x0.size()) {
      x0[state] = it->second[state];
    }
  }
  return x0;
}

std::vector<SplitEvaluation> Simulate(
    const Problem& problem, const std::vector<SplitData>& splits, const Eigen::VectorXd& values,
    const std::map<std::string, Eigen::VectorXd>& initial_states) {
  std::vector<SplitEvaluation> out;
  for (const SplitData& s : splits) {
    out.push_back(EvaluateSplit(problem, s, values, InitialStateOf(s, initial_states)));
  }
  return out;
}

std::vector<DerivativeCheckLine> CheckModelDerivatives(const Problem& problem,
                                                       const SplitData& split,
                                                       const Eigen::VectorXd& values) {
  std::vector<DerivativeCheckLine> lines;
  const models::StateSpaceModel& m = problem.built;
  const Eigen::VectorXd u0 = util::RowAsVector(split.experiment.u, 0);
  for (const auto* f : {&m.dynamics, &m.output}) {
    const std::string out = f->OutputName(0);
    for (const char* in : {"x", "u", "p"}) {
      if (f->OutputSize(0) == 0 || f->InputSize(f->InputIndex(in)) == 0) continue;
      const expr::DerivativeCheckResult r =
          expr::CheckJacobian(*f, out, in, {split.setup.x0, u0, values});
      DerivativeCheckLine line;
      line.what = "d " + out + " / d " + in;
      line.ok = r.ok;
      line.max_error = r.max_error;
      line.report = r.BriefReport();
      if (!r.ok) line.report += "\n" + r.FullReport();
      lines.push_back(line);
    }
  }
  return lines;
}

std::string SplitEvaluation::BriefReport() const {
  std::string s = "split '" + name + "' (" + SplitRoleName(role) +
                  ") simulation: " + simulation.BriefReport() +
                  (simulation_ok ? "" : " [diverged at sample " + std::to_string(failed_at) + "]");
  if (has_n_step) s += "; " + n_step.BriefReport();
  if (has_equation) s += "; equation: " + equation.BriefReport();
  return s;
}

}  // namespace graybox::estimators
