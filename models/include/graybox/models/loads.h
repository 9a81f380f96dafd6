// Added-load blocks: an extra inertia on a rigid axis, a payload (extra inertia plus its gravity
// load) and an elastic coupling (a motor-side inertia behind a spring-damper, which turns the rigid
// axis into a two-mass axis), registered in BlockRegistry::Global() under the type names below.
// They are put in series on the net force a rigid-body block reads (Model::InsertForReaders with
// that block as the only reader), which is how an extra inertia enters without an algebraic loop:
// this header is their reference (equations, units, parameters with nominal values, bounds and
// neutral values, options, states).
//
// ---- Why on the net force ---------------------------------------------------------------------
// A rigid axis integrates M dv/dt = F, F the sum of everything written to its force signal
// (mechanics.mass). An extra inertia dM makes it (M + dM) dv/dt = F, i.e. the body must read
//     F_eff = F / (1 + dM / M).
// Writing the inertial force -dM dv/dt into F instead would make F depend on dv/dt, which depends
// on F (an algebraic loop the Model rejects), and scaling one contribution of F by M / (M + dM)
// would leave the others (the friction blocks' terms) unscaled, which is wrong. Scaling the whole
// sum at its one reader is exact. This requires that the reader integrates F / M and nothing else
// (mechanics.mass; not drive.two_mass, whose motor equation has the spring torque inside the
// block). M is the axis' inertia as an option (a known value: the candidates take the model's
// current value of the body's parameter when they apply the block); dM is the unknown.
// Division by 1 + dM/M with dM = 0 is exact: 1 + 0 = 1 and F / 1 = F in IEEE arithmetic, so at
// the neutral values F_eff = F bit for bit.
//
// ---- Listing format ---------------------------------------------------------------------------
// Signals name [unit] (typical range); parameters name [unit] nominal (lower, upper) neutral.
// Option "motion" = "rotational" (default: N m, kg m^2, rad) or "prismatic" (N, kg, m).
//
// "mechanics.added_inertia"  (rotor or payload inertia without gravity)
//     F_eff = F / (1 + dM / M)
//   input  F [N m] (-10, 10) the net force the body reads;  output F_eff [N m] (-10, 10)
//   dM [kg m^2]  0 (0, inf)  neutral 0   added inertia (a rotor's N^2 J_m seen at the joint, a
//                                        payload's inertia about the axis)
//   option "axis_inertia" M [kg m^2] (> 0, required): the inertia of the body it is added to.
//
// "mechanics.payload"  (payload: inertia and gravity)
//   rotational:  F_eff = (F - g_s sin q - g_c cos q) / (1 + dM / M)
//     g_s, g_c [N m]  0 (-inf, inf)  neutral 0   gravity torque m g l (cos phi, sin phi) of a load
//                                                whose centre of mass is at distance l and angle
//                                                phi from the plane of q = 0 (m g l sin(q + phi)
//                                                = g_s sin q + g_c cos q; linear in g_s, g_c)
//     dM [kg m^2]     0 (0, inf)     neutral 0   payload inertia about the axis, I_c + m l^2 (not
//                                                tied to g_s, g_c: a distributed load's inertia
//                                                is not fixed by its first moment)
//   prismatic:   F_eff = (F + m g_q) / (1 + m / M)
//     m [kg]  0 (0, inf)  neutral 0   payload mass (inertia and weight are the same m)
//     option "gravity" g_q [m/s^2] (default -9.81): gravitational acceleration along +q (-9.81
//     for an axis pointing up, +9.81 pointing down, 0 horizontal)
//   inputs F (as above) and q [rad] (-pi, pi) or [m] (0, 0.25) the axis position; output F_eff
//   option "axis_inertia" M (> 0, required) as above.
//
// "mechanics.elastic_coupling"  (rigid axis -> two-mass axis; the structural candidate elasticity)
//     F_c    = K e + c ed                       the coupling force the body reads
//     de/dt  = ed
//     ded/dt = (F - F_c) / J - F_c / M
//   A motor-side inertia J sits between the net force F and the body (inertia M), joined to the
//   body by a spring K and a damper c: motor side J qdd_m = F - F_c, body M qdd = F_c, and the
//   difference of the two is the equation of the deflection e = q_m - q. The body keeps its own
//   states q, qd (they become the load side); the block adds the deflection and its rate.
//   Attach with Model::InsertForReaders(F, instance, block, {body}): the body then reads F_c, and
//   every force written into F (the actuator and any friction block) acts on the motor side. Such
//   friction blocks keep reading the body's velocity qd, not the motor side's qd + ed: friction
//   moves to the motor side but is evaluated at the load speed (accurate while |ed| << |qd|).
//   states  e   [rad]    (-e_t, e_t)           deflection q_m - q, e_t = 10 / K_0 (the
//                                              spring's extension under the typical force 10)
//           ed  [rad/s]  (-w_0 e_t, w_0 e_t)   its rate qd_m - qd, w_0 = 2 pi f0
//   input   F   [N m]    (-10, 10)  the net force that acted on the body (now on the motor side)
//   output  F_c [N m]    (-10, 10)  the coupling force the body reads instead of F
//   J [kg m^2]     J_0 = M / 4                    (1e-6 M, inf)    no neutral  motor-side inertia
//   K [N m/rad]    K_0 = w_0^2 / (1/J_0 + 1/M)    (1e-6 K_0, inf)  no neutral  stiffness (a mode
//                                                                              f0 / 1000 at the
//                                                                              lower bound)
//   c [N m s/rad]  c_0 = 2 (0.1) sqrt(K_0 J_eff)  (0, inf)         no neutral  damping (damping
//                                                                              ratio 0.1)
//   with J_eff = 1 / (1/J_0 + 1/M) = M / 5; the fraction 1/4 and the damping ratio 0.1 are
//   kDefaultCouplingInertiaRatio and kDefaultCouplingDamping.
//   options "axis_inertia" M (> 0, required) as above; "motion" as above (prismatic: e [m],
//   ed [m/s], F, F_c [N], J [kg], K [N/m], c [N s/m]); "frequency" f0 [Hz] (> 0, default
//   kDefaultCouplingFrequency = 20): the coupled mode's frequency at the nominal values.
//   Roles: F and F_c kForce; e and ed none (kNone): a deflection and its rate are relative
//   quantities, not an axis' own, and a velocity role on ed would make the diagnosis, which finds
//   axes as velocity-role states with a force acting on them, take the deflection rate for an axis.
//   Modes. Linearised, e'' + (c / J_eff) e' + (K / J_eff) e = F / J with J_eff = J M / (J + M):
//   the coupled mode is at omega = sqrt(K (1/J + 1/M)) (w_0 at the nominal values) with damping
//   ratio zeta = c / (2 sqrt(K J_eff)) (0.1 nominal); the other pair is the rigid motion at 0.
//   The centre of mass moves as one rigid body of inertia M + J: q + J e / (J + M) obeys
//   (M + J) d^2/dt^2 = F exactly, so at low frequency (or K -> inf) the body responds to F as an
//   inertia M + J, not M. With a fixed catalogue M the axis thus gets heavier by J; a caller that
//   knows the total inertia M_tot splits it: body parameter and axis_inertia M = 0.8 M_tot, then
//   the nominal J = M / 4 = 0.2 M_tot restores M + J = M_tot.
//   M is an option (a known value, as for added_inertia): it must equal the body's inertia
//   parameter. If a fit moves that parameter away from M, e is no longer q_m - q of a two-mass
//   system; re-create the block with the new value (as the diagnosis' load candidates do on apply).
//   No neutral configuration: the rigid original is the double limit K -> inf (never reached) and
//   J -> 0 (J divides), and at K -> inf alone the body still reads F M / (M + J). An elasticity
//   candidate built on this block therefore cannot start at the fitted model's outputs and be
//   score-tested; it is re-fitted structurally (J, K, c from their nominal values) and judged by
//   the re-fit, without a score test.
//   Motor side. q_m = q + e and qd_m = qd + ed are not outputs of this block (InsertForReaders
//   needs one output, F_c); its states are the signals "<instance>.e", "<instance>.ed", so a
//   caller that measures the motor side sums "<body>.q" and "<instance>.e" into one signal (two
//   signal.gain blocks at k = 1, fixed, writing the same signal).
//   Step size. The mode makes the model stiff for explicit integrators when omega approaches the
//   sample rate: RK4 with step h = T_s / n (sample time T_s, n substeps) is stable only while
//   omega h < 2.8 (2 sqrt 2 on the imaginary axis), i.e. f < 0.45 n / T_s with f = omega / (2 pi)
//   at the current J, K (f0 at the nominal values; it rises when a fit stiffens K or lightens J),
//   and resolves the mode to within 0.3 % per period (amplitude and phase) for omega h <= 0.5, i.e.
//   n >= 12.6 f T_s. Example: 1 kHz data and f0 = 20 Hz need one step (omega h = 0.13); f0 =
//   200 Hz needs n = 3. stiff = false: the mode is a light oscillation to resolve, not a fast
//   decay an implicit method could step over; pick f0 and n (or CVODES) accordingly.
//
// ---- Force elements between signals (plants, not candidates) ----------------------------------
// "mechanics.spring_damper"  (a spring and a damper between two positions)
//     F = k (q_a - q_b) + c (qd_a - qd_b)
//   inputs  q_a, q_b [rad] (-1, 1), qd_a, qd_b [rad/s] (-10, 10) the two ends' positions and
//           speeds (q_b = "" for a spring to ground: an unconnected input reads 0, Model::AddBlock)
//   outputs F_b [N m] (-10, 10) = +F, the force on end b (towards a when stretched);
//           F_a [N m] (-10, 10) = -F, the force on end a. Wire "F_b" to b's force signal and
//           "F_a" to a's (each with "+"): equal and opposite.
//   k [N m/rad]    1 (0, inf)  neutral 0   stiffness
//   c [N m s/rad]  0 (0, inf)  neutral 0   damping
//   option "motion" as above (prismatic: m, m/s, N, N/m, N s/m).
//   Roles: q_a, q_b kPosition; qd_a, qd_b kVelocity; F_a, F_b kForce.
//
// "mechanics.gravity"  (the gravity load of a body on its axis)
//   rotational:  tau_g = mgl sin(q - q_down)      (write it as "-torque": it pulls towards q_down)
//     mgl [N m]     1 (-inf, inf)  neutral 0   m g l of the body's centre of mass at distance l
//     q_down [rad]  0 (-pi, pi)    no neutral  the angle at which the body hangs straight down
//   prismatic:   F_g = m g                        (write it as "-force" on an axis pointing up)
//     m [kg]        1 (0, inf)     neutral 0   the moving mass the axis lifts
//     option "gravity" g [m/s^2] (default 9.80665, > 0)
//   input q [rad] (-pi, pi) or [m] (-1, 1) the axis position (read for a uniform wiring on a
//   prismatic axis, where the weight does not depend on it); output tau_g [N m] or F_g [N]
//   (-10, 10), role kForce; option "motion" as above.
#pragma once

namespace graybox::models {

inline constexpr char kAddedInertia[] = "mechanics.added_inertia";
inline constexpr char kPayload[] = "mechanics.payload";
inline constexpr char kElasticCoupling[] = "mechanics.elastic_coupling";
inline constexpr char kSpringDamper[] = "mechanics.spring_damper";
inline constexpr char kGravityLoad[] = "mechanics.gravity";

/// Standard gravity [m/s^2], the default magnitude of the payload's gravity option.
inline constexpr double kStandardGravity = 9.80665;

/// Default frequency f0 [Hz] of the elastic coupling's mode at its nominal values.
inline constexpr double kDefaultCouplingFrequency = 20.0;
/// Nominal motor-side inertia of the elastic coupling as a fraction of the axis inertia M.
inline constexpr double kDefaultCouplingInertiaRatio = 0.25;
/// Damping ratio of the elastic coupling's mode at its nominal values.
inline constexpr double kDefaultCouplingDamping = 0.1;

}  // namespace graybox::models
