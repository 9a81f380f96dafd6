// Diagnose: the whole gap analysis of a problem in one call — where the sim-to-real gap lies,
// which unmodelled effects close it (greedy forward selection over the candidate library), how far
// the error shrinks with each, and what remains unexplained.
//
//   const estimators::Problem problem = estimators::LoadProblem("problems/emps/....toml");
//   const DiagnosisReport d = Diagnose(problem, estimators::LoadData(problem));
//   std::cout << d.verdict << "\n" << d.FullReport();
//   for (const AcceptedEffect& a : d.accepted) ...   // in the order they were added
//   WriteFileAtomically(dir + "/diagnosis.json", DiagnosisJson(d));   // report_json.h
//
// ---- Steps
// ---------------------------------------------------------------------------------------
// 1. Nominal fit: estimators::Fit(problem, splits, options.fit) on the estimation splits.
// 2. Localisation of the nominal gap: Localize (localization.h) on the validation splits (test,
//    else every split; Localization::splits says which). The flexible reference (reference.h):
//    the nominal model with networks adding a learned force on every mechanical axis, fitted, to
//    measure the gap = e_nominal - e_reference that any static force shape could close.
// 3. Forward selection, round r = 1 .. max_effects, starting from the nominal model M_0:
//    ScreenAndRefit(M_{r-1}) (screening.h: every candidate of EnumerateCandidates(M_{r-1}) scored
//    by the efficient score test at its neutral value, the refit_top best re-fitted warm-started
//    and ranked). The first ranked re-fit is ACCEPTED when all of
//      (a) it is ok (solver usable, finite validation simulation) and no re-fitted parameter ended
//          at a bound;
//      (b) the likelihood-ratio test on the estimation residuals rejects "no effect":
//            LR = N ln(RSS_{r-1} / RSS_r),   p = Q_chi2(LR; k),   p < significance,
//          N = number of residuals, RSS = 2 x the method's least-squares cost, k = the number of
//          free parameters the effect adds, and for a structural candidate also its own
//          parameters its re-fit held at its grids' choice and the option its grid chose
//          (elasticity: J, K, c and the split are estimated either way, less the body's inertia
//          it holds: k = 3) (Gaussian noise of unknown variance; the
//          statistic is the deviance difference of the two nested fits);
//      (c) the validation NRMSE falls by at least min_relative_gain of its value before the step:
//            (e_{r-1} - e_r) / e_{r-1} >= min_relative_gain,
//          so that an effect must help on data it was not fitted to, by a margin that matters.
//    An accepted effect's re-fitted model becomes M_r (its parameters free as in the re-fit, the
//    others of the effect held), and the next round screens M_r. The selection stops at the
//    first round whose best re-fit is not accepted (its reason is kept in
//    DiagnosisReport::stop_reason), or after max_effects accepted effects.
// 4. The remainder: Localize on the final model's validation simulation. It is reported as
//    unexplained; nothing is absorbed into a free parameter or a network.
// 5. The independent proposal: the reference's learned force regressed onto the candidates'
//    shapes (RegressLearnedForce, sparse_regression.h), and where its effects and the accepted
//    ones agree (DiagnosisReport::agreed_effects, agreement).
//
// ---- Metrics (one name, one meaning) ----------------------------------------------------------
//   validation NRMSE  the mean over the validation splits (role validation; test when there is
//                     none; every split when there is neither: DiagnosisReport::validation_role)
//                     of the mean over the output channels of NRMSE = RMSE / std(measured channel)
//                     of the free-run simulation from the split's initial state (metrics.h).
//   shrinkage         e_before - e_after of the validation NRMSE for one accepted effect.
//   error_share       shrinkage / e_nominal: the share of the nominal validation NRMSE an effect
//                     removes (the noise floor stays in the denominator).
//   gap               e_nominal - e_reference, the flexible reference's shrinkage; NaN when the
//                     reference failed or did not improve on the nominal model.
//   gap_closed        shrinkage / gap: the share of the gap an effect closes (NaN without a gap;
//                     above 1 when the effect does better than the reference, e.g. a dynamic
//                     effect the static networks cannot represent).
//   remaining_fraction  e_final / e_nominal.
//   structured energy   of a localisation (the validation splits' residual): the mean over the
//                     output channels of NRMSE_c^2 max(0, r_c(1)), r_c(1) the residual's lag-1
//                     autocorrelation: the part of the normalised residual energy that persists
//                     from one sample to the next (white noise and quantisation give about 0, a
//                     residual that varies slowly over the samples about all of its energy).
//   structured_remaining  structured energy of the remainder / of the nominal residual.
//
// ---- Explained or not ------------------------------------------------------------------------
// The library explains the gap (DiagnosisReport::explained) when at least one effect was accepted
// AND the accepted effects remove most of the residual's structure: structured_remaining <=
// DiagnoseOptions::max_structured_remaining (0.5). An effect outside the library (a friction
// that drifts over time, a periodic disturbance) can still let a candidate through forward
// selection with a small gain (a Dahl state that follows part of a drift), while the residual
// stays as structured as before; the verdict then names the accepted effects and says that the
// gap is not explained by the library, where the remainder lies and how much structure remains.
//
// ---- Verdict
// ------------------------------------------------------------------------------------- One
// sentence, first the place (the channel with the largest residual energy, and the top-ranked
// regime, window or band entry of that channel), then the cause:
//   "the gap lies in force, at load.qd reversal (...): 41 % of its residual energy in 3 % of the
//    samples; coulomb (friction.coulomb) closes 87 % of the gap (validation NRMSE 0.094 -> 0.057,
//    flexible reference 0.052)"   (without a gap: "... removes 40 % of the validation NRMSE";
//    when the accepted effects end below the reference's error, where the gap's shares would add
//    up to more than 100 %, the shares of the nominal error too, and "(validation NRMSE 0.089 ->
//    0.012; below the flexible reference's 0.081: the whole gap closed)")
//   "... ; not explained by the candidate library (best: viscous, 0.4 %, not significant)".
// Effects the data cannot tell apart from an accepted one (AcceptedEffect::alternatives) are named
// after it: "asymmetric_friction (friction.offset; equally: sensor_offset, payload)"; its free
// parameters without a finite interval in the final fit (AcceptedEffect::unidentified) too:
// "stribeck (friction.stribeck; not identified: fc, fs)".
// DiagnosisReport::explained: see "Explained or not" above; with effects accepted but the gap not
// explained: "...; coulomb (...) removes 4 % of the validation NRMSE, but the candidate library
// does not explain the gap: 93 % of the residual's structured energy remains, in <place>".
//
// Threads and processes. Screening and re-fits run on options.screening.num_threads threads
// (screening.h), or, for a problem that Ipopt solves, in child processes, one per re-fit, where
// ScreeningOptions::refit_in_processes says so. The flexible reference (step 2)
// is fitted on one more thread beside the rounds, at a lower scheduling priority (it needs only
// the nominal fit, and only the gap needs it; the diagnosis waits for it after the last round).
// options.progress is called one line at a time.
//
// Failure behaviour. Invalid options throw std::invalid_argument naming the field
// (DiagnoseOptions::Validate); a problem or data defect throws from estimators::Fit as a fit does;
// a nominal fit whose solution is not usable throws std::runtime_error with the solver's status
// (a gap cannot be diagnosed around a failed fit). Candidate failures are recorded, not thrown.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "graybox/diagnosis/localization.h"
#include "graybox/diagnosis/reference.h"
#include "graybox/diagnosis/screening.h"
#include "graybox/diagnosis/sparse_regression.h"
#include "graybox/estimators/fit/fit.h"

namespace graybox::diagnosis {

struct DiagnoseOptions {
  /// The nominal fit (and, through ScreeningOptions, the re-fits use the problem's settings).
  estimators::FitOptions fit;
  LocalizationOptions localization;
  /// Candidates, how many re-fits per round, threads, tie tolerance.
  ScreeningOptions screening;
  /// Most effects forward selection accepts (>= 0; 0: screen and re-fit once, accept nothing).
  int max_effects = 3;
  /// Level of the likelihood-ratio test of step 3(b), in (0, 1).
  double significance = 0.01;
  /// Smallest relative decrease of the validation NRMSE of step 3(c), in [0, 1).
  double min_relative_gain = 0.02;
  /// Largest structured_remaining at which the accepted effects explain the gap (file comment),
  /// in (0, 1].
  double max_structured_remaining = 0.5;
  /// Fit the flexible reference (reference.h) to measure the gap.
  bool fit_reference = true;
  ReferenceOptions reference;
  /// The sparse regression of the reference's learned force (sparse_regression.h; its ripple
  /// periods are round 1's scanned ones unless set here).
  SparseRegressionOptions sparse_regression;
  /// Progress lines ("round 1: screening coulomb (1/9), 3.2 s"); none when empty. Also passed to
  /// the screening.
  std::function<void(const std::string&)> progress;
  /// Throws std::invalid_argument naming the first invalid field and its value.
  void Validate() const;
};

/// One effect accepted by forward selection.
struct AcceptedEffect {
  int round = 0;  // 1-based
  std::string effect, detail, attachment, instance;
  double validation_nrmse_before = 0.0, validation_nrmse_after = 0.0;
  double shrinkage = 0.0;    // before - after
  double error_share = 0.0;  // shrinkage / nominal validation NRMSE
  double gap_closed = 0.0;   // shrinkage / gap (NaN without a gap)
  double lr_statistic = 0.0, lr_p_value = 1.0;
  int dof = 0;  // parameters the effect added: k of the likelihood-ratio test (file comment)
  /// The other re-fits of the same round whose validation NRMSE is within min_relative_gain x
  /// e_before of this one's: effects the data do not tell apart from it (a constant force on an
  /// axis, a vertical payload's weight and an offset of a logged command can be one signature),
  /// as "effect (detail) on attachment".
  std::vector<std::string> alternatives;
  /// The effect's parameters in the final model (values, standard errors, 95 % intervals of the
  /// final fit, after every accepted effect).
  std::vector<estimators::FitParameter> parameters;
  /// Those of `parameters` that are free in the final fit but have no finite 95 % interval while
  /// the final fit has a covariance (its information matrix does not bound them: the data do not
  /// tell them apart, a Stribeck curve's Coulomb and static levels fitted to a saturating static
  /// map); the effect's error reduction stands, these values do not. Names in `parameters`' order.
  std::vector<std::string> unidentified;
};

/// One round of forward selection: the screening and re-fits on the model of that round, and the
/// decision on its best re-fit.
struct SelectionRound {
  int round = 0;
  Diagnosis screening;
  bool accepted = false;
  /// Why the best re-fit was not accepted ("no successful re-fit", "at a bound", "LR p = 0.3 >=
  /// 0.01", "validation gain 0.4 % < 2 %"); empty when accepted.
  std::string reason;
  double lr_statistic = 0.0, lr_p_value = 1.0;
  double relative_gain = 0.0;  // (e_before - e_after) / e_before of the best re-fit
};

struct DiagnosisReport {
  std::string problem;
  std::string validation_role;  // "validation", "test" or "all"
  DiagnoseOptions options;
  /// The budget of every re-fit in every round [s of the re-fit thread's user CPU time]:
  /// options.screening.refit_max_seconds, or AutomaticRefitBudget(nominal) when that is 0.
  double refit_budget_seconds = 0.0;

  estimators::FitResult nominal;
  /// IntegrationCheck (screening.h) of the nominal fit: empty when its validation error holds with
  /// 4 times the substeps, else the reason (a nominal fit at the integrator's stability limit, a
  /// quasi-static corner, leaves every comparison after it in doubt; reported, not thrown).
  std::string nominal_integration_warning;
  Localization nominal_localization;
  double nominal_validation_nrmse = 0.0;
  /// The flexible reference (fitted when options.fit_reference) and the gap it measures.
  FlexibleReference reference;
  double gap = 0.0;  // nominal - reference validation NRMSE; NaN without a usable reference

  std::vector<SelectionRound> rounds;
  std::vector<AcceptedEffect> accepted;
  /// The reference's learned force regressed onto the candidates' shapes (sparse_regression.h):
  /// an independent proposal; not ok without a usable reference.
  SparseRegression sparse_regression;
  /// The effects both forward selection accepted and the sparse regression proposes, in the
  /// order accepted, and one sentence on where the two agree and differ.
  std::vector<std::string> agreed_effects;
  std::string agreement;
  std::string stop_reason;

  /// The final model's fit (the nominal fit when nothing was accepted) and its localisation.
  estimators::FitResult final_fit;
  estimators::Problem final_problem;
  Localization remainder;
  double final_validation_nrmse = 0.0;
  double remaining_fraction = 1.0;  // final / nominal validation NRMSE
  /// Structured energy (file comment) of the nominal residual and of the remainder, and their
  /// ratio (1 when nothing was accepted; NaN when the nominal residual has none).
  double structured_energy_nominal = 0.0, structured_energy_final = 0.0;
  double structured_remaining = 1.0;
  /// At least one effect accepted and structured_remaining <= max_structured_remaining.
  bool explained = false;
  std::string verdict;
  /// Wall time per phase: "nominal fit", "localisation", "round 1", ..., "remainder",
  /// "sparse regression", and "flexible reference (beside the rounds)": the reference is fitted
  /// on its own thread while the rounds run, so its time overlaps theirs (the wait for it after
  /// the last round is in "remainder") and the phases do not add up to the total.
  std::vector<std::pair<std::string, double>> seconds;

  /// The verdict and the figures in one line each for the nominal and final validation NRMSE.
  std::string BriefReport() const;
  /// The brief report, the nominal localisation, each round's screening and re-fit tables with
  /// its decision, the accepted effects with their parameters, the remainder's localisation, and
  /// the timings.
  std::string FullReport() const;
};

/// The gap analysis of `problem` on `splits` (see the file comment).
DiagnosisReport Diagnose(const estimators::Problem& problem,
                         const std::vector<estimators::SplitData>& splits,
                         const DiagnoseOptions& options = {});

}  // namespace graybox::diagnosis
