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
namespace {

using internal::Acceleration;
using internal::CandidateOptionsFor;
using internal::FreshInstance;
using internal::InstanceSignature;
using internal::kFrictionKinds;
using internal::MakeTestPoint;
using internal::Motion;
using internal::SignalRole;
using internal::SignalSource;
using internal::TestPoint;
using internal::TypeSignature;

// Relative agreement of dq/dt with v that makes q the axis' position (the same expression, so
// rounding only).
constexpr double kPositionMatchTolerance = 1e-12;

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

}  // namespace graybox::diagnosis
