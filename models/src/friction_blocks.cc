// The friction block family; equations, units, parameters and choices are documented in
// include/graybox/models/friction.h.
#include "graybox/models/friction.h"

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "builtin_blocks.h"
#include "graybox/models/kuka_kr300.h"
#include "mechanical_block_helpers.h"

namespace graybox::models::internal {
namespace {

// Typical operating ranges (see friction.h, "Typical ranges").
// eSEA of seed 002: chirp torques up to 0.4 N m on J + I = 1.5e-3 kg m^2 give |qd| ~ 20 rad/s.
constexpr double kSeaSpeed = 20.0;  // [rad/s]
// Staubli motors of seed 001 (motor side): ~3000 rpm.
constexpr double kMotorSpeed = 300.0;  // [rad/s]
// KUKA KR300 joints in the roblue data: |qd| < 2.05 rad/s.
constexpr double kKukaSpeed = 2.0;  // [rad/s]

SignalInfo Velocity(double max_speed) {
  SignalInfo s{"qd", "rad/s", "relative velocity of the sliding pair", -max_speed, max_speed};
  s.role = SignalRole::kVelocity;
  return s;
}
SignalInfo Torque(double max_torque) {
  SignalInfo s{"tau", "N m", "friction torque, same sign as the velocity (subtract it)",
               -max_torque, max_torque};
  s.role = SignalRole::kForce;
  return s;
}

// ---- friction.viscous ---------------------------------------------------------------------------
class ViscousFriction : public BlockBase<ViscousFriction> {
 public:
  explicit ViscousFriction(const BlockOptions& options) {
    CheckOptionKeys(kViscousFriction, options, {"motion"});
    info_.type = kViscousFriction;
    info_.description = "Linear viscous friction tau = fv qd.";
    info_.reference = "seed 002 eq. 5-1; nominal fv from seed 002 Table 8.2 (linear model)";
    info_.inputs = {Velocity(kSeaSpeed)};
    info_.outputs = {Torque(0.2)};
    info_.parameters = {
        MakeParameter("fv", "N m s/rad", "viscous friction coefficient", 0.00963, 0.0, kInf, 0.0)};
    ApplyMotionUnits(kViscousFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = a.p[0] * a.u[0];
  }
};

// ---- friction.coulomb ---------------------------------------------------------------------------
class CoulombFriction : public BlockBase<CoulombFriction> {
 public:
  explicit CoulombFriction(const BlockOptions& options) {
    CheckOptionKeys(kCoulombFriction, options, {"steepness", "motion"});
    steepness_is_parameter_ = !HasNumber(options, "steepness");
    steepness_ = PositiveOption(kCoulombFriction, options, "steepness", kDefaultFrictionSteepness);
    info_.type = kCoulombFriction;
    info_.description = "Coulomb friction with a tanh-smoothed sign, tau = fc tanh(s qd).";
    info_.reference =
        "seed 002 eq. 5-3 with fs = fc, fv = 0; nominal fc from seed 002 Table 8.2 "
        "(Coulomb-Stribeck model)";
    info_.inputs = {Velocity(kSeaSpeed)};
    info_.outputs = {Torque(0.02)};
    info_.parameters = {
        MakeParameter("fc", "N m", "Coulomb friction level", 0.0145, 0.0, kInf, 0.0)};
    if (steepness_is_parameter_) {
      info_.parameters.push_back(MakeParameter("steepness", "s/rad",
                                               "slope of tanh(s qd) at qd = 0 divided by fc",
                                               kDefaultFrictionSteepness, 1e-3, 1e7));
    }
    ApplyMotionUnits(kCoulombFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar s = steepness_is_parameter_ ? a.p[1] : Scalar(steepness_);
    a.y[0] = a.p[0] * SmoothSign(a.u[0], s);
  }

 private:
  bool steepness_is_parameter_ = true;
  double steepness_ = kDefaultFrictionSteepness;
};

// ---- friction.offset ----------------------------------------------------------------------------
class OffsetFriction : public BlockBase<OffsetFriction> {
 public:
  explicit OffsetFriction(const BlockOptions& options) {
    CheckOptionKeys(kOffsetFriction, options, {"motion"});
    info_.type = kOffsetFriction;
    info_.description =
        "Constant, direction-independent friction offset tau = f_asym (the asymmetric part of a "
        "friction curve); the velocity input is read for a uniform wiring only.";
    info_.reference = "f_asym term of the KUKA roblue friction (data/roblue_elabee/SOURCE.md)";
    info_.inputs = {Velocity(kKukaSpeed)};
    info_.outputs = {Torque(50.0)};
    info_.parameters = {
        MakeParameter("f_asym", "N m", "constant friction offset", 0.0, -kInf, kInf, 0.0)};
    ApplyMotionUnits(kOffsetFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = a.p[0];
  }
};

// ---- friction.asymmetric ------------------------------------------------------------------------
class AsymmetricFriction : public BlockBase<AsymmetricFriction> {
 public:
  explicit AsymmetricFriction(const BlockOptions& options) {
    CheckOptionKeys(kAsymmetricFriction, options, {"steepness", "motion"});
    steepness_ =
        PositiveOption(kAsymmetricFriction, options, "steepness", kDefaultFrictionSteepness);
    info_.type = kAsymmetricFriction;
    info_.description =
        "Asymmetric friction: tau = f0 + fd tanh(s qd)^2 + fvd qd tanh(s qd), a constant part and "
        "direction-dependent parts (levels fc + fd forward, fc - fd backward beside a symmetric "
        "Coulomb term).";
    info_.reference = "graybox (friction.h); its direction-dependent parts are zero at rest";
    info_.inputs = {Velocity(kSeaSpeed)};
    info_.outputs = {Torque(0.02)};
    info_.parameters = {
        MakeParameter("f0", "N m", "constant part, also at rest (as friction.offset)", 0.0, -kInf,
                      kInf, 0.0),
        MakeParameter("fd", "N m", "half the forward minus backward Coulomb level", 0.0, -kInf,
                      kInf, 0.0),
        MakeParameter("fvd", "N m s/rad", "half the forward minus backward viscous coefficient",
                      0.0, -kInf, kInf, 0.0)};
    ApplyMotionUnits(kAsymmetricFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar t = SmoothSign(a.u[0], Scalar(steepness_));
    a.y[0] = a.p[0] + a.p[1] * t * t + a.p[2] * a.u[0] * t;
  }

 private:
  double steepness_ = kDefaultFrictionSteepness;
};

// ---- friction.stribeck --------------------------------------------------------------------------
class StribeckFriction : public BlockBase<StribeckFriction> {
 public:
  explicit StribeckFriction(const BlockOptions& options) {
    CheckOptionKeys(kStribeckFriction, options, {"steepness", "exponent", "motion"});
    steepness_ = PositiveOption(kStribeckFriction, options, "steepness", kDefaultFrictionSteepness);
    exponent_ = PositiveOption(kStribeckFriction, options, "exponent", 2.0);
    info_.type = kStribeckFriction;
    info_.description =
        "Coulomb-Stribeck-viscous friction tau = (fc + (fs - fc) exp(-|qd/vs|^a)) tanh(s qd) + "
        "fv qd.";
    info_.reference =
        "seed 002 eq. 5-2 and 5-3; nominal values from seed 002 Table 8.2 (Coulomb-Stribeck)";
    info_.inputs = {Velocity(kSeaSpeed)};
    info_.outputs = {Torque(0.06)};
    info_.parameters = {
        MakeParameter("fc", "N m", "Coulomb (kinetic) friction level", 0.0145, 0.0, kInf, 0.0),
        MakeParameter("fs", "N m", "static friction level (at qd -> 0)", 1.03e-5, 0.0, kInf, 0.0),
        MakeParameter("vs", "rad/s", "Stribeck velocity", 0.1677, 1e-6, 1e3),
        MakeParameter("fv", "N m s/rad", "viscous friction coefficient", 0.002, 0.0, kInf, 0.0)};
    ApplyMotionUnits(kStribeckFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar& qd = a.u[0];
    const Scalar g = StribeckLevel(qd, a.p[0], a.p[1], a.p[2], exponent_);
    a.y[0] = g * SmoothSign(qd, Scalar(steepness_)) + a.p[3] * qd;
  }

 private:
  double steepness_ = kDefaultFrictionSteepness;
  double exponent_ = 2.0;
};

// ---- friction.power_viscous ---------------------------------------------------------------------
class PowerViscousFriction : public BlockBase<PowerViscousFriction> {
 public:
  explicit PowerViscousFriction(const BlockOptions& options) {
    CheckOptionKeys(kPowerViscousFriction, options, {"smoothing", "motion"});
    smoothing_ = PositiveOption(kPowerViscousFriction, options, "smoothing", 1e-3);
    info_.type = kPowerViscousFriction;
    info_.description =
        "Power-law viscous friction tau = fv sign(qd) |qd / (1 rad/s)|^k, evaluated smoothly as "
        "fv qd (qd^2 + eps^2)^((k - 1)/2).";
    info_.reference = "seed 001 eq. 4 (k1 = fv, k2 = k; motor side)";
    info_.inputs = {Velocity(kMotorSpeed)};
    info_.outputs = {Torque(3.0)};
    info_.parameters = {
        MakeParameter("fv", "N m", "friction torque at |qd| = 1 rad/s (seed 001 k1)", 0.01, 0.0,
                      kInf, 0.0),
        MakeParameter("k", "1", "velocity exponent (seed 001 k2; 1 = linear viscous)", 1.0, 0.1,
                      3.0)};
    ApplyMotionUnits(kPowerViscousFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::pow;
    const Scalar& qd = a.u[0];
    a.y[0] = a.p[0] * qd * pow(qd * qd + smoothing_ * smoothing_, 0.5 * (a.p[1] - 1.0));
  }

 private:
  double smoothing_ = 1e-3;
};

// ---- friction.dahl ------------------------------------------------------------------------------
class DahlFriction : public BlockBase<DahlFriction> {
 public:
  explicit DahlFriction(const BlockOptions& options) {
    CheckOptionKeys(kDahlFriction, options, {"motion", "form"});
    length_form_ = WordOption(kDahlFriction, options, "form", "stiffness",
                              {"stiffness", "length"}) == "length";
    info_.type = kDahlFriction;
    info_.reference = "seed 002 eq. 5-4 and 5-5; nominal fc from seed 002 Table 8.2 (Dahl)";
    info_.inputs = {Velocity(kSeaSpeed)};
    info_.outputs = {Torque(0.04)};
    if (length_form_) {
      info_.description =
          "Dahl friction, presliding-length form: normalised deflection zn with dzn/dt = (qd - "
          "|qd| zn) / delta, tau = fc zn (sigma0 = fc / delta).";
      info_.states = {
          {"zn", "1", "bristle deflection over its sliding value (tau / fc)", -1.0, 1.0}};
      info_.parameters = {
          MakeParameter("fc", "N m", "Coulomb friction level (saturation of tau)", 0.0379, 0.0,
                        kInf, 0.0),
          MakeParameter("delta", "rad", "presliding length fc / sigma0", 1e-3, 1e-9, kInf)};
    } else {
      info_.description =
          "Dahl friction: bristle deflection z with dz/dt = qd - sigma0 |qd| z / fc, tau = sigma0 "
          "z (rate-independent hysteresis, pre-sliding stiffness sigma0).";
      info_.states = {{"z", "rad", "bristle deflection", -1e-3, 1e-3}};
      info_.parameters = {MakeParameter("sigma0", "N m/rad", "bristle (pre-sliding) stiffness",
                                        37.9, 0.0, 1e8, 0.0),
                          MakeParameter("fc", "N m", "Coulomb friction level (saturation of tau)",
                                        0.0379, 1e-9, kInf)};
    }
    info_.stiff = true;
    ApplyMotionUnits(kDahlFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::abs;
    const Scalar& qd = a.u[0];
    if (length_form_) {
      const Scalar& zn = a.x[0];
      a.xdot[0] = (qd - abs(qd) * zn) / a.p[1];
      a.y[0] = a.p[0] * zn;
      return;
    }
    const Scalar& z = a.x[0];
    const Scalar& sigma0 = a.p[0];
    a.xdot[0] = qd - sigma0 * abs(qd) * z / a.p[1];
    a.y[0] = sigma0 * z;
  }

 private:
  bool length_form_ = false;
};

// ---- friction.lugre -----------------------------------------------------------------------------
class LuGreFriction : public BlockBase<LuGreFriction> {
 public:
  explicit LuGreFriction(const BlockOptions& options) {
    CheckOptionKeys(kLuGreFriction, options, {"exponent", "motion"});
    exponent_ = PositiveOption(kLuGreFriction, options, "exponent", 2.0);
    info_.type = kLuGreFriction;
    info_.description =
        "LuGre friction: bristle deflection z with dz/dt = qd - sigma0 |qd| z / g(qd), "
        "tau = sigma0 z + sigma1 dz/dt + sigma2 qd, g the Stribeck curve.";
    info_.reference =
        "seed 002 eq. 5-2, 5-6 and 5-7; nominal values from seed 002 Table 8.2 (LuGre) except "
        "sigma0 (see friction.h)";
    info_.inputs = {Velocity(kSeaSpeed)};
    info_.states = {{"z", "rad", "bristle deflection", -0.06, 0.06}};
    info_.outputs = {Torque(0.9)};
    info_.parameters = {
        MakeParameter("sigma0", "N m/rad", "bristle (pre-sliding) stiffness", 16.19, 0.0, 1e8, 0.0),
        MakeParameter("sigma1", "N m s/rad", "bristle micro-damping", 0.0036, 0.0, kInf, 0.0),
        MakeParameter("sigma2", "N m s/rad", "viscous friction coefficient", 0.00335, 0.0, kInf,
                      0.0),
        MakeParameter("fc", "N m", "Coulomb (kinetic) friction level", 0.01619, 1e-9, kInf),
        MakeParameter("fs", "N m", "static friction level", 0.8795, 1e-9, kInf),
        MakeParameter("vs", "rad/s", "Stribeck velocity", 3.15e-5, 1e-6, 1e3)};
    info_.stiff = true;
    ApplyMotionUnits(kLuGreFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::abs;
    const Scalar& qd = a.u[0];
    const Scalar& z = a.x[0];
    const Scalar& sigma0 = a.p[0];
    const Scalar g = StribeckLevel(qd, a.p[3], a.p[4], a.p[5], exponent_);
    const Scalar zdot = qd - sigma0 * abs(qd) * z / g;
    a.xdot[0] = zdot;
    a.y[0] = sigma0 * z + a.p[1] * zdot + a.p[2] * qd;
  }

 private:
  double exponent_ = 2.0;
};

// ---- friction.torque_dependent ------------------------------------------------------------------
class TorqueDependentFriction : public BlockBase<TorqueDependentFriction> {
 public:
  explicit TorqueDependentFriction(const BlockOptions& options) {
    CheckOptionKeys(kTorqueDependentFriction, options, {"steepness", "torque_steepness", "motion"});
    steepness_ =
        PositiveOption(kTorqueDependentFriction, options, "steepness", kDefaultFrictionSteepness);
    torque_steepness_ =
        PositiveOption(kTorqueDependentFriction, options, "torque_steepness", 100.0);
    info_.type = kTorqueDependentFriction;
    info_.description =
        "Load-dependent dry friction relaxing over travelled distance towards "
        "sign(qd) (fc + ftau |tau_load|) while moving and decaying in time at standstill "
        "(continuous-time form of the Staubli model).";
    info_.reference = "seed 001 eq. 5 to 8 (k3 = fc, k4 = ftau, k5 = distance, k6 = time)";
    info_.inputs = {Velocity(kMotorSpeed),
                    {"tau_load", "N m",
                     "torque transmitted by the drive (seed 001 tau_jnt, in the frame of qd)",
                     -10.0, 10.0, SignalRole::kForce}};
    info_.states = {{"tau_d", "N m", "dry friction torque", -1.5, 1.5, SignalRole::kForce}};
    info_.outputs = {Torque(1.5)};
    info_.parameters = {
        MakeParameter("fc", "N m", "load-independent dry friction (seed 001 k3)", 0.5, 0.0, kInf,
                      0.0),
        MakeParameter("ftau", "1", "dry friction per unit load torque (seed 001 k4)", 0.05, 0.0,
                      10.0, 0.0),
        MakeParameter("distance", "rad", "relaxation distance (seed 001 k5)", 0.05, 1e-6, 1e3),
        MakeParameter("time", "s", "standstill relaxation time (seed 001 k6)", 0.1, 1e-4, 1e4)};
    info_.stiff = true;
    ApplyMotionUnits(kTorqueDependentFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::tanh;
    const Scalar& qd = a.u[0];
    const Scalar& tau_load = a.u[1];
    const Scalar& tau_d = a.x[0];
    const Scalar s(steepness_);
    const Scalar sign = SmoothSign(qd, s);
    const Scalar target = sign * (a.p[0] + a.p[1] * SmoothAbs(tau_load, Scalar(torque_steepness_)));
    const Scalar standstill = 1.0 - sign * sign;  // sech^2(s qd): 1 at rest, -> 0 when moving
    a.xdot[0] = (target - tau_d) * (qd * sign) / a.p[2] - standstill * tau_d / a.p[3];
    a.y[0] = tau_d;
  }

 private:
  double steepness_ = kDefaultFrictionSteepness;
  double torque_steepness_ = 100.0;
};

// ---- friction.ripple ----------------------------------------------------------------------------
class RippleFriction : public BlockBase<RippleFriction> {
 public:
  explicit RippleFriction(const BlockOptions& options) {
    CheckOptionKeys(kRippleFriction, options, {"harmonics", "period", "motion"});
    harmonics_ = IntegerOption(kRippleFriction, options, "harmonics", 1, 1, 1000);
    period_ = PositiveOption(kRippleFriction, options, "period", 2.0 * kPi);
    info_.type = kRippleFriction;
    info_.description =
        "Position-dependent torque ripple (cogging, gear-mesh or bearing ripple) as a Fourier "
        "series tau = sum_k a_k cos(2 pi k q / P) + b_k sin(2 pi k q / P).";
    info_.reference = "Fourier series in position; seed 001 eq. 1 (hard-to-model residual effects)";
    info_.inputs = {{"q", "rad", "position of the sliding pair", -kPi, kPi, SignalRole::kPosition}};
    info_.outputs = {{"tau", "N m", "ripple torque (subtract it, like every friction torque)", -0.1,
                      0.1, SignalRole::kForce}};
    for (int k = 1; k <= harmonics_; ++k) {
      const std::string n = std::to_string(k);
      info_.parameters.push_back(MakeParameter("a" + n, "N m", "cosine amplitude of harmonic " + n,
                                               0.0, -kInf, kInf, 0.0));
      info_.parameters.push_back(
          MakeParameter("b" + n, "N m", "sine amplitude of harmonic " + n, 0.0, -kInf, kInf, 0.0));
    }
    // The period: known from the design, so fixed unless a caller frees it (friction.h).
    ParameterInfo period = MakeParameter("period", "rad", "period of the first harmonic", period_,
                                         0.5 * period_, 2.0 * period_);
    period.fixed_by_default = true;
    info_.parameters.push_back(period);
    ApplyMotionUnits(kRippleFriction, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::cos;
    using std::sin;
    const Scalar phase = (2.0 * kPi / a.p[2 * harmonics_]) * a.u[0];
    Scalar tau(0.0);
    for (int k = 1; k <= harmonics_; ++k) {
      const Scalar arg = static_cast<double>(k) * phase;
      tau += a.p[2 * (k - 1)] * cos(arg) + a.p[2 * (k - 1) + 1] * sin(arg);
    }
    a.y[0] = tau;
  }

 private:
  int harmonics_ = 1;
  double period_ = 2.0 * kPi;
};

// ---- friction.kuka ------------------------------------------------------------------------------
// f_a and f_b of roblue (computed there but left out of its sum), SOURCE.md.
constexpr std::array<double, kKukaDof> kKukaFa = {20.47, 226.56, 453.59, 65.97, 47.41, 16.47};
constexpr std::array<double, kKukaDof> kKukaFb = {823.4, 29890.6, 39171.9, 4845.3, 2370.3, 2060.9};

class KukaJointFriction : public BlockBase<KukaJointFriction> {
 public:
  explicit KukaJointFriction(const BlockOptions& options) {
    CheckOptionKeys(kKukaFriction, options, {"steepness", "joint"});
    steepness_ = PositiveOption(kKukaFriction, options, "steepness", 1.0);
    const int joint = IntegerOption(kKukaFriction, options, "joint", 1, 1, kKukaDof);
    const auto j = static_cast<std::size_t>(joint - 1);
    const KukaFrictionParameters roblue = KukaRoblueFriction();
    info_.type = kKukaFriction;
    info_.description =
        "KUKA (roblue) joint friction tau = f_asym + f_vis qd + f_coul tanh(s qd) + "
        "f_a tanh(f_b qd).";
    info_.reference = "roblue friction (data/roblue_elabee/SOURCE.md), nominal values of joint " +
                      std::to_string(joint);
    info_.inputs = {Velocity(kKukaSpeed)};
    info_.outputs = {Torque(1.2e4)};
    info_.parameters = {
        MakeParameter("f_asym", "N m", "constant offset", roblue.f_asym[j], -kInf, kInf, 0.0),
        MakeParameter("f_vis", "N m s/rad", "viscous coefficient", roblue.f_vis[j], 0.0, kInf, 0.0),
        MakeParameter("f_coul", "N m", "Coulomb level", roblue.f_coul[j], 0.0, kInf, 0.0),
        MakeParameter("f_a", "N m", "level of the second, steep tanh term", kKukaFa[j], 0.0, kInf,
                      0.0),
        MakeParameter("f_b", "s/rad", "steepness of the second tanh term", kKukaFb[j], 1e-3, 1e7)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::tanh;
    const Scalar& qd = a.u[0];
    a.y[0] = a.p[0] + a.p[1] * qd + a.p[2] * SmoothSign(qd, Scalar(steepness_)) +
             a.p[3] * tanh(a.p[4] * qd);
  }

 private:
  double steepness_ = 1.0;
};

template <typename T>
BlockFactory Factory() {
  return [](const BlockOptions& options) -> std::unique_ptr<Block> {
    return std::make_unique<T>(options);
  };
}

}  // namespace

void RegisterFrictionBlocks(BlockRegistry& registry) {
  registry.Register(kViscousFriction, Factory<ViscousFriction>());
  registry.Register(kCoulombFriction, Factory<CoulombFriction>());
  registry.Register(kOffsetFriction, Factory<OffsetFriction>());
  registry.Register(kAsymmetricFriction, Factory<AsymmetricFriction>());
  registry.Register(kStribeckFriction, Factory<StribeckFriction>());
  registry.Register(kPowerViscousFriction, Factory<PowerViscousFriction>());
  registry.Register(kDahlFriction, Factory<DahlFriction>());
  registry.Register(kLuGreFriction, Factory<LuGreFriction>());
  registry.Register(kTorqueDependentFriction, Factory<TorqueDependentFriction>());
  BlockOptions ripple;
  ripple.numbers["harmonics"] = {3};
  registry.Register(kRippleFriction, Factory<RippleFriction>(), ripple);
  registry.Register(kKukaFriction, Factory<KukaJointFriction>());
}

}  // namespace graybox::models::internal
