// Problem files: [estimation] (the formulation, solver and integrator options) and [metrics]
// (problem_file.h, docs/problem-format.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "graybox/estimators/problem/problem_file.h"
#include "graybox/models/block.h"
#include "problem/problem_file_internal.h"

namespace graybox::estimators::internal {

// ---- [estimation] -------------------------------------------------------------------------------

std::string NumberText(const toml::node& n) {
  if (const auto* i = n.as_integer()) return std::to_string(i->get());
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", n.as_floating_point()->get());
  return buf;
}

// Checks pass-through Ipopt options against Ipopt's registered options (SolveWithIpopt rejects
// unknown keys and invalid values before iterating) on a one-variable NLP with no iteration.
void CheckIpoptOptions(const Section& s, const IpoptOptions& options) {
  Nlp nlp(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, -1.0),
          Eigen::VectorXd::Constant(1, 1.0));
  IpoptOptions probe = options;
  probe.max_iterations = 0;
  probe.print_level = 0;
  probe.pass_through.erase("output_file");  // would create a file
  probe.pass_through.erase("print_level");
  try {
    SolveWithIpopt(nlp, probe);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    for (const auto& [key, value] : options.pass_through) {
      if (what.find("'" + key + "'") == std::string::npos) continue;
      // Ipopt's own names did not come close: try the IpoptOptions fields of this table.
      const std::string hint =
          what.find("did you mean") == std::string::npos
              ? Suggestion(key, {"max_iterations", "tolerance", "exact_hessian", "print_level"})
              : "";
      s.Fail(key, what + hint);
    }
    s.Fail("", what);
  }
}

void ParseIpopt(const Section& s, IpoptOptions* options) {
  for (auto&& [k, v] : s.table()) {
    const std::string key(k.str());
    if (key == "max_iterations" || key == "max_iter") {
      options->max_iterations = static_cast<int>(*s.Integer(key, 0, 1000000000));
    } else if (key == "tolerance" || key == "tol") {
      options->tolerance = *s.PositiveNumber(key);
    } else if (key == "exact_hessian") {
      options->exact_hessian = *s.Bool(key);
    } else if (key == "print_level") {
      options->print_level = static_cast<int>(*s.Integer(key, 0, 12));
    } else if (v.is_string()) {
      options->pass_through[key] = v.as_string()->get();
    } else if (v.is_number()) {
      s.NumberOf(v, key);
      options->pass_through[key] = NumberText(v);
    } else if (v.is_boolean()) {
      options->pass_through[key] = v.as_boolean()->get() ? "yes" : "no";
    } else {
      s.Fail(key, "Ipopt option '" + key + "': expected a number or a word, got " + ValueText(v));
    }
  }
  try {
    options->Validate();
  } catch (const std::invalid_argument& e) {
    s.Fail("", e.what());
  }
  CheckIpoptOptions(s, *options);
}

void ParseIntegrator(const Section& s, IntegratorOptions* options) {
  s.Allow({"method", "relative_tolerance", "absolute_tolerance", "max_steps", "max_order",
           "linear_solver"});
  if (auto v = s.Choice("method", {"fixed_step", "cvodes"})) {
    options->method = ParseIntegrationMethod(*v);
  }
  CvodesOptions& c = options->cvodes;
  if (auto v = s.PositiveNumber("relative_tolerance")) c.relative_tolerance = *v;
  if (auto v = s.PositiveNumber("absolute_tolerance")) c.absolute_tolerance = *v;
  if (auto v = s.Integer("max_steps", 1, 1000000000)) c.max_steps = *v;
  if (auto v = s.Integer("max_order", 1, 5)) c.max_order = static_cast<int>(*v);
  if (auto v = s.Choice("linear_solver", {"dense", "klu"})) {
    c.linear_solver =
        *v == "dense" ? CvodesOptions::LinearSolver::kDense : CvodesOptions::LinearSolver::kKlu;
  }
  try {
    options->Validate();
  } catch (const std::invalid_argument& e) {
    s.Fail("", e.what());
  }
}

void ParseCeres(const Section& s, CeresOptions* options) {
  s.Allow({"max_iterations", "function_tolerance", "gradient_tolerance", "parameter_tolerance",
           "loss", "loss_scale", "num_threads", "print_progress"});
  if (auto v = s.Integer("max_iterations", 0, 1000000000)) options->max_iterations = *v;
  if (auto v = s.PositiveNumber("function_tolerance")) options->function_tolerance = *v;
  if (auto v = s.PositiveNumber("gradient_tolerance")) options->gradient_tolerance = *v;
  if (auto v = s.PositiveNumber("parameter_tolerance")) options->parameter_tolerance = *v;
  if (auto v = s.Choice("loss", {"trivial", "huber", "cauchy", "soft_l1", "arctan"})) {
    options->loss = *v;
  }
  if (auto v = s.PositiveNumber("loss_scale")) options->loss_scale = *v;
  if (auto v = s.Integer("num_threads", 1, 256)) options->num_threads = *v;
  if (auto v = s.Bool("print_progress")) options->print_progress = *v;
  try {
    options->Validate();
  } catch (const std::invalid_argument& e) {
    s.Fail("", e.what());
  }
}

std::map<std::string, double> ParseWeights(const Section& parent, const std::string& key,
                                           const std::vector<std::string>& channels,
                                           const char* kind) {
  std::map<std::string, double> weights;
  auto t = parent.Sub(key);
  if (!t) return weights;
  for (auto&& [k, v] : t->table()) {
    const std::string name(k.str());
    if (std::find(channels.begin(), channels.end(), name) == channels.end()) {
      t->Fail(name, "'" + name + "' is not " + kind + Suggestion(name, channels) + " (" +
                        Quoted(channels) + ")");
    }
    const double w = t->NumberOf(v, name);
    if (!(w > 0.0)) t->Fail(name, "weight of '" + name + "': expected > 0, got " + Format(w));
    weights[name] = w;
  }
  return weights;
}

// The index of the state whose derivative is exactly state `i` (dq/dt = qd makes q the
// "integral" of qd), or -1.
int IntegralOf(const models::StateSpaceModel& m, int i) {
  const auto& x = m.dynamics.InputSymbols(m.dynamics.InputIndex("x"));
  const auto& f = m.dynamics.OutputExprs(0);
  for (int j = 0; j < m.NumStates(); ++j) {
    if (f[j].IsSame(x[i])) return j;
  }
  return -1;
}

StateSourceDefect ResolveStateSources(const models::StateSpaceModel& m, EquationErrorSpec* spec,
                                      bool states_only) {
  std::vector<std::string> states, inputs, outputs;
  for (const auto& s : m.states) states.push_back(s.name);
  for (const auto& s : m.inputs) inputs.push_back(s.name);
  for (const auto& s : m.outputs) outputs.push_back(s.name);
  if (spec->residual_states.empty()) {
    // Kinematic states (their derivative is another state) give no equation to fit.
    const auto& f = m.dynamics.OutputExprs(0);
    const auto& x = m.dynamics.InputSymbols(m.dynamics.InputIndex("x"));
    for (int i = 0; i < m.NumStates(); ++i) {
      bool kinematic = false;
      for (int j = 0; j < m.NumStates(); ++j) kinematic = kinematic || f[i].IsSame(x[j]);
      if (!kinematic && !spec->from_inputs.count(states[i])) {
        spec->residual_states.push_back(states[i]);
      }
    }
  }
  if (spec->residual_states.empty() && !states_only) {
    return {"residual_states",
            "no state equation to fit: every state's derivative is another state"};
  }
  if (spec->form == "inverse" && !states_only) {
    if (spec->inverse_inputs.empty() && inputs.size() == 1 && spec->residual_states.size() == 1) {
      spec->inverse_inputs = inputs;
    }
    if (spec->inverse_inputs.size() != spec->residual_states.size()) {
      return {"inverse_inputs",
              "the inverse form solves for one input per residual state: expected " +
                  std::to_string(spec->residual_states.size()) + " inverse_inputs, got " +
                  std::to_string(spec->inverse_inputs.size())};
    }
  }
  // Every state must come from data: measured (an output of the same name), differentiated, or
  // inferred from a kinematic equation.
  for (int i = 0; i < m.NumStates(); ++i) {
    const std::string& s = states[i];
    if (std::find(outputs.begin(), outputs.end(), s) != outputs.end()) continue;
    if (spec->differentiate.count(s) || spec->from_inputs.count(s)) continue;
    const int j = IntegralOf(m, i);
    if (j >= 0) {
      spec->differentiate[s] = states[j];
      continue;
    }
    return {"differentiate",
            "state '" + s +
                "' is neither a measured output nor the derivative of a measured signal: equation "
                "error and node_guess = 'data' need every state from data (add it to "
                "'differentiate' or measure it as an output)"};
  }
  return {};
}

// `states_only`: parsed for node_guess = 'data' of another method (only the state sources matter).
void ParseEquationError(const Section& e, const Problem& problem, EquationErrorSpec* spec,
                        bool states_only) {
  e.Allow({"form", "residual_states", "inverse_inputs", "differentiate", "differentiation",
           "fft_cutoff_bin", "lowpass_hz", "lowpass_order", "lowpass_padding", "skip_samples",
           "decimate", "decimation", "weights", "input_timing"});
  const models::StateSpaceModel& m = problem.built;
  std::vector<std::string> states, inputs, outputs;
  for (const auto& s : m.states) states.push_back(s.name);
  for (const auto& s : m.inputs) inputs.push_back(s.name);
  for (const auto& s : m.outputs) outputs.push_back(s.name);
  spec->form = e.Choice("form", {"inverse", "state_derivative"}).value_or("inverse");
  auto check_names = [&](const std::string& key, const std::vector<std::string>& names,
                         const std::vector<std::string>& known, const char* kind) {
    for (const auto& n : names) {
      if (std::find(known.begin(), known.end(), n) == known.end()) {
        e.Fail(key, "'" + key + "': '" + n + "' is not a model " + kind + Suggestion(n, known) +
                        " (" + Quoted(known) + ")");
      }
    }
  };
  spec->residual_states = e.Strings("residual_states");
  check_names("residual_states", spec->residual_states, states, "state");
  if (spec->form == "inverse" && !states_only) {
    spec->inverse_inputs = e.Strings("inverse_inputs");
    check_names("inverse_inputs", spec->inverse_inputs, inputs, "input");
  } else if (e.Has("inverse_inputs") && !states_only) {
    e.Fail("inverse_inputs", "'inverse_inputs' applies to form = 'inverse' only");
  }
  if (auto d = e.Sub("differentiate")) {
    for (auto&& [k, v] : d->table()) {
      const std::string state(k.str());
      if (std::find(states.begin(), states.end(), state) == states.end()) {
        d->Fail(state, "'" + state + "' is not a model state" + Suggestion(state, states));
      }
      if (!v.is_string()) {
        d->Fail(state, "'" + state +
                           "': expected the name of the signal it is the derivative of, "
                           "got " +
                           ValueText(v));
      }
      const std::string source = v.as_string()->get();
      std::vector<std::string> known = states;
      known.insert(known.end(), outputs.begin(), outputs.end());
      if (std::find(known.begin(), known.end(), source) == known.end() || source == state) {
        d->Fail(state, "'" + state + "' = '" + source +
                           "': expected another state or a measured output" +
                           Suggestion(source, known));
      }
      spec->differentiate[state] = source;
    }
  }
  for (const auto& [input, state] : problem.first_order_holds) {
    spec->from_inputs[state] = m.inputs[input].name;
  }
  // Defaults a file may leave out: residual states, inverse inputs, derivative sources.
  const StateSourceDefect defect = ResolveStateSources(m, spec, states_only);
  if (!defect.key.empty()) e.Fail(defect.key, defect.message);
  // No cycles in the derivative chains.
  for (const auto& [state, source] : spec->differentiate) {
    std::string cur = source;
    for (std::size_t hop = 0; hop <= states.size() && spec->differentiate.count(cur); ++hop) {
      cur = spec->differentiate.at(cur);
      if (cur == state)
        e.Fail("differentiate", "the derivative chain of '" + state + "' is a cycle");
    }
  }
  if (auto v = e.Number("lowpass_hz")) {
    if (*v < 0.0)
      e.Fail("lowpass_hz", "expected a cut-off >= 0 Hz (0: no filter), got " + Format(*v));
    spec->lowpass_hz = *v;
  }
  spec->differentiation = e.Choice("differentiation", {"central", "fft"}).value_or("central");
  if (auto v = e.Integer("fft_cutoff_bin", 1, 100000000)) {
    if (spec->differentiation != "fft") {
      e.Fail("fft_cutoff_bin",
             "'fft_cutoff_bin' applies to differentiation = 'fft' only, got "
             "differentiation = '" +
                 spec->differentiation + "'");
    }
    spec->fft_cutoff_bin = static_cast<int>(*v);
  }
  if (spec->differentiation == "fft" && spec->lowpass_hz > 0.0) {
    e.Fail("lowpass_hz",
           "differentiation = 'fft' filters with its own ideal low-pass "
           "(fft_cutoff_bin): expected lowpass_hz = 0, got " +
               Format(spec->lowpass_hz));
  }
  if (auto v = e.Integer("lowpass_order", 1, 20)) spec->lowpass_order = static_cast<int>(*v);
  if (auto v = e.Integer("lowpass_padding", -1, 100000))
    spec->lowpass_padding = static_cast<int>(*v);
  if (auto v = e.Integer("skip_samples", 0, 1000000000)) spec->skip_samples = static_cast<int>(*v);
  if (auto v = e.Integer("decimate", 1, 1000)) spec->decimate = static_cast<int>(*v);
  spec->decimation = e.Choice("decimation", {"auto", "parallel", "signals"}).value_or("auto");
  spec->input_timing = e.Choice("input_timing", {"sampled", "held"}).value_or("sampled");
  const std::vector<std::string>& channels =
      spec->form == "inverse" ? spec->inverse_inputs : spec->residual_states;
  spec->weights = ParseWeights(e, "weights", channels, "a residual channel");
}

void ParseNStep(const Section& s, const models::StateSpaceModel& m, NStepLossOptions* options) {
  s.Allow({"steps", "stride", "first_start", "channels", "weights", "num_threads"});
  if (auto v = s.Integer("steps", 1, 100000)) options->steps = static_cast<int>(*v);
  if (auto v = s.Integer("stride", 1, 1000000)) options->stride = static_cast<int>(*v);
  if (auto v = s.Integer("first_start", 0, 100000000)) options->first_start = static_cast<int>(*v);
  if (auto v = s.Integer("num_threads", 1, 256)) options->num_threads = static_cast<int>(*v);
  std::vector<std::string> states;
  for (const auto& x : m.states) states.push_back(x.name);
  for (const std::string& name : s.Strings("channels")) {
    const auto it = std::find(states.begin(), states.end(), name);
    if (it == states.end()) {
      s.Fail("channels", "'" + name + "' is not a model state" + Suggestion(name, states) + " (" +
                             Quoted(states) + ")");
    }
    options->channels.push_back(static_cast<int>(it - states.begin()));
  }
  const std::map<std::string, double> weights = ParseWeights(s, "weights", states, "a model state");
  if (!weights.empty()) {
    // One weight per scored channel; 0 for the channels not given (1 / std, NStepLossOptions).
    std::vector<int> scored = options->channels;
    if (scored.empty()) {
      for (int i = 0; i < m.NumStates(); ++i) scored.push_back(i);
    }
    options->weights = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(scored.size()));
    for (const auto& [name, w] : weights) {
      const int i =
          static_cast<int>(std::find(states.begin(), states.end(), name) - states.begin());
      const auto at = std::find(scored.begin(), scored.end(), i);
      if (at == scored.end()) {
        s.Fail("weights", "weight of '" + name + "': the state is not among 'channels'");
      }
      options->weights[at - scored.begin()] = w;
    }
  }
}

RegularizationTerm ParseRegularization(const Section& s, const models::StateSpaceModel& m) {
  s.Allow({"name", "parameters", "weight", "toward"});
  RegularizationTerm term;
  term.name = s.String("name").value_or(s.path());
  if (!s.Has("weight")) s.Fail("", "missing key 'weight': expected a number >= 0 (lambda)");
  term.weight = *s.Number("weight");
  if (term.weight < 0.0) {
    s.Fail("weight", "'weight': expected a number >= 0, got " + Format(term.weight));
  }
  if (auto t = s.Choice("toward", {"zero", "initial"})) {
    term.reference = ParseRegularizationReference(*t);
  }
  const std::vector<std::string> patterns = s.Strings("parameters");
  if (patterns.empty()) {
    s.Fail("parameters", "expected a non-empty array of parameter names or patterns ('net.*')");
  }
  std::vector<std::string> names;
  for (const auto& p : m.parameters) names.push_back(p.name);
  for (const std::string& pattern : patterns) {
    const bool glob = pattern.find('*') != std::string::npos;
    int matched = 0;
    for (std::size_t i = 0; i < m.parameters.size(); ++i) {
      const models::ModelParameter& par = m.parameters[i];
      if (glob ? !GlobMatch(pattern, par.name) : pattern != par.name) continue;
      if (!par.free) {
        if (glob) continue;  // a pattern selects the free parameters it matches
        s.Fail("parameters", "parameter '" + pattern +
                                 "' is fixed: expected a free parameter (a fixed one has nothing "
                                 "to regularise)");
      }
      if (std::find(term.parameters.begin(), term.parameters.end(), static_cast<int>(i)) ==
          term.parameters.end()) {
        term.parameters.push_back(static_cast<int>(i));
      }
      ++matched;
    }
    if (matched == 0) {
      s.Fail("parameters",
             glob ? "pattern '" + pattern + "' matches no free parameter"
                  : "'" + pattern + "' is not a model parameter" + Suggestion(pattern, names));
    }
  }
  return term;
}

void ParseEstimation(const Section& root, Problem* problem) {
  auto est = root.Sub("estimation");
  if (!est) root.Fail("", "missing table [estimation]: expected at least method = '...'");
  const Section& e = *est;
  e.Allow({"method", "solver", "seed", "max_seconds", "scheme", "substeps", "newton_iterations",
           "integrator", "multiple_shooting", "collocation", "equation_error", "n_step", "ipopt",
           "ceres", "regularization"});
  EstimationSpec& spec = problem->estimation;
  spec.where = e.Where();
  if (!e.Has("method")) e.Fail("", "missing key 'method'");
  spec.method = *e.Choice("method", {"multiple_shooting", "single_shooting", "collocation",
                                     "equation_error", "n_step"});
  const bool least_squares = spec.method == "equation_error" || spec.method == "n_step";
  spec.solver = e.Choice("solver", {"ipopt", "ceres"}).value_or(least_squares ? "ceres" : "ipopt");
  spec.seed = static_cast<unsigned>(e.Integer("seed", 0, 4294967295L).value_or(1));
  spec.max_seconds = e.PositiveNumber("max_seconds").value_or(0.0);
  if (auto v = e.Choice("scheme", {"rk4", "backward_euler", "trapezoidal", "radau_iia"})) {
    spec.step.scheme = ParseStepScheme(*v);
  }
  spec.step.substeps = static_cast<int>(e.Integer("substeps", 1, 1000).value_or(1));
  if (auto v = e.Integer("newton_iterations", 1, 100)) {
    if (spec.step.scheme == StepScheme::kRk4) {
      e.Fail("newton_iterations",
             "'newton_iterations' applies to the implicit schemes only: expected scheme = "
             "'backward_euler', 'trapezoidal' or 'radau_iia', got scheme = 'rk4'");
    }
    spec.step.newton_iterations = static_cast<int>(*v);
  }
  spec.integrator.fixed_step = spec.step;
  if (auto in = e.Sub("integrator")) ParseIntegrator(*in, &spec.integrator);
  if (spec.method == "collocation" && spec.solver != "ipopt") {
    e.Fail("solver", "collocation has equality constraints: expected solver = 'ipopt', got '" +
                         spec.solver + "'");
  }
  std::vector<std::string> outputs;
  for (const auto& s : problem->built.outputs) outputs.push_back(s.name);
  spec.multiple_shooting.step = spec.step;
  spec.multiple_shooting.continuity_as_constraints = spec.solver == "ipopt";
  if (auto ms = e.Sub("multiple_shooting")) {
    ms->Allow({"segment_length", "continuity", "continuity_weight", "weights", "fix_initial_state",
               "node_guess"});
    if (auto v = ms->Integer("segment_length", 1, 1000000)) {
      spec.multiple_shooting.segment_length = static_cast<int>(*v);
    }
    if (auto c = ms->Choice("continuity", {"constraints", "residuals"})) {
      if (*c == "constraints" && spec.solver == "ceres") {
        ms->Fail("continuity",
                 "Ceres handles no constraints: expected continuity = 'residuals' "
                 "with solver = 'ceres', got 'constraints'");
      }
      spec.multiple_shooting.continuity_as_constraints = *c == "constraints";
    }
    if (auto v = ms->PositiveNumber("continuity_weight")) {
      spec.multiple_shooting.continuity_weight = *v;
    }
    spec.output_weights = ParseWeights(*ms, "weights", outputs, "a model output");
    spec.multiple_shooting.fix_initial_state = ms->Bool("fix_initial_state").value_or(false);
    spec.node_guess = ms->Choice("node_guess", {"simulation", "data"}).value_or("simulation");
  }
  if (auto c = e.Sub("collocation")) {
    c->Allow({"scheme", "degree", "weights"});
    if (auto s = c->Choice("scheme", {"radau", "legendre"})) {
      spec.collocation.scheme =
          *s == "radau" ? CollocationScheme::kRadau : CollocationScheme::kLegendre;
    }
    if (auto d = c->Integer("degree", 1, 9)) spec.collocation.degree = static_cast<int>(*d);
    if (spec.method == "collocation") {
      spec.output_weights = ParseWeights(*c, "weights", outputs, "a model output");
    }
  }
  const bool states_only = spec.method != "equation_error";
  if (auto ee = e.Sub("equation_error")) {
    ParseEquationError(*ee, *problem, &spec.equation_error, states_only);
  } else if (!states_only || spec.node_guess == "data" || spec.method == "n_step") {
    const toml::table empty;
    ParseEquationError(Section(e.file(), empty, e.Join("equation_error")), *problem,
                       &spec.equation_error, states_only);
  }
  spec.n_step.integrator = spec.integrator;
  if (auto n = e.Sub("n_step")) ParseNStep(*n, problem->built, &spec.n_step);
  if (auto i = e.Sub("ipopt")) ParseIpopt(*i, &spec.ipopt);
  if (auto c = e.Sub("ceres")) ParseCeres(*c, &spec.ceres);
  for (const Section& r : e.SubArray("regularization")) {
    spec.regularization.terms.push_back(ParseRegularization(r, problem->built));
  }
}

// The default states of the N-step NRMS: those with a model output of the same name, else all.
void DefaultNStepChannels(const models::StateSpaceModel& m, MetricsSpec* spec) {
  for (int i = 0; i < m.NumStates(); ++i) {
    const std::string& name = m.states[static_cast<std::size_t>(i)].name;
    const bool measured = std::any_of(m.outputs.begin(), m.outputs.end(),
                                      [&](const auto& output) { return output.name == name; });
    if (measured) spec->n_step_channel_indices.push_back(i);
  }
  if (spec->n_step_channel_indices.empty()) {
    for (int i = 0; i < m.NumStates(); ++i) spec->n_step_channel_indices.push_back(i);
  }
  for (int i : spec->n_step_channel_indices) {
    spec->n_step_channels.push_back(m.states[static_cast<std::size_t>(i)].name);
  }
}

// `n_step_channels`: state names, each located at its own array element in messages.
void ParseNStepChannels(const Section& s, const models::StateSpaceModel& m, MetricsSpec* spec) {
  const std::string key = "n_step_channels";
  const std::vector<std::string> names = s.Strings(key);  // checks the types
  if (names.empty()) {
    s.Fail(key, "'" + key + "': expected at least one model state, got an empty list");
  }
  std::vector<std::string> states;
  for (const auto& x : m.states) states.push_back(x.name);
  const toml::array& elements = *s.Get(key)->as_array();
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    const SourceLocation where = s.Location(elements.get(i)->source());
    const auto it = std::find(states.begin(), states.end(), name);
    if (it == states.end()) {
      throw ProblemFileError(where, "'" + key + "[" + std::to_string(i) + "]': '" + name +
                                        "' is not a model state" + Suggestion(name, states) +
                                        " (model states: " + Quoted(states) + ")");
    }
    const int index = static_cast<int>(it - states.begin());
    if (std::find(spec->n_step_channel_indices.begin(), spec->n_step_channel_indices.end(),
                  index) != spec->n_step_channel_indices.end()) {
      throw ProblemFileError(where, "'" + key + "[" + std::to_string(i) + "]': expected distinct " +
                                        "states, got '" + name + "' twice");
    }
    spec->n_step_channel_indices.push_back(index);
    spec->n_step_channels.push_back(name);
  }
  spec->n_step_channels_given = true;
}

void ParseMetrics(const Section& top, Problem* problem) {
  MetricsSpec& spec = problem->metrics;
  if (auto m = top.Sub("metrics")) {
    m->Allow({"n_step", "n_step_stride", "n_step_channels"});
    spec.where = m->Where();
    spec.n_step = static_cast<int>(m->Integer("n_step", 0, 1000000).value_or(0));
    spec.n_step_stride = static_cast<int>(m->Integer("n_step_stride", 1, 1000000).value_or(1));
    if (m->Has("n_step_channels")) {
      if (spec.n_step == 0) {
        m->Fail("n_step_channels",
                "'n_step_channels' selects the states of the N-step NRMS, which is off: expected "
                "'n_step' > 0 in [metrics], got n_step = 0");
      }
      ParseNStepChannels(*m, problem->built, &spec);
    }
  }
  if (!spec.n_step_channels_given) DefaultNStepChannels(problem->built, &spec);
}

}  // namespace graybox::estimators::internal
