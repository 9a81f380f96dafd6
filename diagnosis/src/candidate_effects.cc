#include "candidates_internal.h"

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
#include "graybox/util/did_you_mean.h"

namespace graybox::diagnosis::internal {

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

namespace {
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
}  // namespace

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
    std::vector<std::string> held = SplitParameters(*block, &c);
    // The period stays at the candidate's value in the re-fit too (one candidate per period).
    const std::string period_parameter = c.instance + ".period";
    c.refit.erase(std::remove(c.refit.begin(), c.refit.end(), period_parameter), c.refit.end());
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

namespace {
// The rigid body that integrates the axis force (mechanics.mass owning v and reading F), for the
// added-load candidates; empty when the axis has none.
struct RigidBody {
  std::string instance, mass;  // the instance and its inertia parameter
  bool mass_free = false;
};
}  // namespace

namespace {
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
}  // namespace

namespace {
// The inertias a drive block integrates inside its own torque balance, by the velocity state they
// belong to: the block's local parameter names and the effect a change of each stands for.
struct OwnedInertia {
  const char* type;      // block type
  const char* velocity;  // local name of the velocity state
  const char* parameter;
  const char* effect;
  const char* detail;
};
constexpr OwnedInertia kOwnedInertias[] = {
    {models::kTwoMassDrive, "qd_m", "J", "rotor_inertia", "motor-side inertia J freed"},
    {models::kTwoMassDrive, "qd_l", "I", "payload", "link-side inertia I freed"},
    {models::kDcMotorDrive, "omega", "J_rs", "rotor_inertia", "rotor inertia J_rs freed"},
    {models::kDcMotorDrive, "omega", "J_os", "payload", "output-shaft inertia J_os freed"},
};

// rotor_inertia and payload on an axis whose velocity state belongs to a drive block that holds
// its inertias inside (file comment): the fixed inertia parameter is freed at its current value.
void AddOwnedInertias(const estimators::Problem& problem, const MechanicalAxis& axis, bool inertia,
                      bool payload, std::vector<Candidate>* out) {
  const models::StateSpaceModel& built = problem.built;
  const auto& v = built.signals[built.SignalIndex(axis.velocity)];
  if (v.source != SignalSource::kState || v.blocks.size() != 1) return;
  for (const auto& b : problem.model.Blocks()) {
    if (b.instance != v.blocks[0]) continue;
    std::vector<const OwnedInertia*> owned;
    for (const OwnedInertia& o : kOwnedInertias) {
      if (b.type == o.type && axis.velocity == b.instance + "." + o.velocity) owned.push_back(&o);
    }
    // Another inertia of the same balance already free is the same unknown: none is proposed.
    bool any_free = false;
    for (const OwnedInertia* o : owned) {
      any_free =
          any_free || built.parameters[built.ParameterIndex(b.instance + "." + o->parameter)].free;
    }
    if (any_free) return;
    for (const OwnedInertia* o : owned) {
      const std::string effect = o->effect;
      if ((effect == "rotor_inertia" && !inertia) || (effect == "payload" && !payload)) continue;
      const std::string name = b.instance + "." + o->parameter;
      Candidate c;
      c.effect = effect;
      c.detail = o->detail;
      c.attachment = "inertia " + name + " of velocity " + axis.velocity;
      c.instance = b.instance;
      c.parameters = {name};
      c.screened = {name};
      c.refit = {name};
      c.apply = [name](models::Model* m) { m->Free(name); };
      out->push_back(std::move(c));
    }
    return;
  }
}
}  // namespace

// rotor_inertia and payload (file comment).
void AddLoads(const estimators::Problem& problem, const MechanicalAxis& axis, bool inertia,
              bool payload, bool elasticity, std::set<std::string>* taken,
              std::vector<Candidate>* out) {
  const RigidBody body = FindRigidBody(problem, axis);
  if (body.instance.empty()) {
    AddOwnedInertias(problem, axis, inertia, payload, out);
    return;
  }
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
    // The elastic split keeps the axis' total inertia M_tot: the motor side takes the share s,
    // J = s M_tot, the body (the load side) M = (1 - s) M_tot, so J + M = M_tot. The first share
    // is the block's nominal J = r M (r = kDefaultCouplingInertiaRatio): s = r / (1 + r).
    const double first_share =
        models::kDefaultCouplingInertiaRatio / (1.0 + models::kDefaultCouplingInertiaRatio);
    if (is_elastic) {
      // No score test; the stiffness profiled over modes at 1, 2, 4 and 8 % of the sample rate
      // (K = (2 pi f)^2 J_eff, J_eff = J M / (J + M) = r M_tot / (1 + r)^2 at the split).
      c.structural = true;
      const double r = models::kDefaultCouplingInertiaRatio;
      std::vector<double> factors;
      for (const double f : {0.01, 0.02, 0.04, 0.08}) {
        factors.push_back(std::pow(2.0 * M_PI * f, 2) * r / ((1.0 + r) * (1.0 + r)) * mass_now);
      }
      c.shape_grids.push_back(
          {c.instance + ".K", Candidate::ShapeGrid::Scale::kSampleRateSquared, "", factors});
      // How the inertia splits, a structural choice: the motor side's share of the total.
      c.option_grids.push_back({kMotorShareOption,
                                Candidate::ShapeGrid::Scale::kAbsolute,
                                "",
                                {first_share, 0.45, 0.7}});
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
    // Elasticity reads the body's inertia too (its split); it has no declarative form.
    if (is_elastic) c.options_from_parameters = {{"axis_inertia", body.mass}};
    if (!is_elastic) {
      c.augmentation = {models::Augmentation::Kind::kForReaders,
                        c.instance,
                        var.type,
                        options(mass_now),
                        {},
                        {},
                        axis.force,
                        {body.instance},
                        extra};
      c.options_from_parameters = {{"axis_inertia", body.mass}};
    }
    const std::string position = axis.position, velocity = axis.velocity;
    const std::string unit = prismatic ? "m" : "rad";
    // The controllers that also read the axis velocity read the motor side's qd + ed.
    std::vector<std::string> velocity_readers;
    for (const auto& b : problem.model.Blocks()) {
      if (std::find(controllers.begin(), controllers.end(), b.instance) != controllers.end() &&
          std::find(b.inputs.begin(), b.inputs.end(), velocity) != b.inputs.end()) {
        velocity_readers.push_back(b.instance);
      }
    }
    // `share`: the elastic split's motor share (unused by the other loads).
    auto apply_share = [options, instance, force, reader, mass, type, extra, held, is_elastic,
                        motor_feedback, position, velocity, controllers, velocity_readers,
                        unit](models::Model* m, double share) {
      // The body's inertia as the model has it now (the nominal fit's value in screening).
      const double total = m->Parameter(mass).value;
      double body_inertia = total;
      if (is_elastic) {
        // The split of the total (above), the body's inertia held there: the coupling's
        // deflection equation uses it as the option M, which a re-fit that moved the body's
        // parameter would leave stale (loads.h); J, free, carries a change of the total.
        body_inertia = (1.0 - share) * total;
        m->SetParameter(mass, body_inertia);
        m->Fix(mass);
      }
      const auto b = std::shared_ptr<const models::Block>(
          models::BlockRegistry::Global().Create(type, options(body_inertia)));
      m->InsertForReaders(force, instance, b, {reader}, extra);
      if (is_elastic) {
        // J at the share; K and c give the block's nominal mode (frequency and damping ratio).
        const double j = share * total, j_eff = j * body_inertia / (j + body_inertia);
        const double w0 = 2.0 * M_PI * models::kDefaultCouplingFrequency;
        m->SetParameter(instance + ".J", j);
        m->SetParameter(instance + ".K", w0 * w0 * j_eff);
        m->SetParameter(instance + ".c", 2.0 * models::kDefaultCouplingDamping * w0 * j_eff);
      }
      for (const auto& q : held) m->Fix(q);
      if (motor_feedback) {
        // The controllers read the motor side: position q + e (a unit gain in series on q for
        // them, and the deflection e added to its output) and, where they read the velocity,
        // qd + ed the same way (a loop closed on the motor's position but the load's velocity
        // is a non-collocated loop, unstable at a drive's gains).
        auto motor_side = [m, &instance](const std::string& signal, const std::string& suffix,
                                         const std::string& state, const std::string& signal_unit,
                                         const std::vector<std::string>& readers) {
          BlockOptions g;
          g.words["input_unit"] = signal_unit;
          g.words["output_unit"] = signal_unit;
          const std::string gain = instance + "_motor_" + suffix;
          m->InsertForReaders(signal, gain, models::kGainBlock, g, readers);
          m->Augment(instance + "_" + state, models::kGainBlock, g, {instance + "." + state},
                     {gain + ".out"});
          m->Fix(gain + ".k");
          m->Fix(instance + "_" + state + ".k");
        };
        motor_side(position, "q", "e", unit, controllers);
        if (!velocity_readers.empty()) {
          motor_side(velocity, "qd", "ed", unit + "/s", velocity_readers);
        }
      }
    };
    c.apply = [apply_share, first_share](models::Model* m) { apply_share(m, first_share); };
    if (is_elastic) c.apply_with_option = apply_share;
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
      c.augmentation = {models::Augmentation::Kind::kAdd,
                        c.instance,
                        models::kChamberLeak,
                        {},
                        {pressure},
                        {"-" + mdot},
                        "",
                        {},
                        {}};
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
      BlockOptions now;
      now.numbers["temperature"] = {built.parameters[built.ParameterIndex(temperature)].value};
      c.augmentation = {models::Augmentation::Kind::kForReaders,
                        c.instance,
                        models::kPolytropicCorrection,
                        now,
                        {},
                        {},
                        mdot,
                        {chamber},
                        {pressure, rate}};
      c.options_from_parameters = {{"temperature", temperature}};
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
void AddBacklash(const estimators::Problem& problem, std::vector<Candidate>* out) {
  const models::StateSpaceModel& built = problem.built;
  for (const auto& b : problem.model.Blocks()) {
    if (b.type != models::kTwoMassDrive) continue;
    bool has_backlash = false;
    for (const auto& p : built.parameters)
      has_backlash = has_backlash || p.name == b.instance + ".b";
    if (has_backlash) continue;
    const std::string joint = b.instance;
    const std::string motor = b.inputs[0].empty() ? "(none)" : b.inputs[0];
    const std::string load = b.inputs[1].empty() ? "(none)" : b.inputs[1];
    Candidate c;
    c.effect = "backlash";
    c.detail = "drive.two_mass backlash form";
    c.attachment = "joint " + joint + " (torques " + motor + ", " + load + ")";
    c.instance = joint;
    const std::string gap = joint + ".b";
    c.parameters = {gap};
    c.screened = {gap};
    c.refit = {gap};
    // The joint in its backlash form, the same element with the same parameters and one more:
    // exact at b = 0 and consistent when a re-fit moves Ke and d (the reported tau_s included).
    BlockOptions options;
    options.numbers["backlash"] = {1};
    const auto& q_m = built.states[built.StateIndex(joint + ".q_m")];
    if (q_m.unit == "m") options.words["motion"] = "prismatic";
    c.apply = [joint, options](models::Model* m) {
      m->ReplaceBlock(joint, models::kTwoMassDrive, options);
    };
    out->push_back(std::move(c));
  }
}

}  // namespace graybox::diagnosis::internal
