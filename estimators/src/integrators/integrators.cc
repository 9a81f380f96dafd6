#include "graybox/estimators/integrators/integrators.h"
#include "graybox/util/did_you_mean.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "graybox/expr/derivatives.h"
#include "graybox/expr/matrix.h"
#include "graybox/models/block.h"  // DidYouMean
#include "graybox/util/matrix_rows.h"
#include "integrators/integrator_internal.h"

namespace graybox::estimators {

using expr::Expr;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

constexpr StepScheme kAllSchemes[] = {StepScheme::kRk4, StepScheme::kBackwardEuler,
                                      StepScheme::kTrapezoidal, StepScheme::kRadauIIA};

bool IsImplicit(StepScheme scheme) { return scheme != StepScheme::kRk4; }

// Butcher tableau of an implicit scheme: A row-major (s x s) and b (s). The nodes c (the row sums
// of A) are not needed: the input is held over the step, so f does not depend on time.
struct Tableau {
  int stages = 0;
  std::vector<double> a, b;
  double A(int i, int j) const { return a[static_cast<std::size_t>(i * stages + j)]; }
};

Tableau ImplicitTableau(StepScheme scheme) {
  switch (scheme) {
    case StepScheme::kBackwardEuler:
      return {1, {1.0}, {1.0}};
    case StepScheme::kTrapezoidal:
      return {2, {0.0, 0.0, 0.5, 0.5}, {0.5, 0.5}};
    case StepScheme::kRadauIIA:
      return {2, {5.0 / 12.0, -1.0 / 12.0, 3.0 / 4.0, 1.0 / 4.0}, {3.0 / 4.0, 1.0 / 4.0}};
    case StepScheme::kRk4:
      break;
  }
  throw std::logic_error("ImplicitTableau: not an implicit scheme");
}

// Stages with a nonzero row of A (the others are explicit: K_i = f(x)).
std::vector<int> ImplicitStages(const Tableau& t) {
  std::vector<int> implicit;
  for (int i = 0; i < t.stages; ++i) {
    for (int j = 0; j < t.stages; ++j) {
      if (t.A(i, j) != 0.0) {
        implicit.push_back(i);
        break;
      }
    }
  }
  return implicit;
}

// f evaluations inside one step of the map (the summary's counter; see integrators.h).
long RhsEvaluationsPerStep(const FixedStepOptions& o) {
  if (!IsImplicit(o.scheme)) return 4;
  const Tableau t = ImplicitTableau(o.scheme);
  const long m = static_cast<long>(ImplicitStages(t).size());
  const bool explicit_stage = m < t.stages;
  // From K_I = 0 the first iteration's stage values are x (f(x) reused) unless an explicit stage
  // shifts them.
  return 1 + m * o.newton_iterations - (explicit_stage ? 0 : m);
}

std::vector<Expr> Rk4Steps(const expr::Function& dynamics, const std::vector<Expr>& x,
                           const std::vector<Expr>& u, const std::vector<Expr>& p, double h,
                           int steps) {
  const std::size_t n = x.size();
  auto f = [&](const std::vector<Expr>& xs) { return dynamics.Call({xs, u, p})[0]; };
  auto axpy = [&](const std::vector<Expr>& a, double s, const std::vector<Expr>& b) {
    std::vector<Expr> r(n);
    for (std::size_t i = 0; i < n; ++i) r[i] = a[i] + s * b[i];
    return r;
  };
  std::vector<Expr> xs = x;
  for (int s = 0; s < steps; ++s) {
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

// `steps` implicit Runge-Kutta steps of size h by simplified Newton (integrators.h).
std::vector<Expr> ImplicitSteps(const expr::Function& dynamics, const std::vector<Expr>& x,
                                const std::vector<Expr>& u, const std::vector<Expr>& p, double h,
                                int steps, StepScheme scheme, int newton_iterations) {
  const Tableau t = ImplicitTableau(scheme);
  const std::vector<int> implicit = ImplicitStages(t);
  const int nx = static_cast<int>(x.size());
  const int m = static_cast<int>(implicit.size());
  // J = f_x as a symbolic Function of (x, u, p): its sparse nonzeros, scattered below.
  const expr::Function jacobian = dynamics.Jacobian(dynamics.OutputName(0), dynamics.InputName(0));
  const expr::Sparsity& pattern = jacobian.OutputSparsity(0);
  auto f = [&](const std::vector<Expr>& xs) { return dynamics.Call({xs, u, p})[0]; };

  std::vector<Expr> xs = x;
  for (int step = 0; step < steps; ++step) {
    const std::vector<Expr> f0 = f(xs);
    const std::vector<Expr> jnz = jacobian.Call({xs, u, p})[0];
    expr::ExprMatrix j = expr::ExprMatrix::Constant(nx, nx, Expr(0.0));
    for (int c = 0; c < pattern.cols(); ++c) {
      for (int k = pattern.colind()[c]; k < pattern.colind()[c + 1]; ++k) {
        j(pattern.row()[k], c) = jnz[static_cast<std::size_t>(k)];
      }
    }
    // M = I - h (A_II (x) J), stage-major.
    expr::ExprMatrix iteration(m * nx, m * nx);
    for (int bi = 0; bi < m; ++bi) {
      for (int bj = 0; bj < m; ++bj) {
        const double ha = h * t.A(implicit[bi], implicit[bj]);
        for (int r = 0; r < nx; ++r) {
          for (int c = 0; c < nx; ++c) {
            iteration(bi * nx + r, bj * nx + c) =
                Expr(bi == bj && r == c ? 1.0 : 0.0) - ha * j(r, c);
          }
        }
      }
    }
    // Stage derivatives: explicit stages f(x), implicit ones start at 0.
    std::vector<std::vector<Expr>> k(static_cast<std::size_t>(t.stages),
                                     std::vector<Expr>(static_cast<std::size_t>(nx), Expr(0.0)));
    for (int i = 0; i < t.stages; ++i) {
      if (std::find(implicit.begin(), implicit.end(), i) == implicit.end()) {
        k[static_cast<std::size_t>(i)] = f0;
      }
    }
    for (int it = 0; it < newton_iterations; ++it) {
      expr::ExprMatrix residual(m * nx, 1);
      for (int bi = 0; bi < m; ++bi) {
        const int i = implicit[bi];
        std::vector<Expr> y = xs;
        for (int jj = 0; jj < t.stages; ++jj) {
          const double ha = h * t.A(i, jj);
          if (ha == 0.0) continue;
          for (int r = 0; r < nx; ++r) y[r] = y[r] + ha * k[jj][r];
        }
        const std::vector<Expr> fy = f(y);
        for (int r = 0; r < nx; ++r) residual(bi * nx + r, 0) = k[i][r] - fy[r];
      }
      // Hash-consing makes the LU of `iteration` one set of nodes shared by every iteration.
      const expr::ExprMatrix delta = expr::SolveLu(iteration, residual);
      for (int bi = 0; bi < m; ++bi) {
        const int i = implicit[bi];
        for (int r = 0; r < nx; ++r) k[i][r] = k[i][r] - delta(bi * nx + r, 0);
      }
    }
    std::vector<Expr> next = xs;
    for (int i = 0; i < t.stages; ++i) {
      if (t.b[i] == 0.0) continue;
      for (int r = 0; r < nx; ++r) next[r] = next[r] + (h * t.b[i]) * k[i][r];
    }
    xs = std::move(next);
  }
  return xs;
}

}  // namespace

const char* StepSchemeName(StepScheme scheme) {
  switch (scheme) {
    case StepScheme::kRk4:
      return "rk4";
    case StepScheme::kBackwardEuler:
      return "backward_euler";
    case StepScheme::kTrapezoidal:
      return "trapezoidal";
    case StepScheme::kRadauIIA:
      return "radau_iia";
  }
  return "unknown";
}

StepScheme ParseStepScheme(const std::string& name) {
  std::vector<std::string> names;
  for (StepScheme s : kAllSchemes) {
    if (name == StepSchemeName(s)) return s;
    names.push_back(StepSchemeName(s));
  }
  const std::string hint = util::DidYouMean(name, names);
  throw std::invalid_argument(
      "step scheme: expected 'rk4', 'backward_euler', 'trapezoidal' or 'radau_iia', got '" + name +
      "'" + (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

void FixedStepOptions::Validate() const {
  bool known = false;
  for (StepScheme s : kAllSchemes) known = known || s == scheme;
  if (!known) {
    throw std::invalid_argument(
        "FixedStepOptions.scheme: expected kRk4, kBackwardEuler, kTrapezoidal or kRadauIIA, got " +
        std::to_string(static_cast<int>(scheme)));
  }
  if (substeps < 1) {
    throw std::invalid_argument("FixedStepOptions.substeps: expected >= 1, got " +
                                std::to_string(substeps));
  }
  if (IsImplicit(scheme) && newton_iterations < 1) {
    throw std::invalid_argument(std::string("FixedStepOptions.newton_iterations: expected >= 1 "
                                            "for the implicit scheme '") +
                                StepSchemeName(scheme) + "', got " +
                                std::to_string(newton_iterations));
  }
}

std::vector<Expr> FixedStep(const expr::Function& dynamics, const std::vector<Expr>& x,
                            const std::vector<Expr>& u, const std::vector<Expr>& p, double dt,
                            const FixedStepOptions& options) {
  if (!(dt > 0.0)) {
    throw std::invalid_argument("FixedStep: expected a sample time dt > 0, got " +
                                std::to_string(dt));
  }
  options.Validate();
  const double h = dt / options.substeps;
  if (!IsImplicit(options.scheme)) return Rk4Steps(dynamics, x, u, p, h, options.substeps);
  return ImplicitSteps(dynamics, x, u, p, h, options.substeps, options.scheme,
                       options.newton_iterations);
}

expr::Function MakeStepFunction(const models::StateSpaceModel& model, double dt,
                                const FixedStepOptions& options) {
  const auto& x = model.dynamics.InputSymbols(0);
  const auto& u = model.dynamics.InputSymbols(1);
  const auto& p = model.dynamics.InputSymbols(2);
  return expr::Function(model.name + "_" + StepSchemeName(options.scheme),
                        {{"x", x}, {"u", u}, {"p", p}},
                        {{"x_next", FixedStep(model.dynamics, x, u, p, dt, options)}});
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
    xk = util::RowAsVector(t.x, k);
    uk = util::RowAsVector(u, k);
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

// ---- FixedStepIntegrator --------------------------------------------------------------------

struct FixedStepIntegrator::StepDerivatives {
  expr::Function jacobians;  // "jac_x" = dPhi/dx, "jac_p" = dPhi/dp
};

FixedStepIntegrator::FixedStepIntegrator(const models::StateSpaceModel& model, double dt,
                                         const FixedStepOptions& options)
    : Integrator(model, dt), options_(options) {
  options_.Validate();
  rhs_per_step_ = RhsEvaluationsPerStep(options_);
  // One step of dt / substeps, applied substeps times per sample: the same map as
  // MakeStepFunction(model, dt, options), with a tape that does not grow with substeps.
  FixedStepOptions one = options_;
  one.substeps = 1;
  step_ = MakeStepFunction(model, dt / options_.substeps, one);
}

FixedStepIntegrator::~FixedStepIntegrator() = default;

std::string FixedStepIntegrator::Name() const {
  const int n = options_.substeps;
  std::string name = std::string(StepSchemeName(options_.scheme)) + " (" + std::to_string(n) +
                     (n == 1 ? " substep" : " substeps");
  if (IsImplicit(options_.scheme)) {
    const int it = options_.newton_iterations;
    name += ", " + std::to_string(it) + (it == 1 ? " newton iteration" : " newton iterations");
  }
  return name + ")";
}

const FixedStepIntegrator::StepDerivatives& FixedStepIntegrator::Derivatives() const {
  std::call_once(derivatives_once_, [this] {
    derivatives_ = std::make_unique<const StepDerivatives>(
        StepDerivatives{internal::JacobiansXP(step_, "x_next")});
  });
  return *derivatives_;
}

void FixedStepIntegrator::IntegrateStates(const StateRequest& r) const {
  const int nx = model().NumStates(), nu = model().NumInputs();
  const Eigen::Index n = r.u->rows();
  const bool implicit = IsImplicit(options_.scheme);
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
  const char* scheme = StepSchemeName(options_.scheme);
  for (Eigen::Index k = 0; k + 1 < n; ++k) {
    uk = util::RowAsVector(*r.u, k);
    for (int sub = 0; sub < options_.substeps; ++sub) {
      const double* in[3] = {x.data(), uk.data(), r.p->data()};
      if (d) {
        double* jout[2] = {nz_x.data(), nz_p.data()};
        const expr::EvalStatus sj = d->jacobians.Evaluate(in, jout, &ws_jac);
        ++s.num_jacobian_evaluations;
        if (!sj.ok) {
          s.status = IntegrationStatus::kNonFiniteValue;
          s.failed_at = static_cast<int>(k);
          s.message = std::string("Jacobian of the ") + scheme + " step at sample " +
                      std::to_string(k) + " is not finite: " + sj.message;
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
      s.num_rhs_evaluations += rhs_per_step_;
      if (implicit) ++s.num_linear_solver_setups;
      if (!st.ok) {
        s.status = IntegrationStatus::kNonFiniteValue;
        s.failed_at = static_cast<int>(k);
        s.message = std::string(scheme) + " step from sample " + std::to_string(k) +
                    " is not finite: " + st.message;
        return;
      }
      x.swap(x_next);
    }
    r.x->row(k + 1) = x.transpose();
    if (d) (*r.s)[static_cast<std::size_t>(k + 1)] = sens;
  }
}

Trajectory SimulateFixedStep(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                             const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                             const FixedStepOptions& options) {
  return FixedStepIntegrator(model, dt, options).Simulate(x0, u, p);
}

Trajectory SimulateRk4(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                       const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                       int substeps) {
  FixedStepOptions options;
  options.substeps = substeps;
  return SimulateFixedStep(model, x0, u, p, dt, options);
}

}  // namespace graybox::estimators
