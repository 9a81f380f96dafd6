// Solving an Nlp: Ipopt (interior point, general constraints, exact sparse Hessian) and Ceres
// (trust-region least squares on the residuals "r", bounds only).
//
//   IpoptOptions options;             // plain struct with documented defaults
//   options.max_iterations = 200;
//   SolverResult result = SolveWithIpopt(nlp, options);
//   std::cout << result.BriefReport() << "\n";
//
// Neither backend's headers appear here. Pass-through options go in `pass_through` maps; an
// unknown key is rejected with a did-you-mean suggestion before solving. A NaN/Inf produced at a
// trial point is returned to the solver as a failed evaluation (it backs off), never a crash.
//
// Concurrency. Ipopt 3.11.9 with the sequential MUMPS is not known to be thread-safe (MUMPS
// keeps global state), so Ipopt's own code (the step computation, the factorisation, the line
// search) runs under one process-wide lock: two solves never execute Ipopt at the same time.
// SolveWithIpopt releases the lock while the Nlp evaluates (objective, constraints, Jacobian,
// Hessian) and while the iteration callback runs, so the evaluations of solves in several threads
// overlap with each other and with one solve's Ipopt step; the results are the same as in
// sequence. Evaluation (libexpr tapes with per-Nlp workspaces) and Ceres solves may run in
// threads, one Nlp per thread (an Nlp is move-only for that reason).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/nlp/nlp.h"

namespace graybox::estimators {

/// One iteration of a solve, as both backends report it.
struct IterationSummary {
  int iteration = 0;
  double cost = 0.0;                  // objective (Ipopt) or 1/2 |r|^2 (Ceres)
  double constraint_violation = 0.0;  // Ipopt's inf_pr (0 for Ceres)
  double optimality = 0.0;            // Ipopt's inf_du; Ceres' max |gradient|
  double seconds = 0.0;               // since the solve started
  double hessian_perturbation = 0.0;  // Ipopt: delta_w of the step (lg(rg) = log10); Ceres: 0
  bool restoration = false;           // Ipopt's restoration phase (its figures are that phase's)
};

/// Called after every iteration from the solving thread; return false to stop the solve
/// (status kUserInterrupt).
using IterationCallback = std::function<bool(const IterationSummary&)>;

/// A starting point from an earlier solve of an Nlp of the same structure (warm start).
struct WarmStart {
  Eigen::VectorXd w;        // primal (NumVariables())
  Eigen::VectorXd lambda;   // constraint multipliers (Ipopt; empty: not used)
  Eigen::VectorXd z_lower;  // bound multipliers (Ipopt; empty: not used)
  Eigen::VectorXd z_upper;
};

struct IpoptOptions {
  int max_iterations = 500;
  /// Ipopt's "tol" (scaled NLP error).
  double tolerance = 1e-8;
  /// Exact Hessian of the Lagrangian from libexpr; false uses limited-memory BFGS.
  bool exact_hessian = true;
  /// Ipopt's print_level (0 silent ... 12). 5 prints one line per iteration.
  int print_level = 0;
  /// Any other Ipopt option by name, as text ("mu_strategy" -> "adaptive"); types are checked
  /// against Ipopt's registered options.
  std::map<std::string, std::string> pass_through;
  /// Optional: called after every iteration (progress, early stop).
  IterationCallback callback;
  /// Throws std::invalid_argument explaining the first invalid field.
  void Validate() const;
};

struct CeresOptions {
  int max_iterations = 200;
  double function_tolerance = 1e-12;
  double gradient_tolerance = 1e-12;
  double parameter_tolerance = 1e-12;
  /// "trivial" (plain least squares), "huber", "cauchy", "soft_l1", "arctan".
  std::string loss = "trivial";
  /// Scale of the robust loss (residual magnitude where it departs from quadratic).
  double loss_scale = 1.0;
  /// Sparse normal Cholesky through SuiteSparse.
  int num_threads = 1;
  bool print_progress = false;
  /// Optional: called after every iteration (progress, early stop).
  IterationCallback callback;
  void Validate() const;
};

/// How a solve ended, whatever the backend.
enum class SolverStatus {
  kConverged,         // the convergence test passed
  kAcceptable,        // Ipopt stopped at an acceptable (looser-tolerance) point
  kMaxIterations,     // iteration or time limit: the point is the last iterate
  kInfeasible,        // the problem was found (locally) infeasible
  kEvaluationError,   // NaN/Inf at the starting point or the solver could not back off
  kUserInterrupt,     // an IterationCallback returned false
  kNumericalFailure,  // restoration failure, too-small steps, linear solver errors
  kFailed,            // any other failure
};
/// "converged", "acceptable", "max_iterations", "infeasible", "evaluation_error",
/// "user_interrupt", "numerical_failure", "failed".
const char* SolverStatusName(SolverStatus status);

/// Outcome of a solve.
struct SolverResult {
  std::string solver;  // "ipopt" or "ceres"
  /// True for kConverged and kAcceptable.
  bool success = false;
  SolverStatus status_code = SolverStatus::kFailed;
  /// The solver's own status word ("Solve_Succeeded", "CONVERGENCE", "Maximum_Iterations", ...).
  std::string status;
  std::string message;                // explanation when not successful
  Eigen::VectorXd w;                  // the final iterate
  Eigen::VectorXd lambda;             // constraint multipliers (Ipopt)
  Eigen::VectorXd z_lower, z_upper;   // bound multipliers (Ipopt)
  double cost = 0.0;                  // final objective
  double constraint_violation = 0.0;  // max |g - clamp(g, lbg, ubg)|
  int iterations = 0;
  double seconds = 0.0;
  /// One entry per iteration (iteration 0 is the starting point for Ipopt).
  std::vector<IterationSummary> history;

  /// True when `w` is a point worth using: converged, acceptable, or stopped by the iteration
  /// limit or the caller with a finite cost (a usable if unconverged estimate).
  bool IsSolutionUsable() const;
  /// This result as the warm start of a re-solve.
  WarmStart AsWarmStart() const;

  /// "ipopt: Solve_Succeeded after 12 iterations, cost 1.234e-03, 0.41 s".
  std::string BriefReport() const;
  /// The brief line plus sizes, constraint violation and the iteration log.
  std::string FullReport() const;
};

/// `start` (optional) replaces nlp.w0() and, with multipliers, warm-starts Ipopt
/// (warm_start_init_point). Ipopt's own code runs under a process-wide lock (see the file comment).
SolverResult SolveWithIpopt(const Nlp& nlp, const IpoptOptions& options = {},
                            const WarmStart* start = nullptr);

/// Requires an Nlp without constraints "c" and without objective terms "f" (least squares only);
/// std::invalid_argument otherwise.
SolverResult SolveWithCeres(const Nlp& nlp, const CeresOptions& options = {},
                            const WarmStart* start = nullptr);

}  // namespace graybox::estimators
