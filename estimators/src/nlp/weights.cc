#include "graybox/estimators/nlp/weights.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace graybox::estimators {

Eigen::VectorXd InverseStdWeights(const std::vector<const Eigen::MatrixXd*>& blocks) {
  if (blocks.empty()) return Eigen::VectorXd();
  const Eigen::Index n = blocks.front()->cols();
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(n), sum2 = Eigen::VectorXd::Zero(n);
  double count = 0.0;
  for (const Eigen::MatrixXd* b : blocks) {
    if (b->cols() != n) {
      throw std::invalid_argument("InverseStdWeights: expected blocks with " + std::to_string(n) +
                                  " columns, got " + std::to_string(b->cols()));
    }
    sum += b->colwise().sum().transpose();
    sum2 += b->colwise().squaredNorm().transpose();
    count += static_cast<double>(b->rows());
  }
  Eigen::VectorXd w = Eigen::VectorXd::Ones(n);
  if (count == 0.0) return w;
  for (Eigen::Index j = 0; j < n; ++j) {
    const double mean = sum[j] / count;
    const double var = std::max(0.0, sum2[j] / count - mean * mean);
    if (var > 0.0) w[j] = 1.0 / std::sqrt(var);
  }
  return w;
}

}  // namespace graybox::estimators
