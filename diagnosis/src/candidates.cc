#include "graybox/diagnosis/candidates.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "graybox/models/friction.h"

namespace graybox::diagnosis {
namespace {

using models::BlockOptions;
using models::SignalRole;
using models::SignalSource;

const std::vector<std::string>& KnownEffects() {
  static const std::vector<std::string> known = {"coulomb",    "asymmetric_friction", "stribeck",
                                                 "viscous",    "power_law_viscous",   "presliding",
                                                 "input_delay"};
  return known;
}

// The friction-family candidates: effect, detail, block type.
struct FrictionKind {
  const char* effect;
  const char* detail;
  const char* type;
};
constexpr FrictionKind kFrictionKinds[] = {
    {"coulomb", "friction.coulomb", "friction.coulomb"},
    {"asymmetric_friction", "friction.offset", "friction.offset"},
    {"stribeck", "friction.stribeck", "friction.stribeck"},
    {"viscous", "friction.viscous", "friction.viscous"},
    {"power_law_viscous", "friction.power_viscous", "friction.power_viscous"},
    {"presliding", "dahl", "friction.dahl"},
};

BlockOptions Motion(bool prismatic) {
  BlockOptions o;
  o.words["motion"] = prismatic ? "prismatic" : "rotational";
  return o;
}

// The options a candidate of `type` is created with: the axis' motion, and for the Coulomb block
// its smoothing steepness as a fixed setting (kDefaultFrictionSteepness) rather than a parameter.
BlockOptions CandidateOptionsFor(const std::string& type, bool prismatic) {
  BlockOptions o = Motion(prismatic);
  if (type == "friction.coulomb") o.numbers["steepness"] = {models::kDefaultFrictionSteepness};
  return o;
}

// Local parameter names and units of instance `instance` in the built model.
std::set<std::pair<std::string, std::string>> InstanceSignature(
    const models::StateSpaceModel& built, const std::string& instance) {
  std::set<std::pair<std::string, std::string>> sig;
  const std::string prefix = instance + ".";
  for (const auto& p : built.parameters) {
    if (p.name.rfind(prefix, 0) == 0) sig.insert({p.name.substr(prefix.size()), p.info.unit});
  }
  return sig;
}

std::set<std::pair<std::string, std::string>> TypeSignature(const std::string& type,
                                                            const BlockOptions& options) {
  std::set<std::pair<std::string, std::string>> sig;
  const auto block = models::BlockRegistry::Global().Create(type, options);
  for (const auto& p : block->info().parameters) sig.insert({p.name, p.unit});
  return sig;
}

// The test point of the file comment.
struct TestPoint {
  Eigen::VectorXd x, u, p;
};
TestPoint MakeTestPoint(const models::StateSpaceModel& m, int velocity_state) {
  TestPoint t;
  t.x.resize(m.NumStates());
  for (int i = 0; i < m.NumStates(); ++i) {
    t.x[i] = 0.5 * (m.states[i].typical_min + m.states[i].typical_max);
  }
  const double vmax = m.states[velocity_state].typical_max;
  t.x[velocity_state] = 0.5 * (vmax > 0.0 ? vmax : 1.0);
  t.u = Eigen::VectorXd::Zero(m.NumInputs());
  t.p = m.ParameterValues();
  return t;
}

double Acceleration(const models::StateSpaceModel& m, const TestPoint& t, int state) {
  return m.dynamics({t.x, t.u, t.p})[0][state];
}

std::string FreshInstance(const models::Model& model, const std::string& base,
                          std::set<std::string>* taken) {
  std::set<std::string> prefixes;
  for (const auto& s : model.Signals()) prefixes.insert(s.substr(0, s.find('.')));
  for (const auto& p : model.parameters()) prefixes.insert(p.name.substr(0, p.name.find('.')));
  for (int k = 1;; ++k) {
    const std::string name = k == 1 ? base : base + "_" + std::to_string(k);
    if (!prefixes.count(name) && !taken->count(name)) {
      taken->insert(name);
      return name;
    }
  }
}

}  // namespace

std::string Candidate::Name() const { return effect + " (" + detail + ") on " + attachment; }

void CandidateOptions::Validate() const {
  for (const auto& e : effects) {
    const auto& known = KnownEffects();
    if (std::find(known.begin(), known.end(), e) == known.end()) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw std::invalid_argument("CandidateOptions.effects: unknown effect '" + e +
                                  "'; expected one of " + list);
    }
  }
}

std::vector<MechanicalAxis> FindAxes(const estimators::Problem& problem) {
  const models::StateSpaceModel& built = problem.built;
  std::vector<MechanicalAxis> axes;
  for (const auto& v : built.signals) {
    if (v.info.role != SignalRole::kVelocity || v.source != SignalSource::kState) continue;
    const bool prismatic = v.info.unit == "m/s";
    if (!prismatic && v.info.unit != "rad/s") continue;
    const int state = built.StateIndex(v.info.name);
    std::vector<MechanicalAxis> found;
    for (const auto& f : built.signals) {
      if (f.info.role != SignalRole::kForce || f.source == SignalSource::kState) continue;
      // Probe: friction.viscous reading v, writing -F, with fv at 0 and at 1.
      models::Model probe = problem.model;
      std::set<std::string> taken;
      const std::string name = FreshInstance(probe, "probe", &taken);
      probe.AddBlock(name, "friction.viscous", Motion(prismatic), {v.info.name},
                     {"-" + f.info.name});
      const models::StateSpaceModel pm = probe.Build();
      TestPoint t = MakeTestPoint(pm, state);
      const int fv = pm.ParameterIndex(name + ".fv");
      t.p[fv] = 0.0;
      const double a0 = Acceleration(pm, t, state);
      t.p[fv] = 1.0;
      const double a1 = Acceleration(pm, t, state);
      const double change = a1 - a0;
      if (!std::isfinite(change) || change == 0.0) continue;
      MechanicalAxis axis;
      axis.velocity = v.info.name;
      axis.force = f.info.name;
      axis.connection = (change < 0.0 ? "-" : "") + f.info.name;
      axis.prismatic = prismatic;
      for (const auto& kind : kFrictionKinds) {
        bool present = false;
        for (const auto& instance : f.blocks) {
          bool listed = false;
          for (const auto& [inst, type] : problem.blocks) {
            if (inst == instance) {
              listed = true;
              present = present || type == kind.type;
            }
          }
          if (!listed) {
            const auto sig = InstanceSignature(built, instance);
            present = present || sig == TypeSignature(kind.type, Motion(prismatic)) ||
                      sig == TypeSignature(kind.type, CandidateOptionsFor(kind.type, prismatic));
          }
        }
        if (present) axis.present_types.push_back(kind.type);
      }
      found.push_back(axis);
    }
    if (found.empty()) continue;
    auto chosen = std::find_if(found.begin(), found.end(),
                               [](const MechanicalAxis& a) { return !a.present_types.empty(); });
    MechanicalAxis axis = chosen != found.end() ? *chosen : found.front();
    // Inputs feeding the axis directly: dv/dt changes with the input, and no block adds to it.
    const TestPoint t = MakeTestPoint(built, state);
    const double a0 = Acceleration(built, t, state);
    for (int i = 0; i < built.NumInputs(); ++i) {
      const auto& s = built.signals[built.SignalIndex(built.inputs[i].name)];
      if (!s.blocks.empty()) continue;
      TestPoint ti = t;
      const double scale =
          std::max(std::fabs(built.inputs[i].typical_max), std::fabs(built.inputs[i].typical_min));
      ti.u[i] = scale > 0.0 ? 0.5 * scale : 1.0;
      const double a1 = Acceleration(built, ti, state);
      if (std::isfinite(a1) && a1 != a0) axis.inputs.push_back(built.inputs[i].name);
    }
    axes.push_back(axis);
  }
  return axes;
}

std::vector<Candidate> EnumerateCandidates(const estimators::Problem& problem,
                                           const CandidateOptions& options) {
  options.Validate();
  auto wanted = [&](const std::string& effect) {
    return options.effects.empty() || std::find(options.effects.begin(), options.effects.end(),
                                                effect) != options.effects.end();
  };
  std::vector<Candidate> out;
  std::set<std::string> taken;
  std::set<std::string> delayed_inputs;
  for (const MechanicalAxis& axis : FindAxes(problem)) {
    auto present = [&](const std::string& type) {
      return std::find(axis.present_types.begin(), axis.present_types.end(), type) !=
             axis.present_types.end();
    };
    for (const auto& kind : kFrictionKinds) {
      if (!wanted(kind.effect) || present(kind.type)) continue;
      Candidate c;
      c.effect = kind.effect;
      c.detail = kind.detail;
      c.attachment = "velocity " + axis.velocity + " -> force " + axis.force;
      c.instance = FreshInstance(problem.model, kind.effect, &taken);
      const auto block =
          std::shared_ptr<const models::Block>(models::BlockRegistry::Global().Create(
              kind.type, CandidateOptionsFor(kind.type, axis.prismatic)));
      std::vector<std::string> held;  // held at their value for screening and re-fit
      for (const auto& p : block->info().parameters) {
        const std::string q = c.instance + "." + p.name;
        c.parameters.push_back(q);
        const bool repeats_viscous = std::string(kind.type) == "friction.stribeck" &&
                                     p.name == "fv" && present("friction.viscous");
        if (repeats_viscous) {
          held.push_back(q);
        } else if (p.HasNeutral()) {
          c.screened.push_back(q);
          c.refit.push_back(q);
        } else {
          held.push_back(q);
          c.refit.push_back(q);
        }
      }
      const std::string instance = c.instance, velocity = axis.velocity,
                        connection = axis.connection;
      c.apply = [block, instance, velocity, connection, held](models::Model* m) {
        m->Augment(instance, block, {velocity}, {connection});
        for (const auto& q : held) m->Fix(q);
      };
      out.push_back(std::move(c));
    }
    if (!wanted("input_delay")) continue;
    for (const auto& input : axis.inputs) {
      if (!delayed_inputs.insert(input).second) continue;
      const auto& info = problem.built.inputs[problem.built.InputIndex(input)];
      BlockOptions o;
      o.words["unit"] = info.unit.empty() ? "1" : info.unit;
      if (info.typical_min < info.typical_max) {
        o.numbers["typical_range"] = {info.typical_min, info.typical_max};
      }
      Candidate c;
      c.effect = "input_delay";
      c.detail = "delay.first_order";
      c.attachment = "input " + input;
      c.instance = FreshInstance(problem.model, "input_delay", &taken);
      const auto block = std::shared_ptr<const models::Block>(
          models::BlockRegistry::Global().Create("delay.first_order", o));
      std::vector<std::string> held;
      for (const auto& p : block->info().parameters) {
        const std::string q = c.instance + "." + p.name;
        c.parameters.push_back(q);
        if (p.HasNeutral()) {
          c.screened.push_back(q);
        } else {
          held.push_back(q);
        }
        c.refit.push_back(q);
      }
      const std::string instance = c.instance;
      c.apply = [block, instance, input, held](models::Model* m) {
        m->InsertOnSignal(input, instance, block);
        for (const auto& q : held) m->Fix(q);
      };
      out.push_back(std::move(c));
    }
  }
  return out;
}

}  // namespace graybox::diagnosis
