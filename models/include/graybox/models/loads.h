// Added-load blocks: an extra inertia on a rigid axis and a payload (extra inertia plus its
// gravity load), registered in BlockRegistry::Global() under the type names below. They are put
// in series on the net force a rigid-body block reads (Model::InsertForReaders with that block as
// the only reader), which is how an extra inertia enters without an algebraic loop: this header
// is their reference (equations, units, parameters with nominal values, bounds and neutral
// values, options).
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
#pragma once

namespace graybox::models {

inline constexpr char kAddedInertia[] = "mechanics.added_inertia";
inline constexpr char kPayload[] = "mechanics.payload";

/// Standard gravity [m/s^2], the default magnitude of the payload's gravity option.
inline constexpr double kStandardGravity = 9.80665;

}  // namespace graybox::models
