#include "graybox/diagnosis/screening.h"

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

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
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

std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

// The automatic re-fit budget (ScreeningOptions::refit_max_seconds = 0).
constexpr double kAutoBudgetFactor = 20.0;
constexpr double kAutoBudgetFloor = 10.0;

int NumFree(const std::vector<models::ModelParameter>& parameters) {
  int n = 0;
  for (const auto& p : parameters) n += p.free ? 1 : 0;
  return n;
}

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
    const auto it = nominal.initial_states.find(split.name);
    const Eigen::VectorXd& x0 = it != nominal.initial_states.end() ? it->second : split.setup.x0;
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
    const int n_nominal = NumFree(problem.built.parameters);
    const Eigen::VectorXd& w_nom = nominal.solver_result.w;
    // A point of the restricted problem (new parameters held) in the augmented NLP's layout: the
    // free parameters first, the candidate's (at their scaled neutral values, as in w0) after the
    // nominal ones, then the other variables.
    auto insert_neutral = [&](const est::Nlp& nlp, const Eigen::VectorXd& restricted) {
      Eigen::VectorXd w;
      if (restricted.size() == nlp.NumVariables()) return restricted;
      if (restricted.size() + out.dof == nlp.NumVariables() && restricted.size() >= n_nominal) {
        w.resize(nlp.NumVariables());
        w << restricted.head(n_nominal), nlp.w0().segment(n_nominal, out.dof),
            restricted.tail(restricted.size() - n_nominal);
      }
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

void InformationCriteria(const est::FitResult& fit, double* aic, double* bic) {
  const double n = fit.num_residuals;
  const double rss = 2.0 * fit.solver_result.cost;
  int k = 0;
  for (const auto& p : fit.parameters) k += p.free ? 1 : 0;
  if (!(n > 0.0) || !(rss > 0.0)) {
    *aic = *bic = kNaN;
    return;
  }
  const double fit_term = n * std::log(rss / n);
  *aic = fit_term + 2.0 * k;
  *bic = fit_term + k * std::log(n);
}

// The re-fit of one candidate, in two stages (see the header): (A) the screened parameters free,
// started from the score test's one-step estimate (from neutral again when that fails), the shape
// parameters held; (B) the shape parameters freed too, warm-started from A. B is kept only when
// it is usable, no freed shape parameter ends at a bound and its cost is not above A's.
RefitResult Refit(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                  const est::FitResult& nominal, const CandidateScore& screened,
                  const std::string& role, double before, double max_seconds) {
  const Candidate& c = screened.candidate;
  RefitResult out;
  out.candidate = c;
  out.effect = c.effect;
  out.detail = c.detail;
  out.attachment = c.attachment;
  out.score = screened.score;
  out.validation_nrmse_before = before;
  out.validation_nrmse_after = kNaN;
  out.relative_gain = kNaN;
  out.aic = out.bic = kNaN;
  try {
    const auto started = std::chrono::steady_clock::now();
    // The option the screening chose (Candidate::option_grids), in the declarative form too.
    std::string option;
    const std::string option_prefix = c.instance + " option ";
    for (const auto& [key, value] : screened.shape_start) {
      if (key.rfind(option_prefix, 0) != 0) continue;
      option = key.substr(option_prefix.size());
      out.candidate.augmentation.options.numbers[option] = {value};
    }
    est::Problem aug = AugmentedProblem(problem, nominal, c, false);
    est::FitOptions fo;
    fo.max_solve_seconds = max_seconds;
    auto session =
        std::make_unique<est::FitSession>(aug, AugmentedSplits(splits, aug.built.NumStates()), fo);
    // The budget spread over the solves: each may iterate for what is left; false once spent.
    auto elapsed = [&started]() {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    };
    auto budget_left = [&]() {
      if (!(max_seconds > 0.0)) return true;
      const double left = max_seconds - elapsed();
      if (!(left > 0.0)) return false;
      session->SetMaxSolveSeconds(left);
      return true;
    };
    // Wall time of the re-fit's solves and of the solver inside them (FitResult::seconds "solve"),
    // reported in RefitResult::stages: the difference is formulation, covariance and evaluation.
    double solve_wall = 0.0, solver_seconds = 0.0;
    int solves = 0;
    auto timed_solve = [&](const est::FitResult* start) {
      const auto t0 = std::chrono::steady_clock::now();
      est::FitResult r = session->Solve(start);
      solve_wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      for (const auto& [what, seconds] : r.seconds) {
        if (what == "solve") solver_seconds += seconds;
      }
      ++solves;
      return r;
    };
    std::vector<double> neutral;
    neutral.assign(c.screened.size(), 0.0);
    for (std::size_t i = 0; i < c.screened.size(); ++i) {
      for (const models::ModelParameter& p : aug.built.parameters) {
        if (p.name == c.screened[i]) neutral[i] = p.value;
      }
    }
    bool started_one_step = false;
    if (screened.one_step.size() == c.screened.size()) {
      for (std::size_t i = 0; i < c.screened.size(); ++i) {
        const double v = screened.one_step[i];
        if (!std::isfinite(v)) continue;
        for (const models::ModelParameter& p : aug.built.parameters) {
          if (p.name != c.screened[i]) continue;
          session->SetParameterValue(p.name, std::min(std::max(v, p.lower), p.upper));
          started_one_step = true;
        }
      }
    }
    budget_left();
    est::FitResult a = timed_solve(nullptr);
    if (started_one_step && !a.IsSolutionUsable() && budget_left()) {
      for (std::size_t i = 0; i < c.screened.size(); ++i) {
        session->SetParameterValue(c.screened[i], neutral[i]);
      }
      a = timed_solve(nullptr);
      out.stages.push_back("from the one-step estimate: " + a.solver_result.status +
                           "; restarted from the neutral values");
    }
    // The profile over each shape grid: stage A at every other grid value (a fixed value
    // changes, so each solve is warm-started from the best so far), the lowest cost kept.
    // A grid value's solve replaces the best so far when it converged and validates better (or
    // the best so far did not converge, or does not simulate on the validation splits).
    auto validates_better = [&role](const est::FitResult& trial, const est::FitResult& best) {
      if (!trial.IsSolutionUsable() || !trial.solver_result.success) return false;
      if (!best.solver_result.success) return true;
      const double t = ValidationNrmse(trial.evaluations, role);
      const double b = ValidationNrmse(best.evaluations, role);
      if (!std::isfinite(t)) return false;
      return !std::isfinite(b) || t < b;
    };
    for (const auto& [shape, values] : screened.shape_grid_values) {
      if (!a.IsSolutionUsable()) break;
      double best_value = a.Parameter(shape).value;
      const double first = best_value;
      std::size_t tried = 1;
      for (const double v : values) {
        if (v == first) continue;
        if (!budget_left()) break;
        ++tried;
        session->SetParameterValue(shape, v);
        est::FitResult trial = timed_solve(&a);
        if (validates_better(trial, a)) {
          a = std::move(trial);
          best_value = v;
        }
      }
      session->SetParameterValue(shape, best_value);
      char line[160];
      std::snprintf(line, sizeof(line),
                    "%s profiled over %zu of %zu grid values%s: %.4g (score's %.4g)", shape.c_str(),
                    tried, values.size(),
                    tried < values.size() ? " (the re-fit's budget spent)" : "", best_value, first);
      out.stages.push_back(line);
    }
    // The profile over the option grid: the option is structure, so each other value is a new
    // session, started from the best fit's parameter values; the converged solve of lowest
    // validation NRMSE is kept with its session, as for the shape grids (the score picks the
    // option poorly: a Coulomb level's softest sign scored highest on a pendulum whose truth
    // had a hard one, and validated 20 times worse than the steepest).
    if (!option.empty() && c.apply_with_option && screened.option_grid_values.size() > 1 &&
        a.IsSolutionUsable()) {
      const double first = out.candidate.augmentation.options.numbers[option].front();
      double best_value = first;
      std::size_t tried = 1;
      for (const double v : screened.option_grid_values) {
        if (v == first) continue;
        if (!budget_left()) break;
        ++tried;
        Candidate variant = c;
        const auto apply_with_option = c.apply_with_option;
        variant.apply = [apply_with_option, v](models::Model* m) { apply_with_option(m, v); };
        est::Problem variant_problem = AugmentedProblem(problem, nominal, variant, false);
        auto variant_session = std::make_unique<est::FitSession>(
            variant_problem, AugmentedSplits(splits, variant_problem.built.NumStates()), fo);
        for (const est::FitParameter& p : a.parameters) {
          variant_session->SetParameterValue(p.name, p.value);
        }
        std::swap(session, variant_session);
        budget_left();
        est::FitResult trial = timed_solve(nullptr);
        if (validates_better(trial, a)) {
          a = std::move(trial);
          best_value = v;
          aug = std::move(variant_problem);
          out.candidate.apply = variant.apply;
          out.candidate.augmentation.options.numbers[option] = {v};
        } else {
          std::swap(session, variant_session);
        }
      }
      char line[200];
      std::snprintf(
          line, sizeof(line),
          "option %s profiled over %zu of %zu grid values%s: %.4g (score's %.4g)", option.c_str(),
          tried, screened.option_grid_values.size(),
          tried < screened.option_grid_values.size() ? " (the re-fit's budget spent)" : "",
          best_value, first);
      out.stages.push_back(line);
    }
    out.fit = std::move(a);
    std::vector<std::string> shapes;
    for (const auto& q : c.refit) {
      if (std::find(c.screened.begin(), c.screened.end(), q) == c.screened.end()) {
        shapes.push_back(q);
      }
    }
    if (!shapes.empty() && out.fit.IsSolutionUsable() && !budget_left()) {
      out.stages.push_back(
          "shape parameters held (at the nominal or profiled values): the "
          "re-fit's budget was spent");
    } else if (!shapes.empty() && out.fit.IsSolutionUsable()) {
      for (const auto& q : shapes) session->FreeParameter(q);
      est::FitResult b = timed_solve(&out.fit);
      std::string held;
      if (!b.IsSolutionUsable() || !b.solver_result.success) {
        held = "the re-fit with them free stopped with " + b.solver_result.status;
      } else if (b.solver_result.cost > out.fit.solver_result.cost * (1.0 + 1e-6)) {
        char line[200];
        std::snprintf(line, sizeof(line),
                      "the re-fit with them free ended at a higher cost (%.6g > %.6g, %s after "
                      "%d iterations)",
                      b.solver_result.cost, out.fit.solver_result.cost,
                      b.solver_result.status.c_str(), b.solver_result.iterations);
        held = line;
      } else {
        for (const auto& q : shapes) {
          if (b.Parameter(q).at_bound && held.empty()) {
            held = "the re-fit with them free put " + q + " at a bound";
          }
        }
      }
      const double a_validation = ValidationNrmse(out.fit.evaluations, role);
      const double b_validation = ValidationNrmse(b.evaluations, role);
      if (held.empty() && !(b_validation <= a_validation)) {
        char line[200];
        std::snprintf(line, sizeof(line),
                      "with them free the validation NRMSE is higher (%.4g > %.4g): the freed "
                      "shape fits the estimation data only",
                      b_validation, a_validation);
        held = line;
      }
      if (held.empty()) {
        out.fit = std::move(b);
        out.stages.push_back("shape parameters freed");
      } else {
        out.stages.push_back("shape parameters held (at the nominal or profiled values): " + held);
      }
    }
    {
      char line[200];
      std::snprintf(line, sizeof(line),
                    "%d solve(s): %.3g s wall, %.3g s in the solver, re-fit %.3g s so far", solves,
                    solve_wall, solver_seconds, elapsed());
      out.stages.push_back(line);
    }
    for (const auto& q : c.parameters) out.parameters.push_back(out.fit.Parameter(q));
    for (const auto& q : c.refit) {
      const est::FitParameter& p = out.fit.Parameter(q);
      const bool family_end =
          std::find(c.family_ends.begin(), c.family_ends.end(), q) != c.family_ends.end();
      out.at_bound = out.at_bound || (p.free && p.at_bound && !family_end);
    }
    InformationCriteria(out.fit, &out.aic, &out.bic);
    out.validation_nrmse_after = ValidationNrmse(out.fit.evaluations, role);
    if (!out.fit.IsSolutionUsable()) {
      out.failure = "solver: " + out.fit.solver_result.status + " " + out.fit.solver_result.message;
    } else if (!out.fit.solver_result.success) {
      out.failure = "the solver stopped before converging (" + out.fit.solver_result.status +
                    " after " + std::to_string(out.fit.solver_result.iterations) + " iterations)";
    } else if (!std::isfinite(out.validation_nrmse_after)) {
      out.failure = "the validation simulation did not finish";
    } else {
      out.failure = IntegrationCheck(aug, splits, out.fit, role, out.validation_nrmse_after);
      out.ok = out.failure.empty();
      if (out.ok) out.relative_gain = (before - out.validation_nrmse_after) / before;
    }
  } catch (const std::exception& e) {
    out.failure = e.what();
  }
  return out;
}

// Regularised lower incomplete gamma P(a, x) by its series (x < a + 1) and upper Q(a, x) by the
// Lentz continued fraction (otherwise); Numerical Recipes 6.2.
double GammaQ(double a, double x) {
  constexpr int kMaxIterations = 1000;
  constexpr double kEpsilon = 1e-15;
  const double log_prefactor = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < kMaxIterations; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < std::fabs(sum) * kEpsilon) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefactor));
  }
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < kMaxIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < kEpsilon) break;
  }
  return std::exp(log_prefactor) * h;
}

// Runs fn(i) for i = 0 .. n-1 on `threads` threads (0: one per hardware thread), each index once.
// An exception escaping fn is rethrown on the calling thread after every worker has stopped.
template <typename Fn>
void ParallelFor(int n, int threads, Fn&& fn) {
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::max(1, std::min(threads, n));
  if (threads <= 1) {
    for (int i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<int> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&] {
      for (int i = next++; i < n; i = next++) {
        try {
          fn(i);
        } catch (...) {
          std::lock_guard<std::mutex> lock(error_mutex);
          if (!error) error = std::current_exception();
        }
      }
    });
  }
  for (std::thread& w : workers) w.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace

est::Problem AugmentedProblem(const est::Problem& problem, const est::FitResult& start,
                              const Candidate& candidate, bool refit) {
  if (start.values.size() != problem.built.NumParameters()) {
    throw std::invalid_argument(
        "AugmentedProblem: the start has " + std::to_string(start.values.size()) +
        " parameter values; expected " + std::to_string(problem.built.NumParameters()) +
        " (the problem's model)");
  }
  models::Model m = problem.model;
  for (int i = 0; i < problem.built.NumParameters(); ++i) {
    m.Parameter(problem.built.parameters[i].name).value = start.values[i];
  }
  candidate.apply(&m);
  if (refit) {
    for (const auto& q : candidate.refit) m.Free(q);
  }
  est::Problem aug = problem;
  aug.model = m;
  aug.built = m.Build();
  return aug;
}

std::vector<est::SplitData> AugmentedSplits(const std::vector<est::SplitData>& splits,
                                            int num_states) {
  std::vector<est::SplitData> out = splits;
  for (est::SplitData& s : out) {
    const Eigen::Index old = s.setup.x0.size();
    if (old >= num_states) continue;
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(num_states);
    x0.head(old) = s.setup.x0;
    s.setup.x0 = x0;
    if (s.setup.state_guess.size() > 0) {
      Eigen::MatrixXd guess = Eigen::MatrixXd::Zero(s.setup.state_guess.rows(), num_states);
      guess.leftCols(s.setup.state_guess.cols()) = s.setup.state_guess;
      s.setup.state_guess = guess;
    }
  }
  return out;
}

std::string ValidationRole(const std::vector<est::SplitData>& splits) {
  bool validation = false, test = false;
  for (const auto& s : splits) {
    validation = validation || s.role == est::SplitRole::kValidation;
    test = test || s.role == est::SplitRole::kTest;
  }
  return validation ? "validation" : test ? "test" : "all";
}

double ValidationNrmse(const std::vector<est::SplitEvaluation>& evaluations,
                       const std::string& role) {
  double sum = 0.0;
  int count = 0;
  for (const auto& e : evaluations) {
    const bool use = role == "all" ||
                     (role == "validation" && e.role == est::SplitRole::kValidation) ||
                     (role == "test" && e.role == est::SplitRole::kTest);
    if (!use) continue;
    if (!e.simulation_ok) return kNaN;
    sum += e.simulation.overall.nrmse;
    ++count;
  }
  return count > 0 ? sum / count : kNaN;
}

std::string IntegrationCheck(const est::Problem& aug, const std::vector<est::SplitData>& splits,
                             const est::FitResult& fit, const std::string& role, double nrmse) {
  constexpr int kRefinement = 4;
  constexpr double kTolerance = 0.1;
  if (aug.estimation.integrator.method != est::IntegrationMethod::kFixedStep) return "";
  est::Problem fine = aug;
  fine.estimation.integrator.fixed_step.substeps *= kRefinement;
  const std::vector<est::SplitData> s = AugmentedSplits(splits, aug.built.NumStates());
  const double refined =
      ValidationNrmse(est::Simulate(fine, s, fit.values, fit.initial_states), role);
  if (std::isfinite(refined) && std::fabs(refined - nrmse) <= kTolerance * nrmse) return "";
  char line[240];
  std::snprintf(line, sizeof(line),
                "the fitted dynamics are not resolved by the integrator: validation NRMSE %.4g "
                "with the problem's step, %.4g with %d times the substeps",
                nrmse, refined, kRefinement);
  return line;
}

double ChiSquareSurvival(double x, int dof) {
  if (dof < 1) {
    throw std::invalid_argument("ChiSquareSurvival: expected dof >= 1, got " + std::to_string(dof));
  }
  if (!(x > 0.0)) return std::isnan(x) ? kNaN : 1.0;
  return GammaQ(0.5 * dof, 0.5 * x);
}

void ScreeningOptions::Validate() const {
  period_scan.Validate();
  if (!(refit_max_seconds >= 0.0)) {
    throw std::invalid_argument("ScreeningOptions.refit_max_seconds: expected >= 0, got " +
                                std::to_string(refit_max_seconds));
  }
  if (!(nested_margin >= 0.0)) {
    throw std::invalid_argument("ScreeningOptions.nested_margin: expected >= 0, got " +
                                std::to_string(nested_margin));
  }
  if (refit_top < 0) {
    throw std::invalid_argument("ScreeningOptions.refit_top: expected >= 0, got " +
                                std::to_string(refit_top));
  }
  if (num_threads < 0) {
    throw std::invalid_argument("ScreeningOptions.num_threads: expected >= 0, got " +
                                std::to_string(num_threads));
  }
  if (!(tie_tolerance >= 0.0)) {
    throw std::invalid_argument("ScreeningOptions.tie_tolerance: expected >= 0, got " +
                                std::to_string(tie_tolerance));
  }
  candidates.Validate();
}

double AutomaticRefitBudget(const est::FitResult& nominal) {
  double nominal_solve = 0.0;
  for (const auto& [what, seconds] : nominal.seconds) {
    if (what == "solve") nominal_solve = seconds;
  }
  return std::max(kAutoBudgetFactor * nominal_solve, kAutoBudgetFloor);
}

Diagnosis ScreenAndRefit(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                         const est::FitResult& nominal, const ScreeningOptions& options) {
  options.Validate();
  if (nominal.values.size() != problem.built.NumParameters()) {
    throw std::invalid_argument(
        "ScreenAndRefit: nominal has " + std::to_string(nominal.values.size()) +
        " parameter values; expected " + std::to_string(problem.built.NumParameters()) +
        " (the problem's model)");
  }
  Diagnosis d;
  d.validation_role = ValidationRole(splits);
  d.nominal_validation_nrmse = ValidationNrmse(nominal.evaluations, d.validation_role);
  InformationCriteria(nominal, &d.nominal_aic, &d.nominal_bic);
  // The ripple periods from the nominal residuals' periodogram against each axis' position.
  CandidateOptions candidate_options = options.candidates;
  const std::vector<std::string> wanted_effects = SelectedEffects(problem, candidate_options);
  if (candidate_options.ripple_periods.empty() && problem.diagnosis.ripple_periods.empty() &&
      std::find(wanted_effects.begin(), wanted_effects.end(), "ripple") != wanted_effects.end()) {
    for (const MechanicalAxis& axis : FindAxes(problem)) {
      if (axis.position.empty() ||
          candidate_options.ripple_periods_by_position.count(axis.position)) {
        continue;
      }
      const PeriodScan scan =
          ScanPeriods(problem.built, nominal, axis.position, !axis.prismatic, options.period_scan);
      if (scan.peaks.empty()) continue;
      candidate_options.ripple_periods_by_position[axis.position] = scan.peaks;
      d.ripple_periods[axis.position] = scan.peaks;
    }
  }
  const std::vector<Candidate> candidates = EnumerateCandidates(problem, candidate_options);
  std::mutex progress_mutex;
  auto report = [&](const std::string& line) {
    if (!options.progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    options.progress(line);
  };
  d.screened.resize(candidates.size());
  ParallelFor(static_cast<int>(candidates.size()), options.num_threads, [&](int i) {
    report("screening " + candidates[i].Name() + " (" + std::to_string(i + 1) + "/" +
           std::to_string(candidates.size()) + ")");
    d.screened[i] = Score(problem, splits, nominal, candidates[i]);
  });
  std::stable_sort(d.screened.begin(), d.screened.end(),
                   [](const CandidateScore& a, const CandidateScore& b) {
                     const bool fa = std::isfinite(a.score), fb = std::isfinite(b.score);
                     if (fa != fb) return fa;
                     return fa && a.score > b.score;
                   });
  std::vector<const CandidateScore*> to_refit;
  for (const CandidateScore& s : d.screened) {
    if (static_cast<int>(to_refit.size()) >= options.refit_top || !std::isfinite(s.score)) break;
    to_refit.push_back(&s);
  }
  // Structural candidates have no score: each is re-fitted (after the scored ones).
  for (const CandidateScore& s : d.screened) {
    if (s.candidate.structural && s.failure.empty()) to_refit.push_back(&s);
  }
  // The budget of each re-fit: as given, else automatic from this nominal fit.
  const double budget =
      options.refit_max_seconds > 0.0 ? options.refit_max_seconds : AutomaticRefitBudget(nominal);
  d.refits.resize(to_refit.size());
  ParallelFor(static_cast<int>(to_refit.size()), options.num_threads, [&](int i) {
    report("re-fitting " + to_refit[i]->candidate.Name() + " (" + std::to_string(i + 1) + "/" +
           std::to_string(to_refit.size()) + ")");
    d.refits[i] = Refit(problem, splits, nominal, *to_refit[i], d.validation_role,
                        d.nominal_validation_nrmse, budget);
  });
  auto group = [](const RefitResult& r) { return !r.ok ? 2 : r.at_bound ? 1 : 0; };
  const double tie = options.tie_tolerance;
  std::stable_sort(d.refits.begin(), d.refits.end(),
                   [&](const RefitResult& a, const RefitResult& b) {
                     if (group(a) != group(b)) return group(a) < group(b);
                     if (group(a) == 2) return false;
                     const double ea = a.validation_nrmse_after, eb = b.validation_nrmse_after;
                     if (std::fabs(ea - eb) <= tie * std::max(ea, eb)) return a.bic < b.bic;
                     return ea < eb;
                   });
  // Parsimony between nested effects: a re-fit whose effect reduces to a simpler re-fitted one on
  // the same attachment (Candidate::reduces_to) ranks after it unless it is better by more than
  // nested_margin of the nominal validation NRMSE.
  const double margin = options.nested_margin * d.nominal_validation_nrmse;
  for (std::size_t i = 0; i < d.refits.size(); ++i) {
    if (group(d.refits[i]) != 0) break;
    for (std::size_t j = i + 1; j < d.refits.size(); ++j) {
      const RefitResult& general = d.refits[i];
      const RefitResult& simple = d.refits[j];
      const std::vector<std::string>& r = general.candidate.reduces_to;
      if (group(simple) == 0 && simple.attachment == general.attachment &&
          std::find(r.begin(), r.end(), simple.effect) != r.end() &&
          simple.validation_nrmse_after - general.validation_nrmse_after <= margin) {
        std::rotate(d.refits.begin() + i, d.refits.begin() + j, d.refits.begin() + j + 1);
        break;
      }
    }
  }
  return d;
}

std::string Diagnosis::BriefReport() const {
  std::ostringstream o;
  if (!refits.empty() && refits.front().ok && !refits.front().at_bound) {
    const RefitResult& r = refits.front();
    o << "best: " << r.effect << " (" << r.detail << ") on " << r.attachment << ", "
      << validation_role << " NRMSE " << Format("%.4g", r.validation_nrmse_before) << " -> "
      << Format("%.4g", r.validation_nrmse_after) << " (" << Format("%.0f", 100.0 * r.relative_gain)
      << " % of it)";
  } else {
    o << "no successful re-fit";
  }
  o << "; screened " << screened.size() << ", re-fitted " << refits.size();
  return o.str();
}

std::string Diagnosis::FullReport() const {
  std::ostringstream o;
  o << BriefReport() << "\n";
  o << "nominal: " << validation_role << " NRMSE " << Format("%.4g", nominal_validation_nrmse)
    << ", AIC " << Format("%.1f", nominal_aic) << ", BIC " << Format("%.1f", nominal_bic) << "\n";
  o << "screening (score test at the neutral value):\n";
  char line[512];
  std::snprintf(line, sizeof(line), "  %-20s %-24s %-36s %12s %4s %10s\n", "effect", "detail",
                "attachment", "LM", "dof", "p");
  o << line;
  for (const CandidateScore& s : screened) {
    std::snprintf(line, sizeof(line), "  %-20s %-24s %-36s %12.4g %4d %10.3g%s\n",
                  s.candidate.effect.c_str(), s.candidate.detail.c_str(),
                  s.candidate.attachment.c_str(), s.score, s.dof, s.p_value,
                  s.restricted_solve ? "  (restricted solve)" : "");
    o << line;
    if (!s.failure.empty()) o << "    failed: " << s.failure << "\n";
  }
  o << "re-fits (ranked):\n";
  std::snprintf(line, sizeof(line), "  %-20s %-24s %10s %10s %8s %12s %12s  %s\n", "effect",
                "detail", "NRMSE", "after", "closed", "AIC", "BIC", "status");
  o << line;
  for (const RefitResult& r : refits) {
    const std::string status = !r.ok ? "FAILED: " + r.failure : r.at_bound ? "at bound" : "ok";
    std::snprintf(line, sizeof(line), "  %-20s %-24s %10.4g %10.4g %7.1f%% %12.1f %12.1f  %s\n",
                  r.effect.c_str(), r.detail.c_str(), r.validation_nrmse_before,
                  r.validation_nrmse_after, 100.0 * r.relative_gain, r.aic, r.bic, status.c_str());
    o << line;
    for (const std::string& stage : r.stages) o << "      " << stage << "\n";
    for (const auto& p : r.parameters) {
      std::snprintf(line, sizeof(line), "      %-32s %12.5g +- %-10.3g %s%s\n", p.name.c_str(),
                    p.value, p.std_error, p.unit.c_str(),
                    p.at_bound ? "  AT BOUND" : (p.free ? "" : "  (held)"));
      o << line;
    }
  }
  return o.str();
}

}  // namespace graybox::diagnosis
