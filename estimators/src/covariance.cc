#include "graybox/estimators/covariance.h"

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "graybox/estimators/integrators.h"

namespace graybox::estimators {

namespace {
constexpr double kZ95 = 1.959963984540054;  // two-sided 95% quantile of the normal distribution
}

UncertaintyReport CovarianceFromJacobian(const Eigen::MatrixXd& jacobian,
                                         const Eigen::VectorXd& residuals,
                                         const std::vector<models::ModelParameter>& parameters,
                                         const std::vector<int>& free_indices,
                                         const CovarianceOptions& options) {
  const int nf = static_cast<int>(free_indices.size());
  const Eigen::Index n = jacobian.cols();
  if (jacobian.rows() != residuals.size() || n < nf) {
    throw std::invalid_argument("CovarianceFromJacobian: expected a Jacobian with " +
                                std::to_string(residuals.size()) +
                                " rows and >= " + std::to_string(nf) + " columns, got " +
                                std::to_string(jacobian.rows()) + "x" + std::to_string(n));
  }
  UncertaintyReport report;
  report.free_indices = free_indices;
  report.num_residuals = static_cast<int>(residuals.size());
  const double dof = std::max<double>(1.0, static_cast<double>(residuals.size() - n));
  report.residual_variance = residuals.squaredNorm() / dof;
  // Information matrix scaled to unit diagonal (column equilibration) for a meaningful condition
  // number and a stable inverse.
  const Eigen::MatrixXd info = jacobian.transpose() * jacobian;
  Eigen::VectorXd d = info.diagonal().cwiseSqrt();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(d[i] > 0.0)) d[i] = 1.0;
  }
  const Eigen::MatrixXd scaled =
      d.cwiseInverse().asDiagonal() * info * d.cwiseInverse().asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  const double lmax = eig.eigenvalues().maxCoeff();
  const double lmin = eig.eigenvalues().minCoeff();
  report.condition_number = lmin > 0.0 ? lmax / lmin : std::numeric_limits<double>::infinity();
  Eigen::MatrixXd cov_full;
  if (lmin > lmax * 1e-14) {
    cov_full = d.cwiseInverse().asDiagonal() *
               scaled.ldlt().solve(Eigen::MatrixXd::Identity(n, n)) * d.cwiseInverse().asDiagonal();
    cov_full *= report.residual_variance;
  } else {
    cov_full = Eigen::MatrixXd::Constant(n, n, std::nan(""));
  }
  report.covariance = cov_full.topLeftCorner(nf, nf);
  report.correlation.resize(nf, nf);
  for (int i = 0; i < nf; ++i) {
    for (int j = 0; j < nf; ++j) {
      report.correlation(i, j) =
          report.covariance(i, j) / std::sqrt(report.covariance(i, i) * report.covariance(j, j));
    }
  }
  for (const auto& par : parameters) {
    ParameterEstimate e;
    e.name = par.name;
    e.unit = par.info.unit;
    e.value = par.value;
    e.free = false;
    e.ci_low = e.ci_high = e.value;
    report.parameters.push_back(e);
  }
  for (int i = 0; i < nf; ++i) {
    ParameterEstimate& e = report.parameters.at(free_indices[i]);
    e.free = true;
    e.std_error = std::sqrt(report.covariance(i, i));
    e.ci_low = e.value - kZ95 * e.std_error;
    e.ci_high = e.value + kZ95 * e.std_error;
  }
  char buf[256];
  if (!(report.condition_number <= options.max_condition)) {
    std::snprintf(buf, sizeof buf,
                  "poorly identifiable: the scaled information matrix has condition number %.3g "
                  "(> %.3g); some parameter combination is barely determined by the data",
                  report.condition_number, options.max_condition);
    report.warnings.emplace_back(buf);
  }
  for (int i = 0; i < nf; ++i) {
    for (int j = i + 1; j < nf; ++j) {
      if (std::fabs(report.correlation(i, j)) > options.max_correlation) {
        std::snprintf(buf, sizeof buf,
                      "high correlation %.3f between '%s' and '%s': only their combination is "
                      "well identified",
                      report.correlation(i, j), report.parameters[free_indices[i]].name.c_str(),
                      report.parameters[free_indices[j]].name.c_str());
        report.warnings.emplace_back(buf);
      }
    }
  }
  return report;
}

std::string UncertaintyReport::BriefReport() const {
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "%zu free parameters, sigma %.4g over %d residuals, condition %.4g",
                free_indices.size(), std::sqrt(residual_variance), num_residuals, condition_number);
  std::string s = buf;
  if (!warnings.empty()) s += ", " + std::to_string(warnings.size()) + " warning(s)";
  return s;
}

std::string UncertaintyReport::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  char buf[256];
  std::snprintf(buf, sizeof buf, "  %-28s %14s %12s %9s   %-30s %s\n", "parameter", "value",
                "std error", "rel %", "95% interval", "unit");
  os << buf;
  for (const auto& p : parameters) {
    if (p.free) {
      std::snprintf(buf, sizeof buf, "  %-28s %14.6g %12.4g %9.4f   [%12.6g, %12.6g] %s\n",
                    p.name.c_str(), p.value, p.std_error, 100.0 * p.std_error / std::fabs(p.value),
                    p.ci_low, p.ci_high, p.unit.c_str());
    } else {
      std::snprintf(buf, sizeof buf, "  %-28s %14.6g %12s %9s   %-30s %s\n", p.name.c_str(),
                    p.value, "fixed", "", "", p.unit.c_str());
    }
    os << buf;
  }
  for (const auto& w : warnings) os << "  warning: " << w << "\n";
  return os.str();
}

UncertaintyReport SimulationCovariance(const Integrator& integrator,
                                       const std::vector<ExperimentData>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights,
                                       const CovarianceOptions& options) {
  const models::StateSpaceModel& model = integrator.model();
  const int nx = model.NumStates(), ny = model.NumOutputs();
  std::vector<int> free;
  for (int i = 0; i < model.NumParameters(); ++i) {
    if (model.parameters[i].free) free.push_back(i);
  }
  const int nf = static_cast<int>(free.size());
  if (initial_states.size() != experiments.size() || output_weights.size() != ny) {
    throw std::invalid_argument(
        "SimulationCovariance: expected " + std::to_string(experiments.size()) +
        " initial states and " + std::to_string(ny) + " output weights, got " +
        std::to_string(initial_states.size()) + " and " + std::to_string(output_weights.size()));
  }
  long total_rows = 0;
  for (const auto& ex : experiments) total_rows += ex.u.rows() * ny;
  const int ncols = nf + nx * static_cast<int>(experiments.size());
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(total_rows, ncols);
  Eigen::VectorXd res(total_rows);
  long row = 0;
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const auto& ex = experiments[e];
    const SensitivityTrajectory t =
        integrator.SimulateWithSensitivities(initial_states[e], ex.u, p, free);
    if (!t.summary.ok()) {
      throw std::runtime_error("SimulationCovariance: experiment '" + ex.name +
                               "': " + t.summary.BriefReport());
    }
    for (Eigen::Index k = 0; k < ex.u.rows(); ++k) {
      for (int j = 0; j < ny; ++j) {
        res[row + j] = output_weights[j] * (t.y(k, j) - ex.y(k, j));
        jac.row(row + j).head(nf) = output_weights[j] * t.dy_dp[k].row(j);
        jac.row(row + j).segment(nf + nx * static_cast<Eigen::Index>(e), nx) =
            output_weights[j] * t.dy_dx0[k].row(j);
      }
      row += ny;
    }
  }
  std::vector<models::ModelParameter> params = model.parameters;
  for (int i = 0; i < model.NumParameters(); ++i) params[i].value = p[i];
  return CovarianceFromJacobian(jac, res, params, free, options);
}

UncertaintyReport SimulationCovariance(const models::StateSpaceModel& model,
                                       const std::vector<ExperimentData>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights, int substeps,
                                       const CovarianceOptions& options) {
  if (experiments.empty()) {
    throw std::invalid_argument("SimulationCovariance: expected at least one experiment, got 0");
  }
  return SimulationCovariance(Rk4Integrator(model, experiments[0].dt, substeps), experiments, p,
                              initial_states, output_weights, options);
}

}  // namespace graybox::estimators
