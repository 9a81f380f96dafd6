#include "graybox/estimators/formulations/equation_error.h"

#include "graybox/estimators/nlp/weights.h"

#include <stdexcept>

namespace graybox::estimators {

using expr::Expr;
using expr::Function;

namespace {

// The free parameters as scaled symbols z, spliced into the full parameter vector.
std::vector<Expr> ParameterExprs(const ParameterMap& map, std::vector<Expr>* z) {
  *z = Expr::Symbols("theta", map.NumFree());
  std::vector<Expr> p(map.values.size());
  for (Eigen::Index i = 0; i < map.values.size(); ++i) p[i] = Expr(map.values[i]);
  for (int i = 0; i < map.NumFree(); ++i) p[map.free[i]] = map.scale[i] * (*z)[i];
  return p;
}

Nlp VariablesOf(const ParameterMap& map) {
  std::vector<double> w0, lb, ub;
  std::vector<std::string> names;
  map.AppendVariables(&w0, &lb, &ub, &names);
  auto vec = [](std::vector<double>& v) {
    return Eigen::VectorXd(
        Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  return Nlp(vec(w0), vec(lb), vec(ub), names);
}

}  // namespace

EquationErrorProblem BuildInverseDynamicsEquationError(
    const Function& inverse_dynamics, const std::vector<models::ModelParameter>& parameters,
    const std::vector<InverseDynamicsData>& data, Eigen::VectorXd weights) {
  const int n = inverse_dynamics.InputSize(inverse_dynamics.InputIndex("q"));
  const int np = inverse_dynamics.InputSize(inverse_dynamics.InputIndex("p"));
  if (np != static_cast<int>(parameters.size())) {
    throw std::invalid_argument("BuildInverseDynamicsEquationError: expected " +
                                std::to_string(np) + " parameter descriptions, got " +
                                std::to_string(parameters.size()));
  }
  std::vector<const Eigen::MatrixXd*> taus;
  for (std::size_t e = 0; e < data.size(); ++e) {
    const auto& d = data[e];
    const Eigen::Index rows = d.q.rows();
    for (const auto* m : {&d.q, &d.qd, &d.qdd, &d.tau}) {
      if (m->rows() != rows || m->cols() != n) {
        throw std::invalid_argument("equation-error data set " + std::to_string(e) +
                                    ": expected q, qd, qdd and tau of " + std::to_string(rows) +
                                    "x" + std::to_string(n) + ", got " + std::to_string(m->rows()) +
                                    "x" + std::to_string(m->cols()));
      }
      if (!m->allFinite()) {
        throw std::invalid_argument("equation-error data set " + std::to_string(e) +
                                    ": data contains NaN or Inf");
      }
    }
    taus.push_back(&d.tau);
  }
  if (weights.size() == 0) weights = InverseStdWeights(taus);
  if (weights.size() != n) {
    throw std::invalid_argument("BuildInverseDynamicsEquationError: expected " + std::to_string(n) +
                                " weights, got " + std::to_string(weights.size()));
  }
  const ParameterMap map = ParameterMap::FromModel(parameters);
  EquationErrorProblem problem{VariablesOf(map), map, weights};
  std::vector<Expr> z;
  const std::vector<Expr> p = ParameterExprs(map, &z);
  const std::vector<Expr> q = Expr::Symbols("q", n), qd = Expr::Symbols("qd", n),
                          qdd = Expr::Symbols("qdd", n), tau = Expr::Symbols("tau", n);
  const std::vector<Expr> model_tau = inverse_dynamics.Call({q, qd, qdd, p})[0];
  std::vector<Expr> d, r;
  for (const auto* v : {&q, &qd, &qdd, &tau}) d.insert(d.end(), v->begin(), v->end());
  for (int j = 0; j < n; ++j) r.push_back(weights[j] * (model_tau[j] - tau[j]));
  const Function element("idim_sample", {{"z", z}, {"d", d}}, {{"r", r}});
  long total = 0;
  for (const auto& dd : data) total += dd.q.rows();
  ElementGroup g;
  g.name = "idim";
  g.fn = element;
  g.index.resize(map.NumFree(), total);
  g.data.resize(4 * n, total);
  long col = 0;
  for (const auto& dd : data) {
    for (Eigen::Index k = 0; k < dd.q.rows(); ++k, ++col) {
      for (int i = 0; i < map.NumFree(); ++i) g.index(i, col) = i;
      g.data.col(col) << dd.q.row(k).transpose(), dd.qd.row(k).transpose(),
          dd.qdd.row(k).transpose(), dd.tau.row(k).transpose();
    }
  }
  g.lbc.resize(0);
  g.ubc.resize(0);
  problem.nlp.AddGroup(std::move(g));
  return problem;
}

}  // namespace graybox::estimators
