// Private to the screening (screening.cc: the candidates of a round, the ranking, the reports;
// score_test.cc: the efficient score test of one candidate at its neutral value; refit.cc: the
// two-stage re-fit of one candidate): what the three files share.
#pragma once

#include <chrono>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "divergence_test.h"
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

/// Orders a round's re-fits as screening.h ("Ranking") says: by group (ok and interior, ok at a
/// bound, failed), then by validation NRMSE with runs within the relative tie tolerance `tie` of
/// their best ordered by BIC, then parsimony between nested effects with the absolute NRMSE
/// margin `margin` (ScreeningOptions::nested_margin x the nominal validation NRMSE). Ok re-fits
/// must have finite validation NRMSEs and BICs (a re-fit whose validation is not finite fails).
void RankRefits(double tie, double margin, std::vector<RefitResult>* refits);

/// A re-fit's result before any solve: the candidate's identity and score, the validation NRMSE
/// before it, NaN for the figures a fit gives.
RefitResult UnfittedResult(const CandidateScore& screened, double before);

/// The steps of one re-fit as a round drives them (screening.cc): RunStageA() (stage A with the
/// profiles over the grids, evaluated), then either RunStageB() (the shape parameters freed,
/// evaluated again) or HoldShapes(reason) where HasShapeStage(), then Finish(). result() is the
/// result as evaluated so far (after RunStageA: ok, at_bound and the validation NRMSE).
class RefitSteps {
 public:
  virtual ~RefitSteps() = default;
  virtual void RunStageA() = 0;
  virtual bool HasShapeStage() const = 0;
  virtual void RunStageB() = 0;
  virtual void HoldShapes(const std::string& reason) = 0;
  virtual const RefitResult& result() const = 0;
  virtual RefitResult Finish() = 0;
};

/// The re-fit of one screened candidate (screening.h, "Re-fits") in steps, so that a round can
/// run stage B only for its contenders: StageA() (with the profiles over the grids), then
/// optionally StageB() (the shape parameters freed) or HoldShapes(reason), Evaluate() (ok, at
/// bound, validation, information criteria; again after stage B) and Finish(), which releases the
/// session and returns the result. The budget, `max_seconds` of user CPU time, counts the user CPU
/// time of whichever thread runs a step, summed over the steps.
class RefitRun : public RefitSteps {
 public:
  RefitRun(const estimators::Problem& problem, const std::vector<estimators::SplitData>& splits,
           const estimators::FitResult& nominal, const CandidateScore& screened,
           const std::string& role, double before, double max_seconds);
  // Its sessions' iteration callback holds `this`.
  RefitRun(const RefitRun&) = delete;
  RefitRun& operator=(const RefitRun&) = delete;
  void StageA();
  /// True when stage A left a usable fit and the candidate has shape parameters to free.
  bool HasShapeStage() const override;
  void StageB();
  /// Records that the shape parameters stay held, with the reason (when HasShapeStage()).
  void HoldShapes(const std::string& reason) override;
  void Evaluate();
  void RunStageA() override {
    StageA();
    Evaluate();
  }
  void RunStageB() override {
    StageB();
    Evaluate();
  }
  /// The result as evaluated so far.
  const RefitResult& result() const override { return out_; }
  /// The option value of the variant the option profile kept (Candidate::apply_with_option), or
  /// NaN when the candidate's own apply() stayed.
  double variant_option() const { return variant_option_; }
  RefitResult Finish() override;

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
  DivergenceTest divergence_;  // of the current solve (divergence_test.h)
  std::string iterations_;     // per solve, "12+3+..."
  bool failed_ = false;
  estimators::Problem aug_;
  std::unique_ptr<estimators::FitSession> session_;
  std::vector<std::string> shapes_;
  double variant_option_ = kNaN;
  RefitResult out_;
};

/// A RefitRun in a child process of this one (fork), for problems that Ipopt solves: Ipopt's code
/// runs one solve at a time in a process (it is not thread-safe), so a round's re-fits in threads
/// wait for each other; in processes they solve side by side. The child runs RunStageA() at once,
/// then the step the parent asks for and Finish(), and sends the result back through a socket pair:
/// every field but the fit, and of the fit the solver result of its solve with that solve's start
/// values and free set and the option the re-fit kept. The parent builds the fit again with
/// FitSession::ResultOf (the covariance and the evaluations, the same computation on the same
/// data) and checks its validation NRMSE against the child's. The same steps and outcome as a
/// RefitRun in a thread; the budget is the user CPU time of the child's thread. A child that ends
/// without a result (a crash, a signal) gives a failed re-fit saying so.
class RefitProcess : public RefitSteps {
 public:
  /// Forks the child, which starts stage A. std::runtime_error when the socket pair or fork fails.
  RefitProcess(const estimators::Problem& problem, const std::vector<estimators::SplitData>& splits,
               const estimators::FitResult& nominal, const CandidateScore& screened,
               const std::string& role, double before, double max_seconds);
  /// Kills and reaps a child still running.
  ~RefitProcess() override;
  RefitProcess(const RefitProcess&) = delete;
  RefitProcess& operator=(const RefitProcess&) = delete;
  /// Waits for the child's stage A.
  void RunStageA() override;
  bool HasShapeStage() const override { return has_shape_stage_; }
  /// Asks the child for stage B; Finish() waits for it.
  void RunStageB() override;
  void HoldShapes(const std::string& reason) override;
  const RefitResult& result() const override { return out_; }
  RefitResult Finish() override;

 private:
  void Fail(const std::string& why);
  std::string ChildEnd();
  // Waits for the child's next message (RefitProcess's wait limit); Fail()s on none.
  bool ReceiveFromChild(std::string* message);

  const estimators::Problem& problem_;
  const std::vector<estimators::SplitData>& splits_;
  const estimators::FitResult& nominal_;
  const CandidateScore& screened_;
  std::string role_;
  double wait_seconds_;
  int pid_ = -1;
  int channel_ = -1;  // a socket to the child
  bool commanded_ = false, failed_ = false, has_shape_stage_ = false;
  RefitResult out_;
};

/// Whether a round can re-fit in processes (RefitProcess): the problem is solved by Ipopt, more
/// than one re-fit may run at once, and no regularisation term pulls toward the values at
/// formulation (RegularizationReference::kInitial: the parent could not rebuild the child's).
bool RefitsInProcesses(const estimators::Problem& problem, int threads);

/// The whole re-fit of one screened candidate (RefitRun's steps in order, stage B included).
RefitResult Refit(const estimators::Problem& problem,
                  const std::vector<estimators::SplitData>& splits,
                  const estimators::FitResult& nominal, const CandidateScore& screened,
                  const std::string& role, double before, double max_seconds);

}  // namespace graybox::diagnosis::internal
