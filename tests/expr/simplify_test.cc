// Graph construction: structural hashing, constant folding (with its NaN semantics), the
// construction-time simplifications of expr.h, Substitute, FreeSymbols, and very deep graphs.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::ExpectThrowsWith;

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

// ---- structural hashing ---------------------------------------------------------------------

TEST(StructuralHashing, CommutativeArgumentsAreOrderedCanonically) {
  const Expr a = Expr::Symbol("a"), b = Expr::Symbol("b");
  EXPECT_TRUE((a + b).IsSame(b + a));
  EXPECT_TRUE((a * b).IsSame(b * a));
  EXPECT_TRUE(eq(a, b).IsSame(eq(b, a)));
  EXPECT_TRUE(ne(a, b).IsSame(ne(b, a)));
  EXPECT_TRUE(logical_and(a, b).IsSame(logical_and(b, a)));
  EXPECT_TRUE(logical_or(a, b).IsSame(logical_or(b, a)));
  EXPECT_FALSE((a - b).IsSame(b - a));
  EXPECT_FALSE((a / b).IsSame(b / a));
  EXPECT_FALSE(pow(a, b).IsSame(pow(b, a)));
  EXPECT_FALSE(lt(a, b).IsSame(lt(b, a)));
  // gt/ge are lt/le with swapped arguments.
  EXPECT_TRUE(gt(a, b).IsSame(lt(b, a)));
  EXPECT_TRUE(ge(a, b).IsSame(le(b, a)));
}

TEST(StructuralHashing, IdenticalSubtreesShareNodes) {
  const Expr a = Expr::Symbol("a"), b = Expr::Symbol("b");
  // a, b, a+b, sin(a+b), sin*sin: the two sines are one node.
  const Expr e = sin(a + b) * sin(b + a);
  EXPECT_EQ(e.CountNodes(), 5u);
  EXPECT_TRUE(e.Arg(0).IsSame(e.Arg(1)));
  // Built again from scratch: the same node, the same id.
  const Expr again = sin(b + a) * sin(a + b);
  EXPECT_TRUE(e.IsSame(again));
  EXPECT_EQ(e.Id(), again.Id());
  // Constants are hash-consed too: a, 2, a*2, (a*2)+(a*2)... written two ways.
  const Expr c = a * 2.0 + 2.0 * a;
  EXPECT_EQ(c.CountNodes(), 4u);
  // Across several roots, shared nodes count once: {a, b, a+b, sin, *} and {a, b, a+b, cos}.
  EXPECT_EQ(CountNodes({e, cos(a + b)}), 6u);
  EXPECT_EQ(CountNodes({}), 0u);
}

TEST(StructuralHashing, SymbolsAreNeverMerged) {
  const Expr x1 = Expr::Symbol("x"), x2 = Expr::Symbol("x");
  EXPECT_FALSE(x1.IsSame(x2));
  EXPECT_NE(x1.Id(), x2.Id());
  EXPECT_EQ(x1.Name(), "x");
  EXPECT_EQ((x1 + x2).CountNodes(), 3u);
  const std::vector<Expr> v = Expr::Symbols("v", 3);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0].Name(), "v_0");
  EXPECT_EQ(v[2].Name(), "v_2");
  EXPECT_TRUE(v[1].IsSymbol());
  EXPECT_TRUE(v[1].DependsOnSymbols());
  EXPECT_FALSE((Expr(1.0) + 2.0).DependsOnSymbols());
}

TEST(StructuralHashing, ConcurrentConstructionYieldsOneNode) {
  // The hash-consing table is shared by all threads: four threads building the same expression
  // at once must all get the same nodes.
  constexpr int kThreads = 4;
  constexpr int kTerms = 2000;
  const Expr x = Expr::Symbol("x");
  std::vector<Expr> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      Expr e = x;
      for (int k = 0; k < kTerms; ++k) e = sin(e) * (k + 1.0) + cos(x * static_cast<double>(k));
      results[t] = e;
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 1; t < kThreads; ++t) EXPECT_TRUE(results[t].IsSame(results[0])) << t;
}

TEST(ExprBasics, ConstantsAndAccessors) {
  EXPECT_TRUE(Expr().IsZero());
  EXPECT_TRUE(Expr(1).IsOne());
  EXPECT_TRUE(Expr(2.5).IsConstant(2.5));
  EXPECT_EQ(Expr(2.5).Value(), 2.5);
  const Expr x = Expr::Symbol("x");
  const Expr e = (x - 2.0) / x;
  EXPECT_EQ(e.ToString(), "((x-2)/x)");
  EXPECT_EQ(e.op(), Op::kDiv);
  EXPECT_EQ(e.NumArgs(), 2);
  EXPECT_TRUE(e.Arg(1).IsSame(x));
  EXPECT_EQ(e.Name(), "");
  ExpectThrowsWith<std::logic_error>([&] { e.Value(); }, {"expected a constant", "got ((x-2)/x)"});
  ExpectThrowsWith<std::out_of_range>([&] { e.Arg(2); }, {"expected index in [0, 2)", "got 2"});
  EXPECT_THROW(x.Arg(0), std::out_of_range);
  Expr acc = x;
  acc += 1.0;
  acc *= 2.0;
  acc -= x;
  acc /= 4.0;
  EXPECT_TRUE(acc.IsSame(((x + 1.0) * 2.0 - x) / 4.0));
}

TEST(ExprBasics, EqualityIsKnownEqualityNotAComparisonNode) {
  static_assert(std::is_same_v<decltype(Expr() == Expr()), bool>);
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  EXPECT_TRUE(x == x);
  EXPECT_TRUE((x + y) == (y + x));  // one node
  EXPECT_TRUE((x + 0.0) == x);
  EXPECT_FALSE(x == y);  // not known equal
  EXPECT_TRUE(x != y);
  EXPECT_FALSE(x * 2.0 == x + x);  // equal values, different graphs
  // Constants compare as doubles.
  EXPECT_TRUE(Expr(2.0) == 2.0);
  EXPECT_TRUE(Expr(-0.0) == Expr(0.0));
  EXPECT_FALSE(Expr(kNaN) == Expr(kNaN));
  EXPECT_TRUE(Expr(kNaN) != Expr(kNaN));
  EXPECT_FALSE(Expr(1.0) == x);
}

// ---- constant folding -----------------------------------------------------------------------

TEST(ConstantFolding, OperationsOnConstantsFold) {
  const Expr two = 2.0, three = 3.0;
  EXPECT_TRUE((two + three).IsConstant(5.0));
  EXPECT_TRUE((two - three).IsConstant(-1.0));
  EXPECT_TRUE((two * three).IsConstant(6.0));
  EXPECT_TRUE((two / three).IsConstant(2.0 / 3.0));
  EXPECT_TRUE(pow(two, three).IsConstant(8.0));
  EXPECT_TRUE(sin(two).IsConstant(std::sin(2.0)));
  EXPECT_TRUE(atan2(two, -three).IsConstant(std::atan2(2.0, -3.0)));
  EXPECT_TRUE(lt(two, three).IsOne());
  EXPECT_TRUE(if_else(lt(three, two), two, three).IsConstant(3.0));
  // Nested folding of a whole tree.
  EXPECT_TRUE((sqrt(two * 8.0) + exp(Expr(0.0))).IsConstant(5.0));
}

TEST(ConstantFolding, FollowsIeeeIncludingNaN) {
  // NaN constant times the constant 0 is NaN (IEEE), unlike the symbolic x*0 rule below.
  const Expr nan_times_zero = Expr(kNaN) * Expr(0.0);
  ASSERT_TRUE(nan_times_zero.IsConstant());
  EXPECT_TRUE(std::isnan(nan_times_zero.Value()));
  EXPECT_TRUE(std::isnan((Expr(0.0) * Expr(kNaN)).Value()));
  EXPECT_TRUE(std::isnan((Expr(kInf) * Expr(0.0)).Value()));
  EXPECT_TRUE(std::isnan((Expr(kInf) - Expr(kInf)).Value()));
  EXPECT_TRUE(std::isnan((Expr(0.0) / Expr(0.0)).Value()));
  EXPECT_TRUE(std::isnan(log(Expr(-1.0)).Value()));
  EXPECT_EQ((Expr(1.0) / Expr(0.0)).Value(), kInf);
  // NaN constants fold consistently and hash-cons to one node.
  EXPECT_TRUE(Expr(kNaN).IsSame(Expr(kNaN)));
  EXPECT_FALSE(Expr(kNaN).IsConstant(kNaN));  // exact comparison, and NaN != NaN
}

TEST(ConstantFolding, SignedZeroFollowsIeeeLikeTheTape) {
  // Folding and the tape must agree: -(0) is -0.0, so 1/-(0) is -inf and atan2(-(0), -1) is -pi.
  const Expr z = Expr::Symbol("z");
  const std::vector<Expr> exprs = {1.0 / -z, atan2(-z, Expr(-1.0)), -z};
  const Function f("f", {{"z", {z}}}, {{"y", exprs}});
  double y[3];
  double* outs[] = {y};
  const double zero = 0.0;
  const double* ins[] = {&zero};
  Workspace ws = f.MakeWorkspace();
  f.Evaluate(ins, outs, &ws);
  EXPECT_EQ(y[0], -kInf);
  EXPECT_EQ(y[1], -M_PI);
  EXPECT_TRUE(std::signbit(y[2]));
  const std::vector<Expr> folded = Substitute(exprs, {z}, {Expr(0.0)});
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(folded[k].IsConstant());
    EXPECT_EQ(folded[k].Value(), y[k]) << k;
    EXPECT_EQ(std::signbit(folded[k].Value()), std::signbit(y[k])) << k;
  }
  EXPECT_EQ((Expr(1.0) / -Expr(0.0)).Value(), -kInf);
  EXPECT_EQ((Expr(1.0) / Expr(-0.0)).Value(), -kInf);
  // Both zeros are zero for the simplifications.
  const Expr x = Expr::Symbol("x");
  EXPECT_TRUE(Expr(-0.0).IsZero());
  EXPECT_TRUE((x + Expr(-0.0)).IsSame(x));
  EXPECT_TRUE((x * Expr(-0.0)).IsZero());
}

// ---- construction-time simplifications (expr.h) ---------------------------------------------

TEST(Simplification, AdditiveAndMultiplicativeIdentities) {
  const Expr x = Expr::Symbol("x");
  EXPECT_TRUE((x + 0.0).IsSame(x));
  EXPECT_TRUE((0.0 + x).IsSame(x));
  EXPECT_TRUE((x - 0.0).IsSame(x));
  EXPECT_TRUE((0.0 - x).IsSame(-x));
  EXPECT_TRUE((x * 1.0).IsSame(x));
  EXPECT_TRUE((1.0 * x).IsSame(x));
  EXPECT_TRUE((x * -1.0).IsSame(-x));
  EXPECT_TRUE((x / 1.0).IsSame(x));
  EXPECT_TRUE((-(-x)).IsSame(x));
  EXPECT_EQ((-(-(-x))).op(), Op::kNeg);
  EXPECT_TRUE(pow(x, 1.0).IsSame(x));
  EXPECT_TRUE(pow(x, 0.0).IsOne());
  EXPECT_TRUE((+x).IsSame(x));
  // Not simplified: x/x, x+x, pow(x, 2).
  EXPECT_EQ((x / x).op(), Op::kDiv);
  EXPECT_EQ((x + x).op(), Op::kAdd);
  EXPECT_EQ(pow(x, 2.0).op(), Op::kPow);
}

TEST(Simplification, ZeroRulesAreStructuralNotIeee) {
  const Expr x = Expr::Symbol("x");
  EXPECT_TRUE((x * 0.0).IsZero());
  EXPECT_TRUE((0.0 * x).IsZero());
  EXPECT_TRUE((0.0 / x).IsZero());
  EXPECT_TRUE((x - x).IsZero());
  EXPECT_TRUE((sin(x) - sin(x)).IsZero());
  // Documented: not IEEE-exact when x is NaN or Inf at evaluation time.
  const Function f("f", {{"x", {x}}}, {{"y", {x * 0.0, x - x, 0.0 / x}}});
  for (double v : {kNaN, kInf}) {
    double y[3];
    double* outs[] = {y};
    const double* ins[] = {&v};
    Workspace ws = f.MakeWorkspace();
    const EvalStatus s = f.Evaluate(ins, outs, &ws);
    EXPECT_TRUE(s.ok) << s.message;
    EXPECT_EQ(y[0], 0.0);
    EXPECT_EQ(y[1], 0.0);
    EXPECT_EQ(y[2], 0.0);
  }
  // A symbolic NaN factor is not dropped: NaN * x stays an operation.
  EXPECT_EQ((Expr(kNaN) * x).op(), Op::kMul);
}

TEST(Simplification, IfElseWithConstantConditionOrEqualBranches) {
  const Expr c = Expr::Symbol("c"), a = Expr::Symbol("a"), b = Expr::Symbol("b");
  EXPECT_TRUE(if_else(1.0, a, b).IsSame(a));
  EXPECT_TRUE(if_else(-3.0, a, b).IsSame(a));
  EXPECT_TRUE(if_else(0.0, a, b).IsSame(b));
  EXPECT_TRUE(if_else(kNaN, a, b).IsSame(a));  // NaN != 0
  EXPECT_TRUE(if_else(c, a + b, b + a).IsSame(a + b));
  EXPECT_EQ(if_else(c, a, b).op(), Op::kIfElse);
  EXPECT_TRUE(if_else(lt(2.0, 1.0), a, b).IsSame(b));
}

// ---- Substitute and FreeSymbols ---------------------------------------------------------------

TEST(Substitute, ReplacesSymbolsAndKeepsSharing) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y"), z = Expr::Symbol("z");
  const Expr e = sin(x) * x - y;
  const auto r = Substitute({e, y, z}, {x}, {y + 1.0});
  ASSERT_EQ(r.size(), 3u);
  EXPECT_TRUE(r[0].IsSame(sin(y + 1.0) * (y + 1.0) - y));
  EXPECT_TRUE(r[1].IsSame(y));
  EXPECT_TRUE(r[2].IsSame(z));  // untouched expressions are returned as is
  // y+1 is one shared node: y, 1, y+1, sin, *, -.
  EXPECT_EQ(r[0].CountNodes(), 6u);
}

TEST(Substitute, IsSimultaneous) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const auto r = Substitute({x - y}, {x, y}, {y, x});
  EXPECT_TRUE(r[0].IsSame(y - x));
}

TEST(Substitute, ConstantsFoldCompletely) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const auto r = Substitute({pow(x, y) + atan2(y, x) * x}, {x, y}, {Expr(2.0), Expr(3.0)});
  ASSERT_TRUE(r[0].IsConstant());
  EXPECT_EQ(r[0].Value(), std::pow(2.0, 3.0) + std::atan2(3.0, 2.0) * 2.0);
  // Simplifications apply to the substituted graph: x*y with y -> 0 is 0.
  EXPECT_TRUE(Substitute({x * y}, {y}, {Expr(0.0)})[0].IsZero());
}

TEST(Substitute, RejectsBadArguments) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        Substitute({x}, {x, y}, {y});
      },
      {"expected as many replacements as symbols (2)", "got 1"});
  ExpectThrowsWith<std::invalid_argument>([&] { Substitute({x}, {x + y}, {y}); },
                                          {"expected a symbol at position 0", "got (x+y)"});
}

TEST(FreeSymbols, DistinctSymbolsInOrderOfFirstAppearance) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y"), z = Expr::Symbol("z");
  const auto s = FreeSymbols({(x - y) / z, z - x});
  ASSERT_EQ(s.size(), 3u);
  EXPECT_TRUE(s[0].IsSame(x));
  EXPECT_TRUE(s[1].IsSame(y));
  EXPECT_TRUE(s[2].IsSame(z));
  EXPECT_TRUE(FreeSymbols({Expr(1.0) + 2.0}).empty());
  EXPECT_TRUE(FreeSymbols({}).empty());
  // Symbols inside a condition count even though they carry no derivative.
  const auto c = FreeSymbols({if_else(lt(z, 0.0), x, 1.0)});
  ASSERT_EQ(c.size(), 2u);
  EXPECT_TRUE(c[0].IsSame(z));
  EXPECT_TRUE(c[1].IsSame(x));
  // Canceled symbols are gone.
  EXPECT_TRUE(FreeSymbols({x - x}).empty());
}

// ---- deep graphs --------------------------------------------------------------------------------

// Deep enough to overflow any recursive traversal (a few hundred bytes per frame on an 8 MB
// stack), small enough for the sanitizer build.
constexpr int kDeepChain = 200000;
// ToString() is documented to stop after 65536 characters; a message adds a short prefix.
constexpr std::size_t kMaxRenderedMessage = 65536 + 200;
// Steps of a chain p <- sin(p)/2 + x: its derivative is about three nodes deep per step.
constexpr int kDeepProductChain = 50000;

TEST(DeepGraph, LongChainBuildsEvaluatesDifferentiatesAndDestroys) {
  const Expr x = Expr::Symbol("x");
  Expr e = x;
  for (int k = 0; k < kDeepChain; ++k) e = e + 1.0;
  // x, the constant 1 and one addition per step.
  EXPECT_EQ(e.CountNodes(), static_cast<std::size_t>(kDeepChain) + 2);
  EXPECT_EQ(FreeSymbols({e}).size(), 1u);
  {
    const Function f("chain", {{"x", {x}}}, {{"y", {e}}});
    EXPECT_EQ(f.NumInstructions(), kDeepChain);
    // 0.5 + n is exact in double for n < 2^52.
    EXPECT_EQ(f({Eigen::VectorXd::Constant(1, 0.5)})[0][0], 0.5 + kDeepChain);
    EXPECT_EQ(f.Gradient("y", "x")({Eigen::VectorXd::Constant(1, 0.5)})[0][0], 1.0);
    const auto moved = Substitute({e}, {x}, {Expr(0.5)});
    ASSERT_TRUE(moved[0].IsConstant());
    EXPECT_EQ(moved[0].Value(), 0.5 + kDeepChain);
  }
  // A product chain: its derivative is itself a deep graph.
  Expr p = x;
  for (int k = 0; k < kDeepProductChain; ++k) p = sin(p) * 0.5 + x;
  const auto d = ForwardDerivative({p}, {x}, {{Expr(1.0)}});
  EXPECT_GT(d[0][0].CountNodes(), 2u * kDeepProductChain);
  const Function df("df", {{"x", {x}}}, {{"d", d[0]}});
  // The chain is a contraction (|slope| <= 1/2 per step), so its derivative stays finite.
  EXPECT_TRUE(std::isfinite(df({Eigen::VectorXd::Constant(1, 0.3)})[0][0]));
  // Error messages render the expression: they must neither recurse nor grow without bound.
  try {
    e.Value();
    ADD_FAILURE() << "Value() of a non-constant must throw";
  } catch (const std::logic_error& err) {
    const std::string what = err.what();
    EXPECT_LE(what.size(), kMaxRenderedMessage);
    EXPECT_EQ(what.substr(what.size() - 3), "...");
  }
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        Function("f", {{"x", {x, e}}}, {{"y", {x}}});
      },
      {"input 'x'[1]: expected a symbol, got (1+(1+(1+(1+"});
  // Destruction of both chains (and of the derivative) must not recurse.
  e = Expr();
  p = Expr();
  EXPECT_TRUE(e.IsZero());
}

TEST(DeepGraph, RenderingADoublingDagIsBounded) {
  // 101 nodes whose full expansion has 2^100 leaves: rendering must stop, not expand them all.
  const Expr x = Expr::Symbol("x");
  Expr e = x;
  for (int k = 0; k < 100; ++k) e = e * e;
  EXPECT_EQ(e.CountNodes(), 101u);
  const std::string s = e.ToString();
  EXPECT_LE(s.size(), kMaxRenderedMessage);
  EXPECT_EQ(s.substr(0, 6), "((((((");
  EXPECT_EQ(s.substr(s.size() - 3), "...");
  ExpectThrowsWith<std::invalid_argument>([&] { Substitute({x}, {e}, {x}); },
                                          {"expected a symbol at position 0"});
  // Small expressions are rendered completely, every operation form included.
  const Expr y = Expr::Symbol("y");
  EXPECT_EQ((-(x - y)).ToString(), "(-(x-y))");
  EXPECT_EQ(if_else(lt(x, 2.5), atan2(y, x), sqrt(x)).ToString(),
            "if_else((x<2.5), atan2(y, x), sqrt(x))");
}

}  // namespace
}  // namespace graybox::expr
