// Expr: a scalar node of the symbolic expression graph.
//
// An Expr is a cheap, immutable, reference-counted handle to a node: a constant, a named symbol,
// or an operation (see ops.h) applied to other nodes. Nodes are hash-consed ("structural
// hashing"): building the same operation on the same arguments twice returns the same node, so
// identical subexpressions are shared and a graph is a DAG. Commutative operations order their
// arguments canonically, so a+b and b+a are one node.
//
// Construction simplifies as it goes:
//   - an operation on constants only is folded to a constant (IEEE semantics, NaN included);
//   - x+0, 0+x, x-0, x*1, 1*x, x/1, -(-x), pow(x,1) become x; pow(x,0) becomes 1;
//   - x*0, 0*x, 0/x and x-x become the constant 0, and if_else(c,a,a) becomes a.
// NaN semantics: the last line is not IEEE-exact when x evaluates to NaN or +-Inf (IEEE gives NaN).
// It is what makes derivative sparsity structural (a zero seed stays an exact zero), and it is the
// convention of every symbolic AD tool. Non-finite values are not hidden: Function evaluation
// checks every output and reports NaN/Inf to the caller (see function.h).
//
// Thread safety: Exprs may be created and destroyed from several threads at once (the hash-consing
// table is guarded by a mutex). A single Expr object is as thread-safe as a std::shared_ptr.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "graybox/expr/ops.h"

namespace graybox::expr {

namespace internal {
struct Node;
}

class Expr {
 public:
  /// The constant 0.
  Expr();
  /// A constant (implicit, so `x * 2.0` and `Expr e = 1.5` work).
  Expr(double value);                                    // NOLINT(google-explicit-constructor)
  Expr(int value) : Expr(static_cast<double>(value)) {}  // NOLINT

  /// A new free symbol. Every call creates a distinct symbol, even with an equal name.
  static Expr Symbol(const std::string& name);
  /// `n` new symbols named name_0 ... name_{n-1}.
  static std::vector<Expr> Symbols(const std::string& name, int n);

  /// Builds `op` on `args` (simplifying and hash-consing). Throws std::invalid_argument when the
  /// number of arguments differs from Arity(op) or op is kConstant/kSymbol.
  static Expr Make(Op op, const std::vector<Expr>& args);

  Op op() const;
  bool IsConstant() const { return op() == Op::kConstant; }
  bool IsSymbol() const { return op() == Op::kSymbol; }
  /// True when this is the constant `v` (exact comparison).
  bool IsConstant(double v) const;
  bool IsZero() const { return IsConstant(0.0); }
  bool IsOne() const { return IsConstant(1.0); }
  /// The value of a constant; throws std::logic_error for other nodes.
  double Value() const;
  /// Name of a symbol; empty for other nodes.
  const std::string& Name() const;
  int NumArgs() const { return Arity(op()); }
  /// Argument i (0 <= i < NumArgs()).
  Expr Arg(int i) const;
  /// Unique id of the node (identical subexpressions share an id).
  std::uint64_t Id() const;
  /// True when both handles point to the same node.
  bool IsSame(const Expr& other) const { return node_ == other.node_; }
  /// True when the expression contains at least one symbol.
  bool DependsOnSymbols() const;
  /// Number of distinct nodes reachable from this expression (itself included).
  std::size_t CountNodes() const;
  /// Infix rendering with shared subexpressions expanded (for small expressions and messages).
  /// Safe on any graph: it does not recurse, and stops with "..." after 65536 characters.
  std::string ToString() const;

  Expr& operator+=(const Expr& b);
  Expr& operator-=(const Expr& b);
  Expr& operator*=(const Expr& b);
  Expr& operator/=(const Expr& b);

  // Internal access for the graph algorithms.
  const internal::Node* node() const { return node_.get(); }
  explicit Expr(std::shared_ptr<const internal::Node> node) : node_(std::move(node)) {}

 private:
  std::shared_ptr<const internal::Node> node_;
};

std::ostream& operator<<(std::ostream& os, const Expr& e);

Expr operator+(const Expr& a, const Expr& b);
Expr operator-(const Expr& a, const Expr& b);
Expr operator*(const Expr& a, const Expr& b);
Expr operator/(const Expr& a, const Expr& b);
Expr operator-(const Expr& a);
inline Expr operator+(const Expr& a) { return a; }

/// Known equality, for generic code and for Eigen, whose matrix products need `Scalar == Scalar`
/// (e.g. `imag(alpha) == RealScalar(0)`): true when `a` and `b` are the same node, or constants of
/// equal value (as doubles: -0 == 0, NaN != NaN). Distinct symbols compare unequal even though
/// their values may coincide. It does not build a comparison node; eq(a, b) does.
bool operator==(const Expr& a, const Expr& b);
bool operator!=(const Expr& a, const Expr& b);

// Elementary functions (found by argument-dependent lookup, so Eigen and generic code use them).
Expr pow(const Expr& x, const Expr& y);
Expr sqrt(const Expr& x);
Expr exp(const Expr& x);
Expr log(const Expr& x);
Expr sin(const Expr& x);
Expr cos(const Expr& x);
Expr tan(const Expr& x);
Expr atan(const Expr& x);
Expr atan2(const Expr& y, const Expr& x);
Expr tanh(const Expr& x);
Expr abs(const Expr& x);
Expr fabs(const Expr& x);
Expr erf(const Expr& x);
Expr min(const Expr& a, const Expr& b);
Expr max(const Expr& a, const Expr& b);
/// x*x.
Expr square(const Expr& x);
/// Logistic function 1/(1+exp(-x)), evaluated without overflow.
Expr sigmoid(const Expr& x);
/// log(1+exp(x)), evaluated without overflow; derivative sigmoid(x).
Expr softplus(const Expr& x);
/// -1, 0 or +1.
Expr sign(const Expr& x);

// Smooth variants with a width w > 0 (units of x). They approach the exact function as w -> 0.
// Defined once as templates (internal::Smooth*) and offered for Expr and for double, so generic
// model code calls the same function on both.
namespace internal {
template <typename T>
T SmoothAbs(const T& x, const T& w) {
  using std::sqrt;
  return sqrt(x * x + w * w) - w;
}
template <typename T>
T SmoothSign(const T& x, const T& w) {
  using std::tanh;
  return tanh(x / w);
}
template <typename T>
T SmoothMax(const T& a, const T& b, const T& w) {
  using std::sqrt;
  const T d = a - b;
  return 0.5 * (a + b + sqrt(d * d + w * w));
}
template <typename T>
T SmoothMin(const T& a, const T& b, const T& w) {
  using std::sqrt;
  const T d = a - b;
  return 0.5 * (a + b - sqrt(d * d + w * w));
}
}  // namespace internal

/// sqrt(x^2 + w^2) - w: equals 0 at x = 0, |x| - w + O(w^2/|x|) far from 0, slope tanh-like.
inline Expr smooth_abs(const Expr& x, const Expr& w) { return internal::SmoothAbs(x, w); }
inline double smooth_abs(double x, double w) { return internal::SmoothAbs(x, w); }
/// tanh(x/w): slope 1/w at 0.
inline Expr smooth_sign(const Expr& x, const Expr& w) { return internal::SmoothSign(x, w); }
inline double smooth_sign(double x, double w) { return internal::SmoothSign(x, w); }
/// (a + b + sqrt((a-b)^2 + w^2))/2: >= max(a, b), within w/2 of it.
inline Expr smooth_max(const Expr& a, const Expr& b, const Expr& w) {
  return internal::SmoothMax(a, b, w);
}
inline double smooth_max(double a, double b, double w) { return internal::SmoothMax(a, b, w); }
/// (a + b - sqrt((a-b)^2 + w^2))/2: <= min(a, b), within w/2 of it.
inline Expr smooth_min(const Expr& a, const Expr& b, const Expr& w) {
  return internal::SmoothMin(a, b, w);
}
inline double smooth_min(double a, double b, double w) { return internal::SmoothMin(a, b, w); }

// The table operations without a std:: counterpart, on doubles, with the exact values of the op
// table (so generic code gives bit-identical results on double and through a Function).
double sigmoid(double x);
double softplus(double x);
double sign(double x);

// Comparisons and logic give 1.0 (true) or 0.0 (false).
Expr lt(const Expr& a, const Expr& b);
Expr le(const Expr& a, const Expr& b);
Expr gt(const Expr& a, const Expr& b);
Expr ge(const Expr& a, const Expr& b);
Expr eq(const Expr& a, const Expr& b);
Expr ne(const Expr& a, const Expr& b);
Expr logical_and(const Expr& a, const Expr& b);
Expr logical_or(const Expr& a, const Expr& b);
Expr logical_not(const Expr& a);
/// a when c != 0, else b. Only the taken branch contributes to derivatives, but a non-finite
/// partial in the untaken branch still propagates as 0 * NaN: see ops.h for the guard idiom.
Expr if_else(const Expr& c, const Expr& a, const Expr& b);

/// Replaces every occurrence of symbols `from[i]` by `to[i]` in `exprs` (sizes must match; every
/// `from` entry must be a symbol). Shared subexpressions stay shared.
std::vector<Expr> Substitute(const std::vector<Expr>& exprs, const std::vector<Expr>& from,
                             const std::vector<Expr>& to);

/// The distinct symbols the expressions depend on, in order of first appearance (depth first).
std::vector<Expr> FreeSymbols(const std::vector<Expr>& exprs);

/// Number of distinct nodes reachable from `exprs`.
std::size_t CountNodes(const std::vector<Expr>& exprs);

}  // namespace graybox::expr
