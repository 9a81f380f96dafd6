// Star colouring of symmetric patterns and the Hessians built on it.
#include <gtest/gtest.h>

#include <random>

#include "graybox/expr.h"

namespace graybox::expr {
namespace {

// Central differences of an exact gradient: error ~1e-10 relative at the default step.
constexpr double kHessianFdTolerance = 1e-6;
constexpr unsigned kSeed = 20261122;

// No two adjacent vertices share a colour, and every path on four vertices uses >= 3 colours.
void ExpectStarColouring(const Sparsity& sp, const std::vector<int>& color) {
  const int n = sp.cols();
  std::vector<std::vector<int>> adj(n);
  const auto col = sp.ColumnOfNonzeros();
  for (int k = 0; k < sp.nnz(); ++k) {
    if (sp.row()[k] != col[k]) adj[col[k]].push_back(sp.row()[k]);
  }
  for (int v = 0; v < n; ++v) {
    for (int w : adj[v]) {
      ASSERT_NE(color[v], color[w]) << "adjacent " << v << ", " << w;
      for (int x : adj[w]) {
        if (x == v) continue;
        for (int y : adj[x]) {
          if (y == w || y == v) continue;
          const bool two_coloured = color[v] == color[x] && color[w] == color[y];
          EXPECT_FALSE(two_coloured) << "path " << v << "-" << w << "-" << x << "-" << y;
        }
      }
    }
  }
}

TEST(StarColoring, ArrowheadNeedsTwoColours) {
  constexpr int kN = 40;
  std::vector<std::pair<int, int>> entries;
  for (int i = 0; i < kN; ++i) {
    entries.push_back({i, i});
    entries.push_back({i, 0});
    entries.push_back({0, i});
  }
  const Sparsity sp = Sparsity::FromTriplets(kN, kN, entries);
  int num_star = 0, num_columns = 0;
  const auto star = StarColorSymmetric(sp, &num_star);
  ColorColumns(sp, &num_columns);
  EXPECT_EQ(num_star, 2);
  EXPECT_EQ(num_columns, kN);
  ExpectStarColouring(sp, star);
}

TEST(StarColoring, RandomSymmetricPatternsAreStarColourings) {
  std::mt19937 rng(kSeed);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 5 + static_cast<int>(rng() % 30);
    std::vector<std::pair<int, int>> entries;
    std::bernoulli_distribution edge(0.12);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j) {
        if (i == j || edge(rng)) {
          entries.push_back({i, j});
          entries.push_back({j, i});
        }
      }
    }
    const Sparsity sp = Sparsity::FromTriplets(n, n, entries);
    int num = 0;
    const auto color = StarColorSymmetric(sp, &num);
    ExpectStarColouring(sp, color);
  }
}

// A parameter coupled to every state: the Hessian is an arrowhead, which star colouring
// recovers with 2 forward-over-reverse sweeps.
TEST(StarColoring, ArrowheadHessianMatchesFiniteDifferences) {
  constexpr int kN = 30;
  const std::vector<Expr> x = Expr::Symbols("x", kN);
  Expr f = 0.0;
  for (int i = 1; i < kN; ++i) f += x[0] * x[i] * x[i] + sin(x[0] * x[i]);
  const Function fn("arrow", {{"x", x}}, {{"f", {f}}});
  const Function hess = fn.Hessian("f", "x");
  EXPECT_EQ(hess.OutputSparsity(0).nnz(), 3 * kN - 2);
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd x0(kN);
  for (int i = 0; i < kN; ++i) x0[i] = u(rng);
  const DerivativeCheckResult check = CheckHessian(fn, "f", "x", {x0});
  EXPECT_TRUE(check.ok) << check.FullReport();
  EXPECT_LT(check.max_error, kHessianFdTolerance);
}

TEST(StarColoring, LagrangianHessianLowerTriangleMatchesDense) {
  constexpr int kN = 12;
  const std::vector<Expr> x = Expr::Symbols("x", kN);
  Expr obj = 0.0;
  std::vector<Expr> g;
  for (int i = 1; i < kN; ++i) {
    obj += x[0] * exp(0.1 * x[i]);
    g.push_back(x[i] * x[i - 1] - x[0] * x[0]);
  }
  const Function fn("nlp", {{"x", x}}, {{"f", {obj}}, {"g", g}});
  const Function lag = HessianOfLagrangian(fn, "x", "f", "g");
  const Sparsity& sp = lag.OutputSparsity(0);
  for (int k = 0; k < sp.nnz(); ++k) EXPECT_GE(sp.row()[k], sp.ColumnOfNonzeros()[k]);
  // Reference: dense Hessian of sigma*f + lambda^T g formed by hand through Function::Hessian.
  const Expr sigma = Expr::Symbol("s");
  const std::vector<Expr> lambda = Expr::Symbols("l", kN - 1);
  Expr lagrangian = sigma * obj;
  for (int i = 0; i < kN - 1; ++i) lagrangian += lambda[i] * g[i];
  const Function ref("ref", {{"x", x}, {"s", {sigma}}, {"l", lambda}}, {{"L", {lagrangian}}});
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd x0(kN), l0(kN - 1);
  for (int i = 0; i < kN; ++i) x0[i] = u(rng);
  for (int i = 0; i < kN - 1; ++i) l0[i] = u(rng);
  const Eigen::VectorXd s0 = Eigen::VectorXd::Constant(1, 0.7);
  const Eigen::VectorXd lower = lag({x0, s0, l0})[0];
  const Function ref_hess = ref.Hessian("L", "x");
  const Eigen::VectorXd full = ref_hess({x0, s0, l0})[0];
  const Sparsity& fsp = ref_hess.OutputSparsity(0);
  const auto col = sp.ColumnOfNonzeros();
  constexpr double kSameGraphTolerance = 1e-13;  // same expressions, different sweep order
  for (int k = 0; k < sp.nnz(); ++k) {
    const int kf = fsp.Find(sp.row()[k], col[k]);
    ASSERT_GE(kf, 0);
    EXPECT_NEAR(lower[k], full[kf], kSameGraphTolerance * (1.0 + std::fabs(full[kf])));
  }
}

}  // namespace
}  // namespace graybox::expr
