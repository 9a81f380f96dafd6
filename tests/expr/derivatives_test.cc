// Derivative Functions: Forward, Reverse, Jacobian, Gradient and Hessian agree with each other
// and with central differences on random multi-input multi-output trees; exact Jacobian and
// Hessian sparsity on known structures; colouring; HessianOfLagrangian; third derivatives.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::Densify;
using testing::ExpectThrowsWith;
using testing::RandomTrees;
using testing::RandomVector;

constexpr std::uint32_t kSeed = 4242;
constexpr int kNumFunctions = 40;
constexpr int kTreeDepth = 4;
// Every mode is built from the same local partials; they differ only in the order in which
// products are accumulated, i.e. by rounding.
constexpr double kModeAgreementTol = 1e-12;
// Central differences with the checker's default step are accurate to ~1e-10 (derivative_check.h).
constexpr double kFiniteDifferenceTol = 1e-6;

// max |a - b| / max(1, |b|) over all entries.
double RelError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  EXPECT_EQ(a.rows(), b.rows());
  EXPECT_EQ(a.cols(), b.cols());
  double e = 0.0;
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      e = std::max(e, std::fabs(a(i, j) - b(i, j)) / std::max(1.0, std::fabs(b(i, j))));
    }
  }
  return e;
}

// Dense Jacobian d output / d input of f at `point` from f.Jacobian.
Eigen::MatrixXd DenseJacobian(const Function& f, const std::string& out, const std::string& in,
                              const std::vector<Eigen::VectorXd>& point) {
  const Function j = f.Jacobian(out, in);
  return Densify(j.OutputSparsity(0), j(point)[0]);
}

// A random function: inputs x (3) and p (2); outputs y (3 entries), z (2 entries) and the
// scalar s, each a random tree over all five symbols.
Function RandomFunction(RandomTrees* trees, const std::vector<Expr>& x,
                        const std::vector<Expr>& p) {
  std::vector<Expr> y, z;
  for (int k = 0; k < 3; ++k) y.push_back(trees->Generate(kTreeDepth));
  for (int k = 0; k < 2; ++k) z.push_back(trees->Generate(kTreeDepth));
  const Expr s = trees->Generate(kTreeDepth) * trees->Generate(kTreeDepth);
  return Function("rand", {{"x", x}, {"p", p}}, {{"y", y}, {"z", z}, {"s", {s}}});
}

TEST(DerivativeModes, AgreeWithEachOtherAndWithFiniteDifferences) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  const std::vector<Expr> x = Expr::Symbols("x", 3), p = Expr::Symbols("p", 2);
  std::vector<Expr> all = x;
  all.insert(all.end(), p.begin(), p.end());
  RandomTrees trees(all, kSeed);
  DerivativeCheckOptions fd;
  fd.tolerance = kFiniteDifferenceTol;
  for (int t = 0; t < kNumFunctions; ++t) {
    SCOPED_TRACE("function " + std::to_string(t));
    const Function f = RandomFunction(&trees, x, p);
    const std::vector<Eigen::VectorXd> point = {RandomVector(&rng, 3, -1.5, 1.5),
                                                RandomVector(&rng, 2, -1.5, 1.5)};
    // Jacobians of every output with respect to every input, checked against differences.
    Eigen::MatrixXd jac[3][2];
    const char* outs[] = {"y", "z", "s"};
    const char* ins[] = {"x", "p"};
    for (int o = 0; o < 3; ++o) {
      for (int i = 0; i < 2; ++i) {
        jac[o][i] = DenseJacobian(f, outs[o], ins[i], point);
        const DerivativeCheckResult r = CheckJacobian(f, outs[o], ins[i], point, fd);
        EXPECT_TRUE(r.ok) << r.FullReport() << f.OutputExprs(o)[0];
      }
    }
    // Forward mode, two directions at once.
    const Function fwd = f.Forward(2);
    ASSERT_EQ(fwd.NumInputs(), 6);
    EXPECT_EQ(fwd.InputName(2), "fwd0_x");
    EXPECT_EQ(fwd.InputName(5), "fwd1_p");
    EXPECT_EQ(fwd.OutputName(0), "fwd0_y");
    EXPECT_EQ(fwd.OutputName(5), "fwd1_s");
    std::vector<Eigen::VectorXd> fwd_in = point;
    for (int k = 0; k < 4; ++k) fwd_in.push_back(RandomVector(&rng, k % 2 == 0 ? 3 : 2, -1, 1));
    const auto tangents = fwd(fwd_in);
    for (int d = 0; d < 2; ++d) {
      for (int o = 0; o < 3; ++o) {
        const Eigen::VectorXd expected =
            jac[o][0] * fwd_in[2 + 2 * d] + jac[o][1] * fwd_in[3 + 2 * d];
        EXPECT_LE(RelError(tangents[3 * d + o], expected), kModeAgreementTol) << "fwd " << d;
      }
    }
    // Reverse mode.
    const Function rev = f.Reverse(1);
    ASSERT_EQ(rev.NumInputs(), 5);
    EXPECT_EQ(rev.InputName(2), "adj0_y");
    EXPECT_EQ(rev.OutputName(1), "adj0_p");
    std::vector<Eigen::VectorXd> rev_in = point;
    rev_in.push_back(RandomVector(&rng, 3, -1, 1));
    rev_in.push_back(RandomVector(&rng, 2, -1, 1));
    rev_in.push_back(RandomVector(&rng, 1, -1, 1));
    const auto adjoints = rev(rev_in);
    for (int i = 0; i < 2; ++i) {
      Eigen::VectorXd expected = Eigen::VectorXd::Zero(i == 0 ? 3 : 2);
      for (int o = 0; o < 3; ++o) expected += jac[o][i].transpose() * rev_in[2 + o];
      EXPECT_LE(RelError(adjoints[i], expected), kModeAgreementTol) << "rev " << i;
    }
    // Gradient of the scalar output equals its Jacobian row.
    const Eigen::VectorXd grad = f.Gradient("s", "x")(point)[0];
    EXPECT_LE(RelError(grad.transpose(), jac[2][0]), kModeAgreementTol);
    // Hessian: symmetric, equal to the Jacobian of the gradient, and to differences.
    const Function hess = f.Hessian("s", "x");
    const Sparsity& hp = hess.OutputSparsity(0);
    EXPECT_EQ(hp, hp.Transpose());
    const Eigen::MatrixXd h = Densify(hp, hess(point)[0]);
    EXPECT_LE(RelError(h, h.transpose()), kModeAgreementTol);
    const Function g = f.Gradient("s", "x");
    EXPECT_LE(RelError(h, DenseJacobian(g, g.OutputName(0), "x", point)), kModeAgreementTol);
    const DerivativeCheckResult r = CheckHessian(f, "s", "x", point, fd);
    EXPECT_TRUE(r.ok) << r.FullReport() << f.OutputExprs(2)[0];
  }
}

TEST(DerivativeModes, FreeFunctionsValidateArguments) {
  const Expr a = Expr::Symbol("a"), b = Expr::Symbol("b");
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        ForwardDerivative({a * b}, {a, a + b}, {{1.0, 0.0}});
      },
      {"ForwardDerivative", "expected input 1 to be a symbol", "got"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        ForwardDerivative({a * b}, {a, b}, {{1.0}});
      },
      {"expected seed 0 of size 2, got 1"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        ReverseDerivative({a * b}, {a, b}, {{1.0, 2.0}});
      },
      {"expected seed 0 of size 1, got 2"});
  ExpectThrowsWith<std::invalid_argument>([&] { JacobianSparsity({a}, {a * b}); },
                                          {"JacobianSparsity", "to be a symbol"});
  // Outputs that do not depend on an input have zero derivative, not an error.
  const auto d = ForwardDerivative({Expr(2.0), b}, {a}, {{Expr(1.0)}});
  EXPECT_TRUE(d[0][0].IsZero());
  EXPECT_TRUE(d[0][1].IsZero());
  EXPECT_TRUE(Gradient(b * b, {a})[0].IsZero());
}

TEST(DerivativeModes, DerivativesWithoutDependenceAreEmptyOrZero) {
  const std::vector<Expr> x = Expr::Symbols("x", 3), p = Expr::Symbols("p", 1);
  const Function f("lin", {{"x", x}, {"p", p}},
                   {{"lin", {2.0 * x[0] - x[1] + 3.0 * x[2] * p[0]}}, {"c", {p[0] * p[0], 5.0}}});
  const Function h = f.Hessian("lin", "x");
  EXPECT_EQ(h.OutputSparsity(0).nnz(), 0);
  EXPECT_EQ(h.OutputSparsity(0).rows(), 3);
  const Function j = f.Jacobian("c", "x");
  EXPECT_EQ(j.OutputSparsity(0), Sparsity(2, 3, {0, 0, 0, 0}, {}));
  const std::vector<Eigen::VectorXd> point = {Eigen::Vector3d(1, 2, 3), Eigen::VectorXd::Ones(1)};
  EXPECT_EQ(j(point)[0].size(), 0);
  EXPECT_EQ(f.Gradient("lin", "x")(point)[0], Eigen::Vector3d(2, -1, 3));
  // Mixed second derivative through the parameter: d/dp of the gradient.
  const Function g = f.Gradient("lin", "x");
  EXPECT_EQ(DenseJacobian(g, g.OutputName(0), "p", point), Eigen::Vector3d(0, 0, 3));
}

// ---- sparsity of known structures --------------------------------------------------------

TEST(JacobianStructure, ArrowPatternIsExact) {
  constexpr int n = 8;
  const std::vector<Expr> x = Expr::Symbols("x", n);
  std::vector<Expr> y(n);
  y[0] = Expr(0.0);
  for (int i = 0; i < n; ++i) y[0] = y[0] + x[i] * x[i];
  for (int i = 1; i < n; ++i) y[i] = x[0] * sin(x[i]);
  const Function f("arrow", {{"x", x}}, {{"y", y}});
  std::vector<std::pair<int, int>> expected;
  for (int j = 0; j < n; ++j) expected.push_back({0, j});
  for (int i = 1; i < n; ++i) {
    expected.push_back({i, 0});
    expected.push_back({i, i});
  }
  const Sparsity sp = Sparsity::FromTriplets(n, n, expected);
  EXPECT_EQ(f.JacobianSparsity("y", "x"), sp) << f.JacobianSparsity("y", "x").ToString();
  // A dense row and a dense column: neither compression helps, the values must be right anyway.
  const Function j = f.Jacobian("y", "x");
  EXPECT_EQ(j.OutputSparsity(0), sp);
  std::mt19937 rng = testing::SeededRng(kSeed);
  const DerivativeCheckResult r =
      CheckJacobian(f, "y", "x", {RandomVector(&rng, n, -1, 1)}, DerivativeCheckOptions{});
  EXPECT_TRUE(r.ok) << r.FullReport();
}

TEST(JacobianStructure, RowArrowUsesFewReverseSweeps) {
  // y_0 depends on all x, y_i on x_i only: columns need n colours, rows only 2.
  constexpr int n = 30;
  const std::vector<Expr> x = Expr::Symbols("x", n);
  std::vector<Expr> y(n);
  y[0] = Expr(0.0);
  for (int i = 0; i < n; ++i) y[0] = y[0] + exp(x[i]);
  for (int i = 1; i < n; ++i) y[i] = x[i] * x[i];
  const Function f("rows", {{"x", x}}, {{"y", y}});
  const Sparsity sp = f.JacobianSparsity("y", "x");
  int col_colours = 0, row_colours = 0;
  ColorColumns(sp, &col_colours);
  ColorColumns(sp.Transpose(), &row_colours);
  EXPECT_EQ(col_colours, n);
  EXPECT_EQ(row_colours, 2);
  std::mt19937 rng = testing::SeededRng(kSeed);
  const DerivativeCheckResult r =
      CheckJacobian(f, "y", "x", {RandomVector(&rng, n, -1, 1)}, DerivativeCheckOptions{});
  EXPECT_TRUE(r.ok) << r.FullReport();
}

std::vector<Expr> Banded(const std::vector<Expr>& x) {
  const int n = static_cast<int>(x.size());
  std::vector<Expr> y;
  for (int i = 0; i < n; ++i) {
    Expr e = sin(x[i]) * x[i];
    if (i > 0) e = e + x[i - 1] * x[i];
    if (i + 1 < n) e = e + exp(x[i + 1]) * x[i];
    y.push_back(e);
  }
  return y;
}

TEST(JacobianStructure, BandedJacobianNeedsThreeColours) {
  constexpr int n = 100;
  const std::vector<Expr> x = Expr::Symbols("x", n);
  const Function f("band", {{"x", x}}, {{"y", Banded(x)}});
  std::vector<std::pair<int, int>> tri;
  for (int i = 0; i < n; ++i) {
    for (int j = std::max(0, i - 1); j <= std::min(n - 1, i + 1); ++j) tri.push_back({i, j});
  }
  const Sparsity sp = f.JacobianSparsity("y", "x");
  EXPECT_EQ(sp, Sparsity::FromTriplets(n, n, tri));
  int colours = 0;
  const std::vector<int> colour = ColorColumns(sp, &colours);
  EXPECT_EQ(colours, 3);
  const Function j = f.Jacobian("y", "x");
  // 3n - 2 stored entries instead of the n^2 of a dense Jacobian, and a graph whose size grows
  // linearly with n (three compressed sweeps, not n).
  EXPECT_EQ(j.OutputSize(0), 3 * n - 2);
  EXPECT_LT(j.NumNodes(), static_cast<std::size_t>(n * n / 10));
  const std::vector<Expr> x2 = Expr::Symbols("x", 2 * n);
  const Function f2("band2", {{"x", x2}}, {{"y", Banded(x2)}});
  const Function j2 = f2.Jacobian("y", "x");
  EXPECT_LT(j2.NumNodes(), 2 * j.NumNodes() + 20);
  std::mt19937 rng = testing::SeededRng(kSeed);
  const DerivativeCheckResult r =
      CheckJacobian(f, "y", "x", {RandomVector(&rng, n, -1, 1)}, DerivativeCheckOptions{});
  EXPECT_TRUE(r.ok) << r.FullReport();
}

TEST(JacobianStructure, DetectionIsExactAcrossInputBlocks) {
  // Dependencies are propagated 256 input columns at a time: couple columns far apart.
  constexpr int n = 700;
  const std::vector<Expr> x = Expr::Symbols("x", n);
  std::vector<Expr> y;
  std::vector<std::pair<int, int>> expected;
  for (int i = 0; i < n; ++i) {
    const int far = (i * 263 + 5) % n;
    y.push_back(i == far ? exp(x[i]) : x[i] * sin(x[far]));
    expected.push_back({i, i});
    expected.push_back({i, far});
  }
  const Function f("far", {{"x", x}}, {{"y", y}});
  EXPECT_EQ(f.JacobianSparsity("y", "x"), Sparsity::FromTriplets(n, n, expected));
  std::mt19937 rng = testing::SeededRng(kSeed);
  const std::vector<Eigen::VectorXd> point = {RandomVector(&rng, n, -1, 1)};
  const Function j = f.Jacobian("y", "x");
  const Eigen::VectorXd nz = j(point)[0];
  const Sparsity& sp = j.OutputSparsity(0);
  for (int i = 0; i < n; ++i) {
    const int far = (i * 263 + 5) % n;
    if (i == far) continue;
    EXPECT_EQ(nz[sp.Find(i, i)], std::sin(point[0][far]));
    EXPECT_EQ(nz[sp.Find(i, far)], point[0][i] * std::cos(point[0][far]));
  }
}

TEST(JacobianStructure, BlockDiagonalAndConditionsCarryNoDependence) {
  // Three 2x2 blocks; the condition of an if_else and a comparison add no dependence.
  const std::vector<Expr> x = Expr::Symbols("x", 6);
  std::vector<Expr> y;
  for (int b = 0; b < 3; ++b) {
    const Expr& u = x[2 * b];
    const Expr& v = x[2 * b + 1];
    const Expr cond = lt(x[(2 * b + 2) % 6], 0.0);  // from another block
    y.push_back(if_else(cond, u * v, u + v));
    y.push_back(atan2(u, v) + sign(x[(2 * b + 3) % 6]));
  }
  const Function f("blocks", {{"x", x}}, {{"y", y}});
  std::vector<std::pair<int, int>> blocks;
  for (int b = 0; b < 3; ++b) {
    for (int i = 0; i < 2; ++i) {
      for (int j = 0; j < 2; ++j) blocks.push_back({2 * b + i, 2 * b + j});
    }
  }
  EXPECT_EQ(f.JacobianSparsity("y", "x"), Sparsity::FromTriplets(6, 6, blocks));
  int colours = 0;
  ColorColumns(f.JacobianSparsity("y", "x"), &colours);
  EXPECT_EQ(colours, 2);
}

TEST(HessianStructure, ChainedRosenbrockIsTridiagonal) {
  constexpr int n = 12;
  const std::vector<Expr> x = Expr::Symbols("x", n);
  Expr f = 0.0;
  for (int i = 0; i + 1 < n; ++i) {
    f = f + 100.0 * square(x[i + 1] - x[i] * x[i]) + square(1.0 - x[i]);
  }
  const Function fn("rosenbrock", {{"x", x}}, {{"f", {f}}});
  std::vector<std::pair<int, int>> tri;
  for (int i = 0; i < n; ++i) {
    for (int j = std::max(0, i - 1); j <= std::min(n - 1, i + 1); ++j) tri.push_back({i, j});
  }
  const Function h = fn.Hessian("f", "x");
  EXPECT_EQ(h.OutputSparsity(0), Sparsity::FromTriplets(n, n, tri))
      << h.OutputSparsity(0).ToString();
  // Closed form at x = 1: H_ii = 1200 x_i^2 - 400 x_{i+1} + 2 + 200 (i > 0), H_i,i+1 = -400 x_i.
  const Eigen::MatrixXd dense = Densify(h.OutputSparsity(0), h({Eigen::VectorXd::Ones(n)})[0]);
  for (int i = 0; i < n; ++i) {
    const double diag = (i + 1 < n ? 802.0 : 0.0) + (i > 0 ? 200.0 : 0.0);
    EXPECT_EQ(dense(i, i), diag) << i;
    if (i + 1 < n) {
      EXPECT_EQ(dense(i, i + 1), -400.0);
      EXPECT_EQ(dense(i + 1, i), -400.0);
    }
  }
  std::mt19937 rng = testing::SeededRng(kSeed);
  DerivativeCheckOptions fd;
  fd.tolerance = kFiniteDifferenceTol;
  const DerivativeCheckResult r = CheckHessian(fn, "f", "x", {RandomVector(&rng, n, -1, 1)}, fd);
  EXPECT_TRUE(r.ok) << r.FullReport();
}

TEST(HessianStructure, ArrowheadHessianIsRecoveredExactly) {
  // A parameter coupled to every state: column colouring needs n colours, a star colouring 2,
  // so the symmetric recovery path is used. Every entry must still be right.
  constexpr int n = 25;
  const std::vector<Expr> x = Expr::Symbols("x", n);
  Expr f = 0.0;
  for (int i = 1; i < n; ++i) f = f + x[0] * x[i] * x[i] + pow(x[i], 3.0) + sin(x[0] * x[i]);
  const Function fn("arrow", {{"x", x}}, {{"f", {f}}});
  const Function h = fn.Hessian("f", "x");
  std::vector<std::pair<int, int>> arrow;
  for (int i = 0; i < n; ++i) {
    arrow.push_back({i, i});
    if (i > 0) {
      arrow.push_back({0, i});
      arrow.push_back({i, 0});
    }
  }
  EXPECT_EQ(h.OutputSparsity(0), Sparsity::FromTriplets(n, n, arrow));
  std::mt19937 rng = testing::SeededRng(kSeed);
  const std::vector<Eigen::VectorXd> point = {RandomVector(&rng, n, -1, 1)};
  const Eigen::MatrixXd hd = Densify(h.OutputSparsity(0), h(point)[0]);
  const Eigen::VectorXd& v = point[0];
  for (int i = 1; i < n; ++i) {
    // d2f/dx0dxi = 2 xi + cos(x0 xi) - x0 xi sin(x0 xi); d2f/dxi2 = 2 x0 + 6 xi - x0^2 sin(x0 xi)
    const double s = std::sin(v[0] * v[i]), c = std::cos(v[0] * v[i]);
    const double mixed = 2 * v[i] + c - v[0] * v[i] * s;
    const double diag = 2 * v[0] + 6 * v[i] - v[0] * v[0] * s;
    EXPECT_LE(std::fabs(hd(0, i) - mixed), kModeAgreementTol * std::max(1.0, std::fabs(mixed)));
    EXPECT_LE(std::fabs(hd(i, 0) - mixed), kModeAgreementTol * std::max(1.0, std::fabs(mixed)));
    EXPECT_LE(std::fabs(hd(i, i) - diag), kModeAgreementTol * std::max(1.0, std::fabs(diag)));
  }
  DerivativeCheckOptions fd;
  fd.tolerance = kFiniteDifferenceTol;
  const DerivativeCheckResult r = CheckHessian(fn, "f", "x", point, fd);
  EXPECT_TRUE(r.ok) << r.FullReport();
  // The Lagrangian Hessian of the same objective is its lower triangle.
  const Function hl = HessianOfLagrangian(fn, "x", "f", "");
  EXPECT_EQ(hl.OutputSparsity(0), h.OutputSparsity(0).LowerTriangle());
  const Eigen::MatrixXd lower =
      Densify(hl.OutputSparsity(0), hl({point[0], Eigen::VectorXd::Ones(1), Eigen::VectorXd()})[0]);
  EXPECT_LE(RelError(lower, Eigen::MatrixXd(hd.triangularView<Eigen::Lower>())), kModeAgreementTol);
}

TEST(HessianStructure, BlockDiagonalHessian) {
  const std::vector<Expr> x = Expr::Symbols("x", 6);
  Expr f = 0.0;
  for (int b = 0; b < 3; ++b) f = f + exp(x[2 * b] * x[2 * b + 1]) + pow(x[2 * b], 3.0);
  const Function fn("blocks", {{"x", x}}, {{"f", {f}}});
  std::vector<std::pair<int, int>> blocks;
  for (int b = 0; b < 3; ++b) {
    for (int i = 0; i < 2; ++i) {
      for (int j = 0; j < 2; ++j) blocks.push_back({2 * b + i, 2 * b + j});
    }
  }
  EXPECT_EQ(fn.Hessian("f", "x").OutputSparsity(0), Sparsity::FromTriplets(6, 6, blocks));
  std::mt19937 rng = testing::SeededRng(kSeed);
  DerivativeCheckOptions fd;
  fd.tolerance = kFiniteDifferenceTol;
  const DerivativeCheckResult r = CheckHessian(fn, "f", "x", {RandomVector(&rng, 6, -1, 1)}, fd);
  EXPECT_TRUE(r.ok) << r.FullReport();
}

// ---- colouring -----------------------------------------------------------------------------

TEST(Colouring, ColorColumnsIsValidOnRandomPatterns) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  for (int t = 0; t < 60; ++t) {
    const int rows = std::uniform_int_distribution<int>(1, 40)(rng);
    const int cols = std::uniform_int_distribution<int>(1, 40)(rng);
    const double density = std::uniform_real_distribution<double>(0.02, 0.5)(rng);
    std::vector<std::pair<int, int>> entries;
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) {
        if (std::uniform_real_distribution<double>(0, 1)(rng) < density) entries.push_back({i, j});
      }
    }
    const Sparsity sp = Sparsity::FromTriplets(rows, cols, entries);
    int num = -1;
    const std::vector<int> colour = ColorColumns(sp, &num);
    ASSERT_EQ(static_cast<int>(colour.size()), cols);
    EXPECT_GE(num, 1);
    EXPECT_LE(num, cols);
    int max_row_count = 0;
    const Sparsity rows_of = sp.Transpose();  // column i of the transpose = row i
    for (int i = 0; i < rows; ++i) {
      std::vector<int> seen;
      for (int k = rows_of.colind()[i]; k < rows_of.colind()[i + 1]; ++k) {
        const int c = colour[rows_of.row()[k]];
        ASSERT_GE(c, 0);
        ASSERT_LT(c, num);
        EXPECT_EQ(std::count(seen.begin(), seen.end(), c), 0)
            << "two columns of colour " << c << " share row " << i;
        seen.push_back(c);
      }
      max_row_count = std::max(max_row_count, static_cast<int>(seen.size()));
    }
    // A row with k nonzeros needs k colours; greedy may use more, never fewer.
    EXPECT_GE(num, max_row_count);
    for (int c : colour) EXPECT_TRUE(c >= 0 && c < num);
  }
  int num = -1;
  EXPECT_TRUE(ColorColumns(Sparsity(3, 0, {0}, {}), &num).empty());
  EXPECT_EQ(num, 0);
}

// ---- Hessian of the Lagrangian ------------------------------------------------------------

TEST(HessianOfLagrangian, LowerTriangleMatchesFiniteDifferences) {
  const std::vector<Expr> x = Expr::Symbols("x", 4), p = Expr::Symbols("p", 2);
  const Expr f = exp(x[0] * p[0]) + x[1] * x[2] * x[2] + sin(x[3]) * p[1];
  const std::vector<Expr> g = {x[0] * x[1] - p[1], square(x[2]) + pow(x[3], 3.0),
                               log(1.0 + x[0] * x[0] + x[3] * x[3])};
  const Function fn("nlp", {{"x", x}, {"p", p}}, {{"f", {f}}, {"g", g}});
  const Function hl = HessianOfLagrangian(fn, "x", "f", "g");
  ASSERT_EQ(hl.NumInputs(), 4);
  EXPECT_EQ(hl.InputName(2), "sigma");
  EXPECT_EQ(hl.InputName(3), "lambda");
  EXPECT_EQ(hl.InputSize(3), 3);
  EXPECT_EQ(hl.OutputName(0), "hess_lagrangian");
  const Sparsity& lower = hl.OutputSparsity(0);
  for (int k = 0, c = 0; k < lower.nnz(); ++k) {
    while (lower.colind()[c + 1] <= k) ++c;
    EXPECT_GE(lower.row()[k], c) << "entry above the diagonal";
  }
  // Reference Lagrangian built independently, its gradient differenced centrally.
  const Expr sigma = Expr::Symbol("s");
  const std::vector<Expr> lambda = Expr::Symbols("l", 3);
  Expr lag = sigma * f;
  for (int i = 0; i < 3; ++i) lag = lag + lambda[i] * g[i];
  const Function lf("lag", {{"x", x}, {"p", p}, {"s", {sigma}}, {"l", lambda}}, {{"L", {lag}}});
  const Function grad = lf.Gradient("L", "x");
  const Function lh = lf.Hessian("L", "x");
  EXPECT_EQ(lower, lh.OutputSparsity(0).LowerTriangle());
  std::mt19937 rng = testing::SeededRng(kSeed);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<Eigen::VectorXd> point = {
        RandomVector(&rng, 4, -1, 1), RandomVector(&rng, 2, -1, 1), RandomVector(&rng, 1, 0.5, 2),
        RandomVector(&rng, 3, -2, 2)};
    const DerivativeCheckOptions options;
    Eigen::MatrixXd fd(4, 4);
    for (int j = 0; j < 4; ++j) {
      const double x0 = point[0][j];
      const double h = options.relative_step * std::max(1.0, std::fabs(x0));
      point[0][j] = x0 + h;
      const Eigen::VectorXd gp = grad(point)[0];
      point[0][j] = x0 - h;
      const Eigen::VectorXd gm = grad(point)[0];
      point[0][j] = x0;
      fd.col(j) = (gp - gm) / ((x0 + h) - (x0 - h));
    }
    const Eigen::MatrixXd analytic = Densify(lower, hl(point)[0]);
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j <= i; ++j) {
        EXPECT_LE(std::fabs(analytic(i, j) - fd(i, j)) / std::max(1.0, std::fabs(analytic(i, j))),
                  kFiniteDifferenceTol)
            << "(" << i << ", " << j << ") analytic " << analytic(i, j) << " fd " << fd(i, j);
      }
    }
    // And against the full Hessian of the reference Lagrangian: the same lower triangle.
    const Eigen::MatrixXd full = Densify(lh.OutputSparsity(0), lh(point)[0]);
    EXPECT_LE(RelError(Eigen::MatrixXd(analytic.triangularView<Eigen::Lower>()),
                       Eigen::MatrixXd(full.triangularView<Eigen::Lower>())),
              kModeAgreementTol);
  }
}

TEST(HessianOfLagrangian, WithoutConstraintsAndWithSigmaZero) {
  const std::vector<Expr> x = Expr::Symbols("x", 3);
  const Function fn("obj", {{"x", x}}, {{"f", {x[0] * x[1] * x[2] + square(x[0])}}});
  const Function hl = HessianOfLagrangian(fn, "x", "f", "");
  ASSERT_EQ(hl.NumInputs(), 3);
  EXPECT_EQ(hl.InputSize(2), 0);
  const Eigen::Vector3d pt(1.0, 2.0, 3.0);
  const Eigen::MatrixXd h2 = Densify(
      hl.OutputSparsity(0), hl({pt, Eigen::VectorXd::Constant(1, 2.0), Eigen::VectorXd()})[0]);
  Eigen::Matrix3d expected;  // 2 * lower triangle of [[2, z, y], [z, 0, x], [y, x, 0]]
  expected << 4, 0, 0, 6, 0, 0, 4, 2, 0;
  EXPECT_EQ(h2, Eigen::MatrixXd(expected));
  const Eigen::MatrixXd h0 =
      Densify(hl.OutputSparsity(0), hl({pt, Eigen::VectorXd::Zero(1), Eigen::VectorXd()})[0]);
  EXPECT_TRUE(h0.isZero(0.0));
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        const Function two("two", {{"x", x}}, {{"f", {x[0], x[1]}}});
        HessianOfLagrangian(two, "x", "f", "");
      },
      {"expected objective 'f' with 1 entry, got 2"});
}

// ---- higher order ----------------------------------------------------------------------------

TEST(HigherOrder, JacobianOfJacobianToThirdOrder) {
  const std::vector<Expr> x = Expr::Symbols("x", 3);
  const std::vector<Expr> y = {sin(x[0] * x[1]) + pow(x[2], 3.0) * exp(x[0]),
                               x[1] * square(x[2]) / (1.0 + x[0] * x[0])};
  const Function f("f", {{"x", x}}, {{"y", y}});
  const Function j1 = f.Jacobian("y", "x");
  const Function j2 = j1.Jacobian(j1.OutputName(0), "x");
  const Function j3 = j2.Jacobian(j2.OutputName(0), "x");
  std::mt19937 rng = testing::SeededRng(kSeed);
  DerivativeCheckOptions fd;
  fd.tolerance = kFiniteDifferenceTol;
  for (int trial = 0; trial < 4; ++trial) {
    const std::vector<Eigen::VectorXd> point = {RandomVector(&rng, 3, -1.2, 1.2)};
    // Second derivatives against differences of the first, third against the second.
    const DerivativeCheckResult r2 = CheckJacobian(j1, j1.OutputName(0), "x", point, fd);
    EXPECT_TRUE(r2.ok) << r2.FullReport();
    const DerivativeCheckResult r3 = CheckJacobian(j2, j2.OutputName(0), "x", point, fd);
    EXPECT_TRUE(r3.ok) << r3.FullReport();
    // d^3 y0 / dx2^3 = 6 exp(x0): locate it through the nested patterns.
    const Sparsity& s1 = j1.OutputSparsity(0);
    const Sparsity& s2 = j2.OutputSparsity(0);
    const Sparsity& s3 = j3.OutputSparsity(0);
    const int k1 = s1.Find(0, 2);
    ASSERT_GE(k1, 0);
    const int k2 = s2.Find(k1, 2);
    ASSERT_GE(k2, 0);
    const int k3 = s3.Find(k2, 2);
    ASSERT_GE(k3, 0);
    const double third = j3(point)[0][k3];
    EXPECT_LE(std::fabs(third - 6.0 * std::exp(point[0][0])) / (6.0 * std::exp(point[0][0])),
              kModeAgreementTol);
  }
}

}  // namespace
}  // namespace graybox::expr
