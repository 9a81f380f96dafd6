#include "graybox/estimators/integrators.h"

#include <stdexcept>
#include <string>

namespace graybox::estimators {

using expr::Expr;

std::vector<Expr> Rk4Step(const expr::Function& dynamics, const std::vector<Expr>& x,
                          const std::vector<Expr>& u, const std::vector<Expr>& p, double dt,
                          int substeps) {
  if (!(dt > 0.0) || substeps < 1) {
    throw std::invalid_argument("Rk4Step: expected dt > 0 and substeps >= 1, got dt = " +
                                std::to_string(dt) + ", substeps = " + std::to_string(substeps));
  }
  const double h = dt / substeps;
  const std::size_t n = x.size();
  auto f = [&](const std::vector<Expr>& xs) { return dynamics.Call({xs, u, p})[0]; };
  auto axpy = [&](const std::vector<Expr>& a, double s, const std::vector<Expr>& b) {
    std::vector<Expr> r(n);
    for (std::size_t i = 0; i < n; ++i) r[i] = a[i] + s * b[i];
    return r;
  };
  std::vector<Expr> xs = x;
  for (int s = 0; s < substeps; ++s) {
    const auto k1 = f(xs);
    const auto k2 = f(axpy(xs, h / 2, k1));
    const auto k3 = f(axpy(xs, h / 2, k2));
    const auto k4 = f(axpy(xs, h, k3));
    for (std::size_t i = 0; i < n; ++i) {
      xs[i] = xs[i] + (h / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
  }
  return xs;
}

expr::Function MakeRk4StepFunction(const models::StateSpaceModel& model, double dt, int substeps) {
  const auto& x = model.dynamics.InputSymbols(0);
  const auto& u = model.dynamics.InputSymbols(1);
  const auto& p = model.dynamics.InputSymbols(2);
  return expr::Function(model.name + "_rk4", {{"x", x}, {"u", u}, {"p", p}},
                        {{"x_next", Rk4Step(model.dynamics, x, u, p, dt, substeps)}});
}

Trajectory SimulateRk4(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                       const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                       int substeps) {
  if (x0.size() != model.NumStates() || u.cols() != model.NumInputs() ||
      p.size() != model.NumParameters()) {
    throw std::invalid_argument(
        "SimulateRk4: expected x0 of size " + std::to_string(model.NumStates()) + ", inputs with " +
        std::to_string(model.NumInputs()) + " columns and " +
        std::to_string(model.NumParameters()) + " parameters, got " + std::to_string(x0.size()) +
        ", " + std::to_string(u.cols()) + " and " + std::to_string(p.size()));
  }
  const expr::Function step = MakeRk4StepFunction(model, dt, substeps);
  expr::Workspace ws_step = step.MakeWorkspace();
  expr::Workspace ws_out = model.output.MakeWorkspace();
  const Eigen::Index n = u.rows();
  Trajectory t;
  t.x.resize(n, model.NumStates());
  t.y.resize(n, model.NumOutputs());
  Eigen::VectorXd x = x0, x_next(model.NumStates()), uk(model.NumInputs()), yk(model.NumOutputs());
  for (Eigen::Index k = 0; k < n; ++k) {
    uk = u.row(k).transpose();
    t.x.row(k) = x.transpose();
    const double* in[3] = {x.data(), uk.data(), p.data()};
    double* out_y[1] = {yk.data()};
    const bool y_ok = model.output.Evaluate(in, out_y, &ws_out).ok;
    t.y.row(k) = yk.transpose();
    double* out_x[1] = {x_next.data()};
    const bool x_ok = step.Evaluate(in, out_x, &ws_step).ok;
    if ((!y_ok || !x_ok) && t.ok) {
      t.ok = false;
      t.failed_at = static_cast<int>(k);
    }
    x = x_next;
  }
  return t;
}

}  // namespace graybox::estimators
