// robot_2dof_ms: rung 3 of the ladder, a robot arm from a DH table.
//
// Model. A planar two-link arm swinging in a vertical plane, two revolute joints about parallel
// horizontal axes, described by its standard Denavit-Hartenberg table (models/serial_chain.h):
//     link   alpha   a [m]   d [m]   theta   mass [kg]   COM in {i} [m]   I_zz about COM [kg m^2]
//      1      0      0.5      0       q1       4.0        (-0.25, 0, 0)    4.0 * 0.5^2 / 12
//      2      0      0.4      0       q2       2.0        (-0.20, 0, 0)    2.0 * 0.4^2 / 12
// gravity (0, -9.81, 0) m/s^2 in the base frame (hanging at q = (-pi/2, 0)), rotor inertias
// 0.05 kg m^2 per joint. The block "robot.serial_chain" (models/robot_blocks.h) gives the forward
// dynamics
//     M(q, theta) qdd + C(q, qd, theta) qd + g(q, theta) = tau - tau_f(qd),
// with the inertial parameters theta as block parameters, and each joint i gets the registered
// friction blocks
//     tau_f,i = fv_i qd_i + fc_i tanh(s qd_i)      ("friction.viscous", "friction.coulomb"),
// wired as "-tau<i>" onto the joint torque signal. Inputs: the motor torques tau1, tau2 [N m];
// outputs: the encoder angles q1, q2 [rad].
//
// The unknowns. The four friction coefficients fv_1, fv_2 [N m s/rad], fc_1, fc_2 [N m] and the
// mass parameter "l2.m" of link 2. The inertial parameters are taken about the origin of each
// link's DH frame (regressor.h), which for link 2 is the tool tip: changing l2.m with the first
// moment and the inertia fixed adds a point mass at the tip. The truth has l2.m = 2.6 kg (link 2
// carrying a 0.6 kg payload at the tip); the fit starts from the nominal 2.0 kg. Every other
// inertial parameter is known (fixed).
//
// Data. Multisine torques for 6 s at dt = 10 ms, simulated with 8 RK4 substeps per sample; angles
// with white noise of 1 mrad (seed printed, overridable with GRAYBOX_SEED). The forced double
// pendulum is sensitive to its initial state, so a single long simulation makes a rugged cost;
// multiple shooting (segments of 10 samples, one RK4 step per sample, continuity as equality
// constraints) keeps every segment short:
//     minimise over theta, s_j   1/2 sum_k |W (y_k - q_k(theta, s))|^2
//     subject to                 s_{j+1} = Phi(end of segment j; theta, s_j),
// solved by Ipopt with the exact Hessian.
//
// The fit goes through estimators::Fit (fit/fit.h): MakeProblem wraps the model with only the
// unknowns free and the EstimationSpec above (method "multiple_shooting", step.substeps = 1,
// segment_length = 10; Ipopt is the default solver for shooting), MakeSplit the record and its
// x0; Fit formulates, solves, and computes the 95% intervals as the Gauss-Newton covariance of
// the shooting NLP with the nodes eliminated along the continuity constraints (NlpCovariance,
// analysis/covariance.h). The table is built from fit.parameters.
//
// Check. Every estimate within kTolerance (2 %) of the truth; exit code 0 when all are.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/models/friction.h"
#include "graybox/models/model.h"
#include "graybox/models/robot_blocks.h"
#include "graybox/models/serial_chain.h"

namespace {

namespace est = graybox::estimators;
namespace models = graybox::models;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.01;         // sample time [s]
constexpr int kSamples = 600;        // 6 s
constexpr double kNoise = 1e-3;      // angle noise std [rad]
constexpr double kSteepness = 20.0;  // tanh steepness of the Coulomb terms [s/rad] (known)
constexpr int kSubsteps = 1;         // RK4 steps per sample in the estimator
constexpr int kTruthSubsteps = 8;    // RK4 substeps of the "true" simulation
constexpr double kTolerance = 0.02;  // relative error allowed on every free parameter

struct Value {
  const char* name;
  double value;
};
// The free parameters and their true values.
const Value kTruth[] = {{"arm.l2.m", 2.6},
                        {"friction1.fv", 0.8},
                        {"friction2.fv", 0.5},
                        {"coulomb1.fc", 1.0},
                        {"coulomb2.fc", 0.6}};

unsigned Seed() {
  const char* env = std::getenv("GRAYBOX_SEED");
  return env ? static_cast<unsigned>(std::strtoul(env, nullptr, 10)) : 3u;
}

models::Link PlanarLink(double length, double mass) {
  models::Link l;
  l.a = length;
  l.mass = mass;
  l.center_of_mass = Eigen::Vector3d(-0.5 * length, 0.0, 0.0);  // {i} sits at the distal end
  const double bending = mass * length * length / 12.0;         // slender rod
  l.inertia = Eigen::Vector3d(1e-3, bending, bending).asDiagonal();
  l.inertia_reference = models::InertiaReference::kCenterOfMass;
  l.rotor_inertia = 0.05;
  return l;
}

models::Model ArmModel() {
  const models::SerialChain chain("planar 2R", models::DhConvention::kStandard,
                                  {PlanarLink(0.5, 4.0), PlanarLink(0.4, 2.0)},
                                  Eigen::Vector3d(0.0, -9.81, 0.0));
  models::SerialChainBlockOptions arm_options;
  arm_options.parameters = models::InertialParameterSet::kRigidBody;  // rotor inertia known
  models::Model m("planar_arm");
  m.AddInput("tau1", "N m", "joint 1 motor torque", -10.0, 10.0);
  m.AddInput("tau2", "N m", "joint 2 motor torque", -5.0, 5.0);
  m.AddBlock("arm", models::MakeSerialChainBlock(chain, arm_options), {"tau1", "tau2"}, {});
  models::BlockOptions coulomb;
  coulomb.numbers["steepness"] = {kSteepness};
  for (const std::string j : {"1", "2"}) {
    m.AddBlock("friction" + j, models::kViscousFriction, {}, {"arm.qd" + j}, {"-tau" + j});
    m.AddBlock("coulomb" + j, models::kCoulombFriction, coulomb, {"arm.qd" + j}, {"-tau" + j});
  }
  m.AddOutput("arm.q1");
  m.AddOutput("arm.q2");
  // Only the unknowns are free; the friction fit starts from 0.1 (N m s/rad or N m).
  for (const models::ModelParameter& p : std::vector<models::ModelParameter>(m.parameters())) {
    m.Fix(p.name);
  }
  for (const Value& v : kTruth) {
    m.Free(v.name);
    if (std::string(v.name) != "arm.l2.m") m.SetParameter(v.name, 0.1);
  }
  return m;
}

}  // namespace

int main() {
  est::EstimationSpec spec;
  spec.method = "multiple_shooting";  // solver: Ipopt (the default for shooting)
  spec.step.substeps = kSubsteps;
  spec.multiple_shooting.segment_length = 10;
  const est::Problem problem = est::MakeProblem("planar_arm", ArmModel(), spec);
  const models::StateSpaceModel& model = problem.built;
  Eigen::VectorXd truth = model.ParameterValues();
  for (const Value& v : kTruth) truth[model.ParameterIndex(v.name)] = v.value;

  const unsigned seed = Seed();
  std::cout << "seed " << seed << " (override with GRAYBOX_SEED)\n";
  std::mt19937 rng(seed);
  est::Experiment ex;
  ex.name = "multisine";
  ex.dt = kDt;
  ex.u.resize(kSamples, 2);
  for (int k = 0; k < kSamples; ++k) {
    const double t = k * kDt;
    ex.u(k, 0) = 6.0 * std::sin(1.1 * t) + 3.0 * std::sin(3.7 * t) + 1.0 * std::sin(8.3 * t);
    ex.u(k, 1) = 2.5 * std::sin(1.7 * t) + 1.5 * std::sin(5.3 * t) + 0.5 * std::sin(9.7 * t);
  }
  const Eigen::Vector4d x0(-kPi / 2.0, 0.0, 0.0, 0.0);  // hanging at rest
  const est::Trajectory sim = est::SimulateRk4(model, x0, ex.u, truth, kDt, kTruthSubsteps);
  ex.y = sim.y;
  std::normal_distribution<double> noise(0.0, kNoise);
  for (int k = 0; k < kSamples; ++k) {
    for (int j = 0; j < 2; ++j) ex.y(k, j) += noise(rng);
  }
  std::printf("motion: q1 in [%.2f, %.2f] rad, q2 in [%.2f, %.2f] rad, |qd| <= %.2f rad/s\n",
              sim.x.col(0).minCoeff(), sim.x.col(0).maxCoeff(), sim.x.col(1).minCoeff(),
              sim.x.col(1).maxCoeff(), sim.x.rightCols(2).cwiseAbs().maxCoeff());

  const est::FitResult fit =
      est::Fit(problem, {est::MakeSplit("multisine", est::SplitRole::kEstimation, ex, x0)});
  std::cout << fit.BriefReport() << "\n"
            << fit.num_variables << " variables, " << fit.num_constraints
            << " continuity constraints\n";
  if (!fit.solver_result.success) {
    std::cout << fit.FullReport() << "\nFAIL: the solver did not converge\n";
    return 1;
  }
  if (fit.has_uncertainty) {
    std::cout << fit.uncertainty.BriefReport() << "\n";
    for (const std::string& w : fit.uncertainty.warnings) std::cout << "  note: " << w << "\n";
  } else {
    std::cout << "no covariance: " << fit.uncertainty_error << "\n";
  }

  bool ok = true;
  std::printf("\n%-13s %-10s %7s %7s %9s %21s %9s\n", "parameter", "unit", "start", "truth",
              "estimate", "95% interval", "rel.err");
  for (const Value& v : kTruth) {
    const est::FitParameter& e = fit.Parameter(v.name);
    const double rel = (e.value - v.value) / v.value;
    const bool within = std::fabs(rel) <= kTolerance;
    ok = ok && within;
    std::printf("%-13s %-10s %7.3f %7.3f %9.5f [%9.5f, %9.5f] %+8.3f%% %s\n", e.name.c_str(),
                e.unit.c_str(), e.initial, v.value, e.value, e.ci_low, e.ci_high, 100.0 * rel,
                within ? "ok" : "FAIL");
  }
  std::printf("\ncheck: |relative error| <= %.0f%% on every free parameter: %s\n",
              100.0 * kTolerance, ok ? "passed" : "FAILED");
  return ok ? 0 : 1;
}
