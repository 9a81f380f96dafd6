// The operation table of the expression graph.
//
// Every operation is listed once in GRAYBOX_EXPR_OPS with its arity and printed name; its value on
// doubles and its local partial derivatives (as expressions) are defined once, side by side, in
// src/ops.cc. Every consumer (constant folding, the tape, forward and reverse differentiation, code
// generation) dispatches through this table, so the derivative modes cannot disagree.
//
// Derivative conventions at non-smooth points (documented once, used by every mode):
//   abs(x)        d/dx = sign(x), so 0 at x = 0.
//   sign(x)       d/dx = 0 everywhere (the Dirac mass at 0 is dropped).
//   min(a, b)     the partial goes to a when a <= b, else to b (ties pick the first argument).
//   max(a, b)     the partial goes to a when a >= b, else to b (ties pick the first argument).
//   if_else(c,a,b) d/da = (c != 0), d/db = (c == 0), d/dc = 0: the derivative of the branch taken.
//                 The untaken branch is multiplied by 0, so a NaN/Inf partial inside it still
//                 propagates (0 * NaN = NaN): guard its argument too, e.g.
//                 if_else(x > 0, sqrt(if_else(x > 0, x, 1)), 0) has derivative 0 at x < 0.
//   comparisons and logical operations have zero derivative.
//   pow(x, y)     d/dx = y*x^(y-1); d/dy = log(x)*x^y, only formed when y depends on an input.
#pragma once

#include <cstdint>

namespace graybox::expr {

// X(enumerator, arity, printed name)
#define GRAYBOX_EXPR_OPS(X) \
  X(kConstant, 0, "const")  \
  X(kSymbol, 0, "symbol")   \
  GRAYBOX_EXPR_OPS_NO_LEAVES(X)

// The operations proper (everything but constants and symbols).
#define GRAYBOX_EXPR_OPS_NO_LEAVES(X) \
  X(kAdd, 2, "+")                     \
  X(kSub, 2, "-")                     \
  X(kMul, 2, "*")                     \
  X(kDiv, 2, "/")                     \
  X(kNeg, 1, "neg")                   \
  X(kPow, 2, "pow")                   \
  X(kSqrt, 1, "sqrt")                 \
  X(kExp, 1, "exp")                   \
  X(kLog, 1, "log")                   \
  X(kSin, 1, "sin")                   \
  X(kCos, 1, "cos")                   \
  X(kTan, 1, "tan")                   \
  X(kAtan, 1, "atan")                 \
  X(kAtan2, 2, "atan2")               \
  X(kTanh, 1, "tanh")                 \
  X(kSigmoid, 1, "sigmoid")           \
  X(kSoftplus, 1, "softplus")         \
  X(kAbs, 1, "abs")                   \
  X(kSign, 1, "sign")                 \
  X(kMin, 2, "min")                   \
  X(kMax, 2, "max")                   \
  X(kErf, 1, "erf")                   \
  X(kLt, 2, "<")                      \
  X(kLe, 2, "<=")                     \
  X(kEq, 2, "==")                     \
  X(kNe, 2, "!=")                     \
  X(kAnd, 2, "&&")                    \
  X(kOr, 2, "||")                     \
  X(kNot, 1, "!")                     \
  X(kIfElse, 3, "if_else")

enum class Op : std::uint8_t {
#define GRAYBOX_EXPR_ENUM(e, n, s) e,
  GRAYBOX_EXPR_OPS(GRAYBOX_EXPR_ENUM)
#undef GRAYBOX_EXPR_ENUM
};

/// Number of operations in the table.
constexpr int kNumOps = 0
#define GRAYBOX_EXPR_COUNT(e, n, s) +1
    GRAYBOX_EXPR_OPS(GRAYBOX_EXPR_COUNT)
#undef GRAYBOX_EXPR_COUNT
    ;

/// Number of arguments of `op` (0 for constants and symbols).
int Arity(Op op);
/// Printed name of `op`, e.g. "sin" or "+".
const char* OpName(Op op);
/// True for operations whose arguments may be swapped (a+b, a*b, ==, !=, &&, ||). min and max are
/// not: their derivative at a tie goes to the first argument as written (see above), so min(a, b)
/// and min(b, a) are different nodes.
bool IsCommutative(Op op);

/// Value of `op` applied to doubles `a` (of length Arity(op)). The single definition used by
/// constant folding, the tape and the derivative checker.
double EvaluateOp(Op op, const double* a);

}  // namespace graybox::expr
