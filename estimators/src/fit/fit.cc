// FitSession and Fit: formulate once, solve (warm-started), covariance, evaluation.
#include "graybox/estimators/fit/fit.h"

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "fit/formulation.h"
#include "graybox/estimators/nlp/nlp_check.h"
#include "graybox/util/did_you_mean.h"
#include "graybox/util/thread_user_time.h"

namespace graybox::estimators {

namespace {

class Timer {
 public:
  double Seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

std::string Sci(double v, int digits = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*e", digits, v);
  return buf;
}

// Prints a progress line every `interval` seconds while a solve runs, with the latest iteration.
class Heartbeat {
 public:
  Heartbeat(const std::function<void(const std::string&)>& progress, double interval,
            std::string solver)
      : progress_(progress),
        interval_(interval),
        solver_(std::move(solver)),
        cpu_start_(util::ThreadUserSeconds()) {
    if (progress_) thread_ = std::thread([this] { Run(); });
  }
  ~Heartbeat() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  // Keeps the latest iteration for the progress line; false (stop) once the solve has run for
  // more than `max_seconds` (> 0, on the wall clock) or `max_cpu_seconds` (> 0, user CPU time of
  // the thread that constructed this object and calls Record: the solving thread) since it started
  // (checked at each iteration).
  bool Record(const IterationSummary& s, double max_seconds, double max_cpu_seconds) {
    std::lock_guard<std::mutex> lock(mutex_);
    latest_ = s;
    has_latest_ = true;
    if (max_seconds > 0.0 && timer_.Seconds() > max_seconds) return false;
    return !(max_cpu_seconds > 0.0 && util::ThreadUserSeconds() - cpu_start_ > max_cpu_seconds);
  }

 private:
  void Run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!done_) {
      if (cv_.wait_for(lock, std::chrono::duration<double>(interval_), [this] { return done_; })) {
        break;
      }
      std::string line = "  ... " + solver_ + " running (" +
                         std::to_string(static_cast<long>(timer_.Seconds())) + " s)";
      if (has_latest_) {
        line += ": iteration " + std::to_string(latest_.iteration) + ", cost " + Sci(latest_.cost) +
                ", constraint violation " + Sci(latest_.constraint_violation, 2) + ", optimality " +
                Sci(latest_.optimality, 2);
      }
      progress_(line);
    }
  }

  const std::function<void(const std::string&)>& progress_;
  double interval_;
  std::string solver_;
  double cpu_start_;
  Timer timer_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  bool has_latest_ = false;
  IterationSummary latest_;
  std::thread thread_;
};

int FindParameter(const models::StateSpaceModel& m, const std::string& name) {
  for (int i = 0; i < m.NumParameters(); ++i) {
    if (m.parameters[i].name == name) return i;
  }
  std::vector<std::string> names;
  for (const auto& p : m.parameters) names.push_back(p.name);
  throw std::invalid_argument("model '" + m.name + "': no parameter '" + name + "'" +
                              util::DidYouMeanHint(name, names));
}

}  // namespace

void FitOptions::Validate() const {
  if (!(max_solve_seconds >= 0.0)) {
    throw std::invalid_argument("FitOptions.max_solve_seconds: expected >= 0, got " +
                                std::to_string(max_solve_seconds));
  }
  if (!(progress_interval_seconds > 0.0)) {
    throw std::invalid_argument("FitOptions.progress_interval_seconds: expected > 0, got " +
                                std::to_string(progress_interval_seconds));
  }
}

struct FitSession::State {
  Problem problem;
  std::vector<SplitData> splits;
  FitOptions options;
  internal::Formulation formulation;
  int formulations = 0;
  bool stale = false;  // the free set changed: formulate before the next solve
  // Starting values of free parameters set since the last formulation (model index -> value).
  std::map<int, double> pending_starts;

  std::vector<const SplitData*> EstimationSplits() const {
    std::vector<const SplitData*> est;
    for (const auto& s : splits) {
      if (s.role == SplitRole::kEstimation) est.push_back(&s);
    }
    return est;
  }
  void Progress(const std::string& line) const {
    if (options.progress) options.progress(line);
  }
  void Formulate() {
    formulation = internal::Formulate(problem, EstimationSplits(), options.progress);
    ++formulations;
    stale = false;
    pending_starts.clear();
    CheckDetermined();
  }
  // The estimation data must be able to determine the free variables: at least as many
  // residuals as free variables less equality constraints (a one-sample split under multiple
  // shooting otherwise "succeeds" at any parameter values).
  void CheckDetermined() const {
    const Nlp& nlp = *formulation.nlp;
    int free = 0;
    for (int k = 0; k < nlp.NumVariables(); ++k) free += nlp.lbw()[k] < nlp.ubw()[k] ? 1 : 0;
    int equalities = 0;
    if (nlp.NumConstraints() > 0) {
      const Eigen::VectorXd lbg = nlp.lbg(), ubg = nlp.ubg();
      for (Eigen::Index k = 0; k < lbg.size(); ++k) equalities += lbg[k] == ubg[k] ? 1 : 0;
    }
    const int needed = free - equalities;
    if (nlp.NumResiduals() >= needed) return;
    std::string names;
    long samples = 0;
    for (const SplitData* s : EstimationSplits()) {
      names += (names.empty() ? "'" : ", '") + s->name + "'";
      samples += s->experiment.NumSamples();
    }
    throw std::invalid_argument(
        "problem '" + problem.name + "': the estimation splits " + names + " (" +
        std::to_string(samples) + " samples) give " + std::to_string(nlp.NumResiduals()) +
        " residuals for " + std::to_string(needed) + " free variables of " +
        problem.estimation.method + " (" + std::to_string(free) + " free, " +
        std::to_string(equalities) +
        " equality constraints): expected at least as many residuals; give longer estimation "
        "splits or fix parameters");
  }
  // The result's description of the formulation.
  void Describe(FitResult* result) const {
    result->problem = problem.name;
    result->method = problem.estimation.method;
    result->solver = problem.estimation.solver;
    result->formulation = formulation.summary;
    result->num_variables = formulation.nlp->NumVariables();
    result->num_constraints = formulation.nlp->NumConstraints();
    result->num_residuals = formulation.nlp->NumResiduals();
  }
  // What follows a solve (result->solver_result holds it; the model's parameter values are the
  // solve's start): the parameter values and initial states at the final point, the covariance,
  // the parameter table and the evaluation of every split.
  void Complete(FitResult* out) {
    FitResult& result = *out;
    const internal::Formulation& f = formulation;
    const models::StateSpaceModel& m = problem.built;
    const Eigen::VectorXd initial = m.ParameterValues();
    const Eigen::VectorXd& w = result.solver_result.w;
    result.values = f.parameters(w);
    result.initial_states = f.initial_states(w);
    // Covariance.
    Timer t;
    if (options.compute_covariance) {
      try {
        result.uncertainty = f.covariance(w, result.values);
        result.has_uncertainty = result.uncertainty.ok;
        if (!result.uncertainty.ok) result.uncertainty_error = result.uncertainty.failure;
      } catch (const std::exception& e) {
        result.uncertainty_error =
            std::string("the covariance could not be computed because ") + e.what();
      }
    }
    result.seconds.emplace_back("covariance", t.Seconds());
    // Parameters.
    for (int i = 0; i < m.NumParameters(); ++i) {
      const models::ModelParameter& mp = m.parameters[i];
      FitParameter p;
      p.name = mp.name;
      p.unit = mp.info.unit;
      p.initial = initial[i];
      p.value = result.values[i];
      p.lower = mp.lower;
      p.upper = mp.upper;
      p.free = mp.free;
      p.std_error = p.free ? std::nan("") : 0.0;
      p.ci_low = p.ci_high = p.value;
      if (p.free) {
        // Within 1e-6 of the parameter's scale or of the bound's magnitude (a Stribeck velocity of
        // scale 0.17 at 999.999 of its bound 1000 is at the bound).
        auto near = [&](double bound) {
          return std::isfinite(bound) &&
                 std::fabs(p.value - bound) <=
                     1e-6 * std::max({std::fabs(mp.scale), std::fabs(bound), 1e-300});
        };
        p.at_bound = near(p.lower) || near(p.upper);
        p.ci_low = p.ci_high = std::nan("");
      }
      if (result.has_uncertainty) {
        for (const ParameterEstimate& e : result.uncertainty.parameters) {
          if (e.name != p.name || !p.free) continue;
          p.std_error = e.std_error;
          p.ci_low = e.ci_low;
          p.ci_high = e.ci_high;
        }
      }
      result.parameters.push_back(p);
    }
    // Evaluation of every split.
    t = Timer();
    if (options.evaluate_splits) {
      for (const SplitData& split : splits) {
        SplitEvaluation e = EvaluateSplit(problem, split, result.values,
                                          InitialStateOf(split, result.initial_states));
        if (f.evaluate_equation) f.evaluate_equation(split, result.values, &e);
        Progress("  " + e.BriefReport());
        result.evaluations.push_back(std::move(e));
      }
    }
    result.seconds.emplace_back("evaluate", t.Seconds());
    pending_starts.clear();
  }
  // Position of model parameter i among the NLP's variables, or -1 when it is not one.
  int VariableOf(int i) const {
    const ParameterMap& map = *formulation.map;
    for (int k = 0; k < map.NumFree(); ++k) {
      if (map.free[k] == i) return k;
    }
    return -1;
  }
};

FitSession::FitSession(const Problem& problem, std::vector<SplitData> splits, FitOptions options)
    : state_(std::make_unique<State>()) {
  options.Validate();
  state_->problem = problem;
  state_->splits = std::move(splits);
  state_->options = std::move(options);
  state_->Formulate();
}

FitSession::~FitSession() = default;
FitSession::FitSession(FitSession&&) noexcept = default;
FitSession& FitSession::operator=(FitSession&&) noexcept = default;

const Problem& FitSession::problem() const { return state_->problem; }
int FitSession::num_formulations() const { return state_->formulations; }

const Nlp& FitSession::nlp() {
  if (state_->stale) state_->Formulate();
  return *state_->formulation.nlp;
}

std::vector<std::string> FitSession::EstimationSplitNames() const {
  std::vector<std::string> names;
  for (const SplitData* s : state_->EstimationSplits()) names.push_back(s->name);
  return names;
}

void FitSession::SetParameterValue(const std::string& name, double value) {
  State& s = *state_;
  models::StateSpaceModel& m = s.problem.built;
  const int i = FindParameter(m, name);
  models::ModelParameter& par = m.parameters[i];
  if (!std::isfinite(value)) {
    throw std::invalid_argument("parameter '" + name + "': expected a finite value, got " +
                                std::to_string(value));
  }
  if (par.free && (value < par.lower || value > par.upper)) {
    throw std::invalid_argument("parameter '" + name + "': expected a value in [" +
                                std::to_string(par.lower) + ", " + std::to_string(par.upper) +
                                "], got " + std::to_string(value));
  }
  par.value = value;
  s.problem.model.SetParameter(name, value);
  if (s.stale) return;  // the next formulation reads the model
  const int k = s.VariableOf(i);
  if (k >= 0) {
    Eigen::VectorXd w0 = s.formulation.nlp->w0();
    w0[k] = value / s.formulation.map->scale[k];
    s.formulation.nlp->SetInitialPoint(w0);
    s.pending_starts[i] = value;
  } else if (s.formulation.set_fixed_value) {
    s.formulation.set_fixed_value(i, value);
  } else {
    s.stale = true;
  }
}

void FitSession::SetMaxSolveSeconds(double seconds) {
  if (!(seconds >= 0.0) || !std::isfinite(seconds)) {
    throw std::invalid_argument(
        "FitSession::SetMaxSolveSeconds: expected a finite value >= 0, got " +
        std::to_string(seconds));
  }
  state_->options.max_solve_seconds = seconds;
}

void FitSession::FixParameter(const std::string& name) {
  State& s = *state_;
  const int i = FindParameter(s.problem.built, name);
  if (!s.problem.built.parameters[i].free) return;
  s.problem.built.parameters[i].free = false;
  s.problem.model.Fix(name);
  s.stale = true;
}

void FitSession::FreeParameter(const std::string& name) {
  State& s = *state_;
  const int i = FindParameter(s.problem.built, name);
  if (s.problem.built.parameters[i].free) return;
  s.problem.built.parameters[i].free = true;
  s.problem.model.Free(name);
  s.stale = true;
}

FitResult FitSession::Solve(const FitResult* start) {
  State& s = *state_;
  const Problem& problem = s.problem;
  const models::StateSpaceModel& m = problem.built;
  FitResult result;
  Timer t;
  const bool same_structure = start != nullptr && !s.stale &&
                              start->solver_result.w.size() == s.formulation.nlp->NumVariables();
  if (start != nullptr && !same_structure) {
    // Another structure: start the free parameters at the earlier estimates.
    for (int i = 0; i < m.NumParameters() && i < start->values.size(); ++i) {
      if (m.parameters[i].free && std::isfinite(start->values[i])) {
        const double v =
            std::min(std::max(start->values[i], m.parameters[i].lower), m.parameters[i].upper);
        s.problem.built.parameters[i].value = v;
        s.problem.model.SetParameter(m.parameters[i].name, v);
      }
    }
    s.stale = true;
  }
  if (s.stale) s.Formulate();
  s.Describe(&result);
  result.seconds.emplace_back("build", t.Seconds());
  const internal::Formulation& f = s.formulation;
  Nlp& nlp = *f.nlp;
  const Eigen::VectorXd initial = m.ParameterValues();
  const std::vector<const SplitData*> est = s.EstimationSplits();
  if (s.options.check_derivatives) {
    s.Progress("  derivative checks at the initial point (split '" + est[0]->name + "'):");
    result.derivative_checks = CheckModelDerivatives(problem, *est[0], initial);
    s.Progress("  derivative checks of the assembled NLP at its initial point:");
    for (const expr::DerivativeCheckResult& r : CheckNlpDerivatives(nlp, nlp.w0())) {
      DerivativeCheckLine line;
      line.what = r.what;
      line.ok = r.ok;
      line.max_error = r.max_error;
      line.report = r.ok ? r.BriefReport() : r.BriefReport() + "\n" + r.FullReport();
      result.derivative_checks.push_back(line);
    }
    for (const DerivativeCheckLine& l : result.derivative_checks) s.Progress("  " + l.report);
  }
  // Solve.
  WarmStart warm;
  bool warm_primal = same_structure;
  if (same_structure) {
    warm = start->solver_result.AsWarmStart();
    for (const auto& [i, v] : s.pending_starts) {
      const int k = s.VariableOf(i);
      if (k >= 0) warm.w[k] = v / f.map->scale[k];
    }
  } else if (start != nullptr) {
    // Another free set, the same method variables (shooting nodes, initial states, collocation
    // states) and constraints: those values and multipliers are carried over, the parameters
    // start at the earlier estimates (above) with their bound multipliers where they were free
    // before (0 for the newly freed).
    std::vector<int> start_position(m.NumParameters(), -1);  // variable index in the start
    int start_free = 0;
    for (std::size_t i = 0; i < start->parameters.size() && i < start_position.size(); ++i) {
      if (start->parameters[i].free) start_position[i] = start_free++;
    }
    const Eigen::Index n = nlp.NumVariables(), other = n - f.map->NumFree();
    const WarmStart before = start->solver_result.AsWarmStart();
    if (other > 0 && before.w.size() - start_free == other && before.w.tail(other).allFinite()) {
      warm.w = nlp.w0();
      warm.w.tail(other) = before.w.tail(other);
      warm_primal = true;
      if (before.lambda.size() == nlp.NumConstraints() &&
          before.z_lower.size() == before.w.size() && before.z_upper.size() == before.w.size()) {
        warm.lambda = before.lambda;
        warm.z_lower = Eigen::VectorXd::Zero(n);
        warm.z_upper = Eigen::VectorXd::Zero(n);
        warm.z_lower.tail(other) = before.z_lower.tail(other);
        warm.z_upper.tail(other) = before.z_upper.tail(other);
        for (int k = 0; k < f.map->NumFree(); ++k) {
          const int r = start_position[f.map->free[k]];
          if (r >= 0) {
            warm.z_lower[k] = before.z_lower[r];
            warm.z_upper[k] = before.z_upper[r];
          }
        }
      }
    }
  }
  const EstimationSpec& spec = problem.estimation;
  IpoptOptions ipopt = spec.ipopt;
  CeresOptions ceres = spec.ceres;
  if (s.options.verbose) {
    ipopt.print_level = std::max(ipopt.print_level, 5);
    ceres.print_progress = true;
  }
  s.Progress("  solving with " + spec.solver + " (" + std::to_string(nlp.NumVariables()) +
             " variables, " + std::to_string(nlp.NumConstraints()) + " constraints, " +
             std::to_string(nlp.NumResiduals()) + " residuals)" +
             (same_structure ? ", warm-started"
              : warm_primal  ? ", primal warm start"
                             : ""));
  t = Timer();
  const double cpu_start = util::ThreadUserSeconds();
  {
    Heartbeat heartbeat(s.options.progress, s.options.progress_interval_seconds, spec.solver);
    // The caller's limit on its clock; the problem's on the wall clock (the smaller wins when
    // both are wall time).
    const bool cpu = s.options.budget_clock == FitOptions::BudgetClock::kThreadUser;
    double max_seconds = cpu ? 0.0 : s.options.max_solve_seconds;
    const double max_cpu_seconds = cpu ? s.options.max_solve_seconds : 0.0;
    const double problem_limit = s.problem.estimation.max_seconds;
    if (problem_limit > 0.0 && (max_seconds <= 0.0 || problem_limit < max_seconds)) {
      max_seconds = problem_limit;
    }
    const IterationCallback& own = s.options.iteration_callback;
    auto record = [&heartbeat, &own, max_seconds, max_cpu_seconds](const IterationSummary& it) {
      return heartbeat.Record(it, max_seconds, max_cpu_seconds) && (!own || own(it));
    };
    ipopt.callback = record;
    ceres.callback = record;
    result.solver_result = spec.solver == "ceres"
                               ? SolveWithCeres(nlp, ceres, warm_primal ? &warm : nullptr)
                               : SolveWithIpopt(nlp, ipopt, warm_primal ? &warm : nullptr);
  }
  result.seconds.emplace_back("solve", t.Seconds());
  result.solve_thread_user_seconds = util::ThreadUserSeconds() - cpu_start;
  s.Progress("  " + result.solver_result.BriefReport());
  s.Complete(&result);
  return result;
}

FitResult FitSession::ResultOf(SolverResult solved) {
  State& s = *state_;
  if (s.stale) s.Formulate();
  const Nlp& nlp = *s.formulation.nlp;
  if (solved.w.size() != nlp.NumVariables()) {
    throw std::invalid_argument("FitSession::ResultOf: a solver point of " +
                                std::to_string(solved.w.size()) + " variables, expected " +
                                std::to_string(nlp.NumVariables()) + " (problem '" +
                                s.problem.name + "')");
  }
  FitResult result;
  s.Describe(&result);
  result.solver_result = std::move(solved);
  s.Complete(&result);
  return result;
}

FitResult Fit(const Problem& problem, const std::vector<SplitData>& splits,
              const FitOptions& options) {
  FitSession session(problem, splits, options);
  return session.Solve();
}

}  // namespace graybox::estimators
