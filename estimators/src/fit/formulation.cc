#include "fit/formulation.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "fit/equation_error_fit.h"
#include "graybox/estimators/formulations/collocation.h"
#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/formulations/n_step_loss.h"
#include "graybox/estimators/formulations/single_shooting.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/nlp/regularization.h"
#include "graybox/estimators/nlp/weights.h"

namespace graybox::estimators::internal {

namespace {

std::string Sci(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// Dense d r / d theta (the free parameters, unscaled) of an NLP whose only variables are the
// scaled free parameters.
Eigen::MatrixXd ParameterJacobian(const Nlp& nlp, const Eigen::VectorXd& w,
                                  const Eigen::VectorXd& scale) {
  std::vector<double> values(nlp.ResidualJacobianRows().size());
  const NlpEvalStatus status = nlp.ResidualJacobianValues(w.data(), values.data());
  if (!status.ok) throw std::runtime_error("residual Jacobian: " + status.message);
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(nlp.NumResiduals(), nlp.NumVariables());
  for (std::size_t k = 0; k < values.size(); ++k) {
    j(nlp.ResidualJacobianRows()[k], nlp.ResidualJacobianCols()[k]) += values[k];
  }
  for (Eigen::Index c = 0; c < scale.size(); ++c) j.col(c) /= scale[c];
  return j;
}

// Gauss-Newton covariance of an NLP whose only variables are the scaled free parameters
// (equation error, the N-step loss), from its residuals at w; p holds all parameter values.
UncertaintyReport ParameterOnlyCovariance(const Nlp& nlp, const ParameterMap& map,
                                          const models::StateSpaceModel& m,
                                          const Eigen::VectorXd& w, const Eigen::VectorXd& p,
                                          const CovarianceOptions& options = {}) {
  Eigen::VectorXd r(nlp.NumResiduals());
  const NlpEvalStatus status = nlp.Residuals(w.data(), r.data());
  if (!status.ok) throw std::runtime_error("residuals: " + status.message);
  std::vector<models::ModelParameter> params = m.parameters;
  for (std::size_t i = 0; i < params.size(); ++i) params[i].value = p[static_cast<int>(i)];
  return CovarianceFromJacobian(ParameterJacobian(nlp, w, map.scale), r, params, map.free, options);
}

// One noise variance per labelled residual channel (the formulation registers its measured
// channels first, so they are 0 .. k-1), regularisation rows as penalties; `weights` per measured
// channel (for the noise in the channel's unit), `units` likewise (may be empty).
CovarianceOptions ChannelsFromLabels(const Nlp& nlp, const Eigen::VectorXd& weights,
                                     const std::vector<std::string>& units) {
  CovarianceOptions o;
  const std::vector<std::string>& names = nlp.residual_channels();
  int measured = 0;
  while (measured < static_cast<int>(names.size()) &&
         names[static_cast<std::size_t>(measured)].rfind("regularization.", 0) != 0) {
    ++measured;
  }
  o.row_channels.reserve(nlp.residual_labels().size());
  for (const ResidualLabel& l : nlp.residual_labels()) {
    if (l.channel < 0 || l.channel >= measured) {
      o.row_channels.push_back(kPenaltyRow);
    } else {
      o.row_channels.push_back(l.channel);
    }
  }
  o.channel_names.assign(names.begin(), names.begin() + measured);
  if (weights.size() == measured) o.channel_weights = weights;
  if (static_cast<int>(units.size()) == measured) o.channel_units = units;
  return o;
}

// Output weights by name (the rest 1 / std over the estimation data), or empty for the default.
Eigen::VectorXd OutputWeights(const Problem& problem, const std::vector<Experiment>& experiments) {
  const auto& given = problem.estimation.output_weights;
  if (given.empty()) return {};
  const models::StateSpaceModel& m = problem.built;
  std::vector<const Eigen::MatrixXd*> ys;
  for (const auto& e : experiments) ys.push_back(&e.y);
  const Eigen::VectorXd from_data = InverseStdWeights(ys);
  Eigen::VectorXd w(m.NumOutputs());
  for (int j = 0; j < m.NumOutputs(); ++j) {
    auto it = given.find(m.outputs[j].name);
    w[j] = it != given.end() ? it->second : from_data[j];
  }
  return w;
}

struct EquationState {
  EquationModel model;
  std::unique_ptr<EquationErrorFit> fit;
};

void FormulateEquationError(const Problem& problem, const std::vector<const SplitData*>& est,
                            const std::function<void(const std::string&)>& progress,
                            Formulation* f) {
  const models::StateSpaceModel& m = problem.built;
  auto eq = std::make_shared<EquationState>();
  eq->model = BuildEquationModel(problem, *est[0]);
  std::vector<EquationSamples> samples;
  for (const SplitData* s : est) samples.push_back(SampleSplit(problem, eq->model, *s));
  eq->fit = std::make_unique<EquationErrorFit>(BuildEquationErrorFit(problem, eq->model, samples));
  f->owner = eq;
  f->nlp = &eq->fit->nlp;
  f->map = &eq->model.parameters;
  f->parameters = [eq](const Eigen::VectorXd& w) { return eq->model.parameters.Values(w); };
  f->initial_states = [](const Eigen::VectorXd&) {
    return std::map<std::string, Eigen::VectorXd>();
  };
  f->covariance = [eq, &m](const Eigen::VectorXd& w, const Eigen::VectorXd& p) {
    return ParameterOnlyCovariance(
        eq->fit->nlp, eq->model.parameters, m, w, p,
        ChannelsFromLabels(eq->fit->nlp, eq->fit->weights, eq->model.units));
  };
  const Problem* pr = &problem;
  f->evaluate_equation = [eq, pr](const SplitData& split, const Eigen::VectorXd& p,
                                  SplitEvaluation* e) {
    const EquationSamples s = SampleSplit(*pr, eq->model, split);
    e->has_equation = true;
    e->equation_channels = eq->model.channels;
    e->equation_units = eq->model.units;
    e->equation_time = s.time;
    e->equation_measured = s.target;
    e->equation_predicted = PredictTarget(eq->model, s, p);
    MetricOptions options;
    options.channel_names = eq->model.channels;
    options.channel_units = eq->model.units;
    e->equation = ComputeMetrics(e->equation_measured, e->equation_predicted, options);
  };
  const EquationErrorSpec& ee = problem.estimation.equation_error;
  f->summary.emplace_back("form", ee.form);
  std::string channels;
  for (const auto& c : eq->model.channels) channels += (channels.empty() ? "" : ", ") + c;
  f->summary.emplace_back("residual_channels", channels);
  f->summary.emplace_back("lowpass_hz", Sci(ee.lowpass_hz));
  f->summary.emplace_back("lowpass_order", std::to_string(ee.lowpass_order));
  f->summary.emplace_back("skip_samples", std::to_string(ee.skip_samples));
  f->summary.emplace_back("decimate", std::to_string(ee.decimate));
  f->summary.emplace_back("decimation", ee.decimate == 1     ? "none"
                                        : eq->model.parallel ? "parallel (regressors)"
                                                             : "signals");
  f->summary.emplace_back("samples", std::to_string(eq->fit->num_samples));
  if (progress) {
    progress("  equation error (" + ee.form + "): " + std::to_string(eq->fit->num_samples) +
             " samples after preprocessing" +
             (ee.decimate > 1 ? (eq->model.parallel ? " (parallel decimation of the regressors)"
                                                    : " (decimated signals)")
                              : "") +
             ", residual channels " + channels);
  }
}

struct Experiments {
  std::vector<Experiment> data;
  std::vector<ExperimentSetup> setups;
};

// The estimation splits as the simulation formulations take them; with node_guess = "data" (or
// for the N-step loss) the states derived from the measurements are the state guess and x.
std::shared_ptr<const Experiments> ShootingExperiments(const Problem& problem,
                                                       const std::vector<const SplitData*>& est,
                                                       bool measured_states) {
  auto out = std::make_shared<Experiments>();
  for (const SplitData* s : est) {
    Experiment e = s->experiment;
    e.name = s->name;
    ExperimentSetup setup = s->setup;
    if (problem.estimation.node_guess == "data" || measured_states) {
      const Eigen::MatrixXd x =
          StatesFromSpec(problem, problem.estimation.equation_error, s->experiment);
      if (problem.estimation.node_guess == "data") setup.state_guess = x;
      if (measured_states) {
        e.x = x;
        e.dx.resize(0, 0);
        e.x_names.clear();
        e.x_units.clear();
      }
    }
    out->data.push_back(std::move(e));
    out->setups.push_back(std::move(setup));
  }
  return out;
}

// The N-step loss (n_step_loss.h) on the states derived from the estimation splits.
void FormulateNStep(const Problem& problem, const std::shared_ptr<const Experiments>& ex,
                    const std::function<void(const std::string&)>& progress, Formulation* f) {
  const models::StateSpaceModel& m = problem.built;
  // Weights not given in the file are 0 in spec.n_step.weights: BuildNStepLoss makes them 1 / std.
  const NStepLossOptions& options = problem.estimation.n_step;
  auto np = std::make_shared<NStepLossProblem>(BuildNStepLoss(m, ex->data, options));
  f->owner = np;
  f->nlp = &np->nlp;
  f->map = &np->parameters;
  f->parameters = [np](const Eigen::VectorXd& w) { return np->Parameters(w); };
  f->initial_states = [ex](const Eigen::VectorXd&) {  // not estimated: the data's
    std::map<std::string, Eigen::VectorXd> x0;
    for (std::size_t e = 0; e < ex->data.size(); ++e) x0[ex->data[e].name] = ex->setups[e].x0;
    return x0;
  };
  f->set_fixed_value = [np](int i, double v) { np->SetFixedValue(i, v); };
  // Gauss-Newton on the loss's residuals with one noise variance per scored channel;
  // regularisation rows, if any, are penalties.
  f->covariance = [np, &m](const Eigen::VectorXd& w, const Eigen::VectorXd& p) {
    std::vector<std::string> units;
    for (int c : np->channels) units.push_back(m.states[c].unit);
    return ParameterOnlyCovariance(np->nlp, np->parameters, m, w, p,
                                   ChannelsFromLabels(np->nlp, np->weights, units));
  };
  std::string names;
  for (int c : np->channels) names += (names.empty() ? "" : ", ") + m.states[c].name;
  long starts = 0;
  for (const auto& s : np->starts) starts += static_cast<long>(s.size());
  f->summary.emplace_back("steps", std::to_string(options.steps));
  f->summary.emplace_back("stride", std::to_string(options.stride));
  f->summary.emplace_back("starts", std::to_string(starts));
  f->summary.emplace_back("channels", names);
  f->summary.emplace_back("integrator", IntegrationMethodName(options.integrator.method));
  if (progress) {
    progress("  n-step loss: " + std::to_string(starts) + " windows of " +
             std::to_string(options.steps) + " samples, " + std::to_string(np->num_scored) +
             " scored values");
  }
}

Formulation FormulateMethod(const Problem& problem, const std::vector<const SplitData*>& est,
                            const std::function<void(const std::string&)>& progress) {
  const EstimationSpec& spec = problem.estimation;
  const models::StateSpaceModel& m = problem.built;
  Formulation f;
  f.summary.emplace_back("method", spec.method);
  f.summary.emplace_back("solver", spec.solver);
  f.summary.emplace_back("step_scheme", StepSchemeName(spec.step.scheme));
  f.summary.emplace_back("substeps", std::to_string(spec.step.substeps));
  if (spec.step.scheme != StepScheme::kRk4) {
    f.summary.emplace_back("newton_iterations", std::to_string(spec.step.newton_iterations));
  }
  std::string names;
  for (const SplitData* s : est) names += (names.empty() ? "" : ", ") + s->name;
  f.summary.emplace_back("estimation_splits", names);
  if (spec.method == "equation_error") {
    FormulateEquationError(problem, est, progress, &f);
    return f;
  }
  const auto ex = ShootingExperiments(problem, est, spec.method == "n_step");
  if (spec.method == "n_step") {
    FormulateNStep(problem, ex, progress, &f);
    return f;
  }
  const Eigen::VectorXd weights = OutputWeights(problem, ex->data);
  std::shared_ptr<ShootingProblem> shooting;
  Eigen::VectorXd used_weights;
  bool x0_free = true;
  if (spec.method == "collocation") {
    CollocationOptions options = spec.collocation;
    options.output_weights = weights;
    auto cp =
        std::make_shared<CollocationProblem>(BuildCollocation(m, ex->data, ex->setups, options));
    f.owner = cp;
    f.nlp = &cp->nlp;
    f.map = &cp->parameters;
    f.parameters = [cp](const Eigen::VectorXd& w) { return cp->Parameters(w); };
    f.initial_states = [cp, ex](const Eigen::VectorXd& w) {
      std::map<std::string, Eigen::VectorXd> x0;
      for (std::size_t e = 0; e < ex->data.size(); ++e) {
        const Eigen::MatrixXi& idx = cp->state_variables[e];
        Eigen::VectorXd x(idx.cols());
        for (Eigen::Index i = 0; i < idx.cols(); ++i) x[i] = w[idx(0, i)];
        x0[ex->data[e].name] = x;
      }
      return x0;
    };
    f.set_fixed_value = [cp](int i, double v) { cp->SetFixedValue(i, v); };
    used_weights = cp->output_weights;
    f.summary.emplace_back("scheme",
                           options.scheme == CollocationScheme::kRadau ? "radau" : "legendre");
    f.summary.emplace_back("degree", std::to_string(options.degree));
  } else if (spec.method == "single_shooting") {
    SingleShootingOptions options;
    options.integrator = spec.integrator;
    options.output_weights = weights;
    options.fix_initial_state = spec.multiple_shooting.fix_initial_state;
    x0_free = false;
    for (const auto& setup : ex->setups) {
      x0_free = x0_free || setup.AnyInitialStateFree(m.NumStates(), !options.fix_initial_state);
    }
    shooting =
        std::make_shared<ShootingProblem>(BuildSingleShooting(m, ex->data, ex->setups, options));
    f.summary.emplace_back("integrator", IntegrationMethodName(options.integrator.method));
    f.summary.emplace_back("fix_initial_state", options.fix_initial_state ? "true" : "false");
  } else if (spec.method == "multiple_shooting") {
    MultipleShootingOptions options = spec.multiple_shooting;
    options.output_weights = weights;
    shooting =
        std::make_shared<ShootingProblem>(BuildMultipleShooting(m, ex->data, ex->setups, options));
    f.summary.emplace_back("segment_length", std::to_string(options.segment_length));
    f.summary.emplace_back("continuity",
                           options.continuity_as_constraints ? "constraints" : "residuals");
    f.summary.emplace_back("node_guess", spec.node_guess);
    f.summary.emplace_back("fix_initial_state", options.fix_initial_state ? "true" : "false");
  } else {
    throw ProblemFileError(spec.where, "unknown method '" + spec.method + "'");
  }
  if (shooting) {
    f.owner = shooting;
    f.nlp = &shooting->nlp;
    f.map = &shooting->parameters;
    f.parameters = [shooting](const Eigen::VectorXd& w) { return shooting->Parameters(w); };
    f.initial_states = [shooting, ex](const Eigen::VectorXd& w) {
      std::map<std::string, Eigen::VectorXd> x0;
      for (std::size_t e = 0; e < ex->data.size(); ++e) {
        Eigen::VectorXd x = shooting->InitialState(w, static_cast<int>(e));
        for (Eigen::Index i = 0; i < x.size(); ++i) {
          if (!std::isfinite(x[i])) x[i] = ex->setups[e].x0[i];  // fixed initial state
        }
        x0[ex->data[e].name] = x;
      }
      return x0;
    };
    f.set_fixed_value = [shooting](int i, double v) { shooting->SetFixedValue(i, v); };
    used_weights = shooting->output_weights;
  }
  CovarianceOptions channels;  // noise reported per output channel, in the output's unit
  for (const auto& o : m.outputs) {
    channels.channel_names.push_back(o.name);
    channels.channel_units.push_back(o.unit);
  }
  if (spec.method == "multiple_shooting") {
    // Gauss-Newton covariance of the shooting NLP itself (nodes eliminated, continuity exact in
    // both the Ipopt and the Ceres form): finite even when a whole-record simulation drifts.
    f.covariance = [shooting, channels](const Eigen::VectorXd& w, const Eigen::VectorXd&) {
      return NlpCovariance(*shooting, w, channels);
    };
  } else {
    // Output error of the whole record, simulated by the problem's integrator.
    const std::shared_ptr<const Integrator> integrator =
        MakeIntegrator(m, ex->data.at(0).dt, spec.integrator);
    const auto initial = f.initial_states;
    CovarianceOptions options = channels;
    options.free_initial_states = x0_free;  // a fixed x0 is not differentiated
    f.covariance = [initial, ex, integrator, used_weights, options](const Eigen::VectorXd& w,
                                                                    const Eigen::VectorXd& p) {
      const auto x0 = initial(w);
      std::vector<Eigen::VectorXd> states;
      for (const auto& e : ex->data) states.push_back(x0.at(e.name));
      return SimulationCovariance(*integrator, ex->data, p, states, used_weights, options);
    };
  }
  long samples = 0;
  for (const auto& e : ex->data) samples += e.u.rows();
  if (progress) {
    progress("  " + spec.method + ": " + std::to_string(samples) + " samples in " +
             std::to_string(ex->data.size()) + " experiment(s), " +
             std::to_string(f.nlp->NumVariables()) + " variables");
  }
  return f;
}

}  // namespace

Formulation Formulate(const Problem& problem, const std::vector<const SplitData*>& estimation,
                      const std::function<void(const std::string&)>& progress) {
  if (estimation.empty()) {
    throw ProblemFileError(problem.estimation.where,
                           "no split has role 'estimation': expected at least one");
  }
  Formulation f = FormulateMethod(problem, estimation, progress);
  const RegularizationOptions& reg = problem.estimation.regularization;
  if (reg.terms.empty()) return f;
  AddRegularization(*f.map, reg, f.nlp);
  for (const RegularizationTerm& t : reg.terms) {
    const std::string what = "lambda " + Sci(t.weight) + " toward " +
                             RegularizationReferenceName(t.reference) + " on " +
                             std::to_string(t.parameters.size()) + " parameters";
    f.summary.emplace_back("regularization." + t.name, what);
    if (progress) progress("  regularization '" + t.name + "': " + what);
  }
  return f;
}

}  // namespace graybox::estimators::internal
