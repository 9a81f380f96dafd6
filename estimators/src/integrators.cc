#include "graybox/estimators/integrators.h"

#include <chrono>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "graybox/expr/derivatives.h"
#include "integrator_internal.h"

namespace graybox::estimators {

using expr::Expr;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

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

// ---- status and reports ---------------------------------------------------------------------

const char* IntegrationStatusName(IntegrationStatus status) {
  switch (status) {
    case IntegrationStatus::kSuccess:
      return "success";
    case IntegrationStatus::kNonFiniteValue:
      return "non-finite value";
    case IntegrationStatus::kTooMuchWork:
      return "too much work";
    case IntegrationStatus::kTooMuchAccuracy:
      return "too much accuracy requested";
    case IntegrationStatus::kErrorTestFailures:
      return "repeated error test failures";
    case IntegrationStatus::kConvergenceFailures:
      return "repeated convergence failures";
    case IntegrationStatus::kLinearSolverFailure:
      return "linear solver failure";
    case IntegrationStatus::kSolverError:
      return "solver error";
  }
  return "unknown";
}

std::string IntegrationSummary::BriefReport() const {
  std::ostringstream os;
  os << method << ": " << IntegrationStatusName(status);
  if (!ok()) {
    os << " at sample " << failed_at;
    if (!message.empty()) os << ": " << message;
    return os.str();
  }
  char time[32];
  std::snprintf(time, sizeof(time), "%.3g ms", 1e3 * seconds);
  os << ", " << num_samples << " samples";
  if (num_sensitivities > 0) os << " with " << num_sensitivities << " sensitivities";
  os << ", " << num_steps << " steps, " << time;
  return os.str();
}

std::string IntegrationSummary::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n"
     << "  samples                      " << num_samples << "\n"
     << "  sensitivities                " << num_sensitivities << "\n"
     << "  steps                        " << num_steps << "\n"
     << "  rhs evaluations              " << num_rhs_evaluations << "\n"
     << "  jacobian evaluations         " << num_jacobian_evaluations << "\n"
     << "  linear solver setups         " << num_linear_solver_setups << "\n"
     << "  error test failures          " << num_error_test_failures << "\n"
     << "  nonlinear conv. failures     " << num_nonlinear_convergence_failures << "\n"
     << "  sensitivity rhs evaluations  " << num_sensitivity_rhs_evaluations << "\n"
     << "  re-initialisations           " << num_reinitializations << "\n"
     << "  seconds                      " << seconds << "\n";
  return os.str();
}

// ---- shared helpers -------------------------------------------------------------------------

namespace internal {

expr::Function JacobiansXP(const expr::Function& f, const std::string& output) {
  const int j = f.OutputIndex(output);
  const std::vector<Expr>& x = f.InputSymbols(f.InputIndex("x"));
  const std::vector<Expr>& u = f.InputSymbols(f.InputIndex("u"));
  const std::vector<Expr>& p = f.InputSymbols(f.InputIndex("p"));
  expr::Sparsity sx, sp;
  std::vector<Expr> jx = expr::SparseJacobian(f.OutputExprs(j), x, &sx);
  std::vector<Expr> jp = expr::SparseJacobian(f.OutputExprs(j), p, &sp);
  return expr::Function(f.name() + "_jac_xp", {{"x", x}, {"u", u}, {"p", p}},
                        {{"jac_x", std::move(jx), sx}, {"jac_p", std::move(jp), sp}});
}

void AddSparseProduct(const expr::Sparsity& a, const double* nz, const Eigen::MatrixXd& in,
                      Eigen::MatrixXd* out) {
  const auto& colind = a.colind();
  const auto& row = a.row();
  for (int c = 0; c < a.cols(); ++c) {
    for (int k = colind[c]; k < colind[c + 1]; ++k) out->row(row[k]) += nz[k] * in.row(c);
  }
}

void AddSparseColumns(const expr::Sparsity& a, const double* nz, const std::vector<int>& columns,
                      Eigen::MatrixXd* out) {
  const auto& colind = a.colind();
  const auto& row = a.row();
  for (std::size_t j = 0; j < columns.size(); ++j) {
    const int c = columns[j];
    for (int k = colind[c]; k < colind[c + 1]; ++k) {
      (*out)(row[k], static_cast<Eigen::Index>(j)) += nz[k];
    }
  }
}

}  // namespace internal

// ---- Integrator -----------------------------------------------------------------------------

struct Integrator::OutputDerivatives {
  expr::Function jacobians;  // "jac_x" = dh/dx, "jac_p" = dh/dp
};

Integrator::Integrator(const models::StateSpaceModel& model, double dt) : model_(model), dt_(dt) {
  if (!(dt > 0.0)) {
    throw std::invalid_argument("Integrator: expected a sample time dt > 0, got " +
                                std::to_string(dt));
  }
}

Integrator::~Integrator() = default;

const Integrator::OutputDerivatives& Integrator::OutputJacobians() const {
  std::call_once(output_once_, [this] {
    output_derivatives_ = std::make_unique<const OutputDerivatives>(
        OutputDerivatives{internal::JacobiansXP(model_.output, "y")});
  });
  return *output_derivatives_;
}

Trajectory Integrator::Simulate(const Eigen::VectorXd& x0, const Eigen::MatrixXd& u,
                                const Eigen::VectorXd& p) const {
  SensitivityTrajectory t = Run(x0, u, p, nullptr);
  return std::move(static_cast<Trajectory&>(t));
}

SensitivityTrajectory Integrator::SimulateWithSensitivities(const Eigen::VectorXd& x0,
                                                            const Eigen::MatrixXd& u,
                                                            const Eigen::VectorXd& p) const {
  std::vector<int> all(static_cast<std::size_t>(model_.NumParameters()));
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return Run(x0, u, p, &all);
}

SensitivityTrajectory Integrator::SimulateWithSensitivities(
    const Eigen::VectorXd& x0, const Eigen::MatrixXd& u, const Eigen::VectorXd& p,
    const std::vector<int>& parameters) const {
  return Run(x0, u, p, &parameters);
}

SensitivityTrajectory Integrator::Run(const Eigen::VectorXd& x0, const Eigen::MatrixXd& u,
                                      const Eigen::VectorXd& p,
                                      const std::vector<int>* parameters) const {
  const auto start = std::chrono::steady_clock::now();
  const int nx = model_.NumStates(), nu = model_.NumInputs(), ny = model_.NumOutputs();
  const int np = model_.NumParameters();
  if (x0.size() != nx || u.cols() != nu || u.rows() < 1 || p.size() != np) {
    throw std::invalid_argument(
        Name() + ": expected x0 of size " + std::to_string(nx) + ", inputs with " +
        std::to_string(nu) + " columns and at least one row, and " + std::to_string(np) +
        " parameters, got " + std::to_string(x0.size()) + ", " + std::to_string(u.rows()) + " x " +
        std::to_string(u.cols()) + " and " + std::to_string(p.size()));
  }
  if (parameters) {
    std::vector<bool> seen(static_cast<std::size_t>(np), false);
    for (int j : *parameters) {
      if (j < 0 || j >= np || seen[static_cast<std::size_t>(j)]) {
        throw std::invalid_argument(Name() + ": expected distinct parameter indices in [0, " +
                                    std::to_string(np) + "), got " + std::to_string(j) +
                                    (j >= 0 && j < np ? " twice" : ""));
      }
      seen[static_cast<std::size_t>(j)] = true;
    }
  }
  const Eigen::Index n = u.rows();
  const int npc = parameters ? static_cast<int>(parameters->size()) : 0;
  const int ns = parameters ? npc + nx : 0;

  SensitivityTrajectory t;
  t.x.setConstant(n, nx, kNaN);
  t.y.setConstant(n, ny, kNaN);
  IntegrationSummary& s = t.summary;
  s.method = Name();
  s.num_samples = static_cast<int>(n);
  s.num_sensitivities = ns;
  std::vector<Eigen::MatrixXd> sens;
  if (parameters) sens.assign(static_cast<std::size_t>(n), Eigen::MatrixXd::Constant(nx, ns, kNaN));

  StateRequest request;
  request.x0 = &x0;
  request.u = &u;
  request.p = &p;
  request.parameters = parameters;
  request.x = &t.x;
  request.s = parameters ? &sens : nullptr;
  request.summary = &s;
  IntegrateStates(request);

  // Outputs (and their sensitivities) at every sample whose state is valid.
  auto fail = [&s](Eigen::Index k, const std::string& what) {
    if (s.ok() || k < s.failed_at) {
      s.status = IntegrationStatus::kNonFiniteValue;
      s.failed_at = static_cast<int>(k);
      s.message = what;
    }
  };
  const Eigen::Index last = s.ok() ? n - 1 : s.failed_at;
  expr::Workspace ws = model_.output.MakeWorkspace();
  const OutputDerivatives* d = parameters ? &OutputJacobians() : nullptr;
  expr::Workspace ws_jac = d ? d->jacobians.MakeWorkspace() : expr::Workspace();
  Eigen::VectorXd xk(nx), uk(nu), yk(ny), nz_x, nz_p;
  if (d) {
    nz_x.resize(d->jacobians.OutputSize(0));
    nz_p.resize(d->jacobians.OutputSize(1));
    t.parameters = *parameters;
    t.dx_dp.assign(static_cast<std::size_t>(n), Eigen::MatrixXd::Constant(nx, npc, kNaN));
    t.dx_dx0.assign(static_cast<std::size_t>(n), Eigen::MatrixXd::Constant(nx, nx, kNaN));
    t.dy_dp.assign(static_cast<std::size_t>(n), Eigen::MatrixXd::Constant(ny, npc, kNaN));
    t.dy_dx0.assign(static_cast<std::size_t>(n), Eigen::MatrixXd::Constant(ny, nx, kNaN));
  }
  Eigen::MatrixXd dy(ny, ns);
  for (Eigen::Index k = 0; k <= last; ++k) {
    xk = t.x.row(k).transpose();
    uk = u.row(k).transpose();
    const double* in[3] = {xk.data(), uk.data(), p.data()};
    double* out[1] = {yk.data()};
    const expr::EvalStatus st = model_.output.Evaluate(in, out, &ws);
    t.y.row(k) = yk.transpose();
    if (!st.ok) {
      fail(k, "output y_" + std::to_string(k) + " is not finite: " + st.message);
      break;
    }
    if (!d) continue;
    const auto& sk = sens[static_cast<std::size_t>(k)];
    t.dx_dp[static_cast<std::size_t>(k)] = sk.leftCols(npc);
    t.dx_dx0[static_cast<std::size_t>(k)] = sk.rightCols(nx);
    double* jout[2] = {nz_x.data(), nz_p.data()};
    const expr::EvalStatus sj = d->jacobians.Evaluate(in, jout, &ws_jac);
    if (!sj.ok) {
      fail(k, "output Jacobian at sample " + std::to_string(k) + " is not finite: " + sj.message);
      break;
    }
    dy.setZero();
    internal::AddSparseProduct(d->jacobians.OutputSparsity(0), nz_x.data(), sk, &dy);
    internal::AddSparseColumns(d->jacobians.OutputSparsity(1), nz_p.data(), *parameters, &dy);
    t.dy_dp[static_cast<std::size_t>(k)] = dy.leftCols(npc);
    t.dy_dx0[static_cast<std::size_t>(k)] = dy.rightCols(nx);
  }
  if (!s.ok()) {
    const Eigen::Index first_bad = s.failed_at + 1;
    if (first_bad < n) {
      t.x.bottomRows(n - first_bad).setConstant(kNaN);
      t.y.bottomRows(n - first_bad).setConstant(kNaN);
      for (Eigen::Index k = first_bad; k < n && d; ++k) {
        const auto i = static_cast<std::size_t>(k);
        t.dx_dp[i].setConstant(kNaN);
        t.dx_dx0[i].setConstant(kNaN);
        t.dy_dp[i].setConstant(kNaN);
        t.dy_dx0[i].setConstant(kNaN);
      }
    }
  }
  t.ok = s.ok();
  t.failed_at = s.failed_at;
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return t;
}

// ---- Rk4Integrator --------------------------------------------------------------------------

struct Rk4Integrator::StepDerivatives {
  expr::Function jacobians;  // "jac_x" = dPhi/dx, "jac_p" = dPhi/dp
};

Rk4Integrator::Rk4Integrator(const models::StateSpaceModel& model, double dt, int substeps)
    : Integrator(model, dt), substeps_(substeps) {
  if (substeps < 1) {
    throw std::invalid_argument("Rk4Integrator: expected substeps >= 1, got " +
                                std::to_string(substeps));
  }
  // One RK4 step of dt / substeps, applied substeps times per sample: the same map as
  // MakeRk4StepFunction(model, dt, substeps), with a tape that does not grow with substeps.
  step_ = MakeRk4StepFunction(model, dt / substeps, 1);
}

Rk4Integrator::~Rk4Integrator() = default;

std::string Rk4Integrator::Name() const {
  return "rk4 (" + std::to_string(substeps_) + (substeps_ == 1 ? " substep)" : " substeps)");
}

const Rk4Integrator::StepDerivatives& Rk4Integrator::Derivatives() const {
  std::call_once(derivatives_once_, [this] {
    derivatives_ = std::make_unique<const StepDerivatives>(
        StepDerivatives{internal::JacobiansXP(step_, "x_next")});
  });
  return *derivatives_;
}

void Rk4Integrator::IntegrateStates(const StateRequest& r) const {
  const int nx = model().NumStates(), nu = model().NumInputs();
  const Eigen::Index n = r.u->rows();
  IntegrationSummary& s = *r.summary;
  expr::Workspace ws = step_.MakeWorkspace();
  Eigen::VectorXd x = *r.x0, x_next(nx), uk(nu);
  r.x->row(0) = x.transpose();

  const StepDerivatives* d = r.parameters ? &Derivatives() : nullptr;
  expr::Workspace ws_jac = d ? d->jacobians.MakeWorkspace() : expr::Workspace();
  Eigen::VectorXd nz_x, nz_p;
  Eigen::MatrixXd sens, sens_next;
  if (d) {
    const int ns = static_cast<int>(r.parameters->size()) + nx;
    nz_x.resize(d->jacobians.OutputSize(0));
    nz_p.resize(d->jacobians.OutputSize(1));
    sens = Eigen::MatrixXd::Zero(nx, ns);
    sens.rightCols(nx).setIdentity();
    sens_next.resize(nx, ns);
    (*r.s)[0] = sens;
  }
  for (Eigen::Index k = 0; k + 1 < n; ++k) {
    uk = r.u->row(k).transpose();
    for (int sub = 0; sub < substeps_; ++sub) {
      const double* in[3] = {x.data(), uk.data(), r.p->data()};
      if (d) {
        double* jout[2] = {nz_x.data(), nz_p.data()};
        const expr::EvalStatus sj = d->jacobians.Evaluate(in, jout, &ws_jac);
        ++s.num_jacobian_evaluations;
        if (!sj.ok) {
          s.status = IntegrationStatus::kNonFiniteValue;
          s.failed_at = static_cast<int>(k);
          s.message = "Jacobian of the RK4 step at sample " + std::to_string(k) +
                      " is not finite: " + sj.message;
          return;
        }
        sens_next.setZero();
        internal::AddSparseProduct(d->jacobians.OutputSparsity(0), nz_x.data(), sens, &sens_next);
        internal::AddSparseColumns(d->jacobians.OutputSparsity(1), nz_p.data(), *r.parameters,
                                   &sens_next);
        sens.swap(sens_next);
      }
      double* out[1] = {x_next.data()};
      const expr::EvalStatus st = step_.Evaluate(in, out, &ws);
      ++s.num_steps;
      s.num_rhs_evaluations += 4;
      if (!st.ok) {
        s.status = IntegrationStatus::kNonFiniteValue;
        s.failed_at = static_cast<int>(k);
        s.message = "RK4 step from sample " + std::to_string(k) + " is not finite: " + st.message;
        return;
      }
      x.swap(x_next);
    }
    r.x->row(k + 1) = x.transpose();
    if (d) (*r.s)[static_cast<std::size_t>(k + 1)] = sens;
  }
}

Trajectory SimulateRk4(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                       const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                       int substeps) {
  return Rk4Integrator(model, dt, substeps).Simulate(x0, u, p);
}

}  // namespace graybox::estimators
