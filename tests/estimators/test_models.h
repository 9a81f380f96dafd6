// The small models the estimators tests simulate and identify, each written once with its model
// builder:
//
//  - FrictionDrive: an inertia with viscous and smoothed Coulomb friction, optionally on a spring;
//    a smooth, non-stiff plant with known parameters to recover from noisy simulated data.
//    Used by multiple_shooting_test, single_shooting_test (with the spring), n_step_loss_test
//    (inertia bounded below by 0) and nlp_check_test (with the spring, other nominal values).
//  - Robertson: Robertson's stiff chemical kinetics, the standard stiff test problem with a
//    published reference solution. Used by cvodes_test and implicit_step_test.
//  - FirstOrderLag: x' = -a x + b u, exact under a zero-order hold. Used by cvodes_test and
//    covariance_test.
//
// Each block's nominal parameter values are also the models' starting values and, through
// models::DefaultParameterScale, the optimizer's scales: the tests' numbers depend on them.
#pragma once

#include <cmath>
#include <memory>

#include <Eigen/Core>

#include "graybox/estimators/integrators/cvodes_integrator.h"
#include "graybox/models/block.h"
#include "graybox/models/model.h"

namespace graybox::estimators::testing {

// ---- friction drive ---------------------------------------------------------------------------

/// Velocity scale of the smoothed Coulomb friction fc tanh(qd / kCoulombSmoothing), rad/s.
constexpr double kCoulombSmoothing = 0.05;

/// What differs between the tests that use FrictionDrive.
struct FrictionDriveOptions {
  /// Adds the spring torque -k q and the fourth parameter k.
  bool spring = false;
  /// Nominal values (starting values and optimizer scales) of J (kg m^2), fv (N m s/rad),
  /// fc (N m) and, with the spring, k (N m/rad).
  double inertia = 0.5;
  double viscous = 0.3;
  double coulomb = 0.2;
  double stiffness = 2.0;
  /// Lower bound of J. The default keeps an optimizer away from the singular J = 0; a bound of 0
  /// makes J = 0 an admissible trial point (n_step_loss_test uses it to provoke a non-finite
  /// simulation).
  double inertia_lower = 0.01;
};

/// J qdd = tau - fv qd - fc tanh(qd / 0.05) [- k q]: a load inertia J driven by the torque tau
/// (N m, input), with viscous friction fv and Coulomb friction fc smoothed over 0.05 rad/s, and
/// with FrictionDriveOptions::spring a spring of stiffness k. States q (rad) and qd (rad/s).
/// Parameters J in [inertia_lower, 10], fv and fc in [0, 10], k in [0, 100].
class FrictionDrive : public models::BlockBase<FrictionDrive> {
 public:
  explicit FrictionDrive(const FrictionDriveOptions& options = {}) : spring_(options.spring) {
    info_.type = spring_ ? "test.spring_drive" : "test.friction_drive";
    info_.description = spring_ ? "inertia on a spring with viscous and Coulomb friction"
                                : "inertia with viscous and Coulomb friction";
    info_.reference = "test";
    info_.inputs = {{"tau", "N m", "drive torque", -2, 2}};
    info_.states = {{"q", "rad", "angle", -1, 1}, {"qd", "rad/s", "speed", -1, 1}};
    info_.parameters = {{"J", "kg m^2", "inertia", options.inertia, options.inertia_lower, 10.0},
                        {"fv", "N m s/rad", "viscous friction", options.viscous, 0.0, 10.0},
                        {"fc", "N m", "Coulomb friction", options.coulomb, 0.0, 10.0}};
    if (spring_) {
      info_.parameters.push_back(
          {"k", "N m/rad", "spring stiffness", options.stiffness, 0.0, 100.0});
    }
  }
  template <typename S>
  void Compute(const models::BlockArgs<S>& a) const {
    using std::tanh;
    S torque = a.u[0] - a.p[1] * a.x[1] - a.p[2] * tanh(a.x[1] / kCoulombSmoothing);
    if (spring_) torque = torque - a.p[3] * a.x[0];
    a.xdot[0] = a.x[1];
    a.xdot[1] = torque / a.p[0];
  }

 private:
  bool spring_;
};

/// The model "drive" (with the spring "spring_drive"): input "tau" into a FrictionDrive named
/// "drive", output its angle "drive.q". Parameters start at the options' nominal values.
inline models::StateSpaceModel FrictionDriveModel(const FrictionDriveOptions& options = {}) {
  models::Model m(options.spring ? "spring_drive" : "drive");
  m.AddInput("tau", "N m", "drive torque");
  m.AddBlock("drive", std::make_shared<FrictionDrive>(options), {"tau"}, {});
  m.AddOutput("drive.q");
  return m.Build();
}

/// The drive torque of the identification experiments, N m, n samples of dt seconds (n x 1):
/// tau(t) = 1.2 sin(2 t) + 0.6 sin(7.3 t) + 0.3 sin(0.5 t), frequencies 0.5 to 7.3 rad/s.
inline Eigen::MatrixXd DriveTorque(int n, double dt) {
  Eigen::MatrixXd u(n, 1);
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    u(k, 0) = 1.2 * std::sin(2.0 * t) + 0.6 * std::sin(7.3 * t) + 0.3 * std::sin(0.5 * t);
  }
  return u;
}

// ---- Robertson's kinetics ---------------------------------------------------------------------

/// Robertson's chemical kinetics (Robertson 1966; Hairer & Wanner, Solving ODEs II, sec. IV.1):
///   y1' = -k1 y1 + k3 y2 y3,  y2' = k1 y1 - k3 y2 y3 - k2 y2^2,  y3' = k2 y2^2,
/// dimensionless concentrations y1, y2 (~4e-5 at most), y3; rates k1 = 0.04, k2 = 3e7, k3 = 1e4
/// (1/s, the nominal values), usually from y(0) = (1, 0, 0). Eigenvalues reach ~-1e4 within
/// 1e-3 s: stiff (BlockInfo::stiff). y1 + y2 + y3 is conserved.
class Robertson : public models::BlockBase<Robertson> {
 public:
  Robertson() {
    info_.type = "test.robertson";
    info_.description = "Robertson's stiff chemical kinetics";
    info_.reference = "Robertson 1966";
    info_.states = {{"y1", "1", "concentration 1", 0, 1},
                    {"y2", "1", "concentration 2", 0, 4e-5},
                    {"y3", "1", "concentration 3", 0, 1}};
    info_.parameters = {{"k1", "1/s", "rate 1", 0.04, 0.0, 1.0},
                        {"k2", "1/s", "rate 2", 3e7, 0.0, 1e9},
                        {"k3", "1/s", "rate 3", 1e4, 0.0, 1e6}};
    info_.stiff = true;
  }
  template <typename S>
  void Compute(const models::BlockArgs<S>& a) const {
    const S& y1 = a.x[0];
    const S& y2 = a.x[1];
    const S& y3 = a.x[2];
    a.xdot[0] = -a.p[0] * y1 + a.p[2] * y2 * y3;
    a.xdot[1] = a.p[0] * y1 - a.p[2] * y2 * y3 - a.p[1] * y2 * y2;
    a.xdot[2] = a.p[1] * y2 * y2;
  }
};

/// The model "robertson": a Robertson block named "rob" without inputs, outputs "rob.y1" and
/// "rob.y3".
inline models::StateSpaceModel RobertsonModel() {
  models::Model m("robertson");
  m.AddBlock("rob", std::make_shared<Robertson>(), {}, {});
  m.AddOutput("rob.y1");
  m.AddOutput("rob.y3");
  return m.Build();
}

/// CVODES tolerances for Robertson: relative `rtol`, absolute rtol times each species' scale
/// (1e-2, 1e-7, 1e-2; y2 ~ 4e-5).
inline CvodesOptions RobertsonOptions(double rtol) {
  CvodesOptions o;
  o.relative_tolerance = rtol;
  o.absolute_tolerances = rtol * Eigen::Vector3d(1e-2, 1e-7, 1e-2);
  return o;
}

// ---- first-order lag --------------------------------------------------------------------------

/// x' = -a x + b u, y = x: a first-order lag with pole a (1/s, nominal 2 in [0.01, 100]) and gain
/// b (1/s, nominal 3 in [-100, 100]); input u and state x dimensionless. Exact under a
/// zero-order hold: x(t + h) = e^(-a h) x(t) + (b / a) (1 - e^(-a h)) u.
class FirstOrderLag : public models::BlockBase<FirstOrderLag> {
 public:
  FirstOrderLag() {
    info_.type = "test.lag";
    info_.description = "first-order lag";
    info_.reference = "test";
    info_.inputs = {{"u", "1", "input", -1, 1}};
    info_.states = {{"x", "1", "state", -1, 1}};
    info_.parameters = {{"a", "1/s", "pole", 2.0, 0.01, 100.0},
                        {"b", "1/s", "gain", 3.0, -100.0, 100.0}};
  }
  template <typename S>
  void Compute(const models::BlockArgs<S>& a) const {
    a.xdot[0] = -a.p[0] * a.x[0] + a.p[1] * a.u[0];
  }
};

/// The model "lag": input "u" into a FirstOrderLag named "lag", output "lag.x".
inline models::StateSpaceModel LagModel() {
  models::Model m("lag");
  m.AddInput("u", "1");
  m.AddBlock("lag", std::make_shared<FirstOrderLag>(), {"u"}, {});
  m.AddOutput("lag.x");
  return m.Build();
}

}  // namespace graybox::estimators::testing
