#include "graybox/diagnosis/candidates.h"

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
#include "graybox/models/transmission_effects.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::diagnosis {

using internal::AddBacklash;
using internal::AddChamberEffects;
using internal::AddDeadzones;
using internal::AddLoads;
using internal::AddRipples;
using internal::AddSensors;
using internal::BlockOptions;
using internal::CandidateOptionsFor;
using internal::FreshInstance;
using internal::HasSteepnessGrid;
using internal::IsModelInput;
using internal::kFrictionKinds;
using internal::SummedInput;

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

models::Augmentation AugmentationFor(const Candidate& candidate, const models::Model& model) {
  models::Augmentation a = candidate.augmentation;
  for (const auto& [option, parameter] : candidate.options_from_parameters) {
    const auto& ps = model.parameters();
    const std::string& wanted = parameter;  // a structured binding cannot be captured (C++17)
    const auto it = std::find_if(ps.begin(), ps.end(),
                                 [&](const models::ModelParameter& p) { return p.name == wanted; });
    if (it == ps.end()) {
      throw std::invalid_argument("AugmentationFor: candidate '" + candidate.instance +
                                  "' takes option '" + option + "' from parameter '" + parameter +
                                  "', which the model does not have");
    }
    a.options.numbers[option] = {it->value};
  }
  return a;
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
      // A power law at k = 1 is viscous friction; so is the Stribeck block at fc = fs = 0 with its
      // own fv, and LuGre at sigma0 = 0 (dz/dt = v, the force (sigma1 + sigma2) v), each re-fitted
      // with that term free where the axis has no viscous block.
      if ((std::string(kind.type) == "friction.power_viscous" ||
           std::string(kind.type) == "friction.stribeck" || lugre) &&
          !present("friction.viscous")) {
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
  if (wanted("backlash")) AddBacklash(problem, &out);
  AddChamberEffects(problem, wanted("leakage"), wanted("polytropic_index"), &taken, &out);
  for (const char* effect : {"sensor_offset", "sensor_scale"}) {
    if (wanted(effect)) AddSensors(problem, effect, &taken, &out);
  }
  return out;
}

}  // namespace graybox::diagnosis
