#include "graybox/estimators/formulations/multiple_shooting.h"

#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

#include "formulations/experiment_checks.h"
#include "graybox/estimators/integrators/integrators.h"

namespace graybox::estimators {

using expr::Expr;
using expr::Function;

void MultipleShootingOptions::Validate() const {
  if (segment_length < 1) {
    throw std::invalid_argument("MultipleShootingOptions.segment_length: expected >= 1, got " +
                                std::to_string(segment_length));
  }
  step.Validate();
  if (!(continuity_weight > 0.0)) {
    throw std::invalid_argument("MultipleShootingOptions.continuity_weight: expected > 0, got " +
                                std::to_string(continuity_weight));
  }
}

void ShootingProblem::SetFixedValue(int parameter, double value) {
  const int slot = parameters.SetFixedValue(parameter, value);
  if (shared_values) (*shared_values)[parameter] = value;
  for (std::size_t g : fixed_value_groups) nlp.SetGroupDataRow(g, slot, value);
  nlp.ClearCaches();
}

Eigen::VectorXd ShootingProblem::InitialState(const Eigen::VectorXd& w, int e) const {
  const Eigen::MatrixXi& nodes = node_variables.at(e);
  Eigen::VectorXd x(nodes.cols());
  for (Eigen::Index i = 0; i < nodes.cols(); ++i) {
    x[i] = nodes(0, i) >= 0 ? w[nodes(0, i)] : std::nan("");
  }
  return x;
}

namespace {

// Builds the element Function of one segment kind.
Function SegmentFunction(const models::StateSpaceModel& model, const Function& step,
                         const ParameterMap& map, const Eigen::VectorXd& weights, int length,
                         bool start_fixed, bool has_next, bool continuity_as_constraints,
                         double continuity_weight) {
  const int nx = model.NumStates(), nu = model.NumInputs(), ny = model.NumOutputs();
  std::vector<Expr> z = Expr::Symbols("theta", map.NumFree());
  // Fixed parameters are data (rows 0 .. NumFixed()-1 of d), so changing one needs no rebuild.
  std::vector<Expr> d = Expr::Symbols("q", map.NumFixed());
  const std::vector<Expr> p = map.ParameterExprs(z, d);
  std::vector<Expr> s = Expr::Symbols("s", nx);
  if (start_fixed) {
    d.insert(d.end(), s.begin(), s.end());
  } else {
    z.insert(z.end(), s.begin(), s.end());
  }
  std::vector<Expr> s_next;
  if (has_next) {
    s_next = Expr::Symbols("s_next", nx);
    z.insert(z.end(), s_next.begin(), s_next.end());
  }
  const std::vector<Expr> u = Expr::Symbols("u", length * nu);
  const std::vector<Expr> y = Expr::Symbols("y", length * ny);
  d.insert(d.end(), u.begin(), u.end());
  d.insert(d.end(), y.begin(), y.end());
  std::vector<Expr> r, c;
  std::vector<Expr> x = s;
  for (int k = 0; k < length; ++k) {
    const std::vector<Expr> uk(u.begin() + k * nu, u.begin() + (k + 1) * nu);
    const std::vector<Expr> yk = model.output.Call({x, uk, p})[0];
    for (int j = 0; j < ny; ++j) r.push_back(weights[j] * (yk[j] - y[k * ny + j]));
    if (k + 1 < length || has_next) x = step.Call({x, uk, p})[0];
  }
  if (has_next) {
    for (int i = 0; i < nx; ++i) {
      if (continuity_as_constraints) {
        c.push_back(x[i] - s_next[i]);
      } else {
        r.push_back(continuity_weight * (x[i] - s_next[i]));
      }
    }
  }
  return Function("segment", {{"z", z}, {"d", d}}, {{"r", r}, {"c", c}});
}

}  // namespace

ShootingProblem BuildMultipleShooting(const models::StateSpaceModel& model,
                                      const std::vector<Experiment>& experiments,
                                      const std::vector<ExperimentSetup>& setups,
                                      const MultipleShootingOptions& options) {
  options.Validate();
  const int nx = model.NumStates(), nu = model.NumInputs(), ny = model.NumOutputs();
  internal::CheckExperiments(model, experiments, setups, "BuildMultipleShooting");
  const ParameterMap map = ParameterMap::FromModel(model.parameters);
  const int nf = map.NumFree();
  const Eigen::VectorXd& values = map.values;
  const Eigen::VectorXd weights = internal::ResolveOutputWeights(
      options.output_weights, ny, experiments, "MultipleShootingOptions.output_weights");
  // Variables: theta (scaled), then the nodes of every experiment.
  std::vector<double> w0, lbw, ubw;
  std::vector<std::string> names;
  map.AppendVariables(&w0, &lbw, &ubw, &names);
  const Function step = MakeStepFunction(model, experiments[0].dt, options.step);
  const int length = options.segment_length;
  std::vector<Eigen::MatrixXi> node_variables;
  struct Pending {
    int experiment, start, len;
    bool fixed, has_next;
    int node;
  };
  std::vector<Pending> segments;
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const auto& ex = experiments[e];
    const int n = static_cast<int>(ex.u.rows());
    const int num_segments = (n + length - 1) / length;
    const ExperimentSetup& setup = setups[e];
    Eigen::MatrixXd guess = setup.state_guess;
    if (guess.size() == 0)
      guess = SimulateFixedStep(model, setup.x0, ex.u, values, ex.dt, options.step).x;
    if (!guess.allFinite()) {
      throw std::invalid_argument(
          "experiment '" + ex.name +
          "': the simulation at the initial parameter values that guesses the shooting nodes "
          "diverges; give start values that simulate, [estimation.multiple_shooting] node_guess "
          "= \"data\" (nodes from the measurements), or ExperimentSetup::state_guess in C++");
    }
    Eigen::MatrixXi nodes = Eigen::MatrixXi::Constant(num_segments, nx, -1);
    // The first node is data when no state's initial value is estimated; else variables, those
    // of held states with equal bounds (ExperimentSetup::x0_free).
    const bool default_free = !options.fix_initial_state;
    const bool any_free = setup.AnyInitialStateFree(nx, default_free);
    for (int j = 0; j < num_segments; ++j) {
      const bool fixed = j == 0 && !any_free;
      for (int i = 0; i < nx && !fixed; ++i) {
        nodes(j, i) = static_cast<int>(w0.size());
        w0.push_back(j == 0 ? setup.x0[i] : guess(j * length, i));
        const bool held = j == 0 && !setup.InitialStateFree(i, default_free);
        lbw.push_back(held ? setup.x0[i] : -std::numeric_limits<double>::infinity());
        ubw.push_back(held ? setup.x0[i] : std::numeric_limits<double>::infinity());
        names.push_back(ex.name + ".s" + std::to_string(j) + "." + model.states[i].name);
      }
      const int start = j * length;
      segments.push_back({static_cast<int>(e), start, std::min(length, n - start), fixed,
                          j + 1 < num_segments, j});
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
  std::vector<int> output_channel(ny), continuity_channel(nx);
  for (int j = 0; j < ny; ++j)
    output_channel[j] = problem.nlp.ResidualChannel(model.outputs[j].name);
  for (int i = 0; i < nx; ++i) {
    continuity_channel[i] = problem.nlp.ResidualChannel("continuity." + model.states[i].name);
  }
  // One group per segment kind (length, fixed start, continuity).
  std::map<std::tuple<int, bool, bool>, std::vector<const Pending*>> kinds;
  for (const auto& s : segments) kinds[{s.len, s.fixed, s.has_next}].push_back(&s);
  for (const auto& [kind, members] : kinds) {
    const auto [len, fixed, has_next] = kind;
    ElementGroup g;
    g.name =
        "segment_L" + std::to_string(len) + (fixed ? "_fixed" : "") + (has_next ? "" : "_last");
    g.fn = SegmentFunction(model, step, map, weights, len, fixed, has_next,
                           options.continuity_as_constraints, options.continuity_weight);
    const int nz = g.fn.InputSize(0), nd = g.fn.InputSize(1);
    g.index.resize(nz, static_cast<Eigen::Index>(members.size()));
    g.data.resize(nd, static_cast<Eigen::Index>(members.size()));
    const int nc = g.fn.OutputSize(g.fn.OutputIndex("c"));
    g.lbc = Eigen::VectorXd::Zero(nc);
    g.ubc = Eigen::VectorXd::Zero(nc);
    for (std::size_t m = 0; m < members.size(); ++m) {
      const Pending& s = *members[m];
      const auto& ex = experiments[s.experiment];
      const Eigen::MatrixXi& nodes = node_variables[s.experiment];
      int zi = 0;
      for (int i = 0; i < nf; ++i) g.index(zi++, m) = i;
      if (!s.fixed) {
        for (int i = 0; i < nx; ++i) g.index(zi++, m) = nodes(s.node, i);
      }
      if (s.has_next) {
        for (int i = 0; i < nx; ++i) g.index(zi++, m) = nodes(s.node + 1, i);
      }
      int di = 0;
      for (int j = 0; j < map.NumFixed(); ++j) g.data(di++, m) = values[map.fixed[j]];
      if (s.fixed) {
        for (int i = 0; i < nx; ++i) g.data(di++, m) = setups[s.experiment].x0[i];
      }
      for (int k = 0; k < s.len; ++k) {
        for (int i = 0; i < nu; ++i) g.data(di++, m) = ex.u(s.start + k, i);
      }
      for (int k = 0; k < s.len; ++k) {
        for (int i = 0; i < ny; ++i) g.data(di++, m) = ex.y(s.start + k, i);
      }
    }
    const int nr = g.fn.OutputSize(g.fn.OutputIndex("r"));
    const int r0 = problem.nlp.NumResiduals();
    problem.nlp.AddGroup(std::move(g));
    problem.fixed_value_groups.push_back(problem.nlp.groups().size() - 1);
    // Labels: the output rows (sample, channel), then the continuity rows of the Ceres form.
    for (std::size_t m = 0; m < members.size(); ++m) {
      const Pending& s = *members[m];
      int row = r0 + static_cast<int>(m) * nr;
      for (int k = 0; k < s.len; ++k) {
        for (int j = 0; j < ny; ++j) {
          problem.nlp.LabelResidual(row++, {s.experiment, s.start + k, output_channel[j]});
        }
      }
      for (int i = 0; row < r0 + (static_cast<int>(m) + 1) * nr; ++i) {
        problem.nlp.LabelResidual(row++, {s.experiment, s.start + s.len, continuity_channel[i]});
      }
    }
  }
  return problem;
}

}  // namespace graybox::estimators
