// Mechanics, control and signal blocks: a rigid one-degree-of-freedom load, the cascaded
// position/velocity P controller of the EMPS benchmark, a gain and an integrator. They are
// registered in
// BlockRegistry::Global() under the type names below; this header is their reference (equations,
// units, parameters with nominal values, bounds and neutral values, options, smoothing).
//
// ---- Sources ----------------------------------------------------------------------------------
//   EMPS  A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", Workshop on
//         Nonlinear System Identification Benchmarks 2019 (../shared/data/emps/SOURCE.md): the
//         inverse dynamic model tau = M qdd + Fv qd + Fc sign(qd) + offset of the ball-screw
//         load, the cascaded P/P law nu = kp kv (qr - q) - kv qd with |nu| <= 10 V, the drive
//         gain tau = g_tau nu.
//
// ---- Listing format ---------------------------------------------------------------------------
// Signals name [unit] (typical range); parameters name [unit] nominal (lower, upper) neutral.
// The typical ranges are the EMPS operating range (SOURCE.md: position 0 .. 0.246 m, force up to
// about 150 N, controller output up to about 4.3 V); they only guide test points and scaling.
//
// "mechanics.mass"  (Newton's second law of one rigid body on one axis)
//     dq/dt = qd,    dqd/dt = force / mass
//   states  q [m] (0, 0.25) position, qd [m/s] (-0.3, 0.3) velocity
//   input   force [N] (-150, 150), the NET force on the load along the axis
//   mass [kg]  1 (1e-9, inf)  no neutral   moving mass (EMPS: M = 95.1 kg)
//   option "motion" = "prismatic" (default) | "rotational": rotational uses q [rad] (-pi, pi),
//   qd [rad/s] (-10, 10), force [N m] (-10, 10) (a torque) and mass [kg m^2] (an inertia,
//   nominal 0.01).
//   No outputs: the states are the signals "<instance>.q" and "<instance>.qd" (model.h).
//   Roles (SignalInfo::role): q kPosition, qd kVelocity, force kForce. The controller's q and qd
//   are kPosition and kVelocity, its output nu kVoltage; its reference qr has none.
//   Forces are composed on the input signal: a drive writes "+force", friction blocks
//   (friction.h) read "<instance>.qd" and write "-force". The mass has no neutral value (it
//   divides), so this block is a plant, never an augmentation candidate.
//
// "control.cascade_p"  (EMPS position controller)
//     v  = kp kv (qr - q) - kv qd                       unsaturated command
//     nu = S(v) = (sqrt((v + L)^2 + eps^2) - sqrt((v - L)^2 + eps^2)) / 2
//              = 2 L v / (sqrt((v + L)^2 + eps^2) + sqrt((v - L)^2 + eps^2))   (as evaluated)
//   inputs  qr [m] (0, 0.25) position reference, q [m] (0, 0.25) measured position,
//           qd [m/s] (-0.3, 0.3) measured velocity
//   output  nu [V] (-10, 10) controller output (drive command)
//   kp    [1/s]      160.18  (0, inf)     no neutral  position loop gain (EMPS)
//   kv    [V s/m]    243.45  (0, inf)     no neutral  velocity loop gain (EMPS)
//   limit [V]        10      (1e-6, inf)  no neutral  saturation level L (EMPS viradm = 10)
//   The three are known SETTINGS, not unknowns of the plant: their ParameterInfo says
//   fixed_by_default, so Model::AddBlock starts them fixed (and a problem file keeps them fixed
//   unless it sets `free = true`).
//   Smoothing. The saturation clamp(v, -L, L) = (|v + L| - |v - L|) / 2 with |x| replaced by
//   sqrt(x^2 + eps^2): S is odd, C-infinity and strictly inside (-L, L). Inside the linear range
//   S(v) = v - eps^2 v / (2 (L^2 - v^2)) + O(eps^4), so with the default eps = 1e-3 V and L = 10 V
//   the command is exact to 3e-8 V at v = 4.3 V (the largest EMPS command) and to 3e-6 V at
//   v = 9.9 V; at the corner S(L) = L - eps/2 + O(eps^2/L); beyond it
//   S(v) = L - eps^2 L / (2 (v^2 - L^2)) + O(eps^4), approaching L. The slope dS/dv goes from 1 to
//   0 over a width of a few eps around |v| = L, so an optimiser sees a smooth but sharp corner.
//   The second form has no cancellation: deep in saturation (|v| ~ 1e4 V at a 0.25 m position
//   error) the difference form would lose 12 digits of S and of its derivatives.
//   options "smoothing" eps [V] (default kDefaultSaturationSmoothing = 1e-3; > 0) and "motion"
//   as for mechanics.mass (rotational: qr, q [rad] (-pi, pi), qd [rad/s] (-10, 10), kv [V s/rad]).
//   The EMPS loop computes qd from a two-tap averaged position difference at 1 kHz; in a
//   continuous-time model it reads the velocity state of the load.
//
// "signal.gain"  (a static gain)
//     y = k u
//   input u [input_unit] (-10, 10), output y [output_unit] (-10, 10)
//   k [output_unit/input_unit]  1 (-inf, inf)  neutral 1   gain
//   options "input_unit", "output_unit" (words, default "1") only label the signals and k (EMPS:
//   input "V", output "N", k = g_tau = 35.15 N/V, fixed from the data file). At the neutral value
//   k = 1 the output equals the input, so the block can be put in series on any signal
//   (Model::InsertOnSignal) as a candidate gain error without changing the model.
// "signal.integrator"  (an integrator state)
//     dy/dt = u
//   input u [input_unit] (-1, 1), state y [output_unit] (-1, 1); no parameters, no outputs (the
//   state is the signal "<instance>.y")
//   options "input_unit" (default "1/s"), "output_unit" (default "1") label the signals.
//   Use: a first-order hold of a sampled signal. The integrators of the estimators hold every
//   input constant over a sample interval (zero-order hold), which delays a sampled reference by
//   half a sample on average: 62 um at the EMPS's 0.125 m/s, which its position loop
//   (kp kv = 3.9e4 V/m) turns into a 2.4 V bias of the command. Driving an integrator with the
//   forward difference (r[k+1] - r[k]) / dt of the reference (a data mapping with rate = true,
//   problem_file.h) and starting it at r[0] reproduces r exactly at the samples and linearly in
//   between.
// "signal.first_order_hold"  (a sampled signal interpolated linearly between its samples)
//     dy/dt = r,   output v = y
//   inputs u [unit] (-10, 10) the sampled signal, held over each sample by the integrators (read
//   for the wiring only: the block replaces it for its readers), r [unit/s] (-1e3, 1e3) its
//   forward difference (u[k+1] - u[k]) / dt, held over the sample; state y [unit], started at
//   u[0] and held there (ExperimentSetup::x0_free); output v [unit] = y. Exact at every sample
//   and linear in between with every integrator (a constant rate integrates exactly), so each
//   formulation and integrator sees the first-order hold without knowing of it. The problem file
//   inserts it for an input mapped with hold = "foh" (docs/problem-format.md).
//   option "unit" (word, default "1").
#pragma once

#include <string>

namespace graybox::models {

inline constexpr char kMassBlock[] = "mechanics.mass";
inline constexpr char kCascadePController[] = "control.cascade_p";
inline constexpr char kGainBlock[] = "signal.gain";
inline constexpr char kIntegratorBlock[] = "signal.integrator";
inline constexpr char kFirstOrderHold[] = "signal.first_order_hold";

/// Default smoothing width eps [V] of the control.cascade_p saturation (see above).
inline constexpr double kDefaultSaturationSmoothing = 1e-3;

}  // namespace graybox::models
