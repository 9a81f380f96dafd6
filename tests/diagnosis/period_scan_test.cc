// ScanPeriods (period_scan.h): the periodogram of residuals against a position finds the period
// of a position-periodic residual on a prismatic and on a rotational axis (whole numbers per
// turn), orders the peaks by strength, and returns nothing where the position does not move;
// bad options and unknown states are errors.
#include "graybox/diagnosis/period_scan.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;

constexpr double kTwoPi = 6.28318530717958647692;

models::StateSpaceModel Slide(bool prismatic) {
  models::Model m("slide");
  m.AddInput("force", prismatic ? "N" : "N m", "drive", -5.0, 5.0);
  models::BlockOptions o;
  o.words["motion"] = prismatic ? "prismatic" : "rotational";
  m.AddBlock("load", "mechanics.mass", o, {"force"}, {});
  m.AddOutput("load.qd");
  return m.Build();
}

// One estimation split: the position sweeps back and forth over `span` (a triangle wave of
// `sweeps` passes), the measured output is the simulated one plus
//   a1 sin(2 pi q / p1) + a2 cos(2 pi q / p2) + white noise of std `noise`.
est::FitResult Residuals(const models::StateSpaceModel& built, double span, double p1, double a1,
                         double p2, double a2, double noise, unsigned seed) {
  constexpr int kSamples = 4000;
  constexpr int kSweeps = 6;
  std::mt19937 rng(seed);
  std::normal_distribution<double> white(0.0, noise);
  est::SplitEvaluation e;
  e.name = "estimation";
  e.role = est::SplitRole::kEstimation;
  e.states = Eigen::MatrixXd::Zero(kSamples, built.NumStates());
  e.measured.resize(kSamples, 1);
  e.simulated.resize(kSamples, 1);
  const int q = built.StateIndex("load.q");
  for (int t = 0; t < kSamples; ++t) {
    const double phase = static_cast<double>(t) * kSweeps / kSamples;  // passes so far
    const double frac = phase - std::floor(phase);
    const bool up = static_cast<int>(std::floor(phase)) % 2 == 0;
    const double position = -0.3 * span + span * (up ? frac : 1.0 - frac);
    e.states(t, q) = position;
    e.simulated(t, 0) = std::sin(0.37 * t);  // any simulated output
    e.measured(t, 0) = e.simulated(t, 0) + a1 * std::sin(kTwoPi * position / p1) +
                       a2 * std::cos(kTwoPi * position / p2) + white(rng);
  }
  est::FitResult r;
  r.evaluations.push_back(e);
  return r;
}

TEST(ScanPeriods, FindsThePeriodsOfAPositionPeriodicResidualStrongestFirst) {
  const models::StateSpaceModel built = Slide(true);
  // 0.4 m swept, periods 0.02 m (strong) and 0.0137 m (weaker), noise as large as the first.
  const est::FitResult r = Residuals(built, 0.4, 0.02, 0.5, 0.0137, 0.3, 0.5, 20261127u);
  const PeriodScan s = ScanPeriods(built, r, "load.q", false);
  ASSERT_GE(s.peaks.size(), 2u);
  constexpr double kPeriodTolerance = 0.003;  // relative; the grid step near 0.02 m is 0.25 %
  EXPECT_NEAR(s.peaks[0], 0.02, kPeriodTolerance * 0.02);
  EXPECT_NEAR(s.peaks[1], 0.0137, kPeriodTolerance * 0.0137);
  EXPECT_NEAR(s.visited_span, 0.4, 1e-9);
  EXPECT_EQ(s.periods.size(), s.power.size());
  EXPECT_GT(s.periods.front(), s.periods.back());  // longest first
  EXPECT_LE(static_cast<int>(s.peaks.size()), PeriodScanOptions{}.num_peaks);
}

TEST(ScanPeriods, RotationalPeriodsAreWholeNumbersPerTurn) {
  const models::StateSpaceModel built = Slide(false);
  // 3 turns swept; cogging 24 per turn.
  const est::FitResult r =
      Residuals(built, 3.0 * kTwoPi, kTwoPi / 24.0, 0.5, kTwoPi / 7.0, 0.0, 0.3, 7u);
  const PeriodScan s = ScanPeriods(built, r, "load.q", true);
  ASSERT_FALSE(s.peaks.empty());
  EXPECT_DOUBLE_EQ(s.peaks[0], kTwoPi / 24.0);
  for (const double p : s.peaks) {
    const double per_turn = kTwoPi / p;
    EXPECT_NEAR(per_turn, std::round(per_turn), 1e-9) << p;
  }
}

TEST(ScanPeriods, NothingWhereThePositionDoesNotMoveAndErrorsOnBadInput) {
  const models::StateSpaceModel built = Slide(true);
  est::FitResult r = Residuals(built, 0.4, 0.02, 0.5, 0.0137, 0.3, 0.5, 1u);
  r.evaluations[0].states.setZero();
  const PeriodScan s = ScanPeriods(built, r, "load.q", false);
  EXPECT_TRUE(s.peaks.empty());
  EXPECT_TRUE(s.periods.empty());
  EXPECT_THROW(ScanPeriods(built, r, "load.x", false), std::invalid_argument);
  PeriodScanOptions bad;
  bad.num_peaks = 0;
  EXPECT_THROW(ScanPeriods(built, r, "load.q", false, bad), std::invalid_argument);
  bad = {};
  bad.oversampling = 0.5;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad = {};
  bad.min_samples_per_period = 1.0;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace graybox::diagnosis
