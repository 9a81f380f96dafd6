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
// When several forces act on one velocity (in a coupled multibody every joint torque moves every
// joint), the one written by a friction-family block that reads v is taken; else one written by
// any block that reads v; else the one whose probe changes dv/dt the most: one axis per velocity
// state.
//
// Named axes. A problem's [diagnosis] table (estimators::DiagnosisSpec, docs/problem-format.md)
// can name axes by hand, [[diagnosis.axes]] velocity, force, position, motion, sign, inputs: a
// named axis on a velocity replaces the metadata's axis there, and with metadata_axes = false the
// named axes are the only ones (in state order either way). Its velocity may be any state (a
// generic integrator's output); what is not given is found as above: the sign by the probe (an
// error naming the entry when the force does not act on the velocity), the position as the state
// in m or rad (X for a velocity in X/s) whose derivative is v, the inputs by their effect on
// dv/dt. Named `inputs` may be block outputs too, and are then the only actuator commands of the
// axis (input_delay in series on the signal for every reader, deadzone for its readers). The table
// also selects effects (SelectedEffects), ripple periods, LuGre, and the sensor channels.
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
//                                               is the block's fixed option, not a parameter (a
//                                               free steepness runs to a hard sign in re-fits),
//                                               chosen by the screening among 5, 30 and 150
//                                               over the RMS of the axis velocity
//                                               (Candidate::option_grids; without data the
//                                               block's default, 100 s/rad or s/m)
//   asymmetric_friction  friction.offset        f_asym free (neutral 0): a constant force
//   asymmetric_friction  friction.asymmetric    f0, fd free (neutral 0): a constant part and
//                                               Coulomb levels that differ by direction (zero
//                                               at rest); f0 held at 0 when friction.offset is
//                                               on the axis, else the variant reduces to the
//                                               constant offset (Candidate::reduces_to); fvd
//                                               (the even viscous term) held at 0; the
//                                               steepness chosen like the Coulomb candidate's
//   stribeck             friction.stribeck      fc, fs free (neutral 0); vs held at nominal
//                                               for the test, freed to re-fit; fv held at 0
//                                               when friction.viscous is on the axis (it would
//                                               repeat that term), else free; fc likewise held
//                                               at 0 when friction.coulomb is on the axis: the
//                                               block is then the Stribeck excess
//                                               fs exp(-(v/vs)^2) sign(v) alone; the sign's
//                                               steepness 150 over the RMS of the axis velocity
//                                               (the steepest of the Coulomb grid: a softer
//                                               sign flattens the hump)
//   viscous              friction.viscous       fv free (neutral 0)
//   power_law_viscous    friction.power_viscous fv free (neutral 0); the exponent k held at its
//                                               nominal 1 for screening (its direction then
//                                               coincides with viscous friction), freed to re-fit
//   presliding           friction.dahl          in its presliding-length form (option form =
//                                               "length", friction.h): fc free (neutral 0; at
//                                               fc = 0 the direction is a sign smoothed by the
//                                               hysteresis, where the stiffness form's sigma0
//                                               direction is a spring on the position); the
//                                               length delta held for the test and freed to
//                                               re-fit, its start chosen among 1, 3, 10 and 30
//                                               times RMS(v) x dt (a presliding regime lasting
//                                               that many samples); detail "dahl"
//   presliding           friction.lugre         with CandidateOptions::lugre_presliding only;
//                                               detail "lugre". sigma0 screened (neutral 0);
//                                               sigma1 held at 0 for the test, freed to re-fit;
//                                               sigma2 likewise, but held at 0 in the re-fit too
//                                               when friction.viscous is on the axis; fc, fs, vs
//                                               held at nominal (seed 002's eSEA values), freed
//                                               to re-fit. At sigma0 = 0 the bristle integrates
//                                               the position (dz/dt = v), so sigma1 and sigma2
//                                               act as viscous friction there and the
//                                               direction of sigma0 is a spring on the
//                                               position, a poor test of presliding (hence
//                                               opt-in; Dahl's length form is the screened
//                                               presliding candidate)
// each reading v and writing "-F" (or "+F", above), with the block's `motion` option set from v's
// unit; and, for every external input that no block adds to and whose value changes dv/dt at the
// test point (a model input that feeds the axis directly), input_delay: Model::InsertOnSignal of
// "delay.first_order" in its "pade" form (w free in (0, 2), neutral 0: the lag 1/(1 + sT) at w = 1,
// the Pade all-pass of the delay 2T at w = 2, so a lag and a transport delay both fit inside the
// bounds; T held at its nominal), with the input's unit and typical range as options. States a
// candidate adds (Dahl's z, the delay's x) start at 0 in every split (screening.h). An input that
// blocks also write to (a force input friction subtracts from) is delayed alone, before their
// contributions (Model::InsertOnInput; attachment "input <u> (alone)"), so the friction stays
// undelayed.
//
// Parameters without a neutral value (shapes: a steepness, a Stribeck velocity, a time constant)
// cannot be tested at the neutral point: Candidate::screened lists what the score test frees,
// Candidate::refit what a re-fit frees. Everything in `parameters` outside `refit` stays at the
// value Augment gave it. A block's nominal shape is not this machine's (seed 002's Stribeck
// velocity is 0.17 rad/s; a drive's may be 0.02 m/s), and where the shape is far off the test
// looks in the wrong direction and the re-fit cannot recover (at a zero level the shape has no
// gradient). So shapes that scale with the data get a grid (Candidate::shape_grids) and the
// screening keeps the value that scores best: the Stribeck velocity vs at 0.03, 0.1, 0.3 and 1
// times the RMS of the axis velocity; the exponent k of power_law_viscous at 0.3, 0.6 and 2 (at
// its nominal 1 the direction is viscous friction's); the delay's time constant T at 1, 2.5, 6
// and 15 sample times.
//
// ---- Actuator, position, load and sensor effects (models/sensors.h, friction.h, loads.h) ------
//   deadzone       actuator.deadzone  b free (neutral 0, the exact pass-through; lower bound 0);
//                                     smoothing eps = 1e-3 of the command's typical magnitude.
//                  In series on an actuator command, Model::InsertForReaders: (a) every input of
//                  the axis' `inputs` (read by every block that reads it), (b) every input signal
//                  of a block that writes F and is not of a "friction." type (the drive gain of a
//                  closed loop reads the controller output), except states and signals of role
//                  position, velocity or acceleration, read by that block only. The model's outputs
//                  keep the command (a logged controller output is the command before the dead
//                  zone). A signal gets one dead zone. On a force input that friction writes to
//                  the dead zone acts on the input alone (Model::InsertOnInput; attachment
//                  "command <u> (input alone) -> <readers>"), as for input_delay. Detail
//                  "actuator.deadzone", attachment "command <signal> -> <readers>".
//   ripple         friction.ripple    a1, b1 free (neutral 0; amplitude and phase, both linear),
//                                     one harmonic, period P an option (held in the re-fit too).
//                  On every axis with a position: a state in m (rad), of role position or none,
//                  whose time derivative is v (dq/dt equals v at the test point and at a second
//                  value of v, to 1e-12 relative). Reads the position, writes "-F" (or "+F"). One
//                  candidate per period: CandidateOptions::ripple_periods when given; else the
//                  axis' entry of CandidateOptions::ripple_periods_by_position, which
//                  ScreenAndRefit fills with the peaks of the nominal residuals' periodogram
//                  against the position (ScanPeriods, period_scan.h: 4 periods, whole numbers per
//                  turn on a rotational axis); else (no data, or a position that does not move)
//                  the span typical_max - typical_min of the position (2 pi rad on a rotational
//                  axis) over 1, 2, 4 and 8. Detail "period <P> <m|rad>". The period cannot be
//                  screened by a score test (the output does not depend on it at a zero
//                  amplitude), hence one candidate per period: the best score picks among those
//                  proposed, and the scan proposes them from the data. A ripple seen over a short
//                  stroke looks to first order like a constant force (the axis lingers at its
//                  turning points): screen it on data that travel several periods.
//   rotor_inertia  mechanics.added_inertia  dM free (neutral 0, >= 0): the body reads
//                  F / (1 + dM / M) (models/loads.h: an extra inertia enters as a scaling of the
//                  whole net force at its one reader; writing -dM dv/dt into F is an algebraic
//                  loop, scaling one contribution of the sum is wrong). Model::InsertForReaders on
//                  F for the rigid body only, on axes whose velocity state is owned by a
//                  mechanics.mass that reads F (not drive.two_mass, drive.dc_motor: their torque
//                  balances are inside the block). M (option axis_inertia) is the body's inertia
//                  parameter's value when the candidate is applied (the nominal fit's in
//                  screening). Proposed only when that parameter is fixed (next to a free inertia
//                  dM is the same unknown) and on rotational axes (a sliding body has no rotor: its
//                  added mass is a payload). Detail "mechanics.added_inertia", attachment "force
//                  F -> <body>".
//                  On an axis whose velocity state belongs to a drive block that integrates its
//                  inertias inside its own torque balance, the block's fixed inertia parameter
//                  itself is freed at its current value (a freed parameter: Candidate::parameters
//                  names it, Candidate::instance is the block; no block is added and the model is
//                  unchanged at the start value): drive.two_mass J on qd_m (rotor_inertia, detail
//                  "motor-side inertia J freed"), drive.dc_motor J_rs on omega ("rotor inertia
//                  J_rs freed"). Proposed only when no inertia of that balance is free
//                  (drive.two_mass J and I are two balances; drive.dc_motor's J_rs and J_os are
//                  one). Attachment "inertia <parameter> of velocity <v>". No declarative form: the
//                  re-run is the parameter made free in [model.parameters] (diagnosis.json's
//                  parameter lines).
//   payload        mechanics.payload  on the same bodies, reading the axis position too:
//                  rotational: (F - g_s sin q - g_c cos q) / (1 + dM / M), g_s, g_c, dM free
//                  (neutral 0; dM held at 0 when the body's inertia is free, as above), detail
//                  "rotational"; its gravity part equals a ripple of period 2 pi, the inertia
//                  tells them apart. Prismatic, only when the body's mass is fixed (next to a
//                  free mass m repeats it and m g_q alone is a constant force, which
//                  asymmetric_friction's constant offset proposes): (F + m g_q) / (1 + m / M), m
//                  free (neutral 0), detail "horizontal, added mass" (g_q = 0), "vertical, q up"
//                  (g_q = -9.81) and "vertical, q down" (+9.81): the score test sees the vertical
//                  two alike (a sign), the re-fit keeps the one with m >= 0 interior. On a rigid
//                  axis an added mass cannot be told from a reflected rotor inertia; the name
//                  says where it is on a sliding body. Attachment "force F -> <body>, position q".
//                  On the drive blocks above, the load-side inertia freed: drive.two_mass I on
//                  qd_l (detail "link-side inertia I freed"), drive.dc_motor J_os on omega
//                  ("output-shaft inertia J_os freed"); inertia only, no gravity term (those
//                  blocks' loads are horizontal in their equations; a gravity load on a
//                  drive.two_mass link is not proposed).
//   backlash       drive.two_mass in its backlash form (option backlash = 1, drives.h), b free
//                  (neutral 0, >= 0): on every drive.two_mass that has no backlash parameter, the
//                  block is replaced by its backlash form with the same connections and
//                  parameters (Model::ReplaceBlock; a freed parameter: Candidate::instance is the
//                  joint, Candidate::parameters "<joint>.b"). Exact at b = 0 and consistent when a
//                  re-fit moves Ke and d, the reported joint torque tau_s included (a torque
//                  sensor in the spring reads zero inside the gap; the correction block
//                  transmission.backlash with Ke frozen at the nominal fit's value closed 17 % of
//                  a hard backlash's gap where this form closes it). Detail "drive.two_mass
//                  backlash form", attachment "joint <j> (torques <tau_m>, <tau_ext>)". No
//                  declarative form: the re-run is the joint's block with options
//                  { backlash = 1 } and b free.
//   leakage        pneumatic.leak     G free (neutral 0): a laminar leak G (p - p_atm) out of
//                  every pneumatic.chamber: reads the chamber's pressure state, writes "-mdot" on
//                  the chamber's net-inflow signal (its first input). Attachment "chamber <c>
//                  (flow <mdot>)", detail "pneumatic.leak" (models/chamber_effects.h).
//   polytropic_index  pneumatic.polytropic_correction  e free (neutral 0): the chamber's exponent
//                  becomes n (1 + e). The chamber's pressure is its own state, so the change acts
//                  on its inflow, Model::InsertForReaders of (1 + e) mdot - e p Vdot / (R T) on the
//                  mdot signal for the chamber only (also reading its pressure and volume rate),
//                  with T the chamber's temperature parameter's value when applied and R air's.
//                  Proposed only when the chamber's polytropic_exponent is fixed: a free one is
//                  this unknown already (freeing the fixed exponent is the same unknown; the
//                  block keeps the nominal exponent visible beside the correction e).
//   sensor_offset  sensor.offset      b free (neutral 0): y_meas = y + b
//   sensor_scale   sensor.scale       s free (neutral 0): y_meas = (1 + s) y
//                  On every output channel (Model::Outputs), with the channel's unit and typical
//                  range, Model::InsertOnOutput: the channel reports the sensor block's output and
//                  keeps its name (data, output weights and reports name channels). Two variants:
//                  detail "<type>, output": the output only, the physics keeps reading the true
//                  signal; "<type>, output and feedback", proposed when blocks of a "control." type
//                  read the channel's signal: those controllers read the sensor block's output
//                  too. Why both: physically a controller reads a sensor, and in closed loop an
//                  offset on that sensor moves the plant (the loop regulates q + b to the
//                  reference, so q = qr - b and the logged q + b follows qr), while an offset on a
//                  logged channel alone does not; but the metadata cannot tell whether the logged
//                  channel is the controller's sensor (a motor encoder in the loop, a load encoder
//                  logged), so the two hypotheses are scored separately. Friction and other
//                  physics blocks never read the sensor. Mind what data can show: without
//                  position-dependent forces (ripple, gravity) the feedback variant is the nominal
//                  loop shifted by -b (the logged channels are the nominal ones from a shifted
//                  start, candidates_test), so its score is near 0 unless such forces or another
//                  sensor see the shift; the output-only offset is seen against the reference.
//
// Default set. An empty CandidateOptions::effects proposes DefaultEffects(): every effect but
// elasticity (structural re-fits of a stiff two-mass model in every round, no score test to skip
// them, each run to its budget: two per axis on a closed loop; name it in `effects` when a
// resonance is suspected), and of those every one whose
// signals the model has. That is many score tests (on a single axis with two outputs about 20:
// 4 ripple candidates per axis, 2 to 4 sensor candidates per channel), which costs time and raises
// the chance that some candidate looks significant by accident; the diagnosis (diagnose.h)
// therefore accepts an effect only when its re-fit also lowers the validation error by a margin.
// Name a subset in `effects` to screen fewer.
//
//   elasticity     mechanics.elastic_coupling  (models/loads.h) structural: the rigid body
//                  becomes a two-mass axis, a motor-side inertia J and a spring-damper K, c
//                  between the net force F and the body, Model::InsertForReaders on F for the
//                  body only (every force in F then acts on the motor side; friction blocks keep
//                  reading the body's velocity). On the same bodies as rotor_inertia, free inertia
//                  or not. The split keeps the axis' total inertia M_tot (the body's value when
//                  applied): the motor side gets J = s M_tot, the body (load side) M = (1 - s)
//                  M_tot, held there, so the two-mass axis starts as heavy as the rigid one; J,
//                  free in the re-fit, carries a change of the total. The body's inertia is held
//                  because the block's deflection equation reads it as its option M, which a
//                  re-fit moving the parameter would leave stale (the deflection would then not be
//                  q_m - q). How the inertia splits is the candidate's option grid
//                  (kMotorShareOption): s = 0.2 (apply(); the block's nominal J = M / 4), 0.45 and
//                  0.7, each with K and c at the block's nominal mode (20 Hz, damping ratio 0.1).
//                  No parameter has a neutral value (the rigid limit is K -> infinity), so there
//                  is no score test: Candidate::structural, re-fitted in every round with J, K, c
//                  held first while K is profiled over modes at 1, 2, 4 and 8 % of the sample
//                  rate (ShapeGrid kSampleRateSquared; the same K values at the other shares, where
//                  the larger J_eff puts their modes at 0.80 and 0.87 x those frequencies), then
//                  freed (screening.h; always a contender). Its likelihood-ratio test counts J,
//                  K, c and the split as estimated whether freed or held at the grids' choice,
//                  less the body's inertia it holds (diagnose.h). The re-fit's parameters_toml
//                  gives the body's held inertia first (options_from_parameters). Detail "two-mass,
//                  force on the motor side", attachment "force F -> <body>". Where controllers read
//                  the axis position, a second variant "two-mass, force and feedback on the motor
//                  side" closes their loop on the motor side: they read q + e and, those that read
//                  the axis velocity, qd + ed (unit gains in series, fixed). Not proposed: an
//                  elastic transmission where the data log the motor side (the motor position q + e
//                  is not an output of the block). No declarative form (Candidate::augmentation
//                  empty): the re-run sets the body's inertia to the split (its line in
//                  parameters_toml) and adds the coupling.
//
// Structural choices are the variants above (sensor with or without feedback, payload direction,
// presliding Dahl or LuGre, ripple period, the Coulomb smoothing); friction on the motor or the
// load side of a drive.two_mass is the friction family on each of its two axes (qd_m and qd_l are
// separate axes, each with its own candidates, the attachment naming the side).
//
// Failure behaviour. An unknown name in CandidateOptions::effects throws std::invalid_argument
// with a did-you-mean; so does a ripple period that is not finite and > 0. A model without an
// axis, chamber or output gives no candidates (not an error).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "graybox/estimators/fit/fit.h"
#include "graybox/models/augmentation.h"
#include "graybox/models/model.h"

namespace graybox::diagnosis {

/// The option of the elasticity candidate's grid (Candidate::option_grids): the motor side's
/// share of the axis' total inertia (file comment).
inline constexpr char kMotorShareOption[] = "motor_share";

/// One candidate effect: an augmentation of the model at its neutral value.
struct Candidate {
  /// The effect's name from issue 10's list: "coulomb", "asymmetric_friction", "stribeck",
  /// "viscous", "power_law_viscous", "presliding", "input_delay", "deadzone", "ripple",
  /// "rotor_inertia", "payload", "elasticity", "backlash", "leakage", "polytropic_index",
  /// "sensor_offset", "sensor_scale".
  std::string effect;
  /// The variant or block: "dahl" or "lugre" for presliding, "period 0.0625 m" for ripple,
  /// "sensor.offset, output" (or ", output and feedback") for the sensors, else the block type
  /// ("friction.coulomb").
  std::string detail;
  /// Where it attaches: "velocity load.qd -> force force", "input u", "command nu -> drive",
  /// "position load.q -> force force" or "output load.q [and controller c]".
  std::string attachment;
  /// The new block's instance name (for a freed parameter of the model: the block that owns it).
  std::string instance;
  /// Adds the block to a copy of the problem's model (parameters at their neutral values, those
  /// held at their nominal fixed). Apply to a model equal to problem.model, once.
  std::function<void(models::Model*)> apply;
  /// Qualified names of every new parameter, in the block's order (or of the model's parameter
  /// the candidate frees).
  std::vector<std::string> parameters;
  /// Free in the score test (neutral value, not a repeat of a term the axis has).
  std::vector<std::string> screened;
  /// Free in a re-fit: `screened` plus the shape parameters held for the test.
  std::vector<std::string> refit;
  /// Parameters of `refit` whose bounds are ends of the effect's family rather than limits of the
  /// search (the delay's weight w: 1 is the pure lag, 2 the Pade all-pass): a re-fit that ends
  /// there has fitted that member, not run into a degenerate corner, and is ranked (it is still
  /// reported at its bound parameter by parameter).
  std::vector<std::string> family_ends;
  /// A shape parameter (one of `refit` not in `screened`) whose starting value the screening
  /// chooses from the data: the score test runs once per value, factor * scale, and keeps the
  /// value with the largest score (the re-fit starts there).
  struct ShapeGrid {
    enum class Scale {
      kAbsolute,    // scale 1: the factors are the values
      kStateRms,    // the root mean square of `state` over the nominal model's simulation of the
                    // estimation splits
      kSampleTime,  // the sample time of the first estimation split
      kSampleRateSquared,  // 1 / (sample time)^2: a stiffness K = (2 pi f)^2 J_eff of a mode at
                           // f = f_rel / dt has factor (2 pi f_rel)^2 J_eff
      kStateRmsTimesSampleTime,  // kStateRms times the sample time: a distance travelled in a
                                 // few samples at the typical velocity (a presliding length)
    };
    std::string parameter;
    Scale scale = Scale::kAbsolute;
    std::string state;
    std::vector<double> factors;
  };
  std::vector<ShapeGrid> shape_grids;
  /// Simpler effects this one contains at some parameter values (a Stribeck curve with its own
  /// Coulomb level at fs = fc is Coulomb friction, with its own viscous term at fs = fc = 0
  /// viscous friction; a power law at k = 1 and LuGre at sigma0 = 0 are viscous friction; the
  /// two-level asymmetric friction contains the constant offset; a rotational payload without
  /// gravity is a rotor inertia): the ranking prefers them when they fit about as well
  /// (screening.h).
  std::vector<std::string> reduces_to;
  /// A block option chosen from the data like a shape grid: the score test runs with the
  /// candidate applied by apply_with_option(model, value) for each value = factor / scale
  /// (`inverse`) or factor * scale (ShapeGrid::Scale) and keeps the best; the re-fit keeps it.
  /// The smoothing steepness of the Coulomb and direction-dependent blocks is one (an option, not
  /// a parameter: freed, it runs to a hard sign): 5, 30 and 150 over the RMS of the axis
  /// velocity; the Stribeck block's has the single value 150 over that RMS.
  struct OptionGrid {
    std::string option;
    ShapeGrid::Scale scale = ShapeGrid::Scale::kAbsolute;
    std::string state;
    std::vector<double> factors;
    bool inverse = false;
  };
  std::vector<OptionGrid> option_grids;
  std::function<void(models::Model*, double)> apply_with_option;
  /// A structural candidate (elasticity): no parameter has a neutral value, so there is no score
  /// test (`screened` is empty); it is re-fitted in every round instead (screening.h).
  bool structural = false;
  /// The candidate as a problem file states it (a [[model.augment]] table; the parameters outside
  /// `refit` are fixed): every candidate but elasticity (it splits the body's inertia, and its
  /// second variant moves the controller's feedback to the motor side) and those that change a
  /// block of the model (a freed inertia, a joint's backlash form: the re-run frees the parameter
  /// or sets the block's option in the problem file) (empty type). A chosen option
  /// (CandidateScore::shape_start) is not in it. Options that apply() reads from the model's
  /// parameters (a load's axis_inertia, backlash's stiffness and damping, the polytropic
  /// correction's temperature) hold the values at enumeration; AugmentationFor gives them for
  /// another model (the re-fit's start).
  models::Augmentation augmentation;
  /// Those options: (option, qualified parameter whose value it takes).
  std::vector<std::pair<std::string, std::string>> options_from_parameters;
  /// "<effect> (<detail>) on <attachment>".
  std::string Name() const;
};

struct CandidateOptions {
  /// Effects to propose (names as in Candidate::effect); empty: DefaultEffects().
  std::vector<std::string> effects;
  /// Periods [m or rad] of the ripple candidates, one candidate each on every axis with a
  /// position (the pole or slot pitch, a screw lead, a gear-tooth pitch, or the peaks of the
  /// residual spectrum against position); empty: the defaults of the file comment. Each > 0.
  std::vector<double> ripple_periods = {};
  /// Ripple periods per position state (ScanPeriods' peaks, period_scan.h), used on that axis when
  /// ripple_periods is empty; ScreenAndRefit fills it from the nominal residuals.
  std::map<std::string, std::vector<double>> ripple_periods_by_position = {};
  /// Also propose the LuGre variant of presliding (detail "lugre"; see the file comment).
  bool lugre_presliding = false;
  /// Throws std::invalid_argument for an unknown effect name (with a did-you-mean) or a period
  /// that is not finite and > 0.
  void Validate() const;
};

/// `candidate.augmentation` with its options_from_parameters read from `model` (what apply() adds
/// to `model`, as data). Throws std::invalid_argument for a parameter `model` does not have.
models::Augmentation AugmentationFor(const Candidate& candidate, const models::Model& model);

/// Every effect this layer can propose, in enumeration order: per axis the friction family,
/// input_delay, deadzone, ripple, rotor_inertia, payload, elasticity; per chamber leakage,
/// polytropic_index; then per output channel sensor_offset, sensor_scale.
const std::vector<std::string>& AllEffects();

/// The effects proposed when CandidateOptions::effects is empty: AllEffects() without
/// "elasticity" (see the file comment).
const std::vector<std::string>& DefaultEffects();

/// The effects proposed for `problem`: CandidateOptions::effects when not empty, else the problem
/// file's [diagnosis] `effects` when given, else DefaultEffects(); then the table's `add_effects`
/// added and its `remove_effects` taken out; in AllEffects() order.
std::vector<std::string> SelectedEffects(const estimators::Problem& problem,
                                         const CandidateOptions& options);

/// Checks what this layer owns in problem.diagnosis (the [diagnosis] table; the parser checked its
/// signals): every effect name of effects, add_effects and remove_effects. Throws
/// estimators::ProblemFileError at the element ("file:line:col: [diagnosis] 'effects[1]': unknown
/// effect 'colomb'; did you mean 'coulomb'? ..."). Diagnose calls it before the nominal fit.
void CheckDiagnosisSpec(const estimators::Problem& problem);

/// A mechanical axis found from metadata or named in the problem (see the file comment).
struct MechanicalAxis {
  std::string velocity;    // a state signal of role velocity
  std::string force;       // the force signal acting on it
  std::string connection;  // "-force" (the usual convention) or "force"
  /// The axis' position: a state (of role position, or without a role) whose time derivative is
  /// `velocity` (ripple and payload attach there); empty when the model has none.
  std::string position;
  bool prismatic = false;  // velocity in m/s (else rad/s)
  /// The axis' actuator commands: the model inputs that change dv/dt (input_delay and deadzone
  /// attach there), or the signals a [[diagnosis.axes]] entry names (`inputs_named`; then
  /// deadzone attaches to these only, not to the commands of the blocks writing `force`).
  std::vector<std::string> inputs;
  bool inputs_named = false;
  /// Block types present on the axis (friction family only, by Problem::blocks or signature).
  std::vector<std::string> present_types;
};

/// The axes of problem.model (see the file comment).
std::vector<MechanicalAxis> FindAxes(const estimators::Problem& problem);

/// Every applicable candidate on every axis, in axis order, then the order of the table above.
std::vector<Candidate> EnumerateCandidates(const estimators::Problem& problem,
                                           const CandidateOptions& options = {});

}  // namespace graybox::diagnosis
