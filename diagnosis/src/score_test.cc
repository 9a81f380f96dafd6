#include "screening_internal.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>
#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/nlp/nlp.h"

namespace graybox::diagnosis::internal {
namespace {

namespace est = graybox::estimators;
// Ridge on H relative to its largest diagonal entry: far below any direction the data determine
// (condition numbers of scaled identification problems stay well under 1e9), large enough to
// make directions without information (a position node no output sees) solvable.
constexpr double kRidge = 1e-9;
// Regularisation of the multiplier block of the KKT matrix, relative to max diag(H): keeps a
// redundant constraint row from making it singular, changes d by O(1e-14).
constexpr double kMultiplierRidge = 1e-14;
// A variable within this distance of a bound (relative to max(1, |w|), in the NLP's scaled
// variables) is at the bound: Ipopt's interior point stops within about its tolerance of it.
constexpr double kActiveBound = 1e-6;

Eigen::SparseMatrix<double> Triplets(int rows, int cols, const std::vector<int>& r,
                                     const std::vector<int>& c, const Eigen::VectorXd& v) {
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(v.size());
  for (Eigen::Index k = 0; k < v.size(); ++k) t.emplace_back(r[k], c[k], v[k]);
  Eigen::SparseMatrix<double> m(rows, cols);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

// The Gauss-Newton decrease -g^T d of |r|^2 at w over the free variables except those named in
// `held` (see the header), and the noise variance of the full problem. Throws std::runtime_error
// when the NLP cannot be evaluated.
double GaussNewtonDecrease(const est::Nlp& nlp, const Eigen::VectorXd& w,
                           const std::vector<std::string>& held,
                           const std::vector<std::string>& candidate_names, double* sigma2) {
  const int n = nlp.NumVariables();
  const int m = nlp.NumResiduals();
  Eigen::VectorXd r(m);
  est::NlpEvalStatus s = nlp.Residuals(w.data(), r.data());
  if (!s.ok) throw std::runtime_error("residuals: " + s.message);
  Eigen::VectorXd jv(nlp.ResidualJacobianRows().size());
  s = nlp.ResidualJacobianValues(w.data(), jv.data());
  if (!s.ok) throw std::runtime_error("residual Jacobian: " + s.message);
  if (!r.allFinite() || !jv.allFinite()) throw std::runtime_error("non-finite residuals");
  // Free columns.
  std::vector<int> column(n, -1);
  int nf = 0;
  for (int i = 0; i < n; ++i) {
    const bool is_held = std::find(held.begin(), held.end(), nlp.names()[i]) != held.end();
    // A variable at one of its bounds is held too: the score test is taken on the directions
    // the constraints let the estimate move in (a bound-blocked gradient is not a gain).
    const double lb = nlp.lbw()[i], ub = nlp.ubw()[i];
    const double tol = kActiveBound * std::max(1.0, std::fabs(w[i]));
    const bool candidate = std::find(candidate_names.begin(), candidate_names.end(),
                                     nlp.names()[i]) != candidate_names.end();
    const bool active = !candidate && (w[i] - lb <= tol || ub - w[i] <= tol);
    if (lb < ub && !is_held && !active) column[i] = nf++;
  }
  Eigen::SparseMatrix<double> J =
      Triplets(m, n, nlp.ResidualJacobianRows(), nlp.ResidualJacobianCols(), jv);
  Eigen::SparseMatrix<double> P(n, nf);  // selects the free columns
  {
    std::vector<Eigen::Triplet<double>> t;
    for (int i = 0; i < n; ++i) {
      if (column[i] >= 0) t.emplace_back(i, column[i], 1.0);
    }
    P.setFromTriplets(t.begin(), t.end());
  }
  const Eigen::SparseMatrix<double> Jf = J * P;
  Eigen::SparseMatrix<double> H = Eigen::SparseMatrix<double>(Jf.transpose()) * Jf;
  const Eigen::VectorXd g = Jf.transpose() * r;
  // Equality constraints on the free columns.
  Eigen::SparseMatrix<double> A(0, nf);
  if (nlp.NumConstraints() > 0) {
    Eigen::VectorXd cv(nlp.JacobianRows().size());
    s = nlp.JacobianValues(w.data(), cv.data());
    if (!s.ok) throw std::runtime_error("constraint Jacobian: " + s.message);
    const Eigen::SparseMatrix<double> Af =
        Triplets(nlp.NumConstraints(), n, nlp.JacobianRows(), nlp.JacobianCols(), cv) * P;
    const Eigen::VectorXd lbg = nlp.lbg(), ubg = nlp.ubg();
    Eigen::SparseMatrix<double, Eigen::RowMajor> rows(Af);
    std::vector<Eigen::Triplet<double>> t;
    int ce = 0;
    for (int i = 0; i < rows.rows(); ++i) {
      if (lbg[i] != ubg[i] || rows.row(i).nonZeros() == 0) continue;
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(rows, i); it; ++it) {
        t.emplace_back(ce, it.col(), it.value());
      }
      ++ce;
    }
    A.resize(ce, nf);
    A.setFromTriplets(t.begin(), t.end());
  }
  const int ce = static_cast<int>(A.rows());
  double hmax = 0.0;
  for (int i = 0; i < nf; ++i) hmax = std::max(hmax, H.coeff(i, i));
  if (!(hmax > 0.0)) throw std::runtime_error("the residuals do not depend on the variables");
  std::vector<Eigen::Triplet<double>> k;
  for (int j = 0; j < H.outerSize(); ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(H, j); it; ++it) {
      k.emplace_back(it.row(), it.col(), it.value());
    }
  }
  for (int i = 0; i < nf; ++i) k.emplace_back(i, i, kRidge * hmax);
  for (int j = 0; j < A.outerSize(); ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, j); it; ++it) {
      k.emplace_back(nf + it.row(), it.col(), it.value());
      k.emplace_back(it.col(), nf + it.row(), it.value());
    }
  }
  for (int i = 0; i < ce; ++i) k.emplace_back(nf + i, nf + i, -kMultiplierRidge * hmax);
  Eigen::SparseMatrix<double> K(nf + ce, nf + ce);
  K.setFromTriplets(k.begin(), k.end());
  K.makeCompressed();
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
  lu.compute(K);
  if (lu.info() != Eigen::Success) throw std::runtime_error("the KKT matrix is singular");
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(nf + ce);
  rhs.head(nf) = -g;
  const Eigen::VectorXd d = lu.solve(rhs);
  if (lu.info() != Eigen::Success || !d.allFinite()) {
    throw std::runtime_error("the KKT solve failed");
  }
  const int dof_noise = std::max(1, m - (nf - ce));
  if (sigma2 != nullptr) *sigma2 = r.squaredNorm() / dof_noise;
  return -g.dot(d.head(nf));
}

// LM statistic at w: the decrease with the candidate's parameters free minus the decrease without
// them (the efficient score: what the new directions add beyond what the nominal directions would
// still gain at w, which is not zero when w is the nominal optimum only to the solver's
// tolerance; on a closed loop fitted by Ipopt that remainder alone reached LM ~ 4e4 and made every
// candidate score alike).
void ScoreAt(const est::Nlp& nlp, const Eigen::VectorXd& w, const Candidate& candidate,
             CandidateScore* out) {
  double sigma2 = 0.0;
  const double full = GaussNewtonDecrease(nlp, w, {}, candidate.screened, &sigma2);
  const double nominal =
      GaussNewtonDecrease(nlp, w, candidate.screened, candidate.screened, nullptr);
  out->sigma2 = sigma2;
  if (!(out->sigma2 > 0.0)) throw std::runtime_error("zero residuals: no noise level");
  out->score = std::max(0.0, full - nominal) / out->sigma2;
}

// The score of the simulation (output-error) loss on the estimation splits, from forward
// sensitivities of the augmented model at the restricted estimate (see the header): exact, dense
// and small (one column per free parameter), so nothing cancels. Returns false (and leaves `out`
// alone) when a simulation does not finish.
bool ScoreBySimulation(const est::Problem& aug, const std::vector<est::SplitData>& splits,
                       const est::FitResult& nominal, const Candidate& candidate,
                       CandidateScore* out) {
  const models::StateSpaceModel& m = aug.built;
  std::vector<int> columns;   // model parameter indices: nominal free, then the candidate's
  std::vector<double> scale;  // column scaling (the parameter's scale)
  int num_candidate = 0;
  for (int pass = 0; pass < 2; ++pass) {
    for (int i = 0; i < m.NumParameters(); ++i) {
      const models::ModelParameter& p = m.parameters[i];
      const bool is_candidate = std::find(candidate.screened.begin(), candidate.screened.end(),
                                          p.name) != candidate.screened.end();
      if ((pass == 0 && p.free && !is_candidate) || (pass == 1 && is_candidate)) {
        columns.push_back(i);
        scale.push_back(p.scale > 0.0 ? p.scale : 1.0);
        num_candidate += pass;
      }
    }
  }
  const Eigen::VectorXd values = m.ParameterValues();
  std::vector<Eigen::MatrixXd> blocks_j;
  std::vector<Eigen::VectorXd> blocks_r;
  Eigen::Index rows = 0;
  for (const est::SplitData& split : splits) {
    if (split.role != est::SplitRole::kEstimation) continue;
    const est::Experiment& e = split.experiment;
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(m.NumStates());
    const auto it = nominal.initial_states.find(split.name);
    const Eigen::VectorXd& x0_nominal =
        it != nominal.initial_states.end() ? it->second : split.setup.x0;
    x0.head(std::min<Eigen::Index>(x0_nominal.size(), x0.size())) =
        x0_nominal.head(std::min<Eigen::Index>(x0_nominal.size(), x0.size()));
    const std::unique_ptr<est::Integrator> integrator =
        est::MakeIntegrator(m, e.dt, aug.estimation.integrator);
    const est::SensitivityTrajectory t =
        integrator->SimulateWithSensitivities(x0, e.u, values, columns);
    if (!t.ok || !t.y.allFinite()) return false;
    const Eigen::Index n = e.y.rows(), ny = e.y.cols();
    Eigen::VectorXd weight(ny);
    for (Eigen::Index c = 0; c < ny; ++c) {
      const double mean = e.y.col(c).mean();
      const double sd = std::sqrt((e.y.col(c).array() - mean).square().mean());
      weight[c] = sd > 0.0 ? 1.0 / sd : 1.0;
    }
    Eigen::MatrixXd jac(n * ny, columns.size());
    Eigen::VectorXd r(n * ny);
    for (Eigen::Index k = 0; k < n; ++k) {
      for (Eigen::Index c = 0; c < ny; ++c) {
        r[k * ny + c] = weight[c] * (e.y(k, c) - t.y(k, c));
        for (std::size_t j = 0; j < columns.size(); ++j) {
          jac(k * ny + c, j) = weight[c] * t.dy_dp[k](c, j) * scale[j];
        }
      }
    }
    if (!jac.allFinite()) return false;
    rows += n * ny;
    blocks_j.push_back(std::move(jac));
    blocks_r.push_back(std::move(r));
  }
  if (rows == 0) return false;
  Eigen::MatrixXd J(rows, columns.size());
  Eigen::VectorXd r(rows);
  Eigen::Index at = 0;
  for (std::size_t b = 0; b < blocks_j.size(); ++b) {
    J.middleRows(at, blocks_j[b].rows()) = blocks_j[b];
    r.segment(at, blocks_r[b].size()) = blocks_r[b];
    at += blocks_j[b].rows();
  }
  // |projection of r onto the span of the columns|^2, by a rank-revealing QR.
  auto decrease = [&](int num_columns) {
    if (num_columns == 0) return 0.0;
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(J.leftCols(num_columns));
    const Eigen::VectorXd qtr = qr.householderQ().transpose() * r;
    return qtr.head(qr.rank()).squaredNorm();
  };
  const int n_nominal = static_cast<int>(columns.size()) - num_candidate;
  // The one-step (Gauss-Newton) estimate of the candidate's parameters: the least-squares step of
  // every column from this point, in parameter units.
  {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(J);
    const Eigen::VectorXd step = qr.solve(r);
    out->one_step.assign(candidate.screened.size(), kNaN);
    for (std::size_t j = n_nominal; j < columns.size(); ++j) {
      const models::ModelParameter& p = m.parameters[columns[j]];
      const auto at = std::find(candidate.screened.begin(), candidate.screened.end(), p.name);
      if (at != candidate.screened.end() && step.allFinite()) {
        out->one_step[at - candidate.screened.begin()] = values[columns[j]] + step[j] * scale[j];
      }
    }
  }
  const double full = decrease(static_cast<int>(columns.size()));
  const double restricted = decrease(n_nominal);
  const double sigma2 = r.squaredNorm() / std::max<Eigen::Index>(1, rows - n_nominal);
  if (!(sigma2 > 0.0)) return false;
  out->sigma2 = sigma2;
  out->score = std::max(0.0, full - restricted) / sigma2;
  out->method = "simulation";
  return true;
}

// The scale of a shape grid (candidates.h): 1, the first estimation split's sample time, or the
// RMS of a state over the nominal model's simulation of the estimation splits (NaN when that
// simulation fails or the state is unknown).
double ShapeScale(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                  const est::FitResult& nominal, const Candidate::ShapeGrid& grid) {
  using Scale = Candidate::ShapeGrid::Scale;
  if (grid.scale == Scale::kAbsolute) return 1.0;
  if (grid.scale == Scale::kSampleRateSquared) {
    for (const est::SplitData& split : splits) {
      if (split.role == est::SplitRole::kEstimation) {
        return 1.0 / (split.experiment.dt * split.experiment.dt);
      }
    }
    return kNaN;
  }
  double dt = kNaN;
  for (const est::SplitData& split : splits) {
    if (split.role == est::SplitRole::kEstimation) {
      dt = split.experiment.dt;
      break;
    }
  }
  const models::StateSpaceModel& m = problem.built;
  int state = -1;
  for (int i = 0; i < m.NumStates(); ++i) {
    if (m.states[i].name == grid.state) state = i;
  }
  double sum = 0.0;
  Eigen::Index count = 0;
  for (const est::SplitData& split : splits) {
    if (split.role != est::SplitRole::kEstimation) continue;
    const est::Experiment& e = split.experiment;
    if (grid.scale == Scale::kSampleTime) return e.dt;
    if (state < 0) return kNaN;
    const Eigen::VectorXd x0 = est::InitialStateOf(split, nominal.initial_states);
    const std::unique_ptr<est::Integrator> integrator =
        est::MakeIntegrator(m, e.dt, problem.estimation.integrator);
    const est::Trajectory t = integrator->Simulate(x0, e.u, nominal.values);
    if (!t.ok || !t.x.allFinite()) return kNaN;
    sum += t.x.col(state).squaredNorm();
    count += t.x.rows();
  }
  const double rms = count > 0 ? std::sqrt(sum / count) : kNaN;
  return grid.scale == Scale::kStateRmsTimesSampleTime ? rms * dt : rms;
}

// Scores each of `variants` (the simulation score) and keeps the best in *out (candidate, score,
// one-step estimate); returns its index, or -1 when none could be scored (*out unchanged).
int BestScoring(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                const est::FitResult& nominal, const std::vector<Candidate>& variants,
                CandidateScore* out) {
  int best = -1;
  CandidateScore best_score;
  for (std::size_t i = 0; i < variants.size(); ++i) {
    CandidateScore trial = *out;
    trial.candidate = variants[i];
    const est::Problem aug = AugmentedProblem(problem, nominal, variants[i], false);
    if (ScoreBySimulation(aug, splits, nominal, variants[i], &trial) &&
        (best < 0 || trial.score > best_score.score)) {
      best = static_cast<int>(i);
      best_score = std::move(trial);
    }
  }
  if (best >= 0) out->candidate = best_score.candidate;
  return best;
}

// `candidate` with a shape parameter set to `value` after it is applied.
Candidate WithShape(const Candidate& candidate, const std::string& parameter, double value) {
  Candidate c = candidate;
  const std::function<void(models::Model*)> apply = candidate.apply;
  c.apply = [apply, parameter, value](models::Model* m) {
    apply(m);
    m->SetParameter(parameter, value);
  };
  return c;
}

}  // namespace

CandidateScore Score(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                     const est::FitResult& nominal, const Candidate& candidate) {
  CandidateScore out;
  out.candidate = candidate;
  out.dof = static_cast<int>(candidate.screened.size());
  try {
    if (candidate.structural) {
      // No score test; the grids' values are profiled by the re-fit.
      out.method = "structural";
      out.score = out.p_value = kNaN;
      // The option grid's values, the first the one apply() uses: the re-fit profiles them.
      if (!candidate.option_grids.empty() && candidate.apply_with_option) {
        const Candidate::OptionGrid& grid = candidate.option_grids.front();
        Candidate::ShapeGrid g;
        g.scale = grid.scale;
        g.state = grid.state;
        const double scale = ShapeScale(problem, splits, nominal, g);
        if (std::isfinite(scale) && scale > 0.0 && !grid.factors.empty()) {
          for (const double factor : grid.factors) {
            out.option_grid_values.push_back(grid.inverse ? factor / scale : factor * scale);
          }
          out.shape_start.emplace_back(candidate.instance + " option " + grid.option,
                                       out.option_grid_values.front());
        }
      }
      for (const Candidate::ShapeGrid& grid : candidate.shape_grids) {
        const double scale = ShapeScale(problem, splits, nominal, grid);
        if (!(std::isfinite(scale) && scale > 0.0)) continue;
        const est::Problem aug = AugmentedProblem(problem, nominal, candidate, false);
        const models::ModelParameter& p =
            aug.built.parameters[aug.built.ParameterIndex(grid.parameter)];
        std::vector<double> values;
        for (const double factor : grid.factors) {
          const double v = factor * scale;
          if (v >= p.lower && v <= p.upper) values.push_back(v);
        }
        if (!values.empty()) out.shape_grid_values.emplace_back(grid.parameter, values);
      }
      return out;
    }
    if (out.dof == 0) throw std::runtime_error("no parameter with a neutral value to test");
    // The option grid's values (or the candidate as it is), each with the shape grids chosen at
    // it, jointly: the best scoring pair is kept (its candidate re-fitted from there). Jointly,
    // since one shape value can favour another option (a Stribeck hump at a small velocity needs
    // a steep sign) than the block's nominal shape would.
    std::vector<CandidateScore> starts;
    if (!candidate.option_grids.empty() && candidate.apply_with_option) {
      if (candidate.option_grids.size() > 1) {
        throw std::invalid_argument("Candidate " + candidate.Name() +
                                    ": expected at most one option grid, got " +
                                    std::to_string(candidate.option_grids.size()));
      }
      const Candidate::OptionGrid& grid = candidate.option_grids.front();
      Candidate::ShapeGrid g;
      g.scale = grid.scale;
      g.state = grid.state;
      const double scale = ShapeScale(problem, splits, nominal, g);
      if (std::isfinite(scale) && scale > 0.0) {
        for (const double factor : grid.factors) {
          out.option_grid_values.push_back(grid.inverse ? factor / scale : factor * scale);
        }
        for (const double v : out.option_grid_values) {
          CandidateScore start = out;
          const auto apply = candidate.apply_with_option;
          start.candidate.apply = [apply, v](models::Model* m) { apply(m, v); };
          start.shape_start.emplace_back(candidate.instance + " option " + grid.option, v);
          starts.push_back(std::move(start));
        }
      }
    }
    if (starts.empty()) starts.push_back(out);
    int best_start = -1;
    for (std::size_t k = 0; k < starts.size(); ++k) {
      CandidateScore& start = starts[k];
      bool scored = false;
      for (const Candidate::ShapeGrid& grid : candidate.shape_grids) {
        const double scale = ShapeScale(problem, splits, nominal, grid);
        if (!(std::isfinite(scale) && scale > 0.0)) continue;
        const est::Problem augmented = AugmentedProblem(problem, nominal, start.candidate, false);
        const models::ModelParameter& p =
            augmented.built.parameters[augmented.built.ParameterIndex(grid.parameter)];
        std::vector<double> values;
        std::vector<Candidate> variants;
        for (const double factor : grid.factors) {
          const double v = factor * scale;
          if (!(v >= p.lower && v <= p.upper)) continue;
          values.push_back(v);
          variants.push_back(WithShape(start.candidate, grid.parameter, v));
        }
        const int best = BestScoring(problem, splits, nominal, variants, &start);
        if (best >= 0) {
          scored = true;
          start.shape_start.emplace_back(grid.parameter, values[best]);
          start.shape_grid_values.emplace_back(grid.parameter, values);
        }
      }
      if (starts.size() > 1 && !scored) {
        const est::Problem augmented = AugmentedProblem(problem, nominal, start.candidate, false);
        scored = ScoreBySimulation(augmented, splits, nominal, start.candidate, &start);
      }
      if (scored && (best_start < 0 || start.score > starts[best_start].score)) {
        best_start = static_cast<int>(k);
      }
    }
    if (best_start >= 0) {
      out = std::move(starts[best_start]);
    } else if (starts.size() == 1) {
      out = std::move(starts.front());
    }
    const est::Problem aug = AugmentedProblem(problem, nominal, out.candidate, false);
    if (ScoreBySimulation(aug, splits, nominal, out.candidate, &out)) {
      out.p_value = ChiSquareSurvival(out.score, out.dof);
      return out;
    }
    out.method = "nlp";
    est::FitOptions fo;
    fo.compute_covariance = false;
    fo.evaluate_splits = false;
    est::FitSession session(aug, AugmentedSplits(splits, aug.built.NumStates()), fo);
    const Eigen::VectorXd& w_nom = nominal.solver_result.w;
    // A point of the restricted problem (the candidate's parameters held) in the augmented NLP's
    // layout: the free parameters first in the model's parameter order (parameter_map.h), the
    // candidate's at their scaled start values (w0: neutral for a new block, the current value
    // for a freed parameter of the model), the others from `restricted` in order; then the
    // other variables.
    auto insert_neutral = [&](const est::Nlp& nlp, const Eigen::VectorXd& restricted) {
      Eigen::VectorXd w;
      if (restricted.size() == nlp.NumVariables()) return restricted;
      if (restricted.size() + out.dof != nlp.NumVariables()) return w;
      w.resize(nlp.NumVariables());
      Eigen::Index j = 0, r = 0;
      for (const models::ModelParameter& p : aug.built.parameters) {
        if (!p.free) continue;
        const bool held = std::find(candidate.screened.begin(), candidate.screened.end(), p.name) !=
                          candidate.screened.end();
        w(j) = held ? nlp.w0()(j) : restricted(r++);
        ++j;
      }
      w.tail(w.size() - j) = restricted.tail(restricted.size() - r);
      return w;
    };
    Eigen::VectorXd w;
    if (session.nlp().NumVariables() == w_nom.size() + out.dof) {
      w = insert_neutral(session.nlp(), w_nom);
    } else {
      out.restricted_solve = true;
      for (const auto& q : candidate.screened) session.FixParameter(q);
      const est::FitResult restricted = session.Solve();
      if (!restricted.IsSolutionUsable()) {
        throw std::runtime_error("restricted solve: " + restricted.solver_result.status + " " +
                                 restricted.solver_result.message);
      }
      for (const auto& q : candidate.screened) session.FreeParameter(q);
      w = insert_neutral(session.nlp(), restricted.solver_result.w);
      if (w.size() == 0) {
        throw std::runtime_error(
            "the restricted solution has " + std::to_string(restricted.solver_result.w.size()) +
            " variables; expected " + std::to_string(session.nlp().NumVariables()) + " or " +
            std::to_string(session.nlp().NumVariables() - out.dof));
      }
    }
    ScoreAt(session.nlp(), w, candidate, &out);
    out.p_value = ChiSquareSurvival(out.score, out.dof);
  } catch (const std::exception& e) {
    out.score = kNaN;
    out.p_value = kNaN;
    out.failure = e.what();
  }
  return out;
}

}  // namespace graybox::diagnosis::internal
