// Eigen interoperability: Eigen::Matrix<Expr, ...> works (sums, products, transposes, blocks), and
// small dense symbolic solves let M(q)^-1 * b live inside a graph.
//
//   ExprMatrix M = ...;           // symmetric positive definite mass matrix, entries are Exprs
//   ExprVector qdd = SolveSpd(M, tau - h);
//
// Structural zeros are exploited automatically: products with the constant 0 fold away, so a
// banded or block-diagonal matrix yields a correspondingly small graph.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "graybox/expr/expr.h"

namespace Eigen {
template <>
struct NumTraits<graybox::expr::Expr> : GenericNumTraits<double> {
  using Real = graybox::expr::Expr;
  using NonInteger = graybox::expr::Expr;
  using Nested = graybox::expr::Expr;
  using Literal = graybox::expr::Expr;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 1,
    ReadCost = 1,
    AddCost = 1,
    MulCost = 1
  };
  static inline Real epsilon() { return Real(NumTraits<double>::epsilon()); }
  static inline Real dummy_precision() { return Real(NumTraits<double>::dummy_precision()); }
  static inline Real highest() { return Real(NumTraits<double>::highest()); }
  static inline Real lowest() { return Real(NumTraits<double>::lowest()); }
  static inline int digits10() { return NumTraits<double>::digits10(); }
};

// Products of Expr with double scalars.
template <typename BinaryOp>
struct ScalarBinaryOpTraits<graybox::expr::Expr, double, BinaryOp> {
  using ReturnType = graybox::expr::Expr;
};
template <typename BinaryOp>
struct ScalarBinaryOpTraits<double, graybox::expr::Expr, BinaryOp> {
  using ReturnType = graybox::expr::Expr;
};
}  // namespace Eigen

namespace graybox::expr {

using ExprMatrix = Eigen::Matrix<Expr, Eigen::Dynamic, Eigen::Dynamic>;
using ExprVector = Eigen::Matrix<Expr, Eigen::Dynamic, 1>;

/// Conversions between Eigen vectors of Expr and the std::vector<Expr> used by Function.
std::vector<Expr> ToStdVector(const ExprVector& v);
ExprVector ToExprVector(const std::vector<Expr>& v);
/// A vector of n new symbols name_0 ... name_{n-1}.
ExprVector SymbolVector(const std::string& name, int n);
/// A matrix of constants.
ExprMatrix ToExprMatrix(const Eigen::MatrixXd& m);

/// Solves A X = B for symmetric positive definite A with a square-root-free LDL^T factorisation
/// (no pivoting, which SPD matrices do not need). Only the lower triangle of A is read.
/// Throws std::invalid_argument on size mismatch.
ExprMatrix SolveSpd(const ExprMatrix& a, const ExprMatrix& b);

/// Solves A X = B for a general square A with Doolittle LU *without pivoting*: exact whenever all
/// leading principal minors of A are nonzero at the evaluation point (e.g. diagonally dominant
/// matrices); otherwise the result is Inf/NaN, which Function evaluation reports. Pivoting cannot
/// be decided symbolically; use SolveSpd for SPD matrices.
ExprMatrix SolveLu(const ExprMatrix& a, const ExprMatrix& b);

}  // namespace graybox::expr
