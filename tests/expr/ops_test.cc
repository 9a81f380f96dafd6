// Every operation of the op table: value against the std:: closed form, first derivatives
// against hand-written closed forms and central differences, second derivatives against
// central differences, the documented conventions at non-smooth points, the smooth variants and
// overflow-free sigmoid/softplus.
//
// The tests loop over the table (AllOperations), so a new operation without a reference in
// Reference() fails to compile (-Wswitch) or, without -Werror, fails at run time.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::AllOperations;
using testing::ExpectThrowsWith;

constexpr std::uint32_t kSeed = 20240611;
constexpr int kPointsPerOp = 6;
// Reference formulas of sigmoid/softplus/tan'/tanh' differ from the library's by a few roundings,
// amplified at most ~100x by cancellation in 1 - tanh^2 on the sampled domain.
constexpr double kClosedFormRelTol = 1e-13;
// Central differences are accurate to ~1e-10 here (derivative_check.h); 1e-6 is the checker's
// documented default and still catches any wrong partial.
constexpr double kFiniteDifferenceTol = 1e-6;

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

// |a - b| <= tol * max(1, |b|), with NaN equal to NaN and infinities compared exactly.
bool Close(double a, double b, double tol) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (std::isinf(a) || std::isinf(b)) return a == b;
  return std::fabs(a - b) <= tol * std::max(1.0, std::fabs(b));
}

// One argument's sampling domain. `differentiable` arguments go into the input "x" that is
// checked against finite differences; the others (the if_else condition, sampled among values
// including 0) go into "p".
struct ArgSpec {
  double lo;
  double hi;
  bool either_sign;              // sample +-[lo, hi]
  std::vector<double> discrete;  // when nonempty, pick one of these instead
  bool differentiable = true;

  double Sample(std::mt19937* rng) const {
    if (!discrete.empty()) {
      const int last = static_cast<int>(discrete.size()) - 1;
      return discrete[std::uniform_int_distribution<int>(0, last)(*rng)];
    }
    double v = std::uniform_real_distribution<double>(lo, hi)(*rng);
    if (either_sign && std::uniform_int_distribution<int>(0, 1)(*rng) == 1) v = -v;
    return v;
  }
};

ArgSpec Uniform(double lo, double hi) { return {lo, hi, false, {}}; }
ArgSpec Magnitude(double lo, double hi) { return {lo, hi, true, {}}; }
ArgSpec Condition() { return {0, 0, false, {0.0, 1.0, -2.5}, false}; }

using Values = std::vector<double>;

struct OpReference {
  std::vector<ArgSpec> domain;
  // The value by the std:: closed form.
  std::function<double(const Values&)> value;
  // The first partials, hand-written.
  std::function<Values(const Values&)> partials;
  // Extra points where only the value is checked (ties, zeros, NaN, infinities).
  std::vector<Values> special_points;
};

double Sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

std::optional<OpReference> Reference(Op op) {
  const ArgSpec any = Uniform(-2.0, 2.0);
  switch (op) {
    case Op::kConstant:
    case Op::kSymbol:
      return std::nullopt;
    case Op::kAdd:
      return OpReference{{any, any},
                         [](const Values& a) { return a[0] + a[1]; },
                         [](const Values&) {
                           return Values{1.0, 1.0};
                         },
                         {{kInf, -kInf}, {1e308, 1e308}}};
    case Op::kSub:
      return OpReference{{any, any},
                         [](const Values& a) { return a[0] - a[1]; },
                         [](const Values&) {
                           return Values{1.0, -1.0};
                         },
                         {{kInf, kInf}}};
    case Op::kMul:
      return OpReference{{any, any},
                         [](const Values& a) { return a[0] * a[1]; },
                         [](const Values& a) {
                           return Values{a[1], a[0]};
                         },
                         {{kInf, 0.0}, {kNaN, 0.0}}};
    case Op::kDiv:
      return OpReference{{any, Magnitude(0.3, 3.0)},
                         [](const Values& a) { return a[0] / a[1]; },
                         [](const Values& a) {
                           return Values{1.0 / a[1], -a[0] / (a[1] * a[1])};
                         },
                         {{1.0, 0.0}, {0.0, 0.0}}};
    case Op::kNeg:
      return OpReference{{any},
                         [](const Values& a) { return -a[0]; },
                         [](const Values&) { return Values{-1.0}; },
                         {{0.0}}};
    case Op::kPow:
      return OpReference{
          {Uniform(0.2, 3.0), any},
          [](const Values& a) { return std::pow(a[0], a[1]); },
          [](const Values& a) {
            return Values{a[1] * std::pow(a[0], a[1] - 1.0), std::log(a[0]) * std::pow(a[0], a[1])};
          },
          {{-2.0, 3.0}, {0.0, 0.0}, {-8.0, 1.0 / 3.0}, {0.0, -1.0}}};
    case Op::kSqrt:
      return OpReference{{Uniform(0.1, 3.0)},
                         [](const Values& a) { return std::sqrt(a[0]); },
                         [](const Values& a) { return Values{0.5 / std::sqrt(a[0])}; },
                         {{0.0}, {-1.0}, {kInf}}};
    case Op::kExp:
      return OpReference{{any},
                         [](const Values& a) { return std::exp(a[0]); },
                         [](const Values& a) { return Values{std::exp(a[0])}; },
                         {{800.0}, {-800.0}}};
    case Op::kLog:
      return OpReference{{Uniform(0.1, 3.0)},
                         [](const Values& a) { return std::log(a[0]); },
                         [](const Values& a) { return Values{1.0 / a[0]}; },
                         {{0.0}, {-1.0}}};
    case Op::kSin:
      return OpReference{{any},
                         [](const Values& a) { return std::sin(a[0]); },
                         [](const Values& a) { return Values{std::cos(a[0])}; },
                         {{0.0}}};
    case Op::kCos:
      return OpReference{{any},
                         [](const Values& a) { return std::cos(a[0]); },
                         [](const Values& a) { return Values{-std::sin(a[0])}; },
                         {{0.0}}};
    case Op::kTan:
      return OpReference{{Uniform(-1.2, 1.2)},
                         [](const Values& a) { return std::tan(a[0]); },
                         [](const Values& a) {
                           const double c = std::cos(a[0]);
                           return Values{1.0 / (c * c)};
                         },
                         {{0.0}}};
    case Op::kAtan:
      return OpReference{{Uniform(-3.0, 3.0)},
                         [](const Values& a) { return std::atan(a[0]); },
                         [](const Values& a) { return Values{1.0 / (1.0 + a[0] * a[0])}; },
                         {{kInf}}};
    case Op::kAtan2:
      // |y| >= 0.2 keeps the samples away from the branch cut on the negative x axis.
      return OpReference{{Magnitude(0.2, 2.0), Magnitude(0.2, 2.0)},
                         [](const Values& a) { return std::atan2(a[0], a[1]); },
                         [](const Values& a) {
                           const double r2 = a[0] * a[0] + a[1] * a[1];
                           return Values{a[1] / r2, -a[0] / r2};
                         },
                         {{0.0, -1.0}, {-1.0, -1.0}, {1.0, 0.0}, {0.0, 0.0}}};
    case Op::kTanh:
      return OpReference{{Uniform(-3.0, 3.0)},
                         [](const Values& a) { return std::tanh(a[0]); },
                         [](const Values& a) {
                           const double c = std::cosh(a[0]);
                           return Values{1.0 / (c * c)};
                         },
                         {{40.0}, {-40.0}}};
    case Op::kSigmoid:
      return OpReference{
          {Uniform(-5.0, 5.0)},
          [](const Values& a) { return Sigmoid(a[0]); },
          [](const Values& a) { return Values{Sigmoid(a[0]) * (1.0 - Sigmoid(a[0]))}; },
          {{0.0}, {-30.0}, {30.0}}};
    case Op::kSoftplus:
      return OpReference{{Uniform(-5.0, 5.0)},
                         [](const Values& a) { return std::log1p(std::exp(a[0])); },
                         [](const Values& a) { return Values{Sigmoid(a[0])}; },
                         {{0.0}, {-30.0}, {30.0}}};
    case Op::kAbs:
      return OpReference{{Magnitude(0.1, 2.0)},
                         [](const Values& a) { return std::fabs(a[0]); },
                         [](const Values& a) { return Values{a[0] > 0 ? 1.0 : -1.0}; },
                         {{0.0}, {-kInf}}};
    case Op::kSign:
      return OpReference{
          {Magnitude(0.1, 2.0)},
          [](const Values& a) { return std::isnan(a[0]) ? a[0] : (a[0] > 0) - (a[0] < 0) + 0.0; },
          [](const Values&) { return Values{0.0}; },
          {{0.0}, {kNaN}, {-kInf}}};
    case Op::kMin:
      return OpReference{{any, any},
                         [](const Values& a) {
                           return std::isnan(a[0]) || std::isnan(a[1]) ? kNaN
                                                                       : std::min(a[0], a[1]);
                         },
                         [](const Values& a) {
                           return a[0] <= a[1] ? Values{1.0, 0.0} : Values{0.0, 1.0};
                         },
                         {{1.0, 1.0}, {kNaN, 1.0}, {1.0, kNaN}, {-kInf, 3.0}}};
    case Op::kMax:
      return OpReference{{any, any},
                         [](const Values& a) {
                           return std::isnan(a[0]) || std::isnan(a[1]) ? kNaN
                                                                       : std::max(a[0], a[1]);
                         },
                         [](const Values& a) {
                           return a[0] >= a[1] ? Values{1.0, 0.0} : Values{0.0, 1.0};
                         },
                         {{1.0, 1.0}, {kNaN, 1.0}, {1.0, kNaN}, {kInf, 3.0}}};
    case Op::kErf:
      return OpReference{
          {Uniform(-3.0, 3.0)},
          [](const Values& a) { return std::erf(a[0]); },
          [](const Values& a) { return Values{2.0 / std::sqrt(M_PI) * std::exp(-a[0] * a[0])}; },
          {{0.0}, {kInf}}};
    case Op::kLt:
      return OpReference{{any, any},
                         [](const Values& a) { return a[0] < a[1] ? 1.0 : 0.0; },
                         [](const Values&) {
                           return Values{0.0, 0.0};
                         },
                         {{1.0, 1.0}, {kNaN, 1.0}}};
    case Op::kLe:
      return OpReference{{any, any},
                         [](const Values& a) { return a[0] <= a[1] ? 1.0 : 0.0; },
                         [](const Values&) {
                           return Values{0.0, 0.0};
                         },
                         {{1.0, 1.0}, {kNaN, 1.0}}};
    case Op::kEq:
      return OpReference{{any, any},
                         [](const Values& a) { return a[0] == a[1] ? 1.0 : 0.0; },
                         [](const Values&) {
                           return Values{0.0, 0.0};
                         },
                         {{1.0, 1.0}, {kNaN, kNaN}, {0.0, -0.0}}};
    case Op::kNe:
      return OpReference{{any, any},
                         [](const Values& a) { return a[0] != a[1] ? 1.0 : 0.0; },
                         [](const Values&) {
                           return Values{0.0, 0.0};
                         },
                         {{1.0, 1.0}, {kNaN, kNaN}}};
    case Op::kAnd:
      return OpReference{{Magnitude(0.5, 2.0), Magnitude(0.5, 2.0)},
                         [](const Values& a) { return a[0] != 0.0 && a[1] != 0.0 ? 1.0 : 0.0; },
                         [](const Values&) {
                           return Values{0.0, 0.0};
                         },
                         {{0.0, 1.0}, {1.0, 0.0}, {0.0, 0.0}, {kNaN, 2.0}}};
    case Op::kOr:
      return OpReference{{Magnitude(0.5, 2.0), Magnitude(0.5, 2.0)},
                         [](const Values& a) { return a[0] != 0.0 || a[1] != 0.0 ? 1.0 : 0.0; },
                         [](const Values&) {
                           return Values{0.0, 0.0};
                         },
                         {{0.0, 1.0}, {1.0, 0.0}, {0.0, 0.0}}};
    case Op::kNot:
      return OpReference{{Magnitude(0.5, 2.0)},
                         [](const Values& a) { return a[0] == 0.0 ? 1.0 : 0.0; },
                         [](const Values&) { return Values{0.0}; },
                         {{0.0}, {kNaN}}};
    case Op::kIfElse:
      return OpReference{{Condition(), any, any},
                         [](const Values& a) { return a[0] != 0.0 ? a[1] : a[2]; },
                         [](const Values& a) {
                           return Values{0.0, a[0] != 0.0 ? 1.0 : 0.0, a[0] != 0.0 ? 0.0 : 1.0};
                         },
                         {{0.0, 1.0, 2.0}, {kNaN, 1.0, 2.0}, {1.0, kNaN, 2.0}}};
  }
  return std::nullopt;
}

// A Function of one operation: input "x" holds the differentiable arguments, "p" the others;
// output "f" = op(args). `args` maps each argument to its symbol.
struct OpFunction {
  Function f;
  std::vector<Expr> args;
  std::vector<int> slot;  // argument k is entry slot[k] of x (differentiable) or of p
  std::vector<bool> in_x;

  std::vector<Eigen::VectorXd> Point(const Values& a) const {
    int nx = 0, np = 0;
    for (bool b : in_x) (b ? nx : np)++;
    Eigen::VectorXd x(nx), p(np);
    for (std::size_t k = 0; k < a.size(); ++k) (in_x[k] ? x : p)[slot[k]] = a[k];
    return {x, p};
  }
};

OpFunction MakeOpFunction(Op op, const OpReference& ref) {
  OpFunction of;
  std::vector<Expr> xs, ps;
  for (int k = 0; k < Arity(op); ++k) {
    const Expr s = Expr::Symbol("a" + std::to_string(k));
    of.args.push_back(s);
    of.in_x.push_back(ref.domain[k].differentiable);
    auto& list = ref.domain[k].differentiable ? xs : ps;
    of.slot.push_back(static_cast<int>(list.size()));
    list.push_back(s);
  }
  of.f = Function(OpName(op), {{"x", xs}, {"p", ps}}, {{"f", {Expr::Make(op, of.args)}}});
  return of;
}

Values SamplePoint(const OpReference& ref, std::mt19937* rng) {
  Values a;
  for (const ArgSpec& d : ref.domain) a.push_back(d.Sample(rng));
  return a;
}

TEST(OpTable, EveryOperationHasAReference) {
  for (Op op : AllOperations()) {
    const auto ref = Reference(op);
    ASSERT_TRUE(ref.has_value()) << "add a reference for '" << OpName(op) << "' to Reference()";
    EXPECT_EQ(static_cast<int>(ref->domain.size()), Arity(op)) << OpName(op);
  }
}

TEST(OpTable, NamesAreUniqueAndMakeBuildsTheOperation) {
  std::set<std::string> names;
  for (int k = 0; k < kNumOps; ++k) {
    EXPECT_TRUE(names.insert(OpName(static_cast<Op>(k))).second) << OpName(static_cast<Op>(k));
  }
  EXPECT_EQ(Arity(Op::kConstant), 0);
  EXPECT_EQ(Arity(Op::kSymbol), 0);
  for (Op op : AllOperations()) {
    SCOPED_TRACE(OpName(op));
    ASSERT_GE(Arity(op), 1);
    ASSERT_LE(Arity(op), 3);
    const std::vector<Expr> args = Expr::Symbols("s", Arity(op));
    const Expr e = Expr::Make(op, args);
    EXPECT_EQ(e.op(), op);
    EXPECT_EQ(e.NumArgs(), Arity(op));
    // Building the same operation twice gives the same node (structural hashing).
    EXPECT_TRUE(e.IsSame(Expr::Make(op, args)));
    std::vector<Expr> too_many = args;
    too_many.push_back(Expr::Symbol("extra"));
    ExpectThrowsWith<std::invalid_argument>([&] { Expr::Make(op, too_many); },
                                            {"expected " + std::to_string(Arity(op)) + " arguments",
                                             "got " + std::to_string(Arity(op) + 1)});
  }
  ExpectThrowsWith<std::invalid_argument>([] { Expr::Make(Op::kConstant, {}); }, {"expected"});
  ExpectThrowsWith<std::invalid_argument>([] { Expr::Make(Op::kSymbol, {}); }, {"expected"});
  EXPECT_THROW(EvaluateOp(Op::kConstant, nullptr), std::logic_error);
}

TEST(OpTable, CommutativeOperationsShareNodesAndValues) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  const Expr a = Expr::Symbol("a"), b = Expr::Symbol("b");
  for (Op op : AllOperations()) {
    if (Arity(op) != 2) {
      EXPECT_FALSE(IsCommutative(op)) << OpName(op);
      continue;
    }
    SCOPED_TRACE(OpName(op));
    const bool same = Expr::Make(op, {a, b}).IsSame(Expr::Make(op, {b, a}));
    EXPECT_EQ(same, IsCommutative(op));
    if (!IsCommutative(op)) continue;
    // A commutative operation must be symmetric in value and in its derivative conventions,
    // or merging a op b with b op a would change results.
    for (int k = 0; k < kPointsPerOp; ++k) {
      const double v[2] = {std::uniform_real_distribution<double>(-2, 2)(rng),
                           std::uniform_real_distribution<double>(-2, 2)(rng)};
      const double w[2] = {v[1], v[0]};
      EXPECT_EQ(EvaluateOp(op, v), EvaluateOp(op, w));
    }
  }
}

TEST(OpValues, MatchStdClosedFormInFoldingAndTape) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  for (Op op : AllOperations()) {
    const auto ref = Reference(op);
    ASSERT_TRUE(ref.has_value()) << OpName(op);
    SCOPED_TRACE(OpName(op));
    const OpFunction of = MakeOpFunction(op, *ref);
    std::vector<Values> points = ref->special_points;
    for (int k = 0; k < kPointsPerOp; ++k) points.push_back(SamplePoint(*ref, &rng));
    for (const Values& a : points) {
      ASSERT_EQ(static_cast<int>(a.size()), Arity(op));
      ::testing::Message where;
      for (double v : a) where << v << " ";
      SCOPED_TRACE(where);
      const double expected = ref->value(a);
      const double table = EvaluateOp(op, a.data());
      EXPECT_TRUE(Close(table, expected, kClosedFormRelTol)) << table << " vs " << expected;
      // Constant folding goes through the same definition: bitwise equal.
      std::vector<Expr> constants(a.begin(), a.end());
      const Expr folded = Expr::Make(op, constants);
      ASSERT_TRUE(folded.IsConstant());
      EXPECT_TRUE(Close(folded.Value(), table, 0.0)) << folded.Value() << " vs " << table;
      // So does the tape (non-finite results are reported, not thrown, by Evaluate).
      const auto point = of.Point(a);
      double out = 0.0;
      double* outs[] = {&out};
      const double* ins[] = {point[0].data(), point[1].data()};
      Workspace ws = of.f.MakeWorkspace();
      const EvalStatus status = of.f.Evaluate(ins, outs, &ws);
      EXPECT_TRUE(Close(out, table, 0.0)) << out << " vs " << table;
      EXPECT_EQ(status.ok, std::isfinite(table));
    }
  }
}

TEST(OpDerivatives, MatchHandWrittenPartials) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  for (Op op : AllOperations()) {
    const auto ref = Reference(op);
    ASSERT_TRUE(ref.has_value()) << OpName(op);
    SCOPED_TRACE(OpName(op));
    const OpFunction of = MakeOpFunction(op, *ref);
    const Function gx = of.f.Gradient("f", "x");
    const Function gp = of.f.Gradient("f", "p");
    for (int k = 0; k < kPointsPerOp; ++k) {
      const Values a = SamplePoint(*ref, &rng);
      const Values expected = ref->partials(a);
      const auto point = of.Point(a);
      const Eigen::VectorXd dx = gx(point)[0];
      const Eigen::VectorXd dp = gp(point)[0];
      for (int i = 0; i < Arity(op); ++i) {
        const double actual = of.in_x[i] ? dx[of.slot[i]] : dp[of.slot[i]];
        EXPECT_TRUE(Close(actual, expected[i], kClosedFormRelTol))
            << "d/da" << i << " at point " << k << ": " << actual << " vs " << expected[i];
      }
    }
  }
}

TEST(OpDerivatives, JacobianMatchesCentralDifferences) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  DerivativeCheckOptions options;
  options.tolerance = kFiniteDifferenceTol;
  for (Op op : AllOperations()) {
    const auto ref = Reference(op);
    ASSERT_TRUE(ref.has_value()) << OpName(op);
    SCOPED_TRACE(OpName(op));
    const OpFunction of = MakeOpFunction(op, *ref);
    ASSERT_GT(of.f.InputSize(0), 0) << "every operation has a differentiable argument";
    for (int k = 0; k < kPointsPerOp; ++k) {
      const auto point = of.Point(SamplePoint(*ref, &rng));
      const DerivativeCheckResult r = CheckJacobian(of.f, "f", "x", point, options);
      EXPECT_TRUE(r.ok) << r.FullReport();
      EXPECT_EQ(r.entries_checked, of.f.InputSize(0));
    }
  }
}

TEST(OpDerivatives, HessianMatchesCentralDifferences) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  DerivativeCheckOptions options;
  options.tolerance = kFiniteDifferenceTol;
  for (Op op : AllOperations()) {
    const auto ref = Reference(op);
    ASSERT_TRUE(ref.has_value()) << OpName(op);
    SCOPED_TRACE(OpName(op));
    const OpFunction of = MakeOpFunction(op, *ref);
    for (int k = 0; k < kPointsPerOp; ++k) {
      const auto point = of.Point(SamplePoint(*ref, &rng));
      const DerivativeCheckResult r = CheckHessian(of.f, "f", "x", point, options);
      EXPECT_TRUE(r.ok) << r.FullReport();
    }
  }
}

TEST(OpDerivatives, ZeroDerivativeOperationsHaveEmptyJacobianPattern) {
  for (Op op : {Op::kLt, Op::kLe, Op::kEq, Op::kNe, Op::kAnd, Op::kOr, Op::kNot, Op::kSign}) {
    const std::vector<Expr> s = Expr::Symbols("s", Arity(op));
    const Function f("f", {{"x", s}}, {{"y", {Expr::Make(op, s)}}});
    EXPECT_EQ(f.JacobianSparsity("y", "x").nnz(), 0) << OpName(op);
  }
  // if_else depends structurally on its branches only.
  const std::vector<Expr> s = Expr::Symbols("s", 3);
  const Function f("f", {{"x", s}}, {{"y", {if_else(s[0], s[1], s[2])}}});
  EXPECT_EQ(f.JacobianSparsity("y", "x"), Sparsity::FromTriplets(1, 3, {{0, 1}, {0, 2}}));
}

// ---- conventions at non-smooth points (ops.h) ---------------------------------------------

// Gradient of `e` with respect to `wrt` at `values` of `wrt`.
Eigen::VectorXd GradientAt(const Expr& e, const std::vector<Expr>& wrt, const Values& values) {
  const Function f("f", {{"x", wrt}}, {{"y", {e}}});
  return f.Gradient("y", "x")({Eigen::Map<const Eigen::VectorXd>(values.data(), values.size())})[0];
}

TEST(NonSmoothConventions, AbsHasZeroSlopeAtZero) {
  const Expr x = Expr::Symbol("x");
  EXPECT_EQ(GradientAt(abs(x), {x}, {0.0})[0], 0.0);
  EXPECT_EQ(GradientAt(abs(x), {x}, {-3.0})[0], -1.0);
  EXPECT_EQ(GradientAt(fabs(x), {x}, {2.0})[0], 1.0);
}

TEST(NonSmoothConventions, SignHasZeroDerivativeEverywhere) {
  const Expr x = Expr::Symbol("x");
  for (double v : {-1.0, 0.0, 2.0}) EXPECT_EQ(GradientAt(sign(x) * 3.0, {x}, {v})[0], 0.0);
}

TEST(NonSmoothConventions, MinAndMaxTiesGoToTheFirstArgument) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  // Both argument orders: the first argument as written gets the partial at a tie.
  for (const bool x_first : {true, false}) {
    SCOPED_TRACE(x_first ? "x first" : "y first");
    const Expr lo = x_first ? min(x, y) : min(y, x);
    const Expr hi = x_first ? max(x, y) : max(y, x);
    const Eigen::VectorXd expected = x_first ? Eigen::Vector2d(1, 0) : Eigen::Vector2d(0, 1);
    EXPECT_EQ(GradientAt(lo, {x, y}, {1.5, 1.5}), expected);
    EXPECT_EQ(GradientAt(hi, {x, y}, {1.5, 1.5}), expected);
  }
  // Away from ties the partial goes to the selected argument.
  EXPECT_EQ(GradientAt(min(x, y), {x, y}, {1.0, 2.0}), Eigen::Vector2d(1, 0));
  EXPECT_EQ(GradientAt(min(x, y), {x, y}, {3.0, 2.0}), Eigen::Vector2d(0, 1));
  EXPECT_EQ(GradientAt(max(x, y), {x, y}, {1.0, 2.0}), Eigen::Vector2d(0, 1));
  EXPECT_EQ(GradientAt(max(x, y), {x, y}, {3.0, 2.0}), Eigen::Vector2d(1, 0));
}

TEST(NonSmoothConventions, IfElseDifferentiatesTheTakenBranch) {
  const Expr c = Expr::Symbol("c"), x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const Expr e = if_else(c, x * x, 3.0 * y);
  EXPECT_EQ(GradientAt(e, {c, x, y}, {1.0, 2.0, 5.0}), Eigen::Vector3d(0, 4, 0));
  EXPECT_EQ(GradientAt(e, {c, x, y}, {0.0, 2.0, 5.0}), Eigen::Vector3d(0, 0, 3));
  // A condition computed from the arguments: |x| written with if_else.
  const Expr piecewise = if_else(lt(x, 0.0), -x, x);
  EXPECT_EQ(GradientAt(piecewise, {x}, {-2.0})[0], -1.0);
  EXPECT_EQ(GradientAt(piecewise, {x}, {2.0})[0], 1.0);
}

TEST(NonSmoothConventions, GuardedIfElseKeepsTheUntakenBranchFinite) {
  // The idiom documented in ops.h: guard the argument of a branch that is invalid where it is
  // not taken, so its partials stay finite there too.
  const Expr x = Expr::Symbol("x");
  const Expr positive = gt(x, 0.0);
  const Expr e = if_else(positive, sqrt(if_else(positive, x, 1.0)), 0.0);
  const Function f("f", {{"x", {x}}}, {{"y", {e}}});
  for (double v : {-1.0, 0.0, 4.0}) {
    SCOPED_TRACE(v);
    const std::vector<Eigen::VectorXd> point = {Eigen::VectorXd::Constant(1, v)};
    // operator() throws NonFiniteError on NaN, so these also assert finiteness.
    EXPECT_EQ(f.Gradient("y", "x")(point)[0][0], v > 0 ? 0.25 : 0.0);
    EXPECT_EQ(f.Hessian("y", "x")(point)[0][0], v > 0 ? -1.0 / 32.0 : 0.0);
    EXPECT_EQ(f.Forward(1)({point[0], Eigen::VectorXd::Ones(1)})[0][0], v > 0 ? 0.25 : 0.0);
  }
}

TEST(NonSmoothConventions, PowWithConstantExponentHasNoLogTerm) {
  // d/dy = log(x) x^y is only formed for a symbolic exponent, so a negative base is fine.
  const Expr x = Expr::Symbol("x");
  EXPECT_EQ(GradientAt(pow(x, 3.0), {x}, {-2.0})[0], 12.0);
  const Function f("f", {{"x", {x}}}, {{"y", {pow(x, 3.0)}}});
  EXPECT_EQ(f.Hessian("y", "x")({Eigen::VectorXd::Constant(1, -2.0)})[0][0], -12.0);
}

// ---- smooth variants ------------------------------------------------------------------------

// Exact identities of the closed forms below; only the rounding of a few operations.
constexpr double kSmoothRelTol = 1e-14;
// Slack for a documented inequality evaluated in floating point (a few roundings of O(1) values).
constexpr double kRoundingSlack = 8 * std::numeric_limits<double>::epsilon();

// The Expr functions on constant Expr arguments fold to a constant (the arguments are Exprs so
// that double overloads, if any, are not picked instead).
double Eval(const Expr& e) { return e.Value(); }

TEST(SmoothVariants, SmoothAbs) {
  const double w = 0.1;
  EXPECT_EQ(Eval(smooth_abs(Expr(0.0), Expr(w))), 0.0);
  for (double x : {-3.0, -0.5, 0.05, 2.0}) {
    const double v = Eval(smooth_abs(Expr(x), Expr(w)));
    EXPECT_TRUE(Close(v, std::sqrt(x * x + w * w) - w, kSmoothRelTol)) << x;
    EXPECT_LE(v, std::fabs(x));
    EXPECT_GE(v, std::fabs(x) - w);
    // Far from 0: |x| - w + O(w^2 / |x|).
    if (std::fabs(x) > 1.0) {
      EXPECT_LE(std::fabs(v - (std::fabs(x) - w)), w * w / std::fabs(x));
    }
  }
  // Approaches |x| as w -> 0 (|x| - w <= smooth_abs <= |x|).
  const double tiny = 1e-9;
  EXPECT_LE(std::fabs(Eval(smooth_abs(Expr(-0.7), Expr(tiny))) - 0.7), tiny + kRoundingSlack);
  // Smooth at 0: slope 0, curvature 1/w.
  const Expr x = Expr::Symbol("x");
  EXPECT_EQ(GradientAt(smooth_abs(x, w), {x}, {0.0})[0], 0.0);
  const Function f("f", {{"x", {x}}}, {{"y", {smooth_abs(x, w)}}});
  EXPECT_TRUE(Close(f.Hessian("y", "x")({Eigen::VectorXd::Zero(1)})[0][0], 1.0 / w, kSmoothRelTol));
}

TEST(SmoothVariants, SmoothSign) {
  const double w = 0.01;
  EXPECT_EQ(Eval(smooth_sign(Expr(0.0), Expr(w))), 0.0);
  EXPECT_TRUE(Close(Eval(smooth_sign(Expr(0.003), Expr(w))), std::tanh(0.3), kSmoothRelTol));
  // |tanh(x/w) - sign(x)| <= 2 exp(-2|x|/w): the limit w -> 0 is sign(x).
  for (double x : {-0.05, 0.02, 1.0}) {
    const double bound = 2.0 * std::exp(-2.0 * std::fabs(x) / w);
    EXPECT_LE(std::fabs(Eval(smooth_sign(Expr(x), Expr(w))) - (x > 0 ? 1.0 : -1.0)),
              bound + kRoundingSlack);
  }
  const Expr x = Expr::Symbol("x");
  EXPECT_TRUE(Close(GradientAt(smooth_sign(x, w), {x}, {0.0})[0], 1.0 / w, kSmoothRelTol));
}

TEST(SmoothVariants, SmoothMaxAndMinBracketTheExactFunctions) {
  const double w = 0.2;
  std::mt19937 rng = testing::SeededRng(kSeed);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int k = 0; k < 20; ++k) {
    const double a = u(rng), b = u(rng);
    const double smax = Eval(smooth_max(Expr(a), Expr(b), Expr(w)));
    const double smin = Eval(smooth_min(Expr(a), Expr(b), Expr(w)));
    EXPECT_GE(smax, std::max(a, b));
    EXPECT_LE(smax, std::max(a, b) + w / 2 + kRoundingSlack);
    EXPECT_LE(smin, std::min(a, b));
    EXPECT_GE(smin, std::min(a, b) - w / 2 - kRoundingSlack);
    // smooth_max + smooth_min = a + b in exact arithmetic.
    EXPECT_TRUE(Close(smax + smin, a + b, kSmoothRelTol));
  }
  // At a tie the gap is exactly w/2.
  EXPECT_TRUE(Close(Eval(smooth_max(Expr(1.0), Expr(1.0), Expr(w))), 1.0 + w / 2, kSmoothRelTol));
  EXPECT_TRUE(Close(Eval(smooth_min(Expr(1.0), Expr(1.0), Expr(w))), 1.0 - w / 2, kSmoothRelTol));
  // Far from a tie they approach max/min: the gap is w^2 / (4 |a - b|) to first order.
  const double tiny = 1e-6;
  EXPECT_LE(Eval(smooth_max(Expr(5.0), Expr(-5.0), Expr(tiny))) - 5.0,
            tiny * tiny / 40.0 + kRoundingSlack * 5.0);
  EXPECT_LE(-5.0 - Eval(smooth_min(Expr(5.0), Expr(-5.0), Expr(tiny))),
            tiny * tiny / 40.0 + kRoundingSlack * 5.0);
  // Symmetric split of the derivative at a tie.
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  EXPECT_EQ(GradientAt(smooth_max(x, y, w), {x, y}, {1.0, 1.0}), Eigen::Vector2d(0.5, 0.5));
  EXPECT_EQ(GradientAt(smooth_min(x, y, w), {x, y}, {1.0, 1.0}), Eigen::Vector2d(0.5, 0.5));
}

// ---- overflow ---------------------------------------------------------------------------------

TEST(Overflow, SigmoidAndSoftplusStayFiniteAtPlusMinus800) {
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"y", {sigmoid(x), softplus(x)}}});
  const Function j = f.Jacobian("y", "x");
  const Function h0("h0", {{"x", {x}}}, {{"s", {sigmoid(x)}}, {"p", {softplus(x)}}});
  const Function hs = h0.Hessian("s", "x");
  const Function hp = h0.Hessian("p", "x");
  for (double v : {800.0, -800.0}) {
    SCOPED_TRACE(v);
    const std::vector<Eigen::VectorXd> point = {Eigen::VectorXd::Constant(1, v)};
    // operator() throws NonFiniteError on NaN/Inf, so these calls also assert finiteness.
    const Eigen::VectorXd y = f(point)[0];
    const Eigen::VectorXd d = j(point)[0];
    EXPECT_EQ(y[0], v > 0 ? 1.0 : 0.0);
    EXPECT_EQ(y[1], v > 0 ? 800.0 : 0.0);
    EXPECT_EQ(d[0], 0.0);
    EXPECT_EQ(d[1], v > 0 ? 1.0 : 0.0);
    EXPECT_EQ(hs(point)[0][0], 0.0);
    EXPECT_EQ(hp(point)[0][0], 0.0);
    // Constant folding uses the same overflow-free formulas.
    EXPECT_EQ(sigmoid(Expr(v)).Value(), y[0]);
    EXPECT_EQ(softplus(Expr(v)).Value(), y[1]);
  }
  // Far tails keep full relative accuracy, not just finiteness.
  EXPECT_TRUE(Close(sigmoid(Expr(-700.0)).Value() / std::exp(-700.0), 1.0, kSmoothRelTol));
  EXPECT_TRUE(Close(softplus(Expr(-700.0)).Value() / std::exp(-700.0), 1.0, kSmoothRelTol));
}

}  // namespace
}  // namespace graybox::expr
