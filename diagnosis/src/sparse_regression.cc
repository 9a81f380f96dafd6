#include "graybox/diagnosis/sparse_regression.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

namespace graybox::diagnosis {
namespace {

constexpr double kTwoPi = 6.28318530717958647692;
// Steepness of the Coulomb and direction-dependent columns and of the Stribeck columns' sign, in
// units of 1 / RMS(v): the middle and the steepest values of the candidates' option grid.
constexpr double kCoulombSteepness = 30.0;
constexpr double kStribeckSteepness = 150.0;
constexpr double kStribeckVelocities[] = {0.03, 0.1, 0.3};  // x RMS(v)
constexpr double kPowerLawExponents[] = {0.3, 0.6, 2.0};
constexpr double kRippleDivisors[] = {1.0, 2.0, 4.0, 8.0};

// Relative step of the central differences of the force in the nominal parameters.
constexpr double kSensitivityStep = 1e-6;

bool IsNetworkParameter(const std::string& name, const std::vector<std::string>& instances) {
  for (const std::string& inst : instances) {
    if (name.rfind(inst + ".", 0) == 0) return true;
  }
  return false;
}

struct Column {
  std::string effect, shape;
  Eigen::VectorXd values;
};

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4g", v);
  return buf;
}

double Rms(const Eigen::VectorXd& x) {
  return x.size() == 0 ? 0.0 : std::sqrt(x.squaredNorm() / static_cast<double>(x.size()));
}

// The library of the file comment on one axis' samples.
std::vector<Column> Library(const Eigen::VectorXd& v, const Eigen::VectorXd* q, bool prismatic,
                            const std::vector<double>& scanned_periods) {
  std::vector<Column> cols;
  const double s = Rms(v) > 0.0 ? Rms(v) : 1.0;
  const Eigen::Index n = v.size();
  auto add = [&](const std::string& effect, const std::string& shape, auto f) {
    Eigen::VectorXd c(n);
    for (Eigen::Index k = 0; k < n; ++k) c[k] = f(k);
    cols.push_back({effect, shape, c});
  };
  add("asymmetric_friction", "1", [](Eigen::Index) { return 1.0; });
  add("asymmetric_friction", "tanh(30 v / s)^2", [&](Eigen::Index k) {
    const double t = std::tanh(kCoulombSteepness * v[k] / s);
    return t * t;
  });
  add("coulomb", "tanh(30 v / s)",
      [&](Eigen::Index k) { return std::tanh(kCoulombSteepness * v[k] / s); });
  add("viscous", "v", [&](Eigen::Index k) { return v[k]; });
  for (const double c : kStribeckVelocities) {
    add("stribeck", "exp(-(v / " + Num(c) + " s)^2) tanh(150 v / s)", [&](Eigen::Index k) {
      const double r = v[k] / (c * s);
      return std::exp(-r * r) * std::tanh(kStribeckSteepness * v[k] / s);
    });
  }
  for (const double e : kPowerLawExponents) {
    add("power_law_viscous", "sign(v) |v / s|^" + Num(e), [&](Eigen::Index k) {
      const double a = std::pow(std::fabs(v[k]) / s, e);
      return v[k] > 0.0 ? a : (v[k] < 0.0 ? -a : 0.0);
    });
  }
  if (q) {
    std::vector<double> periods = scanned_periods;
    if (periods.empty()) {
      const double span = prismatic ? q->maxCoeff() - q->minCoeff() : kTwoPi;
      if (span > 0.0) {
        for (const double d : kRippleDivisors) periods.push_back(span / d);
      }
    }
    for (const double p : periods) {
      // On a rotary axis a period of 2 pi is gravity: the payload's column.
      const bool gravity = !prismatic && std::fabs(p - kTwoPi) <= 1e-9 * kTwoPi;
      const std::string effect = gravity ? "payload" : "ripple";
      const std::string arg = gravity ? "q" : "2 pi q / " + Num(p);
      add(effect, "sin(" + arg + ")",
          [&](Eigen::Index k) { return std::sin(kTwoPi * (*q)[k] / p); });
      add(effect, "cos(" + arg + ")",
          [&](Eigen::Index k) { return std::cos(kTwoPi * (*q)[k] / p); });
    }
    if (!prismatic && std::none_of(periods.begin(), periods.end(), [](double p) {
          return std::fabs(p - kTwoPi) <= 1e-9 * kTwoPi;
        })) {
      add("payload", "sin(q)", [&](Eigen::Index k) { return std::sin((*q)[k]); });
      add("payload", "cos(q)", [&](Eigen::Index k) { return std::cos((*q)[k]); });
    }
  }
  return cols;
}

// Least-squares residual of f on the columns `a` (column-pivoted QR).
Eigen::VectorXd Residual(const Eigen::MatrixXd& a, const Eigen::VectorXd& f) {
  if (a.cols() == 0) return f;
  return f - a * a.colPivHouseholderQr().solve(f);
}

// The greedy forward selection of the file comment: fills `out`'s terms, effects, r_squared and
// absorbed_by_nominal. `nuisance` are the nominal parameters' force sensitivities.
void ForwardSelect(const std::vector<Column>& cols, const std::vector<Eigen::VectorXd>& nuisance,
                   const Eigen::VectorXd& f, const SparseRegressionOptions& options,
                   AxisRegression* out) {
  const Eigen::Index n = f.size();
  Eigen::MatrixXd a(n, 0);
  auto append = [&](const Eigen::VectorXd& c) {
    a.conservativeResize(n, a.cols() + 1);
    a.col(a.cols() - 1) = c / Rms(c);
  };
  for (const Eigen::VectorXd& c : nuisance) append(c);
  const Eigen::VectorXd r0 = Residual(a, f);
  const double e_total = f.squaredNorm();
  const double e0 = r0.squaredNorm();
  out->absorbed_by_nominal = e_total > 0.0 ? 1.0 - e0 / e_total : 0.0;
  std::vector<int> chosen;
  std::vector<double> gains;  // each chosen column's reduction of the residual energy / e0
  double e = e0;
  std::vector<bool> usable(cols.size());
  for (std::size_t j = 0; j < cols.size(); ++j) {
    const double rms = Rms(cols[j].values);
    usable[j] = rms > 0.0 && std::isfinite(rms);
  }
  while (e0 > 0.0 && static_cast<int>(chosen.size()) < options.max_terms) {
    int best = -1;
    double best_e = e;
    for (std::size_t j = 0; j < cols.size(); ++j) {
      if (!usable[j] ||
          std::find(chosen.begin(), chosen.end(), static_cast<int>(j)) != chosen.end()) {
        continue;
      }
      Eigen::MatrixXd trial(n, a.cols() + 1);
      trial << a, cols[j].values / Rms(cols[j].values);
      const double ej = Residual(trial, f).squaredNorm();
      if (ej < best_e) {
        best_e = ej;
        best = static_cast<int>(j);
      }
    }
    if (best < 0 || (e - best_e) / e0 < options.threshold) break;
    chosen.push_back(best);
    gains.push_back((e - best_e) / e0);
    append(cols[best].values);
    e = best_e;
  }
  out->r_squared = e0 > 0.0 ? 1.0 - e / e0 : 0.0;
  if (chosen.empty()) return;
  // Coefficients of the final fit, in the force's unit per unit of the shape.
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(f);
  std::map<std::string, double> by_effect;
  for (std::size_t i = 0; i < chosen.size(); ++i) {
    const Column& c = cols[chosen[i]];
    const double coef = x[static_cast<Eigen::Index>(nuisance.size() + i)] / Rms(c.values);
    out->terms.push_back({c.effect, c.shape, coef, gains[i]});
    by_effect[c.effect] += gains[i];
  }
  for (const auto& [effect, share] : by_effect) out->effects.push_back({effect, share});
  std::sort(out->effects.begin(), out->effects.end(),
            [](const SparseEffect& a, const SparseEffect& b) { return a.share > b.share; });
}

}  // namespace

void SparseRegressionOptions::Validate() const {
  if (!(threshold > 0.0 && threshold < 1.0)) {
    throw std::invalid_argument(
        "SparseRegressionOptions.threshold: expected a value in (0, 1), got " +
        std::to_string(threshold));
  }
  if (max_terms < 1) {
    throw std::invalid_argument("SparseRegressionOptions.max_terms: expected >= 1, got " +
                                std::to_string(max_terms));
  }
}

SparseRegression RegressLearnedForce(const FlexibleReference& reference,
                                     const SparseRegressionOptions& options) {
  options.Validate();
  SparseRegression r;
  if (!reference.ok) {
    r.failure = "the flexible reference is not available (" + reference.failure + ")";
    return r;
  }
  const models::StateSpaceModel& m = reference.model;
  const Eigen::VectorXd& p = reference.fit.values;
  // The parameters with the networks at their neutral values (zero output).
  Eigen::VectorXd p0 = p;
  for (int i = 0; i < m.NumParameters(); ++i) {
    const models::ModelParameter& par = m.parameters[i];
    if (IsNetworkParameter(par.name, reference.network_instances) && par.info.HasNeutral()) {
      p0[i] = par.info.neutral;
    }
  }
  // One regression per axis (several networks on one axis add up).
  std::vector<std::string> done;
  std::string failures;
  for (const MechanicalAxis& axis : reference.network_axes) {
    if (std::find(done.begin(), done.end(), axis.velocity) != done.end()) continue;
    done.push_back(axis.velocity);
    AxisRegression a;
    a.velocity = axis.velocity;
    a.force = axis.force;
    std::vector<std::string> names = {axis.force, axis.velocity};
    if (!axis.position.empty()) names.push_back(axis.position);
    std::vector<double> f, v, q;
    const bool subtracts = axis.connection.rfind('-', 0) == 0;
    // The estimation splits' samples where both evaluations are finite, per evaluation.
    std::vector<const estimators::SplitEvaluation*> used;
    std::vector<std::vector<Eigen::Index>> rows;
    std::vector<Eigen::VectorXd> nuisance;
    try {
      for (const estimators::SplitEvaluation& e : reference.fit.evaluations) {
        if (e.role != estimators::SplitRole::kEstimation || e.states.rows() == 0) continue;
        const Eigen::MatrixXd with = m.EvaluateSignals(names, e.states, e.inputs, p);
        const Eigen::MatrixXd without = m.EvaluateSignals(names, e.states, e.inputs, p0);
        used.push_back(&e);
        rows.emplace_back();
        for (Eigen::Index k = 0; k < with.rows(); ++k) {
          if (!with.row(k).allFinite() || !without.row(k).allFinite()) continue;
          rows.back().push_back(k);
          // The networks write axis.connection: "-F" adds -net to F.
          const double added = with(k, 0) - without(k, 0);
          f.push_back(subtracts ? -added : added);
          v.push_back(with(k, 1));
          if (names.size() > 2) q.push_back(with(k, 2));
        }
      }
      // The nominal free parameters' force sensitivities dF/dtheta (central differences) at the
      // same samples, in the friction convention: what the physics can absorb.
      for (int i = 0; i < m.NumParameters(); ++i) {
        const models::ModelParameter& par = m.parameters[i];
        if (!par.free || IsNetworkParameter(par.name, reference.network_instances)) continue;
        const double h = kSensitivityStep * std::max(1.0, std::fabs(p[i]));
        Eigen::VectorXd plus = p, minus = p;
        plus[i] += h;
        minus[i] -= h;
        std::vector<double> column;
        for (std::size_t u = 0; u < used.size(); ++u) {
          const Eigen::MatrixXd fp =
              m.EvaluateSignals({axis.force}, used[u]->states, used[u]->inputs, plus);
          const Eigen::MatrixXd fm =
              m.EvaluateSignals({axis.force}, used[u]->states, used[u]->inputs, minus);
          for (const Eigen::Index k : rows[u]) {
            const double d = (fp(k, 0) - fm(k, 0)) / (2.0 * h);
            column.push_back(subtracts ? -d : d);
          }
        }
        const Eigen::VectorXd c = Eigen::Map<const Eigen::VectorXd>(
            column.data(), static_cast<Eigen::Index>(column.size()));
        if (c.allFinite() && Rms(c) > 0.0) nuisance.push_back(c);
      }
    } catch (const std::exception& ex) {
      failures += (failures.empty() ? "" : "; ") + axis.velocity + ": " + ex.what();
      continue;
    }
    a.samples = static_cast<int>(f.size());
    const Eigen::VectorXd fv = Eigen::Map<const Eigen::VectorXd>(f.data(), a.samples);
    a.learned_force_rms = Rms(fv);
    if (a.samples == 0 || !(a.learned_force_rms > 0.0)) {
      failures += (failures.empty() ? "" : "; ") + axis.velocity +
                  (a.samples == 0 ? ": no finite sample" : ": the learned force is zero");
      continue;
    }
    const Eigen::VectorXd vv = Eigen::Map<const Eigen::VectorXd>(v.data(), a.samples);
    const Eigen::VectorXd qv = Eigen::Map<const Eigen::VectorXd>(q.data(), q.size());
    const auto scanned = options.ripple_periods_by_position.find(axis.position);
    const std::vector<Column> cols =
        Library(vv, q.empty() ? nullptr : &qv, axis.prismatic,
                scanned == options.ripple_periods_by_position.end() ? std::vector<double>{}
                                                                    : scanned->second);
    ForwardSelect(cols, nuisance, fv, options, &a);
    r.axes.push_back(std::move(a));
  }
  for (const AxisRegression& a : r.axes) {
    for (const SparseEffect& e : a.effects) {
      auto it = std::find_if(r.effects.begin(), r.effects.end(),
                             [&](const SparseEffect& x) { return x.effect == e.effect; });
      if (it == r.effects.end()) {
        r.effects.push_back(e);
      } else {
        it->share = std::max(it->share, e.share);
      }
    }
  }
  std::sort(r.effects.begin(), r.effects.end(),
            [](const SparseEffect& a, const SparseEffect& b) { return a.share > b.share; });
  r.ok = !r.axes.empty();
  r.failure = r.ok ? failures : (failures.empty() ? "no axis with a network" : failures);
  return r;
}

std::string SparseRegression::BriefReport() const {
  if (!ok) return "sparse regression of the learned force: not available (" + failure + ")";
  std::string s = "sparse regression of the learned force:";
  if (!note.empty()) return s + " no proposal (" + note + ")";
  if (effects.empty()) s += " no shape above the threshold";
  for (std::size_t i = 0; i < effects.size(); ++i) {
    s += (i ? ", " : " ") + effects[i].effect + " " + Num(effects[i].share);
  }
  std::string fits;
  for (const AxisRegression& a : axes) {
    fits += (fits.empty() ? "" : ", ") + Num(a.r_squared) + " on " + a.velocity;
  }
  return s + " (share of the learned force beyond the nominal parameters; R^2 " + fits + ")";
}

}  // namespace graybox::diagnosis
