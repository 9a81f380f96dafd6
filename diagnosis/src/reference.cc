#include "graybox/diagnosis/reference.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "graybox/diagnosis/candidates.h"
#include "graybox/diagnosis/screening.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Moments {
  double mean = 0.0, std = 0.0;
};

// Mean and standard deviation (population) of finite values.
Moments MomentsOf(const std::vector<double>& values) {
  Moments m;
  int n = 0;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    m.mean += v;
    ++n;
  }
  if (n == 0) return m;
  m.mean /= n;
  for (double v : values) {
    if (std::isfinite(v)) m.std += (v - m.mean) * (v - m.mean);
  }
  m.std = std::sqrt(m.std / n);
  return m;
}

// The values of `signals` along the nominal simulation of every estimation split, one vector per
// signal.
std::vector<std::vector<double>> AlongEstimation(const est::Problem& problem,
                                                 const est::FitResult& nominal,
                                                 const std::vector<std::string>& signals) {
  std::vector<std::vector<double>> out(signals.size());
  for (const est::SplitEvaluation& e : nominal.evaluations) {
    if (e.role != est::SplitRole::kEstimation || e.states.rows() == 0) continue;
    const Eigen::MatrixXd v =
        problem.built.EvaluateSignals(signals, e.states, e.inputs, nominal.values);
    for (std::size_t j = 0; j < signals.size(); ++j) {
      for (Eigen::Index k = 0; k < v.rows(); ++k) out[j].push_back(v(k, j));
    }
  }
  return out;
}

// The position state of the block that owns the velocity state `velocity`, or "".
std::string PositionOf(const models::StateSpaceModel& m, const std::string& velocity) {
  const int iv = m.SignalIndex(velocity);
  if (iv < 0 || m.signals[iv].blocks.empty()) return "";
  for (const models::SignalDescription& s : m.signals) {
    if (s.source == models::SignalSource::kState && s.info.role == models::SignalRole::kPosition &&
        !s.blocks.empty() && s.blocks.front() == m.signals[iv].blocks.front()) {
      return s.info.name;
    }
  }
  return "";
}

std::string FreshInstance(const models::Model& m, const std::string& base) {
  auto taken = [&](const std::string& name) {
    for (const auto& p : m.parameters()) {
      if (p.name.rfind(name + ".", 0) == 0) return true;
    }
    return false;
  };
  std::string name = base;
  for (int k = 2; taken(name); ++k) name = base + "_" + std::to_string(k);
  return name;
}

// ", build 1.2 s, solve 0.4 s, ..." from the fit's phases.
std::string Timings(const est::FitResult& fit) {
  std::string out;
  for (const auto& [phase, seconds] : fit.seconds) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), ", %s %.2g s", phase.c_str(), seconds);
    out += buf;
  }
  return out;
}

}  // namespace

void ReferenceOptions::Validate() const {
  if (hidden < 1) {
    throw std::invalid_argument("ReferenceOptions.hidden: expected >= 1, got " +
                                std::to_string(hidden));
  }
  if (!(max_steepness >= 1.0) || !std::isfinite(max_steepness)) {
    throw std::invalid_argument(
        "ReferenceOptions.max_steepness: expected a finite value >= 1, got " +
        std::to_string(max_steepness));
  }
  if (!(weight_decay >= 0.0) || !std::isfinite(weight_decay)) {
    throw std::invalid_argument(
        "ReferenceOptions.weight_decay: expected a finite value >= 0, got " +
        std::to_string(weight_decay));
  }
}

std::string FlexibleReferenceSolver(const est::Problem& problem) {
  // Under multiple shooting: Gauss-Newton on Ceres with penalised continuity, as the exact Hessian
  // of the Lagrangian that Ipopt needs is costly to build symbolically through the networks (see
  // the file comment).
  return problem.estimation.method == "multiple_shooting" ? "ceres" : problem.estimation.solver;
}

FlexibleReference FitFlexibleReference(const est::Problem& problem,
                                       const std::vector<est::SplitData>& splits,
                                       const est::FitResult& nominal,
                                       const ReferenceOptions& options) {
  options.Validate();
  FlexibleReference r;
  r.validation_nrmse = kNaN;
  try {
    const std::vector<MechanicalAxis> axes = FindAxes(problem);
    if (axes.empty()) throw std::runtime_error("the model has no mechanical axis");
    models::Model m = problem.model;
    for (int i = 0; i < problem.built.NumParameters(); ++i) {
      m.Parameter(problem.built.parameters[i].name).value = nominal.values[i];
    }
    std::vector<std::string> instances;
    for (const MechanicalAxis& axis : axes) {
      const std::string position =
          options.position_network ? PositionOf(problem.built, axis.velocity) : "";
      std::vector<std::string> names = {axis.velocity, axis.force};
      if (!position.empty()) names.push_back(position);
      const std::vector<std::vector<double>> values = AlongEstimation(problem, nominal, names);
      const Moments force = MomentsOf(values[1]);
      const double force_scale = force.std > 0.0 ? force.std : 1.0;
      const std::string force_unit =
          problem.built.signals[problem.built.SignalIndex(axis.force)].info.unit;
      // Adds a network on `signal` whose hidden layer holds the fixed features `w` (input weights)
      // and `b` (biases) of the file comment, unless the hidden layer is trained.
      auto add = [&](const std::string& signal, const Moments& in, const std::string& base,
                     const std::vector<double>& w, const std::vector<double>& b) {
        models::BlockOptions o;
        o.numbers["sizes"] = {1.0, static_cast<double>(w.size()), 1.0};
        o.numbers["input_mean"] = {in.mean};
        o.numbers["input_std"] = {in.std};
        o.numbers["output_std"] = {force_scale};
        o.numbers["seed"] = {static_cast<double>(options.seed)};
        o.words["input_unit"] = problem.built.signals[problem.built.SignalIndex(signal)].info.unit;
        o.words["output_unit"] = force_unit;
        const std::string instance = FreshInstance(m, base);
        m.Augment(instance, "network.mlp", o, {signal}, {axis.connection});
        if (!options.train_hidden_layer) {
          for (std::size_t i = 0; i < w.size(); ++i) {
            for (const auto& [name, value] :
                 {std::pair<std::string, double>{".l0.w" + std::to_string(i) + "_0", w[i]},
                  std::pair<std::string, double>{".l0.b" + std::to_string(i), b[i]}}) {
              models::ModelParameter& p = m.Parameter(instance + name);
              p.value = value;
              p.lower = std::min(p.lower, value);
              p.upper = std::max(p.upper, value);
              p.free = false;
            }
          }
        }
        instances.push_back(instance);
        r.networks.push_back("network.mlp on " + signal + " -> " + axis.force);
        r.network_instances.push_back(instance);
        r.network_axes.push_back(axis);
      };
      const Moments v = MomentsOf(values[0]);
      if (v.std > 0.0) {
        // Odd steps tanh(w_i (v - mean) / std) at log-spaced steepness 1 .. max_steepness.
        const int h = options.hidden;
        std::vector<double> w(h), b(h, 0.0);
        for (int i = 0; i < h; ++i) {
          w[i] = h == 1 ? 1.0 : std::pow(options.max_steepness, static_cast<double>(i) / (h - 1));
          b[i] = w[i] * v.mean / v.std;  // centred on v = 0, not on the mean
        }
        add(axis.velocity, v, "reference_velocity", w, b);
      }
      if (!position.empty()) {
        const Moments q = MomentsOf(values[2]);
        if (q.std > 0.0) {
          // Smooth steps at the quantiles (i + 1/2) / h of q, each as wide as the spacing.
          std::vector<double> sorted;
          for (double x : values[2]) {
            if (std::isfinite(x)) sorted.push_back((x - q.mean) / q.std);
          }
          std::sort(sorted.begin(), sorted.end());
          const int h = options.hidden;
          std::vector<double> c(h), w(h), b(h);
          for (int i = 0; i < h; ++i) {
            c[i] = sorted[static_cast<std::size_t>((i + 0.5) / h * (sorted.size() - 1))];
          }
          for (int i = 0; i < h; ++i) {
            const double spacing = std::max(h > 1 ? (c.back() - c.front()) / (h - 1) : 1.0, 1e-3);
            w[i] = 2.0 / spacing;
            b[i] = -w[i] * c[i];
          }
          add(position, q, "reference_position", w, b);
        }
      }
    }
    if (instances.empty()) throw std::runtime_error("every axis signal is constant");
    est::Problem aug = problem;
    aug.model = m;
    aug.built = m.Build();
    est::RegularizationTerm decay;
    decay.name = "reference_weight_decay";
    decay.weight = options.weight_decay;
    decay.reference = est::RegularizationReference::kZero;
    for (int i = 0; i < aug.built.NumParameters(); ++i) {
      const models::ModelParameter& p = aug.built.parameters[i];
      for (const std::string& inst : instances) {
        if (p.name.rfind(inst + ".", 0) == 0 && p.free) decay.parameters.push_back(i);
      }
    }
    r.num_network_parameters = static_cast<int>(decay.parameters.size());
    if (options.weight_decay > 0.0) aug.estimation.regularization.terms.push_back(decay);
    aug.estimation.solver = FlexibleReferenceSolver(problem);
    if (aug.estimation.method == "multiple_shooting") {
      aug.estimation.multiple_shooting.continuity_as_constraints = false;
      aug.estimation.multiple_shooting.continuity_weight = 1e3;
    }
    est::FitOptions fo;
    fo.compute_covariance = false;
    r.fit = est::Fit(aug, AugmentedSplits(splits, aug.built.NumStates()), fo);
    r.model = aug.built;
    r.validation_nrmse = ValidationNrmse(r.fit.evaluations, ValidationRole(splits));
    if (!r.fit.IsSolutionUsable()) {
      r.failure = "solver: " + r.fit.solver_result.status + " " + r.fit.solver_result.message;
    } else if (!std::isfinite(r.validation_nrmse)) {
      r.failure = "the validation simulation did not finish";
    } else {
      r.ok = true;
    }
  } catch (const std::exception& e) {
    r.failure = e.what();
  }
  if (!r.ok) r.validation_nrmse = kNaN;
  return r;
}

std::string FlexibleReference::BriefReport() const {
  char buf[160];
  if (!ok) return "flexible reference: not available (" + failure + ")";
  std::snprintf(buf, sizeof(buf),
                "flexible reference (%zu networks, %d parameters): ", networks.size(),
                num_network_parameters);
  char v[64];
  std::snprintf(v, sizeof(v), "validation NRMSE %.4g", validation_nrmse);
  return std::string(buf) + v + " (" + fit.solver_result.solver + " " + fit.solver_result.status +
         " after " + std::to_string(fit.solver_result.iterations) + " iterations" + Timings(fit) +
         ")";
}

}  // namespace graybox::diagnosis
