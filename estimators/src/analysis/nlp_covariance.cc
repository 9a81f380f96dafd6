// The covariance of a fitted problem: NlpCovariance linearises an Nlp at its solution and
// eliminates the nuisance variables along the exact constraints (the shooting overload reads the
// continuity rows and output channels from the residual labels); SimulationCovariance builds the
// output-error Jacobian from the integrator's forward sensitivities. Both end in the Jacobian-based
// covariance of covariance.cc.
#include "graybox/estimators/analysis/covariance.h"

#include <Eigen/Dense>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/covariance_internal.h"
#include "graybox/estimators/integrators/integrators.h"

namespace graybox::estimators {

using internal::CheckChannels;
using internal::CheckFreeIndices;
using internal::Failed;
using internal::FirstNonFinite;
using internal::FromEffectiveJacobian;
using internal::Num;

namespace {

// Relative residual |K Y - B| / |B| accepted from the sparse KKT solve of NlpCovariance; above
// it the elimination is retried with a regularised nuisance block, then reported as failed.
constexpr double kKktResidualTolerance = 1e-6;
// Relative regularisation of the nuisance block (times its largest diagonal entry) for the retry.
constexpr double kNuisanceRegularisation = 1e-10;

using Sparse = Eigen::SparseMatrix<double>;

// An Nlp linearised at w for the covariance: the rows that estimate the noise (residuals r, their
// Jacobian split into the parameter columns, in parameter units, and the nuisance columns), and
// the exact constraints (equality constraints and penalised residual rows, each row scaled to a
// largest entry of 1: an exact constraint does not care about its weight, and a continuity
// residual weighted 1e7 would otherwise dwarf the rest of the KKT matrix). Nuisance variables
// and constraint rows without any entry are left out: they change nothing.
struct Linearised {
  Eigen::VectorXd r;
  std::vector<int> channel;  // of each row of r (empty: pooled)
  Eigen::MatrixXd j_theta;   // N x nf
  Sparse j_n;                // N x nn
  Eigen::MatrixXd a_theta;   // m x nf
  Sparse a_n;                // m x nn
};

// Fills `out`; returns why the linearisation failed, or "".
std::string Linearise(const Nlp& nlp, const Eigen::VectorXd& w, const ParameterMap& map,
                      const std::vector<char>& is_constraint, const std::vector<int>& row_channels,
                      Linearised* out) {
  const int nf = map.NumFree(), nw = nlp.NumVariables(), nr = nlp.NumResiduals();
  const int ncon = nlp.NumConstraints();
  auto name_of = [&](int col) {
    const auto& names = nlp.names();
    return col < static_cast<int>(names.size()) && !names[col].empty()
               ? "'" + names[col] + "'"
               : "variable " + std::to_string(col);
  };
  Eigen::VectorXd r(nr);
  NlpEvalStatus status = nlp.Residuals(w.data(), r.data());
  if (!status.ok) return "the residuals are not finite at w: " + status.message;
  std::vector<double> rvalues(nlp.ResidualJacobianRows().size());
  status = nlp.ResidualJacobianValues(w.data(), rvalues.data());
  if (!status.ok) return "the residual Jacobian is not finite at w: " + status.message;
  std::vector<double> cvalues(ncon > 0 ? nlp.JacobianRows().size() : 0);
  if (ncon > 0) {
    status = nlp.JacobianValues(w.data(), cvalues.data());
    if (!status.ok) return "the constraint Jacobian is not finite at w: " + status.message;
  }
  // Row maps: noise rows 0 .. n-1; exact constraints (penalised residual rows, then the equality
  // constraints) 0 .. m-1.
  std::vector<int> noise_row(static_cast<std::size_t>(nr), -1), residual_constraint(nr, -1);
  std::vector<int> equality(static_cast<std::size_t>(ncon), -1);
  int n = 0, m = 0;
  for (int i = 0; i < nr; ++i) {
    if (is_constraint[static_cast<std::size_t>(i)]) {
      residual_constraint[static_cast<std::size_t>(i)] = m++;
    } else {
      if (!std::isfinite(r[i])) return "residual " + std::to_string(i) + " is " + Num(r[i]);
      noise_row[static_cast<std::size_t>(i)] = n++;
    }
  }
  if (ncon > 0) {
    const Eigen::VectorXd lbg = nlp.lbg(), ubg = nlp.ubg();
    for (int i = 0; i < ncon; ++i) {
      if (lbg[i] == ubg[i]) equality[static_cast<std::size_t>(i)] = m++;
    }
  }
  out->r.resize(n);
  if (!row_channels.empty()) out->channel.assign(static_cast<std::size_t>(n), 0);
  for (int i = 0; i < nr; ++i) {
    const int o = noise_row[static_cast<std::size_t>(i)];
    if (o < 0) continue;
    out->r[o] = r[i];
    if (!row_channels.empty()) out->channel[static_cast<std::size_t>(o)] = row_channels[i];
  }
  // Triplets in parameter units: the NLP sees theta / scale, so d r / d theta = (d r / d w) /
  // scale.
  auto unscaled = [&](int col, double v) { return col < nf ? v / map.scale[col] : v; };
  std::vector<Eigen::Triplet<double>> jt, at;
  for (std::size_t k = 0; k < rvalues.size(); ++k) {
    const int row = nlp.ResidualJacobianRows()[k], col = nlp.ResidualJacobianCols()[k];
    if (!std::isfinite(rvalues[k])) {
      return "the residual Jacobian has a non-finite entry (" + Num(rvalues[k]) + " at row " +
             std::to_string(row) + ", column " + name_of(col) + ")";
    }
    const int o = noise_row[static_cast<std::size_t>(row)];
    if (o >= 0) {
      jt.emplace_back(o, col, unscaled(col, rvalues[k]));
    } else {
      at.emplace_back(residual_constraint[static_cast<std::size_t>(row)], col,
                      unscaled(col, rvalues[k]));
    }
  }
  for (std::size_t k = 0; k < cvalues.size(); ++k) {
    const int row = nlp.JacobianRows()[k], col = nlp.JacobianCols()[k];
    const int c = equality[static_cast<std::size_t>(row)];
    if (c < 0) continue;
    if (!std::isfinite(cvalues[k])) {
      return "the constraint Jacobian has a non-finite entry (" + Num(cvalues[k]) +
             " at constraint " + std::to_string(row) + ", column " + name_of(col) + ")";
    }
    at.emplace_back(c, col, unscaled(col, cvalues[k]));
  }
  // J^T J must not overflow (a diverging linearisation, e.g. a very steep law under an explicit
  // scheme, gives finite but huge entries).
  double largest = 0.0;
  int largest_row = 0, largest_col = 0;
  for (const auto& t : jt) {
    if (std::fabs(t.value()) > largest) {
      largest = std::fabs(t.value());
      largest_row = t.row();
      largest_col = t.col();
    }
  }
  if (largest > std::sqrt(std::numeric_limits<double>::max() / std::max(1, n))) {
    return "J^T J overflows: the residual Jacobian reaches " + Num(largest) + " (row " +
           std::to_string(largest_row) + ", column " + name_of(largest_col) + ")";
  }
  // Compact numbering of the constraint rows and nuisance variables that have entries.
  Eigen::VectorXd row_max = Eigen::VectorXd::Zero(m);
  std::vector<char> used(static_cast<std::size_t>(nw), 0);
  for (const auto& t : at) {
    row_max[t.row()] = std::max(row_max[t.row()], std::fabs(t.value()));
    if (t.value() != 0.0) used[static_cast<std::size_t>(t.col())] = 1;
  }
  for (const auto& t : jt) {
    if (t.value() != 0.0) used[static_cast<std::size_t>(t.col())] = 1;
  }
  std::vector<int> constraint_index(static_cast<std::size_t>(m), -1);
  std::vector<int> nuisance_index(static_cast<std::size_t>(nw), -1);
  int mm = 0, nn = 0;
  for (int i = 0; i < m; ++i) {
    if (row_max[i] > 0.0) constraint_index[static_cast<std::size_t>(i)] = mm++;
  }
  for (int col = nf; col < nw; ++col) {
    if (used[static_cast<std::size_t>(col)]) nuisance_index[static_cast<std::size_t>(col)] = nn++;
  }
  out->j_theta = Eigen::MatrixXd::Zero(n, nf);
  out->a_theta = Eigen::MatrixXd::Zero(mm, nf);
  std::vector<Eigen::Triplet<double>> jn, an;
  for (const auto& t : jt) {
    if (t.col() < nf) {
      out->j_theta(t.row(), t.col()) += t.value();
    } else if (nuisance_index[static_cast<std::size_t>(t.col())] >= 0) {
      jn.emplace_back(t.row(), nuisance_index[static_cast<std::size_t>(t.col())], t.value());
    }
  }
  for (const auto& t : at) {
    const int row = constraint_index[static_cast<std::size_t>(t.row())];
    if (row < 0) continue;
    const double v = t.value() / row_max[t.row()];
    if (t.col() < nf) {
      out->a_theta(row, t.col()) += v;
    } else if (nuisance_index[static_cast<std::size_t>(t.col())] >= 0) {
      an.emplace_back(row, nuisance_index[static_cast<std::size_t>(t.col())], v);
    }
  }
  out->j_n.resize(n, nn);
  out->j_n.setFromTriplets(jn.begin(), jn.end());
  out->a_n.resize(mm, nn);
  out->a_n.setFromTriplets(an.begin(), an.end());
  return "";
}

// Eliminates the nuisance variables along the exact constraints: for a change dtheta of the
// parameters they move by dn = -Y_n dtheta, the solution of
//   [J_n^T J_n  A_n^T] [Y_n]   [J_n^T J_theta]
//   [A_n        0    ] [Y_l] = [A_theta      ],
// so the effective Jacobian is G = J_theta - J_n Y_n (and G^T G is the Schur complement of the
// whole KKT matrix: the information of the constrained problem). Sparse LU of the KKT matrix,
// linear in the record length for shooting and collocation; retried once with a slightly
// regularised nuisance block (harmless: a nuisance direction without information or constraint
// is uncoupled from the parameters). Returns why it failed, or "".
std::string EliminateNuisance(const Linearised& lin, Eigen::MatrixXd* g,
                              Eigen::VectorXd* reference) {
  const auto nn = static_cast<int>(lin.j_n.cols()), mm = static_cast<int>(lin.a_n.rows());
  *g = lin.j_theta;
  *reference = lin.j_theta.colwise().norm().transpose();
  if (nn == 0) {
    if (mm == 0) return "";
    return "the " + std::to_string(mm) +
           " equality constraints involve the parameters only (no nuisance variable); a "
           "covariance under parameter constraints is not supported";
  }
  const Sparse hnn = Sparse(lin.j_n.transpose() * lin.j_n);
  Eigen::MatrixXd rhs(nn + mm, lin.j_theta.cols());
  rhs.topRows(nn) = lin.j_n.transpose() * lin.j_theta;
  rhs.bottomRows(mm) = lin.a_theta;
  double max_diag = 0.0;
  for (int i = 0; i < nn; ++i) max_diag = std::max(max_diag, hnn.coeff(i, i));
  for (int attempt = 0; attempt < 2; ++attempt) {
    const double mu = attempt == 0 ? 0.0 : kNuisanceRegularisation * std::max(max_diag, 1.0);
    std::vector<Eigen::Triplet<double>> kt;
    kt.reserve(static_cast<std::size_t>(hnn.nonZeros() + 2 * lin.a_n.nonZeros() + nn));
    for (Eigen::Index c = 0; c < hnn.outerSize(); ++c) {
      for (Sparse::InnerIterator it(hnn, c); it; ++it) {
        kt.emplace_back(static_cast<int>(it.row()), static_cast<int>(it.col()), it.value());
      }
    }
    for (int i = 0; i < nn && mu > 0.0; ++i) kt.emplace_back(i, i, mu);
    for (Eigen::Index c = 0; c < lin.a_n.outerSize(); ++c) {
      for (Sparse::InnerIterator it(lin.a_n, c); it; ++it) {
        const auto row = static_cast<int>(it.row()), col = static_cast<int>(it.col());
        kt.emplace_back(nn + row, col, it.value());
        kt.emplace_back(col, nn + row, it.value());
      }
    }
    Sparse kkt(nn + mm, nn + mm);
    kkt.setFromTriplets(kt.begin(), kt.end());
    kkt.makeCompressed();
    Eigen::SparseLU<Sparse, Eigen::COLAMDOrdering<int>> lu;
    lu.analyzePattern(kkt);
    lu.factorize(kkt);
    if (lu.info() != Eigen::Success) continue;
    const Eigen::MatrixXd y = lu.solve(rhs);
    if (lu.info() != Eigen::Success || !y.allFinite()) continue;
    const double scale = std::max(rhs.norm(), std::numeric_limits<double>::min());
    if ((kkt * y - rhs).norm() > kKktResidualTolerance * scale) continue;
    const Eigen::MatrixXd moved = lin.j_n * y.topRows(nn);
    *reference = reference->cwiseMax(moved.colwise().norm().transpose());
    *g -= moved;
    return "";
  }
  return "the elimination of the " + std::to_string(nn) + " nuisance variables along " +
         std::to_string(mm) +
         " exact constraints is singular (a shooting node or initial state is determined neither "
         "by the data nor by the constraints, or constraints are redundant)";
}

}  // namespace

UncertaintyReport NlpCovariance(const Nlp& nlp, const Eigen::VectorXd& w, const ParameterMap& map,
                                const CovarianceOptions& options) {
  options.Validate();
  const int nf = map.NumFree(), nw = nlp.NumVariables(), nr = nlp.NumResiduals();
  if (w.size() != nw || nf > nw || map.scale.size() != nf) {
    throw std::invalid_argument("NlpCovariance: expected w of size " + std::to_string(nw) +
                                " starting with " + std::to_string(map.scale.size()) +
                                " scaled parameters, got w of size " + std::to_string(w.size()) +
                                " and " + std::to_string(nf) + " free parameters");
  }
  std::vector<models::ModelParameter> params = map.source;
  const Eigen::VectorXd p = map.Values(w);
  for (std::size_t i = 0; i < params.size() && i < static_cast<std::size_t>(p.size()); ++i) {
    params[i].value = p[static_cast<Eigen::Index>(i)];
  }
  CheckFreeIndices(params, map.free, "NlpCovariance");
  std::vector<char> is_constraint(static_cast<std::size_t>(nr), 0);
  for (int row : options.constraint_residual_rows) {
    if (row < 0 || row >= nr || is_constraint[static_cast<std::size_t>(row)]) {
      throw std::invalid_argument(
          "NlpCovariance: CovarianceOptions.constraint_residual_rows: expected distinct rows in "
          "[0, " +
          std::to_string(nr) + "), got " + std::to_string(row));
    }
    is_constraint[static_cast<std::size_t>(row)] = 1;
  }
  if (!options.row_channels.empty()) {
    CheckChannels(options.row_channels, static_cast<std::size_t>(nr), "NlpCovariance",
                  &is_constraint);
  }
  const int n = nr - static_cast<int>(options.constraint_residual_rows.size());
  Linearised lin;
  std::string why = Linearise(nlp, w, map, is_constraint, options.row_channels, &lin);
  Eigen::MatrixXd g;
  Eigen::VectorXd reference;
  if (why.empty()) why = EliminateNuisance(lin, &g, &reference);
  if (!why.empty()) return Failed(why, params, map.free, n);
  const auto n_eff = static_cast<int>(nf + lin.j_n.cols() - lin.a_n.rows());
  const double dof = std::max(1.0, static_cast<double>(n - n_eff));
  return FromEffectiveJacobian(std::move(g), reference, lin.r, dof, lin.channel, params, map.free,
                               options);
}

namespace {

// What the residual rows of a shooting problem are, from the labels its formulation gave them
// (Nlp::residual_labels): BuildMultipleShooting and BuildSingleShooting register the model
// outputs first, in output order, so channel j < ny is output j; a channel named
// "continuity.<state>" holds the continuity rows of the Ceres form; any other channel
// ("regularization.<name>", ...) is another residual.
struct ShootingRows {
  std::vector<int> continuity;  // ascending
  std::vector<int> channel;     // per residual row: output channel, -1 continuity, ny other rows
};

ShootingRows ClassifyShootingRows(const ShootingProblem& problem, const char* where) {
  const Nlp& nlp = problem.nlp;
  const auto ny = static_cast<int>(problem.output_weights.size());
  const std::vector<ResidualLabel>& labels = nlp.residual_labels();
  const std::vector<std::string>& names = nlp.residual_channels();
  assert(static_cast<int>(labels.size()) == nlp.NumResiduals() &&
         "Nlp keeps one ResidualLabel per residual row");
  assert(static_cast<int>(names.size()) >= ny &&
         "the shooting formulations register one residual channel per model output first");
  const std::string continuity_prefix = "continuity.";
  ShootingRows rows;
  rows.channel.assign(labels.size(), ny);
  for (std::size_t row = 0; row < labels.size(); ++row) {
    const int c = labels[row].channel;
    if (c < 0) {
      throw std::invalid_argument(
          std::string(where) +
          ": expected every residual row of a shooting problem labelled (Nlp::residual_labels: "
          "an output, a continuity condition or another residual), got row " +
          std::to_string(row) + " of " + std::to_string(labels.size()) +
          " unlabelled (channel -1); hint: label residuals added to problem.nlp after "
          "BuildMultipleShooting / BuildSingleShooting with Nlp::ResidualChannel and "
          "Nlp::LabelResidual");
    }
    assert(c < static_cast<int>(names.size()) && "Nlp::LabelResidual checks the channel index");
    if (c < ny) {
      rows.channel[row] = c;
    } else if (names[static_cast<std::size_t>(c)].rfind(continuity_prefix, 0) == 0) {
      rows.channel[row] = -1;
      rows.continuity.push_back(static_cast<int>(row));
    } else if (names[static_cast<std::size_t>(c)].rfind("regularization.", 0) == 0) {
      rows.channel[row] = kPenaltyRow;  // a penalty: information, no noise
    }
  }
  return rows;
}

}  // namespace

std::vector<int> ContinuityResidualRows(const ShootingProblem& problem) {
  return ClassifyShootingRows(problem, "ContinuityResidualRows").continuity;
}

UncertaintyReport NlpCovariance(const ShootingProblem& problem, const Eigen::VectorXd& w,
                                const CovarianceOptions& options) {
  const ShootingRows rows = ClassifyShootingRows(problem, "NlpCovariance");
  CovarianceOptions o = options;
  if (o.constraint_residual_rows.empty()) o.constraint_residual_rows = rows.continuity;
  if (o.row_channels.empty()) {
    o.row_channels = rows.channel;
    const auto ny = problem.output_weights.size();
    const bool other = std::find(rows.channel.begin(), rows.channel.end(), static_cast<int>(ny)) !=
                       rows.channel.end();
    if (o.channel_weights.size() == 0) {
      o.channel_weights = Eigen::VectorXd::Ones(ny + (other ? 1 : 0));
      o.channel_weights.head(ny) = problem.output_weights;
    }
    if (other && o.channel_names.size() == static_cast<std::size_t>(ny)) {
      o.channel_names.push_back("other residuals");
      if (o.channel_units.size() == static_cast<std::size_t>(ny)) o.channel_units.push_back("");
    }
  }
  return NlpCovariance(problem.nlp, w, problem.parameters, o);
}

UncertaintyReport SimulationCovariance(const Integrator& integrator,
                                       const std::vector<Experiment>& experiments,
                                       const Eigen::VectorXd& p,
                                       const std::vector<Eigen::VectorXd>& initial_states,
                                       const Eigen::VectorXd& output_weights,
                                       const CovarianceOptions& options) {
  options.Validate();
  const models::StateSpaceModel& model = integrator.model();
  const int nx = model.NumStates(), ny = model.NumOutputs();
  std::vector<int> free;
  for (int i = 0; i < model.NumParameters(); ++i) {
    if (model.parameters[i].free) free.push_back(i);
  }
  const int nf = static_cast<int>(free.size());
  if (initial_states.size() != experiments.size() || output_weights.size() != ny ||
      p.size() != model.NumParameters()) {
    throw std::invalid_argument(
        "SimulationCovariance: expected " + std::to_string(experiments.size()) +
        " initial states, " + std::to_string(ny) + " output weights and " +
        std::to_string(model.NumParameters()) + " parameter values, got " +
        std::to_string(initial_states.size()) + ", " + std::to_string(output_weights.size()) +
        " and " + std::to_string(p.size()));
  }
  long total_rows = 0;
  for (const auto& ex : experiments) {
    if (ex.y.cols() != ny || ex.y.rows() != ex.u.rows()) {
      throw std::invalid_argument("SimulationCovariance: experiment '" + ex.name + "': expected " +
                                  std::to_string(ex.u.rows()) + " x " + std::to_string(ny) +
                                  " outputs, got " + std::to_string(ex.y.rows()) + " x " +
                                  std::to_string(ex.y.cols()));
    }
    total_rows += ex.u.rows() * ny;
  }
  std::vector<models::ModelParameter> params = model.parameters;
  for (int i = 0; i < model.NumParameters(); ++i) params[i].value = p[i];
  const int nx0 = options.free_initial_states ? nx : 0;
  const int ncols = nf + nx0 * static_cast<int>(experiments.size());
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(total_rows, ncols);
  Eigen::VectorXd res(total_rows);
  long row = 0;
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const auto& ex = experiments[e];
    const SensitivityTrajectory t =
        integrator.SimulateWithSensitivities(initial_states[e], ex.u, p, free);
    if (!t.summary.ok()) {
      return Failed(
          "the simulation of experiment '" + ex.name + "' failed: " + t.summary.BriefReport(),
          params, free, static_cast<int>(total_rows));
    }
    for (Eigen::Index k = 0; k < ex.u.rows(); ++k) {
      for (int j = 0; j < ny; ++j) {
        res[row + j] = output_weights[j] * (t.y(k, j) - ex.y(k, j));
        jac.row(row + j).head(nf) = output_weights[j] * t.dy_dp[k].row(j);
        if (nx0 > 0) {
          jac.row(row + j).segment(nf + nx0 * static_cast<Eigen::Index>(e), nx0) =
              output_weights[j] * t.dy_dx0[k].row(j);
        }
      }
      row += ny;
    }
    // The integrators check the states, not the sensitivities: name the first non-finite one.
    const long start = row - ex.u.rows() * ny;
    Eigen::Index bad_row = 0, bad_col = 0;
    if (FirstNonFinite(jac.middleRows(start, row - start), &bad_row, &bad_col)) {
      const auto k = static_cast<int>(bad_row / ny), j = static_cast<int>(bad_row % ny);
      const std::string wrt = bad_col < nf ? params[free[bad_col]].name
                                           : "x0[" + std::to_string((bad_col - nf) % nx) + "]";
      return Failed("the sensitivity d " + ex.ChannelName(ChannelGroup::kOutput, j) + " / d " +
                        wrt + " of experiment '" + ex.name + "' is " +
                        Num(jac(start + bad_row, bad_col)) + " at sample " + std::to_string(k) +
                        " (t = " + Num(ex.TimeAt(k)) +
                        " s) while the simulated state is finite: the linearised model diverges "
                        "under " +
                        integrator.Name() +
                        " (a very steep law such as tanh friction with a large steepness; try an "
                        "implicit scheme, more substeps or a smaller steepness)",
                    params, free, static_cast<int>(total_rows));
    }
  }
  CovarianceOptions per_output = options;
  if (per_output.row_channels.empty()) {  // rows are time-major: row k ny + j is output j
    per_output.row_channels.resize(static_cast<std::size_t>(total_rows));
    for (long r = 0; r < total_rows; ++r) per_output.row_channels[r] = static_cast<int>(r % ny);
    if (per_output.channel_weights.size() == 0) per_output.channel_weights = output_weights;
    if (per_output.channel_names.empty() && !experiments.empty()) {
      for (int j = 0; j < ny; ++j) {
        per_output.channel_names.push_back(experiments[0].ChannelName(ChannelGroup::kOutput, j));
        per_output.channel_units.push_back(experiments[0].ChannelUnit(ChannelGroup::kOutput, j));
      }
    }
  }
  return CovarianceFromJacobian(jac, res, params, free, per_output);
}

UncertaintyReport SimulationCovariance(const models::StateSpaceModel& model,
                                       const std::vector<Experiment>& experiments,
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
