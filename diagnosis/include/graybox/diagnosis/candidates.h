// Candidates: the unmodelled effects the diagnosis can add to a model, found from the model's own
// metadata, each an augmentation that leaves the model unchanged at its neutral value.
//
//   const std::vector<Candidate> candidates = EnumerateCandidates(problem);
//   models::Model m = problem.model;
//   candidates[0].apply(&m);               // m's outputs equal problem.model's until the new
//   StateSpaceModel built = m.Build();     // parameters move away from their neutral values
//
// ---- Mechanical axes, from metadata
// -------------------------------------------------------------- An axis is a pair (velocity v,
// force F) of signals of the built model (StateSpaceModel::signals) with
//   - v of role kVelocity and a state (its acceleration is the model's xdot), in "m/s" (prismatic
//     axis) or "rad/s" (rotational axis);
//   - F of role kForce, an external input or a sum of block outputs (a state is written only by
//     its own block), acting on v: a probe viscous friction block reading v and writing "-F"
//     (exactly how the friction blocks are wired: they read the velocity and subtract their
//     force) decelerates v. This is tested numerically on a copy of the model: with the probe's
//     coefficient at 0 and 1, the difference of dv/dt at a test point (every state at the middle
//     of its typical range, v at 0.5 of its typical maximum, inputs 0, the model's parameter
//     values) must be negative. When it is positive the model's sign convention is the other
//     one and the candidates write "+F" instead; when it is zero, F does not act on v.
// When several forces act on one velocity, the one written by an existing friction-family block
// is taken (else the first in signal order): one axis per velocity state.
//
// A friction-family block is "present on the axis" when one of the blocks producing F
// (SignalDescription::blocks) is of that type: by Problem::blocks when the problem lists its
// instances (problem files do), else by the instance's parameter signature (the set of local
// parameter names and units equals that of the type, created with the axis' `motion`).
//
// ---- The candidates (effect names as in issue 10)
// ------------------------------------------------ On every axis, skipping a type already present
// there, Model::Augment with a fresh instance name
// ("<effect>", "<effect>_2", ...; never an existing instance or signal prefix):
//   coulomb              friction.coulomb       fc free (neutral 0); the smoothing steepness
//                                               is the block's fixed option (100 s/rad or s/m,
//                                               kDefaultFrictionSteepness), not a parameter: a
//                                               free steepness runs to a hard sign in re-fits
//   asymmetric_friction  friction.offset        f_asym free (neutral 0)
//   stribeck             friction.stribeck      fc, fs free (neutral 0); vs held at nominal; fv
//                                               held at 0 when friction.viscous is on the axis
//                                               (it would repeat that term), else free
//   viscous              friction.viscous       fv free (neutral 0)
//   power_law_viscous    friction.power_viscous fv free (neutral 0); the exponent k held at its
//                                               nominal 1 for screening (its direction then
//                                               coincides with viscous friction), freed to re-fit
//   presliding           friction.dahl          sigma0 free (neutral 0); fc held at nominal;
//                                               detail "dahl"
// each reading v and writing "-F" (or "+F", above), with the block's `motion` option set from v's
// unit; and, for every external input that no block adds to and whose value changes dv/dt at the
// test point (a model input that feeds the axis directly), input_delay: Model::InsertOnSignal of
// "delay.first_order" (w free, neutral 0; T held at its nominal), with the input's unit and
// typical range as options. States a candidate adds (Dahl's z, the delay's x) start at 0 in every
// split (screening.h). An input that blocks also write to (a force input friction subtracts
// from) is not delayed: a delay there would delay the friction too.
//
// Parameters without a neutral value (shapes: a steepness, a Stribeck velocity, a time constant)
// cannot be tested at the neutral point: Candidate::screened lists what the score test frees,
// Candidate::refit what a re-fit frees. Everything in `parameters` outside `refit` stays at the
// value Augment gave it.
//
// Not yet proposed here: backlash, deadzone, elasticity, ripple, payload, rotor_inertia,
// sensor_offset, sensor_scale, leakage, polytropic_index, LuGre presliding, structural choices.
//
// Failure behaviour. An unknown name in CandidateOptions::effects throws std::invalid_argument
// with a did-you-mean. A model without an axis gives no candidates (not an error).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"

namespace graybox::diagnosis {

/// One candidate effect: an augmentation of the model at its neutral value.
struct Candidate {
  /// The effect's name from issue 10's list: "coulomb", "asymmetric_friction", "stribeck",
  /// "viscous", "power_law_viscous", "presliding", "input_delay".
  std::string effect;
  /// The variant or block: "dahl" for presliding, else the block type ("friction.coulomb").
  std::string detail;
  /// Where it attaches: "velocity load.qd -> force force" or "input u".
  std::string attachment;
  /// The new block's instance name.
  std::string instance;
  /// Adds the block to a copy of the problem's model (parameters at their neutral values, those
  /// held at their nominal fixed). Apply to a model equal to problem.model, once.
  std::function<void(models::Model*)> apply;
  /// Qualified names of every new parameter, in the block's order.
  std::vector<std::string> parameters;
  /// Free in the score test (neutral value, not a repeat of a term the axis has).
  std::vector<std::string> screened;
  /// Free in a re-fit: `screened` plus the shape parameters held for the test.
  std::vector<std::string> refit;
  /// "<effect> (<detail>) on <attachment>".
  std::string Name() const;
};

struct CandidateOptions {
  /// Effects to propose (names as in Candidate::effect); empty: every effect this layer knows.
  std::vector<std::string> effects;
  /// Throws std::invalid_argument for an unknown effect name (with a did-you-mean).
  void Validate() const;
};

/// A mechanical axis found from metadata (see the file comment).
struct MechanicalAxis {
  std::string velocity;    // a state signal of role velocity
  std::string force;       // the force signal acting on it
  std::string connection;  // "-force" (the usual convention) or "force"
  bool prismatic = false;  // velocity in m/s (else rad/s)
  /// External inputs feeding the axis that no block writes to (input_delay attaches there).
  std::vector<std::string> inputs;
  /// Block types present on the axis (friction family only, by Problem::blocks or signature).
  std::vector<std::string> present_types;
};

/// The axes of problem.model (see the file comment).
std::vector<MechanicalAxis> FindAxes(const estimators::Problem& problem);

/// Every applicable candidate on every axis, in axis order, then the order of the table above.
std::vector<Candidate> EnumerateCandidates(const estimators::Problem& problem,
                                           const CandidateOptions& options = {});

}  // namespace graybox::diagnosis
