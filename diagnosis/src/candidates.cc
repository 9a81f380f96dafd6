#include "graybox/diagnosis/candidates.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "graybox/models/chamber_effects.h"
#include "graybox/models/drives.h"
#include "graybox/models/friction.h"
#include "graybox/models/loads.h"
#include "graybox/models/mechanics.h"
#include "graybox/models/sensors.h"
#include "graybox/models/transmission_effects.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::diagnosis {
namespace {

using models::BlockOptions;
using models::SignalRole;
using models::SignalSource;

constexpr double kTwoPi = 6.28318530717958647692;

// Relative agreement of dq/dt with v that makes q the axis' position (the same expression, so
// rounding only).
constexpr double kPositionMatchTolerance = 1e-12;

// The friction-family candidates: effect, detail, block type.
struct FrictionKind {
  const char* effect;
  const char* detail;
  const char* type;
};
constexpr FrictionKind kFrictionKinds[] = {
    {"coulomb", "friction.coulomb", "friction.coulomb"},
    {"asymmetric_friction", "friction.offset", "friction.offset"},
    {"asymmetric_friction", "friction.asymmetric", "friction.asymmetric"},
    {"stribeck", "friction.stribeck", "friction.stribeck"},
    {"viscous", "friction.viscous", "friction.viscous"},
    {"power_law_viscous", "friction.power_viscous", "friction.power_viscous"},
    {"presliding", "dahl", "friction.dahl"},
    {"presliding", "lugre", "friction.lugre"},
};

BlockOptions Motion(bool prismatic) {
  BlockOptions o;
  o.words["motion"] = prismatic ? "prismatic" : "rotational";
  return o;
}

// Whether a candidate block's smoothing steepness is an option set from the axis' velocity (the
// blocks whose shape holds a smoothed sign: the Coulomb level and the direction-dependent level,
// chosen from a grid by score, and the Stribeck excess, whose hump near standstill a fixed default
// steepness flattens when the axis' velocities are small against 1 / steepness).
bool HasSteepnessGrid(const std::string& type) {
  return type == models::kCoulombFriction || type == models::kAsymmetricFriction ||
         type == models::kStribeckFriction;
}

// The options a candidate of `type` is created with: the axis' motion, and for the sign-like
// blocks their smoothing steepness as a fixed setting (kDefaultFrictionSteepness) rather than a
// parameter.
BlockOptions CandidateOptionsFor(const std::string& type, bool prismatic) {
  BlockOptions o = Motion(prismatic);
  if (HasSteepnessGrid(type)) o.numbers["steepness"] = {models::kDefaultFrictionSteepness};
  if (type == models::kDahlFriction) o.words["form"] = "length";
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

// Whether the state `position`'s time derivative equals the state `velocity` at the test point
// and at a second value of the velocity (the same expression, so rounding only).
bool IsIntegralOf(const models::StateSpaceModel& built, const std::string& position,
                  const std::string& velocity) {
  const int v = built.StateIndex(velocity);
  const int q = built.StateIndex(position);
  const TestPoint t = MakeTestPoint(built, v);
  TestPoint t2 = t;
  t2.x[v] = -0.3 * t.x[v] + 0.1;
  const Eigen::VectorXd f1 = built.dynamics({t.x, t.u, t.p})[0];
  const Eigen::VectorXd f2 = built.dynamics({t2.x, t2.u, t2.p})[0];
  auto close = [](double a, double b) {
    return std::fabs(a - b) <= kPositionMatchTolerance * std::max(1.0, std::fabs(b));
  };
  return close(f1[q], t.x[v]) && close(f2[q], t2.x[v]);
}

// The axis' position: a state in m (rad; for another velocity unit "X/s", in X) whose derivative
// is v (file comment).
std::string AxisPosition(const models::StateSpaceModel& built, const MechanicalAxis& axis) {
  const int v = built.StateIndex(axis.velocity);
  const std::string& vunit = built.states[v].unit;
  const std::string unit = vunit.size() > 2 && vunit.compare(vunit.size() - 2, 2, "/s") == 0
                               ? vunit.substr(0, vunit.size() - 2)
                               : (axis.prismatic ? "m" : "rad");
  for (int i = 0; i < built.NumStates(); ++i) {
    if (i == v || built.states[i].unit != unit) continue;
    const auto& s = built.signals[built.SignalIndex(built.states[i].name)];
    // A position by its role, or by its derivative alone when no role is declared (the robot
    // blocks declare none for their joint angles).
    if (s.info.role != SignalRole::kPosition && s.info.role != SignalRole::kNone) continue;
    if (IsIntegralOf(built, built.states[i].name, axis.velocity)) return built.states[i].name;
  }
  return "";
}

// The parameters of `block` instantiated as `c.instance`: those with a neutral value screened and
// re-fitted, the others (shapes) held at nominal for the test and freed to re-fit. Returns the
// held.
std::vector<std::string> SplitParameters(const models::Block& block, Candidate* c) {
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
BlockOptions QuantityOptions(const models::SignalInfo& info) {
  BlockOptions o;
  o.words["unit"] = info.unit.empty() ? "1" : info.unit;
  if (info.typical_min < info.typical_max) {
    o.numbers["typical_range"] = {info.typical_min, info.typical_max};
  }
  return o;
}

// Whether blocks add to (or subtract from) the model input `input` (friction subtracted from a
// torque command): an actuator effect then goes on the input alone (Model::InsertOnInput).
bool SummedInput(const models::StateSpaceModel& built, const std::string& input) {
  return !built.signals[built.SignalIndex(input)].blocks.empty();
}

bool IsModelInput(const models::StateSpaceModel& built, const std::string& signal) {
  for (const auto& in : built.inputs) {
    if (in.name == signal) return true;
  }
  return false;
}

std::vector<std::string> ReadersOf(const models::Model& model, const std::string& signal) {
  std::vector<std::string> readers;
  for (const auto& b : model.Blocks()) {
    if (std::find(b.inputs.begin(), b.inputs.end(), signal) != b.inputs.end()) {
      readers.push_back(b.instance);
    }
  }
  return readers;
}

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

// deadzone (file comment): the axis' free inputs, and the command inputs of the non-friction
// blocks that write the axis force.
void AddDeadzones(const estimators::Problem& problem, const MechanicalAxis& axis,
                  std::set<std::string>* taken, std::set<std::string>* done,
                  std::vector<Candidate>* out) {
  const models::StateSpaceModel& built = problem.built;
  const auto blocks = problem.model.Blocks();
  struct Command {
    std::string signal;
    std::vector<std::string> readers;
    bool summed_input;  // a model input blocks add to: the dead zone goes on the input alone
  };
  std::vector<Command> commands;
  for (const auto& input : axis.inputs) {
    commands.push_back({input, ReadersOf(problem.model, input),
                        IsModelInput(built, input) && SummedInput(built, input)});
  }
  const auto& force = built.signals[built.SignalIndex(axis.force)];
  // Commands named by hand ([[diagnosis.axes]] inputs) are the only ones.
  for (const auto& producer : axis.inputs_named ? std::vector<std::string>{} : force.blocks) {
    for (const auto& b : blocks) {
      if (b.instance != producer || b.type.rfind("friction.", 0) == 0) continue;
      for (const auto& in : b.inputs) {
        const auto& s = built.signals[built.SignalIndex(in)];
        const SignalRole role = s.info.role;
        if (s.source == SignalSource::kState || role == SignalRole::kPosition ||
            role == SignalRole::kVelocity || role == SignalRole::kAcceleration) {
          continue;
        }
        commands.push_back({in, {producer}, false});
      }
    }
  }
  for (const auto& [signal, readers, summed_input] : commands) {
    if (readers.empty() || !done->insert(signal).second) continue;
    const auto& info = built.signals[built.SignalIndex(signal)].info;
    Candidate c;
    c.effect = "deadzone";
    c.detail = models::kActuatorDeadzone;
    c.attachment =
        "command " + signal + (summed_input ? " (input alone)" : "") + " -> " + Join(readers);
    c.instance = FreshInstance(problem.model, "deadzone", taken);
    const auto block = std::shared_ptr<const models::Block>(
        models::BlockRegistry::Global().Create(models::kActuatorDeadzone, QuantityOptions(info)));
    const std::vector<std::string> held = SplitParameters(*block, &c);
    const std::string instance = c.instance;
    const std::string sig = signal;
    const std::vector<std::string> rd = readers;
    c.augmentation = {summed_input ? models::Augmentation::Kind::kOnInput
                                   : models::Augmentation::Kind::kForReaders,
                      c.instance,
                      models::kActuatorDeadzone,
                      QuantityOptions(info),
                      {},
                      {},
                      signal,
                      summed_input ? std::vector<std::string>{} : readers,
                      {}};
    const bool on_input = summed_input;
    c.apply = [block, instance, sig, rd, held, on_input](models::Model* m) {
      if (on_input) {
        m->InsertOnInput(sig, instance, block);
      } else {
        m->InsertForReaders(sig, instance, block, rd);
      }
      for (const auto& q : held) m->Fix(q);
    };
    out->push_back(std::move(c));
  }
}

// The default ripple periods of an axis (file comment).
std::vector<double> DefaultRipplePeriods(const models::StateSpaceModel& built,
                                         const MechanicalAxis& axis) {
  double span = kTwoPi;
  if (axis.prismatic) {
    const auto& q = built.states[built.StateIndex(axis.position)];
    span = q.typical_max - q.typical_min;
    if (!(span > 0.0)) return {};
  }
  return {span, span / 2.0, span / 4.0, span / 8.0};
}

// ripple (file comment): one first-harmonic candidate per period.
void AddRipples(const estimators::Problem& problem, const MechanicalAxis& axis,
                const CandidateOptions& options, std::set<std::string>* taken,
                std::vector<Candidate>* out) {
  if (axis.position.empty()) return;
  std::vector<double> periods = options.ripple_periods;
  if (periods.empty()) {
    const auto scanned = options.ripple_periods_by_position.find(axis.position);
    periods = scanned != options.ripple_periods_by_position.end() && !scanned->second.empty()
                  ? scanned->second
                  : DefaultRipplePeriods(problem.built, axis);
  }
  for (const double period : periods) {
    BlockOptions o = Motion(axis.prismatic);
    o.numbers["harmonics"] = {1};
    o.numbers["period"] = {period};
    Candidate c;
    c.effect = "ripple";
    char buf[64];
    std::snprintf(buf, sizeof(buf), "period %.6g %s", period, axis.prismatic ? "m" : "rad");
    c.detail = buf;
    c.attachment = "position " + axis.position + " -> force " + axis.force;
    c.instance = FreshInstance(problem.model, "ripple", taken);
    const auto block = std::shared_ptr<const models::Block>(
        models::BlockRegistry::Global().Create(models::kRippleFriction, o));
    const std::vector<std::string> held = SplitParameters(*block, &c);
    const std::string instance = c.instance, position = axis.position, connection = axis.connection;
    c.augmentation = {models::Augmentation::Kind::kAdd,
                      c.instance,
                      models::kRippleFriction,
                      o,
                      {axis.position},
                      {axis.connection},
                      "",
                      {},
                      {}};
    c.apply = [block, instance, position, connection, held](models::Model* m) {
      m->Augment(instance, block, {position}, {connection});
      for (const auto& q : held) m->Fix(q);
    };
    out->push_back(std::move(c));
  }
}

// sensor_offset, sensor_scale (file comment): on every output channel; a second variant where a
// controller reads the channel's signal too.
void AddSensors(const estimators::Problem& problem, const std::string& effect,
                std::set<std::string>* taken, std::vector<Candidate>* out) {
  const models::StateSpaceModel& built = problem.built;
  const std::string type = effect == "sensor_offset" ? models::kSensorOffset : models::kSensorScale;
  const auto blocks = problem.model.Blocks();
  const estimators::DiagnosisSpec& spec = problem.diagnosis;
  for (const auto& [channel, signal] : problem.model.Outputs()) {
    if (spec.sensors_given &&
        std::find(spec.sensors.begin(), spec.sensors.end(), channel) == spec.sensors.end()) {
      continue;
    }
    std::vector<std::string> controllers;
    for (const auto& b : blocks) {
      if (b.type.rfind("control.", 0) == 0 &&
          std::find(b.inputs.begin(), b.inputs.end(), signal) != b.inputs.end()) {
        controllers.push_back(b.instance);
      }
    }
    const models::SignalInfo& info = built.outputs[built.OutputIndex(channel)];
    for (const bool feedback : {false, true}) {
      if (feedback && controllers.empty()) continue;
      Candidate c;
      c.effect = effect;
      c.detail = type + (feedback ? ", output and feedback" : ", output");
      c.attachment = "output " + channel + (feedback ? " and controller " + Join(controllers) : "");
      c.instance = FreshInstance(problem.model, effect, taken);
      const auto block = std::shared_ptr<const models::Block>(
          models::BlockRegistry::Global().Create(type, QuantityOptions(info)));
      const std::vector<std::string> held = SplitParameters(*block, &c);
      const std::string instance = c.instance, ch = channel;
      const std::vector<std::string> readers = feedback ? controllers : std::vector<std::string>{};
      c.augmentation = {models::Augmentation::Kind::kOnOutput,
                        c.instance,
                        type,
                        QuantityOptions(info),
                        {},
                        {},
                        channel,
                        readers,
                        {}};
      c.apply = [block, instance, ch, readers, held](models::Model* m) {
        m->InsertOnOutput(ch, instance, block, readers);
        for (const auto& q : held) m->Fix(q);
      };
      out->push_back(std::move(c));
    }
  }
}

// The rigid body that integrates the axis force (mechanics.mass owning v and reading F), for the
// added-load candidates; empty when the axis has none.
struct RigidBody {
  std::string instance, mass;  // the instance and its inertia parameter
  bool mass_free = false;
};
RigidBody FindRigidBody(const estimators::Problem& problem, const MechanicalAxis& axis) {
  const models::StateSpaceModel& built = problem.built;
  const auto& v = built.signals[built.SignalIndex(axis.velocity)];
  if (v.blocks.size() != 1) return {};
  for (const auto& b : problem.model.Blocks()) {
    if (b.instance != v.blocks[0] || b.type != models::kMassBlock || b.inputs.size() != 1 ||
        b.inputs[0] != axis.force) {
      continue;
    }
    RigidBody body{b.instance, b.instance + ".mass", false};
    body.mass_free = built.parameters[built.ParameterIndex(body.mass)].free;
    return body;
  }
  return {};
}

// rotor_inertia and payload (file comment).
void AddLoads(const estimators::Problem& problem, const MechanicalAxis& axis, bool inertia,
              bool payload, bool elasticity, std::set<std::string>* taken,
              std::vector<Candidate>* out) {
  const RigidBody body = FindRigidBody(problem, axis);
  if (body.instance.empty()) return;
  const double mass_now = problem.built.parameters[problem.built.ParameterIndex(body.mass)].value;
  struct Variant {
    std::string effect, type, detail;
    double gravity;  // prismatic payload: g along +q
  };
  std::vector<Variant> variants;
  // An added inertia next to a free inertia is the same unknown twice. A sliding body has no rotor:
  // its added mass is a payload.
  if (inertia && !body.mass_free && !axis.prismatic) {
    variants.push_back({"rotor_inertia", models::kAddedInertia, models::kAddedInertia, 0.0});
  }
  if (payload && !axis.position.empty()) {
    if (axis.prismatic) {
      // Next to a free mass a prismatic payload's mass repeats it and its weight alone is a
      // constant force (asymmetric_friction's constant offset): proposed on a known mass only.
      if (!body.mass_free) {
        variants.push_back({"payload", models::kPayload, "horizontal, added mass", 0.0});
        variants.push_back(
            {"payload", models::kPayload, "vertical, q up", -models::kStandardGravity});
        variants.push_back(
            {"payload", models::kPayload, "vertical, q down", models::kStandardGravity});
      }
    } else {
      variants.push_back({"payload", models::kPayload, "rotational", 0.0});
    }
  }
  // Controllers reading the axis position: the elastic variant with the loop closed on the motor
  // side reads q + e there.
  std::vector<std::string> controllers;
  for (const auto& b : problem.model.Blocks()) {
    if (b.type.rfind("control.", 0) == 0 && !axis.position.empty() &&
        std::find(b.inputs.begin(), b.inputs.end(), axis.position) != b.inputs.end()) {
      controllers.push_back(b.instance);
    }
  }
  if (elasticity) {
    variants.push_back(
        {"elasticity", models::kElasticCoupling, "two-mass, force on the motor side", 0.0});
    if (!controllers.empty()) {
      variants.push_back({"elasticity", models::kElasticCoupling,
                          "two-mass, force and feedback on the motor side", 0.0});
    }
  }
  for (const Variant& var : variants) {
    const bool is_payload = var.effect == "payload";
    const bool is_elastic = var.effect == "elasticity";
    const bool prismatic = axis.prismatic;
    const double gravity = var.gravity;
    auto options = [prismatic, is_payload, gravity](double mass) {
      BlockOptions o = Motion(prismatic);
      o.numbers["axis_inertia"] = {mass};
      if (is_payload && prismatic) o.numbers["gravity"] = {gravity};
      return o;
    };
    Candidate c;
    c.effect = var.effect;
    c.detail = var.detail;
    c.attachment = "force " + axis.force + " -> " + body.instance +
                   (is_payload ? ", position " + axis.position : "");
    c.instance = FreshInstance(problem.model, var.effect, taken);
    if (is_payload && !prismatic && !body.mass_free) c.reduces_to.push_back("rotor_inertia");
    if (is_elastic) {
      // No score test; the stiffness profiled over modes at 1, 2, 4 and 8 % of the sample rate
      // (K = (2 pi f)^2 J_eff, J_eff = J M / (J + M) = M / 5 at the nominal J = M / 4).
      c.structural = true;
      std::vector<double> factors;
      for (const double f : {0.01, 0.02, 0.04, 0.08}) {
        factors.push_back(std::pow(2.0 * M_PI * f, 2) * 0.2 * mass_now);
      }
      c.shape_grids.push_back(
          {c.instance + ".K", Candidate::ShapeGrid::Scale::kSampleRateSquared, "", factors});
    }
    const auto block = models::BlockRegistry::Global().Create(var.type, options(mass_now));
    std::vector<std::string> held = SplitParameters(*block, &c);
    // The payload's rotational inertia next to a free body inertia: held at 0 (gravity only).
    if (is_payload && !prismatic && body.mass_free) {
      const std::string dm = c.instance + ".dM";
      c.screened.erase(std::find(c.screened.begin(), c.screened.end(), dm));
      c.refit.erase(std::find(c.refit.begin(), c.refit.end(), dm));
      held.push_back(dm);
    }
    const std::string instance = c.instance, force = axis.force, reader = body.instance,
                      mass = body.mass, type = var.type;
    const std::vector<std::string> extra =
        is_payload ? std::vector<std::string>{axis.position} : std::vector<std::string>{};
    const bool motor_feedback = is_elastic && var.detail.find("feedback") != std::string::npos;
    if (motor_feedback) c.attachment += ", controller " + Join(controllers) + " on q + e";
    const std::string position = axis.position;
    const std::string unit = prismatic ? "m" : "rad";
    c.apply = [options, instance, force, reader, mass, type, extra, held, motor_feedback, position,
               controllers, unit](models::Model* m) {
      // The body's inertia as the model has it now (the nominal fit's value in screening).
      const auto b = std::shared_ptr<const models::Block>(
          models::BlockRegistry::Global().Create(type, options(m->Parameter(mass).value)));
      m->InsertForReaders(force, instance, b, {reader}, extra);
      for (const auto& q : held) m->Fix(q);
      if (motor_feedback) {
        // The controllers read the motor-side position q + e: a unit gain in series on q for
        // them, and the deflection e added to its output.
        BlockOptions g;
        g.words["input_unit"] = unit;
        g.words["output_unit"] = unit;
        m->InsertForReaders(position, instance + "_motor_q", models::kGainBlock, g, controllers);
        m->Augment(instance + "_deflection", models::kGainBlock, g, {instance + ".e"},
                   {instance + "_motor_q.out"});
        m->Fix(instance + "_motor_q.k");
        m->Fix(instance + "_deflection.k");
      }
    };
    out->push_back(std::move(c));
  }
}

// leakage and polytropic_index on every pneumatic.chamber (file comment).
void AddChamberEffects(const estimators::Problem& problem, bool leakage, bool polytropic,
                       std::set<std::string>* taken, std::vector<Candidate>* out) {
  const models::StateSpaceModel& built = problem.built;
  for (const auto& b : problem.model.Blocks()) {
    if (b.type != "pneumatic.chamber" || b.inputs.size() != 3) continue;
    const std::string pressure = b.instance + ".p", mdot = b.inputs[0];
    const std::string exponent = b.instance + ".polytropic_exponent";
    const std::string temperature = b.instance + ".temperature";
    if (leakage) {
      Candidate c;
      c.effect = "leakage";
      c.detail = models::kChamberLeak;
      c.attachment = "chamber " + b.instance + " (flow " + mdot + ")";
      c.instance = FreshInstance(problem.model, "leakage", taken);
      const auto block = std::shared_ptr<const models::Block>(
          models::BlockRegistry::Global().Create(models::kChamberLeak));
      const std::vector<std::string> held = SplitParameters(*block, &c);
      const std::string instance = c.instance;
      c.apply = [block, instance, pressure, mdot, held](models::Model* m) {
        m->Augment(instance, block, {pressure}, {"-" + mdot});
        for (const auto& q : held) m->Fix(q);
      };
      out->push_back(std::move(c));
    }
    // A free exponent already is this unknown.
    if (polytropic && !built.parameters[built.ParameterIndex(exponent)].free) {
      Candidate c;
      c.effect = "polytropic_index";
      c.detail = models::kPolytropicCorrection;
      c.attachment = "chamber " + b.instance + " (flow " + mdot + ")";
      c.instance = FreshInstance(problem.model, "polytropic_index", taken);
      const auto block = models::BlockRegistry::Global().Create(models::kPolytropicCorrection);
      const std::vector<std::string> held = SplitParameters(*block, &c);
      const std::string instance = c.instance, chamber = b.instance, rate = b.inputs[2];
      c.apply = [instance, chamber, pressure, mdot, rate, temperature, held](models::Model* m) {
        // The chamber's temperature as the model has it now. The gas constant is the chamber
        // block's option, which the model does not expose: air, the chamber's default.
        BlockOptions o;
        o.numbers["temperature"] = {m->Parameter(temperature).value};
        const auto block = std::shared_ptr<const models::Block>(
            models::BlockRegistry::Global().Create(models::kPolytropicCorrection, o));
        m->InsertForReaders(mdot, instance, block, {chamber}, {pressure, rate});
        for (const auto& q : held) m->Fix(q);
      };
      out->push_back(std::move(c));
    }
  }
}

// backlash on every drive.two_mass without one (file comment).
void AddBacklash(const estimators::Problem& problem, std::set<std::string>* taken,
                 std::vector<Candidate>* out) {
  const models::StateSpaceModel& built = problem.built;
  for (const auto& b : problem.model.Blocks()) {
    if (b.type != models::kTwoMassDrive || b.inputs.size() != 2 || b.inputs[0] == b.inputs[1]) {
      continue;
    }
    bool has_backlash = false;
    for (const auto& p : built.parameters)
      has_backlash = has_backlash || p.name == b.instance + ".b";
    if (has_backlash) continue;
    const std::string joint = b.instance, motor = b.inputs[0], load = b.inputs[1];
    Candidate c;
    c.effect = "backlash";
    c.detail = models::kBacklashCorrection;
    c.attachment = "joint " + joint + " (torques " + motor + ", " + load + ")";
    c.instance = FreshInstance(problem.model, "backlash", taken);
    auto options = [](double ke, double d) {
      BlockOptions o;
      o.numbers["stiffness"] = {ke};
      o.numbers["damping"] = {d};
      return o;
    };
    const auto block = models::BlockRegistry::Global().Create(
        models::kBacklashCorrection,
        options(built.parameters[built.ParameterIndex(joint + ".Ke")].value,
                built.parameters[built.ParameterIndex(joint + ".d")].value));
    const std::vector<std::string> held = SplitParameters(*block, &c);
    const std::string instance = c.instance;
    c.apply = [options, instance, joint, motor, load, held](models::Model* m) {
      // The joint's stiffness and damping as the model has them now (transmission_effects.h).
      const auto blk = std::shared_ptr<const models::Block>(models::BlockRegistry::Global().Create(
          models::kBacklashCorrection,
          options(m->Parameter(joint + ".Ke").value, m->Parameter(joint + ".d").value)));
      m->Augment(instance, blk, {joint + ".q_m", joint + ".q_l", joint + ".qd_m", joint + ".qd_l"},
                 {"-" + motor, load});
      for (const auto& q : held) m->Fix(q);
    };
    out->push_back(std::move(c));
  }
}

// d(v)/dt with a probe viscous friction (reading v, writing "-F") at fv = 1 minus at fv = 0, at the
// test point: negative when F acts on v in the usual sign convention, positive in the other, 0
// when F does not act on v.
double ProbeChange(const estimators::Problem& problem, const std::string& velocity,
                   const std::string& force, bool prismatic) {
  models::Model probe = problem.model;
  std::set<std::string> taken;
  const std::string name = FreshInstance(probe, "probe", &taken);
  probe.AddBlock(name, "friction.viscous", Motion(prismatic), {velocity}, {"-" + force});
  const models::StateSpaceModel pm = probe.Build();
  const int state = pm.StateIndex(velocity);
  TestPoint t = MakeTestPoint(pm, state);
  const int fv = pm.ParameterIndex(name + ".fv");
  t.p[fv] = 0.0;
  const double a0 = Acceleration(pm, t, state);
  t.p[fv] = 1.0;
  const double a1 = Acceleration(pm, t, state);
  return a1 - a0;
}

// The friction-family block types among the blocks that write the force signal `f` (file
// comment: by Problem::blocks, else by the instance's parameter signature).
std::vector<std::string> PresentFrictionTypes(const estimators::Problem& problem,
                                              const models::SignalDescription& f, bool prismatic) {
  std::vector<std::string> present_types;
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
        const auto sig = InstanceSignature(problem.built, instance);
        present = present || sig == TypeSignature(kind.type, Motion(prismatic)) ||
                  sig == TypeSignature(kind.type, CandidateOptionsFor(kind.type, prismatic));
      }
    }
    if (present) present_types.push_back(kind.type);
  }
  return present_types;
}

// The model inputs whose value changes d(v)/dt at the test point (`state` is v's index).
std::vector<std::string> FeedingInputs(const models::StateSpaceModel& built, int state) {
  std::vector<std::string> inputs;
  const TestPoint t = MakeTestPoint(built, state);
  const double a0 = Acceleration(built, t, state);
  for (int i = 0; i < built.NumInputs(); ++i) {
    TestPoint ti = t;
    const double scale =
        std::max(std::fabs(built.inputs[i].typical_max), std::fabs(built.inputs[i].typical_min));
    ti.u[i] = scale > 0.0 ? 0.5 * scale : 1.0;
    const double a1 = Acceleration(built, ti, state);
    if (std::isfinite(a1) && a1 != a0) inputs.push_back(built.inputs[i].name);
  }
  return inputs;
}

// An axis named in [[diagnosis.axes]] (problem_file.h DiagnosisAxisSpec): the given signals, the
// rest found as for a metadata axis. Throws estimators::ProblemFileError at the entry when the
// force does not act on the velocity (with no `sign` given) or the position is not its integral.
MechanicalAxis NamedAxis(const estimators::Problem& problem,
                         const estimators::DiagnosisAxisSpec& named) {
  const models::StateSpaceModel& built = problem.built;
  const auto& v = built.signals[built.SignalIndex(named.velocity)];
  const auto& f = built.signals[built.SignalIndex(named.force)];
  MechanicalAxis axis;
  axis.velocity = named.velocity;
  axis.force = named.force;
  axis.prismatic =
      named.motion.empty() ? v.info.unit == "m/s" : named.motion == std::string("linear");
  if (named.sign.empty()) {
    const double change = ProbeChange(problem, named.velocity, named.force, axis.prismatic);
    if (!std::isfinite(change) || change == 0.0) {
      throw estimators::ProblemFileError(
          named.where, "[[diagnosis.axes]] axis on '" + named.velocity + "': expected the force '" +
                           named.force + "' to change d(" + named.velocity +
                           ")/dt, got a change of " + std::to_string(change) +
                           " from a unit viscous probe at the test point (the middle of every "
                           "state's typical range); name the force that acts on the velocity, or "
                           "give 'sign' when it acts only away from that point");
    }
    axis.connection = (change < 0.0 ? "-" : "") + named.force;
  } else {
    axis.connection = (named.sign == "subtract" ? "-" : "") + named.force;
  }
  axis.present_types = PresentFrictionTypes(problem, f, axis.prismatic);
  if (named.inputs_given) {
    axis.inputs = named.inputs;
    axis.inputs_named = true;
  } else {
    axis.inputs = FeedingInputs(built, built.StateIndex(named.velocity));
  }
  axis.position = AxisPosition(built, axis);
  if (!named.position.empty()) {
    if (axis.position != named.position) {
      // Named by hand: its derivative must still be the velocity (ripple and payload read it).
      if (!IsIntegralOf(built, named.position, axis.velocity)) {
        throw estimators::ProblemFileError(
            named.where, "[[diagnosis.axes]] axis on '" + named.velocity +
                             "': expected the position '" + named.position +
                             "' to have d/dt = " + named.velocity +
                             ", got a state whose derivative differs at the test point" +
                             (axis.position.empty()
                                  ? ""
                                  : " (the state '" + axis.position + "' has that derivative)"));
      }
    }
    axis.position = named.position;
  }
  return axis;
}

}  // namespace

const std::vector<std::string>& AllEffects() {
  static const std::vector<std::string> all = {
      "coulomb",       "asymmetric_friction", "stribeck", "viscous", "power_law_viscous",
      "presliding",    "input_delay",         "deadzone", "ripple",  "rotor_inertia",
      "payload",       "elasticity",          "backlash", "leakage", "polytropic_index",
      "sensor_offset", "sensor_scale"};
  return all;
}

const std::vector<std::string>& DefaultEffects() {
  static const std::vector<std::string> defaults = [] {
    std::vector<std::string> d;
    for (const std::string& e : AllEffects()) {
      if (e != "elasticity") d.push_back(e);
    }
    return d;
  }();
  return defaults;
}

std::vector<std::string> SelectedEffects(const estimators::Problem& problem,
                                         const CandidateOptions& options) {
  const estimators::DiagnosisSpec& spec = problem.diagnosis;
  const std::vector<std::string>& base = !options.effects.empty() ? options.effects
                                         : spec.effects_given     ? spec.effects
                                                                  : DefaultEffects();
  auto in = [](const std::vector<std::string>& list, const std::string& e) {
    return std::find(list.begin(), list.end(), e) != list.end();
  };
  std::vector<std::string> out;
  for (const std::string& e : AllEffects()) {
    if ((in(base, e) || in(spec.add_effects, e)) && !in(spec.remove_effects, e)) out.push_back(e);
  }
  return out;
}

void CheckDiagnosisSpec(const estimators::Problem& problem) {
  const estimators::DiagnosisSpec& spec = problem.diagnosis;
  const auto& known = AllEffects();
  std::string list;
  for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
  for (const auto* key : {"effects", "add_effects", "remove_effects"}) {
    const std::vector<std::string>& names = std::string(key) == "effects" ? spec.effects
                                            : std::string(key) == "add_effects"
                                                ? spec.add_effects
                                                : spec.remove_effects;
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (std::find(known.begin(), known.end(), names[i]) != known.end()) continue;
      const std::string k = std::string(key) + "[" + std::to_string(i) + "]";
      const auto w = spec.where.find(k);
      throw estimators::ProblemFileError(
          w != spec.where.end() ? w->second : estimators::SourceLocation{},
          "[diagnosis] '" + k + "': unknown effect '" + names[i] + "'" +
              util::DidYouMeanHint(names[i], known) + "; expected one of " + list);
    }
  }
}

std::string Candidate::Name() const { return effect + " (" + detail + ") on " + attachment; }

void CandidateOptions::Validate() const {
  for (const double p : ripple_periods) {
    if (!std::isfinite(p) || !(p > 0.0)) {
      throw std::invalid_argument(
          "CandidateOptions.ripple_periods: expected finite periods > 0, got " + std::to_string(p));
    }
  }
  for (const auto& [position, periods] : ripple_periods_by_position) {
    for (const double p : periods) {
      if (!std::isfinite(p) || !(p > 0.0)) {
        throw std::invalid_argument("CandidateOptions.ripple_periods_by_position['" + position +
                                    "']: expected finite periods > 0, got " + std::to_string(p));
      }
    }
  }
  for (const auto& e : effects) {
    const auto& known = AllEffects();
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
  const estimators::DiagnosisSpec& spec = problem.diagnosis;
  std::vector<MechanicalAxis> axes;
  for (int state = 0; state < built.NumStates(); ++state) {
    const auto& v = built.signals[built.SignalIndex(built.states[state].name)];
    const estimators::DiagnosisAxisSpec* named = nullptr;
    for (const auto& a : spec.axes) {
      if (a.velocity == v.info.name) named = &a;
    }
    if (named) {
      axes.push_back(NamedAxis(problem, *named));
      continue;
    }
    if (!spec.metadata_axes) continue;
    if (v.info.role != SignalRole::kVelocity) continue;
    const bool prismatic = v.info.unit == "m/s";
    if (!prismatic && v.info.unit != "rad/s") continue;
    std::vector<MechanicalAxis> found;
    std::vector<std::pair<int, double>> found_rank;
    for (const auto& f : built.signals) {
      if (f.info.role != SignalRole::kForce || f.source == SignalSource::kState) continue;
      const double change = ProbeChange(problem, v.info.name, f.info.name, prismatic);
      if (!std::isfinite(change) || change == 0.0) continue;
      MechanicalAxis axis;
      axis.velocity = v.info.name;
      axis.force = f.info.name;
      axis.connection = (change < 0.0 ? "-" : "") + f.info.name;
      axis.prismatic = prismatic;
      axis.present_types = PresentFrictionTypes(problem, f, prismatic);
      // Whether a block writing F reads v (friction on this axis), and how strongly F acts.
      int rank = 0;
      for (const auto& b : problem.model.Blocks()) {
        if (std::find(f.blocks.begin(), f.blocks.end(), b.instance) != f.blocks.end() &&
            std::find(b.inputs.begin(), b.inputs.end(), v.info.name) != b.inputs.end()) {
          rank = 2;
        }
      }
      if (rank == 2 && !axis.present_types.empty()) rank = 3;
      found.push_back(axis);
      found_rank.push_back({rank, std::fabs(change)});
    }
    if (found.empty()) continue;
    // The force whose friction block reads v, else one a block reading v writes, else the one
    // acting most strongly on v (in a coupled multibody every joint torque moves every joint).
    std::size_t best = 0;
    for (std::size_t k = 1; k < found.size(); ++k) {
      if (found_rank[k] > found_rank[best]) best = k;
    }
    MechanicalAxis axis = found[best];
    axis.inputs = FeedingInputs(built, state);
    axis.position = AxisPosition(built, axis);
    axes.push_back(axis);
  }
  return axes;
}

std::vector<Candidate> EnumerateCandidates(const estimators::Problem& problem,
                                           const CandidateOptions& options) {
  options.Validate();
  CheckDiagnosisSpec(problem);
  const std::vector<std::string> selected = SelectedEffects(problem, options);
  auto wanted = [&](const std::string& effect) {
    return std::find(selected.begin(), selected.end(), effect) != selected.end();
  };
  const estimators::DiagnosisSpec& spec = problem.diagnosis;
  const bool lugre_presliding = options.lugre_presliding || spec.lugre_presliding;
  CandidateOptions resolved = options;
  if (resolved.ripple_periods.empty()) resolved.ripple_periods = spec.ripple_periods;
  std::vector<Candidate> out;
  std::set<std::string> taken;
  std::set<std::string> delayed_inputs;
  std::set<std::string> deadzoned;
  for (const MechanicalAxis& axis : FindAxes(problem)) {
    auto present = [&](const std::string& type) {
      return std::find(axis.present_types.begin(), axis.present_types.end(), type) !=
             axis.present_types.end();
    };
    for (const auto& kind : kFrictionKinds) {
      if (!wanted(kind.effect) || present(kind.type)) continue;
      const bool lugre = std::string(kind.detail) == "lugre";
      if (lugre && !lugre_presliding) continue;
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
        const bool repeats_viscous = (std::string(kind.type) == "friction.stribeck" &&
                                      p.name == "fv" && present("friction.viscous")) ||
                                     (lugre && p.name == "sigma2" && present("friction.viscous"));
        // Next to a Coulomb term the Stribeck block's own Coulomb level repeats it: held at 0,
        // the block is the excess fs exp(-(v/vs)^2) sign(v) alone.
        const bool repeats_coulomb = std::string(kind.type) == "friction.stribeck" &&
                                     p.name == "fc" && present("friction.coulomb");
        // The direction-dependent candidate is the difference of the levels alone: its even
        // viscous term (a second, rarer shape) held at 0, so it does not fit any even residual.
        const bool even_viscous =
            kind.type == std::string(models::kAsymmetricFriction) && p.name == "fvd";
        // Its constant part next to a friction.offset repeats that term.
        const bool repeats_offset = kind.type == std::string(models::kAsymmetricFriction) &&
                                    p.name == "f0" && present(models::kOffsetFriction);
        // LuGre's micro-damping and viscous term: at sigma0 = 0, dz/dt = v, so both act as
        // viscous friction there (not a presliding direction); tested by the viscous candidate.
        const bool viscous_at_neutral = lugre && (p.name == "sigma1" || p.name == "sigma2");
        if (repeats_viscous || repeats_coulomb || even_viscous || repeats_offset) {
          held.push_back(q);
        } else if (viscous_at_neutral) {
          held.push_back(q);
          c.refit.push_back(q);
        } else if (p.HasNeutral()) {
          c.screened.push_back(q);
          c.refit.push_back(q);
        } else {
          held.push_back(q);
          c.refit.push_back(q);
        }
      }
      if (std::string(kind.type) == "friction.stribeck" && !present("friction.coulomb")) {
        c.reduces_to.push_back("coulomb");
      }
      if (std::string(kind.type) == "friction.power_viscous" && !present("friction.viscous")) {
        c.reduces_to.push_back("viscous");
      }
      if (lugre) c.reduces_to.push_back("presliding");
      // With its constant part free it contains the constant offset (the other variant).
      if (kind.type == std::string(models::kAsymmetricFriction) &&
          !present(models::kOffsetFriction)) {
        c.reduces_to.push_back("asymmetric_friction");
      }
      if (std::string(kind.type) == "friction.stribeck") {
        c.shape_grids.push_back({c.instance + ".vs",
                                 Candidate::ShapeGrid::Scale::kStateRms,
                                 axis.velocity,
                                 {0.03, 0.1, 0.3, 1.0}});
      } else if (std::string(kind.type) == models::kDahlFriction) {
        c.shape_grids.push_back({c.instance + ".delta",
                                 Candidate::ShapeGrid::Scale::kStateRmsTimesSampleTime,
                                 axis.velocity,
                                 {1.0, 3.0, 10.0, 30.0}});
      } else if (std::string(kind.type) == "friction.power_viscous") {
        c.shape_grids.push_back(
            {c.instance + ".k", Candidate::ShapeGrid::Scale::kAbsolute, "", {0.3, 0.6, 2.0}});
      }
      const std::string instance = c.instance, velocity = axis.velocity,
                        connection = axis.connection;
      if (HasSteepnessGrid(kind.type)) {
        // The Stribeck excess takes the steepest sign of the grid alone: its hump lies at
        // velocities well below the RMS (the vs grid starts at 0.03 RMS, where 150 / RMS still
        // gives s vs = 4.5), and a softer sign flattens it into a Coulomb-like ramp.
        const bool stribeck = kind.type == std::string(models::kStribeckFriction);
        c.option_grids.push_back(
            {"steepness", Candidate::ShapeGrid::Scale::kStateRms, axis.velocity,
             stribeck ? std::vector<double>{150.0} : std::vector<double>{5.0, 30.0, 150.0}, true});
        const bool prismatic = axis.prismatic;
        const std::string type = kind.type;
        c.apply_with_option = [type, prismatic, instance, velocity, connection, held](
                                  models::Model* m, double steepness) {
          BlockOptions o = CandidateOptionsFor(type, prismatic);
          o.numbers["steepness"] = {steepness};
          m->Augment(
              instance,
              std::shared_ptr<const models::Block>(models::BlockRegistry::Global().Create(type, o)),
              {velocity}, {connection});
          for (const auto& q : held) m->Fix(q);
        };
      }
      c.augmentation = {models::Augmentation::Kind::kAdd,
                        c.instance,
                        kind.type,
                        CandidateOptionsFor(kind.type, axis.prismatic),
                        {axis.velocity},
                        {axis.connection},
                        "",
                        {},
                        {}};
      c.apply = [block, instance, velocity, connection, held](models::Model* m) {
        m->Augment(instance, block, {velocity}, {connection});
        for (const auto& q : held) m->Fix(q);
      };
      out.push_back(std::move(c));
    }
    for (const auto& input : wanted("input_delay") ? axis.inputs : std::vector<std::string>{}) {
      if (!delayed_inputs.insert(input).second) continue;
      // A named actuator may be a block output (an equation block's command): delayed for every
      // reader (InsertOnSignal); a model input that blocks add to is delayed alone.
      const auto& info = problem.built.signals[problem.built.SignalIndex(input)].info;
      BlockOptions o;
      o.words["unit"] = info.unit.empty() ? "1" : info.unit;
      // The Pade form: w in (0, 2) spans the lag (w = 1) and the all-pass (w = 2), so a first-order
      // lag and a transport delay both fit inside the bounds (with the lag form a pure delay ends
      // at w = 1, a bound, and the re-fit could not be ranked).
      o.words["form"] = "pade";
      if (info.typical_min < info.typical_max) {
        o.numbers["typical_range"] = {info.typical_min, info.typical_max};
      }
      Candidate c;
      c.effect = "input_delay";
      c.detail = "delay.first_order";
      const bool summed = IsModelInput(problem.built, input) && SummedInput(problem.built, input);
      c.attachment = "input " + input + (summed ? " (alone)" : "");
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
      c.family_ends.push_back(c.instance + ".w");
      c.shape_grids.push_back(
          {c.instance + ".T", Candidate::ShapeGrid::Scale::kSampleTime, "", {1.0, 2.5, 6.0, 15.0}});
      const std::string instance = c.instance;
      c.augmentation = {
          summed ? models::Augmentation::Kind::kOnInput : models::Augmentation::Kind::kOnSignal,
          c.instance,
          "delay.first_order",
          o,
          {},
          {},
          input,
          {},
          {}};
      c.apply = [block, instance, input, held, summed](models::Model* m) {
        if (summed) {
          m->InsertOnInput(input, instance, block);
        } else {
          m->InsertOnSignal(input, instance, block);
        }
        for (const auto& q : held) m->Fix(q);
      };
      out.push_back(std::move(c));
    }
    if (wanted("deadzone")) AddDeadzones(problem, axis, &taken, &deadzoned, &out);
    if (wanted("ripple")) AddRipples(problem, axis, resolved, &taken, &out);
    AddLoads(problem, axis, wanted("rotor_inertia"), wanted("payload"), wanted("elasticity"),
             &taken, &out);
  }
  if (wanted("backlash")) AddBacklash(problem, &taken, &out);
  AddChamberEffects(problem, wanted("leakage"), wanted("polytropic_index"), &taken, &out);
  for (const char* effect : {"sensor_offset", "sensor_scale"}) {
    if (wanted(effect)) AddSensors(problem, effect, &taken, &out);
  }
  return out;
}

}  // namespace graybox::diagnosis
