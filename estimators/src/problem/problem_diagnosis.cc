// [diagnosis]: what the gap diagnosis proposes and where (problem_file.h DiagnosisSpec). The
// signals are checked against the built model here; the effect names by the diagnosis.
#include <string>
#include <vector>

#include "problem_file_internal.h"

namespace graybox::estimators::internal {
namespace {

// The names of `built`'s signals that satisfy `keep`, for suggestions.
template <typename Keep>
std::vector<std::string> SignalNames(const models::StateSpaceModel& built, Keep keep) {
  std::vector<std::string> names;
  for (const auto& s : built.signals) {
    if (keep(s)) names.push_back(s.info.name);
  }
  return names;
}

const models::SignalDescription* FindSignal(const models::StateSpaceModel& built,
                                            const std::string& name) {
  for (const auto& s : built.signals) {
    if (s.info.name == name) return &s;
  }
  return nullptr;
}

bool IsState(const models::SignalDescription& s) {
  return s.source == models::SignalSource::kState;
}

// A state signal named by `key` of `t`: an error naming the key, what a state is, and the closest
// state when it is another signal or unknown.
std::string StateSignal(const Section& t, const std::string& key,
                        const models::StateSpaceModel& built, const std::string& what) {
  const std::string name = t.RequiredString(key);
  const auto* s = FindSignal(built, name);
  const auto states = SignalNames(built, IsState);
  if (!s) {
    t.Fail(key, "'" + key + "': expected " + what + " (a state signal of the model), got the " +
                    "unknown signal '" + name + "'" + Suggestion(name, states) +
                    " (states: " + Quoted(states) + ")");
  }
  if (!IsState(*s)) {
    t.Fail(key, "'" + key + "': expected " + what + " (a state signal of the model), got '" + name +
                    "', which a block output writes" + Suggestion(name, states) +
                    " (states: " + Quoted(states) + ")");
  }
  return name;
}

// A signal that blocks can add to: a model input or a block output, not a state.
std::string WritableSignal(const Section& t, const std::string& key,
                           const models::StateSpaceModel& built) {
  const std::string name = t.RequiredString(key);
  const auto* s = FindSignal(built, name);
  const auto writable = SignalNames(built, [](const auto& d) { return !IsState(d); });
  if (!s || IsState(*s)) {
    t.Fail(key, "'" + key + "': expected the force signal the candidates add to (a model input " +
                    "or a block output, not a state), got " +
                    (s ? "the state '" + name + "'" : "the unknown signal '" + name + "'") +
                    Suggestion(name, writable));
  }
  return name;
}

// Each element of the string array `key` of `t` is a signal of `built` (not a state); records
// the places.
std::vector<std::string> CommandSignals(const Section& t, const std::string& key,
                                        const models::StateSpaceModel& built) {
  const std::vector<std::string> names = t.Strings(key);
  const auto writable = SignalNames(built, [](const auto& d) { return !IsState(d); });
  const toml::array* a = t.Get(key)->as_array();
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto* s = FindSignal(built, names[i]);
    if (!s || IsState(*s)) {
      throw ProblemFileError(
          t.Location(a->get(i)->source()),
          "'" + key + "[" + std::to_string(i) + "]': expected an actuator command (a model " +
              "input or a block output, not a state), got " +
              (s ? "the state '" + names[i] + "'" : "the unknown signal '" + names[i] + "'") +
              Suggestion(names[i], writable));
    }
  }
  return names;
}

// A string array whose elements' places are recorded as "<key>[i]".
std::vector<std::string> NamedList(const Section& t, const std::string& key, DiagnosisSpec* spec) {
  const std::vector<std::string> names = t.Strings(key);
  if (!t.Has(key)) return names;
  spec->where[key] = t.Where(key);
  const toml::array* a = t.Get(key)->as_array();
  for (std::size_t i = 0; i < names.size(); ++i) {
    spec->where[key + "[" + std::to_string(i) + "]"] = t.Location(a->get(i)->source());
    for (std::size_t j = 0; j < i; ++j) {
      if (names[j] == names[i]) {
        throw ProblemFileError(t.Location(a->get(i)->source()),
                               "'" + key + "[" + std::to_string(i) + "]': '" + names[i] +
                                   "' is listed twice (also at index " + std::to_string(j) + ")");
      }
    }
  }
  return names;
}

}  // namespace

void ParseDiagnosis(const Section& top, Problem* problem) {
  DiagnosisSpec& spec = problem->diagnosis;
  const auto d = top.Sub("diagnosis");
  if (!d) return;
  d->Allow({"effects", "add_effects", "remove_effects", "ripple_periods", "lugre_presliding",
            "sensors", "metadata_axes", "axes"});
  const models::StateSpaceModel& built = problem->built;
  spec.where[""] = d->Where();
  spec.effects_given = d->Has("effects");
  spec.effects = NamedList(*d, "effects", &spec);
  spec.add_effects = NamedList(*d, "add_effects", &spec);
  spec.remove_effects = NamedList(*d, "remove_effects", &spec);
  if (d->Has("ripple_periods")) {
    spec.where["ripple_periods"] = d->Where("ripple_periods");
    const toml::array* a = d->Get("ripple_periods")->as_array();
    if (!a) {
      d->Fail("ripple_periods",
              "'ripple_periods': expected an array of periods > 0 [m or rad], "
              "got " +
                  ValueText(*d->Get("ripple_periods")));
    }
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::string k = "ripple_periods[" + std::to_string(i) + "]";
      const double p = d->NumberOf(*a->get(i), k);
      if (!(p > 0.0)) {
        throw ProblemFileError(d->Location(a->get(i)->source()),
                               "'" + k + "': expected a period > 0 [m or rad], got " + Format(p));
      }
      spec.ripple_periods.push_back(p);
    }
  }
  spec.lugre_presliding = d->Bool("lugre_presliding").value_or(false);
  spec.metadata_axes = d->Bool("metadata_axes").value_or(true);
  if (d->Has("sensors")) {
    spec.sensors_given = true;
    spec.sensors = NamedList(*d, "sensors", &spec);
    std::vector<std::string> channels;
    for (const auto& o : built.outputs) channels.push_back(o.name);
    for (std::size_t i = 0; i < spec.sensors.size(); ++i) {
      const std::string& name = spec.sensors[i];
      if (std::find(channels.begin(), channels.end(), name) == channels.end()) {
        throw ProblemFileError(
            spec.where["sensors[" + std::to_string(i) + "]"],
            "'sensors[" + std::to_string(i) + "]': expected an output channel of the model, got '" +
                name + "'" + Suggestion(name, channels) + " (outputs: " + Quoted(channels) + ")");
      }
    }
  }
  for (const Section& a : d->SubArray("axes")) {
    a.Allow({"velocity", "force", "position", "motion", "sign", "inputs"});
    DiagnosisAxisSpec axis;
    axis.where = a.Where();
    axis.velocity = StateSignal(a, "velocity", built, "the axis velocity");
    for (const auto& other : spec.axes) {
      if (other.velocity == axis.velocity) {
        a.Fail("velocity", "'velocity': the axis on '" + axis.velocity + "' is named twice (also " +
                               other.where.ToString() + ")");
      }
    }
    axis.force = WritableSignal(a, "force", built);
    if (a.Has("position")) {
      axis.position = StateSignal(a, "position", built, "the axis position");
      if (axis.position == axis.velocity) {
        a.Fail("position", "'position': expected a state other than the velocity '" +
                               axis.velocity + "', got the same");
      }
    }
    axis.motion = a.Choice("motion", {"linear", "rotary"}).value_or("");
    if (axis.motion.empty()) {
      const std::string unit = FindSignal(built, axis.velocity)->info.unit;
      if (unit != "m/s" && unit != "rad/s") {
        a.Fail("", "axis on '" + axis.velocity + "': its unit '" + unit +
                       "' is neither m/s nor rad/s, so the candidates' units are not known: "
                       "expected 'motion' = \"linear\" (m, m/s, N) or \"rotary\" (rad, rad/s, "
                       "N m), got none");
      }
    }
    axis.sign = a.Choice("sign", {"subtract", "add"}).value_or("");
    axis.inputs_given = a.Has("inputs");
    if (axis.inputs_given) axis.inputs = CommandSignals(a, "inputs", built);
    spec.axes.push_back(std::move(axis));
  }
  if (!spec.metadata_axes && spec.axes.empty()) {
    d->Fail("metadata_axes",
            "'metadata_axes' = false leaves no axis: expected at least one [[diagnosis.axes]] "
            "entry with it, got none");
  }
}

}  // namespace graybox::estimators::internal
