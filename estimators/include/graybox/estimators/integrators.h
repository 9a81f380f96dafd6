// Integration of a StateSpaceModel over sampled data: the fixed-step RK4 map inside the expression
// graph, simulation on doubles, forward sensitivities, and one interface over the integrators.
//
// Sampling convention (used by every formulation and every integrator): samples k = 0..N-1 at
// t_k = k dt; the input u_k is held constant over [t_k, t_{k+1}) (zero-order hold) and the state
// advances by
//     x_{k+1} = Phi(x_k, u_k, p).
// For RK4, Phi is `substeps` classical fourth-order Runge-Kutta steps of size h = dt / substeps:
//     k1 = f(x, u, p),  k2 = f(x + h/2 k1, u, p),  k3 = f(x + h/2 k2, u, p),  k4 = f(x + h k3, u,
//     p), x+ = x + h/6 (k1 + 2 k2 + 2 k3 + k4).
// The output at sample k is y_k = h(x_k, u_k, p). The RK4 Phi is built symbolically from the
// model's dynamics, so it carries exact first and second derivatives into the NLPs.
//
// Stiff models (StateSpaceModel::stiff) need RK4 step sizes far below the sample time; integrate
// them with CvodesIntegrator (cvodes_integrator.h, variable-order BDF) or formulate them by
// collocation. integrator_factory.h picks either from an options struct.
//
// Sensitivities. With theta = (p_j for the chosen parameter indices j, then x0), the forward
// sensitivities S_k = d x_k / d theta (nx x (np_chosen + nx)) obey S_0 = [0, I] and
//     RK4:     S_{k+1} = Phi_x S_k + [Phi_p(:, chosen), 0]        (exact for the discrete map)
//     CVODES:  dS/dt = f_x S + [f_p(:, chosen), 0]  over [t_k, t_{k+1}), with u_k held,
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

/// The symbolic RK4 map: `substeps` steps of dt/substeps with the input held. Throws
/// std::invalid_argument unless dt > 0 and substeps >= 1.
std::vector<expr::Expr> Rk4Step(const expr::Function& dynamics, const std::vector<expr::Expr>& x,
                                const std::vector<expr::Expr>& u, const std::vector<expr::Expr>& p,
                                double dt, int substeps);

/// Phi as a Function: inputs "x", "u", "p", output "x_next".
expr::Function MakeRk4StepFunction(const models::StateSpaceModel& model, double dt, int substeps);

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
  // Counters summed over the whole simulation. RK4: steps = intervals x substeps, f evaluations
  // = 4 steps, Jacobian evaluations (of the step map) = steps with sensitivities. CVODES: its own
  // counters (CVodeGetNum*), summed over re-initialisations.
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

/// Fixed-step RK4: the map Phi above, evaluated as `substeps` applications of the one-step map
/// MakeRk4StepFunction(model, dt / substeps, 1), compiled once at construction (so the tape does
/// not grow with substeps). Sensitivities follow the forward recursion S <- Phi1_x S + [Phi1_p, 0]
/// through the sparse Jacobians of that one-step map Phi1, which are built on first use.
class Rk4Integrator final : public Integrator {
 public:
  /// Throws std::invalid_argument unless dt > 0 and substeps >= 1.
  Rk4Integrator(const models::StateSpaceModel& model, double dt, int substeps = 1);
  ~Rk4Integrator() override;
  int substeps() const { return substeps_; }
  std::string Name() const override;

 private:
  struct StepDerivatives;
  void IntegrateStates(const StateRequest& request) const override;
  const StepDerivatives& Derivatives() const;

  int substeps_;
  expr::Function step_;
  // d Phi / d (x, p), built on the first call with sensitivities.
  mutable std::once_flag derivatives_once_;
  mutable std::unique_ptr<const StepDerivatives> derivatives_;
};

/// Simulates from x0 with inputs U (N x nu, row k = u_k) and parameters p, by the RK4 map:
/// Rk4Integrator(model, dt, substeps).Simulate(x0, u, p).
Trajectory SimulateRk4(const models::StateSpaceModel& model, const Eigen::VectorXd& x0,
                       const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                       int substeps = 1);

}  // namespace graybox::estimators
