#include "graybox/estimators/nlp/nlp_check.h"

#include <random>
#include <stdexcept>
#include <string>

namespace graybox::estimators {

namespace {

using expr::VectorFunction;

Eigen::SparseMatrix<double> FromTriplets(int rows, int cols, const std::vector<int>& r,
                                         const std::vector<int>& c, const std::vector<double>& v) {
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(v.size());
  for (std::size_t k = 0; k < v.size(); ++k) t.emplace_back(r[k], c[k], v[k]);
  Eigen::SparseMatrix<double> m(rows, cols);
  m.setFromTriplets(t.begin(), t.end());  // duplicates are summed, as the solvers do
  return m;
}

void Require(const NlpEvalStatus& s, const std::string& what) {
  if (!s.ok) throw std::runtime_error("CheckNlpDerivatives: " + what + " failed: " + s.message);
}

std::vector<int> Columns(int n, const NlpDerivativeCheckOptions& o) {
  std::vector<int> cols;
  const int lead = std::min(n, std::max(0, o.leading_columns));
  for (int j = 0; j < lead; ++j) cols.push_back(j);
  const int rest = n - lead;
  const int extra = std::min(rest, std::max(0, o.sampled_columns));
  for (int k = 0; k < extra; ++k) {
    cols.push_back(lead + static_cast<int>(static_cast<long>(k) * rest / extra));
  }
  return cols;
}

}  // namespace

std::vector<expr::DerivativeCheckResult> CheckNlpDerivatives(
    const Nlp& nlp, const Eigen::VectorXd& w, const NlpDerivativeCheckOptions& options) {
  const int n = nlp.NumVariables();
  if (w.size() != n) {
    throw std::invalid_argument("CheckNlpDerivatives: expected a point of " + std::to_string(n) +
                                " variables, got " + std::to_string(w.size()));
  }
  const std::vector<int> cols = Columns(n, options);
  std::vector<expr::DerivativeCheckResult> out;
  const int nr = nlp.NumResiduals(), nc = nlp.NumConstraints();

  if (nr > 0) {
    std::vector<double> v(nlp.ResidualJacobianRows().size());
    Require(nlp.ResidualJacobianValues(w.data(), v.data()), "residual Jacobian");
    const VectorFunction r = [&](const Eigen::VectorXd& x, Eigen::VectorXd* value) {
      value->resize(nr);
      return nlp.Residuals(x.data(), value->data()).ok;
    };
    out.push_back(expr::CheckJacobianValues(
        "d r / d w (residuals)", r, w,
        FromTriplets(nr, n, nlp.ResidualJacobianRows(), nlp.ResidualJacobianCols(), v), cols,
        options.check));
  }
  std::vector<double> jac_values(nlp.JacobianRows().size());
  if (nc > 0) {
    Require(nlp.JacobianValues(w.data(), jac_values.data()), "constraint Jacobian");
    const VectorFunction g = [&](const Eigen::VectorXd& x, Eigen::VectorXd* value) {
      value->resize(nc);
      return nlp.Constraints(x.data(), value->data()).ok;
    };
    out.push_back(expr::CheckJacobianValues(
        "d g / d w (constraints)", g, w,
        FromTriplets(nc, n, nlp.JacobianRows(), nlp.JacobianCols(), jac_values), cols,
        options.check));
  }
  Eigen::VectorXd grad(n);
  Require(nlp.Gradient(w.data(), grad.data()), "objective gradient");
  const VectorFunction f = [&](const Eigen::VectorXd& x, Eigen::VectorXd* value) {
    value->resize(1);
    return nlp.Objective(x.data(), value->data()).ok;
  };
  out.push_back(expr::CheckJacobianValues(
      "d f / d w (objective gradient)", f, w,
      Eigen::SparseMatrix<double>(grad.transpose().sparseView()), cols, options.check));

  if (!nlp.residual_blocks().empty()) return out;  // Gauss-Newton Hessian by design
  std::mt19937 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd lambda(nc);
  for (int i = 0; i < nc; ++i) lambda[i] = normal(rng);
  // The exact gradient of the Lagrangian, grad f + J_g^T lambda.
  const VectorFunction lagrangian_gradient = [&](const Eigen::VectorXd& x, Eigen::VectorXd* value) {
    value->resize(n);
    if (!nlp.Gradient(x.data(), value->data()).ok) return false;
    if (nc == 0) return true;
    std::vector<double> jv(nlp.JacobianRows().size());
    if (!nlp.JacobianValues(x.data(), jv.data()).ok) return false;
    for (std::size_t k = 0; k < jv.size(); ++k) {
      (*value)[nlp.JacobianCols()[k]] += jv[k] * lambda[nlp.JacobianRows()[k]];
    }
    return true;
  };
  std::vector<double> h(nlp.HessianRows().size());
  Require(nlp.HessianValues(w.data(), 1.0, lambda.data(), h.data()), "Hessian of the Lagrangian");
  const Eigen::SparseMatrix<double> lower =
      FromTriplets(n, n, nlp.HessianRows(), nlp.HessianCols(), h);
  Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  out.push_back(expr::CheckJacobianValues("d2 L / d w2 (Hessian of the Lagrangian)",
                                          lagrangian_gradient, w, full, cols, options.check));
  return out;
}

}  // namespace graybox::estimators
