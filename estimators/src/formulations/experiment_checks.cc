#include "formulations/experiment_checks.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "graybox/estimators/nlp/weights.h"

namespace graybox::estimators::internal {

std::string NonFiniteSample(const Experiment& ex) {
  for (const bool input : {true, false}) {
    const Eigen::MatrixXd& m = input ? ex.u : ex.y;
    const std::vector<std::string>& names = input ? ex.u_names : ex.y_names;
    for (Eigen::Index k = 0; k < m.rows(); ++k) {
      for (Eigen::Index j = 0; j < m.cols(); ++j) {
        const double v = m(k, j);
        if (std::isfinite(v)) continue;
        const std::string channel =
            j < static_cast<Eigen::Index>(names.size()) ? names[j] : "column " + std::to_string(j);
        char buf[160];
        const double t = ex.IsUniform() ? ex.t0 + k * ex.dt : ex.time[k];
        std::snprintf(buf, sizeof buf, " at sample %ld (t = %.6g s) is %s", static_cast<long>(k), t,
                      std::isnan(v) ? "NaN" : (v > 0 ? "inf" : "-inf"));
        return std::string(input ? "input '" : "output '") + channel + "'" + buf;
      }
    }
  }
  return "";
}

void CheckExperiments(const models::StateSpaceModel& model,
                      const std::vector<Experiment>& experiments,
                      const std::vector<ExperimentSetup>& setups, const std::string& caller) {
  const int nx = model.NumStates(), nu = model.NumInputs(), ny = model.NumOutputs();
  if (experiments.empty()) {
    throw std::invalid_argument(caller + ": expected at least one experiment, got 0");
  }
  if (setups.size() != experiments.size()) {
    throw std::invalid_argument(caller + ": expected one ExperimentSetup per experiment (" +
                                std::to_string(experiments.size()) + "), got " +
                                std::to_string(setups.size()));
  }
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const Experiment& ex = experiments[e];
    const ExperimentSetup& setup = setups[e];
    const std::string where = "experiment '" + ex.name + "'";
    if (!(ex.dt > 0.0)) {
      throw std::invalid_argument(where + ": expected a sample time > 0, got " +
                                  std::to_string(ex.dt));
    }
    if (std::fabs(ex.dt - experiments[0].dt) > 1e-12 * experiments[0].dt) {
      throw std::invalid_argument(where + ": expected the sample time " +
                                  std::to_string(experiments[0].dt) +
                                  " s of the first experiment, got " + std::to_string(ex.dt));
    }
    if (ex.u.cols() != nu || ex.y.cols() != ny || ex.u.rows() != ex.y.rows() || ex.u.rows() < 1) {
      throw std::invalid_argument(where + ": expected u of N x " + std::to_string(nu) +
                                  " and y of N x " + std::to_string(ny) + " with N >= 1, got " +
                                  std::to_string(ex.u.rows()) + "x" + std::to_string(ex.u.cols()) +
                                  " and " + std::to_string(ex.y.rows()) + "x" +
                                  std::to_string(ex.y.cols()));
    }
    if (!ex.u.allFinite() || !ex.y.allFinite()) {
      throw std::invalid_argument(where + ": data contains NaN or Inf: " + NonFiniteSample(ex));
    }
    if (setup.x0.size() != nx || !setup.x0.allFinite()) {
      throw std::invalid_argument(where + ": expected a finite initial state of size " +
                                  std::to_string(nx) + ", got size " +
                                  std::to_string(setup.x0.size()));
    }
    if (setup.state_guess.size() > 0 &&
        (setup.state_guess.rows() != ex.u.rows() || setup.state_guess.cols() != nx)) {
      throw std::invalid_argument(where + ": expected a state guess of " +
                                  std::to_string(ex.u.rows()) + "x" + std::to_string(nx) +
                                  ", got " + std::to_string(setup.state_guess.rows()) + "x" +
                                  std::to_string(setup.state_guess.cols()));
    }
  }
}

Eigen::VectorXd ResolveOutputWeights(const Eigen::VectorXd& weights, int ny,
                                     const std::vector<Experiment>& experiments,
                                     const std::string& field) {
  if (weights.size() == 0) {
    std::vector<const Eigen::MatrixXd*> ys;
    for (const auto& ex : experiments) ys.push_back(&ex.y);
    return InverseStdWeights(ys);
  }
  if (weights.size() != ny) {
    throw std::invalid_argument(field + ": expected " + std::to_string(ny) + " entries, got " +
                                std::to_string(weights.size()));
  }
  return weights;
}

}  // namespace graybox::estimators::internal
