#include <gtest/gtest.h>

#include "graybox/expr.h"

namespace graybox::expr {
namespace {

TEST(Smoke, ProductAndGradient) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const Function f("f", {{"in", {x, y}}}, {{"out", {x * y + sin(x)}}});
  const auto r = f({Eigen::Vector2d(1.0, 2.0)});
  EXPECT_DOUBLE_EQ(r[0][0], 2.0 + std::sin(1.0));
  const auto g = f.Gradient("out", "in")({Eigen::Vector2d(1.0, 2.0)})[0];
  EXPECT_DOUBLE_EQ(g[0], 2.0 + std::cos(1.0));
  EXPECT_DOUBLE_EQ(g[1], 1.0);
}

}  // namespace
}  // namespace graybox::expr
