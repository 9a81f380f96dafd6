// The divergence test of the re-fits' Ipopt solves (screening.h, "Re-fits"; the private
// diagnosis/src/divergence_test.h, on this test's include path): fed iteration histories of the
// kind the re-fits report, it stops a solve whose dual infeasibility has grown 1e4-fold while its
// cost stays far above the nominal fit's, or 1e12-fold at any cost, and lets every other one run.
#include "divergence_test.h"

#include <vector>

#include <gtest/gtest.h>

namespace graybox::diagnosis::internal {
namespace {

using estimators::IterationSummary;

// The nominal fit's cost in these histories (the EMPS closed loop after Coulomb friction: 45.6).
constexpr double kNominalCost = 45.6;

IterationSummary It(int iteration, double cost, double inf_du, bool restoration = false) {
  IterationSummary s;
  s.iteration = iteration;
  s.cost = cost;
  s.optimality = inf_du;
  s.restoration = restoration;
  return s;
}

// The index of the first iteration at which Continue() returned false, or -1.
int StopsAt(DivergenceTest* test, const std::vector<IterationSummary>& history) {
  test->Reset();
  for (std::size_t k = 0; k < history.size(); ++k) {
    if (!test->Continue(history[k])) return static_cast<int>(k);
  }
  return -1;
}

// A closed-loop output-sensor re-fit of EMPS, as it ran until its budget ended: from a start of
// inf_du 1.2, inf_du 5e6-3e7 from the third iteration on, the cost 1e4 x the nominal's.
std::vector<IterationSummary> Diverging() {
  std::vector<IterationSummary> h = {It(0, 4.96e5, 1.2), It(1, 5.29e5, 290), It(2, 4.97e5, 1.8e3)};
  for (int k = 3; k < 40; ++k) h.push_back(It(k, 5.5e5, 1e7));
  return h;
}

TEST(RefitDivergence, StopsASolveWhoseDualInfeasibilityExplodesAboveTheNominalCost) {
  DivergenceTest test(kNominalCost);
  // Iterations 3..7 are the five above both marks.
  EXPECT_EQ(StopsAt(&test, Diverging()), 7);
  EXPECT_TRUE(test.fired());
  EXPECT_EQ(test.fired_at(), 7);
  EXPECT_DOUBLE_EQ(test.start(), 1.2);
  EXPECT_DOUBLE_EQ(test.cost_at_stop(), 5.5e5);
}

TEST(RefitDivergence, EachSolveCountsItsOwnIterations) {
  DivergenceTest test(kNominalCost);
  // Four iterations above both marks in one solve, then a new solve with one: no stop, and the
  // start is the new solve's first iteration.
  std::vector<IterationSummary> first = {It(0, 1e5, 1.0)};
  for (int k = 1; k <= 4; ++k) first.push_back(It(k, 1e5, 1e6));
  EXPECT_EQ(StopsAt(&test, first), -1);
  const std::vector<IterationSummary> second = {It(0, 1e5, 50.0), It(1, 1e5, 1e6)};
  EXPECT_EQ(StopsAt(&test, second), -1);
  EXPECT_FALSE(test.fired());
  EXPECT_DOUBLE_EQ(test.start(), 50.0);
}

TEST(RefitDivergence, RestorationIterationsDoNotCount) {
  DivergenceTest test(kNominalCost);
  std::vector<IterationSummary> h = {It(0, 1e5, 1.0)};
  for (int k = 1; k < 30; ++k) h.push_back(It(k, 1e5, 1e7, /*restoration=*/true));
  EXPECT_EQ(StopsAt(&test, h), -1);
  for (int k = 30; k < 35; ++k) h.push_back(It(k, 1e5, 1e7));
  EXPECT_EQ(StopsAt(&test, h), 34);
}

TEST(RefitDivergence, TheIterationsNeedNotFollowEachOther) {
  DivergenceTest test(kNominalCost);
  std::vector<IterationSummary> h = {It(0, 1e5, 1.0)};
  for (int k = 1; k <= 10; ++k) h.push_back(It(k, 1e5, k % 2 == 0 ? 1e6 : 10.0));
  // Above at iterations 2, 4, 6, 8, 10: the fifth is the tenth iteration.
  EXPECT_EQ(StopsAt(&test, h), 10);
}

TEST(RefitDivergence, ACostBelowTenTimesTheNominalNeverStops) {
  // A converging re-fit that passes through a large dual infeasibility on its way below the
  // nominal cost (an asymmetric-friction re-fit of a sliding mass did).
  DivergenceTest test(kNominalCost);
  std::vector<IterationSummary> h = {It(0, 300.0, 20.0)};
  for (int k = 1; k < 60; ++k) h.push_back(It(k, 400.0, 1e9));
  EXPECT_EQ(StopsAt(&test, h), -1);
  EXPECT_FALSE(test.fired());
}

// The Dahl re-fit of EMPS with its shape freed (stage B), as Ipopt printed it: the cost below the
// nominal fit's, inf_du 1e14-1e20 from the third iteration on; its tenth iteration then spent 12 s
// in MUMPS (Hessian regularised by 1e16) while the other re-fits waited for Ipopt's lock.
std::vector<IterationSummary> RunawayBelowTheNominalCost() {
  return {It(0, 52.93, 0.175),   It(1, 48.37, 4.61),    It(2, 44.68, 1.17e17),
          It(3, 44.14, 9.23e19), It(4, 44.29, 9.23e17), It(5, 44.14, 3.41e17),
          It(6, 43.98, 1.74e17), It(7, 43.99, 1.74e17), It(8, 44.01, 2.59e14)};
}

TEST(RefitDivergence, ARunawayStopsAtAnyCost) {
  DivergenceTest test(kNominalCost);
  // Iterations 2..6 are the five above 1e12 x the start (which counts as 1).
  EXPECT_EQ(StopsAt(&test, RunawayBelowTheNominalCost()), 6);
  EXPECT_TRUE(test.fired());
  EXPECT_EQ(test.fired_at(), 6);
  EXPECT_DOUBLE_EQ(test.cost_at_stop(), 43.98);
  EXPECT_DOUBLE_EQ(test.start(), 1.0);
  EXPECT_DOUBLE_EQ(test.largest_growth(), 9.23e19);
  // The next solve starts afresh: its largest growth is its own.
  const std::vector<IterationSummary> next = {It(0, 44.0, 1.0), It(1, 44.0, 3e13)};
  EXPECT_EQ(StopsAt(&test, next), -1);
  EXPECT_DOUBLE_EQ(test.largest_growth(), 3e13);
}

TEST(RefitDivergence, BothKindsOfIterationCountTowardTheFive) {
  // Three iterations above 1e4 x with the cost above 10 x the nominal's, then two runaways
  // below it.
  DivergenceTest test(kNominalCost);
  std::vector<IterationSummary> h = {It(0, 1e5, 1.0)};
  for (int k = 1; k <= 3; ++k) h.push_back(It(k, 1e5, 1e6));
  h.push_back(It(4, 40.0, 1e9));  // neither: growth below 1e12 with the cost below 10 x
  for (int k = 5; k <= 6; ++k) h.push_back(It(k, 40.0, 1e13));
  EXPECT_EQ(StopsAt(&test, h), 6);
  EXPECT_DOUBLE_EQ(test.largest_growth(), 1e13);
}

TEST(RefitDivergence, GrowthUpToTheRunawayMarkBelowTheCostMarkNeverStops) {
  // The asymmetric-friction re-fit of the synthetic slide that converged reached 2.5e9 x its
  // start with the cost below the nominal fit's; 1e12 x itself does not count.
  DivergenceTest test(kNominalCost);
  std::vector<IterationSummary> h = {It(0, 40.0, 1.0)};
  for (int k = 1; k < 60; ++k) h.push_back(It(k, 40.0, k % 2 == 0 ? 1e12 : 2.5e9));
  EXPECT_EQ(StopsAt(&test, h), -1);
  EXPECT_FALSE(test.fired());
}

TEST(RefitDivergence, GrowthBelowTenThousandfoldNeverStops) {
  DivergenceTest test(kNominalCost);
  std::vector<IterationSummary> h = {It(0, 1e6, 100.0)};
  for (int k = 1; k < 60; ++k) h.push_back(It(k, 1e6, 0.99e6));
  EXPECT_EQ(StopsAt(&test, h), -1);
}

TEST(RefitDivergence, AStartBelowOneCountsAsOne) {
  // inf_du is scaled: a start of 1e-3 (a warm start at an optimum) must not make 100 a
  // divergence.
  DivergenceTest test(kNominalCost);
  std::vector<IterationSummary> h = {It(0, 1e5, 1e-3)};
  for (int k = 1; k < 20; ++k) h.push_back(It(k, 1e5, 100.0));
  EXPECT_EQ(StopsAt(&test, h), -1);
  EXPECT_DOUBLE_EQ(test.start(), 1.0);
  for (int k = 20; k < 25; ++k) h.push_back(It(k, 1e5, 2e4));
  EXPECT_EQ(StopsAt(&test, h), 24);
}

}  // namespace
}  // namespace graybox::diagnosis::internal
