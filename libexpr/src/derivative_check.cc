#include "graybox/expr/derivative_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace graybox::expr {

std::string DerivativeCheckResult::BriefReport() const {
  std::ostringstream os;
  os.precision(3);
  os << "derivative check of " << what << ": " << (ok ? "OK" : "FAILED") << ", max error "
     << std::scientific << max_error << " over " << entries_checked << " entries (" << rows << "x"
     << cols << ")";
  return os.str();
}

std::string DerivativeCheckResult::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  os.precision(10);
  for (const auto& e : worst) {
    os << "  (" << e.row << ", " << e.col << ") analytic " << e.analytic << "  finite difference "
       << e.finite_difference << "  error " << std::scientific << e.error << std::defaultfloat
       << "\n";
  }
  return os.str();
}

DerivativeCheckResult CheckJacobianValues(const std::string& what, const VectorFunction& f,
                                          const Eigen::VectorXd& x,
                                          const Eigen::SparseMatrix<double>& analytic,
                                          const std::vector<int>& columns,
                                          const DerivativeCheckOptions& options) {
  const Eigen::Index n = x.size();
  if (analytic.cols() != n) {
    throw std::invalid_argument("CheckJacobianValues (" + what + "): expected an analytic matrix " +
                                "with " + std::to_string(n) + " columns, got " +
                                std::to_string(analytic.cols()));
  }
  const int m = static_cast<int>(analytic.rows());
  std::vector<int> cols = columns;
  if (cols.empty()) {
    for (int j = 0; j < n; ++j) cols.push_back(j);
  }
  for (int j : cols) {
    if (j < 0 || j >= n) {
      throw std::invalid_argument("CheckJacobianValues (" + what + "): column " +
                                  std::to_string(j) + " outside [0, " + std::to_string(n) + ")");
    }
  }
  DerivativeCheckResult result;
  result.what = what;
  result.rows = m;
  result.cols = static_cast<int>(n);
  std::vector<DerivativeCheckEntry> all;
  std::vector<double> steps(static_cast<std::size_t>(n), 1.0), value_scale(m, 0.0);
  Eigen::VectorXd xs = x, fp, fm;
  std::vector<double> uncertainty;  // per entry, |D(h) - D(h/2)|
  // Central difference along column j at step h (fills fp, fm); returns the step actually taken.
  auto central = [&](int j, double h) {
    const double x0 = x[j];
    xs[j] = x0 + h;
    const bool ok_p = f(xs, &fp);
    xs[j] = x0 - h;
    const bool ok_m = f(xs, &fm);
    xs[j] = x0;
    if (!ok_p || !ok_m || fp.size() != m || fm.size() != m) {
      throw std::runtime_error("CheckJacobianValues (" + what +
                               "): the function failed or changed size at a step of column " +
                               std::to_string(j));
    }
    for (int i = 0; i < m; ++i) {
      value_scale[i] = std::max({value_scale[i], std::fabs(fp[i]), std::fabs(fm[i])});
    }
    return (x0 + h) - (x0 - h);
  };
  for (int j : cols) {
    const double h = options.relative_step * std::max(1.0, std::fabs(x[j]));
    const double step = central(j, h);
    const Eigen::VectorXd d1 = (fp - fm) / step;
    const double half_step = central(j, 0.5 * h);
    const Eigen::VectorXd d2 = (fp - fm) / half_step;
    steps[static_cast<std::size_t>(j)] = half_step;
    const Eigen::VectorXd exact = analytic.col(j);
    for (int i = 0; i < m; ++i) {
      DerivativeCheckEntry e;
      e.row = i;
      e.col = j;
      e.analytic = exact[i];
      e.finite_difference = d2[i] + (d2[i] - d1[i]) / 3.0;  // Richardson: O(h^4)
      all.push_back(e);
      uncertainty.push_back(std::fabs(d2[i] - d1[i]));
    }
  }
  // Scale-free errors (see the header): relative to the entry, floored by a fraction of its row.
  // The row scale covers the whole analytic row, also the columns not differenced.
  std::vector<double> row_scale(m, 0.0);
  for (int k = 0; k < analytic.outerSize(); ++k) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(analytic, k); it; ++it) {
      row_scale[it.row()] = std::max(row_scale[it.row()], std::fabs(it.value()));
    }
  }
  for (const auto& e : all) {
    row_scale[e.row] =
        std::max({row_scale[e.row], std::fabs(e.analytic), std::fabs(e.finite_difference)});
  }
  constexpr double kEps = std::numeric_limits<double>::epsilon();
  for (std::size_t k = 0; k < all.size(); ++k) {
    DerivativeCheckEntry& e = all[k];
    const double noise =
        options.noise_factor * kEps * value_scale[e.row] / steps[static_cast<std::size_t>(e.col)] +
        options.uncertainty_factor * uncertainty[k];
    const double denominator =
        std::max({std::fabs(e.analytic), std::fabs(e.finite_difference),
                  options.row_floor * row_scale[e.row], std::numeric_limits<double>::min()}) +
        noise / options.tolerance;
    e.error = std::fabs(e.analytic - e.finite_difference) / denominator;
    result.max_error = std::max(result.max_error, e.error);
  }
  result.entries_checked = static_cast<int>(all.size());
  result.ok = result.max_error <= options.tolerance;
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.error > b.error; });
  all.resize(std::min<std::size_t>(all.size(), std::max(0, options.max_reported)));
  result.worst = std::move(all);
  return result;
}

DerivativeCheckResult CheckDerivative(const Function& f, const std::string& output,
                                      const std::string& input, const Function& df,
                                      const std::string& df_output,
                                      const std::vector<Eigen::VectorXd>& point,
                                      const DerivativeCheckOptions& options) {
  const int jo = f.OutputIndex(output);
  const int ji = f.InputIndex(input);
  const int jdo = df.OutputIndex(df_output);
  const Sparsity& sp = df.OutputSparsity(jdo);
  const int m = f.OutputSize(jo);
  const int n = f.InputSize(ji);
  if (sp.rows() != m || sp.cols() != n) {
    throw std::invalid_argument("CheckDerivative: expected '" + df_output + "' of shape " +
                                std::to_string(m) + "x" + std::to_string(n) + ", got " +
                                std::to_string(sp.rows()) + "x" + std::to_string(sp.cols()));
  }
  // Analytic values as a sparse matrix (the pattern's entries; elsewhere structural zeros, which
  // are checked too).
  const Eigen::VectorXd nz = df(point)[jdo];
  const std::vector<int> col = sp.ColumnOfNonzeros();
  std::vector<Eigen::Triplet<double>> triplets;
  for (int k = 0; k < sp.nnz(); ++k) triplets.emplace_back(sp.row()[k], col[k], nz[k]);
  Eigen::SparseMatrix<double> analytic(m, n);
  analytic.setFromTriplets(triplets.begin(), triplets.end());
  const VectorFunction along_input = [&](const Eigen::VectorXd& v, Eigen::VectorXd* out) {
    std::vector<Eigen::VectorXd> x = point;
    x[ji] = v;
    *out = f(x)[jo];
    return true;
  };
  return CheckJacobianValues("d " + f.name() + "." + output + " / d " + input, along_input,
                             point[ji], analytic, {}, options);
}

DerivativeCheckResult CheckJacobian(const Function& f, const std::string& output,
                                    const std::string& input,
                                    const std::vector<Eigen::VectorXd>& point,
                                    const DerivativeCheckOptions& options) {
  const Function jac = f.Jacobian(output, input);
  return CheckDerivative(f, output, input, jac, jac.OutputName(0), point, options);
}

DerivativeCheckResult CheckHessian(const Function& f, const std::string& output,
                                   const std::string& input,
                                   const std::vector<Eigen::VectorXd>& point,
                                   const DerivativeCheckOptions& options) {
  const Function grad = f.Gradient(output, input);
  const Function hess = f.Hessian(output, input);
  return CheckDerivative(grad, grad.OutputName(0), input, hess, hess.OutputName(0), point, options);
}

}  // namespace graybox::expr
