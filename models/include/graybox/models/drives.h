// Transmission and drive blocks: elastic joints, backlash, gears, DC motors and input delays,
// registered in BlockRegistry::Global() under the type names below. This header is their
// reference: equations with their source, units, parameters, nominal values, bounds, neutral
// values, options and modelling choices.
//
// ---- Sources ----------------------------------------------------------------------------------
//   seed 001  Clavel et al., hybrid inverse dynamics of Staubli robots: Sec. 2.2 (transmission
//             layer: joint quantities to motor quantities) and eq. 9 (rotor inertia).
//   seed 002  Thesis on the elastomer-based series elastic actuator (eSEA): eq. 6-1 and the
//             constants J = 1e-4 kg m^2, I = 1.4e-3 kg m^2, Ke = 8.459 N m/rad of Sec. 6.1 (the
//             seed prints the inertias' unit as "m4"; they are kg m^2).
//   seed 003  Ayankoso and Olejnik, geared 12 V DC motor (SG555123000-10K): eq. 31-34, Table 5;
//             gear ratio 10 from ../shared/data/geared_dc_motor_ayankoso/SOURCE.md.
//   roblue    KUKA KR300 gear ratios and rotor inertias (kuka_kr300.h, SOURCE.md).
//
// Listing format: signals name [unit] (typical range); parameters name [unit] nominal
// (lower, upper) neutral.
//
// Signal roles (SignalInfo::role, block.h): angles q_m, q_l, theta are kPosition; speeds qd_m,
// qd_l, qd, omega kVelocity; qdd kAcceleration; torques tau_m, tau_ext, tau_s, tau, tau_load
// kForce; the DC motor's u kVoltage and i kCurrent. The deflections of drive.backlash (relative
// angles, not an axis') and the generic signal of delay.first_order have none (kNone).
//
// "drive.two_mass"  (seed 002 eq. 6-1)
//     delta = q_m - q_l,  tau_s = Ke delta + d d(delta)/dt,
//     J dqd_m/dt = tau_m - tau_s,   I dqd_l/dt = tau_s + tau_ext.
//   Seed 002 writes J d2delta/dt2 + Ke (delta - theta) + F(d delta/dt) = tau and I d2theta/dt2 +
//   Ke (theta - delta) = 0 with delta the motor and theta the link angle; here the motor friction
//   F is a separate friction block subtracted from tau_m (friction.h), and the load may receive
//   an external torque.
//   states  q_m [rad] (-1, 1), qd_m [rad/s] (-20, 20), q_l [rad] (-1, 1), qd_l [rad/s] (-20, 20)
//   inputs  tau_m [N m] (-0.4, 0.4) net motor torque, tau_ext [N m] (-0.4, 0.4) on the load
//   outputs q_m, qd_m, q_l, qd_l (the states) and tau_s [N m], the torque through the joint
//   J  [kg m^2]     1e-4    (1e-9, inf)  no neutral  motor inertia
//   I  [kg m^2]     1.4e-3  (1e-9, inf)  no neutral  link inertia
//   Ke [N m/rad]    8.459   (1e-6, inf)  no neutral  joint stiffness
//   d  [N m s/rad]  0       (0, inf)     neutral 0   joint damping (not in the seed)
//   option "backlash" = 1 adds the parameter
//   b  [rad]        2e-3    (0, 0.5)     neutral 0   half width of a backlash dead zone,
//   and then tau_s = Ke DZ(delta) + d DZ'(delta) d(delta)/dt with the smooth dead zone DZ of
//   drive.backlash (the damper acts on the rate of the effective deflection, so no torque passes
//   inside the gap); option "smoothing" eps [rad] (default 1e-4, only with backlash).
//   option "motion" = "rotational" (default) | "prismatic": a linear elastic drive (a belt or a
//   series elastic slide) in m, m/s, N, kg, N/m, N s/m; the equations are the same.
//   Linearised (d = 0, no backlash) the modes are a rigid-body pair at 0 and an oscillation at
//   omega_n = sqrt(Ke (1/J + 1/I)) = 301 rad/s (47.9 Hz) at the nominal values; J qd_m + I qd_l
//   is conserved when tau_m = tau_ext = 0. The block has no neutral configuration: the rigid
//   limit is Ke -> infinity, which no finite value reaches (so J, I, Ke have no neutral).
//   stiff = false (an undamped 48 Hz mode; the data are sampled at 500 Hz).
//
// "drive.backlash"  (dead zone on the spring deflection of seed 002 eq. 6-1)
//     delta_eff = DZ(delta) = delta - (sqrt((delta + b)^2 + eps^2) - sqrt((delta - b)^2 + eps^2))/2
//   The exact dead zone is delta - clamp(delta, -b, b) = delta - (|delta + b| - |delta - b|)/2;
//   the smoothing replaces |x| by sqrt(x^2 + eps^2). DZ is odd and C-infinity; outside the gap
//   (|delta| > b) it is delta -+ b to within eps^2 b / (2 (delta^2 - b^2)); inside the gap its
//   slope at 0 is 1 - b/sqrt(b^2 + eps^2) ~ eps^2/(2 b^2); at the corners it rounds over a
//   width ~eps. At b = 0 the two square roots
//   are equal and DZ(delta) = delta EXACTLY (also in floating point).
//   input delta [rad] (-0.05, 0.05), output delta_eff [rad] (-0.05, 0.05)
//   b [rad]  2e-3 (0, 0.5)  neutral 0   half width of the dead zone (total play 2b)
//   option "smoothing" eps [rad] (default kDefaultBacklashSmoothing = 1e-4; keep eps << b).
//   Use it in series on a deflection signal (Model::InsertOnSignal), or through the "backlash"
//   option of drive.two_mass for the spring inside that block.
//
// "drive.gear"  (seed 001 Sec. 2.2 and eq. 9)
//     tau  = eta N (tau_m - J_m N qdd),   qd_m = N qd.
//   The rotor inertia sits before the gear, so its inertial torque J_m qdd_m = J_m N qdd also
//   passes the gear losses: the reflected inertia is eta N^2 J_m (N^2 J_m for an ideal gear,
//   roblue's I_a = J_m u^2). A constant eta is a motoring efficiency; it does not switch when the
//   load drives the motor.
//   inputs  tau_m [N m] (-20, 20) motor torque, qd [rad/s] (-2, 2), qdd [rad/s^2] (-10, 10)
//   outputs tau [N m] (-5000, 5000) joint torque, qd_m [rad/s] (-500, 500) motor speed
//   N   [1]       256.857 (1e-3, 1e5)  neutral 1   gear ratio (motor angle / joint angle)
//   eta [1]       1       (1e-3, 1)    neutral 1   efficiency (roblue has none: 1)
//   J_m [kg m^2]  0.00923 (0, inf)     neutral 0   rotor inertia
//   option "joint" (1..6, default 1): nominal N and J_m of that KUKA KR300 joint
//   (kKukaGearRatios, kKukaMotorInertias). At the neutral values tau = tau_m and qd_m = qd.
//
// "drive.dc_motor"  (seed 003 eq. 31-34)
//     L di/dt = u - Kb N omega - R i                                   (eq. 31, E = Kb omega_rs)
//     (J_os + N^2 J_rs) domega/dt = N Km i - (B_os + N^2 B_rs) omega - tau_load   (eq. 33, 34)
//     dtheta/dt = omega
//   with the rigid gear omega_rs = N omega (eq. 34 in the output-shaft speed psi_os = omega).
//   states  i [A] (0, 3), omega [rad/s] (0, 35) output-shaft speed, theta [rad] (0, 100)
//   inputs  u [V] (0, 12), tau_load [N m] (-1, 1) (optional, opposing omega)
//   outputs theta, omega, i (theta only with the angle state)
//   L    [H]          0.001   (1e-7, 10)   armature inductance
//   R    [Ohm]        1.3798  (1e-4, 1e3)  armature resistance
//   Kb   [V s/rad]    0.3938  (1e-5, 100)  back-EMF constant (per rotor rad/s)
//   Km   [N m/A]      0.6585  (1e-5, 100)  torque constant
//   N    [1]          10      (1e-3, 1e5)  gear ratio (SOURCE.md: 10:1)
//   J_rs [kg m^2]     0.001   (1e-9, 10)   rotor inertia
//   J_os [kg m^2]     0.0379  (0, 10)      output-shaft inertia
//   B_rs [N m s/rad]  1.2539  (0, 100)     rotor damping
//   B_os [N m s/rad]  0.3532  (0, 100)     output-shaft damping
//   No parameter has a neutral value (a motor is never a pass-through).
//   options "angle_state" (0/1, default 1) adds theta; "load_input" (0/1, default 0) adds
//   tau_load (seed 003 has no load torque).
//   Steady state (constant u, tau_load): omega_ss = (N Km u - R tau_load) / (R B + N^2 Km Kb),
//   i_ss = (u - Kb N omega_ss) / R, with B = B_os + N^2 B_rs. Only J = J_os + N^2 J_rs and B are
//   identifiable from speed data (fix one of each pair). Nominal values: seed 003 Table 5, the
//   PINN estimates, which the authors call non-unique; J_rs and L sit on their search bound
//   0.001, and Km = 0.6585 N m/A differs from Kb = 0.3938 V s/rad although energy conservation
//   makes them equal in SI units (the block keeps both, as the seed). They give
//   omega_ss = 0.033 rad/s per volt, two orders of magnitude below the measured
//   31.7 rad/s (303 rpm) at full PWM (SOURCE.md): an initial guess to be identified, not a fit.
//   The data's input is a PWM duty (0..255) that the authors scale by 5/255; 12 V is the motor's
//   rating. stiff = true: the eigenvalues at the nominal values are -1146 +- 365i 1/s (L/R = 0.7
//   ms) against the data's 20 ms sampling.
//
// "delay.first_order"  (input delay approximation)
//     T dx/dt = u - x,   y = u + w (x - u),
//   i.e. Y/U = (1 + (1 - w) s T) / (1 + s T), whose low-frequency delay (group delay at 0) is w T:
//     w = 1  first-order lag 1/(1 + sT) (delay T),
//     w = 2  Pade(1,1) all-pass (1 - sT)/(1 + sT) of the delay 2T,
//     w = 0  y = u exactly, for every T and x: the NEUTRAL value.
//   A plain lag y = x, T dx/dt = u - x has no exact pass-through (T = 0 makes f singular), so the
//   block carries the direct path u explicitly and the weight w of the lagged path is the
//   parameter with a neutral value; T has none and keeps its nominal value. The step response
//   from x(0) = 0 is y(t) = u (1 - w exp(-t/T)).
//   input u, state x, output y: unit from option "unit" (default "1"), typical range from option
//   "typical_range" = {min, max} (default {-1, 1})
//   T [s]  kDefaultDelayTimeConstant = 0.01 (1e-5, 10)  no neutral  time constant (2.5 samples of
//          the 250 Hz controllers of seed 001 and roblue)
//   w [1]  1 (0, 1) for form "lag", 2 (0, 2) for form "pade"   neutral 0   weight of the lag
//   option "form" = "lag" (default) or "pade" selects the nominal value and upper bound of w.
//   Made for Model::InsertOnSignal (one input, one output).
#pragma once

namespace graybox::models {

inline constexpr char kTwoMassDrive[] = "drive.two_mass";
inline constexpr char kBacklashDrive[] = "drive.backlash";
inline constexpr char kGearDrive[] = "drive.gear";
inline constexpr char kDcMotorDrive[] = "drive.dc_motor";
inline constexpr char kFirstOrderDelay[] = "delay.first_order";

/// Default smoothing width eps [rad] of the backlash dead zone.
inline constexpr double kDefaultBacklashSmoothing = 1e-4;
/// Default (nominal) time constant T [s] of delay.first_order.
inline constexpr double kDefaultDelayTimeConstant = 0.01;

}  // namespace graybox::models
