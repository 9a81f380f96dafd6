// Truth-only blocks of the withheld-effect cases (and the pendulum's gravity, which the nominal
// model uses too). Private to graybox::withheld: they are never registered in the global block
// registry, so no candidate of the diagnosis can be one of them. Each is written once, generic
// over the scalar (double and expr::Expr), as the blocks of models/src.
//
// Sign convention as friction.h: friction outputs have the sign of the velocity and are
// SUBTRACTED ("-force"); disturbance outputs are subtracted the same way. Units are given for a
// rotational axis (rad, rad/s, N m); the friction, ripple, drift and disturbance blocks take
// `prismatic` = true for a slide (m, m/s, N).
//
// The hard sign. sgn(v) = (2/pi) atan(v / vd): odd, |sgn| < 1, within 1 % of sign(v) above
// |v| = 64 vd. The library's blocks use tanh(s v), which reaches sign(v) exponentially; with
// vd = 1e-4 .. 1e-3 of the speeds the cases reach, the atan is the "hard" sign of the truth (a
// true discontinuity would make the simulation of a stuck axis chatter). Its slope 2/(pi vd) at 0
// is stiff, which CVODES integrates without trouble.
//
// "withheld.gravity"   tau = mgl sin(q)
//   input q [rad] (position), output tau [N m] (force; connect "-torque");
//   mgl [N m] mass times gravity times distance of the centre of mass from the pivot.
//
// "withheld.dry_friction"   direction-dependent Coulomb levels with a Stribeck hump:
//     s = sgn(v),  p = (s + |s|) / 2,  n = (s - |s|) / 2,
//     e = exp(-((v / vs)^2 + 1e-12)^(a/2)),
//     tau = (fc_pos + ds e) p + (fc_neg + ds e) n
//   input qd [rad/s]; output tau [N m]; parameters
//     fc_pos [N m] Coulomb level in positive motion, fc_neg [N m] in negative motion,
//     ds [N m] Stribeck excess at standstill (fs - fc), vs [rad/s] Stribeck velocity,
//     a [1] Stribeck exponent (the library's friction.stribeck uses 2), vd [rad/s] atan width.
//   Symmetric Coulomb: fc_pos = fc_neg, ds = 0. Direction-dependent levels: fc_pos != fc_neg.
//   Stribeck excess on top of a Coulomb level modelled elsewhere: fc_pos = fc_neg = 0, ds > 0.
//
// "withheld.power_law"   tau = c sgn(v) ((v / v0)^2 + 1e-12)^(k/2)
//   input qd [rad/s]; output tau [N m]; c [N m] the torque at |v| = v0, k [1] the exponent,
//   v0 [rad/s] the reference speed, vd [rad/s] atan width.
//
// "withheld.dead_zone"   y = u - (|u + d| - |u - d|) / 2   (exact: 0 inside [-d, d], u -+ d
// outside)
//   input u, output y (unit as the option "unit"); d the half width.
//
// "withheld.two_mass"   drive.two_mass (drives.h) with the EXACT backlash dead zone:
//     delta = q_m - q_l,  DZ(delta) = delta - (|delta + b| - |delta - b|) / 2,
//     DZ'(delta) = 1 - (sign(delta + b) - sign(delta - b)) / 2  (1 outside the gap, 0 inside),
//     tau_s = Ke DZ(delta) + d DZ'(delta) (qd_m - qd_l),
//     J dqd_m/dt = tau_m - tau_s,  I dqd_l/dt = tau_s + tau_ext
//   Same states, inputs, outputs and parameter names (J, I, Ke, d, b) as drive.two_mass with the
//   option backlash = 1, whose dead zone is smoothed over eps = 1e-4 rad.
//
// "withheld.coupling"   a spring-damper between two bodies on one axis:
//     f = k (q1 - q2) + d (qd1 - qd2)
//   inputs q1, qd1, q2, qd2; outputs f1 = -f [N] (the force on body 1) and f2 = +f (on body 2);
//   k [N/m] stiffness, d [N s/m] damping.
//
// "withheld.cogging"   tau = a1 sin(2 pi q / P + phi1) + a2 sin(2 pi h2 q / P + phi2)
//   input q [rad]; output tau [N m]; a1, a2 [N m] amplitudes, P [rad] the period, h2 [1] the
//   order of the second harmonic, phi1, phi2 [rad] phases.
//
// "withheld.friction_drift"   a Coulomb level that drifts with time (warm-up of a lubricant):
//     dt_c/dt = 1,  tau = fc r (t_c / T) sgn(v)
//   state t_c [s] (a clock; start it at 0); input qd; output tau [N m]; fc [N m] the level at
//   t = 0 that drifts, r [1] its relative change over T [s], vd [rad/s] atan width.
//
// "withheld.periodic_force"   a disturbance unrelated to the motion (a pump, an unbalanced fan):
//     dt_c/dt = 1,  tau = A sin(2 pi f t_c + phi)
//   state t_c [s]; no input; output tau [N m]; A [N m], f [Hz], phi [rad].
//
// "withheld.sensor"   y = scale u + offset   (a miscalibrated sensor: gain and zero errors)
//   input u [rad]; output y [rad]; scale [1], offset [rad].
#pragma once

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "graybox/models/block.h"

namespace graybox::bench::internal {

inline constexpr double kPi = 3.14159265358979323846;

inline models::ParameterInfo TruthParameter(std::string name, std::string unit,
                                            std::string description, double nominal, double lower,
                                            double upper) {
  models::ParameterInfo p;
  p.name = std::move(name);
  p.unit = std::move(unit);
  p.description = std::move(description);
  p.nominal = nominal;
  p.lower = lower;
  p.upper = upper;
  return p;
}

inline models::SignalInfo TruthSignal(std::string name, std::string unit, std::string description,
                                      double lo, double hi, models::SignalRole role) {
  models::SignalInfo s;
  s.name = std::move(name);
  s.unit = std::move(unit);
  s.description = std::move(description);
  s.typical_min = lo;
  s.typical_max = hi;
  s.role = role;
  return s;
}

// The unit of a rotational axis quantity, or of its prismatic counterpart (rad -> m, rad/s ->
// m/s, N m -> N) for a block on a slide: Model::Build refuses a rotational port on a prismatic
// signal.
inline std::string AxisUnit(const std::string& rotational, bool prismatic) {
  if (!prismatic) return rotational;
  if (rotational == "rad") return "m";
  if (rotational == "rad/s") return "m/s";
  if (rotational == "N m") return "N";
  return rotational;
}

// (2/pi) atan(v / vd), the truth's hard sign.
template <typename Scalar>
Scalar HardSign(const Scalar& v, const Scalar& vd) {
  using std::atan;
  return (2.0 / kPi) * atan(v / vd);
}

inline constexpr double kInf = std::numeric_limits<double>::infinity();
using models::SignalRole;

class GravityBlock : public models::BlockBase<GravityBlock> {
 public:
  GravityBlock() {
    info_.type = "withheld.gravity";
    info_.description = "Gravity torque of a rigid arm on a horizontal pivot: tau = mgl sin(q).";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.inputs = {TruthSignal("q", "rad", "arm angle from the hanging position", -3.2, 3.2,
                                SignalRole::kPosition)};
    info_.outputs = {
        TruthSignal("tau", "N m", "gravity torque (subtract it)", -3.0, 3.0, SignalRole::kForce)};
    info_.parameters = {TruthParameter(
        "mgl", "N m", "mass x gravity x distance of the centre of mass", 1.0, 0.0, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    using std::sin;
    a.y[0] = a.p[0] * sin(a.u[0]);
  }
};

class DryFrictionBlock : public models::BlockBase<DryFrictionBlock> {
 public:
  explicit DryFrictionBlock(bool prismatic = false) {
    info_.type = "withheld.dry_friction";
    info_.description =
        "Direction-dependent Coulomb levels with a Stribeck hump of exponent a, "
        "hard (atan) sign.";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.inputs = {TruthSignal("qd", AxisUnit("rad/s", prismatic), "velocity", -20, 20,
                                SignalRole::kVelocity)};
    info_.outputs = {TruthSignal("tau", AxisUnit("N m", prismatic), "friction (subtract it)", -1, 1,
                                 SignalRole::kForce)};
    info_.parameters = {
        TruthParameter("fc_pos", "N m", "Coulomb level in positive motion", 0.0, 0.0, kInf),
        TruthParameter("fc_neg", "N m", "Coulomb level in negative motion", 0.0, 0.0, kInf),
        TruthParameter("ds", "N m", "Stribeck excess fs - fc", 0.0, 0.0, kInf),
        TruthParameter("vs", "rad/s", "Stribeck velocity", 1.0, 1e-9, kInf),
        TruthParameter("a", "1", "Stribeck exponent", 1.4, 0.1, 5.0),
        TruthParameter("vd", "rad/s", "width of the atan sign", 1e-3, 1e-12, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    using std::abs;
    using std::exp;
    using std::pow;
    const Scalar& v = a.u[0];
    const Scalar s = HardSign(v, a.p[5]);
    const Scalar pos = 0.5 * (s + abs(s));
    const Scalar neg = 0.5 * (s - abs(s));
    const Scalar r = v / a.p[3];
    const Scalar e = exp(-pow(r * r + 1e-12, 0.5 * a.p[4]));
    a.y[0] = (a.p[0] + a.p[2] * e) * pos + (a.p[1] + a.p[2] * e) * neg;
  }
};

class PowerLawBlock : public models::BlockBase<PowerLawBlock> {
 public:
  explicit PowerLawBlock(bool prismatic = false) {
    info_.type = "withheld.power_law";
    info_.description = "Power-law viscous friction c sgn(v) |v/v0|^k with a hard (atan) sign.";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.inputs = {TruthSignal("qd", AxisUnit("rad/s", prismatic), "velocity", -20, 20,
                                SignalRole::kVelocity)};
    info_.outputs = {TruthSignal("tau", AxisUnit("N m", prismatic), "friction (subtract it)", -1, 1,
                                 SignalRole::kForce)};
    info_.parameters = {TruthParameter("c", "N m", "torque at |v| = v0", 0.0, 0.0, kInf),
                        TruthParameter("k", "1", "exponent", 0.5, 0.05, 5.0),
                        TruthParameter("v0", "rad/s", "reference speed", 1.0, 1e-9, kInf),
                        TruthParameter("vd", "rad/s", "width of the atan sign", 1e-3, 1e-12, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    using std::pow;
    const Scalar r = a.u[0] / a.p[2];
    a.y[0] = a.p[0] * HardSign(a.u[0], a.p[3]) * pow(r * r + 1e-12, 0.5 * a.p[1]);
  }
};

class DeadZoneBlock : public models::BlockBase<DeadZoneBlock> {
 public:
  explicit DeadZoneBlock(const std::string& unit) {
    info_.type = "withheld.dead_zone";
    info_.description = "Exact dead zone y = u - clamp(u, -d, d).";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.inputs = {TruthSignal("u", unit, "command", -10, 10, SignalRole::kNone)};
    info_.outputs = {
        TruthSignal("y", unit, "command after the dead zone", -10, 10, SignalRole::kNone)};
    info_.parameters = {TruthParameter("d", unit, "half width of the dead zone", 0.0, 0.0, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    using std::abs;
    const Scalar& u = a.u[0];
    a.y[0] = u - 0.5 * (abs(u + a.p[0]) - abs(u - a.p[0]));
  }
};

class TwoMassBlock : public models::BlockBase<TwoMassBlock> {
 public:
  TwoMassBlock() {
    info_.type = "withheld.two_mass";
    info_.description = "drive.two_mass with the exact backlash dead zone on the deflection.";
    info_.reference = "bench/withheld/src/truth_blocks.h; models drives.h (seed 002 eq. 6-1)";
    info_.states = {TruthSignal("q_m", "rad", "motor angle", -1, 1, SignalRole::kPosition),
                    TruthSignal("qd_m", "rad/s", "motor speed", -20, 20, SignalRole::kVelocity),
                    TruthSignal("q_l", "rad", "load angle", -1, 1, SignalRole::kPosition),
                    TruthSignal("qd_l", "rad/s", "load speed", -20, 20, SignalRole::kVelocity)};
    info_.inputs = {
        TruthSignal("tau_m", "N m", "net motor torque", -0.4, 0.4, SignalRole::kForce),
        TruthSignal("tau_ext", "N m", "torque on the load", -0.4, 0.4, SignalRole::kForce)};
    info_.outputs = {
        info_.states[0], info_.states[1], info_.states[2], info_.states[3],
        TruthSignal("tau_s", "N m", "torque through the joint", -0.4, 0.4, SignalRole::kForce)};
    info_.parameters = {TruthParameter("J", "kg m^2", "motor inertia", 1e-4, 1e-9, kInf),
                        TruthParameter("I", "kg m^2", "load inertia", 1.4e-3, 1e-9, kInf),
                        TruthParameter("Ke", "N m/rad", "joint stiffness", 8.459, 1e-6, kInf),
                        TruthParameter("d", "N m s/rad", "joint damping", 0.0, 0.0, kInf),
                        TruthParameter("b", "rad", "backlash half width", 0.0, 0.0, 0.5)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    using std::abs;
    const Scalar& b = a.p[4];
    const Scalar delta = a.x[0] - a.x[2];
    const Scalar dz = delta - 0.5 * (abs(delta + b) - abs(delta - b));
    const Scalar slope = 1.0 - 0.5 * (Sign(delta + b) - Sign(delta - b));
    const Scalar tau_s = a.p[2] * dz + a.p[3] * slope * (a.x[1] - a.x[3]);
    a.xdot[0] = a.x[1];
    a.xdot[1] = (a.u[0] - tau_s) / a.p[0];
    a.xdot[2] = a.x[3];
    a.xdot[3] = (tau_s + a.u[1]) / a.p[1];
    for (int i = 0; i < 4; ++i) a.y[i] = a.x[i];
    a.y[4] = tau_s;
  }

 private:
  static double Sign(double x) { return (x > 0.0) - (x < 0.0); }
  static expr::Expr Sign(const expr::Expr& x) { return expr::sign(x); }
};

class CouplingBlock : public models::BlockBase<CouplingBlock> {
 public:
  CouplingBlock() {
    info_.type = "withheld.coupling";
    info_.description = "Spring-damper between two bodies: f = k (q1 - q2) + d (qd1 - qd2).";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.inputs = {
        TruthSignal("q1", "m", "position of body 1", 0, 0.25, SignalRole::kPosition),
        TruthSignal("qd1", "m/s", "velocity of body 1", -0.3, 0.3, SignalRole::kVelocity),
        TruthSignal("q2", "m", "position of body 2", 0, 0.25, SignalRole::kPosition),
        TruthSignal("qd2", "m/s", "velocity of body 2", -0.3, 0.3, SignalRole::kVelocity)};
    info_.outputs = {TruthSignal("f1", "N", "force on body 1, -f", -200, 200, SignalRole::kForce),
                     TruthSignal("f2", "N", "force on body 2, +f", -200, 200, SignalRole::kForce)};
    info_.parameters = {TruthParameter("k", "N/m", "stiffness", 1e5, 0.0, kInf),
                        TruthParameter("d", "N s/m", "damping", 0.0, 0.0, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    const Scalar f = a.p[0] * (a.u[0] - a.u[2]) + a.p[1] * (a.u[1] - a.u[3]);
    a.y[0] = -f;
    a.y[1] = f;
  }
};

class CoggingBlock : public models::BlockBase<CoggingBlock> {
 public:
  explicit CoggingBlock(bool prismatic = false) {
    info_.type = "withheld.cogging";
    info_.description = "Cogging/ripple with two harmonics of the period P.";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.inputs = {
        TruthSignal("q", AxisUnit("rad", prismatic), "position", -3, 3, SignalRole::kPosition)};
    info_.outputs = {TruthSignal("tau", AxisUnit("N m", prismatic), "ripple (subtract it)", -1, 1,
                                 SignalRole::kForce)};
    info_.parameters = {TruthParameter("a1", "N m", "first amplitude", 0, -kInf, kInf),
                        TruthParameter("a2", "N m", "second amplitude", 0, -kInf, kInf),
                        TruthParameter("P", "rad", "period", 1, 1e-9, kInf),
                        TruthParameter("h2", "1", "order of the second harmonic", 2, 1, 100),
                        TruthParameter("phi1", "rad", "first phase", 0, -kInf, kInf),
                        TruthParameter("phi2", "rad", "second phase", 0, -kInf, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    using std::sin;
    const Scalar w = (2.0 * kPi) * a.u[0] / a.p[2];
    a.y[0] = a.p[0] * sin(w + a.p[4]) + a.p[1] * sin(a.p[3] * w + a.p[5]);
  }
};

class FrictionDriftBlock : public models::BlockBase<FrictionDriftBlock> {
 public:
  explicit FrictionDriftBlock(bool prismatic = false) {
    info_.type = "withheld.friction_drift";
    info_.description = "Coulomb level drifting linearly with time: fc r (t/T) sgn(v).";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.states = {TruthSignal("t_c", "s", "clock", 0, 10, SignalRole::kNone)};
    info_.inputs = {TruthSignal("qd", AxisUnit("rad/s", prismatic), "velocity", -20, 20,
                                SignalRole::kVelocity)};
    info_.outputs = {TruthSignal("tau", AxisUnit("N m", prismatic), "friction (subtract it)", -1, 1,
                                 SignalRole::kForce)};
    info_.parameters = {TruthParameter("fc", "N m", "drifting level", 0, 0, kInf),
                        TruthParameter("r", "1", "relative change over T", 0, -kInf, kInf),
                        TruthParameter("T", "s", "drift time", 1, 1e-9, kInf),
                        TruthParameter("vd", "rad/s", "width of the atan sign", 1e-3, 1e-12, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    a.xdot[0] = Scalar(1.0);
    a.y[0] = a.p[0] * a.p[1] * (a.x[0] / a.p[2]) * HardSign(a.u[0], a.p[3]);
  }
};

class PeriodicForceBlock : public models::BlockBase<PeriodicForceBlock> {
 public:
  explicit PeriodicForceBlock(bool prismatic = false) {
    info_.type = "withheld.periodic_force";
    info_.description = "A sinusoidal disturbance A sin(2 pi f t + phi) independent of the motion.";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.states = {TruthSignal("t_c", "s", "clock", 0, 10, SignalRole::kNone)};
    info_.outputs = {TruthSignal("tau", AxisUnit("N m", prismatic), "disturbance (subtract it)", -1,
                                 1, SignalRole::kForce)};
    info_.parameters = {TruthParameter("A", "N m", "amplitude", 0, -kInf, kInf),
                        TruthParameter("f", "Hz", "frequency", 1, 0, kInf),
                        TruthParameter("phi", "rad", "phase", 0, -kInf, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    using std::sin;
    a.xdot[0] = Scalar(1.0);
    a.y[0] = a.p[0] * sin((2.0 * kPi) * a.p[1] * a.x[0] + a.p[2]);
  }
};

class SensorBlock : public models::BlockBase<SensorBlock> {
 public:
  SensorBlock() {
    info_.type = "withheld.sensor";
    info_.description = "Miscalibrated sensor y = scale u + offset.";
    info_.reference = "bench/withheld/src/truth_blocks.h";
    info_.inputs = {TruthSignal("u", "rad", "true angle", -3, 3, SignalRole::kPosition)};
    info_.outputs = {TruthSignal("y", "rad", "measured angle", -3, 3, SignalRole::kPosition)};
    info_.parameters = {TruthParameter("scale", "1", "gain", 1, 0, kInf),
                        TruthParameter("offset", "rad", "zero error", 0, -kInf, kInf)};
  }
  template <typename Scalar>
  void Compute(const models::BlockArgs<Scalar>& a) const {
    a.y[0] = a.p[0] * a.u[0] + a.p[1];
  }
};

}  // namespace graybox::bench::internal
