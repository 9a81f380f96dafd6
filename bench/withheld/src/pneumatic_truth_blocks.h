// Truth-only blocks of the pneumatic withheld-effect cases (pneumatic_base.cc), private to
// graybox::withheld like truth_blocks.h: never registered, so no diagnosis candidate can be one of
// them. Units as graybox/models/pneumatics.h: pressures absolute in kPa, mass flows in kg/s,
// volumes in mm^3, volume rates in mm^3/s, temperatures in K, areas in mm^2.
//
// "withheld.orifice_leak"   a worn seal as a small orifice from the chamber to the atmosphere:
//     mdot = orifice(p, p_ext, a_leak)        (pneumatics.h OrificeMassFlow: choked/unchoked,
//                                              turbulent; the library's candidate is laminar)
//   input p [kPa] (pressure); output mdot [kg/s], the flow leaving the chamber (connect it as
//   "-<chamber's net mass-flow signal>"); parameters area [mm^2] the leak area, alpha
//   [sqrt(K) s/m] 0.1124, kappa [1] 1.4, temperature [K] 298; option p_ext = 101.325 kPa.
//
// "withheld.thermal_chamber"   a chamber whose gas exchanges heat with the cylinder wall (the
// nominal "pneumatic.chamber" is polytropic with a fixed exponent). Energy balance of an ideal
// gas with the internal energy U = p V / (k - 1), inflow from the supply at T_s, outflow at the
// gas temperature T, heat flow hA (T_w - T) from the wall (SI inside: P = 1e3 p [Pa],
// V = 1e-9 volume [m^3]):
//     dP/dt = (k R (T_s ms - T me) - k P dV/dt + (k - 1) hA (T_w - T)) / V
//     dT/dt = T (dP/dt / P + dV/dt / V - (ms - me) / m),   m = P V / (R T)
//   hA = 0 with T = T_s is the adiabatic chamber (exponent k); hA -> inf the isothermal one
//   (exponent 1); in between the effective exponent depends on the speed of the process, which
//   no single polytropic exponent reproduces exactly.
//   states p [kPa] (pressure), T [K]; inputs ms [kg/s] supply -> chamber, me [kg/s] chamber ->
//   exhaust (pneumatic.ports' second and third outputs), volume [mm^3], volume_rate [mm^3/s];
//   parameters kappa [1] 1.4, T_s [K] supply temperature 298, T_w [K] wall temperature 298,
//   hA [W/K] heat-transfer conductance; option R = 287.058 J/(kg K).
#pragma once

#include <cmath>

#include "graybox/models/pneumatics.h"
#include "truth_blocks.h"

namespace graybox::bench::internal {

class OrificeLeakBlock : public models::BlockBase<OrificeLeakBlock> {
 public:
  OrificeLeakBlock() {
    info_.type = "withheld.orifice_leak";
    info_.description = "Turbulent leak of a chamber to the atmosphere through a small orifice.";
    info_.reference = "bench/withheld/src/pneumatic_truth_blocks.h";
    info_.inputs = {
        TruthSignal("p", "kPa", "chamber pressure", 101.325, 600.0, SignalRole::kPressure)};
    info_.outputs = {TruthSignal("mdot", "kg/s", "flow leaving the chamber (subtract it)", -1e-3,
                                 1e-3, SignalRole::kNone)};
    info_.parameters = {
        TruthParameter("area", "mm^2", "leak area", 0.01, 0.0, kInf),
        TruthParameter("alpha", "sqrt(K) s/m", "orifice flow constant", 0.1124, 0.0, kInf),
        TruthParameter("kappa", "1", "isentropic exponent", 1.4, 1.1, 1.67),
        TruthParameter("temperature", "K", "gas temperature", 298.0, 200.0, 400.0)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    namespace pn = models::pneumatics;
    const pn::OrificeConstants<Scalar> c{a.p[1], a.p[2], a.p[3]};
    a.y[0] = pn::OrificeMassFlow(a.u[0], Scalar(pn::kAtmosphericPressure), a.p[0], c);
  }
};

class ThermalChamberBlock : public models::BlockBase<ThermalChamberBlock> {
 public:
  ThermalChamberBlock() {
    info_.type = "withheld.thermal_chamber";
    info_.description =
        "Chamber pressure and gas temperature with heat exchange to the wall (energy balance).";
    info_.reference = "bench/withheld/src/pneumatic_truth_blocks.h";
    info_.states = {
        TruthSignal("p", "kPa", "absolute chamber pressure", 101.325, 600.0, SignalRole::kPressure),
        TruthSignal("T", "K", "gas temperature", 250.0, 350.0, SignalRole::kNone)};
    info_.inputs = {
        TruthSignal("ms", "kg/s", "mass flow supply -> chamber", -5e-3, 5e-3, SignalRole::kNone),
        TruthSignal("me", "kg/s", "mass flow chamber -> exhaust", -5e-3, 5e-3, SignalRole::kNone),
        TruthSignal("volume", "mm^3", "chamber volume", 1.5e4, 5e4, SignalRole::kNone),
        TruthSignal("volume_rate", "mm^3/s", "dV/dt", -2e5, 2e5, SignalRole::kNone)};
    info_.parameters = {
        TruthParameter("kappa", "1", "ratio of specific heats", 1.4, 1.1, 1.67),
        TruthParameter("T_s", "K", "supply gas temperature", 298.0, 200.0, 400.0),
        TruthParameter("T_w", "K", "wall temperature", 298.0, 200.0, 400.0),
        TruthParameter("hA", "W/K", "heat-transfer conductance gas <-> wall", 0.2, 0.0, kInf)};
    info_.stiff = true;
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    constexpr double kR = models::pneumatics::kAirGasConstant;
    const Scalar P = 1e3 * a.x[0];
    const Scalar T = a.x[1];
    const Scalar V = 1e-9 * a.u[2];
    const Scalar Vd = 1e-9 * a.u[3];
    const Scalar& k = a.p[0];
    const Scalar heat = a.p[3] * (a.p[2] - T);
    const Scalar Pdot =
        (k * kR * (a.p[1] * a.u[0] - T * a.u[1]) - k * P * Vd + (k - 1.0) * heat) / V;
    const Scalar mass = P * V / (kR * T);
    a.xdot[0] = 1e-3 * Pdot;
    a.xdot[1] = T * (Pdot / P + Vd / V - (a.u[0] - a.u[1]) / mass);
  }
};

}  // namespace graybox::bench::internal
