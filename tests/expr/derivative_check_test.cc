// The finite-difference checker itself: it must pass correct derivatives, and catch a wrong
// entry, a wrong structural zero and a wrong shape, reporting where. Every other derivative test
// relies on it, so a checker that always says OK would make them vacuous.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::ExpectThrowsWith;

// The checker's documented default (derivative_check.h).
constexpr double kDefaultTolerance = 1e-6;
// A deliberate error in a derivative entry, far above the tolerance.
constexpr double kPlantedError = 1e-3;

struct Fixture {
  std::vector<Expr> x = Expr::Symbols("x", 3);
  // y0 = x0 * x1, y1 = sin(x2): d y / d x = [[x1, x0, 0], [0, 0, cos(x2)]].
  Function f{"f", {{"x", x}}, {{"y", {x[0] * x[1], sin(x[2])}}}};
  std::vector<Eigen::VectorXd> point = {Eigen::Vector3d(0.5, -1.5, 0.25)};
};

// A derivative Function with nonzeros `nz` in pattern `sp` (same inputs as f).
Function Derivative(const Fixture& fx, const Sparsity& sp, const std::vector<Expr>& nz) {
  return Function("df", {{"x", fx.x}}, {FunctionIo("d", nz, sp)});
}

TEST(DerivativeCheck, AcceptsCorrectDerivatives) {
  const Fixture fx;
  const DerivativeCheckResult r = CheckJacobian(fx.f, "y", "x", fx.point);
  EXPECT_TRUE(r.ok) << r.FullReport();
  EXPECT_EQ(r.rows, 2);
  EXPECT_EQ(r.cols, 3);
  EXPECT_EQ(r.entries_checked, 6);  // every entry, zeros included
  EXPECT_LT(r.max_error, kDefaultTolerance);
  EXPECT_EQ(r.BriefReport().rfind("derivative check of d f.y / d x: OK, max error ", 0), 0u)
      << r.BriefReport();
  EXPECT_NE(r.BriefReport().find("over 6 entries (2x3)"), std::string::npos) << r.BriefReport();
  const Function scalar("s", {{"x", fx.x}}, {{"v", {fx.x[0] * fx.x[1] * exp(fx.x[2])}}});
  EXPECT_TRUE(CheckHessian(scalar, "v", "x", fx.point).ok);
}

TEST(DerivativeCheck, CatchesAWrongEntryAndReportsIt) {
  const Fixture fx;
  const Sparsity sp = Sparsity::FromTriplets(2, 3, {{0, 0}, {0, 1}, {1, 2}});
  // d y0 / d x1 is off by kPlantedError.
  const Function df = Derivative(fx, sp, {fx.x[1], fx.x[0] + kPlantedError, cos(fx.x[2])});
  const DerivativeCheckResult r = CheckDerivative(fx.f, "y", "x", df, "d", fx.point);
  EXPECT_FALSE(r.ok);
  ASSERT_FALSE(r.worst.empty());
  EXPECT_EQ(r.worst[0].row, 0);
  EXPECT_EQ(r.worst[0].col, 1);
  // |analytic - fd| / (max(|analytic|, |fd|) + noise / tolerance) = planted / (0.5 + planted +
  // noise term); the noise term is below 4e-2 |y0| = 2% of the denominator here.
  constexpr double kNoiseTermShare = 0.05;
  EXPECT_NEAR(r.worst[0].error, kPlantedError / (0.5 + kPlantedError),
              kNoiseTermShare * kPlantedError / (0.5 + kPlantedError));
  EXPECT_NEAR(r.worst[0].finite_difference, 0.5, kDefaultTolerance);
  EXPECT_NE(r.BriefReport().find("FAILED"), std::string::npos);
  EXPECT_NE(r.FullReport().find("(0, 1) analytic"), std::string::npos) << r.FullReport();
  // Worst entries come first and the list is capped.
  for (std::size_t k = 1; k < r.worst.size(); ++k)
    EXPECT_LE(r.worst[k].error, r.worst[k - 1].error);
  DerivativeCheckOptions one;
  one.max_reported = 1;
  EXPECT_EQ(CheckDerivative(fx.f, "y", "x", df, "d", fx.point, one).worst.size(), 1u);
  // A looser tolerance accepts it.
  DerivativeCheckOptions loose;
  loose.tolerance = 10 * kPlantedError;
  EXPECT_TRUE(CheckDerivative(fx.f, "y", "x", df, "d", fx.point, loose).ok);
}

TEST(DerivativeCheck, CatchesAMissingStructuralNonzero) {
  const Fixture fx;
  // Claims d y0 / d x0 is a structural zero although it is x1 = -1.5.
  const Sparsity sp = Sparsity::FromTriplets(2, 3, {{0, 1}, {1, 2}});
  const Function df = Derivative(fx, sp, {fx.x[0], cos(fx.x[2])});
  const DerivativeCheckResult r = CheckDerivative(fx.f, "y", "x", df, "d", fx.point);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.worst[0].row, 0);
  EXPECT_EQ(r.worst[0].col, 0);
  EXPECT_EQ(r.worst[0].analytic, 0.0);
  EXPECT_NEAR(r.worst[0].finite_difference, -1.5, kDefaultTolerance);
}

TEST(DerivativeCheck, CatchesAWrongHessian) {
  // f = x0^2 x1: a Hessian function that forgets the x0-x1 coupling must fail.
  const std::vector<Expr> x = Expr::Symbols("x", 2);
  const Function f("f", {{"x", x}}, {{"v", {x[0] * x[0] * x[1]}}});
  const Function grad = f.Gradient("v", "x");
  const Function wrong("h", {{"x", x}},
                       {FunctionIo("h", {2.0 * x[1]}, Sparsity::FromTriplets(2, 2, {{0, 0}}))});
  const std::vector<Eigen::VectorXd> point = {Eigen::Vector2d(1.5, 2.0)};
  EXPECT_FALSE(CheckDerivative(grad, grad.OutputName(0), "x", wrong, "h", point).ok);
  EXPECT_TRUE(CheckHessian(f, "v", "x", point).ok);
}

TEST(DerivativeCheck, RejectsShapeMismatchesAndUnknownNames) {
  const Fixture fx;
  const Function df = Derivative(fx, Sparsity::Dense(3, 3), std::vector<Expr>(9, Expr(0.0)));
  ExpectThrowsWith<std::invalid_argument>(
      [&] { CheckDerivative(fx.f, "y", "x", df, "d", fx.point); },
      {"CheckDerivative: expected 'd' of shape 2x3, got 3x3"});
  ExpectThrowsWith<std::invalid_argument>([&] { CheckJacobian(fx.f, "q", "x", fx.point); },
                                          {"unknown output 'q'"});
  ExpectThrowsWith<std::invalid_argument>([&] { CheckJacobian(fx.f, "y", "q", fx.point); },
                                          {"unknown input 'q'"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] { CheckJacobian(fx.f, "y", "x", {Eigen::Vector2d(1, 2)}); }, {"expected size 3, got 2"});
}

}  // namespace
}  // namespace graybox::expr
