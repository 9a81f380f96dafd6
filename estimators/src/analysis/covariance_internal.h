// Private helpers shared by covariance.cc (the covariance from a Jacobian or an information
// matrix, the identifiability analysis, the reports) and nlp_covariance.cc (NlpCovariance of an
// Nlp or a shooting problem, SimulationCovariance). Not installed.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/analysis/covariance.h"
#include "graybox/models/model.h"

namespace graybox::estimators::internal {

/// `v` with 3 significant digits ("%.3g"), for messages.
std::string Num(double v);

/// Throws std::invalid_argument ("<where>: expected free indices in [0, n), got i") unless every
/// free index names one of `parameters`.
void CheckFreeIndices(const std::vector<models::ModelParameter>& parameters,
                      const std::vector<int>& free_indices, const char* where);

/// Throws std::invalid_argument naming `where` unless `channel` has `rows` entries, each >= 0
/// except on the rows marked in `ignored` (may be null).
void CheckChannels(const std::vector<int>& channel, std::size_t rows, const char* where,
                   const std::vector<char>* ignored = nullptr);

/// A report that says why no covariance was computed (ok = false, failure = "the covariance could
/// not be computed because <reason>"): every free parameter has NaN errors.
UncertaintyReport Failed(const std::string& reason,
                         const std::vector<models::ModelParameter>& parameters,
                         const std::vector<int>& free_indices, int num_residuals);

/// The covariance from the effective Jacobian g = dr/dtheta (nuisance eliminated, N x nf,
/// parameter units) and the residuals r that estimate the noise, with `dof` = N - n_eff.
/// `channel` is empty (pooled variance) or has one entry >= 0 per row. reference[i] is the size
/// of the terms whose difference column i of g is (|J_theta_i| and |J_n Y_n_i|): a column that the
/// elimination of the nuisance variables shrank below reference / sqrt(max_condition) holds no
/// information but rounding errors, and is zeroed (the parameter is confounded with the nuisance
/// variables).
UncertaintyReport FromEffectiveJacobian(Eigen::MatrixXd g, const Eigen::VectorXd& reference,
                                        const Eigen::VectorXd& r, double dof,
                                        const std::vector<int>& channel,
                                        const std::vector<models::ModelParameter>& parameters,
                                        const std::vector<int>& free_indices,
                                        const CovarianceOptions& options);

/// The first non-finite entry of a dense matrix in row-major order (earliest row first): true and
/// its position, or false when every entry is finite.
template <typename M>
bool FirstNonFinite(const Eigen::MatrixBase<M>& m, Eigen::Index* row, Eigen::Index* col) {
  if (m.allFinite()) return false;
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      if (!std::isfinite(m(r, c))) {
        *row = r;
        *col = c;
        return true;
      }
    }
  }
  return false;
}

}  // namespace graybox::estimators::internal
