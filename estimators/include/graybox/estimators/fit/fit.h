// Fit and Simulate: the identification pipeline of a Problem, as one library call.
//
//   Problem problem = LoadProblem("problems/emps/emps_closed_loop.toml");   // or built in C++
//   std::vector<SplitData> splits = LoadData(problem);
//   FitResult fit = Fit(problem, splits);
//   std::cout << fit.BriefReport() << "\n" << fit.FullReport();
//   if (!fit.IsSolutionUsable()) ...;
//   double m = fit.Parameter("mechanics.m").value;
//
// Fit formulates the problem's method (problem.estimation.method: multiple shooting, single
// shooting, collocation, equation error or the N-step loss) on the splits whose role is
// estimation, adds the regularisation terms, solves with the problem's solver (Ipopt or Ceres),
// computes the covariance that belongs to the method (below), and evaluates every split
// (simulation metrics per channel, the equation-error metrics, the N-step NRMS of [metrics]).
// The command line (`graybox fit`), the examples, the bench and the diagnosis all call it.
//
// Covariance by method (covariance.h):
//   multiple_shooting   NlpCovariance of the shooting NLP, continuity as exact constraints
//                       (the same for Ipopt's constraints and Ceres' penalised continuity)
//   single_shooting,    SimulationCovariance: sensitivities of the whole-record simulation by
//   collocation         the problem's integrator, w.r.t. the free parameters and the free
//                       initial states (fixed initial states are not differentiated)
//   equation_error,     Gauss-Newton on the NLP's own residuals (its variables are the free
//   n_step              parameters only), one noise variance per residual channel
//
// Re-fitting cheaply: FitSession formulates once and solves many times. Fixed parameters are data
// of the formulation (parameter_map.h), so SetParameterValue on a fixed parameter changes numbers
// and not the symbolic graph (multiple and single shooting, collocation, the N-step loss; equation
// error evaluates the model in its preprocessing and formulates again, which is cheap).
// Solve(start) warm-starts from an earlier result (the primal point, and for Ipopt the
// multipliers). Fixing or freeing a parameter changes the NLP's variables: the session then
// formulates again before the next solve (counted in num_formulations()).
//
// Threads. A FitSession is used by one thread at a time. Several sessions may solve at once:
// Ceres solves run in parallel; Ipopt's own code runs under a process-wide lock while the
// evaluations overlap (Ipopt 3.11.9 with the sequential MUMPS is not known to be thread-safe;
// solvers.h); the results are the same as in sequence.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/analysis/covariance.h"
#include "graybox/estimators/analysis/metrics.h"
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/estimators/solvers/solvers.h"

namespace graybox::estimators {

/// The evaluation of one split with a parameter vector: the simulation of the whole split from
/// its initial state with its metrics per output channel, and, when they apply, the equation
/// error's prediction (equation-error fits) and the N-step-ahead NRMS ([metrics] n_step).
struct SplitEvaluation {
  std::string name;
  std::string data_name;
  SplitRole role = SplitRole::kEstimation;
  Eigen::VectorXd time;       // N
  Eigen::MatrixXd measured;   // N x ny
  Eigen::MatrixXd simulated;  // N x ny (NaN after a divergence)
  Eigen::MatrixXd states;     // N x nx, the simulated states (NaN after a divergence)
  Eigen::MatrixXd inputs;     // N x nu, the measured inputs the simulation was driven by
  Eigen::VectorXd x0;
  bool simulation_ok = true;
  int failed_at = -1;  // first sample the integrator could not reach, or -1
  MetricReport simulation;
  // Equation error only: the fitted equation, measured against predicted target.
  bool has_equation = false;
  std::vector<std::string> equation_channels;
  std::vector<std::string> equation_units;
  Eigen::VectorXd equation_time;
  Eigen::MatrixXd equation_measured, equation_predicted;
  MetricReport equation;
  // N-step-ahead NRMS ([metrics] n_step > 0).
  bool has_n_step = false;
  NStepResult n_step;
  /// "split 'test' (test) simulation: <metrics brief> [; 150-step NRMS ...]".
  std::string BriefReport() const;
};

/// One finite-difference check of the model or of the assembled NLP (FitOptions::
/// check_derivatives).
struct DerivativeCheckLine {
  std::string what;
  bool ok = true;
  double max_error = 0.0;
  std::string report;  // the checker's brief report
};

struct FitOptions {
  /// Print the solver's own iteration lines (Ipopt print_level 5, Ceres progress) to stdout.
  bool verbose = false;
  /// Check the model's derivatives (xdot and y w.r.t. x, u, p at the first estimation split's
  /// start) and the assembled NLP's (nlp_check.h) before solving; results in
  /// FitResult::derivative_checks.
  bool check_derivatives = false;
  /// Progress lines (formulation, solver heartbeat with iteration, cost and constraint
  /// violation, evaluation); none when empty. Called from the calling thread and the solver's.
  std::function<void(const std::string&)> progress;
  /// Seconds between two solver progress lines.
  double progress_interval_seconds = 15.0;
  /// Stop a solve that has run longer than this [s] since it started, checked at each iteration
  /// (0: no limit; the time before the first iteration, Ipopt's initialisation and the first
  /// factorisation, counts; one long iteration is not interrupted); the result then has status
  /// kUserInterrupt (usable, not converged). A budget for unattended fits such as the diagnosis'
  /// re-fits.
  double max_solve_seconds = 0.0;
  /// The clock max_solve_seconds is measured on: wall time (kWall), or the user-mode CPU time of
  /// the thread that runs the solve (kThreadUser: the solver's iterations and the evaluations on
  /// that thread; time spent waiting for Ipopt's process-wide lock or for the CPU on a loaded
  /// machine does not count, nor the kernel's, such as the page faults of a freshly forked
  /// process), which makes a budget's outcome independent of the machine's load and of the
  /// process the solve runs in (the diagnosis' re-fits). The problem's [estimation] max_seconds is
  /// wall time either way.
  enum class BudgetClock { kWall, kThreadUser };
  BudgetClock budget_clock = BudgetClock::kWall;
  /// Optional: called at the starting point (iteration 0) and after every solver iteration, after
  /// the budget's check, from the solving thread; returning false stops the solve like the budget
  /// (status kUserInterrupt; the result is the iterate where it stopped: usable, not converged).
  /// A caller's own stopping test, such as the diagnosis' divergence test of its re-fits
  /// (screening.h).
  IterationCallback iteration_callback;
  /// Compute the covariance after solving.
  bool compute_covariance = true;
  /// Evaluate every split after solving (simulation, equation error, N-step NRMS).
  bool evaluate_splits = true;
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// One model parameter after a fit.
struct FitParameter {
  std::string name;  // qualified, "<instance>.<parameter>"
  std::string unit;
  double initial = 0.0;
  double value = 0.0;
  double std_error = 0.0;  // NaN when not available (fixed: 0)
  double ci_low = 0.0;     // 95 % interval (value +- 1.96 std_error)
  double ci_high = 0.0;
  double lower = 0.0, upper = 0.0;  // bounds
  bool free = false;
  /// True when a free parameter ended within 1e-6 (relative to its scale) of a bound.
  bool at_bound = false;
};

struct FitResult {
  std::string problem;
  std::string method;  // "multiple_shooting", ...
  std::string solver;  // "ipopt" or "ceres"
  /// Formulation settings in order (method, solver, step scheme, segment length, ...).
  std::vector<std::pair<std::string, std::string>> formulation;
  int num_variables = 0, num_constraints = 0, num_residuals = 0;

  /// The solve: typed status, the solver's own word, iterations, cost, the final point.
  SolverResult solver_result;
  /// Every model parameter, in the model's order.
  std::vector<FitParameter> parameters;
  /// All parameter values (the model's order), the vector Simulate and the model Functions take.
  Eigen::VectorXd values;
  /// Initial state per estimation split (estimated, or the fixed value used).
  std::map<std::string, Eigen::VectorXd> initial_states;

  bool has_uncertainty = false;
  UncertaintyReport uncertainty;
  std::string uncertainty_error;  // why there is none ("the covariance could not be computed ...")

  std::vector<SplitEvaluation> evaluations;  // every split, in the problem's order
  std::vector<DerivativeCheckLine> derivative_checks;
  /// Wall time per phase: "build", "solve", "covariance", "evaluate".
  std::vector<std::pair<std::string, double>> seconds;
  /// User-mode CPU time of the thread that ran the solve, during the solve [s]: the clock of
  /// FitOptions::BudgetClock::kThreadUser (work on other threads, such as Ceres' own with
  /// num_threads > 1, is not in it; waiting for Ipopt's lock or for a core is not either). 0 for
  /// a result that was not solved here (FitSession::ResultOf).
  double solve_thread_user_seconds = 0.0;

  /// The solver's verdict on its final point (SolverResult::IsSolutionUsable).
  bool IsSolutionUsable() const { return solver_result.IsSolutionUsable(); }
  /// The parameter called `name`; std::invalid_argument with a did-you-mean otherwise.
  const FitParameter& Parameter(const std::string& name) const;
  /// The evaluation of split `name`; std::invalid_argument with a did-you-mean otherwise.
  const SplitEvaluation& Evaluation(const std::string& name) const;
  /// "multiple_shooting/ipopt: converged after 6 iterations, cost 1.2e+03; test: <metrics>".
  std::string BriefReport() const;
  /// The brief line, the formulation, the parameter table with errors and intervals, the
  /// uncertainty report, the metrics of every split, the iteration history and the timings.
  std::string FullReport() const;
};

/// A Problem built in C++ instead of read from a file: `model` (built here), the estimation
/// settings and the metrics. As a problem file does, it derives from `estimation.step` the
/// fixed-step map of multiple shooting and of the integrator (when its method is fixed_step), the
/// N-step loss's integrator from `estimation.integrator`, the solver from the method when
/// `estimation.solver` is empty (Ceres for equation error and the N-step loss, else Ipopt) and
/// multiple shooting's continuity form from the solver (constraints on Ipopt, residuals on
/// Ceres), the equation-error defaults where states come from data (residual states, inverse
/// input, `differentiate` for states that are derivatives of others) and the N-step metric's
/// states (metrics.n_step_channels by name, default the measured states). Throws
/// std::invalid_argument for an unknown method or solver, collocation on Ceres, or a model that
/// does not build.
Problem MakeProblem(const std::string& name, const models::Model& model,
                    EstimationSpec estimation = {}, MetricsSpec metrics = {});

/// One split of measured data built in C++: `experiment` (uniform dt, u and y in the model's
/// input and output order) with its role and initial state x0.
SplitData MakeSplit(const std::string& name, SplitRole role, Experiment experiment,
                    Eigen::VectorXd x0);

/// A formulated problem that can be solved many times (see the file comment).
class FitSession {
 public:
  /// Formulates problem.estimation.method on the estimation splits. Throws std::invalid_argument
  /// (ProblemFileError where a place in the file is known) for bad options, data or bounds, and
  /// when the estimation splits give fewer residuals than the NLP's free variables less its
  /// equality constraints (data that cannot determine the free parameters).
  FitSession(const Problem& problem, std::vector<SplitData> splits, FitOptions options = {});
  ~FitSession();
  FitSession(FitSession&&) noexcept;
  FitSession& operator=(FitSession&&) noexcept;
  FitSession(const FitSession&) = delete;
  FitSession& operator=(const FitSession&) = delete;

  /// Sets a parameter's value: a fixed parameter's value used by the next solve (no symbolic
  /// work), or a free parameter's starting value. std::invalid_argument for an unknown name
  /// (did-you-mean), a non-finite value, or a free value outside its bounds.
  void SetParameterValue(const std::string& name, double value);
  /// Holds a parameter at its current value in the next solves.
  void FixParameter(const std::string& name);
  /// The time budget of the next solves (FitOptions::max_solve_seconds; >= 0, 0: no limit), for a
  /// caller that spreads one budget over several solves. std::invalid_argument when negative or
  /// not finite.
  void SetMaxSolveSeconds(double seconds);
  /// Lets a parameter move within its bounds in the next solves (reformulates when it was fixed
  /// when the session was built).
  void FreeParameter(const std::string& name);
  /// Solves from the current starting point, or warm-started from an earlier result of this
  /// session (primal point and multipliers; the parameter values set since then win). After
  /// FixParameter / FreeParameter changed the free set, the start's parameter estimates and its
  /// method variables (shooting nodes, initial states, collocation states) are the start, with
  /// the constraint multipliers (the newly freed parameters' bound multipliers at 0).
  FitResult Solve(const FitResult* start = nullptr);
  /// The result Solve returns for a solve of this session's NLP made elsewhere, from its solver
  /// result `solved` (its final point w, status, iterations, cost): the parameter values and
  /// initial states at w, the covariance, the parameter table and every split's evaluation, with
  /// the session's parameter values as the solve's start values. For a solve run in another
  /// process of the same program (the diagnosis' Ipopt re-fits), whose session held the same
  /// problem, free set and fixed values. std::invalid_argument when w has not the NLP's size.
  FitResult ResultOf(SolverResult solved);

  /// The problem as the session currently holds it (parameter values and free flags).
  const Problem& problem() const;
  /// How many times the NLP was formulated (1 after construction).
  int num_formulations() const;
  /// The formulated NLP (formulated again first when the free set changed): its variables, its
  /// residuals with their labels (experiment = index among the estimation splits, sample,
  /// channel; nlp.h ResidualLabel) for residual analysis by channel and time window.
  const Nlp& nlp();
  /// The names of the estimation splits, in the order of ResidualLabel::experiment.
  std::vector<std::string> EstimationSplitNames() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// Fit in one call: FitSession(problem, splits, options).Solve().
FitResult Fit(const Problem& problem, const std::vector<SplitData>& splits,
              const FitOptions& options = {});

/// The initial state split `split` is simulated from: its entry in `estimated` (the estimated
/// initial states by split name, FitResult::initial_states) when there is one, else
/// SplitData::setup.x0 with the states of SplitData::x0_from_split taken from the named split's
/// entry in `estimated` where it has one.
Eigen::VectorXd InitialStateOf(const SplitData& split,
                               const std::map<std::string, Eigen::VectorXd>& estimated);

/// Simulates and scores every split with the parameter values `values` (all model parameters,
/// the model's order), each split from InitialStateOf(split, initial_states), with the problem's
/// integrator; adds the N-step NRMS of [metrics].
std::vector<SplitEvaluation> Simulate(
    const Problem& problem, const std::vector<SplitData>& splits, const Eigen::VectorXd& values,
    const std::map<std::string, Eigen::VectorXd>& initial_states = {});

/// The evaluation of one split (Simulate for one split).
SplitEvaluation EvaluateSplit(const Problem& problem, const SplitData& split,
                              const Eigen::VectorXd& values, const Eigen::VectorXd& x0);

/// Finite-difference checks of the model's xdot and y w.r.t. x, u and p at (x0, u_0, values) of
/// `split`.
std::vector<DerivativeCheckLine> CheckModelDerivatives(const Problem& problem,
                                                       const SplitData& split,
                                                       const Eigen::VectorXd& values);

/// The states of a split derived from its measurements (N x nx), as equation error, the N-step
/// metric and node_guess = "data" use them: measured outputs (low-pass filtered), derivatives by
/// central differences, or both through the ideal FFT low-pass (EquationErrorSpec).
Eigen::MatrixXd StatesFromData(const Problem& problem, const Experiment& experiment);

}  // namespace graybox::estimators
