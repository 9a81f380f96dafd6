// Shared helpers of the libexpr tests: the operation list, random expression trees with domain
// guards, node traversal and exception-message checks.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <iostream>
#include <random>
#include <set>
#include <string>
#include <unordered_set>
#include <vector>

#include "graybox/expr.h"

namespace graybox::expr::testing {

/// Every operation of GRAYBOX_EXPR_OPS except the leaves (constants and symbols), in table order.
/// Built from kNumOps, so an operation added to the table shows up here automatically.
inline std::vector<Op> AllOperations() {
  std::vector<Op> ops;
  for (int k = 0; k < kNumOps; ++k) {
    const Op op = static_cast<Op>(k);
    if (op != Op::kConstant && op != Op::kSymbol) ops.push_back(op);
  }
  return ops;
}

/// The set of operations occurring in the graphs below `exprs` (leaves excluded), found through the
/// public Arg() interface so it does not depend on library internals.
inline std::set<Op> OperationsIn(const std::vector<Expr>& exprs) {
  std::set<Op> ops;
  std::unordered_set<std::uint64_t> seen;
  std::vector<Expr> stack(exprs.begin(), exprs.end());
  while (!stack.empty()) {
    const Expr e = stack.back();
    stack.pop_back();
    if (!seen.insert(e.Id()).second) continue;
    if (!e.IsConstant() && !e.IsSymbol()) ops.insert(e.op());
    for (int i = 0; i < e.NumArgs(); ++i) stack.push_back(e.Arg(i));
  }
  return ops;
}

/// Random expression trees over a fixed set of symbols, using every operation of the table.
/// Arguments are guarded so every value stays finite and every derivative defined for symbol
/// values in about [-2, 2]: log/sqrt of 1/4 + a^2, division by 1 + b^2, exp of sin(a), tan of
/// tanh(a), atan2 with a positive second argument (away from the branch cut), pow of a positive
/// base with a bounded exponent or of any base with an integer exponent.
class RandomTrees {
 public:
  RandomTrees(std::vector<Expr> symbols, std::uint32_t seed)
      : symbols_(std::move(symbols)), rng_(seed), ops_(AllOperations()) {}

  /// A tree of at most `depth` operation levels (guards add a few nodes).
  Expr Generate(int depth) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    if (depth <= 0 || u(rng_) < 0.15) return Leaf();
    const Op op =
        ops_[std::uniform_int_distribution<int>(0, static_cast<int>(ops_.size()) - 1)(rng_)];
    std::vector<Expr> args;
    for (int i = 0; i < Arity(op); ++i) args.push_back(Generate(depth - 1));
    return Guarded(op, std::move(args));
  }

  /// Applies `op` to `args` after the domain guards described above.
  Expr Guarded(Op op, std::vector<Expr> a) {
    switch (op) {
      case Op::kDiv:
        a[1] = 1.0 + a[1] * a[1];
        break;
      case Op::kPow:
        if (std::uniform_int_distribution<int>(0, 1)(rng_) == 0) {
          a[0] = 0.5 + a[0] * a[0];
          a[1] = 2.0 * tanh(a[1]);
        } else {
          a[1] = Expr(static_cast<double>(std::uniform_int_distribution<int>(2, 3)(rng_)));
        }
        break;
      case Op::kSqrt:
      case Op::kLog:
        a[0] = 0.25 + a[0] * a[0];
        break;
      case Op::kExp:
        a[0] = sin(a[0]);
        break;
      case Op::kTan:
        a[0] = tanh(a[0]);
        break;
      case Op::kAtan2:
        a[1] = 0.5 + a[1] * a[1];
        break;
      default:
        break;
    }
    return Expr::Make(op, a);
  }

  std::mt19937& rng() { return rng_; }

 private:
  Expr Leaf() {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    if (symbols_.empty() || u(rng_) < 0.2) {
      // Quarter-integers in [-2, 2]: exact 0, 1 and -1 occur and exercise the simplifications.
      return Expr(0.25 * std::uniform_int_distribution<int>(-8, 8)(rng_));
    }
    return symbols_[std::uniform_int_distribution<int>(
        0, static_cast<int>(symbols_.size()) - 1)(rng_)];
  }

  std::vector<Expr> symbols_;
  std::mt19937 rng_;
  std::vector<Op> ops_;
};

/// A std::mt19937 seeded with `seed`; the seed is printed so a failure can be replayed.
inline std::mt19937 SeededRng(std::uint32_t seed) {
  std::cout << "[   SEED   ] " << seed << std::endl;
  return std::mt19937(seed);
}

/// A vector of `n` values uniform in [lo, hi].
inline Eigen::VectorXd RandomVector(std::mt19937* rng, int n, double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = u(*rng);
  return v;
}

/// Runs `fn`, expects an exception of type E whose what() contains every string of `parts`.
template <typename E>
void ExpectThrowsWith(const std::function<void()>& fn, const std::vector<std::string>& parts) {
  try {
    fn();
    ADD_FAILURE() << "expected an exception, none was thrown";
  } catch (const E& e) {
    const std::string what = e.what();
    for (const std::string& p : parts) {
      EXPECT_NE(what.find(p), std::string::npos)
          << "message '" << what.substr(0, 300) << (what.size() > 300 ? "..." : "") << "' lacks '"
          << p << "'";
    }
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type, message: " << e.what();
  }
}

/// Densifies the nonzeros `nz` of pattern `sp`.
inline Eigen::MatrixXd Densify(const Sparsity& sp, const Eigen::VectorXd& nz) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(sp.rows(), sp.cols());
  const std::vector<int> col = sp.ColumnOfNonzeros();
  for (int k = 0; k < sp.nnz(); ++k) m(sp.row()[k], col[k]) = nz[k];
  return m;
}

}  // namespace graybox::expr::testing
