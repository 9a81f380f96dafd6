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
/// ... in this many iterations of one solve (not necessarily in a row) stops it.
inline constexpr int kDivergenceIterations = 5;

/// The divergence test of one solve at a time: Reset() before each solve, Continue() at each of
/// its iterations (false: stop).
class DivergenceTest {
 public:
  /// `nominal_cost`: the cost of the nominal fit, which the candidate at its neutral value attains.
  explicit DivergenceTest(double nominal_cost = 0.0) : nominal_cost_(nominal_cost) {}
  void Reset() {
    iterations_ = above_ = 0;
    fired_at_ = -1;
    start_ = 1.0;
    cost_ = 0.0;
  }
  bool Continue(const estimators::IterationSummary& it) {
    if (iterations_++ == 0) {
      start_ = std::max(1.0, it.optimality);
      return true;
    }
    if (it.optimality > kDivergenceGrowth * start_ && it.cost > kDivergenceCost * nominal_cost_) {
      ++above_;
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
  double nominal_cost() const { return nominal_cost_; }

 private:
  double nominal_cost_;
  int iterations_ = 0, above_ = 0, fired_at_ = -1;
  double start_ = 1.0, cost_ = 0.0;
};

}  // namespace graybox::diagnosis::internal
