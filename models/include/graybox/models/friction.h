// Friction blocks: one block per joint (or sliding pair), registered in BlockRegistry::Global()
// under the type names below. This header is their reference: the equations with their source,
// units, parameters, nominal values, bounds, neutral values, options and the smoothing choices.
//
// ---- Sources ----------------------------------------------------------------------------------
//   seed 001  S. Clavel, M. Alamir, J. Faure-Favre, "On hybrid inverse dynamic modeling for
//             industrial robots", Mechatronics (Staubli TS2-80 / TX2-90): eq. 4 (power-law
//             viscous friction), eq. 5-8 (load-dependent dry friction with distance relaxation).
//   seed 002  Thesis on the elastomer-based series elastic actuator (eSEA): eq. 5-1 (viscous),
//             5-2/5-3 (Coulomb-Stribeck), 5-4/5-5 (Dahl), 5-6/5-7 (LuGre), Table 8.2 (the
//             identified values used as nominal values here).
//   roblue    the KUKA KR300 friction of ../shared/data/roblue_elabee/SOURCE.md (kuka_kr300.h).
//
// ---- Sign convention --------------------------------------------------------------------------
// Every block outputs "tau" [N m], the friction torque with the SAME sign as the velocity (for the
// dissipative terms): the torque the friction takes away from the drive. Models SUBTRACT it:
// connect the output as "-<torque signal>" (model.h). The power tau * qd of the dissipative terms
// is >= 0. friction.offset and friction.ripple are not dissipative; they are subtracted the same
// way, so f_asym > 0 means a torque opposing positive motion.
//
// ---- Rotational or sliding --------------------------------------------------------------------
// Every block except friction.kuka takes the word option "motion" = "rotational" (default: the
// units below, rad, rad/s, N m) or "prismatic" (a sliding pair such as the EMPS ball-screw stage
// seen at the load: m, m/s, N). The equations are identical; only the units reported for the
// signals and parameters change (N m -> N, kg m^2 -> kg, rad -> m: fv in N s/m, steepness in s/m).
//
// ---- Neutral values ---------------------------------------------------------------------------
// Every friction coefficient (fv, fc, fs, ftau, f_asym, fd, fvd, f_vis, f_coul, f_a, sigma0,
// sigma1, sigma2, a_k, b_k) has neutral value 0: with every neutral parameter at 0 and states
// starting at 0, a block outputs exactly zero torque for every input, so Model::Augment leaves the
// model unchanged. Shape parameters (a Stribeck velocity, a steepness such as f_b, an exponent, a
// relaxation distance or time) and the levels fc, fs of Dahl and LuGre (they divide there) have
// no neutral value (NaN) and stay at their nominal values: the output is zero whatever they are,
// and their nominal values keep every expression finite.
//
// ---- Smoothing --------------------------------------------------------------------------------
// Identification differentiates through simulations, so the static curves are made smooth:
//   sign(v) -> tanh(s v)      with the steepness s [s/rad] (slope s at 0; |error| < 2 exp(-2
//   s|v|)), |v|     -> v tanh(s v)    (even, >= 0, zero at 0; |v| - 0.28/s <= v tanh(s v) <= |v|),
//   |r|^a   -> (r^2 + 1e-3^2)^(a/2) for r = v/vs, a != 1, 2 (exact r^2 for a = 2, the seed's
//              value; sqrt(r^2 + 1e-3^2) for a = 1): smooth at 0 and harmless there, since the
//              exponential factor is then exp(-(1e-3)^a), 1 to within 0.1 % for a >= 1.
// The default steepness kDefaultFrictionSteepness = 100 s/rad (the roblue MATLAB model's value)
// puts the sign within 1 % of +-1 above 0.026 rad/s, below the eSEA's velocity resolution (one
// encoder count of 2 pi/32768 rad per 2 ms sample = 0.1 rad/s). Mind that tanh(s v) acts near
// v = 0 like a viscous damper s fc: on the eSEA motor (J = 1e-4 kg m^2) s fc / J = 1.5e4 1/s for
// friction.coulomb, a stiff mode; lower s or integrate implicitly.
// Dahl and LuGre use the exact |v| (abs; its derivative at 0 is 0 by the libexpr convention) in
// the bristle dynamics: their right-hand side is then Lipschitz, and the steady state is exactly
// the seed's. Smooth replacements break the steady state: with v tanh(s v) the steady deflection
// g(v)/(sigma0 tanh(s v)) grows without bound as v -> 0, and with sqrt(v^2 + e^2) the bristle
// creeps back at standstill.
//
// ---- Typical ranges (SignalInfo::typical_min/max; the shared tests sample there) ----------------
// Each block is sized for the machine of its source: the eSEA of seed 002 (|qd| <= 20 rad/s: the
// 0.4 N m chirp on J + I = 1.5e-3 kg m^2), the Staubli motors of seed 001 (motor side,
// |qd| <= 300 rad/s ~ 3000 rpm, |tau_load| <= 10 N m), the KUKA KR300 joints of roblue
// (|qd| <= 2 rad/s).
//
// ---- Signal roles (SignalInfo::role, block.h) -------------------------------------------------
// Every velocity input "qd" is a kVelocity, the ripple's "q" a kPosition, every "tau" output, the
// load torque "tau_load" and the dry-friction state "tau_d" are kForce; the bristle deflection "z"
// of Dahl and LuGre is not an axis quantity (kNone).
//
// ---- The blocks -------------------------------------------------------------------------------
// Inputs, outputs and states are listed as name [unit] (typical range); parameters as
// name [unit] nominal (lower, upper) neutral.
//
// "friction.viscous"  (seed 002 eq. 5-1)
//     tau = fv qd
//   input  qd [rad/s] (-20, 20);  output tau [N m]
//   fv [N m s/rad]  0.00963 (0, inf)  neutral 0   viscous coefficient (seed 002 Table 8.2, linear)
//
// "friction.coulomb"  (seed 002 eq. 5-3 with fs = fc and fv = 0)
//     tau = fc tanh(s qd)
//   input  qd [rad/s] (-20, 20);  output tau [N m]
//   fc        [N m]    0.0145 (0, inf)  neutral 0   Coulomb level (seed 002 Table 8.2, C-S model)
//   steepness [s/rad]  100 (1e-3, 1e7)  no neutral  s, a PARAMETER by default (the example of
//             block.h); the option "steepness" = {s} fixes it instead and removes the parameter.
//
// "friction.offset"  (the f_asym term of roblue)
//     tau = f_asym
//   input  qd [rad/s] (-2, 2), not used (read so that every friction block wires the same way)
//   f_asym [N m]  0 (-inf, inf)  neutral 0   constant offset (roblue joints: -47 .. 14 N m)
//
// "friction.asymmetric"  (asymmetric friction: a constant part and an even part in qd)
//     tau = f0 + fd tanh(s qd)^2 + fvd qd tanh(s qd)
//   Added to a symmetric Coulomb-viscous term fc sign(qd) + fv qd, the friction moving forward is
//   f0 + (fc + fd) + (fv + fvd) qd and moving backward f0 - (fc - fd) - (fv - fvd) |qd|: levels
//   that differ by direction (a preloaded seal, a belt, a guide loaded on one side). The
//   direction-dependent parts vanish at rest (tanh^2 and qd tanh are 0 at qd = 0), f0 does not
//   (it is friction.offset's f_asym).
//   input  qd [rad/s] (-20, 20);  output tau [N m]
//   f0  [N m]        0 (-inf, inf)  neutral 0   constant part, also at rest
//   fd  [N m]        0 (-inf, inf)  neutral 0   half the difference of the forward and backward
//                                               Coulomb levels
//   fvd [N m s/rad]  0 (-inf, inf)  neutral 0   half the difference of the viscous coefficients
//   option "steepness" s [s/rad] (default kDefaultFrictionSteepness): tanh(s qd)^2 is within
//   1 % of 1 above |qd| = 2.6 / s; qd tanh(s qd) is the smoothed |qd| of "Smoothing".
//
// "friction.stribeck"  (seed 002 eq. 5-2, 5-3)
//     g(qd) = fc + (fs - fc) exp(-|qd/vs|^a),   tau = g(qd) tanh(s qd) + fv qd
//   input  qd [rad/s] (-20, 20);  output tau [N m]
//   fc [N m]        0.0145   (0, inf)     neutral 0   Coulomb (kinetic) level
//   fs [N m]        1.03e-5  (0, inf)     neutral 0   static level: tau -> fs as qd -> 0+
//   vs [rad/s]      0.1677   (1e-6, 1e3)  no neutral  Stribeck velocity
//   fv [N m s/rad]  0.002    (0, inf)     neutral 0   viscous coefficient
//   Nominal values: seed 002 Table 8.2, Coulomb-Stribeck column, as identified there (fs < fc
//   there, i.e. friction rising from standstill; the bounds allow either order).
//   options: "steepness" s [s/rad] (default 100), "exponent" a (default 2, the seed's square; the
//   printed eq. 5-2 has lost its minus sign: the exponent of e is -(qd/vs)^2).
//   Limits: tau(0+) = fs (for s vs >> 1), tau -> fc + fv qd for qd >> vs.
//
// "friction.power_viscous"  (seed 001 eq. 4, motor side)
//     tau = fv sign(qd) |qd / (1 rad/s)|^k,  evaluated as  fv qd (qd^2 + eps^2)^((k - 1)/2)
//   input  qd [rad/s] (-300, 300);  output tau [N m]
//   fv [N m]  0.01 (0, inf)  neutral 0    seed 001 k1: the torque at |qd| = 1 rad/s (this fixes the
//             unit; the seed's k1 multiplies |qd|^k2 with qd in the robot's units)
//   k  [1]    1 (0.1, 3)     no neutral  seed 001 k2 (1 = linear viscous; the nominal value)
//   option "smoothing" eps [rad/s] (default 1e-3): the odd power x |x|^(k-1) is written
//   x (x^2 + eps^2)^((k-1)/2), smooth at 0 (slope eps^(k-1) there) and relatively within
//   (k-1) eps^2/(2 qd^2) of the exact law. Seed 001 gives no values; the nominal values are of
//   the order of the motor-side viscous friction of the KUKA motors (SOURCE.md, B = 0.0015 ..
//   0.084 N m s/rad).
//
// "friction.dahl"  (seed 002 eq. 5-4, 5-5)
//     dz/dt = qd (1 - sigma0 z sign(qd) / fc) = qd - sigma0 |qd| z / fc,   tau = sigma0 z
//   input qd [rad/s] (-20, 20);  state z [rad] (-1e-3, 1e-3) bristle deflection;  output tau [N m]
//   sigma0 [N m/rad]  37.9    (0, 1e8)     neutral 0   bristle (pre-sliding) stiffness
//   fc     [N m]      0.0379  (1e-9, inf)  no neutral  Coulomb level, |tau| -> fc in sliding
//   Rate-independent hysteresis: in terms of the position q, d tau/dq = sigma0 (1 - tau sign(qd)
//   / fc); for q oscillating between -A and A the steady loop reaches tau = +-fc tanh(sigma0 A/fc)
//   at the turning points. stiff = true: |d zdot / dz| = sigma0 |qd| / fc = 2e4 1/s at 20 rad/s.
//   option "form" = "stiffness" (default, the seed's, above) or "length": the same law in the
//   presliding length delta = fc / sigma0 and the normalised deflection zn = sigma0 z / fc,
//       dzn/dt = (qd - |qd| zn) / delta,   tau = fc zn,
//   state zn [1] (-1, 1);  fc [N m] 0.0379 (0, inf) neutral 0;  delta [rad] 1e-3 (1e-9, inf) no
//   neutral. Here the level is linear and has a neutral value, so at fc = 0 its direction is a
//   sign smoothed by the presliding (the hysteresis), where the stiffness form's direction at
//   sigma0 = 0 is the position itself (a spring): the form the diagnosis screens.
//
// "friction.lugre"  (seed 002 eq. 5-2, 5-6, 5-7)
//     g(qd) = fc + (fs - fc) exp(-|qd/vs|^a),   dz/dt = qd - sigma0 |qd| z / g(qd),
//     tau = sigma0 z + sigma1 dz/dt + sigma2 qd
//   input qd [rad/s] (-20, 20);  state z [rad] (-0.06, 0.06) bristle deflection;  output tau
//   sigma0 [N m/rad]    16.19    (0, 1e8)     neutral 0   bristle stiffness
//   sigma1 [N m s/rad]  0.0036   (0, inf)     neutral 0   bristle micro-damping
//   sigma2 [N m s/rad]  0.00335  (0, inf)     neutral 0   viscous coefficient
//   fc     [N m]        0.01619  (1e-9, inf)  no neutral  Coulomb level
//   fs     [N m]        0.8795   (1e-9, inf)  no neutral  static level
//   vs     [rad/s]      3.15e-5  (1e-6, 1e3)  no neutral  Stribeck velocity
//   option "exponent" a (default 2), as in friction.stribeck.
//   Steady state at constant qd != 0: sigma0 z_ss = g(qd) sign(qd) and tau_ss = g(qd) sign(qd) +
//   sigma2 qd, the Stribeck curve (friction.stribeck with fv = sigma2, up to tanh vs. sign).
//   Nominal values: seed 002 Table 8.2 (LuGre column) except sigma0. The seed's identified
//   sigma0 = 0.0512 N m/rad (and 0.5034 for Dahl) would mean fc/sigma0 = 0.32 rad (0.075 rad) of
//   pre-sliding travel, more than the whole elastic deflection of the eSEA joint at the test
//   torque (0.4 N m / 8.459 N m/rad = 0.047 rad): not a bristle. The nominal sigma0 here is
//   fc / 1 mrad (about 5 encoder counts of pre-sliding travel), for Dahl and LuGre alike. Note
//   that the seed's fs, vs put a 0.88 N m peak within 3e-5 rad/s of standstill; treat them as an
//   initial guess only. stiff = true: sigma0 |qd| / g = 2e4 1/s at 20 rad/s.
//   Neutral: sigma0 = sigma1 = sigma2 = 0 gives tau = 0 (z then integrates qd, harmlessly).
//   fc and fs cannot be 0 (they divide) and keep their nominal values.
//
// "friction.torque_dependent"  (seed 001 eq. 5-8, in continuous time; motor side)
//     target = tanh(s qd) (fc + ftau |tau_load|_s),   |x|_s = x tanh(s_tau x),
//     d tau_d/dt = (target - tau_d) |qd|_s / distance - sech^2(s qd) tau_d / time,   tau = tau_d
//   inputs qd [rad/s] (-300, 300), tau_load [N m] (-10, 10) the torque the drive transmits (seed
//   001 tau_jnt in the frame of qd);  state tau_d [N m] (-1.5, 1.5);  output tau [N m]
//   fc       [N m]  0.5   (0, inf)     neutral 0   seed 001 k3, Coulomb level
//   ftau     [1]    0.05  (0, 10)      neutral 0   seed 001 k4, friction per unit load torque
//   distance [rad]  0.05  (1e-6, 1e3)  no neutral  seed 001 k5, relaxation distance
//   time     [s]    0.1   (1e-4, 1e4)  no neutral  seed 001 k6, standstill relaxation time
//   options "steepness" s [s/rad] (default 100), "torque_steepness" s_tau [1/(N m)] (default 100).
//   Derivation. Seed 001 updates the dry friction D once per controller sample dt:
//     moving (eq. 5-7):    D_k = T_k + (D_{k-1} - T_k) exp(-|q_k - q_{k-1}| / k5),
//                          T_k = sign(qd_k) (k3 + k4 |tau_jnt,k|),
//     standstill (eq. 8):  D_k = D_{k-1} (1 - dt / k6).
//   With q_k - q_{k-1} = qd dt, (D_k - D_{k-1}) / dt = (T - D)(1 - exp(-|qd| dt/k5)) / dt ->
//   (T - D) |qd| / k5 as dt -> 0: a first-order relaxation over the travelled distance s
//   (dD/ds = (T - D)/k5), the Dahl mechanism (with ftau = 0 it IS the Dahl model with
//   sigma0 = fc/distance). The standstill law tends to dD/dt = -D/k6. The seed switches on
//   qd == 0 exactly (it runs on desired trajectories); the continuous form weights the time
//   relaxation by sech^2(s qd) = 1 - tanh^2(s qd), 1 at rest and < 2e-3 above 0.04 rad/s, and
//   smooths sign and |.| as above. Both laws are the limits of the seed's updates as dt -> 0; at
//   the seed's dt = 4 ms they differ by O(dt |qd|/k5). Neutral: fc = ftau = 0 makes the target 0,
//   so tau_d stays 0 from 0. Seed 001 publishes no values: the nominal values are assumptions of
//   the order of the KUKA motor-side Coulomb friction (0.37 .. 1.9 N m, SOURCE.md). stiff = true:
//   the relaxation rate |qd|/distance is 6e3 1/s at 300 rad/s (250 Hz sampling).
//
// "friction.ripple"  (position-dependent ripple or cogging)
//     tau = sum_{k=1..K} a_k cos(2 pi k q / P) + b_k sin(2 pi k q / P)
//   input q [rad] (-pi, pi);  output tau [N m]
//   a1, b1, ..., aK, bK [N m]  0 (-inf, inf)  neutral 0   Fourier amplitudes (parameters in this
//   order: a1, b1, a2, b2, ...)
//   period [rad]  P (P/2, 2 P)  no neutral   period of the first harmonic, fixed by default
//   options "harmonics" K (integer 1..1000, default 1), "period" P [rad] (default 2 pi, one
//   revolution): the period's value. It is usually known from the design (pole and slot counts,
//   gear teeth) and a free period makes the fit multimodal, so the parameter starts fixed
//   (ParameterInfo::fixed_by_default); free it (`free = true` in a problem file) to refine a
//   period known to within a factor of 2, from a start near it.
//
// "friction.kuka"  (roblue, SOURCE.md)
//     tau = f_asym + f_vis qd + f_coul tanh(s qd) + f_a tanh(f_b qd)
//   input qd [rad/s] (-2, 2);  output tau [N m]
//   f_asym [N m]        14.0625  (-inf, inf)  neutral 0
//   f_vis  [N m s/rad]  5000     (0, inf)     neutral 0
//   f_coul [N m]        45.3125  (0, inf)     neutral 0
//   f_a    [N m]        20.47    (0, inf)     neutral 0
//   f_b    [s/rad]      823.4    (1e-3, 1e7)  no neutral
//   options "joint" (1..6, default 1) selects the nominal values of that roblue joint (f_asym,
//   f_vis, f_coul as KukaRoblueFriction(); f_a, f_b the values roblue computes but leaves out of
//   its sum), "steepness" s [s/rad] (default 1, roblue's; its MATLAB model uses 100).
#pragma once

namespace graybox::models {

inline constexpr char kViscousFriction[] = "friction.viscous";
inline constexpr char kCoulombFriction[] = "friction.coulomb";
inline constexpr char kOffsetFriction[] = "friction.offset";
inline constexpr char kAsymmetricFriction[] = "friction.asymmetric";
inline constexpr char kStribeckFriction[] = "friction.stribeck";
inline constexpr char kPowerViscousFriction[] = "friction.power_viscous";
inline constexpr char kDahlFriction[] = "friction.dahl";
inline constexpr char kLuGreFriction[] = "friction.lugre";
inline constexpr char kTorqueDependentFriction[] = "friction.torque_dependent";
inline constexpr char kRippleFriction[] = "friction.ripple";
inline constexpr char kKukaFriction[] = "friction.kuka";

/// Default tanh steepness s [s/rad] of the smoothed sign (see "Smoothing").
inline constexpr double kDefaultFrictionSteepness = 100.0;

}  // namespace graybox::models
