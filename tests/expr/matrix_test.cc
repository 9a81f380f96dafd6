// Eigen::Matrix<Expr> arithmetic and the symbolic dense solves SolveSpd / SolveLu: values
// against Eigen's double solvers, derivatives against central differences, structural zeros and
// size errors.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <string>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::ExpectThrowsWith;

constexpr std::uint32_t kSeed = 777;
// Products and sums of a few terms: only the summation order may differ from Eigen's kernels
// (scaled by the number of terms for longer sums).
constexpr double kArithmeticRelTol = 1e-14;
// Backward-stable factorizations of well-conditioned matrices (condition number < 100 by
// construction): forward error ~ cond * eps ~ 1e-14; 1e-11 leaves margin for n up to 8.
constexpr double kSolveRelTol = 1e-11;
// Central differences with the checker's default step are accurate to ~1e-10 (derivative_check.h).
constexpr double kFiniteDifferenceTol = 1e-6;

double RelError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

// A matrix of n x m new symbols named name_i_j.
ExprMatrix SymbolMatrix(const std::string& name, int n, int m) {
  ExprMatrix s(n, m);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      s(i, j) = Expr::Symbol(name + "_" + std::to_string(i) + "_" + std::to_string(j));
    }
  }
  return s;
}

std::vector<Expr> Flatten(const ExprMatrix& m) {
  return std::vector<Expr>(m.data(), m.data() + m.size());  // column-major, like Eigen
}

Eigen::VectorXd FlattenValues(const Eigen::MatrixXd& m) {
  return Eigen::Map<const Eigen::VectorXd>(m.data(), m.size());
}

Eigen::MatrixXd RandomMatrix(std::mt19937* rng, int n, int m) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd a(n, m);
  for (int j = 0; j < m; ++j) {
    for (int i = 0; i < n; ++i) a(i, j) = u(*rng);
  }
  return a;
}

// B B^T + n I: symmetric positive definite with eigenvalues in [n, n + |B|^2].
Eigen::MatrixXd RandomSpd(std::mt19937* rng, int n) {
  const Eigen::MatrixXd b = RandomMatrix(rng, n, n);
  return b * b.transpose() + n * Eigen::MatrixXd::Identity(n, n);
}

// Strictly diagonally dominant, not symmetric: LU without pivoting is stable.
Eigen::MatrixXd RandomDominant(std::mt19937* rng, int n) {
  Eigen::MatrixXd a = RandomMatrix(rng, n, n);
  for (int i = 0; i < n; ++i) a(i, i) = (a(i, i) >= 0 ? 1.0 : -1.0) * (n + 1.0);
  return a;
}

TEST(ExprMatrix, ProductsSumsTransposesAndBlocks) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  const ExprMatrix a = SymbolMatrix("a", 3, 4);
  const ExprMatrix b = SymbolMatrix("b", 4, 2);
  const ExprVector v = SymbolVector("v", 4);
  const ExprMatrix prod = a * b;
  const ExprVector mv = a * v;
  const ExprMatrix sum = a + 2.0 * a - a.transpose().transpose();
  const ExprMatrix blk = a.block(1, 1, 2, 2) * Expr(0.5);
  const Expr dot = v.dot(v);
  const Function f("mat", {{"a", Flatten(a)}, {"b", Flatten(b)}, {"v", ToStdVector(v)}},
                   {{"prod", Flatten(prod)},
                    {"mv", ToStdVector(mv)},
                    {"sum", Flatten(sum)},
                    {"blk", Flatten(blk)},
                    {"dot", {dot}}});
  const Eigen::MatrixXd av = RandomMatrix(&rng, 3, 4), bv = RandomMatrix(&rng, 4, 2);
  const Eigen::VectorXd vv = RandomMatrix(&rng, 4, 1);
  const auto r = f({FlattenValues(av), FlattenValues(bv), vv});
  EXPECT_LE(RelError(Eigen::Map<const Eigen::MatrixXd>(r[0].data(), 3, 2), av * bv),
            kArithmeticRelTol);
  EXPECT_LE(RelError(r[1], av * vv), kArithmeticRelTol);
  EXPECT_LE(RelError(Eigen::Map<const Eigen::MatrixXd>(r[2].data(), 3, 4), 2.0 * av),
            kArithmeticRelTol);
  EXPECT_LE(
      RelError(Eigen::Map<const Eigen::MatrixXd>(r[3].data(), 2, 2), 0.5 * av.block(1, 1, 2, 2)),
      kArithmeticRelTol);
  EXPECT_LE(std::fabs(r[4][0] - vv.squaredNorm()) / vv.squaredNorm(), kArithmeticRelTol);
  // Conversions.
  EXPECT_EQ(ToStdVector(v).size(), 4u);
  EXPECT_TRUE(ToExprVector(ToStdVector(v))[2].IsSame(v[2]));
  EXPECT_EQ(v[3].Name(), "v_3");
  const ExprMatrix c = ToExprMatrix(av);
  EXPECT_TRUE(c(2, 3).IsConstant(av(2, 3)));
}

TEST(ExprMatrix, LargeDynamicProductsGoThroughEigenKernels) {
  // Large enough for Eigen's blocked GEMM and GEMV kernels rather than coefficient-wise products.
  constexpr int n = 24;
  std::mt19937 rng = testing::SeededRng(kSeed);
  const ExprMatrix a = SymbolMatrix("a", n, n);
  const ExprVector v = SymbolVector("v", n);
  const Eigen::MatrixXd c = RandomMatrix(&rng, n, n);
  const ExprMatrix ac = ToExprMatrix(c) * a;
  const ExprVector cv = ToExprMatrix(c) * v;
  const ExprVector atv = a.transpose() * v;
  const Function f("big", {{"a", Flatten(a)}, {"v", ToStdVector(v)}},
                   {{"ac", Flatten(ac)}, {"cv", ToStdVector(cv)}, {"atv", ToStdVector(atv)}});
  const Eigen::MatrixXd av = RandomMatrix(&rng, n, n);
  const Eigen::VectorXd vv = RandomMatrix(&rng, n, 1);
  const auto r = f({FlattenValues(av), vv});
  EXPECT_LE(RelError(Eigen::Map<const Eigen::MatrixXd>(r[0].data(), n, n), c * av),
            kArithmeticRelTol * n);
  EXPECT_LE(RelError(r[1], c * vv), kArithmeticRelTol * n);
  EXPECT_LE(RelError(r[2], av.transpose() * vv), kArithmeticRelTol * n);
  // Each entry of A^T v depends on one column of A and on all of v.
  EXPECT_EQ(f.JacobianSparsity("atv", "a").nnz(), n * n);
  EXPECT_EQ(f.JacobianSparsity("atv", "v").nnz(), n * n);
}

TEST(ExprMatrix, FixedSizeOperationsMatchDoubles) {
  // Eigen's fixed-size kernels (cross, norm, trace, determinant, inverse) instantiated on Expr.
  using M3 = Eigen::Matrix<Expr, 3, 3>;
  using V3 = Eigen::Matrix<Expr, 3, 1>;
  const ExprMatrix ms = SymbolMatrix("m", 3, 3);
  const M3 m = ms;
  const V3 a = SymbolVector("a", 3), b = SymbolVector("b", 3);
  const V3 cross = a.cross(b);
  const M3 inv = (m + 4.0 * M3::Identity()).inverse();
  const Function f("fixed", {{"m", Flatten(ms)}, {"a", ToStdVector(a)}, {"b", ToStdVector(b)}},
                   {{"cross", ToStdVector(cross)},
                    {"scalars", {a.norm(), m.trace(), m.determinant(), a.dot(b), m.sum()}},
                    {"inv", Flatten(inv)}});
  std::mt19937 rng = testing::SeededRng(kSeed);
  const Eigen::Matrix3d mv = RandomMatrix(&rng, 3, 3);
  const Eigen::Vector3d av = RandomMatrix(&rng, 3, 1), bv = RandomMatrix(&rng, 3, 1);
  const auto r = f({FlattenValues(mv), av, bv});
  EXPECT_LE(RelError(r[0], av.cross(bv)), kArithmeticRelTol);
  const Eigen::VectorXd scalars =
      (Eigen::VectorXd(5) << av.norm(), mv.trace(), mv.determinant(), av.dot(bv), mv.sum())
          .finished();
  EXPECT_LE(RelError(r[1], scalars), kArithmeticRelTol);
  const Eigen::Matrix3d expected_inv = (mv + 4.0 * Eigen::Matrix3d::Identity()).inverse();
  EXPECT_LE(RelError(Eigen::Map<const Eigen::MatrixXd>(r[2].data(), 3, 3), expected_inv),
            kSolveRelTol);
}

TEST(ExprMatrix, StructuralZerosFoldAway) {
  // A diagonal matrix times a vector: only n products, no additions of zero terms.
  constexpr int n = 6;
  ExprMatrix d = ExprMatrix::Constant(n, n, Expr(0.0));
  const ExprVector s = SymbolVector("s", n), v = SymbolVector("v", n);
  for (int i = 0; i < n; ++i) d(i, i) = s[i];
  const ExprVector y = d * v;
  for (int i = 0; i < n; ++i) EXPECT_TRUE(y[i].IsSame(s[i] * v[i])) << y[i];
}

class SolveTest : public ::testing::TestWithParam<int> {};

TEST_P(SolveTest, SpdMatchesEigenAndReadsOnlyTheLowerTriangle) {
  const int n = GetParam();
  std::mt19937 rng = testing::SeededRng(kSeed + n);
  const ExprMatrix a = SymbolMatrix("a", n, n);
  const ExprMatrix b = SymbolMatrix("b", n, 2);
  const ExprMatrix x = SolveSpd(a, b);
  ASSERT_EQ(x.rows(), n);
  ASSERT_EQ(x.cols(), 2);
  // Only the lower triangle of A is read: the upper symbols must not occur.
  const auto used = FreeSymbols(Flatten(x));
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (const Expr& u : used) EXPECT_FALSE(u.IsSame(a(i, j))) << i << "," << j;
    }
  }
  const Function f("spd", {{"a", Flatten(a)}, {"b", Flatten(b)}}, {{"x", Flatten(x)}});
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::MatrixXd av = RandomSpd(&rng, n);
    const Eigen::MatrixXd bv = RandomMatrix(&rng, n, 2);
    const Eigen::MatrixXd expected = av.llt().solve(bv);
    const Eigen::VectorXd got = f({FlattenValues(av), FlattenValues(bv)})[0];
    EXPECT_LE(RelError(Eigen::Map<const Eigen::MatrixXd>(got.data(), n, 2), expected),
              kSolveRelTol);
    // Garbage in the upper triangle changes nothing.
    Eigen::MatrixXd garbage = av;
    garbage.triangularView<Eigen::StrictlyUpper>().setConstant(1e3);
    EXPECT_EQ(f({FlattenValues(garbage), FlattenValues(bv)})[0], got);
  }
}

TEST_P(SolveTest, LuMatchesEigenOnDiagonallyDominantMatrices) {
  const int n = GetParam();
  std::mt19937 rng = testing::SeededRng(kSeed + 100 + n);
  const ExprMatrix a = SymbolMatrix("a", n, n);
  const ExprMatrix b = SymbolMatrix("b", n, 1);
  const Function f("lu", {{"a", Flatten(a)}, {"b", Flatten(b)}}, {{"x", Flatten(SolveLu(a, b))}});
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::MatrixXd av = RandomDominant(&rng, n);
    const Eigen::VectorXd bv = RandomMatrix(&rng, n, 1);
    const Eigen::VectorXd expected = av.partialPivLu().solve(bv);
    EXPECT_LE(RelError(f({FlattenValues(av), bv})[0], expected), kSolveRelTol);
  }
}

TEST_P(SolveTest, SolveDerivativesMatchFiniteDifferences) {
  const int n = GetParam();
  std::mt19937 rng = testing::SeededRng(kSeed + 200 + n);
  // A(q) = A0 + diag(q^2) + q_0 * E with symmetric E, so A stays SPD near the sample point.
  const ExprVector q = SymbolVector("q", n);
  const Eigen::MatrixXd a0 = RandomSpd(&rng, n);
  const Eigen::MatrixXd g = RandomMatrix(&rng, n, n);
  const Eigen::MatrixXd e = 0.1 * (g + g.transpose());
  ExprMatrix a = ToExprMatrix(a0) + q[0] * ToExprMatrix(e);
  for (int i = 0; i < n; ++i) a(i, i) = a(i, i) + q[i] * q[i];
  const ExprVector rhs = SymbolVector("r", n);
  const ExprMatrix x_spd = SolveSpd(a, rhs);
  const ExprMatrix x_lu = SolveLu(a, rhs);
  const Function f("solve", {{"q", ToStdVector(q)}, {"r", ToStdVector(rhs)}},
                   {{"spd", Flatten(x_spd)}, {"lu", Flatten(x_lu)}});
  DerivativeCheckOptions fd;
  fd.tolerance = kFiniteDifferenceTol;
  const std::vector<Eigen::VectorXd> point = {RandomMatrix(&rng, n, 1), RandomMatrix(&rng, n, 1)};
  for (const char* out : {"spd", "lu"}) {
    for (const char* in : {"q", "r"}) {
      const DerivativeCheckResult r = CheckJacobian(f, out, in, point, fd);
      EXPECT_TRUE(r.ok) << r.FullReport();
    }
  }
  // d x / d r = A^-1 exactly.
  Eigen::MatrixXd a_val = a0 + point[0][0] * e;
  for (int i = 0; i < n; ++i) a_val(i, i) += point[0][i] * point[0][i];
  const Function jac = f.Jacobian("spd", "r");
  const Eigen::MatrixXd dxdr = testing::Densify(jac.OutputSparsity(0), jac(point)[0]);
  EXPECT_LE(RelError(dxdr, a_val.inverse()), kSolveRelTol);
}

INSTANTIATE_TEST_SUITE_P(Sizes, SolveTest, ::testing::Values(1, 2, 5, 8));

TEST(Solve, BlockDiagonalSystemsStayDecoupled) {
  // Two decoupled 2x2 blocks: x of one block must not depend on the other block's data.
  const ExprMatrix blocks = SymbolMatrix("a", 4, 4);
  ExprMatrix a = ExprMatrix::Constant(4, 4, Expr(0.0));
  a.block(0, 0, 2, 2) = blocks.block(0, 0, 2, 2);
  a.block(2, 2, 2, 2) = blocks.block(2, 2, 2, 2);
  const ExprVector r = SymbolVector("r", 4);
  for (const ExprMatrix& x : {SolveSpd(a, r), SolveLu(a, r)}) {
    const Function f("f", {{"a", FreeSymbols(Flatten(a))}, {"r", ToStdVector(r)}},
                     {{"x", Flatten(x)}});
    const Sparsity sp = f.JacobianSparsity("x", "r");
    EXPECT_EQ(sp, Sparsity::FromTriplets(
                      4, 4, {{0, 0}, {0, 1}, {1, 0}, {1, 1}, {2, 2}, {2, 3}, {3, 2}, {3, 3}}))
        << sp.ToString();
  }
}

TEST(Solve, SizeMismatchesThrow) {
  const ExprMatrix a = SymbolMatrix("a", 3, 3);
  ExpectThrowsWith<std::invalid_argument>([&] { SolveSpd(SymbolMatrix("n", 2, 3), a); },
                                          {"SolveSpd", "expected a square matrix, got 2x3"});
  ExpectThrowsWith<std::invalid_argument>([&] { SolveLu(SymbolMatrix("n", 3, 2), a); },
                                          {"SolveLu", "expected a square matrix, got 3x2"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] { SolveSpd(a, SymbolMatrix("b", 2, 1)); },
      {"SolveSpd", "expected a right-hand side with 3 rows, got 2"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] { SolveLu(a, SymbolMatrix("b", 4, 2)); },
      {"SolveLu", "expected a right-hand side with 3 rows, got 4"});
}

TEST(Solve, SingularPivotIsReportedAsNonFinite) {
  // LU without pivoting fails on a zero leading minor; evaluation reports it instead of hiding it.
  const ExprMatrix a = SymbolMatrix("a", 2, 2);
  const ExprVector r = SymbolVector("r", 2);
  const Function f("lu", {{"a", Flatten(a)}, {"r", ToStdVector(r)}},
                   {{"x", Flatten(SolveLu(a, r))}});
  Eigen::Matrix2d av;
  av << 0.0, 1.0, 1.0, 0.0;  // a permutation: nonsingular, but a_00 = 0
  EXPECT_THROW(f({FlattenValues(av), Eigen::Vector2d(1, 2)}), NonFiniteError);
}

}  // namespace
}  // namespace graybox::expr
