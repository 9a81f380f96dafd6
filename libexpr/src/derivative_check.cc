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
  // Analytic values, densified.
  const Eigen::VectorXd nz = df(point)[jdo];
  Eigen::MatrixXd analytic = Eigen::MatrixXd::Zero(m, n);
  const std::vector<int> col = sp.ColumnOfNonzeros();
  for (int k = 0; k < sp.nnz(); ++k) analytic(sp.row()[k], col[k]) = nz[k];

  DerivativeCheckResult result;
  result.what = "d " + f.name() + "." + output + " / d " + input;
  result.rows = m;
  result.cols = n;
  std::vector<DerivativeCheckEntry> all;
  std::vector<Eigen::VectorXd> x = point;
  std::vector<double> steps(n, 1.0), value_scale(m, 0.0);
  for (int j = 0; j < n; ++j) {
    const double x0 = point[ji][j];
    const double h = options.relative_step * std::max(1.0, std::fabs(x0));
    x[ji][j] = x0 + h;
    const Eigen::VectorXd fp = f(x)[jo];
    x[ji][j] = x0 - h;
    const Eigen::VectorXd fm = f(x)[jo];
    x[ji][j] = x0;
    const double step = (x0 + h) - (x0 - h);  // the step actually taken, after rounding
    steps[j] = step;
    for (int i = 0; i < m; ++i) {
      value_scale[i] = std::max({value_scale[i], std::fabs(fp[i]), std::fabs(fm[i])});
    }
    for (int i = 0; i < m; ++i) {
      DerivativeCheckEntry e;
      e.row = i;
      e.col = j;
      e.analytic = analytic(i, j);
      e.finite_difference = (fp[i] - fm[i]) / step;
      all.push_back(e);
    }
  }
  // Scale-free errors (see the header): relative to the entry, floored by a fraction of its row.
  std::vector<double> row_scale(m, 0.0);
  for (const auto& e : all) {
    row_scale[e.row] =
        std::max({row_scale[e.row], std::fabs(e.analytic), std::fabs(e.finite_difference)});
  }
  constexpr double kEps = std::numeric_limits<double>::epsilon();
  for (auto& e : all) {
    const double noise = options.noise_factor * kEps * value_scale[e.row] / steps[e.col];
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
