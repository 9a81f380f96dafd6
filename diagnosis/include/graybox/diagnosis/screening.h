// ScreenAndRefit: which unmodelled effect causes the gap. Every candidate (candidates.h) is first
// screened by a score (Lagrange-multiplier) test at its neutral value, then the best are re-fitted,
// warm-started from the nominal fit, and ranked by their validation error.
//
//   const estimators::FitResult nominal = estimators::Fit(problem, splits);
//   const Diagnosis d = ScreenAndRefit(problem, splits, nominal);
//   std::cout << d.BriefReport() << "\n" << d.FullReport();
//   d.refits.front().effect   // the best successful re-fit ("coulomb"), if refits[0].ok
//
// ---- The score test
// ------------------------------------------------------------------------------ For a candidate
// the augmented problem is problem.model with every parameter at its value in `nominal`, plus the
// candidate's block at its neutral value (Candidate::apply); the nominal free parameters theta and
// Candidate::screened phi are free.
//
// Option grids (Candidate::option_grids: the smoothing steepness of the sign-like friction
// blocks; at most one per candidate) are chosen the same way, jointly with the shape grids (every
// option value with the shape values scored at it; the best pair kept), and kept in the re-fit (an
// option is structure, not a parameter).
//
// Shape grids. A candidate with Candidate::shape_grids is scored once per grid value (the shape
// parameter set to factor * scale, candidates.h) and the value with the largest LM is kept:
// CandidateScore::candidate applies it and CandidateScore::shape_start records it. The maximum of
// a few correlated statistics is a little larger than one chi^2(k) draw under the null; with 3 or
// 4 values this raises the nominal level at most that many times (Bonferroni), which the
// diagnosis' acceptance (a likelihood-ratio test on the re-fit and a validation margin) absorbs.
//
// Simulation score (CandidateScore::method "simulation", the default). Every estimation split is
// simulated by the problem's integrator from the nominal fit's initial state (the candidate's own
// states at 0) with forward sensitivities dy/d(theta, phi) (integrators.h). With the residual
// r = W (y_measured - y_simulated), W = 1 / std of each measured channel, stacked over samples,
// channels and splits (N rows), J = dr/d(theta, phi) with columns scaled by each parameter's scale,
// and P_S the orthogonal projector on the columns S (rank-revealing QR),
//
//   LM = (|P_(theta,phi) r|^2 - |P_theta r|^2) / sigma^2,   sigma^2 = |r|^2 / (N - |theta|):
//
// the decrease of the output-error loss one Gauss-Newton step would give with the new parameters,
// beyond what the nominal parameters would still give at this point (the efficient score; at an
// exact output-error optimum the second term is 0). It scores every method's fit by the
// simulation error the diagnosis ranks by. It replaced a score on the formulation's own NLP for
// multiple shooting, whose KKT projection cancelled a gradient of norm 9e5 against the
// continuity multipliers and left numerical noise of ~4e4 sigma^2 (the EMPS closed loop: Coulomb
// friction scored 0.2 there, 3.8e4 here, its re-fit's likelihood ratio being 7.6e4).
//
// NLP score (method "nlp"), the fallback when a simulation does not finish (an unstable model
// that only multiple shooting can fit). The augmented problem's NLP (FitSession::nlp(): the
// formulation of problem.estimation.method on the estimation splits) has variables w = (theta, nu):
// the free parameters theta first, scaled (parameter_map.h), then the method's other variables nu
// (shooting nodes, initial states), and residuals r(w), equality constraints c(w) = 0 (multiple
// shooting's continuity on Ipopt). The test is evaluated at the restricted estimate w0: the
// nominal optimum with the new parameters at neutral. It is nominal.solver_result.w with the
// candidate's scaled start values (neutral for a new block's parameters, the current value for a
// parameter of the model the candidate frees) inserted at their places among the free parameters
// when the augmented NLP has exactly that many more variables (the candidate adds no state);
// otherwise (a candidate with a state adds shooting-node entries) the augmented problem is solved
// once with the candidate's parameters held and w0 is that solution.
//
// At w0, with J = dr/dw (every variable whose bounds differ; the nuisance variables nu included,
// so that the inverse below marginalises them), g = J^T r (the gradient of 1/2 |r|^2), A = dc/dw,
// H = J^T J (Gauss-Newton information, plus a ridge of 1e-9 max diag(H) that only acts on
// directions the data do not determine),
//
//   d solves   [H  A^T] [d]   [-g]          D = -g^T d
//              [A  0  ] [l] = [ 0],
//
// i.e. D = g^T Z (Z^T H Z)^-1 Z^T g with Z a basis of the null space of A: the decrease of |r|^2
// one Gauss-Newton step on the constraint manifold would give. D_full has every free variable,
// D_nominal holds the candidate's parameters (Candidate::screened) at neutral, and
//
//   LM = (D_full - D_nominal) / sigma^2,   sigma^2 = |r(w0)|^2 / (N - n_eff),
//
// N = number of residuals, n_eff = free variables minus equality constraints: the new
// parameters' gradient weighted by the inverse of their information given the nominal
// directions (the efficient score). At an exact nominal optimum D_nominal = 0; subtracting it
// removes what the nominal directions would still gain at a point that is optimal only to the
// solver's tolerance (on the EMPS closed loop fitted by Ipopt that remainder alone was 3.9e4 in
// units of sigma^2 and made every candidate score alike). Under the
// null hypothesis (the effect is absent) LM ~ chi^2(k), k = |Candidate::screened|. The p-value is
// the chi-square survival function Q(k/2, LM/2) (regularised upper incomplete gamma, series and
// continued fraction). A new parameter whose direction repeats one the model has (power-law
// friction at exponent 1 next to viscous friction) adds nothing to LM; k still counts it, so the
// test is conservative there. A neutral value at a bound (a friction level >= 0) makes the true
// null distribution a mixture with half the mass at 0: the chi^2(k) p-value is then conservative
// too. Regularisation terms of the objective are not in g.
//
// ---- Re-fits
// ------------------------------------------------------------------------------------- The
// refit_top candidates with the largest LM (finite scores only), and every structural candidate
// (Candidate::structural: no score test, CandidateScore::method "structural", score NaN; its
// grids' values listed in shape_grid_values for the profile of stage A), are re-fitted side by
// side, each
// in two stages on one FitSession of the augmented problem (the nominal free parameters free):
//   A. Candidate::screened free, the shape parameters (Candidate::refit minus screened) held at
//      their nominal values, started from the score test's one-step estimate
//      (CandidateScore::one_step, clipped to the bounds) or, when that solve is not usable, from
//      the neutral values again. With the shapes held the new parameters enter nearly linearly,
//      so this stage does not wander: started at the neutral point with every shape free, a
//      Stribeck re-fit went to vs = 438 m/s and fc = 1,616 N (a curve that vanishes on the data)
//      with no gain over the nominal model although the effect was there.
//      With shape grids (CandidateScore::shape_grid_values) stage A is then solved at each other
//      grid value too (only a fixed value changes: each solve is warm-started from the best so
//      far) and the converged solve of lowest validation NRMSE is kept: the shape is chosen as
//      the candidates are ranked, on the validation splits. The score picks where the
//      first-order signal is largest, which need not be where the fit is best (a Stribeck
//      velocity far below the truth's can score high by fitting a sharper Coulomb sign near
//      standstill, then stall there), and the estimation cost can prefer such a shape too: on
//      point-to-point moves a Stribeck velocity 8 times below the truth's fitted the standstill
//      phases best and validated 20 % worse than the grid value next to the truth's.
//      With an option grid (CandidateScore::option_grid_values: a sign's smoothing steepness)
//      stage A is solved at each other option value too, on a new session of that structure
//      started from the best fit's parameter values, and the converged solve of lowest
//      validation NRMSE is kept with its structure (RefitResult::candidate applies it; its
//      augmentation names the option). The score picked a Coulomb level's softest sign on a
//      pendulum whose truth had a hard one; that re-fit validated 20 times worse than the
//      steepest sign's, which a Stribeck curve with fs = fc then fitted in its place. A structural
//      candidate's option (the elastic split) sets its held parameters itself: its new session
//      takes only the free parameters from the best fit, and its shape grids are profiled again
//      at each option value.
//      Second start: when this warm-started solve converged but a nominal free parameter ends at
//      a bound in the nominal fit or in it, stage A is solved once more from the problem's own
//      start values of the nominal parameters (the user's guesses in the first round; the
//      previous round's estimates later) with the candidate's at the same start, and kept when
//      it validates better (RefitResult::stages says which). A nominal model that lacks an effect
//      absorbs it in such corners and a re-fit started there stays: a series elastic joint
//      fitted without its true link inertia went to Ke = 0.057 against 8.459 N m/rad, and the
//      true structure's warm re-fit from there to a damping of 0.52 against 0.004 N m s/rad,
//      validating 5 times worse than from the guesses (owned_inertia_test).
//   B. when the candidate has shape parameters: they are freed too, warm-started from A's
//      estimates (parameters, method variables and multipliers: FitSession::Solve). B replaces
//      A when its solver converged, no freed shape parameter ends at a bound, its cost is not
//      above A's (they are nested: B can only lower it) and its validation NRMSE is not above
//      A's (a freed shape can fit the estimation data's peculiarities: a Stribeck velocity
//      shrinking to 1.6 mm/s with a 300 N peak fitted the standstill phases of point-to-point
//      moves and raised the validation error by 12 %); otherwise A is kept, the reason in
//      RefitResult::stages. Stage B runs only for the round's contenders, after every re-fit's
//      stage A: a re-fit whose stage-A validation gain is below ScreeningOptions::contender_share
//      of the round's best keeps its shapes held. A structural candidate (elasticity) is always
//      a contender when its stage A is ok: its stage A holds its own parameters at guesses, not
//      at screened values, and only stage B fits them.
// The stages share the re-fit's time budget (ScreeningOptions::refit_max_seconds): once it is
// spent the remaining grid values and stage B are skipped and A's best point is the re-fit.
// Divergence test (Ipopt solves; Ceres' trust region never raises its cost): a solve is stopped
// once, in 5 of its iterations, Ipopt's dual infeasibility (inf_du, the scaled gradient of the
// Lagrangian) has exceeded 1e4 x its value at the solve's first iteration (at least 1) while the
// cost was above 10 x the nominal fit's (which the candidate at its neutral value attains, so a
// re-fit that helps ends below it; 10 x the cost is 3.2 x its RMS residual), or has exceeded
// 1e12 x that value whatever the cost (a runaway); iterations of Ipopt's restoration phase do not
// count. The solve then counts as not converged (RefitResult::stages and
// the failure say "diverging"), and when stage A's first solve, from the one-step estimate,
// diverged, it is solved again from the neutral values. On EMPS
// the closed-loop output-sensor re-fits (the controller reads the scaled or offset position) ran
// with inf_du at 1e6-1e12 and the cost 100-10,000 x the nominal fit's until their budgets ended
// (41-100 iterations, 6-21 s of CPU each, the last iterations the slowest). inf_du alone does
// not tell: a converging asymmetric-friction re-fit of a sliding mass passed 1e4 x its start on
// its way below the nominal cost (2.5e9 x, the most of any re-fit that converged in the diagnosis
// tests). A runaway is stopped at any cost: the Dahl re-fit of EMPS with its shape freed went to
// 1e14-1e20 x its start while below the nominal cost, and one of its iterations then spent 12 s
// in MUMPS (Ipopt perturbed the Hessian by 1e16) while the round's other Ipopt re-fits waited for
// the lock.
// A re-fit is ok when the solver converged (SolverResult::success: a re-fit stopped at its
// iteration limit is reported, not ranked), its validation NRMSE is finite, and, with a fixed-step
// integrator, that NRMSE changes by at most 10 % when the validation splits are simulated again
// with 4 times the substeps (a fit can exploit the integrator: a decay rate pushed to RK4's
// stability limit, where the discrete map turns into an integrator, fitted a DC motor's steps
// 8 times better than its accurate solution). A failure is reported with its reason and never
// ranked as a success. at_bound is true when a parameter of Candidate::refit ends at a bound
// (FitParameter::at_bound), except at the bounds that are ends of the effect's family
// (Candidate::family_ends: the delay's weight at the pure lag or the Pade all-pass): reported, and
// ranked after the interior re-fits (an effect that ends at its bound did not help).
//
// Validation metric: the mean over the splits of role validation of the overall simulation NRMSE
// (FitResult::evaluations, metrics.h); the test splits when there is no validation split; every
// split when there is neither (Diagnosis::validation_role says which). relative_gain =
// (before - after) / before: the share of the validation NRMSE of the model screened (`nominal`)
// the effect removes. Diagnose (diagnose.h) measures accepted effects against the first model's.
//
// Information criteria from the estimation residuals: with N = FitResult::num_residuals,
// RSS = 2 * SolverResult::cost (the least-squares cost 1/2 |r|^2 of the method) and k the number of
// free model parameters,
//   AIC = N ln(RSS / N) + 2 k,      BIC = N ln(RSS / N) + k ln N.
// Ranking: ok and interior first, then ok at a bound, then failures; within a group by validation
// NRMSE, each run of re-fits whose NRMSEs exceed the run's best by at most
// ScreeningOptions::tie_tolerance (relative) ordered by BIC (a run is measured from its best, so
// that the order is one: pairwise ties are not transitive). Then parsimony: where an effect that
// contains a simpler one (Candidate::reduces_to: a Stribeck curve with its own Coulomb level
// contains Coulomb friction, a power law viscous friction, the two-level asymmetric friction the
// constant offset) ranks ahead of that simpler effect's re-fit on the same attachment and its
// validation NRMSE is lower by at most ScreeningOptions::nested_margin x the nominal validation
// NRMSE, the simpler re-fit takes its place and it follows: the family ranks by its best member
// and is named by its simplest adequate one (a hard Coulomb sign in the data is fitted a little
// better by a Stribeck peak at a tiny velocity, which does not make it Stribeck friction).
//
// Failure behaviour. Invalid options throw std::invalid_argument (ScreeningOptions::Validate). A
// candidate whose augmented problem cannot be built or evaluated gets a NaN score and its reason
// in CandidateScore::failure; it is not re-fitted.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "graybox/diagnosis/candidates.h"
#include "graybox/diagnosis/period_scan.h"
#include "graybox/estimators/fit/fit.h"

namespace graybox::diagnosis {

struct ScreeningOptions {
  /// How many of the best-screened candidates to re-fit (>= 0).
  int refit_top = 5;
  /// Which candidates to propose.
  CandidateOptions candidates;
  /// The periodogram of the residuals against each axis' position whose peaks are the ripple
  /// candidates' periods (period_scan.h), unless candidates.ripple_periods gives them.
  PeriodScanOptions period_scan;
  /// Relative excess of a validation NRMSE over the best of its run up to which BIC decides the
  /// order within the run (>= 0; file comment, "Ranking").
  double tie_tolerance = 1e-3;
  /// Parsimony between nested effects (Candidate::reduces_to): the more general re-fit ranks
  /// first only when its validation NRMSE is lower than the simpler one's by more than
  /// nested_margin x the nominal validation NRMSE (>= 0).
  double nested_margin = 0.02;
  /// Budget of each re-fit [s], user-mode CPU time of the thread that runs it (util::
  /// ThreadUserSeconds) over all its solves (stage A,
  /// the profile over the shape grids, stage B): each solve may iterate for what is left
  /// (FitOptions:: max_solve_seconds, checked at every iteration); the profile and stage B are
  /// skipped once it is spent (said in RefitResult::stages). 0: automatic (AutomaticRefitBudget;
  /// Diagnose takes it once from the problem's nominal fit for every round), 25 times the user
  /// CPU time of the nominal fit's solve and at least 10 s (a re-fit is a warm-started fit of a
  /// model one block larger). A re-fit whose stage A is stopped by it is reported as not converged,
  /// never ranked: an unattended diagnosis must not hang on one candidate (a ripple re-fit on EMPS
  /// took 150 s where the nominal fit takes 0.8 s). A single iteration is not interrupted (a
  /// payload's unmeasured angle once made MUMPS reallocate for minutes within one). User CPU time,
  /// not wall time: waiting for Ipopt's process-wide lock or for a core of a loaded machine does
  /// not spend it, nor does the kernel's time (page faults), so the diagnosis' outcome does not
  /// depend on the machine's load (with a wall budget a Dahl re-fit on the withheld pendulum missed
  /// its grid when other work shared the cores). The automatic value comes from the nominal solve
  /// on the same clock (its thread's user CPU time), so load changes neither side (from the
  /// nominal's wall time, the DC motor's budget was 43 s in one run and 56 s in another, and its
  /// later rounds ran to it). The factor was 20 on the wall time; the nominal solves' CPU time is
  /// 0.85-0.92 of their wall time on the idle machine of docs/performance.md (the DC motor 1.88
  /// of 2.2 s, EMPS 0.83 of 0.91 s), and with 20 x it the DC motor's asymmetric-friction re-fit of
  /// round 2 stopped unconverged at its 37.6 s; 25 x keeps the budgets the validated runs had.
  double refit_max_seconds = 0.0;
  /// Stage B (the shape parameters freed, file comment) runs only for the round's contenders:
  /// re-fits that are ok after stage A and whose validation NRMSE gain (before - after) is at
  /// least this share of the best gain of the round's ok re-fits not at a bound (in [0, 1]; 0:
  /// every re-fit with shape parameters). The others keep their shapes held (at the nominal or
  /// profiled values; RefitResult::stages says so): a shape that cannot make its effect the
  /// round's best need not be freed, and stage B is the longest part of a re-fit (on EMPS a
  /// Stribeck re-fit's stage B ran into its budget in rounds where it gained 1 % of the best's).
  /// Structural candidates are always contenders (file comment).
  double contender_share = 0.5;
  /// Threads that screen and re-fit candidates side by side (>= 0; 0: one per hardware thread).
  /// Each candidate has its own FitSession; Ceres solves run in parallel, Ipopt's own code
  /// runs under the estimators' process-wide lock, everything else (the NLP's evaluations,
  /// formulation, derivatives, covariance, simulation of the splits) overlaps. The results do not
  /// depend on it.
  int num_threads = 0;
  /// Where more than one re-fit runs at a time and the problem is solved by Ipopt (not
  /// thread-safe, so its solves in threads wait for each other), run each re-fit in a child
  /// process (fork) whose result comes back through a socket; the fit is then built again in this
  /// process from the child's solver point (FitSession::ResultOf). The results are those of the
  /// re-fits in threads where the budget does not stop a re-fit (test; a budget that binds stops
  /// at a point that depends on timing either way). Off by default: each child faults in the
  /// memory it writes (copy-on-write), which on the 2-core virtual machine of docs/performance.md
  /// cost about 3 s of kernel time per re-fit and made the EMPS diagnosis slower (106 s against
  /// 97 s in threads); on a machine with more cores, where threads leave cores idle while their
  /// solves wait for Ipopt's lock, it may pay (not measured). Ceres problems, and problems with a
  /// regularisation toward the initial values, re-fit in threads either way (a child that cannot
  /// be forked too).
  bool refit_in_processes = false;
  /// Progress lines ("screening coulomb (1/7)"); none when empty. Called from the worker
  /// threads, one call at a time.
  std::function<void(const std::string&)> progress;
  /// Throws std::invalid_argument naming the first invalid field and its value.
  void Validate() const;
};

/// The score test of one candidate.
struct CandidateScore {
  Candidate candidate;
  double score = 0.0;             // LM statistic (NaN on failure)
  double p_value = 1.0;           // chi^2(dof) survival of LM (NaN on failure)
  int dof = 0;                    // |Candidate::screened|
  double sigma2 = 0.0;            // |r|^2 / (N - n_eff)
  bool restricted_solve = false;  // w0 came from a restricted solve, not the nominal point
  /// "simulation" (the score of the output-error loss by forward sensitivities) or "nlp" (the
  /// score on the formulation's own NLP, when a simulation did not finish).
  std::string method;
  std::string failure;  // empty unless the test could not be evaluated
  /// The one-step (Gauss-Newton) estimate of Candidate::screened, in their order and units: the
  /// candidate's values after the least-squares step of every column from the nominal point
  /// (method "simulation"; empty with "nlp", NaN entries where not determined). The re-fit
  /// starts there.
  std::vector<double> one_step;
  /// The shape values chosen by Candidate::shape_grids (parameter, value): the test and the
  /// re-fit start there (`candidate` applies them).
  std::vector<std::pair<std::string, double>> shape_start;
  /// Every value tried per shape grid (parameter, values); the re-fit profiles over them.
  std::vector<std::pair<std::string, std::vector<double>>> shape_grid_values;
  /// Every value of the option grid (Candidate::option_grids); the re-fit profiles over them too.
  std::vector<double> option_grid_values;
};

/// The re-fit of one candidate.
struct RefitResult {
  std::string effect, detail, attachment;
  /// The candidate re-fitted (AugmentedProblem(problem, fit, candidate, true) rebuilds its model).
  Candidate candidate;
  bool ok = false;
  bool at_bound = false;
  std::string failure;  // why not ok
  /// How the re-fit went, stage by stage (file comment): a restart from the neutral values, shape
  /// parameters freed or held with the reason.
  std::vector<std::string> stages;
  double validation_nrmse_before = 0.0, validation_nrmse_after = 0.0;
  double relative_gain = 0.0;  // (before - after) / before
  double aic = 0.0, bic = 0.0;
  double score = 0.0;  // its screening LM
  /// The candidate's parameters after the re-fit (values, standard errors, intervals, bounds).
  std::vector<estimators::FitParameter> parameters;
  estimators::FitResult fit;
};

struct Diagnosis {
  /// The ripple periods screened per position state, from the residuals' periodogram
  /// (ScanPeriods' peaks, strongest first); empty where the defaults or given periods were used.
  std::map<std::string, std::vector<double>> ripple_periods;
  /// Every candidate with its score, by LM descending (failures last).
  std::vector<CandidateScore> screened;
  /// The re-fits, ranked (see the file comment).
  std::vector<RefitResult> refits;
  std::string validation_role;  // "validation", "test" or "all"
  double nominal_validation_nrmse = 0.0;
  double nominal_aic = 0.0, nominal_bic = 0.0;

  /// "best: coulomb on velocity load.qd -> force force, validation NRMSE 0.21 -> 0.05 (76 % of
  /// the gap); screened 6, re-fitted 3".
  std::string BriefReport() const;
  /// The brief line, the screening table (effect, detail, attachment, LM, dof, p) and the re-fit
  /// table (NRMSE before/after, gap closed, AIC, BIC, status) with each re-fit's parameters.
  std::string FullReport() const;
};

/// Screens every candidate of EnumerateCandidates(problem, options.candidates) against the
/// nominal fit `nominal` (estimators::Fit(problem, splits)) and re-fits the best. See the file
/// comment.
/// The automatic re-fit budget of ScreeningOptions::refit_max_seconds = 0: 25 times the user CPU
/// time of `nominal`'s solve on its thread (FitResult::solve_thread_user_seconds, the clock the
/// re-fits' budgets are measured on), at least 10 s. A nominal result that was not solved in this
/// process (solve_thread_user_seconds 0) gets the 10 s.
double AutomaticRefitBudget(const estimators::FitResult& nominal);

Diagnosis ScreenAndRefit(const estimators::Problem& problem,
                         const std::vector<estimators::SplitData>& splits,
                         const estimators::FitResult& nominal,
                         const ScreeningOptions& options = {});

/// The augmented problem of the file comment: problem.model with every parameter at its value in
/// `start` (values in the problem's parameter order), plus the candidate's block at its neutral
/// value; with `refit`, Candidate::refit is free. std::invalid_argument when `start` has the
/// wrong number of values.
estimators::Problem AugmentedProblem(const estimators::Problem& problem,
                                     const estimators::FitResult& start, const Candidate& candidate,
                                     bool refit);

/// `splits` with each initial state (and state guess, when given) extended by zeros to
/// `num_states` (the states a candidate adds are appended after the model's own).
std::vector<estimators::SplitData> AugmentedSplits(const std::vector<estimators::SplitData>& splits,
                                                   int num_states);

/// Which splits score a model (file comment): "validation" when a split has that role, else
/// "test" when one has that role, else "all".
std::string ValidationRole(const std::vector<estimators::SplitData>& splits);

/// The validation metric of the file comment: the mean over the evaluations of role `role`
/// ("validation", "test", or "all" for every one) of the overall simulation NRMSE; NaN when one
/// of them diverged or none has the role.
double ValidationNrmse(const std::vector<estimators::SplitEvaluation>& evaluations,
                       const std::string& role);

/// Whether `fit`'s dynamics are resolved by `problem`'s fixed-step integrator: the validation NRMSE
/// (role `role`) simulated again with 4 times the substeps. A fit can exploit the integrator (a
/// decay rate pushed to RK4's stability limit, where the discrete map becomes an integrator);
/// such a fit's validation error changes with the step. Returns the reason when it changes by
/// more than 10 % of `nrmse` (or the refined simulation fails), else "" (also for CVODES, which
/// controls its own error). The splits are extended to the problem's states (AugmentedSplits).
std::string IntegrationCheck(const estimators::Problem& problem,
                             const std::vector<estimators::SplitData>& splits,
                             const estimators::FitResult& fit, const std::string& role,
                             double nrmse);

/// The chi-square survival function P(X > x), X ~ chi^2(dof): Q(dof/2, x/2). 1 for x <= 0;
/// std::invalid_argument for dof < 1.
double ChiSquareSurvival(double x, int dof);

}  // namespace graybox::diagnosis
