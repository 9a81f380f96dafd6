// Consumer of the installed graybox package: builds a function, differentiates it, checks it.
#include <cmath>
#include <cstdio>

#include <graybox/expr.h>

int main() {
  using namespace graybox::expr;
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"y", {exp(x) * sin(x)}}});
  const double g = f.Gradient("y", "x")({Eigen::VectorXd::Constant(1, 0.5)})[0][0];
  const double expected = std::exp(0.5) * (std::sin(0.5) + std::cos(0.5));
  std::printf("consumer: d/dx exp(x) sin(x) at 0.5 = %.15g (expected %.15g)\n", g, expected);
  return std::fabs(g - expected) < 1e-14 ? 0 : 1;
}
