// Function: tape evaluation against constant folding on random trees, batch evaluation, special
// outputs, non-finite reporting, argument validation with its messages, concurrent evaluation,
// and symbolic composition with Call().

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::ExpectThrowsWith;
using testing::RandomTrees;
using testing::RandomVector;

constexpr std::uint32_t kSeed = 987654321;
constexpr int kNumSymbols = 4;
constexpr int kNumTrees = 480;
constexpr int kTreesPerFunction = 8;
constexpr int kTreeDepth = 5;
constexpr int kPointsPerFunction = 3;

const double kNaN = std::numeric_limits<double>::quiet_NaN();

// Bitwise equality, except that any NaN equals any NaN. The tape and constant folding apply the
// same definitions (ops.h) to the same operands, so no tolerance is needed.
bool SameDouble(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// Reference values: substitute the point for the symbols; folding evaluates every operation.
std::vector<double> FoldedValues(const std::vector<Expr>& exprs, const std::vector<Expr>& symbols,
                                 const Eigen::VectorXd& point) {
  std::vector<Expr> values;
  for (int i = 0; i < point.size(); ++i) values.push_back(Expr(point[i]));
  std::vector<double> out;
  for (const Expr& e : Substitute(exprs, symbols, values)) {
    EXPECT_TRUE(e.IsConstant()) << e;
    out.push_back(e.IsConstant() ? e.Value() : kNaN);
  }
  return out;
}

// One Function of kTreesPerFunction random trees per group, over the symbols x_0..x_3.
struct RandomFunctions {
  std::vector<Expr> symbols = Expr::Symbols("x", kNumSymbols);
  std::vector<Function> functions;
  std::vector<Expr> all_trees;

  explicit RandomFunctions(std::uint32_t seed, int num_trees) {
    RandomTrees trees(symbols, seed);
    for (int g = 0; g < num_trees / kTreesPerFunction; ++g) {
      std::vector<Expr> outs;
      for (int k = 0; k < kTreesPerFunction; ++k) outs.push_back(trees.Generate(kTreeDepth));
      all_trees.insert(all_trees.end(), outs.begin(), outs.end());
      functions.emplace_back("random" + std::to_string(g), std::vector<FunctionIo>{{"x", symbols}},
                             std::vector<FunctionIo>{{"y", outs}});
    }
  }
};

TEST(FunctionEvaluation, TapeEqualsConstantFoldingOnRandomTrees) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  const RandomFunctions rf(kSeed, kNumTrees);
  // The trees must exercise every operation of the table.
  const std::set<Op> used = testing::OperationsIn(rf.all_trees);
  for (Op op : testing::AllOperations()) EXPECT_TRUE(used.count(op)) << OpName(op) << " unused";
  int compared = 0;
  for (const Function& f : rf.functions) {
    Workspace ws = f.MakeWorkspace();
    std::vector<double> y(f.OutputSize(0));
    double* outs[] = {y.data()};
    for (int p = 0; p < kPointsPerFunction; ++p) {
      const Eigen::VectorXd x = RandomVector(&rng, kNumSymbols, -2.0, 2.0);
      const double* ins[] = {x.data()};
      const EvalStatus status = f.Evaluate(ins, outs, &ws);
      EXPECT_TRUE(status.ok) << status.message;  // the domain guards keep every value finite
      const std::vector<double> expected = FoldedValues(f.OutputExprs(0), rf.symbols, x);
      for (int k = 0; k < f.OutputSize(0); ++k, ++compared) {
        EXPECT_TRUE(SameDouble(y[k], expected[k]))
            << f.name() << " output " << k << " = " << f.OutputExprs(0)[k] << "\n tape " << y[k]
            << " folded " << expected[k];
      }
    }
  }
  EXPECT_EQ(compared, kNumTrees * kPointsPerFunction);
}

TEST(FunctionEvaluation, FusedSumsOfProductsEqualSeparateOperations) {
  // Products consumed once by a sum or difference are fused on the tape; shared products and
  // products that are outputs are not. Every variant must give the unfused two-rounding result.
  const std::vector<Expr> s = Expr::Symbols("s", 4);
  const Expr ab = s[0] * s[1];
  const std::vector<Expr> outs = {s[0] * s[1] + s[2],
                                  s[2] + s[0] * s[3],
                                  s[0] * s[2] - s[3],
                                  s[3] - s[1] * s[2],
                                  ab * s[3] + ab,
                                  s[0] * s[1] * s[2] + s[3] * s[3],
                                  (s[0] * s[3] + s[1]) * s[2] - s[1] * s[3]};
  std::vector<Expr> with_product = outs;
  with_product.push_back(ab);
  const Function f("sop", {{"s", s}}, {{"y", with_product}});
  std::mt19937 rng = testing::SeededRng(kSeed);
  for (int p = 0; p < 10; ++p) {
    const Eigen::VectorXd x = RandomVector(&rng, 4, -3.0, 3.0);
    const Eigen::VectorXd y = f({x})[0];
    const std::vector<double> expected = FoldedValues(with_product, s, x);
    for (int k = 0; k < y.size(); ++k) EXPECT_TRUE(SameDouble(y[k], expected[k])) << k;
  }
}

TEST(FunctionEvaluation, BatchEqualsRepeatedEvaluation) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  const RandomFunctions rf(kSeed + 1, 2 * kTreesPerFunction);
  for (const Function& f : rf.functions) {
    Workspace ws = f.MakeWorkspace();
    std::vector<Eigen::MatrixXd> outputs;
    // Point counts below, at and around the lane width, and not multiples of 8.
    for (int n : {1, 5, 8, 15, 16, 17, 40, 0}) {
      SCOPED_TRACE(n);
      Eigen::MatrixXd x(kNumSymbols, n);
      for (int j = 0; j < n; ++j) x.col(j) = RandomVector(&rng, kNumSymbols, -2.0, 2.0);
      const EvalStatus status = f.EvaluateBatch({x}, &outputs, &ws);  // reuses ws and outputs
      EXPECT_TRUE(status.ok) << status.message;
      ASSERT_EQ(outputs.size(), 1u);
      ASSERT_EQ(outputs[0].rows(), f.OutputSize(0));
      ASSERT_EQ(outputs[0].cols(), n);
      Workspace single = f.MakeWorkspace();
      for (int j = 0; j < n; ++j) {
        const Eigen::VectorXd xj = x.col(j);
        Eigen::VectorXd yj(f.OutputSize(0));
        const double* ins[] = {xj.data()};
        double* outs[] = {yj.data()};
        f.Evaluate(ins, outs, &single);
        for (int k = 0; k < yj.size(); ++k) {
          EXPECT_TRUE(SameDouble(outputs[0](k, j), yj[k])) << "point " << j << " output " << k;
        }
      }
    }
  }
}

TEST(FunctionEvaluation, BatchReportsTheFirstNonFinitePoint) {
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"r", {x + 1.0, log(x)}}});
  Workspace ws = f.MakeWorkspace();
  Eigen::MatrixXd in(1, 20);
  in.setConstant(2.0);
  in(0, 17) = -1.0;
  std::vector<Eigen::MatrixXd> out;
  const EvalStatus s = f.EvaluateBatch({in}, &out, &ws);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(s.output, 0);
  EXPECT_EQ(s.index, 1);
  EXPECT_TRUE(std::isnan(s.value));
  EXPECT_NE(s.message.find("'r'[1]"), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("at point 17"), std::string::npos) << s.message;
  EXPECT_TRUE(std::isnan(out[0](1, 17)));
  EXPECT_EQ(out[0](0, 17), 0.0);  // values are still written
  EXPECT_EQ(out[0](1, 3), std::log(2.0));
}

TEST(FunctionEvaluation, ConstantRawAndUnusedEntries) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y"), unused = Expr::Symbol("unused");
  const Function f("f", {{"a", {x, unused}}, {"b", {y}}},
                   {{"c", {Expr(3.5), Expr(-0.0), x, y, x}}, {"empty", {}}, {"s", {x * y}}});
  EXPECT_EQ(f.NumInputs(), 2);
  EXPECT_EQ(f.InputSize(0), 2);
  EXPECT_EQ(f.OutputSize(1), 0);
  EXPECT_EQ(f.OutputSparsity(0), Sparsity::Dense(5, 1));
  EXPECT_EQ(f.AllInputSymbols().size(), 3u);
  // The unused input may hold anything, even NaN.
  const auto r = f({Eigen::Vector2d(2.0, kNaN), Eigen::VectorXd::Constant(1, -4.0)});
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0], (Eigen::VectorXd(5) << 3.5, 0.0, 2.0, -4.0, 2.0).finished());
  EXPECT_TRUE(std::signbit(r[0][1]));
  EXPECT_EQ(r[1].size(), 0);
  EXPECT_EQ(r[2][0], -8.0);
  // Batch too: constants and raw inputs in every lane.
  Workspace ws = f.MakeWorkspace();
  std::vector<Eigen::MatrixXd> out;
  Eigen::MatrixXd a(2, 19), b(1, 19);
  a.row(0).setLinSpaced(19, 0.0, 18.0);
  a.row(1).setConstant(kNaN);
  b.setConstant(0.5);
  EXPECT_TRUE(f.EvaluateBatch({a, b}, &out, &ws).ok);
  for (int j = 0; j < 19; ++j) {
    EXPECT_EQ(out[0](0, j), 3.5);
    EXPECT_EQ(out[0](2, j), j);
    EXPECT_EQ(out[0](3, j), 0.5);
    EXPECT_EQ(out[2](0, j), 0.5 * j);
  }
  // A function of no inputs.
  const Function c("c", {}, {{"k", {Expr(2.0) * 3.0}}});
  EXPECT_EQ(c({})[0][0], 6.0);
  EXPECT_EQ(c.NumInstructions(), 0);
  const Function empty;
  EXPECT_EQ(empty.NumInputs(), 0);
  EXPECT_EQ(empty.NumOutputs(), 0);
  EXPECT_TRUE(empty({}).empty());
}

TEST(FunctionEvaluation, RegistersAreReused) {
  const Expr x = Expr::Symbol("x");
  Expr e = x;
  for (int k = 0; k < 1000; ++k) e = sin(e);
  const Function f("f", {{"x", {x}}}, {{"y", {e}}});
  EXPECT_EQ(f.NumInstructions(), 1000);
  // One pinned input and at most two live work registers along a chain.
  EXPECT_LE(f.NumRegisters(), 3);
  double v = 0.7;
  for (int k = 0; k < 1000; ++k) v = std::sin(v);
  EXPECT_EQ(f({Eigen::VectorXd::Constant(1, 0.7)})[0][0], v);
}

TEST(FunctionEvaluation, NullOutputIsSkipped) {
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"bad", {log(x)}}, {"good", {x * 2.0}}});
  Workspace ws = f.MakeWorkspace();
  const double in = -1.0;
  const double* ins[] = {&in};
  double good = 0.0;
  double* outs[] = {nullptr, &good};
  const EvalStatus s = f.Evaluate(ins, outs, &ws);
  EXPECT_TRUE(s.ok) << "a skipped output is not checked: " << s.message;
  EXPECT_EQ(good, -2.0);
}

// ---- non-finite outputs -------------------------------------------------------------------

TEST(NonFinite, StatusNamesOutputAndIndex) {
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"a", {x}}, {"r", {x * x, log(x), 1.0 / x}}});
  Workspace ws = f.MakeWorkspace();
  double a[1], r[3];
  double* outs[] = {a, r};
  for (const double v : {-1.0, 0.0}) {
    SCOPED_TRACE(v);
    const double* ins[] = {&v};
    const EvalStatus s = f.Evaluate(ins, outs, &ws);
    EXPECT_FALSE(s.ok);
    EXPECT_EQ(s.output, 1);
    EXPECT_EQ(s.index, 1);   // the first non-finite entry (1/0 = inf comes later)
    EXPECT_EQ(r[0], v * v);  // values are still written
    if (v < 0) {
      EXPECT_TRUE(std::isnan(s.value));
      // The sign of a NaN is libm's choice (glibc prints log(-1) as -nan).
      EXPECT_EQ(s.message.rfind("Function 'f': output 'r'[1] = ", 0), 0u) << s.message;
      EXPECT_NE(s.message.find("nan"), std::string::npos) << s.message;
    } else {
      EXPECT_EQ(s.value, -std::numeric_limits<double>::infinity());
      EXPECT_EQ(s.message, "Function 'f': output 'r'[1] = -inf");
      EXPECT_EQ(r[2], std::numeric_limits<double>::infinity());
    }
  }
  const double ok = 2.0;
  const double* ins[] = {&ok};
  EXPECT_TRUE(f.Evaluate(ins, outs, &ws).ok);
}

TEST(NonFinite, OperatorCallThrowsNonFiniteError) {
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"r", {x, sqrt(x)}}});
  ExpectThrowsWith<NonFiniteError>([&] { f({Eigen::VectorXd::Constant(1, -4.0)}); },
                                   {"Function 'f': output 'r'[1] = ", "nan"});
  EXPECT_EQ(f({Eigen::VectorXd::Constant(1, 4.0)})[0][1], 2.0);
}

// ---- argument validation -------------------------------------------------------------------

TEST(FunctionErrors, ConstructionRejectsBadInputsAndOutputs) {
  const Expr a = Expr::Symbol("a"), b = Expr::Symbol("b");
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        Function("f", {{"x", {a, a - 1.0}}}, {{"y", {a}}});
      },
      {"input 'x'[1]: expected a symbol, got (a-1)"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        Function("f", {{"x", {a}}, {"p", {b, a}}}, {{"y", {a}}});
      },
      {"input 'p'[1]", "symbol 'a' appears twice"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        Function("f", {{"x", {a}}}, {{"y", {a * b}}});
      },
      {"output 'y' depends on symbol 'b'", "not among"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        Function("f", {{"x", {a}}}, {{"x", {a}}});
      },
      {"output name 'x' is used twice", "expected unique names"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        Function("f", {{"", {a}}}, {{"y", {a}}});
      },
      {"expected a nonempty input name", "got \"\""});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        FunctionIo("y", {a, b}, Sparsity::Dense(3, 1));
      },
      {"FunctionIo 'y'", "expected 3 expressions", "got 2"});
}

TEST(FunctionErrors, EvaluationRejectsBadArguments) {
  const Expr a = Expr::Symbol("a"), b = Expr::Symbol("b"), c = Expr::Symbol("c");
  const Function f("f", {{"x", {a, b}}, {"p", {c}}}, {{"y", {a * b + c}}, {"z", {a}}});
  const Eigen::Vector2d x(1, 2);
  const Eigen::VectorXd p = Eigen::VectorXd::Constant(1, 3.0);
  EXPECT_EQ(f({x, p})[0][0], 5.0);
  ExpectThrowsWith<std::invalid_argument>([&] { f({x}); }, {"expected 2 inputs, got 1"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        f({Eigen::Vector3d(1, 2, 3), p});
      },
      {"input 'x': expected size 2, got 3"});
  ExpectThrowsWith<std::invalid_argument>([&] { f.InputIndex("q"); },
                                          {"unknown input 'q'", "expected one of 'x', 'p'"});
  ExpectThrowsWith<std::invalid_argument>([&] { f.OutputIndex("q"); },
                                          {"unknown output 'q'", "expected one of 'y', 'z'"});
  ExpectThrowsWith<std::invalid_argument>([&] { f.Jacobian("y", "q"); }, {"unknown input 'q'"});
  ExpectThrowsWith<std::invalid_argument>([&] { f.Gradient("w", "x"); }, {"unknown output 'w'"});
  ExpectThrowsWith<std::out_of_range>([&] { f.InputName(2); },
                                      {"expected input index in [0, 2), got 2"});
  ExpectThrowsWith<std::out_of_range>([&] { f.OutputSize(-1); }, {"got -1"});
  // Workspaces belong to one function.
  const Function g("g", {{"x", {a, b}}, {"p", {c}}}, {{"y", {a - b}}, {"z", {c}}});
  Workspace wrong = g.MakeWorkspace();
  double y[1], z[1];
  double* outs[] = {y, z};
  const double* ins[] = {x.data(), p.data()};
  ExpectThrowsWith<std::invalid_argument>(
      [&] { f.Evaluate(ins, outs, &wrong); },
      {"expected a workspace from this function's MakeWorkspace()",
       "got a workspace of another function"});
  ExpectThrowsWith<std::invalid_argument>([&] { f.Evaluate(ins, outs, nullptr); }, {"got null"});
  Workspace fresh;
  EXPECT_THROW(f.Evaluate(ins, outs, &fresh), std::invalid_argument);
  std::vector<Eigen::MatrixXd> out;
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        f.EvaluateBatch({x, p}, &out, &wrong);
      },
      {"expected a workspace"});
  Workspace ws = f.MakeWorkspace();
  ExpectThrowsWith<std::invalid_argument>([&] { f.EvaluateBatch({x}, &out, &ws); },
                                          {"expected 2 inputs, got 1"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        f.EvaluateBatch({Eigen::MatrixXd::Zero(2, 5), Eigen::MatrixXd::Zero(1, 4)}, &out, &ws);
      },
      {"input 'p': expected 1x5, got 1x4"});
  // A copy of a Function shares its tape, so its workspaces are interchangeable.
  const Function copy = f;
  Workspace copy_ws = copy.MakeWorkspace();
  EXPECT_TRUE(f.Evaluate(ins, outs, &copy_ws).ok);
  EXPECT_EQ(y[0], 5.0);
}

TEST(FunctionErrors, DerivativeRequestsAreValidated) {
  const Expr a = Expr::Symbol("a"), b = Expr::Symbol("b");
  const Function f("f", {{"x", {a, b}}}, {{"y", {a * b, a}}});
  ExpectThrowsWith<std::invalid_argument>([&] { f.Gradient("y", "x"); },
                                          {"expected output 'y' with 1 entry, got 2"});
  ExpectThrowsWith<std::invalid_argument>([&] { f.Hessian("y", "x"); },
                                          {"expected output 'y' with 1 entry, got 2"});
}

// ---- concurrency ----------------------------------------------------------------------------

TEST(FunctionConcurrency, ThreadsWithOwnWorkspacesMatchSerialBitwise) {
  constexpr int kThreads = 4;
  constexpr int kPoints = 300;
  const RandomFunctions rf(kSeed + 2, kTreesPerFunction);
  const Function& f = rf.functions.at(0);
  std::mt19937 rng = testing::SeededRng(kSeed);
  Eigen::MatrixXd points(kNumSymbols, kPoints);
  for (int j = 0; j < kPoints; ++j) points.col(j) = RandomVector(&rng, kNumSymbols, -2.0, 2.0);

  auto evaluate_all = [&](Eigen::MatrixXd* result) {
    Workspace ws = f.MakeWorkspace();
    result->resize(f.OutputSize(0), kPoints);
    for (int j = 0; j < kPoints; ++j) {
      const double* ins[] = {points.col(j).data()};
      double* outs[] = {result->col(j).data()};
      f.Evaluate(ins, outs, &ws);
    }
  };
  Eigen::MatrixXd serial;
  evaluate_all(&serial);
  std::vector<Eigen::MatrixXd> parallel(kThreads);
  std::vector<Eigen::MatrixXd> batch(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      evaluate_all(&parallel[t]);
      Workspace ws = f.MakeWorkspace();
      std::vector<Eigen::MatrixXd> out;
      f.EvaluateBatch({points}, &out, &ws);
      batch[t] = out[0];
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) {
    ASSERT_EQ(parallel[t].size(), serial.size());
    EXPECT_EQ(std::memcmp(parallel[t].data(), serial.data(), sizeof(double) * serial.size()), 0)
        << "thread " << t;
    EXPECT_EQ(std::memcmp(batch[t].data(), serial.data(), sizeof(double) * serial.size()), 0)
        << "thread " << t << " (batch)";
  }
}

// ---- Call ----------------------------------------------------------------------------------

TEST(FunctionCall, ComposesSymbolically) {
  const Expr u = Expr::Symbol("u"), v = Expr::Symbol("v");
  // f(u, v) = (u*v + sin(u), u - v)
  const Function f("f", {{"in", {u, v}}}, {{"out", {u * v + sin(u), u - v}}, {"n", {u * u}}});
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const auto once = f.Call({{x, y}});
  ASSERT_EQ(once.size(), 2u);
  EXPECT_TRUE(once[0][0].IsSame(x * y + sin(x)));
  EXPECT_TRUE(once[1][0].IsSame(x * x));
  // g = f(f(x, y)): compose and compare with applying f twice numerically.
  const auto twice = f.Call({once[0]});
  const Function g("g", {{"xy", {x, y}}}, {{"out", twice[0]}});
  const Eigen::Vector2d p(0.3, -1.2);
  const Eigen::VectorXd inner = f({p})[0];
  const Eigen::VectorXd outer = f({inner})[0];
  const Eigen::VectorXd composed = g({p})[0];
  EXPECT_EQ(composed, outer);  // the same operations on the same values
  // Call on the function's own symbols returns its outputs unchanged.
  EXPECT_TRUE(f.Call({{u, v}})[0][0].IsSame(f.OutputExprs(0)[0]));
  // Swapping the arguments.
  EXPECT_TRUE(f.Call({{v, u}})[0][1].IsSame(v - u));
  ExpectThrowsWith<std::invalid_argument>([&] { f.Call({}); }, {"expected 1 arguments, got 0"});
  ExpectThrowsWith<std::invalid_argument>([&] { f.Call({{x}}); },
                                          {"argument 'in': expected size 2, got 1"});
}

}  // namespace
}  // namespace graybox::expr
