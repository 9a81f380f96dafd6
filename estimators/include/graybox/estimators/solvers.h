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
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/nlp.h"

namespace graybox::estimators {

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
  void Validate() const;
};

/// Outcome of a solve.
struct SolverResult {
  std::string solver;  // "ipopt" or "ceres"
  bool success = false;
  /// The solver's own status word ("Solve_Succeeded", "CONVERGENCE", "Maximum_Iterations", ...).
  std::string status;
  std::string message;                // explanation when not successful
  Eigen::VectorXd w;                  // the final iterate
  Eigen::VectorXd lambda;             // constraint multipliers (Ipopt)
  double cost = 0.0;                  // final objective
  double constraint_violation = 0.0;  // max |g - clamp(g, lbg, ubg)|
  int iterations = 0;
  double seconds = 0.0;
  /// One line per iteration: iteration, objective, infeasibility (for progress and reports).
  std::vector<std::string> log;

  /// "ipopt: Solve_Succeeded after 12 iterations, cost 1.234e-03, 0.41 s".
  std::string BriefReport() const;
  /// The brief line plus sizes, constraint violation and the iteration log.
  std::string FullReport() const;
};

SolverResult SolveWithIpopt(const Nlp& nlp, const IpoptOptions& options = {});

/// Requires an Nlp without constraints "c" and without objective terms "f" (least squares only);
/// std::invalid_argument otherwise.
SolverResult SolveWithCeres(const Nlp& nlp, const CeresOptions& options = {});

}  // namespace graybox::estimators
