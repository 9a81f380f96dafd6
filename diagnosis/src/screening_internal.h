// Private to the screening (screening.cc: the candidates of a round, the ranking, the reports;
// score_test.cc: the efficient score test of one candidate at its neutral value; refit.cc: the
// two-stage re-fit of one candidate): what the three files share.
#pragma once

#include <chrono>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "graybox/diagnosis/screening.h"
#include "graybox/estimators/fit/fit.h"

namespace graybox::diagnosis::internal {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The score test of `candidate` on `problem` (screening.h, "Screening"), with its shape and
/// option grids.
CandidateScore Score(const estimators::Problem& problem,
                     const std::vector<estimators::SplitData>& splits,
                     const estimators::FitResult& nominal, const Candidate& candidate);

/// AIC and BIC of a fit from its cost (RSS = 2 cost) and free parameters; NaN without residuals.
void InformationCriteria(const estimators::FitResult& fit, double* aic, double* bic);

/// The re-fit of one screened candidate (screening.h, "Re-fits") in steps, so that a round can
/// run stage B only for its contenders: StageA() (with the profiles over the grids), then
/// optionally StageB() (the shape parameters freed) or HoldShapes(reason), Evaluate() (ok, at
/// bound, validation, information criteria; again after stage B) and Finish(), which releases the
/// session and returns the result. The budget, `max_seconds` of CPU time, counts the CPU time of
/// whichever thread runs a step, summed over the steps.
class RefitRun {
 public:
  RefitRun(const estimators::Problem& problem, const std::vector<estimators::SplitData>& splits,
           const estimators::FitResult& nominal, const CandidateScore& screened,
           const std::string& role, double before, double max_seconds);
  void StageA();
  /// True when stage A left a usable fit and the candidate has shape parameters to free.
  bool HasShapeStage() const;
  void StageB();
  /// Records that the shape parameters stay held, with the reason (when HasShapeStage()).
  void HoldShapes(const std::string& reason);
  void Evaluate();
  /// The result as evaluated so far.
  const RefitResult& result() const { return out_; }
  RefitResult Finish();

 private:
  double CpuElapsed() const;
  bool BudgetLeft();
  estimators::FitResult TimedSolve(const estimators::FitResult* start);
  void Resume();
  void Pause();

  const estimators::Problem& problem_;
  const std::vector<estimators::SplitData>& splits_;
  const estimators::FitResult& nominal_;
  const CandidateScore& screened_;
  std::string role_;
  double before_;
  double max_seconds_;
  std::chrono::steady_clock::time_point started_;
  double cpu_spent_ = 0.0, cpu_mark_ = 0.0;
  bool running_ = false;
  double solve_wall_ = 0.0, solver_seconds_ = 0.0;
  int solves_ = 0;
  bool failed_ = false;
  estimators::Problem aug_;
  std::unique_ptr<estimators::FitSession> session_;
  std::vector<std::string> shapes_;
  RefitResult out_;
};

/// The whole re-fit of one screened candidate (RefitRun's steps in order, stage B included).
RefitResult Refit(const estimators::Problem& problem,
                  const std::vector<estimators::SplitData>& splits,
                  const estimators::FitResult& nominal, const CandidateScore& screened,
                  const std::string& role, double before, double max_seconds);

}  // namespace graybox::diagnosis::internal
