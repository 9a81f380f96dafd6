#include "fit/equation_error_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>

#include "graybox/estimators/data/preprocessing.h"
#include "graybox/estimators/nlp/weights.h"
#include "graybox/expr/matrix.h"
#include "graybox/util/matrix_rows.h"

namespace graybox::estimators::internal {

using estimators::EquationErrorSpec;
using estimators::Experiment;
using estimators::ProblemFileError;
using expr::Expr;
using expr::Function;

namespace {

// Affinity (in the inverse inputs, and in the free parameters for parallel decimation) is
// checked on this many samples spread over a split. An affine function evaluated through its
// formula deviates at rounding level (~1e-14 relative with the divisions of the inverse form),
// a nonlinear one by O(1) of its curvature, so 1e-8 relative separates the two cases widely.
constexpr int kAffinityCheckSamples = 16;
constexpr double kAffinityTolerance = 1e-8;
// The free parameters move by this fraction of their scale in the parameter-affinity check.
constexpr double kAffinityStep = 0.25;

int IndexOf(const std::vector<models::SignalInfo>& signals, const std::string& name) {
  for (std::size_t i = 0; i < signals.size(); ++i) {
    if (signals[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

// The signals of a split at full rate after skip_samples.
struct FullRate {
  Eigen::VectorXd time;
  Eigen::MatrixXd x, u, xdot, target;  // xdot: residual states only
  double dt = 0.0;
};

FullRate FullRateSignals(const estimators::Problem& problem, const EquationModel& model,
                         const estimators::SplitData& split) {
  const EquationErrorSpec& spec = problem.estimation.equation_error;
  const Experiment& e = split.experiment;
  const Eigen::MatrixXd x = StatesFromSpec(problem, spec, e);
  const bool fft = spec.differentiation == "fft";
  const Eigen::MatrixXd xdot = fft ? estimators::FftDerivative(x, e.dt, spec.fft_cutoff_bin)
                                   : estimators::CentralDifference(x, e.dt);
  Eigen::MatrixXd u = fft ? estimators::FftLowPass(e.u, spec.fft_cutoff_bin) : e.u;
  if (spec.input_timing == "held" && u.rows() > 1) {
    // Zero-order hold: the input's mean over the central difference's [t_{k-1}, t_{k+1}].
    const Eigen::MatrixXd sampled = u;
    u.bottomRows(u.rows() - 1) =
        0.5 * (sampled.topRows(u.rows() - 1) + sampled.bottomRows(u.rows() - 1));
  }
  const int n = e.NumSamples();
  const int kept = n - spec.skip_samples;
  if (kept < 2) {
    throw ProblemFileError(split.where, "split '" + split.name + "': skip_samples = " +
                                            std::to_string(spec.skip_samples) + " leaves " +
                                            std::to_string(std::max(kept, 0)) + " of its " +
                                            std::to_string(n) + " samples: expected at least 2");
  }
  FullRate f;
  f.dt = e.dt;
  f.time = e.Time().tail(kept);
  f.x = x.bottomRows(kept);
  f.u = u.bottomRows(kept);
  const int nc = static_cast<int>(model.residual_states.size());
  f.xdot.resize(kept, nc);
  f.target.resize(kept, nc);
  for (int i = 0; i < nc; ++i) {
    f.xdot.col(i) = xdot.col(model.residual_states[i]).tail(kept);
    f.target.col(i) = model.inverse_inputs.empty()
                          ? Eigen::VectorXd(f.xdot.col(i))
                          : Eigen::VectorXd(f.u.col(model.inverse_inputs[i]));
  }
  return f;
}

// g(x, u, xdot, p) for every row (N x nc).
Eigen::MatrixXd EvaluateTarget(const EquationModel& model, const Eigen::MatrixXd& x,
                               const Eigen::MatrixXd& u, const Eigen::MatrixXd& xdot,
                               const Eigen::VectorXd& p) {
  const Eigen::Index n = x.rows();
  std::vector<Eigen::MatrixXd> out;
  expr::Workspace ws = model.predict.MakeWorkspace();
  model.predict.EvaluateBatch({x.transpose(), u.transpose(), xdot.transpose(), p.replicate(1, n)},
                              &out, &ws);
  Eigen::MatrixXd g = out[0].transpose();
  for (Eigen::Index k = 0; k < g.size(); ++k) {
    if (!std::isfinite(g.data()[k])) g.data()[k] = std::numeric_limits<double>::quiet_NaN();
  }
  return g;
}

// d g_i / d theta_free for every row: one N x n_free matrix per channel.
std::vector<Eigen::MatrixXd> EvaluateRegressors(const EquationModel& model,
                                                const Eigen::MatrixXd& x, const Eigen::MatrixXd& u,
                                                const Eigen::MatrixXd& xdot,
                                                const Eigen::VectorXd& p) {
  const Eigen::Index n = x.rows();
  const int nc = model.predict.OutputSize(0);
  const int nf = model.parameters.NumFree();
  std::vector<Eigen::MatrixXd> out;
  expr::Workspace ws = model.jacobian.MakeWorkspace();
  model.jacobian.EvaluateBatch({x.transpose(), u.transpose(), xdot.transpose(), p.replicate(1, n)},
                               &out, &ws);
  const expr::Sparsity& sp = model.jacobian.OutputSparsity(0);
  const std::vector<int> cols = sp.ColumnOfNonzeros();
  std::vector<int> free_column(model.parameters.values.size(), -1);
  for (int f = 0; f < nf; ++f) free_column[model.parameters.free[f]] = f;
  std::vector<Eigen::MatrixXd> y(nc, Eigen::MatrixXd::Zero(n, nf));
  for (int k = 0; k < sp.nnz(); ++k) {
    const int f = free_column[cols[k]];
    if (f >= 0) y[sp.row()[k]].col(f) = out[0].row(k).transpose();
  }
  return y;
}

Eigen::MatrixXd DecimateRows(const Eigen::MatrixXd& m, double dt, int factor) {
  estimators::DecimateOptions options;
  options.offset = static_cast<int>((m.rows() - 1) % factor);  // MATLAB: end at the last sample
  return estimators::Decimate(m, dt, factor, options);
}

Eigen::VectorXd FreeValues(const EquationModel& model, const Eigen::VectorXd& p) {
  Eigen::VectorXd t(model.parameters.NumFree());
  for (int f = 0; f < t.size(); ++f) t[f] = p[model.parameters.free[f]];
  return t;
}

}  // namespace

Eigen::MatrixXd StatesFromSpec(const estimators::Problem& problem, const EquationErrorSpec& spec,
                               const Experiment& experiment) {
  const models::StateSpaceModel& m = problem.built;
  const int n = experiment.NumSamples();
  const double dt = experiment.dt;
  if (spec.lowpass_hz > 0.0) {
    const int padding = spec.lowpass_padding < 0 ? 3 * spec.lowpass_order : spec.lowpass_padding;
    if (n <= padding || n < 3) {
      throw std::invalid_argument("[estimation.equation_error] lowpass_hz: split '" +
                                  experiment.name + "': the low-pass filter needs more than " +
                                  std::to_string(padding) + " samples (its edge padding), got " +
                                  std::to_string(n));
    }
    if (!(spec.lowpass_hz < 0.5 / dt)) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "[estimation.equation_error] lowpass_hz: expected a cut-off below the Nyquist "
                    "frequency %.6g Hz of split '%s', got %.6g",
                    0.5 / dt, experiment.name.c_str(), spec.lowpass_hz);
      throw std::invalid_argument(buf);
    }
  }
  if (n < 2) {
    throw std::invalid_argument("split '" + experiment.name +
                                "': differentiation needs at least 2 samples, got " +
                                std::to_string(n));
  }
  std::map<std::string, Eigen::VectorXd> cache;
  std::function<Eigen::VectorXd(const std::string&)> value = [&](const std::string& name) {
    auto it = cache.find(name);
    if (it != cache.end()) return it->second;
    Eigen::VectorXd v;
    const int out = IndexOf(m.outputs, name);
    const auto held = spec.from_inputs.find(name);
    if (held != spec.from_inputs.end()) {
      v = experiment.u.col(IndexOf(m.inputs, held->second));  // a first-order hold's samples
    } else if (out >= 0) {
      v = experiment.y.col(out);
      if (spec.differentiation == "fft") {
        v = estimators::FftLowPass(v, spec.fft_cutoff_bin);
      } else if (spec.lowpass_hz > 0.0) {
        v = estimators::FiltFilt(
            estimators::ButterworthLowPass(spec.lowpass_order, spec.lowpass_hz, dt), v,
            spec.lowpass_padding);
      }
    } else {
      auto d = spec.differentiate.find(name);
      if (d == spec.differentiate.end()) {
        throw std::invalid_argument("equation error: state '" + name +
                                    "' cannot be obtained from the data");
      }
      v = spec.differentiation == "fft"
              ? Eigen::VectorXd(
                    estimators::FftDerivative(value(d->second), dt, spec.fft_cutoff_bin))
              : Eigen::VectorXd(estimators::CentralDifference(value(d->second), dt));
    }
    cache[name] = v;
    return v;
  };
  Eigen::MatrixXd x(n, m.NumStates());
  for (int i = 0; i < m.NumStates(); ++i) x.col(i) = value(m.states[i].name);
  return x;
}

EquationModel BuildEquationModel(const estimators::Problem& problem,
                                 const estimators::SplitData& check_split) {
  const models::StateSpaceModel& m = problem.built;
  const EquationErrorSpec& spec = problem.estimation.equation_error;
  const bool inverse = spec.form == "inverse";
  const int nx = m.NumStates(), nu = m.NumInputs(), np = m.NumParameters();
  EquationModel model;
  model.parameters = estimators::ParameterMap::FromModel(m.parameters);
  for (const auto& s : spec.residual_states) model.residual_states.push_back(m.StateIndex(s));
  if (inverse) {
    for (const auto& s : spec.inverse_inputs) model.inverse_inputs.push_back(m.InputIndex(s));
  }
  const int nc = static_cast<int>(model.residual_states.size());
  for (int i = 0; i < nc; ++i) {
    if (inverse) {
      model.channels.push_back(m.inputs[model.inverse_inputs[i]].name);
      model.units.push_back(m.inputs[model.inverse_inputs[i]].unit);
    } else {
      const models::SignalInfo& s = m.states[model.residual_states[i]];
      model.channels.push_back("d(" + s.name + ")/dt");
      model.units.push_back(s.unit.empty() ? "1/s" : s.unit + "/s");
    }
  }
  const std::vector<Expr> x = Expr::Symbols("x", nx), u = Expr::Symbols("u", nu),
                          xd = Expr::Symbols("xdot", nc), p = Expr::Symbols("p", np);
  auto f_c = [&](const std::vector<Expr>& uu) {
    const std::vector<Expr> f = m.dynamics.Call({x, uu, p})[0];
    std::vector<Expr> out;
    for (int c : model.residual_states) out.push_back(f[c]);
    return out;
  };
  std::vector<Expr> target_hat;
  std::vector<Expr> defect, level;  // affinity in the inverse inputs: f - (a + B u_j), and f
  if (inverse) {
    std::vector<Expr> u0 = u;
    for (int j : model.inverse_inputs) u0[j] = Expr(0.0);
    const std::vector<Expr> a = f_c(u0);
    expr::ExprMatrix b(nc, nc);
    for (int k = 0; k < nc; ++k) {
      std::vector<Expr> uk = u0;
      uk[model.inverse_inputs[k]] = Expr(1.0);
      const std::vector<Expr> fk = f_c(uk);
      for (int i = 0; i < nc; ++i) b(i, k) = fk[i] - a[i];
    }
    if (nc == 1) {
      target_hat.push_back((xd[0] - a[0]) / b(0, 0));
    } else {
      expr::ExprMatrix rhs(nc, 1);
      for (int i = 0; i < nc; ++i) rhs(i, 0) = xd[i] - a[i];
      const expr::ExprMatrix sol = expr::SolveLu(b, rhs);
      for (int i = 0; i < nc; ++i) target_hat.push_back(sol(i, 0));
    }
    const std::vector<Expr> f = f_c(u);
    for (int i = 0; i < nc; ++i) {
      Expr affine = a[i];
      for (int k = 0; k < nc; ++k) affine = affine + b(i, k) * u[model.inverse_inputs[k]];
      defect.push_back(f[i] - affine);
      level.push_back(f[i]);
    }
  } else {
    target_hat = f_c(u);
  }
  model.predict = Function("equation_target", {{"x", x}, {"u", u}, {"xdot", xd}, {"p", p}},
                           {{"target", target_hat}});
  model.jacobian = model.predict.Jacobian("target", "p");
  const FullRate full = FullRateSignals(problem, model, check_split);
  const Eigen::VectorXd p0 = m.ParameterValues();
  const Eigen::Index rows = full.x.rows();
  if (inverse) {
    const Function check("affinity", {{"x", x}, {"u", u}, {"p", p}},
                         {{"defect", defect}, {"f", level}});
    for (int s = 0; s < kAffinityCheckSamples; ++s) {
      const Eigen::Index k = rows * s / kAffinityCheckSamples;
      const Eigen::VectorXd xk = util::RowAsVector(full.x, k), uk = util::RowAsVector(full.u, k);
      Eigen::VectorXd uk2 = uk;
      for (int j : model.inverse_inputs) uk2[j] = 2.0 * uk[j] + 1.0;
      for (const Eigen::VectorXd* up : {&uk, static_cast<const Eigen::VectorXd*>(&uk2)}) {
        std::vector<Eigen::VectorXd> out;
        try {
          out = check({xk, *up, p0});
        } catch (const std::exception&) {
          continue;  // a non-finite value at this point says nothing about affinity
        }
        for (int i = 0; i < nc; ++i) {
          if (std::fabs(out[0][i]) > kAffinityTolerance * (1.0 + std::fabs(out[1][i]))) {
            throw std::invalid_argument("equation_error form 'inverse': the derivative of state '" +
                                        m.states[model.residual_states[i]].name +
                                        "' is not affine in the inverse input(s) (deviation " +
                                        std::to_string(out[0][i]) + " at sample " +
                                        std::to_string(k) + " of split '" + check_split.name +
                                        "'); use form = 'state_derivative'");
          }
        }
      }
    }
  }
  // Decimation mode: parallel needs g affine in the free parameters; checked on the data.
  const std::string mode = spec.decimation;
  if (spec.decimate > 1 && mode != "signals") {
    const int nf = model.parameters.NumFree();
    Eigen::VectorXd p1 = p0;
    for (int f = 0; f < nf; ++f) {
      p1[model.parameters.free[f]] +=
          kAffinityStep * (f % 2 ? -1.0 : 1.0) * model.parameters.scale[f];
    }
    std::vector<Eigen::Index> picks;
    for (int s = 0; s < kAffinityCheckSamples; ++s)
      picks.push_back(rows * s / kAffinityCheckSamples);
    Eigen::MatrixXd xs(picks.size(), nx), us(picks.size(), nu), xds(picks.size(), nc);
    for (std::size_t s = 0; s < picks.size(); ++s) {
      util::CopyRow(full.x, picks[s], xs, static_cast<Eigen::Index>(s));
      util::CopyRow(full.u, picks[s], us, static_cast<Eigen::Index>(s));
      xds.row(s) = full.xdot.row(picks[s]);
    }
    const Eigen::MatrixXd g0 = EvaluateTarget(model, xs, us, xds, p0);
    const Eigen::MatrixXd g1 = EvaluateTarget(model, xs, us, xds, p1);
    const std::vector<Eigen::MatrixXd> y = EvaluateRegressors(model, xs, us, xds, p0);
    const Eigen::VectorXd step = FreeValues(model, p1) - FreeValues(model, p0);
    bool affine = g0.allFinite() && g1.allFinite();
    for (int i = 0; i < nc && affine; ++i) {
      const Eigen::VectorXd predicted = g0.col(i) + y[i] * step;
      for (Eigen::Index s = 0; s < predicted.size(); ++s) {
        if (std::fabs(predicted[s] - g1(s, i)) > kAffinityTolerance * (1.0 + std::fabs(g1(s, i)))) {
          affine = false;
        }
      }
    }
    if (!affine && mode == "parallel") {
      throw std::invalid_argument(
          "equation_error.decimation = 'parallel' decimates regressor columns and needs a model "
          "affine in its free parameters; this one is not: use decimation = 'signals'");
    }
    model.parallel = affine;
  }
  return model;
}

EquationSamples SampleSplit(const estimators::Problem& problem, const EquationModel& model,
                            const estimators::SplitData& split) {
  const int factor = problem.estimation.equation_error.decimate;
  const FullRate full = FullRateSignals(problem, model, split);
  EquationSamples s;
  s.split = split.name;
  auto decimate = [&](const Eigen::MatrixXd& m) {
    if (factor == 1) return m;
    try {
      return DecimateRows(m, full.dt, factor);
    } catch (const std::invalid_argument& e) {
      throw ProblemFileError(split.where, "split '" + split.name + "': decimation by " +
                                              std::to_string(factor) + ": " + e.what());
    }
  };
  const Eigen::MatrixXd t = full.time;
  const Eigen::Index offset = factor == 1 ? 0 : (t.rows() - 1) % factor;
  const Eigen::Index kept = factor == 1 ? t.rows() : (t.rows() - 1 - offset) / factor + 1;
  s.time.resize(kept);
  for (Eigen::Index k = 0; k < kept; ++k) s.time[k] = full.time[offset + k * factor];
  s.target = decimate(full.target);
  if (model.parallel) {
    const Eigen::VectorXd p0 = problem.built.ParameterValues();
    const Eigen::MatrixXd g0 = EvaluateTarget(model, full.x, full.u, full.xdot, p0);
    const std::vector<Eigen::MatrixXd> y = EvaluateRegressors(model, full.x, full.u, full.xdot, p0);
    if (!g0.allFinite()) {
      throw std::invalid_argument("split '" + split.name +
                                  "': the equation is not finite at the initial parameters");
    }
    const Eigen::VectorXd theta0 = FreeValues(model, p0);
    s.offset.resize(s.target.rows(), static_cast<Eigen::Index>(y.size()));
    for (std::size_t i = 0; i < y.size(); ++i) {
      s.regressors.push_back(decimate(y[i]));
      s.offset.col(static_cast<Eigen::Index>(i)) =
          decimate(g0.col(static_cast<Eigen::Index>(i)) - y[i] * theta0);
    }
  } else {
    s.x = decimate(full.x);
    s.u = decimate(full.u);
    s.xdot = decimate(full.xdot);
  }
  return s;
}

EquationErrorFit BuildEquationErrorFit(const estimators::Problem& problem,
                                       const EquationModel& model,
                                       const std::vector<EquationSamples>& samples) {
  const models::StateSpaceModel& m = problem.built;
  const EquationErrorSpec& spec = problem.estimation.equation_error;
  const int nx = m.NumStates(), nu = m.NumInputs(), np = m.NumParameters();
  const int nc = static_cast<int>(model.residual_states.size());
  const estimators::ParameterMap& map = model.parameters;
  const int nf = map.NumFree();
  long total = 0;
  for (const auto& s : samples) total += s.target.rows();
  if (total == 0) throw std::invalid_argument("equation error: no estimation samples");
  std::vector<double> w0, lbw, ubw;
  std::vector<std::string> names;
  map.AppendVariables(&w0, &lbw, &ubw, &names);
  auto vec = [](const std::vector<double>& v) {
    return Eigen::VectorXd(
        Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  EquationErrorFit fit{estimators::Nlp(vec(w0), vec(lbw), vec(ubw), names), Eigen::VectorXd(nc),
                       static_cast<int>(total)};
  // Weights: given per channel, else 1 / std of the measured target.
  std::vector<const Eigen::MatrixXd*> targets;
  for (const auto& smp : samples) targets.push_back(&smp.target);
  const Eigen::VectorXd from_data = estimators::InverseStdWeights(targets);
  for (int i = 0; i < nc; ++i) {
    const std::string key =
        model.inverse_inputs.empty() ? m.states[model.residual_states[i]].name : model.channels[i];
    auto w = spec.weights.find(key);
    if (w != spec.weights.end()) {
      fit.weights[i] = w->second;
      continue;
    }
    fit.weights[i] = from_data[i];
  }
  // One element per sample; z = the scaled free parameters.
  const std::vector<Expr> z = Expr::Symbols("theta", nf);
  const std::vector<Expr> target = Expr::Symbols("target", nc);
  std::vector<Expr> r, d;
  estimators::ElementGroup g;
  if (model.parallel) {
    // r_i = w_i (sum_f Y_if scale_f z_f + offset_i - target_i)
    const std::vector<Expr> y = Expr::Symbols("Y", nc * nf), off = Expr::Symbols("offset", nc);
    for (int i = 0; i < nc; ++i) {
      Expr sum = off[i];
      for (int f = 0; f < nf; ++f) sum = sum + y[i * nf + f] * (map.scale[f] * z[f]);
      r.push_back(fit.weights[i] * (sum - target[i]));
    }
    d = y;
    d.insert(d.end(), off.begin(), off.end());
    g.name = "regression";
  } else {
    const std::vector<Expr> x = Expr::Symbols("x", nx), u = Expr::Symbols("u", nu),
                            xd = Expr::Symbols("xdot", nc);
    std::vector<Expr> pz(np);
    for (int i = 0; i < np; ++i) pz[i] = Expr(map.values[i]);
    for (int f = 0; f < nf; ++f) pz[map.free[f]] = map.scale[f] * z[f];
    const std::vector<Expr> hat = model.predict.Call({x, u, xd, pz})[0];
    for (int i = 0; i < nc; ++i) r.push_back(fit.weights[i] * (hat[i] - target[i]));
    d = x;
    d.insert(d.end(), u.begin(), u.end());
    d.insert(d.end(), xd.begin(), xd.end());
    g.name = model.inverse_inputs.empty() ? "state_equation" : "inverse_equation";
  }
  d.insert(d.end(), target.begin(), target.end());
  g.fn = Function(g.name + "_sample", {{"z", z}, {"d", d}}, {{"r", r}});
  g.index.resize(nf, total);
  g.data.resize(static_cast<Eigen::Index>(d.size()), total);
  long col = 0;
  for (const auto& s : samples) {
    for (Eigen::Index k = 0; k < s.target.rows(); ++k, ++col) {
      for (int f = 0; f < nf; ++f) g.index(f, col) = f;
      Eigen::Index row = 0;
      if (model.parallel) {
        for (int i = 0; i < nc; ++i) {
          for (int f = 0; f < nf; ++f) g.data(row++, col) = s.regressors[i](k, f);
        }
        for (int i = 0; i < nc; ++i) g.data(row++, col) = s.offset(k, i);
      } else {
        for (int i = 0; i < nx; ++i) g.data(row++, col) = s.x(k, i);
        for (int i = 0; i < nu; ++i) g.data(row++, col) = s.u(k, i);
        for (int i = 0; i < nc; ++i) g.data(row++, col) = s.xdot(k, i);
      }
      for (int i = 0; i < nc; ++i) g.data(row++, col) = s.target(k, i);
    }
  }
  g.lbc.resize(0);
  g.ubc.resize(0);
  fit.nlp.AddGroup(std::move(g));
  // Labels: split, sample (after skip_samples and decimation), residual channel.
  std::vector<int> channel(nc);
  for (int i = 0; i < nc; ++i) channel[i] = fit.nlp.ResidualChannel(model.channels[i]);
  int row = 0;
  for (std::size_t e = 0; e < samples.size(); ++e) {
    for (Eigen::Index k = 0; k < samples[e].target.rows(); ++k) {
      for (int i = 0; i < nc; ++i) {
        fit.nlp.LabelResidual(row++, {static_cast<int>(e), static_cast<int>(k), channel[i]});
      }
    }
  }
  return fit;
}

Eigen::MatrixXd PredictTarget(const EquationModel& model, const EquationSamples& samples,
                              const Eigen::VectorXd& p) {
  if (!model.parallel) return EvaluateTarget(model, samples.x, samples.u, samples.xdot, p);
  const Eigen::VectorXd theta = FreeValues(model, p);
  Eigen::MatrixXd g = samples.offset;
  for (std::size_t i = 0; i < samples.regressors.size(); ++i) {
    g.col(static_cast<Eigen::Index>(i)) += samples.regressors[i] * theta;
  }
  return g;
}

}  // namespace graybox::estimators::internal
