// Chamber effects: a leak and a change of the polytropic exponent of a pneumatic.chamber
// (pneumatics.h), as blocks that leave the chamber unchanged at their neutral values, registered
// in BlockRegistry::Global() under the type names below. Units as in pneumatics.h: pressures
// absolute in kPa, mass flows in kg/s, volume rates in mm^3/s, temperatures in K.
//
// ---- Why blocks outside the chamber -----------------------------------------------------------
// The chamber's pressure is its own state, which only the chamber block writes (model.h), and its
// exponent n may be a fixed setting of the problem. Both effects therefore act on the chamber's
// net mass-flow input: a leak subtracts a flow from it; the exponent change rescales it together
// with the volume term, which gives exactly the chamber equation with another exponent.
//
// ---- Listing format ---------------------------------------------------------------------------
// Signals name [unit] (typical range); parameters name [unit] nominal (lower, upper) neutral.
//
// "pneumatic.leak"  (laminar leak to the atmosphere)
//     mdot = G (p - p_ext)
//   input  p [kPa] (101.325, 600) the chamber pressure;  output mdot [kg/s] (-5e-3, 5e-3), the
//   flow leaving the chamber (connect it as "-<chamber mdot signal>")
//   G [kg/(s kPa)]  2.5e-8 (0, inf)  neutral 0   leak conductance (the nominal: about 0.5 l/min of
//                   free air at 400 kPa of overpressure, a worn seal)
//   option "exhaust_pressure" p_ext [kPa] (> 0, default 101.325). Laminar (linear in the
//   pressure difference): small leaks through seals are; an orifice leak is pneumatic.orifice.
//
// "pneumatic.polytropic_correction"  (relative change e of the chamber's exponent)
//     mdot_eff = (1 + e) mdot - e p Vdot / (R T) * 1e-6
//   so that R T mdot_eff / 1e-6 - p Vdot = (1 + e) (R T mdot / 1e-6 - p Vdot) (the 1e-6 converts
//   kPa mm^3 to J): a chamber reading mdot_eff follows pdot = n (1 + e) (R T mdot - p Vdot) / V,
//   the exponent n (1 + e). At e = 0, mdot_eff = 1.0 mdot - 0 = mdot exactly.
//   inputs mdot [kg/s] (-5e-3, 5e-3) the net inflow, p [kPa] (101.325, 600) the chamber pressure,
//   volume_rate [mm^3/s] (-2e5, 2e5);  output mdot_eff [kg/s]
//   e [1]  0 (-0.5, 1)  neutral 0   relative change of the polytropic exponent (n = 1.4, e = -0.2:
//          n 1.12, towards isothermal)
//   options "temperature" T [K] (> 0, default 298) and "gas_constant" R [J/(kg K)] (> 0, default
//   287.058): the chamber's (its temperature parameter's value when the block is applied).
#pragma once

namespace graybox::models {

inline constexpr char kChamberLeak[] = "pneumatic.leak";
inline constexpr char kPolytropicCorrection[] = "pneumatic.polytropic_correction";

}  // namespace graybox::models
