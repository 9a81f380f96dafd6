// The commands: fit (formulate, solve, covariance, evaluate, write), simulate and check. Nothing
// is written before the problem, its data and the formulation have been validated; outputs are
// written atomically, result.json last.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <future>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "app.h"
#include "equation_error_fit.h"
#include "graybox/estimators/collocation.h"
#include "graybox/estimators/covariance.h"
#include "graybox/estimators/multiple_shooting.h"
#include "graybox/estimators/n_step_loss.h"
#include "graybox/estimators/nlp_check.h"
#include "graybox/estimators/regularization.h"
#include "graybox/estimators/single_shooting.h"
#include "graybox/estimators/weights.h"
#include "report.h"

namespace graybox::app {

using estimators::Problem;
using estimators::SplitData;
using estimators::SplitRole;

namespace {

// Seconds between progress lines while a solver runs without printing its own.
constexpr auto kHeartbeat = std::chrono::seconds(15);

class Timer {
 public:
  double Seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

void Progress(const std::string& line) { std::cout << line << std::endl; }

std::string Fixed(double v, int digits = 2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

std::string Sci(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// Runs `body` and maps exceptions to exit codes: bad input (std::invalid_argument, including
// ProblemFileError) -> 2, anything else -> 1.
int Guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const std::invalid_argument& e) {
    std::cerr << "graybox: error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "graybox: internal error: " << e.what() << "\n";
    return kExitInternalError;
  }
}

// The output directory must be a directory or not exist yet (it is created after validation).
void CheckOutputDirectory(const std::string& dir) {
  namespace fs = std::filesystem;
  if (dir.empty()) throw std::invalid_argument("--out: expected an output directory, got ''");
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw std::invalid_argument("--out '" + dir +
                                "': expected a directory (or a path to create), got an existing "
                                "file");
  }
}

void PrintProblem(const Problem& problem, const std::vector<SplitData>& splits) {
  const models::StateSpaceModel& m = problem.built;
  int free = 0;
  for (const auto& p : m.parameters) free += p.free ? 1 : 0;
  Progress("  model '" + m.name + "': " + std::to_string(m.NumStates()) + " states, " +
           std::to_string(m.NumInputs()) + " inputs, " + std::to_string(m.NumOutputs()) +
           " outputs, " + std::to_string(m.NumParameters()) + " parameters (" +
           std::to_string(free) + " free)");
  for (const SplitData& s : splits) {
    Progress("  split '" + s.name + "' (" + estimators::SplitRoleName(s.role) + ") from data '" +
             s.data_name + "': samples " + std::to_string(s.begin) + ".." +
             std::to_string(s.begin + s.experiment.NumSamples()) + " at " + Sci(s.experiment.dt) +
             " s");
  }
}

std::vector<const SplitData*> EstimationSplits(const Problem& problem,
                                               const std::vector<SplitData>& splits) {
  std::vector<const SplitData*> est;
  for (const auto& s : splits) {
    if (s.role == SplitRole::kEstimation) est.push_back(&s);
  }
  if (est.empty()) {
    throw estimators::ProblemFileError(problem.estimation.where,
                                       "no split has role 'estimation': expected at least one");
  }
  return est;
}

estimators::SolverResult Solve(const estimators::Nlp& nlp, const estimators::EstimationSpec& spec,
                               bool verbose) {
  estimators::IpoptOptions ipopt = spec.ipopt;
  estimators::CeresOptions ceres = spec.ceres;
  if (verbose) {
    ipopt.print_level = std::max(ipopt.print_level, 5);
    ceres.print_progress = true;
  }
  Progress("  solving with " + spec.solver + " (" + std::to_string(nlp.NumVariables()) +
           " variables, " + std::to_string(nlp.NumConstraints()) + " constraints, " +
           std::to_string(nlp.NumResiduals()) + " residuals)" +
           (verbose ? "" : "; --verbose prints the iterations"));
  Timer timer;
  auto future = std::async(std::launch::async, [&] {
    return spec.solver == "ipopt" ? estimators::SolveWithIpopt(nlp, ipopt)
                                  : estimators::SolveWithCeres(nlp, ceres);
  });
  while (future.wait_for(kHeartbeat) != std::future_status::ready) {
    Progress("  ... " + spec.solver + " still running (" + Fixed(timer.Seconds(), 0) + " s)");
  }
  return future.get();
}

// Output weights by name (the rest 1 / std over the estimation data), or empty for the default.
Eigen::VectorXd OutputWeights(const Problem& problem,
                              const std::vector<estimators::ExperimentData>& experiments) {
  const auto& given = problem.estimation.output_weights;
  if (given.empty()) return {};
  const models::StateSpaceModel& m = problem.built;
  std::vector<const Eigen::MatrixXd*> ys;
  for (const auto& e : experiments) ys.push_back(&e.y);
  const Eigen::VectorXd from_data = estimators::InverseStdWeights(ys);
  Eigen::VectorXd w(m.NumOutputs());
  for (int j = 0; j < m.NumOutputs(); ++j) {
    auto it = given.find(m.outputs[j].name);
    if (it != given.end()) {
      w[j] = it->second;
      continue;
    }
    w[j] = from_data[j];
  }
  return w;
}

// Dense d r / d theta (the free parameters, unscaled) of an NLP whose first variables are the
// scaled free parameters and which has no other variables.
Eigen::MatrixXd ParameterJacobian(const estimators::Nlp& nlp, const Eigen::VectorXd& w,
                                  const Eigen::VectorXd& scale) {
  std::vector<double> values(nlp.ResidualJacobianRows().size());
  const auto status = nlp.ResidualJacobianValues(w.data(), values.data());
  if (!status.ok) throw std::runtime_error("residual Jacobian: " + status.message);
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(nlp.NumResiduals(), nlp.NumVariables());
  for (std::size_t k = 0; k < values.size(); ++k) {
    j(nlp.ResidualJacobianRows()[k], nlp.ResidualJacobianCols()[k]) += values[k];
  }
  for (Eigen::Index c = 0; c < scale.size(); ++c) j.col(c) /= scale[c];
  return j;
}

// Gauss-Newton covariance of an NLP whose only variables are the scaled free parameters (equation
// error, the N-step loss), from its residuals at w; p holds all model parameter values.
estimators::UncertaintyReport ParameterOnlyCovariance(
    const estimators::Nlp& nlp, const estimators::ParameterMap& map,
    const models::StateSpaceModel& m, const Eigen::VectorXd& w, const Eigen::VectorXd& p,
    const estimators::CovarianceOptions& options = {}) {
  Eigen::VectorXd r(nlp.NumResiduals());
  const auto status = nlp.Residuals(w.data(), r.data());
  if (!status.ok) throw std::runtime_error("residuals: " + status.message);
  std::vector<models::ModelParameter> params = m.parameters;
  for (std::size_t i = 0; i < params.size(); ++i) params[i].value = p[static_cast<int>(i)];
  return estimators::CovarianceFromJacobian(ParameterJacobian(nlp, w, map.scale), r, params,
                                            map.free, options);
}

struct EquationState {
  EquationModel model;
  std::unique_ptr<EquationErrorFit> fit;
};

struct Formulated {
  // The NLP (owned by one of the problems below), its parameter map, and how to read the solution.
  estimators::Nlp* nlp = nullptr;
  const estimators::ParameterMap* map = nullptr;
  std::function<Eigen::VectorXd(const Eigen::VectorXd&)> parameters;
  std::function<std::map<std::string, Eigen::VectorXd>(const Eigen::VectorXd&)> initial_states;
  std::function<estimators::UncertaintyReport(const Eigen::VectorXd&, const Eigen::VectorXd&)>
      covariance;
  std::shared_ptr<estimators::ShootingProblem> shooting;
  std::shared_ptr<estimators::CollocationProblem> collocation;
  std::shared_ptr<estimators::NStepLossProblem> n_step;
  std::shared_ptr<EquationState> equation;
  std::shared_ptr<const std::vector<estimators::ExperimentData>> experiments;
  std::vector<std::pair<std::string, std::string>> summary;
};

std::vector<estimators::ExperimentData> ShootingExperiments(
    const Problem& problem, const std::vector<const SplitData*>& est) {
  std::vector<estimators::ExperimentData> out;
  for (const SplitData* s : est) {
    estimators::ExperimentData d;
    d.name = s->name;
    d.dt = s->experiment.dt;
    d.u = s->experiment.u;
    d.y = s->experiment.y;
    d.x0 = s->x0;
    if (problem.estimation.node_guess == "data") {
      d.state_guess = StatesFromData(problem, problem.estimation.equation_error, s->experiment);
    }
    out.push_back(std::move(d));
  }
  return out;
}

// The N-step loss (n_step_loss.h) from the states of the estimation splits (derived from the
// measurements as for node_guess = "data").
void FormulateNStep(const Problem& problem, const std::vector<const SplitData*>& est,
                    Formulated* f) {
  const estimators::EstimationSpec& spec = problem.estimation;
  const models::StateSpaceModel& m = problem.built;
  std::vector<Eigen::MatrixXd> states;
  for (const SplitData* s : est) {
    states.push_back(StatesFromData(problem, spec.equation_error, s->experiment));
  }
  // Weights not given in the file are 0 in spec.n_step.weights: BuildNStepLoss makes them 1 / std.
  const estimators::NStepLossOptions& options = spec.n_step;
  f->n_step = std::make_shared<estimators::NStepLossProblem>(
      estimators::BuildNStepLoss(m, *f->experiments, states, options));
  const auto np = f->n_step;
  const auto ex = f->experiments;
  f->nlp = &np->nlp;
  f->map = &np->parameters;
  f->parameters = [np](const Eigen::VectorXd& w) { return np->Parameters(w); };
  f->initial_states = [ex](const Eigen::VectorXd&) {  // not estimated: the data's
    std::map<std::string, Eigen::VectorXd> x0;
    for (const auto& e : *ex) x0[e.name] = e.x0;
    return x0;
  };
  // Gauss-Newton on the loss's residuals with one noise variance per scored channel (rows are
  // window, step, channel; regularisation rows, if any, follow as one more channel).
  f->covariance = [np, &m](const Eigen::VectorXd& w, const Eigen::VectorXd& p) {
    estimators::CovarianceOptions options;
    const int nc = static_cast<int>(np->channels.size());
    options.row_channels.resize(static_cast<std::size_t>(np->nlp.NumResiduals()));
    for (std::size_t k = 0; k < options.row_channels.size(); ++k) {
      options.row_channels[k] =
          static_cast<long>(k) < np->num_scored ? static_cast<int>(k % nc) : nc;
    }
    return ParameterOnlyCovariance(np->nlp, np->parameters, m, w, p, options);
  };
  std::string names;
  for (int c : np->channels) names += (names.empty() ? "" : ", ") + m.states[c].name;
  long starts = 0;
  for (const auto& s : np->starts) starts += static_cast<long>(s.size());
  f->summary.emplace_back("steps", std::to_string(options.steps));
  f->summary.emplace_back("stride", std::to_string(options.stride));
  f->summary.emplace_back("starts", std::to_string(starts));
  f->summary.emplace_back("channels", names);
  f->summary.emplace_back("integrator",
                          estimators::IntegrationMethodName(options.integrator.method));
  Progress("  n-step loss: " + std::to_string(starts) + " windows of " +
           std::to_string(options.steps) + " samples, " + std::to_string(np->num_scored) +
           " scored values");
}

Formulated BuildFormulation(const Problem& problem, const std::vector<const SplitData*>& est) {
  const estimators::EstimationSpec& spec = problem.estimation;
  const models::StateSpaceModel& m = problem.built;
  Formulated f;
  f.summary.emplace_back("method", spec.method);
  f.summary.emplace_back("solver", spec.solver);
  f.summary.emplace_back("step_scheme", estimators::StepSchemeName(spec.step.scheme));
  f.summary.emplace_back("substeps", std::to_string(spec.step.substeps));
  if (spec.step.scheme != estimators::StepScheme::kRk4) {
    f.summary.emplace_back("newton_iterations", std::to_string(spec.step.newton_iterations));
  }
  std::string names;
  for (const SplitData* s : est) names += (names.empty() ? "" : ", ") + s->name;
  f.summary.emplace_back("estimation_splits", names);
  if (spec.method == "equation_error") {
    f.equation = std::make_shared<EquationState>();
    EquationState& eq = *f.equation;
    eq.model = BuildEquationModel(problem, *est[0]);
    std::vector<EquationSamples> samples;
    for (const SplitData* s : est) samples.push_back(SampleSplit(problem, eq.model, *s));
    eq.fit = std::make_unique<EquationErrorFit>(BuildEquationErrorFit(problem, eq.model, samples));
    const auto state = f.equation;
    f.nlp = &eq.fit->nlp;
    f.map = &eq.model.parameters;
    f.parameters = [state](const Eigen::VectorXd& w) { return state->model.parameters.Values(w); };
    f.initial_states = [](const Eigen::VectorXd&) {
      return std::map<std::string, Eigen::VectorXd>();
    };
    f.covariance = [state, &m](const Eigen::VectorXd& w, const Eigen::VectorXd& p) {
      return ParameterOnlyCovariance(state->fit->nlp, state->model.parameters, m, w, p);
    };
    const auto& ee = spec.equation_error;
    f.summary.emplace_back("form", ee.form);
    std::string channels;
    for (const auto& c : eq.model.channels) channels += (channels.empty() ? "" : ", ") + c;
    f.summary.emplace_back("residual_channels", channels);
    f.summary.emplace_back("lowpass_hz", Sci(ee.lowpass_hz));
    f.summary.emplace_back("lowpass_order", std::to_string(ee.lowpass_order));
    f.summary.emplace_back("skip_samples", std::to_string(ee.skip_samples));
    f.summary.emplace_back("decimate", std::to_string(ee.decimate));
    f.summary.emplace_back("decimation", ee.decimate == 1    ? "none"
                                         : eq.model.parallel ? "parallel (regressors)"
                                                             : "signals");
    f.summary.emplace_back("samples", std::to_string(eq.fit->num_samples));
    Progress("  equation error (" + ee.form + "): " + std::to_string(eq.fit->num_samples) +
             " samples after preprocessing" +
             (ee.decimate > 1 ? (eq.model.parallel ? " (parallel decimation of the regressors)"
                                                   : " (decimated signals)")
                              : "") +
             ", residual channels " + channels);
    return f;
  }
  f.experiments = std::make_shared<const std::vector<estimators::ExperimentData>>(
      ShootingExperiments(problem, est));
  const auto ex = f.experiments;
  const Eigen::VectorXd weights = OutputWeights(problem, *ex);
  if (spec.method == "collocation") {
    estimators::CollocationOptions options = spec.collocation;
    options.output_weights = weights;
    f.collocation = std::make_shared<estimators::CollocationProblem>(
        estimators::BuildCollocation(m, *ex, options));
    const auto cp = f.collocation;
    f.nlp = &cp->nlp;
    f.map = &cp->parameters;
    f.parameters = [cp](const Eigen::VectorXd& w) { return cp->Parameters(w); };
    f.initial_states = [cp, ex](const Eigen::VectorXd& w) {
      std::map<std::string, Eigen::VectorXd> x0;
      for (std::size_t e = 0; e < ex->size(); ++e) {
        const Eigen::MatrixXi& idx = cp->state_variables[e];
        Eigen::VectorXd x(idx.cols());
        for (Eigen::Index i = 0; i < idx.cols(); ++i) x[i] = w[idx(0, i)];
        x0[(*ex)[e].name] = x;
      }
      return x0;
    };
    f.summary.emplace_back(
        "scheme", options.scheme == estimators::CollocationScheme::kRadau ? "radau" : "legendre");
    f.summary.emplace_back("degree", std::to_string(options.degree));
  } else if (spec.method == "single_shooting") {
    estimators::SingleShootingOptions options;
    options.integrator = spec.integrator;
    options.output_weights = weights;
    options.fix_initial_state = spec.multiple_shooting.fix_initial_state;
    f.shooting = std::make_shared<estimators::ShootingProblem>(
        estimators::BuildSingleShooting(m, *ex, options));
    f.summary.emplace_back("integrator",
                           estimators::IntegrationMethodName(options.integrator.method));
    f.summary.emplace_back("fix_initial_state", options.fix_initial_state ? "true" : "false");
  } else if (spec.method == "n_step") {
    FormulateNStep(problem, est, &f);
  } else {
    estimators::MultipleShootingOptions options = spec.multiple_shooting;
    options.output_weights = weights;
    f.shooting = std::make_shared<estimators::ShootingProblem>(
        estimators::BuildMultipleShooting(m, *ex, options));
    f.summary.emplace_back("segment_length", std::to_string(options.segment_length));
    f.summary.emplace_back("continuity",
                           options.continuity_as_constraints ? "constraints" : "residuals");
    f.summary.emplace_back("node_guess", spec.node_guess);
    f.summary.emplace_back("fix_initial_state", options.fix_initial_state ? "true" : "false");
  }
  if (f.shooting) {
    const auto sp = f.shooting;
    f.nlp = &sp->nlp;
    f.map = &sp->parameters;
    f.parameters = [sp](const Eigen::VectorXd& w) { return sp->Parameters(w); };
    f.initial_states = [sp, ex](const Eigen::VectorXd& w) {
      std::map<std::string, Eigen::VectorXd> x0;
      for (std::size_t e = 0; e < ex->size(); ++e) {
        Eigen::VectorXd x = sp->InitialState(w, static_cast<int>(e));
        for (Eigen::Index i = 0; i < x.size(); ++i) {
          if (!std::isfinite(x[i])) x[i] = (*ex)[e].x0[i];  // fixed initial state
        }
        x0[(*ex)[e].name] = x;
      }
      return x0;
    };
  }
  const Eigen::VectorXd used_weights = f.shooting      ? f.shooting->output_weights
                                       : f.collocation ? f.collocation->output_weights
                                                       : Eigen::VectorXd();
  if (spec.method == "n_step") {
    // Set by FormulateNStep: the Gauss-Newton covariance of the loss itself.
  } else if (spec.method == "multiple_shooting") {
    // Gauss-Newton covariance of the shooting NLP itself (continuity weighted as the Ceres form
    // penalises it, nodes marginalised): finite even when a whole-record simulation drifts.
    const auto sp = f.shooting;
    const double continuity_weight = spec.multiple_shooting.continuity_weight;
    f.covariance = [sp, continuity_weight](const Eigen::VectorXd& w, const Eigen::VectorXd&) {
      return estimators::NlpCovariance(sp->nlp, w, sp->parameters, continuity_weight);
    };
  } else {
    // Output error of the whole record, simulated by the problem's integrator.
    const std::shared_ptr<const estimators::Integrator> integrator =
        estimators::MakeIntegrator(m, ex->at(0).dt, spec.integrator);
    f.covariance = [initial = f.initial_states, ex, integrator, used_weights](
                       const Eigen::VectorXd& w, const Eigen::VectorXd& p) {
      const auto x0 = initial(w);
      std::vector<Eigen::VectorXd> states;
      for (const auto& e : *ex) states.push_back(x0.at(e.name));
      return estimators::SimulationCovariance(*integrator, *ex, p, states, used_weights);
    };
  }
  long samples = 0;
  for (const auto& e : *ex) samples += e.u.rows();
  Progress("  " + spec.method + ": " + std::to_string(samples) + " samples in " +
           std::to_string(ex->size()) + " experiment(s), " + std::to_string(f.nlp->NumVariables()) +
           " variables");
  return f;
}

// The formulation with the [[estimation.regularization]] terms added to its NLP.
Formulated Formulate(const Problem& problem, const std::vector<const SplitData*>& est) {
  Formulated f = BuildFormulation(problem, est);
  const estimators::RegularizationOptions& reg = problem.estimation.regularization;
  if (reg.terms.empty()) return f;
  estimators::AddRegularization(*f.map, reg, f.nlp);
  for (const estimators::RegularizationTerm& t : reg.terms) {
    const std::string what = "lambda " + Sci(t.weight) + " toward " +
                             estimators::RegularizationReferenceName(t.reference) + " on " +
                             std::to_string(t.parameters.size()) + " parameters";
    f.summary.emplace_back("regularization." + t.name, what);
    Progress("  regularization '" + t.name + "': " + what);
  }
  return f;
}

void PrintEvaluation(const SplitEvaluation& e) {
  Progress("  split '" + e.name + "' (" + estimators::SplitRoleName(e.role) +
           ") simulation: " + e.simulation.BriefReport() +
           (e.simulation_ok ? "" : " [diverged at sample " + std::to_string(e.failed_at) + "]"));
  if (e.has_n_step) {
    Progress("  split '" + e.name + "' (" + estimators::SplitRoleName(e.role) + ") " +
             e.n_step.BriefReport());
  }
  if (e.has_equation) {
    Progress("  split '" + e.name + "' (" + estimators::SplitRoleName(e.role) +
             ") equation: " + e.equation.BriefReport());
  }
}

// Adds the equation-error evaluation (predicted against measured target) of a split.
void EvaluateEquation(const Problem& problem, const EquationModel& model, const SplitData& split,
                      const Eigen::VectorXd& p, SplitEvaluation* e) {
  const EquationSamples s = SampleSplit(problem, model, split);
  e->has_equation = true;
  e->equation_channels = model.channels;
  e->equation_units = model.units;
  e->equation_time = s.time;
  e->equation_measured = s.target;
  e->equation_predicted = PredictTarget(model, s, p);
  estimators::MetricOptions options;
  options.channel_names = model.channels;
  options.channel_units = model.units;
  e->equation = estimators::ComputeMetrics(e->equation_measured, e->equation_predicted, options);
}

void Finish(const std::string& out, const std::string& json_name, RunReport* report,
            const Timer& total) {
  report->seconds.emplace_back("total", total.Seconds());
  const auto written = WriteOutputs(out, json_name, *report);
  Progress("  wrote " + written.back() + " and " + std::to_string(written.size() - 1) +
           " plots and traces in " + out);
}

}  // namespace

int RunFit(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Timer total;
    RunReport report;
    report.command = "fit";
    report.command_line = o.command_line;
    Timer t;
    const Problem problem = estimators::LoadProblem(o.problem);
    report.problem = &problem;
    report.seed = problem.estimation.seed;
    Progress("graybox fit: problem '" + problem.name + "' (" + o.problem + ")");
    CheckOutputDirectory(o.out);
    const std::vector<SplitData> splits = estimators::LoadData(problem);
    PrintProblem(problem, splits);
    report.seconds.emplace_back("load", t.Seconds());
    const auto est = EstimationSplits(problem, splits);
    t = Timer();
    const Formulated f = Formulate(problem, est);
    report.seconds.emplace_back("build", t.Seconds());
    report.formulation = f.summary;
    report.num_variables = f.nlp->NumVariables();
    report.num_constraints = f.nlp->NumConstraints();
    report.num_residuals = f.nlp->NumResiduals();
    report.initial_parameters = problem.built.ParameterValues();
    if (o.check_derivatives) {
      Progress("  derivative checks at the initial point (split '" + est[0]->name + "'):");
      report.derivative_checks = CheckModelDerivatives(problem, *est[0], report.initial_parameters);
      Progress("  derivative checks of the assembled NLP at its initial point:");
      for (const expr::DerivativeCheckResult& r :
           estimators::CheckNlpDerivatives(*f.nlp, f.nlp->w0())) {
        DerivativeCheckLine line;
        line.what = r.what;
        line.ok = r.ok;
        line.max_error = r.max_error;
        line.report = r.BriefReport();
        Progress("  " + line.report);
        if (!r.ok) std::cout << r.FullReport();
        report.derivative_checks.push_back(line);
      }
    }
    // Solve. From here on a failure is reported in result.json.
    t = Timer();
    report.solver = Solve(*f.nlp, problem.estimation, o.verbose);
    report.has_solver = true;
    report.seconds.emplace_back("solve", t.Seconds());
    Progress("  " + report.solver.BriefReport());
    report.parameters = f.parameters(report.solver.w);
    report.estimated_initial_states = f.initial_states(report.solver.w);
    if (!report.solver.success) {
      report.status = "solver_failure";
      report.exit_code = kExitSolverFailure;
      report.message = report.solver.message.empty()
                           ? "the solver stopped with status " + report.solver.status
                           : report.solver.message;
    }
    t = Timer();
    try {
      report.uncertainty = f.covariance(report.solver.w, report.parameters);
      report.has_uncertainty = true;
      std::cout << report.uncertainty.FullReport();
    } catch (const std::exception& e) {
      report.uncertainty_error = e.what();
      Progress("  no parameter uncertainty: " + report.uncertainty_error);
    }
    report.seconds.emplace_back("covariance", t.Seconds());
    t = Timer();
    for (const SplitData& s : splits) {
      auto x0 = report.estimated_initial_states.find(s.name);
      SplitEvaluation e =
          EvaluateSimulation(problem, s, report.parameters,
                             x0 != report.estimated_initial_states.end() ? x0->second : s.x0);
      if (f.equation) EvaluateEquation(problem, f.equation->model, s, report.parameters, &e);
      EvaluateNStep(problem, s, report.parameters, &e);
      PrintEvaluation(e);
      report.evaluations.push_back(std::move(e));
    }
    report.seconds.emplace_back("evaluate", t.Seconds());
    Finish(o.out, "result.json", &report, total);
    if (report.exit_code != kExitSuccess) {
      std::cerr << "graybox: solver failure: " << report.message << "\n";
    }
    return report.exit_code;
  });
}

int RunSimulate(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Timer total;
    RunReport report;
    report.command = "simulate";
    report.command_line = o.command_line;
    report.parameter_file = o.params;
    Timer t;
    const Problem problem = estimators::LoadProblem(o.problem);
    report.problem = &problem;
    Progress("graybox simulate: problem '" + problem.name + "' (" + o.problem + ")");
    CheckOutputDirectory(o.out);
    const std::map<std::string, double> values = LoadParameterValues(o.params, problem.built);
    const std::vector<SplitData> splits = estimators::LoadData(problem);
    PrintProblem(problem, splits);
    report.seconds.emplace_back("load", t.Seconds());
    report.initial_parameters = problem.built.ParameterValues();
    report.parameters = report.initial_parameters;
    for (const auto& [name, value] : values) {
      report.parameters[problem.built.ParameterIndex(name)] = value;
    }
    Progress("  " + std::to_string(values.size()) + " parameter values from " + o.params);
    if (o.check_derivatives && !splits.empty()) {
      Progress("  derivative checks at the given parameters (split '" + splits[0].name + "'):");
      report.derivative_checks = CheckModelDerivatives(problem, splits[0], report.parameters);
    }
    t = Timer();
    for (const SplitData& s : splits) {
      SplitEvaluation e = EvaluateSimulation(problem, s, report.parameters, s.x0);
      EvaluateNStep(problem, s, report.parameters, &e);
      PrintEvaluation(e);
      if (!e.simulation_ok && report.exit_code == kExitSuccess) {
        report.status = "simulation_failure";
        report.exit_code = kExitSolverFailure;
        report.message = "the simulation of split '" + s.name + "' diverged at sample " +
                         std::to_string(e.failed_at);
      }
      report.evaluations.push_back(std::move(e));
    }
    report.seconds.emplace_back("simulate", t.Seconds());
    Finish(o.out, "simulation.json", &report, total);
    if (report.exit_code != kExitSuccess) std::cerr << "graybox: " << report.message << "\n";
    return report.exit_code;
  });
}

int RunCheck(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Problem problem = estimators::LoadProblem(o.problem);
    Progress("graybox check: problem '" + problem.name + "' (" + o.problem + ")");
    const std::vector<SplitData> splits = estimators::LoadData(problem);
    PrintProblem(problem, splits);
    const models::StateSpaceModel& m = problem.built;
    for (const auto& p : m.parameters) {
      Progress("    " + p.name + " = " + Sci(p.value) + " " + p.info.unit +
               (p.free ? "  free in [" + Sci(p.lower) + ", " + Sci(p.upper) + "]" : "  fixed"));
    }
    if (o.check_derivatives && !splits.empty()) {
      CheckModelDerivatives(problem, splits[0], m.ParameterValues());
    }
    Progress("  OK: method " + problem.estimation.method + " with " + problem.estimation.solver);
    return kExitSuccess;
  });
}

}  // namespace graybox::app
