#include "bases.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>

#include "base_helpers.h"
#include "graybox/models/drives.h"
#include "graybox/models/friction.h"
#include "graybox/models/mechanics.h"
#include "truth_blocks.h"

namespace graybox::bench::internal {
namespace {

void CheckSupported(const std::string& base, const std::vector<std::string>& withheld) {
  for (const std::string& e : withheld) {
    if (!BaseSupports(base, e)) {
      throw std::invalid_argument("withheld cases: base '" + base + "' cannot withhold '" + e +
                                  "'");
    }
  }
}

// ---- drive_closed_loop --------------------------------------------------------------------------
// The EMPS-like prismatic drive in its position loop (problems/emps/emps_closed_loop.toml): the
// reference integrator driven by the reference rate, the cascaded P/P controller (fixed gains),
// the drive gain (fixed), the load mass with viscous, Coulomb (tanh, 1000 s/m) and offset friction.

constexpr double kDriveMass = 95.1;      // [kg]
constexpr double kDriveViscous = 203.5;  // [N s/m]
constexpr double kDriveCoulomb = 20.4;   // [N]
constexpr double kDriveOffset = -3.2;    // [N]
constexpr double kDriveGain = 35.15;     // [N/V]
constexpr double kDriveSteepness = 1e3;  // [s/m] of the nominal tanh
constexpr double kDriveVd = 1e-4;        // [m/s] width of the truth's atan sign
constexpr double kDriveStart = 0.12;     // [m] start position of both splits

Eigen::MatrixXd DriveExcitation(bool validation, double dt, int n, Rng* rng) {
  Eigen::VectorXd rate;
  if (!validation) {
    rate = TrapezoidalMoves(n, dt, kDriveStart, 0.03, 0.21, 0.01, 0.2, 1.5, rng);
  } else {
    // A smooth multisine position reference (0.2 .. 1.1 Hz), faded in, differentiated.
    const double f[3] = {0.2, 0.55, 1.1};
    const double a[3] = {0.05, 0.02, 0.008};
    double phase[3];
    for (double& p : phase) p = rng->Uniform(0.0, 2.0 * kPi);
    Eigen::VectorXd r(n + 1);
    for (int k = 0; k <= n; ++k) {
      const double t = k * dt;
      const double w = t < 1.0 ? 0.5 * (1.0 - std::cos(kPi * t)) : 1.0;
      double s = 0.0;
      for (int i = 0; i < 3; ++i) s += a[i] * (std::sin(2.0 * kPi * f[i] * t + phase[i]));
      r(k) = kDriveStart + w * s;
    }
    rate = (r.tail(n) - r.head(n)) / dt;
  }
  return rate;
}

BaseBuild BuildDrive(const std::vector<std::string>& w) {
  BaseBuild b;
  b.nominal = models::Model("drive_closed_loop");
  b.truth = models::Model("drive_closed_loop_truth");
  const bool elastic = Has(w, "elasticity");
  for (models::Model* m : {&b.nominal, &b.truth}) {
    const bool truth = m == &b.truth;
    m->AddInput("qr_rate", "m/s", "rate of the position reference", -0.3, 0.3);
    models::BlockOptions integrator;
    integrator.words = {{"input_unit", "m/s"}, {"output_unit", "m"}};
    m->AddBlock("reference", models::kIntegratorBlock, integrator, {"qr_rate"}, {});
    const bool two_bodies = truth && elastic;
    const std::string sensed = two_bodies ? "motor" : "load";
    m->AddBlock("controller", models::kCascadePController, {},
                {"reference.y", sensed + ".q", sensed + ".qd"}, {"nu"});
    models::BlockOptions volts;
    volts.words = {{"input_unit", "V"}, {"output_unit", "N"}};
    const bool dead_zone = truth && Has(w, "deadzone");
    if (dead_zone) {
      m->AddBlock("deadzone", Make<DeadZoneBlock>("V"), {"nu"}, {"nu_dz"});
    }
    m->AddBlock("drive", models::kGainBlock, volts, {dead_zone ? "nu_dz" : "nu"}, {"force"});
    if (two_bodies) {
      m->AddBlock("motor", models::kMassBlock, Motion("prismatic"), {"force"}, {});
      m->AddBlock("load", models::kMassBlock, Motion("prismatic"), {"load_force"}, {});
      m->AddBlock("coupling", Make<CouplingBlock>(), {"motor.q", "motor.qd", "load.q", "load.qd"},
                  {"force", "load_force"});
    } else {
      m->AddBlock("load", models::kMassBlock, Motion("prismatic"), {"force"}, {});
    }
    const std::string load_force = two_bodies ? "-load_force" : "-force";
    if (truth || !Has(w, "viscous")) {
      m->AddBlock("viscous", models::kViscousFriction, Motion("prismatic"), {"load.qd"},
                  {load_force});
    }
    if (!Has(w, "coulomb")) {
      m->AddBlock("coulomb", models::kCoulombFriction, CoulombOptions("prismatic", kDriveSteepness),
                  {"load.qd"}, {load_force});
    } else if (truth) {
      m->AddBlock("dry", Make<DryFrictionBlock>(true), {"load.qd"}, {load_force});
    }
    if (!Has(w, "asymmetric_friction")) {
      m->AddBlock("offset", models::kOffsetFriction, Motion("prismatic"), {"load.qd"},
                  {load_force});
    } else if (truth) {
      m->AddBlock("asymmetry", Make<DryFrictionBlock>(true), {"load.qd"}, {load_force});
    }
    if (!truth) continue;
    if (Has(w, "stribeck")) {
      m->AddBlock("stribeck", Make<DryFrictionBlock>(true), {"load.qd"}, {load_force});
    }
    if (Has(w, "power_law_viscous")) {
      m->AddBlock("power_law", Make<PowerLawBlock>(true), {"load.qd"}, {load_force});
    }
    if (Has(w, "ripple")) {
      m->AddBlock("cogging", Make<CoggingBlock>(true), {"load.q"}, {load_force});
    }
    if (Has(w, "friction_drift")) {
      m->AddBlock("drift", Make<FrictionDriftBlock>(true), {"load.qd"}, {load_force});
    }
    if (Has(w, "periodic_disturbance")) {
      m->AddBlock("disturbance", Make<PeriodicForceBlock>(true), {}, {load_force});
    }
  }
  for (models::Model* m : {&b.nominal, &b.truth}) {
    m->AddOutput("load.q");
    m->AddOutput("nu");
  }
  const bool payload = Has(w, "payload");
  Apply({{"controller.kp", 160.18, 160.18, 160.18, false},
         {"controller.kv", 243.45, 243.45, 243.45, false},
         {"controller.limit", 10.0, 10.0, 10.0, false},
         {"drive.k", kDriveGain, kDriveGain, kDriveGain, false},
         {"load.mass", kDriveMass, 1.0, 1000.0, !payload},
         {"viscous.fv", kDriveViscous, 0.0, 10000.0, true},
         {"coulomb.fc", kDriveCoulomb, 0.0, 1000.0, true},
         {"offset.f_asym", kDriveOffset, -100.0, 100.0, true}},
        &b);
  if (Has(w, "coulomb")) {
    SetTruth("dry", {{"fc_pos", kDriveCoulomb}, {"fc_neg", kDriveCoulomb}, {"vd", kDriveVd}}, &b);
    AddDetail("Coulomb " + Num(kDriveCoulomb) + " N with the hard sign (2/pi) atan(v/" +
                  Num(kDriveVd) + " m/s)",
              &b);
  }
  if (Has(w, "asymmetric_friction")) {
    SetTruth("asymmetry", {{"fc_pos", 6.0}, {"fc_neg", 0.0}, {"vd", kDriveVd}}, &b);
    AddDetail("direction-dependent Coulomb levels: " + Num(kDriveCoulomb + 6.0) + " N moving up, " +
                  Num(kDriveCoulomb) + " N moving down (atan sign), no offset",
              &b);
  }
  if (Has(w, "stribeck")) {
    SetTruth("stribeck", {{"ds", 14.0}, {"vs", 0.02}, {"a", 1.4}, {"vd", kDriveVd}}, &b);
    AddDetail("Stribeck excess 14 N exp(-|v/0.02 m/s|^1.4) with atan sign", &b);
  }
  if (Has(w, "viscous")) {
    b.truth_values["viscous.fv"] = kDriveViscous;
    AddDetail("viscous " + Num(kDriveViscous) + " N s/m", &b);
  }
  if (Has(w, "power_law_viscous")) {
    SetTruth("power_law", {{"c", 30.0}, {"k", 0.4}, {"v0", 0.1}, {"vd", kDriveVd}}, &b);
    AddDetail("power-law viscous 30 N |v/0.1 m/s|^0.4 (atan sign) beside the linear term", &b);
  }
  if (Has(w, "ripple")) {
    SetTruth("cogging",
             {{"a1", 8.0}, {"a2", 4.0}, {"P", 0.02}, {"h2", 2.0}, {"phi1", 0.3}, {"phi2", 1.9}},
             &b);
    AddDetail("cogging 8 N sin(2 pi q/0.02 m + 0.3) + 4 N sin(4 pi q/0.02 m + 1.9)", &b);
  }
  if (Has(w, "deadzone")) {
    SetTruth("deadzone", {{"d", 0.5}}, &b);
    AddDetail("hard dead zone of +-0.5 V on the drive command", &b);
  }
  if (elastic) {
    b.truth.SetParameter("motor.mass", 40.0);
    b.truth.SetParameter("load.mass", kDriveMass - 40.0);
    SetTruth("coupling", {{"k", 4e5}, {"d", 300.0}}, &b);
    b.truth_values["motor.mass"] = 40.0;
    b.truth_values["load.mass"] = kDriveMass - 40.0;
    AddDetail(
        "motor 40 kg and load 55.1 kg coupled by 4e5 N/m, 300 N s/m (21 Hz); the "
        "controller reads the motor, the output is the load position",
        &b);
  }
  if (payload) {
    b.truth.SetParameter("load.mass", kDriveMass + 35.0);
    b.truth_values["payload.mass"] = 35.0;
    AddDetail("payload 35 kg on the 95.1 kg carriage (the nominal mass is fixed at 95.1 kg)", &b);
  }
  if (Has(w, "friction_drift")) {
    SetTruth("drift", {{"fc", kDriveCoulomb}, {"r", 0.6}, {"T", 5.0}, {"vd", kDriveVd}}, &b);
    AddDetail("Coulomb level drifting +60 % over 5 s (warm-up)", &b);
  }
  if (Has(w, "periodic_disturbance")) {
    SetTruth("disturbance", {{"A", 10.0}, {"f", 3.7}, {"phi", 0.4}}, &b);
    AddDetail("disturbance force 10 N sin(2 pi 3.7 Hz t + 0.4)", &b);
  }
  b.x0 = {{"reference.y", kDriveStart}, {"load.q", kDriveStart}, {"motor.q", kDriveStart}};
  b.dt = 0.002;
  b.samples = 2500;
  b.quantum = {1e-6, 0.0};
  b.noise_std = {0.0, 0.02};
  b.spec.method = "multiple_shooting";
  b.spec.solver = "ipopt";
  b.spec.step.substeps = 2;
  b.spec.multiple_shooting.segment_length = 20;
  b.spec.multiple_shooting.fix_initial_state = true;
  b.spec.ipopt.max_iterations = 200;
  b.excite = &DriveExcitation;
  return b;
}

// ---- sea ----------------------------------------------------------------------------------------
// The eSEA two-mass actuator driven by motor torque in open loop (drives.h "drive.two_mass", seed
// 002 constants), motor viscous and Coulomb friction (tanh, 10 s/rad), link bearing viscous
// friction; measured: both encoder angles and the joint torque sensor.

constexpr double kSeaJ = 1e-4, kSeaI = 1.4e-3, kSeaKe = 8.459, kSeaD = 0.004;
constexpr double kSeaViscous = 0.00963, kSeaCoulomb = 0.0145, kSeaLinkViscous = 0.002;
constexpr double kSeaSteepness = 10.0;  // [s/rad]
constexpr double kSeaVd = 1e-3;         // [rad/s]
constexpr double kSeaCount = 2.0 * kPi / 32768.0;

Eigen::MatrixXd SeaExcitation(bool validation, double dt, int n, Rng* rng) {
  if (!validation) return Multisine(n, dt, 0.5, 25.0, 12, 0.06, rng);
  Eigen::VectorXd u = FilteredRandom(n, dt, 10.0, 0.04, rng);
  u += TrapezoidalPulses(n, dt, 0.05, rng);
  return u;
}

BaseBuild BuildSea(const std::vector<std::string>& w) {
  BaseBuild b;
  b.nominal = models::Model("sea");
  b.truth = models::Model("sea_truth");
  for (models::Model* m : {&b.nominal, &b.truth}) {
    const bool truth = m == &b.truth;
    const bool dead_zone = truth && Has(w, "deadzone");
    if (dead_zone) {
      m->AddInput("tau_cmd", "N m", "motor torque command", -0.4, 0.4);
      m->AddBlock("deadzone", Make<DeadZoneBlock>("N m"), {"tau_cmd"}, {"tau_m"});
    } else {
      m->AddInput("tau_m", "N m", "motor torque", -0.4, 0.4);
    }
    const std::vector<std::string> outs = {"", "", "", "", "tau_s"};
    if (truth && Has(w, "backlash")) {
      m->AddBlock("sea", Make<TwoMassBlock>(), {"tau_m", "tau_ext"}, outs);
    } else {
      m->AddBlock("sea", models::kTwoMassDrive, {}, {"tau_m", "tau_ext"}, outs);
    }
    if (truth || !Has(w, "viscous")) {
      m->AddBlock("viscous", models::kViscousFriction, {}, {"sea.qd_m"}, {"-tau_m"});
    }
    if (!Has(w, "coulomb") && !(truth && Has(w, "presliding"))) {
      m->AddBlock("coulomb", models::kCoulombFriction, CoulombOptions("rotational", kSeaSteepness),
                  {"sea.qd_m"}, {"-tau_m"});
    } else if (truth && Has(w, "coulomb")) {
      m->AddBlock("dry", Make<DryFrictionBlock>(), {"sea.qd_m"}, {"-tau_m"});
    } else if (truth) {
      m->AddBlock("lugre", models::kLuGreFriction, {}, {"sea.qd_m"}, {"-tau_m"});
    }
    m->AddBlock("link_viscous", models::kViscousFriction, {}, {"sea.qd_l"}, {"-tau_ext"});
    if (truth && Has(w, "sensor_scale")) {
      m->AddBlock("link_sensor", Make<SensorBlock>(), {"sea.q_l"}, {"q_l_measured"});
    }
    if (!truth) continue;
    if (Has(w, "asymmetric_friction")) {
      m->AddBlock("asymmetry", Make<DryFrictionBlock>(), {"sea.qd_m"}, {"-tau_m"});
    }
    if (Has(w, "stribeck")) {
      m->AddBlock("stribeck", Make<DryFrictionBlock>(), {"sea.qd_m"}, {"-tau_m"});
    }
    if (Has(w, "power_law_viscous")) {
      m->AddBlock("power_law", Make<PowerLawBlock>(), {"sea.qd_m"}, {"-tau_m"});
    }
    if (Has(w, "ripple")) {
      m->AddBlock("cogging", Make<CoggingBlock>(), {"sea.q_m"}, {"-tau_m"});
    }
    if (Has(w, "friction_drift")) {
      m->AddBlock("drift", Make<FrictionDriftBlock>(), {"sea.qd_m"}, {"-tau_m"});
    }
    if (Has(w, "periodic_disturbance")) {
      m->AddBlock("disturbance", Make<PeriodicForceBlock>(), {}, {"-tau_ext"});
    }
  }
  b.nominal.AddOutput("sea.q_m");
  b.nominal.AddOutput("sea.q_l");
  b.nominal.AddOutput("tau_s");
  b.truth.AddOutput("sea.q_m");
  b.truth.AddOutput(Has(w, "sensor_scale") ? "q_l_measured" : "sea.q_l");
  b.truth.AddOutput("tau_s");
  Apply({{"sea.J", kSeaJ, 1e-6, 1e-2, !Has(w, "rotor_inertia")},
         {"sea.I", kSeaI, 1e-5, 1e-1, !Has(w, "payload")},
         {"sea.Ke", kSeaKe, 0.1, 1000.0, true},
         {"sea.d", kSeaD, 0.0, 1.0, true},
         {"viscous.fv", kSeaViscous, 0.0, 1.0, true},
         {"coulomb.fc", kSeaCoulomb, 0.0, 1.0, true},
         {"link_viscous.fv", kSeaLinkViscous, 0.0, 1.0, true}},
        &b);
  if (Has(w, "coulomb")) {
    SetTruth("dry", {{"fc_pos", kSeaCoulomb}, {"fc_neg", kSeaCoulomb}, {"vd", kSeaVd}}, &b);
    AddDetail("motor Coulomb 0.0145 N m with the hard sign (2/pi) atan(v/0.001 rad/s)", &b);
  }
  if (Has(w, "asymmetric_friction")) {
    SetTruth("asymmetry", {{"fc_pos", 0.008}, {"fc_neg", 0.0}, {"vd", kSeaVd}}, &b);
    AddDetail("motor Coulomb levels 0.0225 N m forward, 0.0145 N m backward (atan sign)", &b);
  }
  if (Has(w, "stribeck")) {
    SetTruth("stribeck", {{"ds", 0.012}, {"vs", 0.5}, {"a", 1.4}, {"vd", kSeaVd}}, &b);
    AddDetail("motor Stribeck excess 0.012 N m exp(-|v/0.5 rad/s|^1.4), atan sign", &b);
  }
  if (Has(w, "viscous")) {
    b.truth_values["viscous.fv"] = kSeaViscous;
    AddDetail("motor viscous 0.00963 N m s/rad", &b);
  }
  if (Has(w, "power_law_viscous")) {
    SetTruth("power_law", {{"c", 0.04}, {"k", 1.6}, {"v0", 5.0}, {"vd", kSeaVd}}, &b);
    AddDetail("motor power-law viscous 0.04 N m |v/5 rad/s|^1.6 beside the linear term", &b);
  }
  if (Has(w, "presliding")) {
    SetTruth("lugre",
             {{"sigma0", kSeaCoulomb / 2e-3},
              {"sigma1", 0.01},
              {"sigma2", 0.0},
              {"fc", kSeaCoulomb},
              {"fs", kSeaCoulomb * 1.5},
              {"vs", 0.3}},
             &b);
    AddDetail(
        "motor LuGre: presliding 2 mrad (sigma0 7.25 N m/rad), sigma1 0.01 N m s/rad, "
        "fc 0.0145, fs 0.02175 N m, vs 0.3 rad/s (Gaussian Stribeck)",
        &b);
  }
  if (Has(w, "backlash")) {
    SetTruth("sea", {{"b", 0.01}}, &b);
    AddDetail("hard backlash, half width 0.01 rad, on the joint deflection", &b);
  }
  if (Has(w, "deadzone")) {
    SetTruth("deadzone", {{"d", 0.015}}, &b);
    AddDetail("hard dead zone of +-0.015 N m on the motor torque", &b);
  }
  if (Has(w, "input_delay")) {
    b.delay_seconds = 0.005;
    b.truth_values["input_delay.seconds"] = 0.005;
    AddDetail("exact transport delay of 5 ms (2.5 samples) on the motor torque", &b);
  }
  if (Has(w, "ripple")) {
    SetTruth("cogging",
             {{"a1", 0.01},
              {"a2", 0.006},
              {"P", 2.0 * kPi / 8.0},
              {"h2", 3.0},
              {"phi1", 0.7},
              {"phi2", 2.2}},
             &b);
    AddDetail("motor cogging 0.01 N m sin(8 q + 0.7) + 0.006 N m sin(24 q + 2.2)", &b);
  }
  if (Has(w, "rotor_inertia")) {
    b.truth.SetParameter("sea.J", kSeaJ + 1e-4);
    b.truth_values["rotor_inertia.J"] = 1e-4;
    AddDetail("extra rotor inertia 1e-4 kg m^2 (nominal J fixed at 1e-4)", &b);
  }
  if (Has(w, "payload")) {
    b.truth.SetParameter("sea.I", kSeaI + 0.7e-3);
    b.truth_values["payload.I"] = 0.7e-3;
    AddDetail("payload inertia 7e-4 kg m^2 on the link (nominal I fixed at 1.4e-3)", &b);
  }
  if (Has(w, "sensor_scale")) {
    SetTruth("link_sensor", {{"scale", 1.06}, {"offset", 0.0}}, &b);
    AddDetail("link encoder reads 1.06 x the angle", &b);
  }
  if (Has(w, "friction_drift")) {
    SetTruth("drift", {{"fc", kSeaCoulomb}, {"r", 1.0}, {"T", 4.0}, {"vd", kSeaVd}}, &b);
    AddDetail("motor Coulomb level drifting +100 % over 4 s", &b);
  }
  if (Has(w, "periodic_disturbance")) {
    SetTruth("disturbance", {{"A", 0.03}, {"f", 6.3}, {"phi", 1.1}}, &b);
    AddDetail("link disturbance 0.03 N m sin(2 pi 6.3 Hz t + 1.1)", &b);
  }
  b.dt = 0.002;
  b.samples = 2000;
  b.quantum = {kSeaCount, kSeaCount, 0.0};
  b.noise_std = {0.0, 0.0, 0.003};
  b.spec.method = "multiple_shooting";
  b.spec.solver = "ipopt";
  b.spec.step.substeps = 4;
  b.spec.multiple_shooting.segment_length = 20;
  b.spec.ipopt.max_iterations = 200;
  b.excite = &SeaExcitation;
  return b;
}

// ---- pendulum -----------------------------------------------------------------------------------
// A robot axis with gravity: a rigid arm on a horizontal pivot driven by a torque in open loop,
// with viscous and Coulomb (tanh, 100 s/rad) friction; measured: the encoder angle.

constexpr double kPendJ = 0.05, kPendMgl = 1.96, kPendViscous = 0.1, kPendCoulomb = 0.08;
constexpr double kPendSteepness = 100.0;  // [s/rad]
constexpr double kPendVd = 1e-3;          // [rad/s]
constexpr double kPendCount = 2.0 * kPi / 16384.0;

Eigen::MatrixXd PendulumExcitation(bool validation, double dt, int n, Rng* rng) {
  if (!validation) return Multisine(n, dt, 0.15, 2.5, 10, 0.3, rng);
  Eigen::VectorXd u = FilteredRandom(n, dt, 1.5, 0.2, rng);
  u += TrapezoidalPulses(n, dt, 0.5, rng);
  return u;
}

BaseBuild BuildPendulum(const std::vector<std::string>& w) {
  BaseBuild b;
  b.nominal = models::Model("pendulum");
  b.truth = models::Model("pendulum_truth");
  for (models::Model* m : {&b.nominal, &b.truth}) {
    const bool truth = m == &b.truth;
    if (truth && Has(w, "deadzone")) {
      m->AddInput("torque_cmd", "N m", "drive torque command", -1.5, 1.5);
      m->AddBlock("deadzone", Make<DeadZoneBlock>("N m"), {"torque_cmd"}, {"torque"});
    } else {
      m->AddInput("torque", "N m", "drive torque", -1.5, 1.5);
    }
    m->AddBlock("arm", models::kMassBlock, Motion("rotational"), {"torque"}, {});
    m->AddBlock("gravity", Make<GravityBlock>(), {"arm.q"}, {"-torque"});
    if (truth || !Has(w, "viscous")) {
      m->AddBlock("viscous", models::kViscousFriction, {}, {"arm.qd"}, {"-torque"});
    }
    if (!Has(w, "coulomb") && !(truth && Has(w, "presliding"))) {
      m->AddBlock("coulomb", models::kCoulombFriction, CoulombOptions("rotational", kPendSteepness),
                  {"arm.qd"}, {"-torque"});
    } else if (truth && Has(w, "coulomb")) {
      m->AddBlock("dry", Make<DryFrictionBlock>(), {"arm.qd"}, {"-torque"});
    } else if (truth) {
      m->AddBlock("lugre", models::kLuGreFriction, {}, {"arm.qd"}, {"-torque"});
    }
    const bool sensor = Has(w, "sensor_offset") || Has(w, "sensor_scale");
    if (truth && sensor) {
      m->AddBlock("sensor", Make<SensorBlock>(), {"arm.q"}, {"angle_measured"});
    }
    if (!truth) continue;
    if (Has(w, "asymmetric_friction")) {
      m->AddBlock("asymmetry", Make<DryFrictionBlock>(), {"arm.qd"}, {"-torque"});
    }
    if (Has(w, "stribeck")) {
      m->AddBlock("stribeck", Make<DryFrictionBlock>(), {"arm.qd"}, {"-torque"});
    }
    if (Has(w, "power_law_viscous")) {
      m->AddBlock("power_law", Make<PowerLawBlock>(), {"arm.qd"}, {"-torque"});
    }
    if (Has(w, "ripple")) {
      m->AddBlock("cogging", Make<CoggingBlock>(), {"arm.q"}, {"-torque"});
    }
    if (Has(w, "friction_drift")) {
      m->AddBlock("drift", Make<FrictionDriftBlock>(), {"arm.qd"}, {"-torque"});
    }
    if (Has(w, "periodic_disturbance")) {
      m->AddBlock("disturbance", Make<PeriodicForceBlock>(), {}, {"-torque"});
    }
  }
  b.nominal.AddOutput("arm.q");
  b.truth.AddOutput(Has(w, "sensor_offset") || Has(w, "sensor_scale") ? "angle_measured" : "arm.q");
  const bool payload = Has(w, "payload");
  const bool rotor = Has(w, "rotor_inertia");
  Apply({{"arm.mass", kPendJ, 1e-3, 1.0, !(payload || rotor)},
         {"gravity.mgl", kPendMgl, 0.1, 20.0, !payload},
         {"viscous.fv", kPendViscous, 0.0, 1.0, true},
         {"coulomb.fc", kPendCoulomb, 0.0, 2.0, true}},
        &b);
  if (Has(w, "coulomb")) {
    SetTruth("dry", {{"fc_pos", kPendCoulomb}, {"fc_neg", kPendCoulomb}, {"vd", kPendVd}}, &b);
    AddDetail("Coulomb 0.08 N m with the hard sign (2/pi) atan(v/0.001 rad/s)", &b);
  }
  if (Has(w, "asymmetric_friction")) {
    SetTruth("asymmetry", {{"fc_pos", 0.06}, {"fc_neg", 0.0}, {"vd", kPendVd}}, &b);
    AddDetail("Coulomb levels 0.14 N m forward, 0.08 N m backward (atan sign)", &b);
  }
  if (Has(w, "stribeck")) {
    SetTruth("stribeck", {{"ds", 0.08}, {"vs", 0.1}, {"a", 1.4}, {"vd", kPendVd}}, &b);
    AddDetail("Stribeck excess 0.08 N m exp(-|v/0.1 rad/s|^1.4), atan sign", &b);
  }
  if (Has(w, "viscous")) {
    b.truth_values["viscous.fv"] = kPendViscous;
    AddDetail("viscous 0.1 N m s/rad", &b);
  }
  if (Has(w, "power_law_viscous")) {
    SetTruth("power_law", {{"c", 0.05}, {"k", 0.5}, {"v0", 1.0}, {"vd", kPendVd}}, &b);
    AddDetail("power-law viscous 0.05 N m |v/1 rad/s|^0.5 beside the linear term", &b);
  }
  if (Has(w, "presliding")) {
    SetTruth("lugre",
             {{"sigma0", kPendCoulomb / 5e-3},
              {"sigma1", 0.05},
              {"sigma2", 0.0},
              {"fc", kPendCoulomb},
              {"fs", kPendCoulomb * 1.5},
              {"vs", 0.1}},
             &b);
    AddDetail(
        "LuGre: presliding 5 mrad (sigma0 16 N m/rad), sigma1 0.05 N m s/rad, fc 0.08, "
        "fs 0.12 N m, vs 0.1 rad/s (Gaussian Stribeck)",
        &b);
  }
  if (Has(w, "deadzone")) {
    SetTruth("deadzone", {{"d", 0.12}}, &b);
    AddDetail("hard dead zone of +-0.12 N m on the drive torque", &b);
  }
  if (Has(w, "input_delay")) {
    b.delay_seconds = 0.0175;
    b.truth_values["input_delay.seconds"] = 0.0175;
    AddDetail("exact transport delay of 17.5 ms (3.5 samples) on the drive torque", &b);
  }
  if (payload) {
    b.truth.SetParameter("arm.mass", kPendJ + 0.5 * 0.25 * 0.25);
    b.truth.SetParameter("gravity.mgl", kPendMgl + 0.5 * 9.81 * 0.25);
    b.truth_values["payload.mass"] = 0.5;
    b.truth_values["payload.distance"] = 0.25;
    AddDetail(
        "payload 0.5 kg at 0.25 m (J +0.03125 kg m^2, mgl +1.226 N m; nominal J and mgl "
        "fixed)",
        &b);
  }
  if (rotor) {
    b.truth.SetParameter("arm.mass", kPendJ + 0.02);
    b.truth_values["rotor_inertia.J"] = 0.02;
    AddDetail("reflected rotor inertia 0.02 kg m^2 (nominal J fixed at 0.05)", &b);
  }
  if (Has(w, "sensor_offset") || Has(w, "sensor_scale")) {
    const double scale = Has(w, "sensor_scale") ? 1.05 : 1.0;
    const double offset = Has(w, "sensor_offset") ? 0.06 : 0.0;
    SetTruth("sensor", {{"scale", scale}, {"offset", offset}}, &b);
    AddDetail("encoder reads " + Num(scale) + " x angle + " + Num(offset) + " rad", &b);
  }
  if (Has(w, "ripple")) {
    SetTruth("cogging",
             {{"a1", 0.06},
              {"a2", 0.03},
              {"P", 2.0 * kPi / 6.0},
              {"h2", 2.0},
              {"phi1", 0.5},
              {"phi2", 2.6}},
             &b);
    AddDetail("cogging 0.06 N m sin(6 q + 0.5) + 0.03 N m sin(12 q + 2.6)", &b);
  }
  if (Has(w, "friction_drift")) {
    SetTruth("drift", {{"fc", kPendCoulomb}, {"r", 1.0}, {"T", 10.0}, {"vd", kPendVd}}, &b);
    AddDetail("Coulomb level drifting +100 % over 10 s", &b);
  }
  if (Has(w, "periodic_disturbance")) {
    SetTruth("disturbance", {{"A", 0.12}, {"f", 2.7}, {"phi", 0.9}}, &b);
    AddDetail("disturbance torque 0.12 N m sin(2 pi 2.7 Hz t + 0.9)", &b);
  }
  b.dt = 0.005;
  b.samples = 2000;
  b.quantum = {kPendCount};
  b.noise_std = {1e-4};
  b.spec.method = "multiple_shooting";
  b.spec.solver = "ipopt";
  b.spec.step.substeps = 2;
  b.spec.multiple_shooting.segment_length = 20;
  b.spec.ipopt.max_iterations = 200;
  b.excite = &PendulumExcitation;
  return b;
}

}  // namespace

bool BaseSupports(const std::string& base, const std::string& effect) {
  static const std::map<std::string, std::set<std::string>> kSupported = {
      {"drive_closed_loop",
       {"coulomb", "asymmetric_friction", "stribeck", "viscous", "power_law_viscous", "ripple",
        "deadzone", "elasticity", "payload", "friction_drift", "periodic_disturbance"}},
      {"sea",
       {"coulomb", "asymmetric_friction", "stribeck", "viscous", "power_law_viscous", "presliding",
        "backlash", "deadzone", "input_delay", "ripple", "rotor_inertia", "payload", "sensor_scale",
        "friction_drift", "periodic_disturbance"}},
      {"pendulum",
       {"coulomb", "asymmetric_friction", "stribeck", "viscous", "power_law_viscous", "presliding",
        "deadzone", "input_delay", "payload", "rotor_inertia", "sensor_offset", "sensor_scale",
        "ripple", "friction_drift", "periodic_disturbance"}},
      {"pneumatic", {"leakage", "polytropic_index", "coulomb", "viscous", "friction_drift"}}};
  const auto it = kSupported.find(base);
  return it != kSupported.end() && it->second.count(effect) > 0;
}

BaseBuild BuildBase(const std::string& base, const std::vector<std::string>& withheld) {
  CheckSupported(base, withheld);
  if (base == "drive_closed_loop") return BuildDrive(withheld);
  if (base == "sea") return BuildSea(withheld);
  if (base == "pendulum") return BuildPendulum(withheld);
  if (base == "pneumatic") return BuildPneumatic(withheld);
  throw std::invalid_argument("withheld cases: unknown base '" + base + "'");
}

}  // namespace graybox::bench::internal
