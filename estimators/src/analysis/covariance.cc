// The covariance from a residual Jacobian or an information matrix, the identifiability analysis
// of the information matrix and the reports. NlpCovariance and SimulationCovariance, which build
// the Jacobian from an Nlp or a simulation, are in nlp_covariance.cc.
#include "graybox/estimators/analysis/covariance.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "analysis/covariance_internal.h"

namespace graybox::estimators {

using internal::CheckChannels;
using internal::CheckFreeIndices;
using internal::Failed;
using internal::FirstNonFinite;
using internal::FromEffectiveJacobian;
using internal::Num;

namespace {
constexpr double kZ95 = 1.959963984540054;  // two-sided 95% quantile of the normal distribution
const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();
constexpr const char* kBecause = "the covariance could not be computed because ";
// Gauss-Jordan pivots of the null-space basis (orthonormal rows, entries O(1)) smaller than this
// are numerical zeros.
constexpr double kPivotTolerance = 1e-9;

// The parameters with their values and no error yet (free ones are marked later).
std::vector<ParameterEstimate> Estimates(const std::vector<models::ModelParameter>& parameters) {
  std::vector<ParameterEstimate> out;
  for (const auto& par : parameters) {
    ParameterEstimate e;
    e.name = par.name;
    e.unit = par.info.unit;
    e.value = par.value;
    e.free = false;
    e.ci_low = e.ci_high = e.value;
    out.push_back(e);
  }
  return out;
}

// Spectral analysis of an information matrix R (nf x nf, parameter units; finite).
struct Identifiability {
  Eigen::MatrixXd pinv;              // R^+ on the identifiable directions, parameter units
  std::vector<bool> unidentifiable;  // per free parameter
  Eigen::MatrixXd null_space;        // nf x k, unit columns in the unit-diagonal scaling
  double condition = 1.0;
  /// Per free parameter: its information was lost to the elimination of the nuisance variables.
  std::vector<bool> confounded;
};

Identifiability Analyse(const Eigen::MatrixXd& info, const CovarianceOptions& options) {
  const Eigen::Index n = info.rows();
  Identifiability id;
  id.unidentifiable.assign(static_cast<std::size_t>(n), false);
  id.pinv = Eigen::MatrixXd::Zero(n, n);
  id.null_space.resize(n, 0);
  if (n == 0) return id;
  // Unit-diagonal scaling (a parameter without information keeps 1: its row stays zero).
  Eigen::VectorXd d = info.diagonal().cwiseMax(0.0).cwiseSqrt();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(d[i] > 0.0)) d[i] = 1.0;
  }
  const Eigen::VectorXd dinv = d.cwiseInverse();
  Eigen::MatrixXd s = dinv.asDiagonal() * info * dinv.asDiagonal();
  s = (0.5 * (s + s.transpose())).eval();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(s);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const Eigen::MatrixXd& v = eig.eigenvectors();
  const double lmax = lambda.maxCoeff(), lmin = lambda.minCoeff();
  id.condition = lmin > 0.0 && lmax > 0.0 ? lmax / lmin : kInf;
  const double threshold = lmax / options.max_condition;
  std::vector<Eigen::Index> null_columns;
  Eigen::MatrixXd pinv_scaled = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    if (lambda[k] > threshold && lambda[k] > 0.0) {
      pinv_scaled.noalias() += v.col(k) * v.col(k).transpose() / lambda[k];
    } else {
      null_columns.push_back(k);
    }
  }
  id.pinv = dinv.asDiagonal() * pinv_scaled * dinv.asDiagonal();
  const auto nk = static_cast<Eigen::Index>(null_columns.size());
  if (nk == 0) return id;
  Eigen::MatrixXd basis(n, nk);
  for (Eigen::Index c = 0; c < nk; ++c) basis.col(c) = v.col(null_columns[c]);
  // A parameter with a share of the null space has no standard error (invariant under the
  // choice of basis: the norm of its projection).
  for (Eigen::Index i = 0; i < n; ++i) {
    if (basis.row(i).norm() >= options.null_space_coefficient) id.unidentifiable[i] = true;
  }
  // Reduced row echelon form of the basis (directions as rows): each direction involves as few
  // parameters as possible and starts with a positive coefficient.
  Eigen::MatrixXd b = basis.transpose();
  Eigen::Index row = 0;
  for (Eigen::Index col = 0; col < n && row < nk; ++col) {
    Eigen::Index piv = 0;
    const double m = b.col(col).segment(row, nk - row).cwiseAbs().maxCoeff(&piv);
    if (m < kPivotTolerance) continue;
    piv += row;
    b.row(row).swap(b.row(piv));
    b.row(row) /= b(row, col);
    for (Eigen::Index r = 0; r < nk; ++r) {
      if (r != row) b.row(r) -= b(r, col) * b.row(row);
    }
    ++row;
  }
  if (row < nk) b = basis.transpose();  // not reducible numerically: keep the eigenvectors
  for (Eigen::Index r = 0; r < nk; ++r) b.row(r).normalize();
  id.null_space = b.transpose();
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index c = 0; c < nk; ++c) {
      if (std::fabs(id.null_space(i, c)) >= options.null_space_coefficient) {
        id.unidentifiable[i] = true;
      }
    }
  }
  return id;
}

// "0.71*a.p1 - 0.71*b.p2" for column c of the null space.
std::string Combination(const Eigen::MatrixXd& null_space, Eigen::Index c,
                        const std::vector<models::ModelParameter>& parameters,
                        const std::vector<int>& free_indices, double drop_below,
                        const std::vector<bool>& confounded_with_nuisance) {
  std::string s;
  char buf[32];
  bool confounded = false;
  for (Eigen::Index i = 0; i < null_space.rows(); ++i) {
    const double a = null_space(i, c);
    if (!(std::fabs(a) >= drop_below) || a == 0.0) continue;
    std::snprintf(buf, sizeof buf, "%.2g*", std::fabs(a));
    if (s.empty()) {
      s = (a < 0.0 ? "-" : "");
    } else {
      s += (a < 0.0 ? " - " : " + ");
    }
    s += buf + parameters.at(static_cast<std::size_t>(free_indices[i])).name;
    confounded = confounded || (i < static_cast<Eigen::Index>(confounded_with_nuisance.size()) &&
                                confounded_with_nuisance[static_cast<std::size_t>(i)]);
  }
  if (confounded) s += " (confounded with the eliminated initial states / nodes)";
  return s;
}

// Fills the estimates, correlation, combinations and warnings of a report whose free_indices,
// condition number and covariance (NaN rows for unidentifiable parameters) are set.
void FinishReport(const Identifiability& id, const std::vector<models::ModelParameter>& parameters,
                  const CovarianceOptions& options, UncertaintyReport* report) {
  const std::vector<int>& free_indices = report->free_indices;
  const auto nf = static_cast<Eigen::Index>(free_indices.size());
  report->correlation.resize(nf, nf);
  for (Eigen::Index i = 0; i < nf; ++i) {
    for (Eigen::Index j = 0; j < nf; ++j) {
      report->correlation(i, j) =
          report->covariance(i, j) / std::sqrt(report->covariance(i, i) * report->covariance(j, j));
    }
  }
  report->parameters = Estimates(parameters);
  for (Eigen::Index i = 0; i < nf; ++i) {
    ParameterEstimate& e = report->parameters.at(static_cast<std::size_t>(free_indices[i]));
    e.free = true;
    e.std_error = std::sqrt(report->covariance(i, i));
    e.ci_low = e.value - kZ95 * e.std_error;
    e.ci_high = e.value + kZ95 * e.std_error;
  }
  report->null_space = id.null_space;
  for (Eigen::Index c = 0; c < id.null_space.cols(); ++c) {
    report->unidentifiable.push_back(Combination(id.null_space, c, parameters, free_indices,
                                                 options.null_space_coefficient, id.confounded));
  }
  char buf[320];
  if (!(report->condition_number <= options.max_condition) || !report->unidentifiable.empty()) {
    std::string list;
    for (const auto& u : report->unidentifiable) list += (list.empty() ? "" : "; ") + u;
    std::snprintf(buf, sizeof buf,
                  "poorly identifiable: the scaled information matrix has condition number %.3g "
                  "(> %.3g); ",
                  report->condition_number, options.max_condition);
    report->warnings.push_back(
        std::string(buf) + "the data do not determine the combination(s) " + list +
        " (their parameters have no standard error; fix or regularise one of each)");
  }
  for (Eigen::Index i = 0; i < nf; ++i) {
    for (Eigen::Index j = i + 1; j < nf; ++j) {
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

// NaN rows and columns for the unidentifiable parameters.
void BlankUnidentifiable(const Identifiability& id, Eigen::MatrixXd* covariance) {
  for (Eigen::Index i = 0; i < covariance->rows(); ++i) {
    if (id.unidentifiable[static_cast<std::size_t>(i)]) {
      covariance->row(i).setConstant(kNaN);
      covariance->col(i).setConstant(kNaN);
    }
  }
}

}  // namespace

namespace internal {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

void CheckFreeIndices(const std::vector<models::ModelParameter>& parameters,
                      const std::vector<int>& free_indices, const char* where) {
  for (int i : free_indices) {
    if (i < 0 || i >= static_cast<int>(parameters.size())) {
      throw std::invalid_argument(std::string(where) + ": expected free indices in [0, " +
                                  std::to_string(parameters.size()) + "), got " +
                                  std::to_string(i));
    }
  }
}

void CheckChannels(const std::vector<int>& channel, std::size_t rows, const char* where,
                   const std::vector<char>* ignored) {
  if (channel.size() != rows) {
    throw std::invalid_argument(std::string(where) + ": CovarianceOptions.row_channels: expected " +
                                std::to_string(rows) + " entries, got " +
                                std::to_string(channel.size()));
  }
  for (std::size_t k = 0; k < rows; ++k) {
    if (channel[k] < 0 && channel[k] != kPenaltyRow && !(ignored && (*ignored)[k])) {
      throw std::invalid_argument(std::string(where) +
                                  ": CovarianceOptions.row_channels: expected a channel >= 0 for "
                                  "row " +
                                  std::to_string(k) + ", got " + std::to_string(channel[k]));
    }
  }
}

UncertaintyReport Failed(const std::string& reason,
                         const std::vector<models::ModelParameter>& parameters,
                         const std::vector<int>& free_indices, int num_residuals) {
  UncertaintyReport report;
  report.ok = false;
  report.failure = kBecause + reason;
  report.free_indices = free_indices;
  report.num_residuals = num_residuals;
  report.residual_variance = kNaN;
  report.condition_number = kNaN;
  const auto nf = static_cast<Eigen::Index>(free_indices.size());
  report.covariance = Eigen::MatrixXd::Constant(nf, nf, kNaN);
  report.correlation = Eigen::MatrixXd::Constant(nf, nf, kNaN);
  report.null_space.resize(nf, 0);
  report.parameters = Estimates(parameters);
  for (int i : free_indices) {
    ParameterEstimate& e = report.parameters.at(static_cast<std::size_t>(i));
    e.free = true;
    e.std_error = e.ci_low = e.ci_high = kNaN;
  }
  return report;
}

UncertaintyReport FromEffectiveJacobian(Eigen::MatrixXd g, const Eigen::VectorXd& reference,
                                        const Eigen::VectorXd& r, double dof,
                                        const std::vector<int>& channel,
                                        const std::vector<models::ModelParameter>& parameters,
                                        const std::vector<int>& free_indices,
                                        const CovarianceOptions& options) {
  const auto n = static_cast<int>(r.size());
  std::vector<bool> confounded(static_cast<std::size_t>(g.cols()), false);
  for (Eigen::Index i = 0; i < g.cols() && i < reference.size(); ++i) {
    const double norm = g.col(i).norm();
    if (reference[i] > 0.0 && norm * norm <= reference[i] * reference[i] / options.max_condition) {
      g.col(i).setZero();
      confounded[static_cast<std::size_t>(i)] = true;
    }
  }
  const Eigen::MatrixXd info = g.transpose() * g;
  if (!info.allFinite()) {
    return Failed("the information matrix has non-finite entries (overflow in J^T J)", parameters,
                  free_indices, n);
  }
  Identifiability id = Analyse(info, options);
  id.confounded = confounded;
  UncertaintyReport report;
  report.free_indices = free_indices;
  report.num_residuals = n;
  report.residual_variance = r.squaredNorm() / dof;
  report.condition_number = id.condition;
  if (channel.empty()) {
    report.covariance = report.residual_variance * id.pinv;
  } else {
    // One noise variance per channel (same degrees-of-freedom correction as the pooled one) and
    // the sandwich R^+ (G^T S G) R^+ with S = diag(sigma_c(row)^2).
    // Penalty rows (kPenaltyRow) carry no noise: they shape the information only.
    const int nc = std::max(0, *std::max_element(channel.begin(), channel.end()) + 1);
    Eigen::VectorXd ss = Eigen::VectorXd::Zero(nc), count = Eigen::VectorXd::Zero(nc);
    double penalty_rows = 0.0;
    for (Eigen::Index k = 0; k < r.size(); ++k) {
      if (channel[k] < 0) {
        penalty_rows += 1.0;
        continue;
      }
      ss[channel[k]] += r[k] * r[k];
      count[channel[k]] += 1.0;
    }
    const double data_rows = static_cast<double>(n) - penalty_rows;
    const double correction = data_rows / std::max(1.0, dof - penalty_rows);
    Eigen::VectorXd variance(nc);
    for (int c = 0; c < nc; ++c) variance[c] = count[c] > 0 ? correction * ss[c] / count[c] : 0.0;
    if (penalty_rows > 0.0) {
      double data_ss = 0.0;
      for (int c = 0; c < nc; ++c) data_ss += ss[c];
      report.residual_variance = data_ss / std::max(1.0, dof - penalty_rows);
    }
    Eigen::VectorXd row_variance(r.size());
    for (Eigen::Index k = 0; k < r.size(); ++k) {
      row_variance[k] = channel[k] < 0 ? 0.0 : variance[channel[k]];
    }
    const Eigen::MatrixXd middle = g.transpose() * row_variance.asDiagonal() * g;
    report.covariance = id.pinv * middle * id.pinv;
    for (int c = 0; c < nc; ++c) {
      if (count[c] == 0) continue;
      ChannelNoise ch;
      const auto cs = static_cast<std::size_t>(c);
      ch.name = cs < options.channel_names.size() ? options.channel_names[cs]
                                                  : "channel " + std::to_string(c);
      ch.unit = cs < options.channel_units.size() ? options.channel_units[cs] : "";
      ch.weight = c < options.channel_weights.size() ? options.channel_weights[c] : 1.0;
      ch.num_residuals = static_cast<int>(count[c]);
      ch.weighted_sigma = std::sqrt(variance[c]);
      ch.sigma = ch.weighted_sigma / ch.weight;
      report.channels.push_back(ch);
    }
  }
  BlankUnidentifiable(id, &report.covariance);
  FinishReport(id, parameters, options, &report);
  return report;
}

}  // namespace internal

void CovarianceOptions::Validate() const {
  if (!(max_condition > 1.0)) {
    throw std::invalid_argument("CovarianceOptions.max_condition: expected > 1, got " +
                                Num(max_condition));
  }
  if (!(max_correlation > 0.0 && max_correlation <= 1.0)) {
    throw std::invalid_argument("CovarianceOptions.max_correlation: expected in (0, 1], got " +
                                Num(max_correlation));
  }
  if (!(null_space_coefficient >= 0.0 && null_space_coefficient < 1.0)) {
    throw std::invalid_argument(
        "CovarianceOptions.null_space_coefficient: expected in [0, 1), got " +
        Num(null_space_coefficient));
  }
  for (Eigen::Index c = 0; c < channel_weights.size(); ++c) {
    if (!(channel_weights[c] > 0.0) || !std::isfinite(channel_weights[c])) {
      throw std::invalid_argument("CovarianceOptions.channel_weights[" + std::to_string(c) +
                                  "]: expected a finite weight > 0, got " +
                                  Num(channel_weights[c]));
    }
  }
  if (!channel_names.empty() && !channel_units.empty() &&
      channel_names.size() != channel_units.size()) {
    throw std::invalid_argument(
        "CovarianceOptions.channel_units: expected " + std::to_string(channel_names.size()) +
        " entries (one per channel name), got " + std::to_string(channel_units.size()));
  }
}

UncertaintyReport CovarianceFromJacobian(const Eigen::MatrixXd& jacobian,
                                         const Eigen::VectorXd& residuals,
                                         const std::vector<models::ModelParameter>& parameters,
                                         const std::vector<int>& free_indices,
                                         const CovarianceOptions& options) {
  options.Validate();
  const auto nf = static_cast<Eigen::Index>(free_indices.size());
  const Eigen::Index n = jacobian.cols();
  if (jacobian.rows() != residuals.size() || n < nf) {
    throw std::invalid_argument("CovarianceFromJacobian: expected a Jacobian with " +
                                std::to_string(residuals.size()) +
                                " rows and >= " + std::to_string(nf) + " columns, got " +
                                std::to_string(jacobian.rows()) + "x" + std::to_string(n));
  }
  CheckFreeIndices(parameters, free_indices, "CovarianceFromJacobian");
  if (!options.row_channels.empty()) {
    CheckChannels(options.row_channels, static_cast<std::size_t>(residuals.size()),
                  "CovarianceFromJacobian");
  }
  const auto rows = static_cast<int>(residuals.size());
  Eigen::Index bad_row = 0, bad_col = 0;
  if (FirstNonFinite(jacobian, &bad_row, &bad_col)) {
    const std::string column = bad_col < nf ? "d r / d " + parameters[free_indices[bad_col]].name
                                            : "nuisance column " + std::to_string(bad_col - nf);
    return Failed("the Jacobian has a non-finite entry (" + Num(jacobian(bad_row, bad_col)) +
                      " at row " + std::to_string(bad_row) + ", " + column + ")",
                  parameters, free_indices, rows);
  }
  for (Eigen::Index k = 0; k < residuals.size(); ++k) {
    if (!std::isfinite(residuals[k])) {
      return Failed("residual " + std::to_string(k) + " is " + Num(residuals[k]), parameters,
                    free_indices, rows);
    }
  }
  // Eliminate the nuisance columns: project the parameter columns orthogonally to their span
  // (rank-revealing, so an undetermined nuisance variable does no harm).
  Eigen::MatrixXd g = jacobian.leftCols(nf);
  const Eigen::VectorXd reference = g.colwise().norm().transpose();
  if (n > nf) {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(jacobian.rightCols(n - nf));
    g -= jacobian.rightCols(n - nf) * qr.solve(g);
  }
  const double dof = std::max<double>(1.0, static_cast<double>(residuals.size() - n));
  return FromEffectiveJacobian(std::move(g), reference, residuals, dof, options.row_channels,
                               parameters, free_indices, options);
}

UncertaintyReport CovarianceFromInformation(const Eigen::MatrixXd& information,
                                            double residual_variance, int num_residuals,
                                            const std::vector<models::ModelParameter>& parameters,
                                            const std::vector<int>& free_indices,
                                            const CovarianceOptions& options) {
  options.Validate();
  const auto nf = static_cast<Eigen::Index>(free_indices.size());
  if (information.rows() != nf || information.cols() != nf) {
    throw std::invalid_argument("CovarianceFromInformation: expected a " + std::to_string(nf) +
                                "x" + std::to_string(nf) + " information matrix, got " +
                                std::to_string(information.rows()) + "x" +
                                std::to_string(information.cols()));
  }
  CheckFreeIndices(parameters, free_indices, "CovarianceFromInformation");
  if (!information.allFinite()) {
    return Failed("the information matrix has non-finite entries", parameters, free_indices,
                  num_residuals);
  }
  if (!std::isfinite(residual_variance)) {
    return Failed("the residual variance is " + Num(residual_variance), parameters, free_indices,
                  num_residuals);
  }
  const Identifiability id = Analyse(information, options);
  UncertaintyReport report;
  report.free_indices = free_indices;
  report.num_residuals = num_residuals;
  report.residual_variance = residual_variance;
  report.condition_number = id.condition;
  report.covariance = residual_variance * id.pinv;
  BlankUnidentifiable(id, &report.covariance);
  FinishReport(id, parameters, options, &report);
  return report;
}

std::string UncertaintyReport::BriefReport() const {
  if (!ok) return "covariance failed: " + failure;
  char buf[200];
  std::snprintf(buf, sizeof buf, "%zu free parameters, sigma %.4g over %d residuals",
                free_indices.size(), std::sqrt(residual_variance), num_residuals);
  std::string s = buf;
  if (!channels.empty()) {
    std::string list;
    for (const auto& c : channels) {
      std::snprintf(buf, sizeof buf, "%s %.4g%s%s", c.name.c_str(), c.sigma,
                    c.unit.empty() ? "" : " ", c.unit.c_str());
      list += (list.empty() ? "" : ", ") + std::string(buf);
    }
    s += " (" + list + ")";
  }
  std::snprintf(buf, sizeof buf, ", condition %.4g", condition_number);
  s += buf;
  if (!unidentifiable.empty()) {
    s += ", " + std::to_string(unidentifiable.size()) + " unidentifiable combination(s)";
  }
  if (!warnings.empty()) s += ", " + std::to_string(warnings.size()) + " warning(s)";
  return s;
}

double ParameterEstimate::RelativeStdPercent() const {
  const double magnitude = std::fabs(value);
  if (!free || !std::isfinite(std_error) || !std::isfinite(value) ||
      !(magnitude >= kRelativeErrorFloor * std_error) || magnitude == 0.0) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return 100.0 * std_error / magnitude;
}

std::string UncertaintyReport::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  char buf[320];
  std::snprintf(buf, sizeof buf, "  %-28s %14s %12s %9s   %-30s %s\n", "parameter", "value",
                "std error", "rel %", "95% interval", "unit");
  os << buf;
  for (const auto& p : parameters) {
    if (p.free) {
      const double relative = p.RelativeStdPercent();
      char rel[32];
      if (std::isfinite(relative)) {
        std::snprintf(rel, sizeof rel, "%9.4f", relative);
      } else {
        std::snprintf(rel, sizeof rel, "%9s", "n/a");
      }
      std::snprintf(buf, sizeof buf, "  %-28s %14.6g %12.4g %s   [%12.6g, %12.6g] %s\n",
                    p.name.c_str(), p.value, p.std_error, rel, p.ci_low, p.ci_high, p.unit.c_str());
    } else {
      std::snprintf(buf, sizeof buf, "  %-28s %14.6g %12s %9s   %-30s %s\n", p.name.c_str(),
                    p.value, "fixed", "", "", p.unit.c_str());
    }
    os << buf;
  }
  if (!channels.empty()) {
    std::snprintf(buf, sizeof buf, "  %-28s %14s %12s %12s %9s\n", "channel", "noise sigma",
                  "weight", "weighted", "residuals");
    os << buf;
    for (const auto& c : channels) {
      std::snprintf(buf, sizeof buf, "  %-28s %14.6g %12.4g %12.4g %9d%s%s\n", c.name.c_str(),
                    c.sigma, c.weight, c.weighted_sigma, c.num_residuals, c.unit.empty() ? "" : " ",
                    c.unit.c_str());
      os << buf;
    }
  }
  for (const auto& u : unidentifiable) os << "  unidentifiable: " << u << "\n";
  for (const auto& w : warnings) os << "  warning: " << w << "\n";
  return os.str();
}

}  // namespace graybox::estimators
