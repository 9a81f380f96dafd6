#include "graybox/estimators/formulations/collocation.h"

#include <unsupported/Eigen/Polynomials>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "formulations/experiment_checks.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/nlp/weights.h"
#include "graybox/util/matrix_rows.h"

namespace graybox::estimators {

using expr::Expr;
using expr::Function;

void CollocationOptions::Validate() const {
  if (degree < 1 || degree > 9) {
    throw std::invalid_argument("CollocationOptions.degree: expected 1..9, got " +
                                std::to_string(degree));
  }
}

namespace {

// Coefficients (ascending powers of s) of the Legendre polynomial P_n(s), by the three-term
// recurrence (n + 1) P_{n+1} = (2n + 1) s P_n - n P_{n-1}.
Eigen::VectorXd Legendre(int n) {
  Eigen::VectorXd p0 = Eigen::VectorXd::Zero(n + 1), p1 = Eigen::VectorXd::Zero(n + 1);
  p0[0] = 1.0;
  if (n == 0) return p0;
  p1[1] = 1.0;
  for (int k = 1; k < n; ++k) {
    Eigen::VectorXd p2 = Eigen::VectorXd::Zero(n + 1);
    for (int i = 0; i < n; ++i) p2[i + 1] += (2.0 * k + 1.0) * p1[i];
    p2 -= k * p0;
    p2 /= (k + 1.0);
    p0 = p1;
    p1 = p2;
  }
  return p1;
}

// Lagrange basis on the nodes: value and derivative of L_r at tau.
double Basis(const Eigen::VectorXd& nodes, int r, double tau) {
  double v = 1.0;
  for (Eigen::Index m = 0; m < nodes.size(); ++m) {
    if (m != r) v *= (tau - nodes[m]) / (nodes[r] - nodes[m]);
  }
  return v;
}
double BasisDerivative(const Eigen::VectorXd& nodes, int r, double tau) {
  double sum = 0.0;
  for (Eigen::Index j = 0; j < nodes.size(); ++j) {
    if (j == r) continue;
    double term = 1.0 / (nodes[r] - nodes[j]);
    for (Eigen::Index m = 0; m < nodes.size(); ++m) {
      if (m != r && m != j) term *= (tau - nodes[m]) / (nodes[r] - nodes[m]);
    }
    sum += term;
  }
  return sum;
}

}  // namespace

Eigen::VectorXd CollocationPoints(CollocationScheme scheme, int degree) {
  if (degree < 1 || degree > 9) {
    throw std::invalid_argument("CollocationPoints: expected degree 1..9, got " +
                                std::to_string(degree));
  }
  Eigen::VectorXd poly = Legendre(degree);  // in s = 2 tau - 1
  if (scheme == CollocationScheme::kRadau) {
    const Eigen::VectorXd lower = Legendre(degree - 1);
    poly.head(lower.size()) -= lower;
  }
  Eigen::PolynomialSolver<double, Eigen::Dynamic> solver;
  solver.compute(poly);
  std::vector<double> roots;
  solver.realRoots(roots, 1e-9);
  if (static_cast<int>(roots.size()) != degree) {
    throw std::logic_error("CollocationPoints: expected " + std::to_string(degree) +
                           " real roots, got " + std::to_string(roots.size()));
  }
  std::sort(roots.begin(), roots.end());
  Eigen::VectorXd tau(degree);
  for (int i = 0; i < degree; ++i) tau[i] = std::clamp(0.5 * (roots[i] + 1.0), 0.0, 1.0);
  if (scheme == CollocationScheme::kRadau) tau[degree - 1] = 1.0;  // exact end point
  return tau;
}

void CollocationProblem::SetFixedValue(int parameter, double value) {
  const int slot = parameters.SetFixedValue(parameter, value);
  for (std::size_t g : fixed_value_groups) nlp.SetGroupDataRow(g, slot, value);
}

CollocationProblem BuildCollocation(const models::StateSpaceModel& model,
                                    const std::vector<Experiment>& experiments,
                                    const std::vector<ExperimentSetup>& setups,
                                    const CollocationOptions& options) {
  options.Validate();
  const int nx = model.NumStates(), nu = model.NumInputs(), ny = model.NumOutputs();
  const int deg = options.degree;
  if (experiments.empty()) {
    throw std::invalid_argument("BuildCollocation: expected at least one experiment, got 0");
  }
  if (setups.size() != experiments.size()) {
    throw std::invalid_argument("BuildCollocation: expected one ExperimentSetup per experiment (" +
                                std::to_string(experiments.size()) + "), got " +
                                std::to_string(setups.size()));
  }
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const Experiment& ex = experiments[e];
    const Eigen::VectorXd& x0 = setups[e].x0;
    if (!(ex.dt > 0.0) || ex.u.cols() != nu || ex.y.cols() != ny || ex.u.rows() != ex.y.rows() ||
        ex.u.rows() < 2 || x0.size() != nx) {
      throw std::invalid_argument("experiment '" + ex.name + "': expected dt > 0, u of N x " +
                                  std::to_string(nu) + ", y of N x " + std::to_string(ny) +
                                  " (N >= 2) and x0 of size " + std::to_string(nx));
    }
    if (!ex.u.allFinite() || !ex.y.allFinite()) {
      throw std::invalid_argument("experiment '" + ex.name +
                                  "': data contains NaN or Inf: " + internal::NonFiniteSample(ex));
    }
    if (!x0.allFinite()) {
      throw std::invalid_argument("experiment '" + ex.name + "': the initial state is not finite");
    }
  }
  const ParameterMap map = ParameterMap::FromModel(model.parameters);
  const int nf = map.NumFree();
  Eigen::VectorXd weights = options.output_weights;
  if (weights.size() == 0) {
    std::vector<const Eigen::MatrixXd*> ys;
    for (const auto& ex : experiments) ys.push_back(&ex.y);
    weights = InverseStdWeights(ys);
  }
  // Nodes tau_0 = 0, tau_1..tau_d and the matrices of the collocation equations.
  const Eigen::VectorXd tau = CollocationPoints(options.scheme, deg);
  Eigen::VectorXd nodes(deg + 1);
  nodes << 0.0, tau;
  Eigen::MatrixXd c(deg + 1, deg);  // c(r, j) = L_r'(tau_j)
  Eigen::VectorXd end(deg + 1);     // L_r(1)
  for (int r = 0; r <= deg; ++r) {
    for (int j = 0; j < deg; ++j) c(r, j) = BasisDerivative(nodes, r, tau[j]);
    end[r] = Basis(nodes, r, 1.0);
  }
  // Variables.
  std::vector<double> w0, lbw, ubw;
  std::vector<std::string> names;
  map.AppendVariables(&w0, &lbw, &ubw, &names);
  const Eigen::VectorXd values = map.values;
  std::vector<Eigen::MatrixXi> state_vars;
  std::vector<Eigen::MatrixXi> colloc_vars;
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const Experiment& ex = experiments[e];
    const int n = static_cast<int>(ex.u.rows());
    Eigen::MatrixXd guess = setups[e].state_guess;
    if (guess.size() == 0) {
      // Stiff models: the L-stable Radau IIA map, stable at any step; otherwise RK4.
      FixedStepOptions step;
      step.scheme = model.stiff ? StepScheme::kRadauIIA : StepScheme::kRk4;
      step.substeps = 4;
      step.newton_iterations = 2;
      guess = SimulateFixedStep(model, setups[e].x0, ex.u, values, ex.dt, step).x;
    }
    if (!guess.allFinite()) {
      throw std::invalid_argument(
          "experiment '" + ex.name +
          "': the simulation at the initial parameter values that guesses the collocation states "
          "diverges; give start values that simulate ([model.parameters]), or "
          "ExperimentSetup::state_guess in C++");
    }
    Eigen::MatrixXi sv(n, nx), cv((n - 1) * deg, nx);
    for (int k = 0; k < n; ++k) {
      for (int i = 0; i < nx; ++i) {
        sv(k, i) = static_cast<int>(w0.size());
        // The initial state is estimated, except states held by ExperimentSetup::x0_free (a
        // variable with equal bounds at x0).
        const bool held = k == 0 && !setups[e].InitialStateFree(i, true);
        w0.push_back(held ? setups[e].x0[i] : guess(k, i));
        lbw.push_back(held ? setups[e].x0[i] : -std::numeric_limits<double>::infinity());
        ubw.push_back(held ? setups[e].x0[i] : std::numeric_limits<double>::infinity());
        names.push_back(ex.name + ".x" + std::to_string(k) + "." + model.states[i].name);
      }
      if (k + 1 == n) break;
      for (int j = 0; j < deg; ++j) {
        for (int i = 0; i < nx; ++i) {
          cv(k * deg + j, i) = static_cast<int>(w0.size());
          // Linear interpolation between the guessed samples.
          w0.push_back(guess(k, i) + tau[j] * (guess(k + 1, i) - guess(k, i)));
          lbw.push_back(-std::numeric_limits<double>::infinity());
          ubw.push_back(std::numeric_limits<double>::infinity());
          names.push_back(ex.name + ".x" + std::to_string(k) + "_c" + std::to_string(j + 1) + "." +
                          model.states[i].name);
        }
      }
    }
    state_vars.push_back(sv);
    colloc_vars.push_back(cv);
  }
  auto vec = [](std::vector<double>& v) {
    return Eigen::VectorXd(
        Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  CollocationProblem problem{Nlp(vec(w0), vec(lbw), vec(ubw), names), map, state_vars, weights, {}};
  // Element functions: an interval, and the output residual of the last sample.
  std::vector<Expr> theta = Expr::Symbols("theta", nf);
  // Fixed parameters are data (rows 0 .. NumFixed()-1 of d): SetFixedValue needs no rebuild.
  std::vector<Expr> d = Expr::Symbols("q", map.NumFixed());
  const std::vector<Expr> p = map.ParameterExprs(theta, d);
  const Eigen::VectorXd q = map.FixedValues();
  const int nq = map.NumFixed();
  const std::vector<Expr> u = Expr::Symbols("u", nu), y = Expr::Symbols("y", ny);
  d.insert(d.end(), u.begin(), u.end());
  d.insert(d.end(), y.begin(), y.end());
  const std::vector<Expr> xk = Expr::Symbols("xk", nx), xnext = Expr::Symbols("xnext", nx);
  std::vector<std::vector<Expr>> xc(deg + 1);
  xc[0] = xk;
  for (int j = 1; j <= deg; ++j) xc[j] = Expr::Symbols("xc" + std::to_string(j), nx);
  const std::vector<Expr> yk = model.output.Call({xk, u, p})[0];
  std::vector<Expr> r;
  for (int j = 0; j < ny; ++j) r.push_back(weights[j] * (yk[j] - y[j]));
  const double h = experiments[0].dt;
  std::vector<Expr> cons;
  for (int j = 1; j <= deg; ++j) {
    const std::vector<Expr> f = model.dynamics.Call({xc[j], u, p})[0];
    for (int i = 0; i < nx; ++i) {
      Expr lhs(0.0);
      for (int rr = 0; rr <= deg; ++rr) lhs += c(rr, j - 1) * xc[rr][i];
      cons.push_back(lhs - h * f[i]);
    }
  }
  for (int i = 0; i < nx; ++i) {
    Expr x_end(0.0);
    for (int rr = 0; rr <= deg; ++rr) x_end += end[rr] * xc[rr][i];
    cons.push_back(x_end - xnext[i]);
  }
  std::vector<Expr> z(theta);
  for (int j = 0; j <= deg; ++j) z.insert(z.end(), xc[j].begin(), xc[j].end());
  z.insert(z.end(), xnext.begin(), xnext.end());
  ElementGroup interval;
  interval.name = "collocation_interval";
  interval.fn = Function("collocation_interval", {{"z", z}, {"d", d}}, {{"r", r}, {"c", cons}});
  std::vector<Expr> z_last(theta);
  z_last.insert(z_last.end(), xk.begin(), xk.end());
  ElementGroup last;
  last.name = "last_sample";
  last.fn = Function("last_sample", {{"z", z_last}, {"d", d}}, {{"r", r}});
  long intervals = 0;
  for (const auto& ex : experiments) intervals += ex.u.rows() - 1;
  interval.index.resize(static_cast<Eigen::Index>(z.size()), intervals);
  interval.data.resize(nq + nu + ny, intervals);
  last.index.resize(static_cast<Eigen::Index>(z_last.size()),
                    static_cast<Eigen::Index>(experiments.size()));
  last.data.resize(nq + nu + ny, static_cast<Eigen::Index>(experiments.size()));
  long col = 0;
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const auto& ex = experiments[e];
    const int n = static_cast<int>(ex.u.rows());
    for (int k = 0; k + 1 < n; ++k, ++col) {
      int zi = 0;
      for (int i = 0; i < nf; ++i) interval.index(zi++, col) = i;
      for (int i = 0; i < nx; ++i) interval.index(zi++, col) = state_vars[e](k, i);
      for (int j = 0; j < deg; ++j) {
        for (int i = 0; i < nx; ++i) interval.index(zi++, col) = colloc_vars[e](k * deg + j, i);
      }
      for (int i = 0; i < nx; ++i) interval.index(zi++, col) = state_vars[e](k + 1, i);
      interval.data.col(col) << q, util::RowAsVector(ex.u, k), util::RowAsVector(ex.y, k);
    }
    int zi = 0;
    for (int i = 0; i < nf; ++i) last.index(zi++, static_cast<Eigen::Index>(e)) = i;
    for (int i = 0; i < nx; ++i)
      last.index(zi++, static_cast<Eigen::Index>(e)) = state_vars[e](n - 1, i);
    last.data.col(static_cast<Eigen::Index>(e)) << q, util::RowAsVector(ex.u, n - 1),
        util::RowAsVector(ex.y, n - 1);
  }
  interval.lbc = Eigen::VectorXd::Zero((deg + 1) * nx);
  interval.ubc = Eigen::VectorXd::Zero((deg + 1) * nx);
  last.lbc.resize(0);
  last.ubc.resize(0);
  std::vector<int> output_channel(ny);
  for (int j = 0; j < ny; ++j)
    output_channel[j] = problem.nlp.ResidualChannel(model.outputs[j].name);
  problem.nlp.AddGroup(std::move(interval));
  problem.nlp.AddGroup(std::move(last));
  // Labels: interval k of experiment e holds sample k's outputs; the last group sample N-1.
  int row = 0;
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    for (int k = 0; k + 1 < experiments[e].NumSamples(); ++k) {
      for (int j = 0; j < ny; ++j) {
        problem.nlp.LabelResidual(row++, {static_cast<int>(e), k, output_channel[j]});
      }
    }
  }
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    for (int j = 0; j < ny; ++j) {
      problem.nlp.LabelResidual(
          row++, {static_cast<int>(e), experiments[e].NumSamples() - 1, output_channel[j]});
    }
  }
  problem.fixed_value_groups = {0, 1};
  return problem;
}

}  // namespace graybox::estimators
