// RegressLearnedForce (sparse_regression.h): the flexible reference fitted on the shared slide
// truth learns the withheld force, and the sparse regression of that learned force names its shape
// (a hard Coulomb friction; a cubic damping) with most of the learned force explained;
// invalid options and a reference that is not available are reported, not guessed.
#include "graybox/diagnosis/sparse_regression.h"

#include <cmath>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/diagnosis/reference.h"
#include "slide_truth.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;

// The withheld forces are small beside the 2.5 N drive (0.4 N Coulomb): with a Coulomb level of
// half the drive the nominal slide's best fit is a quasi-static one at RK4's stability limit (a
// mass of 8 g), which leaves the reference nothing to learn.
SparseRegression RegressOn(const std::function<double(double)>& withheld) {
  testing::SlideTruth truth;
  truth.friction = withheld;
  std::mt19937 rng(testing::TestSeed(20261127u));
  const std::vector<est::SplitData> splits = {
      testing::SlideSplit(truth, "estimation", est::SplitRole::kEstimation, 0.0, &rng),
      testing::SlideSplit(truth, "validation", est::SplitRole::kValidation, 0.7, &rng)};
  const est::Problem problem = testing::NominalSlideProblem();
  const est::FitResult nominal = est::Fit(problem, splits);
  EXPECT_TRUE(nominal.IsSolutionUsable()) << nominal.BriefReport();
  const FlexibleReference reference = FitFlexibleReference(problem, splits, nominal);
  std::cout << reference.BriefReport() << "\n";
  std::cout << "nominal " << nominal.BriefReport() << "\n";
  EXPECT_TRUE(reference.ok) << reference.failure;
  const SparseRegression s = RegressLearnedForce(reference);
  std::cout << s.BriefReport() << "\n";
  for (const AxisRegression& a : s.axes) {
    std::cout << "  absorbed by the nominal parameters " << a.absorbed_by_nominal << ", R^2 "
              << a.r_squared << "\n";
    for (const SparseTerm& t : a.terms) {
      std::cout << "  " << t.effect << " " << t.shape << " " << t.coefficient << " share "
                << t.share << "\n";
    }
  }
  return s;
}

// The learned force is the networks' static approximation of the withheld one: most of it must be
// a combination of the library's shapes.
constexpr double kMinRSquared = 0.9;
// The named effect carries most of the learned force.
constexpr double kMinShare = 0.5;

TEST(SparseRegression, NamesAHardCoulombFriction) {
  const SparseRegression s = RegressOn([](double v) { return 0.4 * std::tanh(v / 0.002); });
  ASSERT_TRUE(s.ok) << s.failure;
  ASSERT_EQ(s.axes.size(), 1u);
  EXPECT_EQ(s.axes[0].velocity, "load.qd");
  EXPECT_GT(s.axes[0].r_squared, kMinRSquared);
  ASSERT_FALSE(s.effects.empty());
  // A hard sign is the Coulomb column; a narrow Stribeck hump with its steep sign is nearly the
  // same shape over a record that spends little time near rest.
  EXPECT_TRUE(s.effects.front().effect == "coulomb" || s.effects.front().effect == "stribeck")
      << s.BriefReport();
  EXPECT_GT(s.effects.front().share, kMinShare);
  // The learned force opposes motion (friction convention): the Coulomb coefficient is positive.
  for (const SparseTerm& t : s.axes[0].terms) {
    if (t.effect == "coulomb") {
      EXPECT_GT(t.coefficient, 0.0);
    }
  }
}

TEST(SparseRegression, NamesACubicDampingAsAPowerLaw) {
  // An extra linear viscous term would be absorbed by the free nominal coefficient (the nominal
  // columns come first); a cubic damping is not, and the library's nearest shape is a power law.
  const SparseRegression s = RegressOn([](double v) { return 2.0 * v * v * v; });
  ASSERT_TRUE(s.ok) << s.failure;
  ASSERT_FALSE(s.effects.empty());
  EXPECT_EQ(s.effects.front().effect, "power_law_viscous") << s.BriefReport();
  EXPECT_GT(s.axes[0].r_squared, kMinRSquared);
}

TEST(SparseRegression, ReportsWhatItCannotDo) {
  FlexibleReference none;
  none.failure = "not fitted";
  const SparseRegression s = RegressLearnedForce(none);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.failure.find("not fitted"), std::string::npos) << s.failure;
  EXPECT_NE(s.BriefReport().find("not available"), std::string::npos);
  SparseRegressionOptions bad;
  bad.threshold = 1.5;
  EXPECT_THROW(RegressLearnedForce(none, bad), std::invalid_argument);
  bad.threshold = 0.05;
  bad.max_terms = 0;
  EXPECT_THROW(RegressLearnedForce(none, bad), std::invalid_argument);
}

}  // namespace
}  // namespace graybox::diagnosis
