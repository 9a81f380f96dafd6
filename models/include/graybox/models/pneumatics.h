// Pneumatic actuation: orifice flow, chamber pressure, valve areas, slider-crank coupling and the
// 1-DoF pneumatic arm of seed 004 ("Modeling and System Identification of Pneumatic Robot",
// chapter 3), as registered Blocks (block.h) and as the scalar templates below, which every block
// calls, so each equation is written exactly once.
//
// ---- Units ----------------------------------------------------------------------------------
// Pressures are absolute, in kPa; mass flows in kg/s; temperatures in K; time in s; angles in
// rad; torques in N m. Geometry is in millimetres, as in table 3.3: lengths in mm, areas in mm^2,
// volumes in mm^3, volume rates in mm^3/s. These SI-prefixed units are deliberate:
//  - in base SI a chamber volume is ~3e-5 m^3 and a valve area ~1e-6 m^2, smaller than the
//    finite-difference step 6e-6 * max(1, |x|) of the derivative checker (derivative_check.h),
//    and badly scaled for optimizers; in mm they are ~3e4 mm^3 and ~1 mm^2;
//  - in Pa a pressure rate is ~1e7 Pa/s, so one rounding unit of it (~2e-9) over the checker's
//    central difference on a valve voltage (2 x 3e-5 V) is ~3e-5 Pa/s/V: a partial of 20 Pa/s/V
//    (a nearly closed port) fails the relative check at 1e-6. In kPa (values 100..600, rates
//    ~1e4 kPa/s) such partials fall under the checker's absolute floor and pass.
// The conversions live in the templates (kKilopascal, kSquareMillimetre, kCubicMillimetre,
// kMillimetre), never in the caller. Every pressure must be > 0 (absolute): the flow functions
// divide by the higher pressure.
// Signal roles (SignalInfo::role, block.h): pressures are kPressure, the joint angle q kPosition,
// its speed qd kVelocity, the arm torque kForce, valve commands kVoltage; flows, areas and volumes
// have none.
//
// ---- Seed 004 constants (tables 3.2 and 3.3) --------------------------------------------------
//   alpha = 0.1124 sqrt(K) s/m   flow constant of the unchoked branch (eq. 3.1)
//   beta  = 0.029  sqrt(K) s/m   flow constant of the choked branch (eq. 3.2); here DERIVED, below
//   k     = 1.4                  ratio of specific heats of air (and chamber exponent, eq. 3.3)
//   R     = 287.058 J/(kg K)     gas constant of air
//   T     = 298 K                gas temperature
//   A1 = 804 mm^2, A2 = 603 mm^2 bore areas of chambers 1 and 2 (32 mm bore, 16 mm rod)
//   D1 = 8 mm^3, D2 = 6 mm^3     dead volumes (as printed; negligible next to A*x ~ 2e4 mm^3,
//                                and perhaps cm^3 were meant: identify them if it matters)
//   l = 40 mm, r = 15 mm         connecting-rod length and crank radius (the seed's text swaps
//                                the two names; l > r is what makes eq. 3.7-3.10 real)
// alpha and beta are Richer & Hurmuzlu's C2 = sqrt(2k / (R (k - 1))) = 0.15616 and
// C1 = sqrt(k / R (2 / (k + 1))^((k + 1) / (k - 1))) = 0.040414 times a discharge coefficient
// C_f ~ 0.72; the mass flow through an area a is a * (alpha / sqrt(T)) * P_u * psi (kg/s).
//
// Not in the seed, chosen here (document and identify them): the supply pressure 600 kPa absolute
// (5 bar gauge), the exhaust (atmospheric) pressure 101.325 kPa, the length L of eq. 3.10 (80 mm =
// 2 l, so that both chambers sweep the same length range [l - r, l + r] = [25, 55] mm), the valve
// area parameters (a FESTO MPYE-5-M5-class valve, fully open ~2 mm^2 ~ 100 l/min), and the arm's
// inertia, damping and gravity torque.
//
// ---- Seed 004 as printed versus as implemented ------------------------------------------------
//  - eq. 3.3 prints  pdot = +k Vdot p / V + k R T mdot / V.  Compressing a closed chamber must
//    raise its pressure, so the volume term is -k p Vdot / V (Vdot = dV/dt as in eq. 3.7/3.9).
//  - eq. 3.4 prints the factor k R T / V in front of the port flows; that factor turns a mass flow
//    into a pressure rate and belongs to eq. 3.3 (eq. 3.11 shows the seed uses it once). Here the
//    ports block returns the mass flow itself.
//  - eq. 3.10 prints V2 = A2 (L - r cos q + sqrt(l^2 - r^2 sin^2 q)) + D2, but its derivative
//    eq. 3.8 is -A2/A1 times eq. 3.7, which holds for V2 = A2 (L - x) + D2 with the piston position
//    x = r cos q + sqrt(l^2 - r^2 sin^2 q) of eq. 3.9. The latter is implemented.
//  - beta: eq. 3.1 and 3.2 join continuously only if beta = alpha psi(r_cr); with alpha = 0.1124
//    and k = 1.4 that is 0.02909, the table's 0.029 to its two digits. beta is therefore not a
//    parameter; it follows from alpha and kappa, which also makes the derivative continuous.
//  - eq. 3.6 replaces the torque by the pressure difference ("assuming the difference in bore
//    areas is small"); the arm here uses the piston force of both bore areas, see
//    PneumaticTorque.
//
// ---- Block "pneumatic.orifice" (seed 004 eq. 3.1, 3.2) -------------------------------------
// Mass flow through a thin-plate orifice of area a from side "up" to side "down":
//   mdot = sign(p_up - p_down) * a * (alpha / sqrt(T)) * P_u * psi(r),
//   P_u = max(p_up, p_down), P_d = min(p_up, p_down), r = P_d / P_u in (0, 1],
//   psi(r) = r^(1/k) sqrt(1 - r^((k-1)/k))   if r > r_cr   (eq. 3.1: sqrt(r^(2/k) - r^((k+1)/k)))
//   psi(r) = psi(r_cr)                       if r <= r_cr  (choked, eq. 3.2)
//   r_cr = (2 / (k + 1))^(k / (k - 1))       (0.5283 for k = 1.4; the seed's 0.528)
// psi has its maximum at r_cr, so the two branches join with equal value AND equal first
// derivative (with respect to both pressures and to kappa); the second derivative jumps there.
// Reverse flow: the formula is applied with the higher pressure upstream and the sign of the
// pressure difference, so mdot(p_a, p_b) = -mdot(p_b, p_a) exactly.
// Regularisation near equal pressures: sqrt(s), s = 1 - r^((k-1)/k), has an infinite slope at
// s = 0 (r = 1). Below s_lam = 1 - (1 - w)^((k-1)/k), i.e. for pressure ratios r > 1 - w, sqrt(s)
// is replaced by the odd cubic
//   sqrt(s_lam) * (5/4 t - 1/4 t^3),  t = s / s_lam,
// which matches sqrt(s) in value and slope at s = s_lam (C1) and is linear in the pressure
// difference at equal pressures, like the laminar regime of real valves (ISO 6358-3 treats
// r > 0.999 as laminar). Outside the band the flow is exactly eq. 3.1. The default w = 1e-2 (a 1 %
// pressure difference) is a numerical choice: the curvature of sqrt(s) grows like (1 - r)^(-3/2),
// and at 1 - r = 1e-2 central differences with relative step 6e-6 (derivative_check.h) are still
// accurate to 1e-7, and the slope at equal pressures (~1/sqrt(w)) keeps CVODES's Newton
// iterations well conditioned. w = 1e-3 (ISO's laminar limit) is allowed; it makes that slope
// 3x steeper and the finite-difference checks of points just outside the band inaccurate.
// The slope at equal pressures is d mdot / d p_up = a alpha / sqrt(T) * (5/4) ((k-1)/k) /
// sqrt(s_lam) in SI units (finite). All derivatives are finite for positive pressures: the branches
// not taken by an if_else are evaluated at clamped arguments so they cannot produce Inf/NaN
// partials.
//   inputs      p_up [kPa], p_down [kPa], area [mm^2]   (area from "pneumatic.valve_area")
//   outputs     mdot [kg/s], positive from "up" to "down"
//   parameters  alpha [sqrt(K) s/m] 0.1124, >= 0, NEUTRAL 0 (no flow)
//               kappa [-] 1.4 in [1.1, 1.67] (isentropic exponent of the gas)
//               temperature [K] 298 in [200, 400] (upstream gas temperature)
//   options     laminar_width (number, default 1e-2, in (0, 0.05]): w above.
// alpha and temperature enter only as alpha / sqrt(T): identify one of them.
//
// ---- Block "pneumatic.chamber" (seed 004 eq. 3.3, sign corrected) ---------------------------
// Pressure of an ideal gas in a chamber of volume V changing at Vdot, with net inflow mdot:
//   pdot = n (R T mdot - p Vdot) / V
// n = polytropic exponent: 1 isothermal (slow processes), k = 1.4 adiabatic (fast, the seed's
// choice), in between for real cylinders. The R T mdot term assumes the inflowing gas is at T.
// A closed chamber (mdot = 0) follows p V^n = const.
//   state       p [kPa]
//   inputs      mdot [kg/s] (net mass flow into the chamber), volume [mm^3], volume_rate [mm^3/s]
//   parameters  polytropic_exponent [-] 1.4 in [1, 1.67]; temperature [K] 298 in [200, 400]
//   options     gas_constant (number, J/(kg K), default 287.058 for air)
//   stiff       yes: the pressure time constant V / (n R T dmdot/dp) is milliseconds, far below
//               the mechanics; integrate with CVODES (BDF).
//
// ---- Block "pneumatic.ports" (seed 004 eq. 3.4 without the k R T / V factor) ------------------
// The two orifices of one valve: supply (compressor at p_supply) to chamber, chamber to exhaust
// (atmosphere at p_exhaust):
//   mdot_supply  = orifice(p_supply, p, area_supply)     (into the chamber)
//   mdot_exhaust = orifice(p, p_exhaust, area_exhaust)   (out of the chamber)
//   mdot         = mdot_supply - mdot_exhaust
// The seed switches between eq. 3.1 and 3.2 per orifice at P_d / P_u = 0.528 (j in eq. 3.4); the
// orifice function above does the same, smoothly.
//   inputs      p [kPa] (chamber), area_supply [mm^2], area_exhaust [mm^2]
//   outputs     mdot, mdot_supply, mdot_exhaust [kg/s]
//   parameters  alpha (NEUTRAL 0), kappa, temperature as the orifice;
//               p_supply [kPa] 600 in [100, 1200]; p_exhaust [kPa] 101.325 in [50, 200]
//   options     laminar_width as the orifice.
//
// ---- Block "pneumatic.valve_area" (seed 004 section 3.3, eq. 3.12-3.16) ------------------------
// Supply and exhaust orifice areas of a proportional valve as functions of its command u [V]
// (0..10 V; supply open above ~5 V, exhaust below). One block type; the option "model" selects
// one of the seed's three area models:
//   "smax" (default; area model 3, eq. 3.14-3.16):
//       a_c = L_c + smax((u - U_c) B - L_c),   a_r = L_r + smax((U_r - u) B - L_r),
//       smax(z) = (z + sqrt(z^2 + w^2)) / 2    (eq. 3.14 with the width w made explicit; the
//                                              seed's w = 1 is in its lumped area units)
//     i.e. a smoothed max(L, (u - U) B): leakage area L below the opening voltage U, then linear.
//     parameters  leak_supply L_c [mm^2] 0.01 >= 0, leak_exhaust L_r [mm^2] 0.01 >= 0,
//                 u_supply U_c [V] 5.2 in [0, 10], u_exhaust U_r [V] 4.8 in [0, 10],
//                 gain B [mm^2/V] 0.4 >= 0 (one gain for both ports, as in the seed)
//     option      smax_width w [mm^2] (default 0.05, > 0)
//   "quadratic" (area model 2, eq. 3.12, 3.13):
//       a_c = c_theta1 + c_theta2 u + c_theta3 u^2,  a_r = r_theta1 + r_theta2 u + r_theta3 u^2
//     parameters  supply_theta1 [mm^2] 0.165, supply_theta2 [mm^2/V] -0.188,
//                 supply_theta3 [mm^2/V^2] 0.0373, exhaust_theta1 2.02, exhaust_theta2 -0.559,
//                 exhaust_theta3 0.0371 (the least-squares fit of the smax nominal curves on the
//                 seed's grid 0.2..10 V). A quadratic can dip below zero (the nominal supply
//                 curve does near 2.5 V); a negative area reverses that port's flow, as in the
//                 seed's model 2.
//   "table" (area model 1): linear interpolation of per-breakpoint areas,
//       a(u) = a_i + (a_{i+1} - a_i) (u - u_i) / (u_{i+1} - u_i)   for u_i <= u < u_{i+1},
//     held constant below the first and above the last breakpoint.
//     option      breakpoints [V] (numbers, strictly increasing, >= 2 of them; default the seed's
//                 grid 0.2, 0.4, ..., 10.0)
//     parameters  supply_area_<i>, exhaust_area_<i> [mm^2] >= 0, one per breakpoint; nominal: the
//                 smax nominal curve at the breakpoint.
//     derivative  d a / d u at a breakpoint is the slope of the interval to its RIGHT (so 0 at
//                 and beyond the last breakpoint, the right slope at the first); the function is
//                 continuous, its derivative jumps at breakpoints (built with if_else).
//   input   u [V];  outputs area_supply, area_exhaust [mm^2].  No neutral values (a valve is not
//   an additive effect).
//
// ---- Block "pneumatic.slider_crank" (seed 004 eq. 3.7-3.10) -----------------------------------
// Cylinder chambers driven by a crank of radius r through a rod of length l (l > r), joint angle q:
//   x(q)   = r cos q + sqrt(l^2 - r^2 sin^2 q)          piston position [mm] (eq. 3.9)
//   h(q)   = dx/dq = -r sin q - r^2 sin q cos q / sqrt(l^2 - r^2 sin^2 q)   [mm/rad]
//   V1     = A1 x + D1,          V2     = A2 (L - x) + D2                    (eq. 3.9, 3.10)
//   V1dot  = A1 h qd,            V2dot  = -A2 h qd                           (eq. 3.7, 3.8)
// h is the lever arm: a piston force F [N] pushing towards larger x (expanding chamber 1) gives
// the joint torque h F (virtual work). Dead centres (h = 0) at q = 0 and q = pi.
//   inputs      q [rad], qd [rad/s]
//   outputs     volume_1, volume_2 [mm^3]; volume_rate_1, volume_rate_2 [mm^3/s]; lever_arm
//   [mm/rad] parameters  bore_area_1 [mm^2] 804, bore_area_2 [mm^2] 603, dead_volume_1 [mm^3] 8,
//               dead_volume_2 [mm^3] 6, crank_radius [mm] 15 in [5, 25], rod_length [mm] 40 in
//               [30, 60] (the bounds keep l > r), length [mm] 80 (L; must exceed l + r).
//
// ---- Block "pneumatic.piston_torque" (seed 004 eq. 3.6 with both bore areas) ---------------
// Joint torque of a double-acting cylinder's piston force through the slider-crank's lever arm
// (PneumaticTorque below), so that an arm can be assembled from its parts (valve areas, ports,
// chambers, slider-crank, a rigid body) and each part's effects attach where they act:
//   tau = 1e-6 h (A1 (p1 - p_exhaust) - A2 (p2 - p_exhaust))     [N m]
//   inputs      p1, p2 [kPa] (absolute chamber pressures), lever_arm h [mm/rad] (from
//               "pneumatic.slider_crank")
//   outputs     torque [N m] (on the joint; role force)
//   parameters  bore_area_1 [mm^2] 804, bore_area_2 [mm^2] 603 (as the slider-crank's: fix them or
//               tie them to the same values), p_exhaust [kPa] 101.325 in [50, 200] (the ambient
//               pressure on the rod cross-section A1 - A2).
//
// ---- Block "pneumatic.arm" (seed 004 eq. 3.1-3.4, 3.6-3.10, 3.12-3.16) ------------------------
// One joint driven by a double-acting cylinder through the slider-crank, each chamber fed by its
// own proportional valve (figure 3.3):
//   q' = qd
//   qd' = (tau - damping qd - gravity_torque sin(q - gravity_angle)) / inertia
//   tau = 1e-6 h(q) (A1 (p1 - p_exhaust) - A2 (p2 - p_exhaust))     [N m]      (PneumaticTorque)
//   p1' = chamber(p1, ports(p1, valve_area_1(u1)), V1(q), V1dot(q, qd))
//   p2' = chamber(p2, ports(p2, valve_area_2(u2)), V2(q), V2dot(q, qd))
// The ambient pressure p_exhaust acts on the rod cross-section A1 - A2, so equal chamber pressures
// give zero torque only when they are atmospheric or the bore areas are equal (the seed's eq. 3.6
// approximation). The same kappa is used by all four orifices and the same temperature by the
// orifices and chambers (the seed's k and T).
//   states      q [rad], qd [rad/s], p1 [kPa], p2 [kPa]
//   inputs      u1, u2 [V] (valve commands)
//   outputs     torque [N m] (pneumatic torque tau)
//   parameters  alpha, kappa, temperature, polytropic_exponent, p_supply, p_exhaust (as above);
//               the seven slider-crank parameters; inertia [kg m^2] 0.02 > 0, damping
//               [N m s/rad] 0.05 >= 0, gravity_torque [N m] 0.5 (m g l_c), gravity_angle [rad]
//               pi/2 (angle of the stable hanging position); then the valve-area parameters of
//               valve 1 and valve 2, prefixed "valve1_" and "valve2_".
//   options     valve_model ("smax", "quadratic", "table"), breakpoints, smax_width,
//               laminar_width, gas_constant (as above).
//   stiff       yes (the chamber pressures, as "pneumatic.chamber").
// Seed 004 also lists q1, q1d of the other joint as inputs for coupling effects; the 1-DoF block
// leaves them out (add a rigid-body block for that).
//
// Every factory validates its options (CheckOptionKeys: unknown keys fail with a did-you-mean
// hint; values out of range fail with "expected ..., got ...").
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include "graybox/expr/expr.h"

namespace graybox::models::pneumatics {

// ---- Units and constants --------------------------------------------------------------------
constexpr double kKilopascal = 1e3;         // Pa per kPa
constexpr double kMillimetre = 1e-3;        // m per mm
constexpr double kSquareMillimetre = 1e-6;  // m^2 per mm^2
constexpr double kCubicMillimetre = 1e-9;   // m^3 per mm^3

constexpr double kAirGasConstant = 287.058;       // J/(kg K), table 3.2
constexpr double kAtmosphericPressure = 101.325;  // kPa
constexpr double kDefaultLaminarWidth = 1e-2;     // pressure-ratio band 1 - r of the cubic
constexpr double kDefaultSmaxWidth = 0.05;        // mm^2, width of eq. 3.14

// Nominal values (tables 3.2 and 3.3, and the documented choices above).
constexpr double kNominalAlpha = 0.1124;          // sqrt(K) s/m
constexpr double kNominalKappa = 1.4;             // -
constexpr double kNominalTemperature = 298.0;     // K
constexpr double kNominalSupplyPressure = 600.0;  // kPa absolute
constexpr double kNominalBoreArea1 = 804.0;       // mm^2
constexpr double kNominalBoreArea2 = 603.0;       // mm^2
constexpr double kNominalDeadVolume1 = 8.0;       // mm^3
constexpr double kNominalDeadVolume2 = 6.0;       // mm^3
constexpr double kNominalCrankRadius = 15.0;      // mm (r)
constexpr double kNominalRodLength = 40.0;        // mm (l)
constexpr double kNominalLength = 80.0;           // mm (L, not in the seed: 2 l)

namespace internal {
// Scalar-generic selection and comparison, with libexpr's derivative conventions (ops.h): the
// derivative of a selection is that of the branch taken; max passes the derivative to its first
// argument at a tie.
inline double IfElse(double c, double a, double b) { return c != 0.0 ? a : b; }
inline expr::Expr IfElse(const expr::Expr& c, const expr::Expr& a, const expr::Expr& b) {
  return expr::if_else(c, a, b);
}
inline double Less(double a, double b) { return a < b ? 1.0 : 0.0; }
inline expr::Expr Less(const expr::Expr& a, const expr::Expr& b) { return expr::lt(a, b); }
inline double LessEqual(double a, double b) { return a <= b ? 1.0 : 0.0; }
inline expr::Expr LessEqual(const expr::Expr& a, const expr::Expr& b) { return expr::le(a, b); }
inline double GreaterEqual(double a, double b) { return a >= b ? 1.0 : 0.0; }
inline expr::Expr GreaterEqual(const expr::Expr& a, const expr::Expr& b) { return expr::ge(a, b); }
inline double Max(double a, double b) { return a >= b ? a : b; }
inline expr::Expr Max(const expr::Expr& a, const expr::Expr& b) { return expr::max(a, b); }
}  // namespace internal

// ---- Orifice (eq. 3.1, 3.2) -----------------------------------------------------------------

/// r_cr = (2 / (kappa + 1))^(kappa / (kappa - 1)): 0.528 for air.
template <typename Scalar>
Scalar CriticalPressureRatio(const Scalar& kappa) {
  using std::pow;
  return pow(Scalar(2.0) / (kappa + 1.0), kappa / (kappa - 1.0));
}

/// sqrt(s) for s >= width, the odd C1 cubic sqrt(width) (5/4 t - 1/4 t^3), t = s / width, below.
/// `s` must be >= 0 (the sign is applied by the caller); the result and its derivative are finite.
template <typename Scalar>
Scalar RegularizedSqrt(const Scalar& s, const Scalar& width) {
  using std::sqrt;
  const Scalar t = s / width;
  const Scalar cubic = sqrt(width) * (1.25 * t - 0.25 * t * t * t);
  return internal::IfElse(internal::Less(s, width), cubic, sqrt(internal::Max(s, width)));
}

/// The flow constants of an orifice: mdot = area * alpha / sqrt(T) * P_u * psi(r).
template <typename Scalar>
struct OrificeConstants {
  Scalar alpha;                                 // sqrt(K) s/m, table 3.2: 0.1124
  Scalar kappa;                                 // isentropic exponent, 1.4 for air
  Scalar temperature;                           // K, upstream gas temperature
  double laminar_width = kDefaultLaminarWidth;  // pressure-ratio band 1 - r of the cubic
};

/// Mass flow [kg/s] from side a to side b through an orifice of area `area` [mm^2]: eq. 3.1/3.2
/// with the higher pressure upstream, the sign of p_a - p_b, and the regularisation described in
/// the header comment. Pressures are absolute [kPa] and must be > 0.
template <typename Scalar>
Scalar OrificeMassFlow(const Scalar& p_a, const Scalar& p_b, const Scalar& area,
                       const OrificeConstants<Scalar>& c) {
  using std::pow;
  using std::sqrt;
  const Scalar forward = internal::GreaterEqual(p_a, p_b);
  const Scalar p_up = internal::IfElse(forward, p_a, p_b);
  const Scalar p_down = internal::IfElse(forward, p_b, p_a);
  const Scalar direction = internal::IfElse(forward, Scalar(1.0), Scalar(-1.0));
  const Scalar ratio = p_down / p_up;
  const Scalar ratio_cr = CriticalPressureRatio(c.kappa);
  const Scalar inv_kappa = 1.0 / c.kappa;
  const Scalar gamma = (c.kappa - 1.0) / c.kappa;
  // Unchoked branch, evaluated at max(r, r_cr) so it stays finite where it is not taken.
  const Scalar ratio_sub = internal::Max(ratio, ratio_cr);
  const Scalar s = 1.0 - pow(ratio_sub, gamma);
  const Scalar s_laminar = 1.0 - pow(Scalar(1.0 - c.laminar_width), gamma);
  const Scalar psi_unchoked = pow(ratio_sub, inv_kappa) * RegularizedSqrt(s, s_laminar);
  // Choked branch: the same expression at r_cr (its maximum), so both branches join in C1.
  const Scalar psi_choked = pow(ratio_cr, inv_kappa) * sqrt(1.0 - pow(ratio_cr, gamma));
  const Scalar psi =
      internal::IfElse(internal::LessEqual(ratio, ratio_cr), psi_choked, psi_unchoked);
  return direction * (kSquareMillimetre * kKilopascal * area) * (c.alpha / sqrt(c.temperature)) *
         p_up * psi;
}

// ---- Chamber (eq. 3.3) ----------------------------------------------------------------------

/// pdot = n (R T mdot - p Vdot) / V [kPa/s]; p [kPa], volume [mm^3], volume_rate [mm^3/s],
/// mdot [kg/s].
template <typename Scalar>
Scalar ChamberPressureRate(const Scalar& p, const Scalar& mdot, const Scalar& volume,
                           const Scalar& volume_rate, const Scalar& polytropic_exponent,
                           const Scalar& temperature, double gas_constant = kAirGasConstant) {
  return polytropic_exponent *
         (gas_constant * temperature * mdot / (kCubicMillimetre * kKilopascal) - p * volume_rate) /
         volume;
}

// ---- Ports (eq. 3.4) ------------------------------------------------------------------------

template <typename Scalar>
struct PortFlows {
  Scalar net;      // into the chamber, supply - exhaust [kg/s]
  Scalar supply;   // supply -> chamber [kg/s]
  Scalar exhaust;  // chamber -> exhaust [kg/s]
};

template <typename Scalar>
PortFlows<Scalar> PortMassFlows(const Scalar& p, const Scalar& area_supply,
                                const Scalar& area_exhaust, const Scalar& p_supply,
                                const Scalar& p_exhaust, const OrificeConstants<Scalar>& c) {
  PortFlows<Scalar> f;
  f.supply = OrificeMassFlow(p_supply, p, area_supply, c);
  f.exhaust = OrificeMassFlow(p, p_exhaust, area_exhaust, c);
  f.net = f.supply - f.exhaust;
  return f;
}

// ---- Valve areas (section 3.3) --------------------------------------------------------------

template <typename Scalar>
struct ValveAreas {
  Scalar supply;   // a_c [mm^2]
  Scalar exhaust;  // a_r [mm^2]
};

/// Eq. 3.14-3.16: a = L + smax(z - L) with smax(z) = (z + sqrt(z^2 + w^2)) / 2.
template <typename Scalar>
Scalar SmaxArea(const Scalar& leak, const Scalar& z, double width) {
  using std::sqrt;
  const Scalar y = z - leak;
  return leak + 0.5 * (y + sqrt(y * y + width * width));
}

template <typename Scalar>
ValveAreas<Scalar> ValveAreaSmax(const Scalar& u, const Scalar& leak_supply,
                                 const Scalar& leak_exhaust, const Scalar& u_supply,
                                 const Scalar& u_exhaust, const Scalar& gain, double width) {
  return {SmaxArea(leak_supply, (u - u_supply) * gain, width),
          SmaxArea(leak_exhaust, (u_exhaust - u) * gain, width)};
}

/// Eq. 3.12, 3.13; theta_* point to three coefficients (constant, linear, quadratic).
template <typename Scalar>
ValveAreas<Scalar> ValveAreaQuadratic(const Scalar& u, const Scalar* theta_supply,
                                      const Scalar* theta_exhaust) {
  return {theta_supply[0] + (theta_supply[1] + theta_supply[2] * u) * u,
          theta_exhaust[0] + (theta_exhaust[1] + theta_exhaust[2] * u) * u};
}

/// Piecewise-linear interpolation of values[i] at breakpoints[i] (strictly increasing, >= 2),
/// held constant outside; derivative at a breakpoint: the slope of the interval to its right.
template <typename Scalar>
Scalar PiecewiseLinear(const Scalar& u, const std::vector<double>& breakpoints,
                       const Scalar* values) {
  // a(u) = values[0] + sum_i slope_i * clamp(u - b_i, 0, b_{i+1} - b_i), with the clamp written
  // as selections so that each breakpoint belongs to the interval on its right.
  Scalar a = values[0];
  for (std::size_t i = 0; i + 1 < breakpoints.size(); ++i) {
    const double b0 = breakpoints[i], b1 = breakpoints[i + 1];
    const Scalar slope = (values[i + 1] - values[i]) / (b1 - b0);
    const Scalar run =
        internal::IfElse(internal::Less(u, Scalar(b0)), Scalar(0.0),
                         internal::IfElse(internal::Less(u, Scalar(b1)), u - b0, Scalar(b1 - b0)));
    a = a + slope * run;
  }
  return a;
}

// ---- Slider-crank coupling (eq. 3.7-3.10) ---------------------------------------------------

template <typename Scalar>
struct SliderCrankGeometry {
  Scalar bore_area_1;    // A1 [mm^2]
  Scalar bore_area_2;    // A2 [mm^2]
  Scalar dead_volume_1;  // D1 [mm^3]
  Scalar dead_volume_2;  // D2 [mm^3]
  Scalar crank_radius;   // r [mm]
  Scalar rod_length;     // l [mm], > r
  Scalar length;         // L [mm], > l + r
};

template <typename Scalar>
struct SliderCrankState {
  Scalar piston_position;  // x [mm]
  Scalar lever_arm;        // h = dx/dq [mm/rad]
  Scalar volume_1;         // V1 [mm^3]
  Scalar volume_2;         // V2 [mm^3]
  Scalar volume_rate_1;    // dV1/dt [mm^3/s]
  Scalar volume_rate_2;    // dV2/dt [mm^3/s]
};

template <typename Scalar>
SliderCrankState<Scalar> SliderCrank(const Scalar& q, const Scalar& qd,
                                     const SliderCrankGeometry<Scalar>& g) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const Scalar s = sin(q), c = cos(q);
  const Scalar r = g.crank_radius;
  const Scalar root = sqrt(g.rod_length * g.rod_length - r * r * s * s);
  SliderCrankState<Scalar> k;
  k.piston_position = r * c + root;
  k.lever_arm = -r * s - r * r * s * c / root;
  k.volume_1 = g.bore_area_1 * k.piston_position + g.dead_volume_1;
  k.volume_2 = g.bore_area_2 * (g.length - k.piston_position) + g.dead_volume_2;
  k.volume_rate_1 = g.bore_area_1 * k.lever_arm * qd;
  k.volume_rate_2 = -g.bore_area_2 * k.lever_arm * qd;
  return k;
}

/// Joint torque [N m] of the piston force A1 p1 - A2 p2 - (A1 - A2) p_ambient through the lever
/// arm h [mm]; areas in mm^2, pressures in kPa. Written with gauge pressures, so that equal
/// atmospheric pressures (or equal pressures and bores) give exactly zero.
template <typename Scalar>
Scalar PneumaticTorque(const Scalar& lever_arm, const Scalar& p1, const Scalar& p2,
                       const Scalar& bore_area_1, const Scalar& bore_area_2,
                       const Scalar& p_ambient) {
  const Scalar force_mm2_kpa = bore_area_1 * (p1 - p_ambient) - bore_area_2 * (p2 - p_ambient);
  return (kMillimetre * kSquareMillimetre * kKilopascal) * lever_arm * force_mm2_kpa;
}

}  // namespace graybox::models::pneumatics
