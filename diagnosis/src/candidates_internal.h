// Private to the candidate library (candidates.cc: the effect lists and EnumerateCandidates;
// candidate_axes.cc: the mechanical axes, from metadata or named in the problem;
// candidate_effects.cc: the actuator, position, load, chamber and sensor candidates): what they
// share.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "graybox/diagnosis/candidates.h"
#include "graybox/models/friction.h"

namespace graybox::diagnosis::internal {

using models::BlockOptions;
using models::SignalRole;
using models::SignalSource;

inline constexpr double kTwoPi = 6.28318530717958647692;

// The friction-family candidates: effect, detail, block type.
struct FrictionKind {
  const char* effect;
  const char* detail;
  const char* type;
};
inline constexpr FrictionKind kFrictionKinds[] = {
    {"coulomb", "friction.coulomb", "friction.coulomb"},
    {"asymmetric_friction", "friction.offset", "friction.offset"},
    {"asymmetric_friction", "friction.asymmetric", "friction.asymmetric"},
    {"stribeck", "friction.stribeck", "friction.stribeck"},
    {"viscous", "friction.viscous", "friction.viscous"},
    {"power_law_viscous", "friction.power_viscous", "friction.power_viscous"},
    {"presliding", "dahl", "friction.dahl"},
    {"presliding", "lugre", "friction.lugre"},
};

inline BlockOptions Motion(bool prismatic) {
  BlockOptions o;
  o.words["motion"] = prismatic ? "prismatic" : "rotational";
  return o;
}

// Whether a candidate block's smoothing steepness is an option set from the axis' velocity (the
// blocks whose shape holds a smoothed sign: the Coulomb level and the direction-dependent level,
// chosen from a grid by score, and the Stribeck excess, whose hump near standstill a fixed default
// steepness flattens when the axis' velocities are small against 1 / steepness).
inline bool HasSteepnessGrid(const std::string& type) {
  return type == models::kCoulombFriction || type == models::kAsymmetricFriction ||
         type == models::kStribeckFriction;
}

// The options a candidate of `type` is created with: the axis' motion, and for the sign-like
// blocks their smoothing steepness as a fixed setting (kDefaultFrictionSteepness) rather than a
// parameter.
inline BlockOptions CandidateOptionsFor(const std::string& type, bool prismatic) {
  BlockOptions o = Motion(prismatic);
  if (HasSteepnessGrid(type)) o.numbers["steepness"] = {models::kDefaultFrictionSteepness};
  if (type == models::kDahlFriction) o.words["form"] = "length";
  return o;
}

// Local parameter names and units of instance `instance` in the built model.
inline std::set<std::pair<std::string, std::string>> InstanceSignature(
    const models::StateSpaceModel& built, const std::string& instance) {
  std::set<std::pair<std::string, std::string>> sig;
  const std::string prefix = instance + ".";
  for (const auto& p : built.parameters) {
    if (p.name.rfind(prefix, 0) == 0) sig.insert({p.name.substr(prefix.size()), p.info.unit});
  }
  return sig;
}

inline std::set<std::pair<std::string, std::string>> TypeSignature(const std::string& type,
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
inline TestPoint MakeTestPoint(const models::StateSpaceModel& m, int velocity_state) {
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

inline double Acceleration(const models::StateSpaceModel& m, const TestPoint& t, int state) {
  return m.dynamics({t.x, t.u, t.p})[0][state];
}

inline std::string FreshInstance(const models::Model& model, const std::string& base,
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

// The parameters of `block` instantiated as `c.instance`: those with a neutral value screened and
// re-fitted, the others (shapes) held at nominal for the test and freed to re-fit. Returns the
// held.
inline std::vector<std::string> SplitParameters(const models::Block& block, Candidate* c) {
  std::vector<std::string> held;
  for (const auto& p : block.info().parameters) {
    const std::string q = c->instance + "." + p.name;
    c->parameters.push_back(q);
    if (p.HasNeutral()) {
      c->screened.push_back(q);
    } else {
      held.push_back(q);
    }
    c->refit.push_back(q);
  }
  return held;
}

// Options "unit" and "typical_range" of the sensor and actuator blocks from a signal's metadata.
inline BlockOptions QuantityOptions(const models::SignalInfo& info) {
  BlockOptions o;
  o.words["unit"] = info.unit.empty() ? "1" : info.unit;
  if (info.typical_min < info.typical_max) {
    o.numbers["typical_range"] = {info.typical_min, info.typical_max};
  }
  return o;
}

// Whether blocks add to (or subtract from) the model input `input` (friction subtracted from a
// torque command): an actuator effect then goes on the input alone (Model::InsertOnInput).
inline bool SummedInput(const models::StateSpaceModel& built, const std::string& input) {
  return !built.signals[built.SignalIndex(input)].blocks.empty();
}

inline bool IsModelInput(const models::StateSpaceModel& built, const std::string& signal) {
  for (const auto& in : built.inputs) {
    if (in.name == signal) return true;
  }
  return false;
}

inline std::vector<std::string> ReadersOf(const models::Model& model, const std::string& signal) {
  std::vector<std::string> readers;
  for (const auto& b : model.Blocks()) {
    if (std::find(b.inputs.begin(), b.inputs.end(), signal) != b.inputs.end()) {
      readers.push_back(b.instance);
    }
  }
  return readers;
}

inline std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

// deadzone (file comment): the axis' free inputs, and the command inputs of the non-friction
// blocks that write the axis force.
void AddDeadzones(const estimators::Problem& problem, const MechanicalAxis& axis,
                  std::set<std::string>* taken, std::set<std::string>* done,
                  std::vector<Candidate>* out);

// ripple (file comment): one first-harmonic candidate per period.
void AddRipples(const estimators::Problem& problem, const MechanicalAxis& axis,
                const CandidateOptions& options, std::set<std::string>* taken,
                std::vector<Candidate>* out);

// sensor_offset, sensor_scale (file comment): on every output channel; a second variant where a
// controller reads the channel's signal too.
void AddSensors(const estimators::Problem& problem, const std::string& effect,
                std::set<std::string>* taken, std::vector<Candidate>* out);

// rotor_inertia and payload (file comment).
void AddLoads(const estimators::Problem& problem, const MechanicalAxis& axis, bool inertia,
              bool payload, bool elasticity, std::set<std::string>* taken,
              std::vector<Candidate>* out);

// leakage and polytropic_index on every pneumatic.chamber (file comment).
void AddChamberEffects(const estimators::Problem& problem, bool leakage, bool polytropic,
                       std::set<std::string>* taken, std::vector<Candidate>* out);

// backlash on every drive.two_mass without one (file comment).
void AddBacklash(const estimators::Problem& problem, std::vector<Candidate>* out);

}  // namespace graybox::diagnosis::internal
