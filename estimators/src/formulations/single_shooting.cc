#include "graybox/estimators/formulations/single_shooting.h"

#include <limits>
#include <memory>
#include <stdexcept>

#include "formulations/experiment_checks.h"

namespace graybox::estimators {

void SingleShootingOptions::Validate() const { integrator.Validate(); }

namespace {

// The weighted output error of one experiment simulated by the integrator; z = (theta scaled,
// x0 when free).
class SimulationResidual final : public ResidualBlock {
 public:
  SimulationResidual(std::shared_ptr<const Integrator> integrator, const Experiment& ex,
                     const ExperimentSetup& setup, const ParameterMap& map,
                     std::shared_ptr<const Eigen::VectorXd> values, Eigen::VectorXd weights,
                     bool x0_free)
      : integrator_(std::move(integrator)),
        u_(ex.u),
        y_(ex.y),
        x0_(setup.x0),
        map_(map),
        values_(std::move(values)),
        weights_(std::move(weights)),
        x0_free_(x0_free) {}

  int NumResiduals() const override { return static_cast<int>(y_.size()); }

  NlpEvalStatus Evaluate(const Eigen::VectorXd& z, Eigen::VectorXd* r,
                         Eigen::MatrixXd* jacobian) const override {
    const int nf = map_.NumFree();
    const Eigen::Index nx = x0_.size(), ny = y_.cols(), n = y_.rows();
    Eigen::VectorXd p = *values_;  // fixed values shared with the problem (SetFixedValue)
    for (int i = 0; i < nf; ++i) p[map_.free[i]] = map_.scale[i] * z[i];
    const Eigen::VectorXd x0 = x0_free_ ? Eigen::VectorXd(z.segment(nf, nx)) : x0_;
    SensitivityTrajectory t;
    if (jacobian != nullptr) {
      t = integrator_->SimulateWithSensitivities(x0, u_, p, map_.free);
    } else {
      static_cast<Trajectory&>(t) = integrator_->Simulate(x0, u_, p);
    }
    if (!t.summary.ok()) return {false, t.summary.BriefReport()};
    r->resize(n * ny);
    for (Eigen::Index k = 0; k < n; ++k) {
      for (Eigen::Index j = 0; j < ny; ++j)
        r->coeffRef(k * ny + j) = weights_[j] * (t.y(k, j) - y_(k, j));
    }
    if (jacobian == nullptr) return {};
    jacobian->resize(n * ny, z.size());
    for (Eigen::Index k = 0; k < n; ++k) {
      for (Eigen::Index j = 0; j < ny; ++j) {
        const Eigen::Index row = k * ny + j;
        for (int i = 0; i < nf; ++i) {
          (*jacobian)(row, i) = weights_[j] * t.dy_dp[k](j, i) * map_.scale[i];
        }
        for (Eigen::Index i = 0; x0_free_ && i < nx; ++i) {
          (*jacobian)(row, nf + i) = weights_[j] * t.dy_dx0[k](j, i);
        }
      }
    }
    return {};
  }

 private:
  std::shared_ptr<const Integrator> integrator_;
  Eigen::MatrixXd u_, y_;
  Eigen::VectorXd x0_;
  ParameterMap map_;
  std::shared_ptr<const Eigen::VectorXd> values_;
  Eigen::VectorXd weights_;
  bool x0_free_;
};

}  // namespace

ShootingProblem BuildSingleShooting(const models::StateSpaceModel& model,
                                    const std::vector<Experiment>& experiments,
                                    const std::vector<ExperimentSetup>& setups,
                                    const SingleShootingOptions& options) {
  options.Validate();
  internal::CheckExperiments(model, experiments, setups, "BuildSingleShooting");
  const int nx = model.NumStates();
  const ParameterMap map = ParameterMap::FromModel(model.parameters);
  const Eigen::VectorXd weights =
      internal::ResolveOutputWeights(options.output_weights, model.NumOutputs(), experiments,
                                     "SingleShootingOptions.output_weights");
  std::vector<double> w0, lbw, ubw;
  std::vector<std::string> names;
  map.AppendVariables(&w0, &lbw, &ubw, &names);
  std::vector<Eigen::MatrixXi> node_variables;
  // Per experiment: its initial state is a variable when any state's is estimated (held states
  // with equal bounds, ExperimentSetup::x0_free).
  const bool default_free = !options.fix_initial_state;
  std::vector<bool> x0_variables(experiments.size());
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const Experiment& ex = experiments[e];
    Eigen::MatrixXi nodes = Eigen::MatrixXi::Constant(1, nx, -1);
    x0_variables[e] = setups[e].AnyInitialStateFree(nx, default_free);
    for (int i = 0; i < nx && x0_variables[e]; ++i) {
      nodes(0, i) = static_cast<int>(w0.size());
      w0.push_back(setups[e].x0[i]);
      const bool held = !setups[e].InitialStateFree(i, default_free);
      lbw.push_back(held ? setups[e].x0[i] : -std::numeric_limits<double>::infinity());
      ubw.push_back(held ? setups[e].x0[i] : std::numeric_limits<double>::infinity());
      names.push_back(ex.name + ".x0." + model.states[i].name);
    }
    node_variables.push_back(nodes);
  }
  ShootingProblem problem{
      Nlp(Eigen::Map<Eigen::VectorXd>(w0.data(), static_cast<Eigen::Index>(w0.size())),
          Eigen::Map<Eigen::VectorXd>(lbw.data(), static_cast<Eigen::Index>(lbw.size())),
          Eigen::Map<Eigen::VectorXd>(ubw.data(), static_cast<Eigen::Index>(ubw.size())), names),
      map,
      node_variables,
      weights,
      nullptr,
      {}};
  problem.shared_values = std::make_shared<Eigen::VectorXd>(map.values);
  const std::shared_ptr<const Integrator> integrator =
      MakeIntegrator(model, experiments[0].dt, options.integrator);
  std::vector<int> output_channel(model.NumOutputs());
  for (int j = 0; j < model.NumOutputs(); ++j) {
    output_channel[j] = problem.nlp.ResidualChannel(model.outputs[j].name);
  }
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const int r0 = problem.nlp.NumResiduals();
    std::vector<int> variables;
    for (int i = 0; i < map.NumFree(); ++i) variables.push_back(i);
    for (int i = 0; i < nx && x0_variables[e]; ++i) {
      variables.push_back(node_variables[e](0, i));
    }
    problem.nlp.AddResidualBlock(
        "simulation_" + experiments[e].name, variables,
        std::make_shared<SimulationResidual>(integrator, experiments[e], setups[e], map,
                                             problem.shared_values, weights, x0_variables[e]));
    const int ny = model.NumOutputs();
    for (int k = 0; k < experiments[e].NumSamples(); ++k) {
      for (int j = 0; j < ny; ++j) {
        problem.nlp.LabelResidual(r0 + k * ny + j, {static_cast<int>(e), k, output_channel[j]});
      }
    }
  }
  return problem;
}

}  // namespace graybox::estimators
