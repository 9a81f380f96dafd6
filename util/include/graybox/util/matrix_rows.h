// Rows of Eigen matrices that may have no columns (an experiment without inputs, a model
// without states): Eigen's m.row(k) of such a matrix offsets its null data pointer, which is
// undefined behaviour even though nothing is read. Every layer takes such rows through here.
#pragma once

#include <Eigen/Core>

namespace graybox::util {

/// Row k of m as a column vector (size m.cols()); an empty vector when m has no columns.
/// Precondition: 0 <= k < m.rows() when m has columns.
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, 1> RowAsVector(
    const Eigen::MatrixBase<Derived>& m, Eigen::Index k) {
  if (m.cols() == 0) return {};
  return m.row(k).transpose();
}

/// Copies row `from` of src into row `to` of dst (same number of columns); nothing when the
/// matrices have no columns.
template <typename Dst, typename Src>
void CopyRow(const Eigen::MatrixBase<Src>& src, Eigen::Index from, Eigen::MatrixBase<Dst>& dst,
             Eigen::Index to) {
  if (src.cols() == 0) return;
  dst.row(to) = src.row(from);
}

}  // namespace graybox::util
