// Simulation of splits with metrics, finite-difference checks of the model, and atomic writes.
#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "app.h"
#include "equation_error_fit.h"
#include "graybox/estimators/integrator_factory.h"
#include "graybox/estimators/n_step.h"
#include "graybox/expr/derivative_check.h"

namespace graybox::app {

SplitEvaluation EvaluateSimulation(const estimators::Problem& problem,
                                   const estimators::SplitData& split, const Eigen::VectorXd& p,
                                   const Eigen::VectorXd& x0) {
  const estimators::Experiment& e = split.experiment;
  SplitEvaluation ev;
  ev.name = split.name;
  ev.data_name = split.data_name;
  ev.role = split.role;
  ev.time = e.Time();
  ev.measured = e.y;
  ev.x0 = x0;
  const estimators::Trajectory traj =
      estimators::MakeIntegrator(problem.built, e.dt, problem.estimation.integrator)
          ->Simulate(x0, e.u, p);
  ev.simulated = traj.y;
  ev.simulation_ok = traj.ok;
  ev.failed_at = traj.failed_at;
  if (!traj.ok && traj.failed_at >= 0) {
    ev.simulated.bottomRows(ev.simulated.rows() - traj.failed_at).setConstant(std::nan(""));
  }
  ev.simulation = estimators::ComputeMetrics(e, ev.simulated);
  return ev;
}

void EvaluateNStep(const estimators::Problem& problem, const estimators::SplitData& split,
                   const Eigen::VectorXd& p, SplitEvaluation* e) {
  const int steps = problem.metrics.n_step;
  if (steps <= 0) return;
  const estimators::Experiment& ex = split.experiment;
  if (ex.NumSamples() <= steps) {
    throw std::invalid_argument("split '" + split.name +
                                "': [metrics] n_step = " + std::to_string(steps) +
                                " needs more than " + std::to_string(steps) + " samples, got " +
                                std::to_string(ex.NumSamples()));
  }
  const Eigen::MatrixXd x = StatesFromData(problem, problem.estimation.equation_error, ex);
  estimators::NStepSimulationOptions options;
  options.scoring.steps = steps;
  options.scoring.stride = problem.metrics.n_step_stride;
  options.step = problem.estimation.step;
  e->n_step = estimators::NStepNrmsSimulated(problem.built, x, ex.u, p, ex.dt, options);
  e->has_n_step = true;
}

std::vector<DerivativeCheckLine> CheckModelDerivatives(const estimators::Problem& problem,
                                                       const estimators::SplitData& split,
                                                       const Eigen::VectorXd& p) {
  std::vector<DerivativeCheckLine> lines;
  const models::StateSpaceModel& m = problem.built;
  const Eigen::VectorXd u0 = split.experiment.u.row(0).transpose();
  for (const auto* f : {&m.dynamics, &m.output}) {
    const std::string out = f->OutputName(0);
    for (const char* in : {"x", "u", "p"}) {
      if (f->OutputSize(0) == 0 || f->InputSize(f->InputIndex(in)) == 0) continue;
      const expr::DerivativeCheckResult r = expr::CheckJacobian(*f, out, in, {split.x0, u0, p});
      DerivativeCheckLine line;
      line.what = "d " + out + " / d " + in;
      line.ok = r.ok;
      line.max_error = r.max_error;
      line.report = r.BriefReport();
      std::cout << "  " << line.report << "\n";
      if (!r.ok) std::cout << r.FullReport();
      lines.push_back(line);
    }
  }
  return lines;
}

void WriteFileAtomically(const std::string& path, const std::string& content) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path temp = target.parent_path() / ("." + target.filename().string() + ".tmp-" +
                                                std::to_string(static_cast<long>(::getpid())));
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << content;
    out.flush();
    if (!out) {
      std::error_code ignored;
      fs::remove(temp, ignored);
      throw std::runtime_error("cannot write '" + temp.string() + "'");
    }
  }
  std::error_code ec;
  fs::rename(temp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw std::runtime_error("cannot rename '" + temp.string() + "' to '" + path +
                             "': " + ec.message());
  }
}

}  // namespace graybox::app
