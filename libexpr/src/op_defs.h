// Private: the single definition of every operation's value and local partials.
//
// OpDef<op>::F(a) is the value on doubles (a has Arity(op) entries); OpDef<op>::D(a, f, d) writes
// the symbolic partials d[i] = d f / d a[i] given the arguments a and the node's own value f.
// Everything that evaluates or differentiates the graph goes through these definitions.
#pragma once

#include <cmath>

#include "graybox/expr/expr.h"

namespace graybox::expr::internal {

inline double SigmoidValue(double x) {
  if (x >= 0.0) return 1.0 / (1.0 + std::exp(-x));
  const double e = std::exp(x);
  return e / (1.0 + e);
}
inline double SoftplusValue(double x) {
  return std::fmax(x, 0.0) + std::log1p(std::exp(-std::fabs(x)));
}
inline double SignValue(double x) {
  return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : (x == 0.0 ? 0.0 : x));
}
inline double MinValue(double a, double b) { return a <= b ? a : (b < a ? b : a + b); }
inline double MaxValue(double a, double b) { return a >= b ? a : (b > a ? b : a + b); }

template <Op op>
struct OpDef;

#define GRAYBOX_UNARY(OP, VALUE, PARTIAL)                  \
  template <>                                              \
  struct OpDef<Op::OP> {                                   \
    static double F(const double* a) {                     \
      const double x = a[0];                               \
      return VALUE;                                        \
    }                                                      \
    static void D(const Expr* a, const Expr& f, Expr* d) { \
      const Expr& x = a[0];                                \
      (void)x;                                             \
      (void)f;                                             \
      d[0] = PARTIAL;                                      \
    }                                                      \
  };

#define GRAYBOX_BINARY(OP, VALUE, PARTIAL_X, PARTIAL_Y)    \
  template <>                                              \
  struct OpDef<Op::OP> {                                   \
    static double F(const double* a) {                     \
      const double x = a[0];                               \
      const double y = a[1];                               \
      return VALUE;                                        \
    }                                                      \
    static void D(const Expr* a, const Expr& f, Expr* d) { \
      const Expr& x = a[0];                                \
      const Expr& y = a[1];                                \
      (void)x;                                             \
      (void)y;                                             \
      (void)f;                                             \
      if (x.DependsOnSymbols()) d[0] = PARTIAL_X;          \
      if (y.DependsOnSymbols()) d[1] = PARTIAL_Y;          \
    }                                                      \
  };

// clang-format off
GRAYBOX_BINARY(kAdd, x + y, Expr(1.0), Expr(1.0))
GRAYBOX_BINARY(kSub, x - y, Expr(1.0), Expr(-1.0))
GRAYBOX_BINARY(kMul, x * y, y, x)
GRAYBOX_BINARY(kDiv, x / y, 1.0 / y, -f / y)
GRAYBOX_UNARY(kNeg, -x, Expr(-1.0))
GRAYBOX_BINARY(kPow, std::pow(x, y), y * pow(x, y - 1.0), log(x) * f)
GRAYBOX_UNARY(kSqrt, std::sqrt(x), 0.5 / f)
GRAYBOX_UNARY(kExp, std::exp(x), f)
GRAYBOX_UNARY(kLog, std::log(x), 1.0 / x)
GRAYBOX_UNARY(kSin, std::sin(x), cos(x))
GRAYBOX_UNARY(kCos, std::cos(x), -sin(x))
GRAYBOX_UNARY(kTan, std::tan(x), 1.0 + f * f)
GRAYBOX_UNARY(kAtan, std::atan(x), 1.0 / (1.0 + x * x))
GRAYBOX_BINARY(kAtan2, std::atan2(x, y), y / (x * x + y * y), -x / (x * x + y * y))
GRAYBOX_UNARY(kTanh, std::tanh(x), 1.0 - f * f)
GRAYBOX_UNARY(kSigmoid, SigmoidValue(x), f * (1.0 - f))
GRAYBOX_UNARY(kSoftplus, SoftplusValue(x), sigmoid(x))
GRAYBOX_UNARY(kAbs, std::fabs(x), sign(x))
GRAYBOX_UNARY(kSign, SignValue(x), Expr(0.0))
GRAYBOX_BINARY(kMin, MinValue(x, y), le(x, y), logical_not(le(x, y)))
GRAYBOX_BINARY(kMax, MaxValue(x, y), ge(x, y), logical_not(ge(x, y)))
GRAYBOX_UNARY(kErf, std::erf(x), 1.1283791670955126 * exp(-(x * x)))
GRAYBOX_BINARY(kLt, x < y ? 1.0 : 0.0, Expr(0.0), Expr(0.0))
GRAYBOX_BINARY(kLe, x <= y ? 1.0 : 0.0, Expr(0.0), Expr(0.0))
GRAYBOX_BINARY(kEq, x == y ? 1.0 : 0.0, Expr(0.0), Expr(0.0))
GRAYBOX_BINARY(kNe, x != y ? 1.0 : 0.0, Expr(0.0), Expr(0.0))
GRAYBOX_BINARY(kAnd, (x != 0.0 && y != 0.0) ? 1.0 : 0.0, Expr(0.0), Expr(0.0))
GRAYBOX_BINARY(kOr, (x != 0.0 || y != 0.0) ? 1.0 : 0.0, Expr(0.0), Expr(0.0))
GRAYBOX_UNARY(kNot, x == 0.0 ? 1.0 : 0.0, Expr(0.0))
// clang-format on

template <>
struct OpDef<Op::kIfElse> {
  static double F(const double* a) { return a[0] != 0.0 ? a[1] : a[2]; }
  static void D(const Expr* a, const Expr& /*f*/, Expr* d) {
    d[0] = Expr(0.0);
    if (a[1].DependsOnSymbols()) d[1] = if_else(a[0], Expr(1.0), Expr(0.0));
    if (a[2].DependsOnSymbols()) d[2] = if_else(a[0], Expr(0.0), Expr(1.0));
  }
};

#undef GRAYBOX_UNARY
#undef GRAYBOX_BINARY

}  // namespace graybox::expr::internal
