// Private to the re-fits (refit.cc; screening.h, "Re-fits", divergence test): the test that stops
// an Ipopt solve of a re-fit once it diverges, on the iterations as the solver reports them.
#pragma once

#include <algorithm>

#include "graybox/estimators/solvers/solvers.h"

namespace graybox::diagnosis::internal {

/// Ipopt's dual infeasibility (inf_du) this many times its value at the solve's first iteration
/// (at least 1) ...
inline constexpr double kDivergenceGrowth = 1e4;
/// ... with the cost above this many times the nominal fit's ...
inline constexpr double kDivergenceCost = 10.0;
/// ... or above this many times its start whatever the cost (a runaway: the re-fits that
/// converged in the diagnosis tests reached at most 2.5e9 x; a Dahl re-fit of EMPS passed 1e17 x
/// and one of its iterations then held Ipopt's lock for 12 s, Hessian perturbed by 1e16) ...
inline constexpr double kRunawayGrowth = 1e12;
/// ... in this many iterations of one solve (not necessarily in a row; not counting Ipopt's
/// restoration phase, whose figures are those of its own problem) stops it.
inline constexpr int kDivergenceIterations = 5;
/// The start of SolverResult::message of a solve the test stopped (the one mark of a divergence,
/// also where a re-fit's result crosses a process boundary).
inline constexpr const char* kDivergedPrefix = "diverging";

/// Whether `r` is a solve the divergence test stopped.
inline bool Diverged(const estimators::SolverResult& r) {
  return r.status_code == estimators::SolverStatus::kUserInterrupt &&
         r.message.rfind(kDivergedPrefix, 0) == 0;
}

/// The divergence test of one solve at a time: Reset() before each solve, Continue() at each of
/// its iterations (false: stop).
class DivergenceTest {
 public:
  /// `nominal_cost`: the cost of the nominal fit, which the candidate at its neutral value attains.
  explicit DivergenceTest(double nominal_cost) : nominal_cost_(nominal_cost) {}
  void Reset() {
    iterations_ = above_ = 0;
    fired_at_ = -1;
    start_ = 1.0;
    cost_ = largest_growth_ = 0.0;
  }
  bool Continue(const estimators::IterationSummary& it) {
    if (iterations_++ == 0) {
      start_ = std::max(1.0, it.optimality);
      return true;
    }
    if (it.restoration) return true;
    const double growth = it.optimality / start_;
    if (growth > kRunawayGrowth ||
        (growth > kDivergenceGrowth && it.cost > kDivergenceCost * nominal_cost_)) {
      ++above_;
      largest_growth_ = std::max(largest_growth_, growth);
    }
    if (above_ < kDivergenceIterations) return true;
    fired_at_ = it.iteration;
    cost_ = it.cost;
    return false;
  }
  /// Whether the current solve was stopped, and where.
  bool fired() const { return fired_at_ >= 0; }
  int fired_at() const { return fired_at_; }
  double start() const { return start_; }
  double cost_at_stop() const { return cost_; }
  /// The largest inf_du / start of the iterations that counted.
  double largest_growth() const { return largest_growth_; }
  double nominal_cost() const { return nominal_cost_; }

 private:
  double nominal_cost_;
  int iterations_ = 0, above_ = 0, fired_at_ = -1;
  double start_ = 1.0, cost_ = 0.0, largest_growth_ = 0.0;
};

}  // namespace graybox::diagnosis::internal
