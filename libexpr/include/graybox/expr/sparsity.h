// Sparsity: the structural nonzero pattern of a matrix in compressed column storage (CCS).
//
// Nonzeros are ordered column by column, rows ascending within a column; `colind` has ncol+1
// entries and `row` has nnz entries. A dense column vector of size n is Dense(n, 1). Functions
// carry a Sparsity per output: a sparse Jacobian output holds exactly the nnz values in this order.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace graybox::expr {

class Sparsity {
 public:
  Sparsity() = default;
  /// From CCS arrays. Throws std::invalid_argument with the offending index when the arrays are
  /// inconsistent (sizes, non-monotone colind, rows out of range or not strictly ascending).
  Sparsity(int nrow, int ncol, std::vector<int> colind, std::vector<int> row);

  static Sparsity Dense(int nrow, int ncol);
  /// From (row, col) pairs in any order; duplicates are merged.
  static Sparsity FromTriplets(int nrow, int ncol, const std::vector<std::pair<int, int>>& rc);

  int rows() const { return nrow_; }
  int cols() const { return ncol_; }
  int nnz() const { return static_cast<int>(row_.size()); }
  bool IsDense() const { return nnz() == nrow_ * ncol_; }
  const std::vector<int>& colind() const { return colind_; }
  const std::vector<int>& row() const { return row_; }
  /// Column index of every nonzero (same order as row()).
  std::vector<int> ColumnOfNonzeros() const;
  /// True when (i, j) is a structural nonzero.
  bool Has(int i, int j) const;
  /// Index of (i, j) among the nonzeros, or -1.
  int Find(int i, int j) const;
  Sparsity Transpose() const;
  /// Entries with row >= col only (for Ipopt's lower-triangular Hessian).
  Sparsity LowerTriangle() const;
  /// Rendering with '*' for nonzeros and '.' for structural zeros (for small patterns).
  std::string ToString() const;
  bool operator==(const Sparsity& o) const {
    return nrow_ == o.nrow_ && ncol_ == o.ncol_ && colind_ == o.colind_ && row_ == o.row_;
  }
  bool operator!=(const Sparsity& o) const { return !(*this == o); }

 private:
  int nrow_ = 0;
  int ncol_ = 0;
  std::vector<int> colind_{0};
  std::vector<int> row_;
};

/// A partition of the columns of `pattern` into groups ("colours") in which no two columns share
/// a row, so one directional derivative per colour recovers every nonzero (Curtis-Powell-Reid).
/// Greedy, columns visited by decreasing nonzero count. Returns colour per column.
std::vector<int> ColorColumns(const Sparsity& pattern, int* num_colors);

/// A star colouring of the columns of a symmetric pattern (diagonal ignored): a distance-1
/// colouring in which every path on four vertices uses at least three colours (greedy algorithm of
/// Gebremedhin, Manne and Pothen, SIAM Review 2005, Alg. 4.1). One Hessian-vector product per
/// colour then determines every nonzero of a symmetric matrix directly: an arrowhead pattern
/// (parameters coupled to all states) needs 2 colours where column colouring needs n.
std::vector<int> StarColorSymmetric(const Sparsity& pattern, int* num_colors);

}  // namespace graybox::expr
