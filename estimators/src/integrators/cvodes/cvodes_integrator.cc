#include "graybox/estimators/integrators/cvodes_integrator.h"
#include "graybox/util/did_you_mean.h"

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunlinsol/sunlinsol_klu.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunmatrix/sunmatrix_sparse.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "graybox/models/block.h"  // DidYouMean
#include "graybox/util/matrix_rows.h"
#include "integrators/integrator_internal.h"

namespace graybox::estimators {

// ---- compiled functions ---------------------------------------------------------------------

namespace internal {

struct CvodesFunctions {
  /// df/dx, sparse ("jac_xdot_x").
  expr::Function jac_x;
  /// CSC pattern of the Newton matrix I - gamma df/dx: df/dx's pattern plus the diagonal.
  std::vector<sunindextype> newton_colptr;
  std::vector<sunindextype> newton_rowind;
  /// Where nonzero k of jac_x goes: in the CSC values (KLU) and in the column-major dense array.
  std::vector<int> newton_position;
  std::vector<int> dense_position;
  /// Absolute tolerance per state.
  Eigen::VectorXd absolute_tolerance;
  /// (df/dx, df/dp) for the sensitivity right-hand side; built on first use.
  std::unique_ptr<const expr::Function> sensitivity;
};

}  // namespace internal

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- pass-through settings ------------------------------------------------------------------

struct PassThroughSetting {
  const char* name;
  bool integer;
  double min_value;
  double max_value;
  std::function<int(void*, double)> apply;
};

const std::vector<PassThroughSetting>& PassThroughSettings() {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  static const std::vector<PassThroughSetting> settings = {
      {"max_step", false, 0.0, kInf, [](void* m, double v) { return CVodeSetMaxStep(m, v); }},
      {"min_step", false, 0.0, kInf, [](void* m, double v) { return CVodeSetMinStep(m, v); }},
      {"max_nonlin_iters", true, 0.0, kInf,
       [](void* m, double v) { return CVodeSetMaxNonlinIters(m, static_cast<int>(v)); }},
      {"max_conv_fails", true, 0.0, kInf,
       [](void* m, double v) { return CVodeSetMaxConvFails(m, static_cast<int>(v)); }},
      {"max_err_test_fails", true, 0.0, kInf,
       [](void* m, double v) { return CVodeSetMaxErrTestFails(m, static_cast<int>(v)); }},
      {"max_hnil_warns", true, -kInf, kInf,
       [](void* m, double v) { return CVodeSetMaxHnilWarns(m, static_cast<int>(v)); }},
      {"nonlin_conv_coef", false, 0.0, kInf,
       [](void* m, double v) { return CVodeSetNonlinConvCoef(m, v); }},
      {"stab_lim_det", true, 0.0, 1.0,
       [](void* m, double v) { return CVodeSetStabLimDet(m, v != 0.0 ? SUNTRUE : SUNFALSE); }},
      {"jac_eval_frequency", true, 0.0, kInf,
       [](void* m, double v) { return CVodeSetJacEvalFrequency(m, static_cast<long>(v)); }},
      {"lsetup_frequency", true, 0.0, kInf,
       [](void* m, double v) { return CVodeSetLSetupFrequency(m, static_cast<long>(v)); }},
      {"sens_max_nonlin_iters", true, 0.0, kInf,
       [](void* m, double v) { return CVodeSetSensMaxNonlinIters(m, static_cast<int>(v)); }},
  };
  return settings;
}

const PassThroughSetting* FindSetting(const std::string& name) {
  for (const auto& s : PassThroughSettings()) {
    if (name == s.name) return &s;
  }
  return nullptr;
}

// ---- per-call state shared with the callbacks -----------------------------------------------

struct CallbackData {
  const models::StateSpaceModel* model = nullptr;
  const internal::CvodesFunctions* functions = nullptr;
  const expr::Function* sensitivity = nullptr;  // null without sensitivities
  const std::vector<int>* parameters = nullptr;
  bool klu = false;
  const double* u = nullptr;  // the input held over the current segment
  const double* p = nullptr;
  int nx = 0;

  expr::Workspace ws_f, ws_jac, ws_sens;
  std::vector<double> nz_jac;
  // Cache of (df/dx, df/dp) at cached_y: the staggered corrector evaluates the sensitivity
  // right-hand side several times at the same state.
  std::vector<double> nz_sens_x, nz_sens_p, cached_y;
  bool cache_valid = false;

  // Diagnostics, written by the callbacks without throwing.
  bool non_finite = false;  // in the current sample interval
  std::string non_finite_message;
  std::string last_error;

  void NoteNonFinite(const char* where, double t, const std::string& message) noexcept {
    if (non_finite) return;
    non_finite = true;
    try {
      non_finite_message = std::string(where) + " at t = " + std::to_string(t) + ": " + message;
    } catch (...) {
    }
  }
};

// Every callback returns 0 on success, 1 (recoverable: CVODES retries with a smaller step) on a
// non-finite value, -1 (unrecoverable) if anything throws; nothing escapes into C.
int Rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) noexcept {
  auto* d = static_cast<CallbackData*>(user);
  try {
    const double* in[3] = {N_VGetArrayPointer(y), d->u, d->p};
    double* out[1] = {N_VGetArrayPointer(ydot)};
    const expr::EvalStatus st = d->model->dynamics.Evaluate(in, out, &d->ws_f);
    if (!st.ok) {
      d->NoteNonFinite("f(x, u, p)", t, st.message);
      return 1;
    }
    return 0;
  } catch (...) {
    return -1;
  }
}

int Jacobian(sunrealtype t, N_Vector y, N_Vector /*fy*/, SUNMatrix jac, void* user,
             N_Vector /*tmp1*/, N_Vector /*tmp2*/, N_Vector /*tmp3*/) noexcept {
  auto* d = static_cast<CallbackData*>(user);
  try {
    const internal::CvodesFunctions& fn = *d->functions;
    const double* in[3] = {N_VGetArrayPointer(y), d->u, d->p};
    double* out[1] = {d->nz_jac.data()};
    const expr::EvalStatus st = fn.jac_x.Evaluate(in, out, &d->ws_jac);
    if (!st.ok) {
      d->NoteNonFinite("df/dx", t, st.message);
      return 1;
    }
    const std::size_t nnz = d->nz_jac.size();
    if (d->klu) {
      // The pattern is rewritten every time: SUNMatZero clears it and CVODES hands back the
      // matrix it last modified.
      if (SUNSparseMatrix_NNZ(jac) < static_cast<sunindextype>(fn.newton_rowind.size())) return -1;
      std::copy(fn.newton_colptr.begin(), fn.newton_colptr.end(),
                SUNSparseMatrix_IndexPointers(jac));
      std::copy(fn.newton_rowind.begin(), fn.newton_rowind.end(), SUNSparseMatrix_IndexValues(jac));
      double* values = SUNSparseMatrix_Data(jac);
      std::fill(values, values + fn.newton_rowind.size(), 0.0);
      for (std::size_t k = 0; k < nnz; ++k) values[fn.newton_position[k]] = d->nz_jac[k];
    } else {
      double* values = SUNDenseMatrix_Data(jac);
      std::fill(values, values + static_cast<std::size_t>(d->nx) * d->nx, 0.0);
      for (std::size_t k = 0; k < nnz; ++k) values[fn.dense_position[k]] = d->nz_jac[k];
    }
    return 0;
  } catch (...) {
    return -1;
  }
}

int SensitivityRhs(int ns, sunrealtype t, N_Vector y, N_Vector /*ydot*/, N_Vector* ys,
                   N_Vector* ys_dot, void* user, N_Vector /*tmp1*/, N_Vector /*tmp2*/) noexcept {
  auto* d = static_cast<CallbackData*>(user);
  try {
    const double* yv = N_VGetArrayPointer(y);
    const int nx = d->nx;
    if (!d->cache_valid || !std::equal(yv, yv + nx, d->cached_y.begin())) {
      const double* in[3] = {yv, d->u, d->p};
      double* out[2] = {d->nz_sens_x.data(), d->nz_sens_p.data()};
      const expr::EvalStatus st = d->sensitivity->Evaluate(in, out, &d->ws_sens);
      if (!st.ok) {
        d->cache_valid = false;
        d->NoteNonFinite("df/dx, df/dp", t, st.message);
        return 1;
      }
      std::copy(yv, yv + nx, d->cached_y.begin());
      d->cache_valid = true;
    }
    const expr::Sparsity& sx = d->sensitivity->OutputSparsity(0);
    const expr::Sparsity& sp = d->sensitivity->OutputSparsity(1);
    const int npc = static_cast<int>(d->parameters->size());
    for (int i = 0; i < ns; ++i) {
      const double* s = N_VGetArrayPointer(ys[i]);
      double* out = N_VGetArrayPointer(ys_dot[i]);
      std::fill(out, out + nx, 0.0);
      // out = df/dx s_i (+ df/dp_j for parameter columns)
      for (int c = 0; c < nx; ++c) {
        const double sc = s[c];
        if (sc == 0.0) continue;
        for (int k = sx.colind()[c]; k < sx.colind()[c + 1]; ++k) {
          out[sx.row()[k]] += d->nz_sens_x[static_cast<std::size_t>(k)] * sc;
        }
      }
      if (i < npc) {
        const int j = (*d->parameters)[static_cast<std::size_t>(i)];
        for (int k = sp.colind()[j]; k < sp.colind()[j + 1]; ++k) {
          out[sp.row()[k]] += d->nz_sens_p[static_cast<std::size_t>(k)];
        }
      }
    }
    return 0;
  } catch (...) {
    return -1;
  }
}

void ErrorHandler(int error_code, const char* /*module*/, const char* function, char* message,
                  void* user) noexcept {
  if (error_code == CV_WARNING) return;  // e.g. "t + h = t": not a failure by itself
  auto* d = static_cast<CallbackData*>(user);
  try {
    d->last_error = std::string(function ? function : "") + ": " + (message ? message : "");
  } catch (...) {
  }
}

// ---- SUNDIALS objects, freed in reverse order -----------------------------------------------

struct Sundials {
  SUNContext context = nullptr;
  void* cvode = nullptr;
  N_Vector y = nullptr;
  N_Vector absolute_tolerance = nullptr;
  N_Vector* ys = nullptr;
  int ns = 0;
  SUNMatrix matrix = nullptr;
  SUNLinearSolver solver = nullptr;

  Sundials() = default;
  Sundials(const Sundials&) = delete;
  Sundials& operator=(const Sundials&) = delete;
  ~Sundials() {
    if (cvode) CVodeFree(&cvode);
    if (solver) SUNLinSolFree(solver);
    if (matrix) SUNMatDestroy(matrix);
    if (ys) N_VDestroyVectorArray(ys, ns);
    if (absolute_tolerance) N_VDestroy(absolute_tolerance);
    if (y) N_VDestroy(y);
    if (context) SUNContext_Free(&context);
  }
};

std::string FlagName(int flag) {
  char* name = CVodeGetReturnFlagName(flag);
  std::string s = name ? name : std::to_string(flag);
  std::free(name);
  return s;
}

IntegrationStatus StatusOf(int flag, bool non_finite) {
  switch (flag) {
    case CV_TOO_MUCH_WORK:
      return IntegrationStatus::kTooMuchWork;
    case CV_TOO_MUCH_ACC:
      return IntegrationStatus::kTooMuchAccuracy;
    case CV_ERR_FAILURE:
      return non_finite ? IntegrationStatus::kNonFiniteValue
                        : IntegrationStatus::kErrorTestFailures;
    case CV_CONV_FAILURE:
    case CV_NLS_FAIL:
      return non_finite ? IntegrationStatus::kNonFiniteValue
                        : IntegrationStatus::kConvergenceFailures;
    case CV_LSETUP_FAIL:
    case CV_LSOLVE_FAIL:
      return non_finite ? IntegrationStatus::kNonFiniteValue
                        : IntegrationStatus::kLinearSolverFailure;
    case CV_RHSFUNC_FAIL:
    case CV_FIRST_RHSFUNC_ERR:
    case CV_REPTD_RHSFUNC_ERR:
    case CV_UNREC_RHSFUNC_ERR:
    case CV_SRHSFUNC_FAIL:
    case CV_FIRST_SRHSFUNC_ERR:
    case CV_REPTD_SRHSFUNC_ERR:
    case CV_UNREC_SRHSFUNC_ERR:
      return non_finite ? IntegrationStatus::kNonFiniteValue : IntegrationStatus::kSolverError;
    default:
      return IntegrationStatus::kSolverError;
  }
}

// CVodeReInit and CVodeSensReInit reset CVODES's counters: add them up before each restart.
void AddCounters(void* cvode, bool sensitivities, IntegrationSummary* s) {
  long v = 0;
  if (CVodeGetNumSteps(cvode, &v) == CV_SUCCESS) s->num_steps += v;
  if (CVodeGetNumRhsEvals(cvode, &v) == CV_SUCCESS) s->num_rhs_evaluations += v;
  if (CVodeGetNumJacEvals(cvode, &v) == CV_SUCCESS) s->num_jacobian_evaluations += v;
  if (CVodeGetNumLinSolvSetups(cvode, &v) == CV_SUCCESS) s->num_linear_solver_setups += v;
  if (CVodeGetNumErrTestFails(cvode, &v) == CV_SUCCESS) s->num_error_test_failures += v;
  if (CVodeGetNumNonlinSolvConvFails(cvode, &v) == CV_SUCCESS) {
    s->num_nonlinear_convergence_failures += v;
  }
  if (sensitivities && CVodeGetSensNumRhsEvals(cvode, &v) == CV_SUCCESS) {
    s->num_sensitivity_rhs_evaluations += v;
  }
}

}  // namespace

// ---- options --------------------------------------------------------------------------------

void CvodesOptions::Validate() const {
  if (!(relative_tolerance > 0.0) || !std::isfinite(relative_tolerance)) {
    throw std::invalid_argument(
        "CvodesOptions.relative_tolerance: expected a finite value > 0, got " +
        std::to_string(relative_tolerance));
  }
  if (!(absolute_tolerance > 0.0) || !std::isfinite(absolute_tolerance)) {
    throw std::invalid_argument(
        "CvodesOptions.absolute_tolerance: expected a finite value > 0, got " +
        std::to_string(absolute_tolerance));
  }
  for (Eigen::Index i = 0; i < absolute_tolerances.size(); ++i) {
    if (!(absolute_tolerances[i] > 0.0) || !std::isfinite(absolute_tolerances[i])) {
      throw std::invalid_argument("CvodesOptions.absolute_tolerances[" + std::to_string(i) +
                                  "]: expected a finite value > 0, got " +
                                  std::to_string(absolute_tolerances[i]));
    }
  }
  if (max_steps < 1) {
    throw std::invalid_argument("CvodesOptions.max_steps: expected >= 1, got " +
                                std::to_string(max_steps));
  }
  if (max_order < 1 || max_order > 5) {
    throw std::invalid_argument("CvodesOptions.max_order: expected 1..5 (BDF), got " +
                                std::to_string(max_order));
  }
  if (!(initial_step >= 0.0) || !std::isfinite(initial_step)) {
    throw std::invalid_argument(
        "CvodesOptions.initial_step: expected >= 0 (0: estimated by CVODES), got " +
        std::to_string(initial_step));
  }
  for (const auto& [key, value] : pass_through) {
    const PassThroughSetting* s = FindSetting(key);
    if (!s) {
      std::vector<std::string> names;
      for (const auto& t : PassThroughSettings()) names.emplace_back(t.name);
      const std::string hint = util::DidYouMean(key, names);
      throw std::invalid_argument("CvodesOptions.pass_through: unknown CVODES option '" + key +
                                  "'" + (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
    }
    if (!std::isfinite(value) || value < s->min_value || value > s->max_value ||
        (s->integer && value != std::floor(value))) {
      throw std::invalid_argument(
          "CvodesOptions.pass_through['" + key + "']: expected " +
          (s->integer ? std::string("an integer") : std::string("a number")) +
          (s->min_value == 0.0 ? " >= 0" : "") + (s->max_value == 1.0 ? " <= 1" : "") + ", got " +
          std::to_string(value));
    }
  }
}

// ---- CvodesIntegrator -----------------------------------------------------------------------

CvodesIntegrator::CvodesIntegrator(const models::StateSpaceModel& model, double dt,
                                   const CvodesOptions& options)
    : Integrator(model, dt), options_(options) {
  options_.Validate();
  const int nx = model.NumStates();
  if (options_.absolute_tolerances.size() != 0 && options_.absolute_tolerances.size() != nx) {
    throw std::invalid_argument("CvodesOptions.absolute_tolerances: expected " +
                                std::to_string(nx) + " entries (one per state) or none, got " +
                                std::to_string(options_.absolute_tolerances.size()));
  }
  functions_ = std::make_unique<internal::CvodesFunctions>();
  internal::CvodesFunctions& fn = *functions_;
  fn.absolute_tolerance = options_.absolute_tolerances.size() == nx && nx > 0
                              ? options_.absolute_tolerances
                              : Eigen::VectorXd::Constant(nx, options_.absolute_tolerance);
  fn.jac_x = model.dynamics.Jacobian("xdot", "x");
  // Map df/dx's pattern once into the Newton matrix's pattern (with the diagonal) and into the
  // dense column-major array.
  const expr::Sparsity& sx = fn.jac_x.OutputSparsity(0);
  std::vector<std::pair<int, int>> entries;
  const std::vector<int> cols = sx.ColumnOfNonzeros();
  for (int k = 0; k < sx.nnz(); ++k) entries.emplace_back(sx.row()[k], cols[k]);
  for (int i = 0; i < nx; ++i) entries.emplace_back(i, i);
  const expr::Sparsity newton = expr::Sparsity::FromTriplets(nx, nx, entries);
  fn.newton_colptr.assign(newton.colind().begin(), newton.colind().end());
  fn.newton_rowind.assign(newton.row().begin(), newton.row().end());
  for (int k = 0; k < sx.nnz(); ++k) {
    fn.newton_position.push_back(newton.Find(sx.row()[k], cols[k]));
    fn.dense_position.push_back(cols[k] * nx + sx.row()[k]);
  }
}

CvodesIntegrator::~CvodesIntegrator() = default;

std::string CvodesIntegrator::Name() const {
  return options_.linear_solver == CvodesOptions::LinearSolver::kKlu ? "cvodes bdf (klu)"
                                                                     : "cvodes bdf (dense)";
}

const expr::Function& CvodesIntegrator::SensitivityJacobians() const {
  std::call_once(sensitivity_once_, [this] {
    functions_->sensitivity =
        std::make_unique<const expr::Function>(internal::JacobiansXP(model().dynamics, "xdot"));
  });
  return *functions_->sensitivity;
}

void CvodesIntegrator::IntegrateStates(const StateRequest& r) const {
  const models::StateSpaceModel& m = model();
  const int nx = m.NumStates(), nu = m.NumInputs();
  const Eigen::Index n = r.u->rows();
  IntegrationSummary& summary = *r.summary;
  r.x->row(0) = r.x0->transpose();
  const bool with_sens = r.parameters != nullptr;
  const int npc = with_sens ? static_cast<int>(r.parameters->size()) : 0;
  const int ns = with_sens ? npc + nx : 0;
  if (with_sens) {
    (*r.s)[0].setZero(nx, ns);
    (*r.s)[0].rightCols(nx).setIdentity();
  }
  if (nx == 0 || n == 1) return;  // nothing to integrate

  const internal::CvodesFunctions& fn = *functions_;
  CallbackData data;
  data.model = &m;
  data.functions = &fn;
  data.parameters = r.parameters;
  data.klu = options_.linear_solver == CvodesOptions::LinearSolver::kKlu;
  data.p = r.p->data();
  data.nx = nx;
  data.ws_f = m.dynamics.MakeWorkspace();
  data.ws_jac = fn.jac_x.MakeWorkspace();
  data.nz_jac.resize(static_cast<std::size_t>(fn.jac_x.OutputSize(0)));
  if (with_sens) {
    data.sensitivity = &SensitivityJacobians();
    data.ws_sens = data.sensitivity->MakeWorkspace();
    data.nz_sens_x.resize(static_cast<std::size_t>(data.sensitivity->OutputSize(0)));
    data.nz_sens_p.resize(static_cast<std::size_t>(data.sensitivity->OutputSize(1)));
    data.cached_y.resize(static_cast<std::size_t>(nx));
  }

  auto fail = [&](IntegrationStatus status, int sample, const std::string& message) {
    summary.status = status;
    summary.failed_at = sample;
    summary.message = message;
  };
  Sundials sun;
  // Set-up errors cannot come from the model; they are reported like any other solver error.
  auto setup = [&](int flag, const char* call) {
    if (flag >= 0) return true;
    fail(IntegrationStatus::kSolverError, 0,
         std::string(call) + " failed with " + FlagName(flag) +
             (data.last_error.empty() ? "" : ": " + data.last_error));
    return false;
  };
  if (SUNContext_Create(nullptr, &sun.context) != 0 || !sun.context) {
    fail(IntegrationStatus::kSolverError, 0, "SUNContext_Create failed");
    return;
  }
  sun.y = N_VNew_Serial(nx, sun.context);
  sun.absolute_tolerance = N_VNew_Serial(nx, sun.context);
  sun.cvode = CVodeCreate(CV_BDF, sun.context);
  if (!sun.y || !sun.absolute_tolerance || !sun.cvode) {
    fail(IntegrationStatus::kSolverError, 0, "out of memory creating the CVODES objects");
    return;
  }
  // Fused vector operations: CVODES then updates all sensitivity vectors in one call per
  // operation instead of one call per vector (the clones below inherit the setting).
  N_VEnableFusedOps_Serial(sun.y, SUNTRUE);
  double* y = N_VGetArrayPointer(sun.y);
  std::copy(r.x0->data(), r.x0->data() + nx, y);
  std::copy(fn.absolute_tolerance.data(), fn.absolute_tolerance.data() + nx,
            N_VGetArrayPointer(sun.absolute_tolerance));
  if (!setup(CVodeSetErrHandlerFn(sun.cvode, ErrorHandler, &data), "CVodeSetErrHandlerFn") ||
      !setup(CVodeInit(sun.cvode, Rhs, 0.0, sun.y), "CVodeInit") ||
      !setup(CVodeSVtolerances(sun.cvode, options_.relative_tolerance, sun.absolute_tolerance),
             "CVodeSVtolerances") ||
      !setup(CVodeSetUserData(sun.cvode, &data), "CVodeSetUserData") ||
      !setup(CVodeSetMaxNumSteps(sun.cvode, options_.max_steps), "CVodeSetMaxNumSteps") ||
      !setup(CVodeSetMaxOrd(sun.cvode, options_.max_order), "CVodeSetMaxOrd") ||
      !setup(CVodeSetInitStep(sun.cvode, options_.initial_step), "CVodeSetInitStep")) {
    return;
  }
  if (data.klu) {
    sun.matrix = SUNSparseMatrix(nx, nx, static_cast<sunindextype>(fn.newton_rowind.size()),
                                 CSC_MAT, sun.context);
    sun.solver = sun.matrix ? SUNLinSol_KLU(sun.y, sun.matrix, sun.context) : nullptr;
  } else {
    sun.matrix = SUNDenseMatrix(nx, nx, sun.context);
    sun.solver = sun.matrix ? SUNLinSol_Dense(sun.y, sun.matrix, sun.context) : nullptr;
  }
  if (!sun.matrix || !sun.solver) {
    fail(IntegrationStatus::kSolverError, 0, "could not create the linear solver");
    return;
  }
  if (!setup(CVodeSetLinearSolver(sun.cvode, sun.solver, sun.matrix), "CVodeSetLinearSolver") ||
      !setup(CVodeSetJacFn(sun.cvode, Jacobian), "CVodeSetJacFn")) {
    return;
  }
  const int ism = options_.sensitivity_method == CvodesOptions::SensitivityMethod::kSimultaneous
                      ? CV_SIMULTANEOUS
                      : CV_STAGGERED;
  if (with_sens) {
    sun.ys = N_VCloneVectorArray(ns, sun.y);
    if (!sun.ys) {
      fail(IntegrationStatus::kSolverError, 0, "out of memory creating the sensitivities");
      return;
    }
    sun.ns = ns;
    for (int i = 0; i < ns; ++i) {
      double* s = N_VGetArrayPointer(sun.ys[i]);
      std::fill(s, s + nx, 0.0);
      if (i >= npc) s[i - npc] = 1.0;
    }
    // Parameter scales for the error test of the scaled sensitivities pbar_i dx/dtheta_i.
    std::vector<double> pbar(static_cast<std::size_t>(ns), 1.0);
    for (int i = 0; i < npc; ++i) {
      const double scale = m.parameters[static_cast<std::size_t>((*r.parameters)[i])].scale;
      if (std::isfinite(scale) && scale > 0.0) pbar[static_cast<std::size_t>(i)] = scale;
    }
    if (!setup(CVodeSensInit(sun.cvode, ns, ism, SensitivityRhs, sun.ys), "CVodeSensInit") ||
        !setup(CVodeSensEEtolerances(sun.cvode), "CVodeSensEEtolerances") ||
        !setup(CVodeSetSensParams(sun.cvode, nullptr, pbar.data(), nullptr),
               "CVodeSetSensParams") ||
        !setup(
            CVodeSetSensErrCon(sun.cvode, options_.sensitivity_error_control ? SUNTRUE : SUNFALSE),
            "CVodeSetSensErrCon")) {
      return;
    }
  }
  for (const auto& [key, value] : options_.pass_through) {
    const PassThroughSetting* s = FindSetting(key);
    if (key == "sens_max_nonlin_iters" && !with_sens) continue;
    if (!setup(s->apply(sun.cvode, value), ("CVODES option '" + key + "'").c_str())) return;
  }

  // Segments of equal inputs: integrate continuously over [t_a, t_b], where u_a = ... = u_{b-1}
  // and u_b differs (or b = N - 1), then restart at t_b with the new input.
  Eigen::VectorXd u_held(nu);
  Eigen::Index a = 0;
  while (a + 1 < n) {
    Eigen::Index b = a + 1;
    // Rows of an input matrix without columns are not taken (Eigen offsets its null data
    // pointer): without inputs, the whole record is one segment.
    while (b + 1 < n && (nu == 0 || r.u->row(b) == r.u->row(a))) ++b;
    u_held = util::RowAsVector(*r.u, a);
    data.u = u_held.data();
    data.cache_valid = false;
    const double t_a = static_cast<double>(a) * dt(), t_b = static_cast<double>(b) * dt();
    if (a > 0) {
      AddCounters(sun.cvode, with_sens, &summary);
      ++summary.num_reinitializations;
      if (!setup(CVodeReInit(sun.cvode, t_a, sun.y), "CVodeReInit") ||
          (with_sens && !setup(CVodeSensReInit(sun.cvode, ism, sun.ys), "CVodeSensReInit"))) {
        summary.failed_at = static_cast<int>(a);
        return;
      }
    }
    if (!setup(CVodeSetStopTime(sun.cvode, t_b), "CVodeSetStopTime")) {
      summary.failed_at = static_cast<int>(a);
      return;
    }
    for (Eigen::Index k = a + 1; k <= b; ++k) {
      data.non_finite = false;
      data.last_error.clear();
      sunrealtype t_reached = 0.0;
      const int flag =
          CVode(sun.cvode, static_cast<double>(k) * dt(), sun.y, &t_reached, CV_NORMAL);
      if (flag < 0) {
        AddCounters(sun.cvode, with_sens, &summary);
        std::string message = "CVODES " + FlagName(flag) +
                              " between t = " + std::to_string(static_cast<double>(k - 1) * dt()) +
                              " and " + std::to_string(static_cast<double>(k) * dt());
        if (!data.last_error.empty()) message += ": " + data.last_error;
        if (data.non_finite) message += " (non-finite value in " + data.non_finite_message + ")";
        fail(StatusOf(flag, data.non_finite), static_cast<int>(k - 1), message);
        return;
      }
      r.x->row(k) = Eigen::Map<const Eigen::VectorXd>(y, nx).transpose();
      if (with_sens) {
        const int sflag = CVodeGetSens(sun.cvode, &t_reached, sun.ys);
        if (sflag < 0) {
          AddCounters(sun.cvode, with_sens, &summary);
          fail(IntegrationStatus::kSolverError, static_cast<int>(k - 1),
               "CVodeGetSens failed with " + FlagName(sflag));
          return;
        }
        Eigen::MatrixXd& s = (*r.s)[static_cast<std::size_t>(k)];
        s.resize(nx, ns);
        for (int i = 0; i < ns; ++i) {
          s.col(i) = Eigen::Map<const Eigen::VectorXd>(N_VGetArrayPointer(sun.ys[i]), nx);
        }
      }
    }
    a = b;
  }
  AddCounters(sun.cvode, with_sens, &summary);
}

Trajectory SimulateCvodes(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                          const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                          const CvodesOptions& options) {
  return CvodesIntegrator(model, dt, options).Simulate(x0, u, p);
}

}  // namespace graybox::estimators
