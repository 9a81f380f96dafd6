// Integration of a StateSpaceModel over sampled data: the fixed-step one-step maps inside the
// expression graph (explicit RK4 and the implicit Runge-Kutta schemes for stiff models),
// simulation on doubles, forward sensitivities, and one interface over the integrators.
//
// Sampling convention (used by every formulation and every integrator): samples k = 0..N-1 at
// t_k = k dt; the input u_k is held constant over [t_k, t_{k+1}) (zero-order hold) and the state
// advances by
//     x_{k+1} = Phi(x_k, u_k, p).
// The output at sample k is y_k = h(x_k, u_k, p).
//
// Fixed-step maps. Phi is `substeps` steps of size h = dt / substeps of a Runge-Kutta scheme with
// s stages and Butcher tableau (A, b, c):
//     K_i = f(x + h sum_j a_ij K_j, u, p),  i = 1..s,        x+ = x + h sum_i b_i K_i.
// The schemes (StepScheme), with order, stability and the stability function R(z), z = h lambda,
// that one step applies to the test equation x' = lambda x:
//   rk4             classical explicit RK4, order 4, stable for |z| up to ~2.8 on the real axis:
//                   K1 = f(x), K2 = f(x + h/2 K1), K3 = f(x + h/2 K2), K4 = f(x + h K3),
//                   b = (1/6, 1/3, 1/3, 1/6); R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24.
//   backward_euler  c = (1), A = [[1]], b = (1): order 1, L-stable, R(z) = 1 / (1 - z).
//   trapezoidal     Crank-Nicolson, c = (0, 1), A = [[0, 0], [1/2, 1/2]], b = (1/2, 1/2): order
//                   2, A-stable but not L-stable, R(z) = (1 + z/2) / (1 - z/2) -> -1 for z -> -inf
//                   (stiff modes are not damped; they flip sign every step).
//   radau_iia       2-stage Radau IIA, c = (1/3, 1), A = [[5/12, -1/12], [3/4, 1/4]],
//                   b = (3/4, 1/4): order 3, L-stable, R(z) = (1 + z/3) / (1 - 2z/3 + z^2/6).
// The implicit schemes are for stiff models (StateSpaceModel::stiff): they stay stable and damp
// fast modes at step sizes where RK4 blows up, at the price of a linear solve per step.
//
// How an implicit step is built. Stages with a zero row of A (trapezoidal's first) are explicit:
// K_i = f(x). The m implicit stages K_I (m nx unknowns) solve G(K) = K_I - F(x + h (A (x) I) K) = 0
// by `newton_iterations` simplified-Newton iterations
//     K_I <- K_I - M^-1 G(K),       M = I - h (A_II (x) J),      J = f_x(x, u, p),
// with the Jacobian J of the dynamics taken once, symbolically (libexpr), at the step's start state
// x, and M factorised once per step by libexpr's symbolic LU (expr::SolveLu; the factors are
// hash-consed nodes shared by every iteration, so each further iteration costs m evaluations of f
// and one forward/back substitution). The iteration starts from K_I = 0, i.e. from the stage
// values Y_i = x (+ h a_i1 f(x) for trapezoidal's implicit stage), not from an explicit predictor:
// for stiff modes an explicit predictor x + h c_i f(x) overshoots by a factor |z| and can leave
// the domain of f (negative pressures), while the first iteration from K_I = 0 is the
// linearly-implicit (Rosenbrock-like) step that is already stable (Robertson's kinetics at
// h = 4 s: finite from K_I = 0, overflow from K_I = f(x); and on x' = lambda x no O(|z|) term has
// to cancel, so R(z) comes out to rounding even at z = -1e6). Consequences:
//   - Phi is an explicit expression graph: the Newton-iterated approximation of the implicit
//     step, not the exact root of G. For linear dynamics (f affine in x) one iteration solves
//     G = 0 exactly, so Phi is the implicit step (R(z) x on x' = lambda x); for nonlinear
//     dynamics the remaining residual contracts by O(h |f_x(Y) - J|) per iteration (O(h^2)
//     when not stiff), so the default 4 iterations keep the scheme's order (observed 1, 2, 3).
//   - Its derivatives (the Jacobians the sensitivities and the NLPs use, and the Hessians) are
//     the exact derivatives of that map by AD, including the derivative of J: they are consistent
//     with Phi to rounding, whatever the number of iterations.
//   - No convergence test and no step-size control: a fixed number of iterations is what makes
//     Phi a smooth explicit map. When the frozen J is a poor model of f over the step (a stiff,
//     strongly nonlinear transient such as Robertson's initial layer from (1, 0, 0), where J at
//     the start lacks the terms that dominate a moment later), the iteration diverges and Phi is
//     wrong or non-finite; more iterations make it worse there. Use substeps through such
//     transients, or CVODES. Past them (Robertson from t = 0.01 s at h = 0.4 s, h |lambda| ~ 4e3)
//     radau_iia with 4 iterations is as accurate as CVODES at rtol 1e-6.
//   - The LU has no pivoting (pivoting cannot be decided symbolically): it needs the leading
//     principal minors of M to be nonzero, true for stable or moderately unstable dynamics at
//     any step (M -> I as h -> 0). Otherwise the step evaluates to Inf/NaN, which Function
//     evaluation and the integrators report as a numerical failure.
// Cost per step: rk4 4 evaluations of f. Implicit: 1 f and 1 f_x at x, an LU of the m nx x m nx
// matrix M (m = 1 for backward_euler and trapezoidal, 2 for radau_iia; sparse where J is), and
// per iteration m evaluations of f and one substitution (backward_euler and radau_iia reuse f(x)
// in their first iteration). The derivatives of an implicit map also differentiate f_x (second
// derivatives of f; a Hessian of the map needs third derivatives), so its tapes are several
// times larger than RK4's (KUKA KR300, 12 states: radau_iia's step 4.4x, its Jacobians 5.5x).
//
// CvodesIntegrator (cvodes_integrator.h, variable-order BDF with error control) is the reference
// for stiff models; collocation is the other stiff formulation. integrator_factory.h picks a
// fixed-step scheme or CVODES from an options struct.
//
// Sensitivities. With theta = (p_j for the chosen parameter indices j, then x0), the forward
// sensitivities S_k = d x_k / d theta (nx x (np_chosen + nx)) obey S_0 = [0, I] and
//     fixed-step:  S_{k+1} = Phi_x S_k + [Phi_p(:, chosen), 0]     (exact for the discrete map)
//     CVODES:      dS/dt = f_x S + [f_p(:, chosen), 0]  over [t_k, t_{k+1}), with u_k held,
// and the output sensitivities are d y_k / d theta = h_x S_k + [h_p(:, chosen), 0]. All partials
// come from libexpr (sparse Jacobian Functions), never from difference quotients.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/function.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

/// The fixed-step Runge-Kutta schemes of the one-step map (tableaux in the file comment).
enum class StepScheme {
  kRk4,            // explicit, order 4 (non-stiff models)
  kBackwardEuler,  // implicit, order 1, L-stable
  kTrapezoidal,    // implicit, order 2, A-stable (Crank-Nicolson)
  kRadauIIA,       // implicit, 2 stages, order 3, L-stable
};

/// "rk4", "backward_euler", "trapezoidal" or "radau_iia".
const char* StepSchemeName(StepScheme scheme);
/// Inverse of StepSchemeName; std::invalid_argument with a did-you-mean hint otherwise.
StepScheme ParseStepScheme(const std::string& name);

/// The fixed-step map Phi: `substeps` steps of `scheme` per sample interval.
struct FixedStepOptions {
  StepScheme scheme = StepScheme::kRk4;
  /// Steps per sample interval (>= 1): h = dt / substeps.
  int substeps = 1;
  /// Simplified-Newton iterations per step of an implicit scheme (>= 1; unused by rk4). One is
  /// exact for linear dynamics; each further one costs m evaluations of f per step.
  int newton_iterations = 4;
  /// Throws std::invalid_argument naming the first invalid field ("FixedStepOptions.substeps:
  /// expected >= 1, got 0").
  void Validate() const;
};

/// The symbolic map Phi(x, u, p) over one sample interval dt (> 0) with the input held, built from
/// `dynamics` (inputs "x", "u", "p", one output: xdot). Throws std::invalid_argument unless dt > 0
/// and the options are valid.
std::vector<expr::Expr> FixedStep(const expr::Function& dynamics, const std::vector<expr::Expr>& x,
                                  const std::vector<expr::Expr>& u,
                                  const std::vector<expr::Expr>& p, double dt,
                                  const FixedStepOptions& options = {});

/// Phi as a Function named "<model>_<scheme>": inputs "x", "u", "p", output "x_next".
expr::Function MakeStepFunction(const models::StateSpaceModel& model, double dt,
                                const FixedStepOptions& options = {});

/// How a simulation ended. Everything but kSuccess is a numerical failure at the trial point
/// (x0, u, p): the caller (an optimizer, a line search) should back off, not abort.
enum class IntegrationStatus {
  kSuccess,
  /// f, its Jacobian, a sensitivity right-hand side or an output was NaN/Inf (also when CVODES
  /// gave up with convergence or error test failures after meeting NaN/Inf in that interval).
  kNonFiniteValue,
  /// CVODES: more than max_steps internal steps within one sample interval.
  kTooMuchWork,
  /// CVODES: the requested accuracy is below what double precision can deliver.
  kTooMuchAccuracy,
  /// CVODES: repeated local error test failures (step size driven to its minimum).
  kErrorTestFailures,
  /// CVODES: repeated Newton convergence failures (e.g. a singular or inaccurate Jacobian).
  kConvergenceFailures,
  /// CVODES: the dense or KLU factorization / solve failed unrecoverably.
  kLinearSolverFailure,
  /// Any other CVODES error (its flag name is in the message).
  kSolverError,
};

/// "success", "non-finite value", "too much work", ...
const char* IntegrationStatusName(IntegrationStatus status);

/// What an integrator did: status, where it failed, counters and time.
struct IntegrationSummary {
  /// "rk4 (4 substeps)", "cvodes bdf (dense)", "cvodes bdf (klu)".
  std::string method;
  IntegrationStatus status = IntegrationStatus::kSuccess;
  /// First failing sample k: x_0..x_k are valid; advancing from t_k to t_{k+1} failed (or y_k is
  /// non-finite). -1 on success.
  int failed_at = -1;
  /// Explanation on failure (the solver's own message where there is one); empty on success.
  std::string message;
  int num_samples = 0;
  int num_sensitivities = 0;  // columns of S (chosen parameters + initial states); 0 without
  // Counters summed over the whole simulation. Fixed-step: steps = intervals x substeps; f
  // evaluations = 4 per rk4 step, 1 + newton_iterations x m per implicit step (one fewer
  // iteration's worth for backward_euler and radau_iia, which reuse f(x)); linear solver setups =
  // implicit steps (one symbolic LU each); Jacobian evaluations (of the step map) = steps with
  // sensitivities. CVODES: its own counters (CVodeGetNum*), summed over re-initialisations.
  long num_steps = 0;
  long num_rhs_evaluations = 0;
  long num_jacobian_evaluations = 0;
  long num_linear_solver_setups = 0;
  long num_error_test_failures = 0;
  long num_nonlinear_convergence_failures = 0;
  long num_sensitivity_rhs_evaluations = 0;
  /// CVODES: number of CVodeReInit calls (one per sample at which the input changes).
  long num_reinitializations = 0;
  /// Wall time of the call (the first call with sensitivities also builds their Functions).
  double seconds = 0.0;

  bool ok() const { return status == IntegrationStatus::kSuccess; }
  /// "cvodes bdf (dense): success, 200 samples, 1234 steps, 0.8 ms" or, on failure,
  /// "cvodes bdf (dense): too much work at sample 17: <message>".
  std::string BriefReport() const;
  /// The brief line plus every counter, one per line.
  std::string FullReport() const;
};

/// A simulated trajectory: x (N x nx) the states at t_0 .. t_{N-1}, y (N x ny) the outputs.
/// On failure the rows after `failed_at` are NaN (and y_k may be non-finite at failed_at).
struct Trajectory {
  Eigen::MatrixXd x;
  Eigen::MatrixXd y;
  /// Same as summary.ok() and summary.failed_at (kept for existing callers).
  bool ok = true;
  int failed_at = -1;
  IntegrationSummary summary;
};

/// A trajectory with its forward sensitivities at every sample k = 0..N-1 (sizes below; all
/// vectors have N entries). Column j of dx_dp[k] is d x_k / d p[parameters[j]]; dx_dx0[k] is
/// d x_k / d x0 (the state transition matrix, identity at k = 0). On failure the entries after
/// failed_at are NaN.
struct SensitivityTrajectory : Trajectory {
  std::vector<int> parameters;          // model parameter indices, the columns of dx_dp, dy_dp
  std::vector<Eigen::MatrixXd> dx_dp;   // nx x parameters.size()
  std::vector<Eigen::MatrixXd> dx_dx0;  // nx x nx
  std::vector<Eigen::MatrixXd> dy_dp;   // ny x parameters.size()
  std::vector<Eigen::MatrixXd> dy_dx0;  // ny x nx
};

/// One interface over the integrators. An Integrator is bound to a model and a sample time at
/// construction and is immutable afterwards: Simulate and SimulateWithSensitivities are const and
/// may run concurrently (each call owns its workspaces and solver memory).
///
/// Argument errors (x0 not of size nx, u not N x nu with N >= 1, p not of size np, a parameter
/// index out of range or repeated) throw std::invalid_argument. Numerical failures never throw:
/// they end in summary.status with the failing sample.
class Integrator {
 public:
  virtual ~Integrator();
  Integrator(const Integrator&) = delete;
  Integrator& operator=(const Integrator&) = delete;

  const models::StateSpaceModel& model() const { return model_; }
  double dt() const { return dt_; }
  /// e.g. "rk4 (4 substeps)" or "cvodes bdf (klu)".
  virtual std::string Name() const = 0;

  /// Simulates from x0 with inputs u (N x nu, row k = u_k) and parameters p (all np of them).
  Trajectory Simulate(const Eigen::VectorXd& x0, const Eigen::MatrixXd& u,
                      const Eigen::VectorXd& p) const;
  /// The same with sensitivities with respect to every parameter and x0.
  SensitivityTrajectory SimulateWithSensitivities(const Eigen::VectorXd& x0,
                                                  const Eigen::MatrixXd& u,
                                                  const Eigen::VectorXd& p) const;
  /// With respect to the parameters p[parameters[j]] (distinct indices, any order; may be empty)
  /// and x0.
  SensitivityTrajectory SimulateWithSensitivities(const Eigen::VectorXd& x0,
                                                  const Eigen::MatrixXd& u,
                                                  const Eigen::VectorXd& p,
                                                  const std::vector<int>& parameters) const;

 protected:
  /// Throws std::invalid_argument unless dt > 0.
  Integrator(const models::StateSpaceModel& model, double dt);

  /// Where IntegrateStates writes. `x` is N x nx; with sensitivities, s[k] is nx x ns, ns =
  /// parameters->size() + nx, ordered (chosen parameters, x0). Rows/entries after a failure are
  /// left to the caller (it fills NaN).
  struct StateRequest {
    const Eigen::VectorXd* x0 = nullptr;
    const Eigen::MatrixXd* u = nullptr;
    const Eigen::VectorXd* p = nullptr;
    const std::vector<int>* parameters = nullptr;  // null: no sensitivities
    Eigen::MatrixXd* x = nullptr;
    std::vector<Eigen::MatrixXd>* s = nullptr;
    IntegrationSummary* summary = nullptr;
  };
  /// Integrates the states (and sensitivities when requested) over the N samples. Sets
  /// summary->status, failed_at, message and the counters; never throws on numerical failure.
  virtual void IntegrateStates(const StateRequest& request) const = 0;

 private:
  struct OutputDerivatives;
  SensitivityTrajectory Run(const Eigen::VectorXd& x0, const Eigen::MatrixXd& u,
                            const Eigen::VectorXd& p, const std::vector<int>* parameters) const;
  const OutputDerivatives& OutputJacobians() const;

  models::StateSpaceModel model_;
  double dt_;
  // d y / d (x, p), built on the first call with sensitivities.
  mutable std::once_flag output_once_;
  mutable std::unique_ptr<const OutputDerivatives> output_derivatives_;
};

/// A fixed-step scheme: the map Phi above, evaluated as `substeps` applications of the one-step
/// map MakeStepFunction(model, dt / substeps, {scheme, 1, newton_iterations}), compiled once at
/// construction (so the tape does not grow with substeps). Sensitivities follow the forward
/// recursion S <- Phi1_x S + [Phi1_p, 0] through the sparse Jacobians of that one-step map Phi1
/// (for an implicit scheme: of the Newton-iterated map, see the file comment), built on first use.
class FixedStepIntegrator final : public Integrator {
 public:
  /// Throws std::invalid_argument unless dt > 0 and the options are valid.
  FixedStepIntegrator(const models::StateSpaceModel& model, double dt,
                      const FixedStepOptions& options = {});
  ~FixedStepIntegrator() override;
  const FixedStepOptions& options() const { return options_; }
  /// "rk4 (4 substeps)", "backward_euler (1 substep, 4 newton iterations)".
  std::string Name() const override;

 private:
  struct StepDerivatives;
  void IntegrateStates(const StateRequest& request) const override;
  const StepDerivatives& Derivatives() const;

  FixedStepOptions options_;
  long rhs_per_step_ = 0;  // f evaluations inside one step of the map (for the summary)
  expr::Function step_;
  // d Phi / d (x, p), built on the first call with sensitivities.
  mutable std::once_flag derivatives_once_;
  mutable std::unique_ptr<const StepDerivatives> derivatives_;
};

/// Simulates from x0 with inputs U (N x nu, row k = u_k) and parameters p by the fixed-step map:
/// FixedStepIntegrator(model, dt, options).Simulate(x0, u, p).
Trajectory SimulateFixedStep(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                             const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                             const FixedStepOptions& options = {});

/// Shorthand for the common explicit case: SimulateFixedStep with scheme rk4 and `substeps`.
Trajectory SimulateRk4(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                       const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                       int substeps = 1);

}  // namespace graybox::estimators
