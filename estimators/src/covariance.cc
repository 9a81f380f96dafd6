#include "graybox/estimators/covariance.h"

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "graybox/estimators/integrators.h"

namespace graybox::estimators {

namespace {
constexpr double kZ95 = 1.959963984540054;  // two-sided 95% quantile of the normal distribution

// Fills the correlation, the per-parameter estimates with intervals, and the warnings of a
// report whose condition number is set, from the covariance of the free parameters.
void FinishReport(const Eigen::MatrixXd& covariance,
                  const std::vector<models::ModelParameter>& parameters,
                  const CovarianceOptions& options, UncertaintyReport* report) {
  const std::vector<int>& free_indices = report->free_indices;
  const int nf = static_cast<int>(free_indices.size());
  report->covariance = covariance;
  report->correlation.resize(nf, nf);
  for (int i = 0; i < nf; ++i) {
    for (int j = 0; j < nf; ++j) {
      report->correlation(i, j) =
          report->covariance(i, j) / std::sqrt(report->covariance(i, i) * report->covariance(j, j));
    }
  }
  for (const auto& par : parameters) {
    ParameterEstimate e;
    e.name = par.name;
    e.unit = par.info.unit;
    e.value = par.value;
    e.free = false;
    e.ci_low = e.ci_high = e.value;
    report->parameters.push_back(e);
  }
  for (int i = 0; i < nf; ++i) {
    ParameterEstimate& e = report->parameters.at(free_indices[i]);
    e.free = true;
    e.std_error = std::sqrt(report->covariance(i, i));
    e.ci_low = e.value - kZ95 * e.std_error;
    e.ci_high = e.value + kZ95 * e.std_error;
  }
  char buf[256];
  if (!(report->condition_number <= options.max_condition)) {
    std::snprintf(buf, sizeof buf,
                  "poorly identifiable: the scaled information matrix has condition number %.3g "
                  "(> %.3g); some parameter combination is barely determined by the data",
                  report->condition_number, options.max_condition);
    report->warnings.emplace_back(buf);
  }
  for (int i = 0; i < nf; ++i) {
    for (int j = i + 1; j < nf; ++j) {
      if (std::fabs(report->correlation(i, j)) > options.max_correlation) {
        std::snprintf(buf, sizeof buf,
                      "high correlation %.3f between '%s' and '%s': only their combination is "
                      "well identified",
                      report->correlation(i, j), report->parameters[free_indices[i]].name.c_str(),
                      report->parameters[free_indices[j]].name.c_str());
        report->warnings.emplace_back(buf);
      }
    }
  }
}

}  // namespace

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
  const Eigen::MatrixXd info = jacobian.transpose() * jacobian;
  Eigen::MatrixXd reduced = info.topLeftCorner(nf, nf);
  if (n > nf) {  // marginalise the nuisance block: I_tt - I_tn I_nn^-1 I_nt
    const Eigen::Index nn = n - nf;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(info.bottomRightCorner(nn, nn));
    reduced -= info.topRightCorner(nf, nn) * ldlt.solve(info.bottomLeftCorner(nn, nf));
  }
  const double dof = std::max<double>(1.0, static_cast<double>(residuals.size() - n));
  UncertaintyReport report = CovarianceFromInformation(reduced, residuals.squaredNorm() / dof,
                                                       static_cast<int>(residuals.size()),
                                                       parameters, free_indices, options);
  const std::vector<int>& channel = options.row_channels;
  if (channel.empty()) return report;
  if (channel.size() != static_cast<std::size_t>(residuals.size())) {
    throw std::invalid_argument("CovarianceOptions.row_channels: expected " +
                                std::to_string(residuals.size()) + " entries, got " +
                                std::to_string(channel.size()));
  }
  // One noise variance per channel (same degrees-of-freedom correction as the pooled one), and
  // the sandwich A^-1 (J^T S J) A^-1 with A = J^T J, S = diag(sigma_c(row)^2).
  const int nc = *std::max_element(channel.begin(), channel.end()) + 1;
  Eigen::VectorXd ss = Eigen::VectorXd::Zero(nc), count = Eigen::VectorXd::Zero(nc);
  for (Eigen::Index r = 0; r < residuals.size(); ++r) {
    if (channel[r] < 0) throw std::invalid_argument("CovarianceOptions.row_channels: negative");
    ss[channel[r]] += residuals[r] * residuals[r];
    count[channel[r]] += 1.0;
  }
  const double correction = static_cast<double>(residuals.size()) / dof;
  Eigen::VectorXd row_variance(residuals.size());
  for (Eigen::Index r = 0; r < residuals.size(); ++r) {
    row_variance[r] = correction * ss[channel[r]] / count[channel[r]];
  }
  const Eigen::LDLT<Eigen::MatrixXd> a(info);
  if (a.info() != Eigen::Success || !(report.condition_number < 1e14)) return report;  // NaN
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(n, nf);
  e.topRows(nf).setIdentity();
  const Eigen::MatrixXd x = a.solve(e);  // columns of A^-1 for the parameters
  const Eigen::MatrixXd jx = jacobian * x;
  const Eigen::MatrixXd covariance = jx.transpose() * row_variance.asDiagonal() * jx;
  report.warnings.clear();
  report.parameters.clear();
  FinishReport(covariance, parameters, options, &report);
  return report;
}

UncertaintyReport CovarianceFromInformation(const Eigen::MatrixXd& information,
                                            double residual_variance, int num_residuals,
                                            const std::vector<models::ModelParameter>& parameters,
                                            const std::vector<int>& free_indices,
                                            const CovarianceOptions& options) {
  const int nf = static_cast<int>(free_indices.size());
  if (information.rows() != nf || information.cols() != nf) {
    throw std::invalid_argument("CovarianceFromInformation: expected a " + std::to_string(nf) +
                                "x" + std::to_string(nf) + " information matrix, got " +
                                std::to_string(information.rows()) + "x" +
                                std::to_string(information.cols()));
  }
  UncertaintyReport report;
  report.free_indices = free_indices;
  report.num_residuals = num_residuals;
  report.residual_variance = residual_variance;
  // Information matrix scaled to unit diagonal (column equilibration) for a meaningful condition
  // number and a stable inverse.
  const Eigen::Index n = nf;
  const Eigen::MatrixXd& info = information;
  Eigen::VectorXd d = info.diagonal().cwiseMax(0.0).cwiseSqrt();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(d[i] > 0.0)) d[i] = 1.0;
  }
  const Eigen::MatrixXd scaled =
      d.cwiseInverse().asDiagonal() * info * d.cwiseInverse().asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  const double lmax = n > 0 ? eig.eigenvalues().maxCoeff() : 1.0;
  const double lmin = n > 0 ? eig.eigenvalues().minCoeff() : 1.0;
  report.condition_number = lmin > 0.0 ? lmax / lmin : std::numeric_limits<double>::infinity();
  Eigen::MatrixXd cov_full;
  if (lmin > lmax * 1e-14 && scaled.allFinite()) {
    cov_full = d.cwiseInverse().asDiagonal() *
               scaled.ldlt().solve(Eigen::MatrixXd::Identity(n, n)) * d.cwiseInverse().asDiagonal();
    cov_full *= report.residual_variance;
  } else {
    cov_full = Eigen::MatrixXd::Constant(n, n, std::nan(""));
  }
  FinishReport(cov_full, parameters, options, &report);
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

UncertaintyReport NlpCovariance(const Nlp& nlp, const Eigen::VectorXd& w, const ParameterMap& map,
                                double constraint_weight, const CovarianceOptions& options) {
  const int nf = map.NumFree();
  const int nw = nlp.NumVariables();
  const int nr = nlp.NumResiduals();
  const int nc = constraint_weight > 0.0 ? nlp.NumConstraints() : 0;
  if (w.size() != nw) {
    throw std::invalid_argument("NlpCovariance: expected w of size " + std::to_string(nw) +
                                ", got " + std::to_string(w.size()));
  }
  Eigen::VectorXd r(nr + nc);
  NlpEvalStatus status = nlp.Residuals(w.data(), r.data());
  if (!status.ok) throw std::runtime_error("NlpCovariance: residuals: " + status.message);
  std::vector<Eigen::Triplet<double>> triplets;
  std::vector<double> values(nlp.ResidualJacobianRows().size());
  status = nlp.ResidualJacobianValues(w.data(), values.data());
  if (!status.ok) throw std::runtime_error("NlpCovariance: residual Jacobian: " + status.message);
  // Columns of the free parameters in their own units (the NLP sees value / scale).
  auto column_scale = [&](int col) { return col < nf ? 1.0 / map.scale[col] : 1.0; };
  for (std::size_t k = 0; k < values.size(); ++k) {
    const int col = nlp.ResidualJacobianCols()[k];
    triplets.emplace_back(nlp.ResidualJacobianRows()[k], col, values[k] * column_scale(col));
  }
  if (nc > 0) {
    Eigen::VectorXd c(nc);
    status = nlp.Constraints(w.data(), c.data());
    if (!status.ok) throw std::runtime_error("NlpCovariance: constraints: " + status.message);
    r.tail(nc) = constraint_weight * c;
    values.assign(nlp.JacobianRows().size(), 0.0);
    status = nlp.JacobianValues(w.data(), values.data());
    if (!status.ok) throw std::runtime_error("NlpCovariance: Jacobian: " + status.message);
    for (std::size_t k = 0; k < values.size(); ++k) {
      const int col = nlp.JacobianCols()[k];
      triplets.emplace_back(nr + nlp.JacobianRows()[k], col,
                            constraint_weight * values[k] * column_scale(col));
    }
  }
  Eigen::SparseMatrix<double> j(nr + nc, nw);
  j.setFromTriplets(triplets.begin(), triplets.end());
  const Eigen::SparseMatrix<double> info = Eigen::SparseMatrix<double>(j.transpose() * j);
  Eigen::MatrixXd reduced = Eigen::MatrixXd(info.topLeftCorner(nf, nf));
  const int nn = nw - nf;
  if (nn > 0) {  // Schur complement of the nuisance block (sparse: shooting nodes, states)
    const Eigen::SparseMatrix<double> inn = info.bottomRightCorner(nn, nn);
    const Eigen::MatrixXd int_ = Eigen::MatrixXd(info.bottomLeftCorner(nn, nf));
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(inn);
    if (ldlt.info() != Eigen::Success) {
      reduced.setConstant(std::nan(""));
    } else {
      reduced -= int_.transpose() * ldlt.solve(int_);
    }
  }
  std::vector<models::ModelParameter> params = map.source;
  const Eigen::VectorXd p = map.Values(w);
  for (std::size_t i = 0; i < params.size(); ++i) params[i].value = p[static_cast<Eigen::Index>(i)];
  const double dof = std::max<double>(1.0, static_cast<double>(nr + nc - nw));
  return CovarianceFromInformation(reduced, r.squaredNorm() / dof, nr + nc, params, map.free,
                                   options);
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
  CovarianceOptions per_output = options;
  if (per_output.row_channels.empty()) {  // rows are time-major: row k ny + j is output j
    per_output.row_channels.resize(static_cast<std::size_t>(total_rows));
    for (long r = 0; r < total_rows; ++r) per_output.row_channels[r] = static_cast<int>(r % ny);
  }
  return CovarianceFromJacobian(jac, res, params, free, per_output);
}

UncertaintyReport SimulationCovariance(const models::StateSpaceModel& model,
                                       const std::vector<ExperimentData>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights,
                                       const FixedStepOptions& step,
                                       const CovarianceOptions& options) {
  if (experiments.empty()) {
    throw std::invalid_argument("SimulationCovariance: expected at least one experiment, got 0");
  }
  return SimulationCovariance(FixedStepIntegrator(model, experiments[0].dt, step), experiments, p,
                              initial_states, output_weights, options);
}

}  // namespace graybox::estimators
