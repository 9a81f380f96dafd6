// Equation blocks (models/equation_block.h): a damped oscillator written as text evaluates as the
// same equations written in C++, on doubles and through libexpr (exact derivatives, checked against
// finite differences); the operator precedence and every function of the language; and the
// defects: unknown names with a suggestion and the column, wrong arity, a state without an
// equation, a name used twice, unknown option keys, bad roles and ranges.
#include "graybox/models/equation_block.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/expr/function.h"
#include "graybox/models/model.h"
#include "test_util.h"

namespace graybox::models {
namespace {

// Rounding only: the same operations in the same order.
constexpr double kSameOperations = 1e-14;

BlockOptions Oscillator() {
  BlockOptions o;
  o.words["inputs"] = "f";
  o.words["unit.f"] = "N";
  o.words["states"] = "q, v";
  o.words["unit.q"] = "m";
  o.words["unit.v"] = "m/s";
  o.words["role.q"] = "position";
  o.words["role.v"] = "velocity";
  o.words["parameters"] = "k, c, m";
  o.numbers["nominal.k"] = {40.0};
  o.numbers["nominal.c"] = {0.8};
  o.numbers["nominal.m"] = {2.0};
  o.numbers["bounds.m"] = {0.01, 100.0};
  o.words["outputs"] = "spring";
  o.words["unit.spring"] = "N";
  o.words["value.spring"] = "k*q + 0.1*k*q^3";
  o.words["derivative.q"] = "v";
  o.words["derivative.v"] = "(f - spring - c*v) / m";
  return o;
}

// Evaluates `block` at (x, u, p) on doubles.
std::pair<std::vector<double>, std::vector<double>> Evaluate(const Block& block,
                                                             const std::vector<double>& x,
                                                             const std::vector<double>& u,
                                                             const std::vector<double>& p) {
  std::vector<double> xdot(block.NumStates()), y(block.NumOutputs());
  block.Evaluate(BlockArgs<double>{x.data(), u.data(), p.data(), xdot.data(), y.data()});
  return {xdot, y};
}

// The value of the single output of a block whose only output is `text` (inputs a, b, c).
double Value(const std::string& text, double a, double b = 0.0, double c = 0.0) {
  BlockOptions o;
  o.words["inputs"] = "a, b, c";
  o.words["outputs"] = "y";
  o.words["value.y"] = text;
  const auto block = MakeEquationBlock(o);
  return Evaluate(*block, {}, {a, b, c}, {}).second[0];
}

// The EquationError of `o`, or a test failure.
EquationError ErrorOf(const BlockOptions& o) {
  try {
    MakeEquationBlock(o);
  } catch (const EquationError& e) {
    return e;
  }
  ADD_FAILURE() << "expected an EquationError";
  return EquationError("", -1, "");
}

TEST(EquationBlock, EqualsTheSameEquationsInCpp) {
  const auto block = MakeEquationBlock(Oscillator());
  const BlockInfo& info = block->info();
  ASSERT_EQ(block->NumStates(), 2);
  ASSERT_EQ(block->NumParameters(), 3);
  EXPECT_EQ(info.states[1].role, SignalRole::kVelocity);
  EXPECT_EQ(info.states[1].unit, "m/s");
  EXPECT_EQ(info.parameters[2].lower, 0.01);
  EXPECT_EQ(info.parameters[2].nominal, 2.0);
  const double q = 0.3, v = -0.7, f = 1.1, k = 40.0, c = 0.8, m = 2.0;
  const auto [xdot, y] = Evaluate(*block, {q, v}, {f}, {k, c, m});
  const double spring = k * q + 0.1 * k * q * q * q;
  EXPECT_NEAR(y[0], spring, kSameOperations * std::fabs(spring));
  EXPECT_EQ(xdot[0], v);
  EXPECT_NEAR(xdot[1], (f - spring - c * v) / m, kSameOperations);
  // Through a model and libexpr: the same values, and derivatives that match finite differences.
  testing::ExpectBlockDerivativesMatch(*block, 20261127u);
}

TEST(EquationBlock, PrecedenceAndFunctions) {
  EXPECT_EQ(Value("-a^2", 3.0), -9.0);              // ^ binds tighter than unary minus
  EXPECT_EQ(Value("a^b^c", 2.0, 3.0, 2.0), 512.0);  // right-associative
  EXPECT_EQ(Value("a - b - c", 10.0, 3.0, 2.0), 5.0);
  EXPECT_EQ(Value("a / b / c", 12.0, 3.0, 2.0), 2.0);
  EXPECT_EQ(Value("2 * (a + b) * .5e1", 1.0, 2.0), 30.0);
  EXPECT_EQ(Value("a + b < c", 1.0, 1.0, 3.0), 1.0);
  EXPECT_EQ(Value("if_else(a >= b, a, b)", 1.0, 4.0), 4.0);
  EXPECT_EQ(Value("if_else(a != b, 1, 2) + (a == a)", 1.0, 4.0), 2.0);
  EXPECT_NEAR(Value("atan2(a, b) + pi", 1.0, 1.0), 0.25 * M_PI + M_PI, 1e-15);
  EXPECT_EQ(Value("min(a, b) + max(a, b) + abs(-c) + sign(-a)", 2.0, 5.0, 3.0), 9.0);
  EXPECT_NEAR(Value("sqrt(a) + exp(b) + log(c)", 4.0, 0.0, 1.0), 3.0, 1e-15);
  EXPECT_NEAR(Value("sin(a) + cos(a) + tan(b) + atan(b) + tanh(b) + erf(b)", 0.0, 0.0), 1.0, 1e-15);
  EXPECT_NEAR(Value("square(a) + pow(a, 3) + sigmoid(b) + softplus(c)", 2.0, 0.0, 0.0),
              4.0 + 8.0 + 0.5 + std::log(2.0), 1e-14);
  EXPECT_NEAR(Value("smooth_abs(a, 1) + smooth_sign(b, 1) + smooth_max(a, b, c) + "
                    "smooth_min(a, b, c)",
                    3.0, 0.0, 1e-9),
              (std::sqrt(10.0) - 1.0) + 0.0 + 3.0 + 0.0, 1e-8);
}

TEST(EquationBlock, DefectsNameTheFieldTheColumnAndWhatWasExpected) {
  struct Bad {
    std::string key, text;
    std::string field;
    int offset;
    std::string reason;
  };
  const std::vector<Bad> cases = {
      {"derivative.v", "(f - sprng - c*v) / m", "derivative.v", 5,
       "unknown name 'sprng'; did you mean 'spring'?"},
      {"derivative.v", "(f - spring - c*v / m", "derivative.v", 21, "expected ')', got the end"},
      {"derivative.v", "atan2(f) / m", "derivative.v", 0, "'atan2' takes 2 arguments, got 1"},
      {"derivative.v", "tanhh(v)", "derivative.v", 0,
       "unknown function 'tanhh'; did you mean 'tanh'?"},
      {"derivative.v", "f * * v", "derivative.v", 4, "expected a number, a name or '('"},
      {"derivative.v", "f v", "derivative.v", 2, "expected an operator or the end, got 'v'"},
      {"derivative.v", "  ", "derivative.v", 2, "expected an expression, got an empty text"},
      {"value.spring", "k*q + sqrt", "value.spring", 6, "'sqrt' is a function: call it"},
  };
  for (const Bad& b : cases) {
    BlockOptions o = Oscillator();
    o.words[b.key] = b.text;
    const EquationError e = ErrorOf(o);
    EXPECT_EQ(e.field(), b.field) << e.what();
    EXPECT_EQ(e.offset(), b.offset) << e.what();
    EXPECT_NE(e.reason().find(b.reason), std::string::npos) << e.what();
  }
  // Declarations.
  BlockOptions o = Oscillator();
  o.words.erase("derivative.v");
  EXPECT_NE(std::string(ErrorOf(o).what()).find("state 'v' has no equation"), std::string::npos);
  o = Oscillator();
  o.words["parameters"] = "k, c, m, q";
  EXPECT_NE(std::string(ErrorOf(o).what()).find("'q' is used twice (also in 'states')"),
            std::string::npos);
  o = Oscillator();
  o.words["parameters"] = "k, c, m, sin";
  EXPECT_NE(std::string(ErrorOf(o).what()).find("'sin' is a function"), std::string::npos);
  o = Oscillator();
  o.words["unit.vv"] = "m/s";
  EXPECT_NE(std::string(ErrorOf(o).what()).find("unknown option 'unit.vv'; did you mean 'unit.v'"),
            std::string::npos);
  o = Oscillator();
  o.words["role.v"] = "velocty";
  EXPECT_NE(std::string(ErrorOf(o).what()).find("did you mean 'velocity'"), std::string::npos);
  o = Oscillator();
  o.numbers["range.q"] = {1.0, -1.0};
  EXPECT_EQ(ErrorOf(o).field(), "range.q");
  o = Oscillator();
  o.numbers["nominal.m"] = {1000.0};
  EXPECT_EQ(ErrorOf(o).field(), "nominal.m");
  o = Oscillator();
  o.words["states"] = "q, 2v";
  EXPECT_EQ(ErrorOf(o).field(), "states");
  // The registry creates it by its type name.
  EXPECT_EQ(BlockRegistry::Global().Create(kEquationBlock, Oscillator())->NumStates(), 2);
}

}  // namespace
}  // namespace graybox::models
