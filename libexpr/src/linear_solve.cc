#include <stdexcept>
#include <string>

#include "graybox/expr/matrix.h"

namespace graybox::expr {

std::vector<Expr> ToStdVector(const ExprVector& v) { return {v.data(), v.data() + v.size()}; }

ExprVector ToExprVector(const std::vector<Expr>& v) {
  ExprVector out(static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) out[static_cast<Eigen::Index>(i)] = v[i];
  return out;
}

ExprVector SymbolVector(const std::string& name, int n) {
  return ToExprVector(Expr::Symbols(name, n));
}

ExprMatrix ToExprMatrix(const Eigen::MatrixXd& m) {
  ExprMatrix out(m.rows(), m.cols());
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) out(i, j) = Expr(m(i, j));
  }
  return out;
}

namespace {
void CheckSizes(const ExprMatrix& a, const ExprMatrix& b, const char* who) {
  if (a.rows() != a.cols()) {
    throw std::invalid_argument(std::string(who) + ": expected a square matrix, got " +
                                std::to_string(a.rows()) + "x" + std::to_string(a.cols()));
  }
  if (b.rows() != a.rows()) {
    throw std::invalid_argument(std::string(who) + ": expected a right-hand side with " +
                                std::to_string(a.rows()) + " rows, got " +
                                std::to_string(b.rows()));
  }
}
}  // namespace

ExprMatrix SolveSpd(const ExprMatrix& a, const ExprMatrix& b) {
  CheckSizes(a, b, "SolveSpd");
  const Eigen::Index n = a.rows();
  // A = L D L^T with unit lower L.
  ExprMatrix l = ExprMatrix::Constant(n, n, Expr(0.0));
  ExprVector d(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    Expr djj = a(j, j);
    for (Eigen::Index k = 0; k < j; ++k) djj -= l(j, k) * l(j, k) * d[k];
    d[j] = djj;
    l(j, j) = Expr(1.0);
    for (Eigen::Index i = j + 1; i < n; ++i) {
      Expr lij = a(i, j);
      for (Eigen::Index k = 0; k < j; ++k) lij -= l(i, k) * l(j, k) * d[k];
      l(i, j) = lij / djj;
    }
  }
  ExprMatrix x = b;
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    for (Eigen::Index i = 0; i < n; ++i) {  // L y = b
      for (Eigen::Index k = 0; k < i; ++k) x(i, c) -= l(i, k) * x(k, c);
    }
    for (Eigen::Index i = 0; i < n; ++i) x(i, c) = x(i, c) / d[i];  // D z = y
    for (Eigen::Index i = n; i-- > 0;) {                            // L^T x = z
      for (Eigen::Index k = i + 1; k < n; ++k) x(i, c) -= l(k, i) * x(k, c);
    }
  }
  return x;
}

ExprMatrix SolveLu(const ExprMatrix& a, const ExprMatrix& b) {
  CheckSizes(a, b, "SolveLu");
  const Eigen::Index n = a.rows();
  ExprMatrix lu = a;  // unit lower L below the diagonal, U on and above
  for (Eigen::Index k = 0; k < n; ++k) {
    for (Eigen::Index i = k + 1; i < n; ++i) {
      if (lu(i, k).IsZero()) continue;
      lu(i, k) = lu(i, k) / lu(k, k);
      for (Eigen::Index j = k + 1; j < n; ++j) lu(i, j) -= lu(i, k) * lu(k, j);
    }
  }
  ExprMatrix x = b;
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index k = 0; k < i; ++k) x(i, c) -= lu(i, k) * x(k, c);
    }
    for (Eigen::Index i = n; i-- > 0;) {
      for (Eigen::Index k = i + 1; k < n; ++k) x(i, c) -= lu(i, k) * x(k, c);
      x(i, c) = x(i, c) / lu(i, i);
    }
  }
  return x;
}

}  // namespace graybox::expr
