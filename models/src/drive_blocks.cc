// The transmission and drive block family; equations, units, parameters and choices are
// documented in include/graybox/models/drives.h.
#include "graybox/models/drives.h"

#include <memory>
#include <string>
#include <vector>

#include "builtin_blocks.h"
#include "graybox/models/kuka_kr300.h"
#include "mechanical_block_helpers.h"

namespace graybox::models::internal {
namespace {

// ---- drive.two_mass -----------------------------------------------------------------------------
class TwoMassDrive : public BlockBase<TwoMassDrive> {
 public:
  explicit TwoMassDrive(const BlockOptions& options) {
    CheckOptionKeys(kTwoMassDrive, options, {"backlash", "smoothing", "motion"});
    backlash_ = FlagOption(kTwoMassDrive, options, "backlash", false);
    if (!backlash_ && HasNumber(options, "smoothing")) {
      throw std::invalid_argument("block '" + std::string(kTwoMassDrive) +
                                  "': option 'smoothing' expected only with backlash = 1, got "
                                  "backlash = 0");
    }
    smoothing_ = PositiveOption(kTwoMassDrive, options, "smoothing", kDefaultBacklashSmoothing);
    info_.type = kTwoMassDrive;
    info_.description =
        "Elastic joint as a two-mass system: motor inertia J and load inertia I coupled by a "
        "spring Ke (and damper d), optionally through a smooth backlash dead zone.";
    info_.reference = "seed 002 eq. 6-1 (eSEA constants J, I, Ke of seed 002 Sec. 6.1)";
    constexpr SignalRole kPosition = SignalRole::kPosition, kVelocity = SignalRole::kVelocity,
                         kForce = SignalRole::kForce;
    info_.states = {{"q_m", "rad", "motor angle", -1.0, 1.0, kPosition},
                    {"qd_m", "rad/s", "motor speed", -20.0, 20.0, kVelocity},
                    {"q_l", "rad", "load (link) angle", -1.0, 1.0, kPosition},
                    {"qd_l", "rad/s", "load (link) speed", -20.0, 20.0, kVelocity}};
    info_.inputs = {
        {"tau_m", "N m", "net motor torque (motor torque minus motor-side friction)", -0.4, 0.4,
         kForce},
        {"tau_ext", "N m", "external torque on the load, positive along q_l", -0.4, 0.4, kForce}};
    info_.outputs = {{"q_m", "rad", "motor angle", -1.0, 1.0, kPosition},
                     {"qd_m", "rad/s", "motor speed", -20.0, 20.0, kVelocity},
                     {"q_l", "rad", "load angle", -1.0, 1.0, kPosition},
                     {"qd_l", "rad/s", "load speed", -20.0, 20.0, kVelocity},
                     {"tau_s", "N m", "torque transmitted by the joint (spring plus damper)", -0.4,
                      0.4, kForce}};
    info_.parameters = {
        MakeParameter("J", "kg m^2", "motor-side inertia", 1e-4, 1e-9, kInf),
        MakeParameter("I", "kg m^2", "load-side (link) inertia", 1.4e-3, 1e-9, kInf),
        MakeParameter("Ke", "N m/rad", "joint stiffness", 8.459, 1e-6, kInf),
        MakeParameter("d", "N m s/rad", "joint damping", 0.0, 0.0, kInf, 0.0)};
    if (backlash_) {
      info_.parameters.push_back(
          MakeParameter("b", "rad", "backlash: half width of the dead zone", 2e-3, 0.0, 0.5, 0.0));
    }
    ApplyMotionUnits(kTwoMassDrive, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar& q_m = a.x[0];
    const Scalar& qd_m = a.x[1];
    const Scalar& q_l = a.x[2];
    const Scalar& qd_l = a.x[3];
    const Scalar& J = a.p[0];
    const Scalar& I = a.p[1];
    const Scalar& ke = a.p[2];
    const Scalar& d = a.p[3];
    const Scalar delta = q_m - q_l;
    const Scalar delta_dot = qd_m - qd_l;
    Scalar tau_s;
    if (backlash_) {
      const Scalar& b = a.p[4];
      tau_s = ke * SmoothDeadZone(delta, b, smoothing_) +
              d * SmoothDeadZoneSlope(delta, b, smoothing_) * delta_dot;
    } else {
      tau_s = ke * delta + d * delta_dot;
    }
    a.xdot[0] = qd_m;
    a.xdot[1] = (a.u[0] - tau_s) / J;
    a.xdot[2] = qd_l;
    a.xdot[3] = (tau_s + a.u[1]) / I;
    a.y[0] = q_m;
    a.y[1] = qd_m;
    a.y[2] = q_l;
    a.y[3] = qd_l;
    a.y[4] = tau_s;
  }

 private:
  bool backlash_ = false;
  double smoothing_ = kDefaultBacklashSmoothing;
};

// ---- drive.backlash -----------------------------------------------------------------------------
class BacklashDrive : public BlockBase<BacklashDrive> {
 public:
  explicit BacklashDrive(const BlockOptions& options) {
    CheckOptionKeys(kBacklashDrive, options, {"smoothing"});
    smoothing_ = PositiveOption(kBacklashDrive, options, "smoothing", kDefaultBacklashSmoothing);
    info_.type = kBacklashDrive;
    info_.description =
        "Backlash as a smooth dead zone on a deflection: delta_eff = delta - clamp(delta, -b, b), "
        "smoothed with width eps; exactly delta_eff = delta at b = 0.";
    info_.reference = "dead-zone backlash model on the spring deflection of seed 002 eq. 6-1";
    info_.inputs = {{"delta", "rad", "deflection (motor angle minus load angle)", -0.05, 0.05}};
    info_.outputs = {{"delta_eff", "rad", "deflection the spring sees", -0.05, 0.05}};
    info_.parameters = {
        MakeParameter("b", "rad", "half width of the dead zone", 2e-3, 0.0, 0.5, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = SmoothDeadZone(a.u[0], a.p[0], smoothing_);
  }

 private:
  double smoothing_ = kDefaultBacklashSmoothing;
};

// ---- drive.gear ---------------------------------------------------------------------------------
class GearDrive : public BlockBase<GearDrive> {
 public:
  explicit GearDrive(const BlockOptions& options) {
    CheckOptionKeys(kGearDrive, options, {"joint"});
    const int joint = IntegerOption(kGearDrive, options, "joint", 1, 1, kKukaDof);
    const auto j = static_cast<std::size_t>(joint - 1);
    info_.type = kGearDrive;
    info_.description =
        "Rigid gear with efficiency and rotor inertia: tau = eta N (tau_m - J_m N qdd), "
        "qd_m = N qd (reflected inertia eta N^2 J_m).";
    info_.reference =
        "transmission layer of seed 001 Sec. 2.2 and eq. 9; KUKA gear ratios and rotor inertias "
        "of joint " +
        std::to_string(joint) + " (data/roblue_elabee/SOURCE.md)";
    info_.inputs = {
        {"tau_m", "N m", "motor (air-gap) torque", -20.0, 20.0, SignalRole::kForce},
        {"qd", "rad/s", "joint speed", -2.0, 2.0, SignalRole::kVelocity},
        {"qdd", "rad/s^2", "joint acceleration", -10.0, 10.0, SignalRole::kAcceleration}};
    info_.outputs = {
        {"tau", "N m", "torque delivered to the joint", -5000.0, 5000.0, SignalRole::kForce},
        {"qd_m", "rad/s", "motor speed", -500.0, 500.0, SignalRole::kVelocity}};
    info_.parameters = {MakeParameter("N", "1", "gear ratio (motor angle / joint angle)",
                                      kKukaGearRatios[j], 1e-3, 1e5, 1.0),
                        MakeParameter("eta", "1", "gear efficiency", 1.0, 1e-3, 1.0, 1.0),
                        MakeParameter("J_m", "kg m^2", "rotor inertia (motor side)",
                                      kKukaMotorInertias[j], 0.0, kInf, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar& n = a.p[0];
    a.y[0] = a.p[1] * n * (a.u[0] - a.p[2] * n * a.u[2]);
    a.y[1] = n * a.u[1];
  }
};

// ---- drive.dc_motor -----------------------------------------------------------------------------
class DcMotorDrive : public BlockBase<DcMotorDrive> {
 public:
  explicit DcMotorDrive(const BlockOptions& options) {
    CheckOptionKeys(kDcMotorDrive, options, {"angle_state", "load_input"});
    angle_state_ = FlagOption(kDcMotorDrive, options, "angle_state", true);
    load_input_ = FlagOption(kDcMotorDrive, options, "load_input", false);
    info_.type = kDcMotorDrive;
    info_.description =
        "Geared DC motor with armature dynamics: L di/dt = u - Kb N omega - R i, "
        "(J_os + N^2 J_rs) domega/dt = N Km i - (B_os + N^2 B_rs) omega - tau_load.";
    info_.reference =
        "seed 003 eq. 31-34 and Table 5; gear ratio from data/geared_dc_motor_ayankoso/SOURCE.md";
    using R = SignalRole;
    const SignalInfo current{"i", "A", "armature current", 0.0, 3.0, R::kCurrent};
    const SignalInfo speed{"omega", "rad/s", "output shaft speed", 0.0, 35.0, R::kVelocity};
    const SignalInfo angle{"theta", "rad", "output shaft angle", 0.0, 100.0, R::kPosition};
    info_.states = {current, speed};
    if (angle_state_) info_.states.push_back(angle);
    info_.inputs = {{"u", "V", "armature voltage", 0.0, 12.0, R::kVoltage}};
    if (load_input_) {
      info_.inputs.push_back({"tau_load", "N m", "load torque on the output shaft, opposing omega",
                              -1.0, 1.0, R::kForce});
    }
    if (angle_state_) info_.outputs.push_back(angle);
    info_.outputs.push_back(speed);
    info_.outputs.push_back(current);
    info_.parameters = {
        MakeParameter("L", "H", "armature inductance", 0.001, 1e-7, 10.0),
        MakeParameter("R", "Ohm", "armature resistance", 1.3798, 1e-4, 1e3),
        MakeParameter("Kb", "V s/rad", "back-EMF constant (rotor speed)", 0.3938, 1e-5, 100.0),
        MakeParameter("Km", "N m/A", "torque constant", 0.6585, 1e-5, 100.0),
        MakeParameter("N", "1", "gear ratio (rotor speed / output speed)", 10.0, 1e-3, 1e5),
        MakeParameter("J_rs", "kg m^2", "rotor inertia", 0.001, 1e-9, 10.0),
        MakeParameter("J_os", "kg m^2", "output-shaft (gear and load) inertia", 0.0379, 0.0, 10.0),
        MakeParameter("B_rs", "N m s/rad", "rotor viscous damping", 1.2539, 0.0, 100.0),
        MakeParameter("B_os", "N m s/rad", "output-shaft viscous damping", 0.3532, 0.0, 100.0)};
    info_.stiff = true;
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar& i = a.x[0];
    const Scalar& omega = a.x[1];
    const Scalar& u = a.u[0];
    const Scalar& L = a.p[0];
    const Scalar& R = a.p[1];
    const Scalar& kb = a.p[2];
    const Scalar& km = a.p[3];
    const Scalar& n = a.p[4];
    const Scalar inertia = a.p[6] + n * n * a.p[5];
    const Scalar damping = a.p[8] + n * n * a.p[7];
    Scalar torque = n * km * i - damping * omega;
    if (load_input_) torque -= a.u[1];
    a.xdot[0] = (u - kb * n * omega - R * i) / L;
    a.xdot[1] = torque / inertia;
    int k = 0;
    if (angle_state_) {
      a.xdot[2] = omega;
      a.y[k++] = a.x[2];
    }
    a.y[k++] = omega;
    a.y[k] = i;
  }

 private:
  bool angle_state_ = true;
  bool load_input_ = false;
};

// ---- delay.first_order --------------------------------------------------------------------------
class FirstOrderDelay : public BlockBase<FirstOrderDelay> {
 public:
  explicit FirstOrderDelay(const BlockOptions& options) {
    CheckOptionKeys(kFirstOrderDelay, options, {"form", "unit", "typical_range"});
    const std::string form = WordOption(kFirstOrderDelay, options, "form", "lag", {"lag", "pade"});
    std::string unit = "1";
    if (auto it = options.words.find("unit"); it != options.words.end()) {
      if (it->second.empty()) {
        throw std::invalid_argument("block '" + std::string(kFirstOrderDelay) +
                                    "': option 'unit' expected a unit such as \"N m\", got \"\"");
      }
      unit = it->second;
    }
    double lo = -1.0, hi = 1.0;
    if (auto it = options.numbers.find("typical_range"); it != options.numbers.end()) {
      if (it->second.size() != 2 || !(it->second[0] < it->second[1])) {
        throw std::invalid_argument("block '" + std::string(kFirstOrderDelay) +
                                    "': option 'typical_range' expected two numbers min < max, "
                                    "got " +
                                    std::to_string(it->second.size()) + " value(s)");
      }
      lo = it->second[0];
      hi = it->second[1];
    }
    const bool pade = form == "pade";
    info_.type = kFirstOrderDelay;
    info_.description =
        "Input delay approximation y = u + w (x - u), T dx/dt = u - x: low-frequency delay w T; "
        "w = 1 first-order lag, w = 2 Pade(1,1) of delay 2T, w = 0 exact pass-through.";
    info_.reference = "first-order lag / Pade(1,1) approximation of exp(-s d) (drives.h)";
    info_.inputs = {{"u", unit, "signal before the delay", lo, hi}};
    info_.states = {{"x", unit, "lagged signal", lo, hi}};
    info_.outputs = {{"y", unit, "delayed signal", lo, hi}};
    info_.parameters = {
        MakeParameter("T", "s", "time constant of the lag", kDefaultDelayTimeConstant, 1e-5, 10.0),
        MakeParameter("w", "1",
                      pade ? "weight of the lagged path (2 = Pade(1,1), 0 = no delay)"
                           : "weight of the lagged path (1 = first-order lag, 0 = no delay)",
                      pade ? 2.0 : 1.0, 0.0, pade ? 2.0 : 1.0, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar& u = a.u[0];
    const Scalar& x = a.x[0];
    a.xdot[0] = (u - x) / a.p[0];
    a.y[0] = u + a.p[1] * (x - u);
  }
};

template <typename T>
BlockFactory Factory() {
  return [](const BlockOptions& options) -> std::unique_ptr<Block> {
    return std::make_unique<T>(options);
  };
}

}  // namespace

void RegisterDriveBlocks(BlockRegistry& registry) {
  BlockOptions two_mass;
  two_mass.numbers["backlash"] = {1};
  registry.Register(kTwoMassDrive, Factory<TwoMassDrive>(), two_mass);
  registry.Register(kBacklashDrive, Factory<BacklashDrive>());
  registry.Register(kGearDrive, Factory<GearDrive>());
  BlockOptions dc_motor;
  dc_motor.numbers["load_input"] = {1};
  registry.Register(kDcMotorDrive, Factory<DcMotorDrive>(), dc_motor);
  BlockOptions delay;
  delay.words["form"] = "pade";
  registry.Register(kFirstOrderDelay, Factory<FirstOrderDelay>(), delay);
}

}  // namespace graybox::models::internal
