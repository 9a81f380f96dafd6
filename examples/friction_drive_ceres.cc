// friction_drive_ceres: rung 2 of the ladder, registered blocks and a least-squares solver.
//
// Model. A rotating load of inertia J driven by a motor torque u [N m], braked by viscous and
// (smoothed) Coulomb friction, composed from blocks of the global registry:
//     J qdd = u - fv qd - fc tanh(s qd)
//   "mechanics.mass" (motion = rotational)  states q [rad], qd [rad/s], parameter J  [kg m^2]
//   "friction.viscous"                      tau = fv qd,            parameter fv [N m s/rad]
//   "friction.coulomb" (steepness s fixed)  tau = fc tanh(s qd),    parameter fc [N m]
// The friction blocks read the velocity state "load.qd" and subtract their torque from the
// torque signal (models/friction.h: connect as "-torque"). Output: the encoder angle q.
//
// Data. Truth (J, fv, fc) = (0.05 kg m^2, 0.02 N m s/rad, 0.1 N m), s = 20 s/rad; a multisine
// torque with frequent velocity reversals (so the Coulomb level shows) over 8 s at dt = 10 ms;
// the angle is measured with white noise of 1 mrad (seed printed, overridable with GRAYBOX_SEED).
//
// Estimation problem. Output error by multiple shooting as a pure least-squares problem:
//     minimise over theta = (J, fv, fc), s_j
//         1/2 sum_k ((y_k - q_k(theta, s)) / std(y))^2
//       + 1/2 sum_j |w_c (Phi(end of segment j) - s_{j+1})|^2
// i.e. continuity between the 20-sample segments is a residual with weight w_c = 1e3, so Ceres
// (trust-region Levenberg-Marquardt with a sparse Cholesky) can solve it. The fit starts from the
// blocks' nominal values, 2 to 7 times off the truth, with the shooting nodes initialised from the
// data (angle measured, speed by central differences).
//
// The fit goes through estimators::Fit (fit/fit.h): MakeProblem with EstimationSpec solver =
// "ceres" (which puts multiple shooting's continuity into the residuals) and node_guess = "data"
// (the node guess is the states derived from the measurements as for equation error,
// EquationErrorSpec: q as measured, unfiltered, and qd = dq/dt by central differences;
// StatesFromData returns the same matrix for the printout), MakeSplit for the record. The 95%
// intervals are Fit's covariance for multiple shooting, the Gauss-Newton covariance of the shooting
// NLP with the continuity residuals taken as exact constraints (NlpCovariance,
// analysis/covariance.h), which does not depend on w_c.
//
// Check. Every estimate within kTolerance (2 %) of the truth; exit code 0 when all are.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>

#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/models/friction.h"
#include "graybox/models/mechanics.h"
#include "graybox/models/model.h"

namespace {

namespace est = graybox::estimators;
namespace models = graybox::models;

constexpr double kDt = 0.01;         // sample time [s]
constexpr int kSamples = 800;        // 8 s
constexpr double kNoise = 1e-3;      // angle noise std [rad]
constexpr double kSteepness = 20.0;  // tanh steepness of the Coulomb term [s/rad] (known)
constexpr double kTolerance = 0.02;  // relative error allowed on every parameter

struct TrueValue {
  const char* name;
  double value;
};
const TrueValue kTruth[] = {{"load.mass", 0.05}, {"viscous.fv", 0.02}, {"coulomb.fc", 0.1}};

unsigned Seed() {
  const char* env = std::getenv("GRAYBOX_SEED");
  return env ? static_cast<unsigned>(std::strtoul(env, nullptr, 10)) : 5u;
}

models::Model DriveModel() {
  models::Model m("friction_drive");
  m.AddInput("torque", "N m", "motor torque", -0.5, 0.5);
  models::BlockOptions rotational;
  rotational.words["motion"] = "rotational";
  m.AddBlock("load", models::kMassBlock, rotational, {"torque"}, {});
  m.AddBlock("viscous", models::kViscousFriction, {}, {"load.qd"}, {"-torque"});
  models::BlockOptions coulomb;
  coulomb.numbers["steepness"] = {kSteepness};  // fixed, not a parameter
  m.AddBlock("coulomb", models::kCoulombFriction, coulomb, {"load.qd"}, {"-torque"});
  m.AddOutput("load.q");
  return m;
}

}  // namespace

int main() {
  // Multiple shooting with continuity as residuals, solved by Ceres, nodes guessed from the data.
  est::EstimationSpec spec;
  spec.method = "multiple_shooting";
  spec.solver = "ceres";
  spec.step.substeps = 2;
  spec.multiple_shooting.segment_length = 20;
  spec.multiple_shooting.continuity_weight = 1e3;
  spec.node_guess = "data";
  // qd = dq/dt: a problem file infers this from the kinematics, MakeProblem takes the spec as
  // given.
  spec.equation_error.differentiate["load.qd"] = "load.q";
  const est::Problem problem = est::MakeProblem("friction_drive", DriveModel(), spec);
  const models::StateSpaceModel& model = problem.built;
  Eigen::VectorXd truth = model.ParameterValues();
  for (const TrueValue& t : kTruth) truth[model.ParameterIndex(t.name)] = t.value;

  // Synthetic experiment.
  const unsigned seed = Seed();
  std::cout << "seed " << seed << " (override with GRAYBOX_SEED)\n";
  std::mt19937 rng(seed);
  est::Experiment ex;
  ex.name = "multisine";
  ex.dt = kDt;
  ex.u.resize(kSamples, 1);
  for (int k = 0; k < kSamples; ++k) {
    const double t = k * kDt;
    ex.u(k, 0) = 0.25 * std::sin(2.1 * t) + 0.12 * std::sin(5.3 * t) + 0.06 * std::sin(11.0 * t);
  }
  const Eigen::Vector2d x0 = Eigen::Vector2d::Zero();
  ex.y = est::SimulateRk4(model, x0, ex.u, truth, kDt, 4).y;
  std::normal_distribution<double> noise(0.0, kNoise);
  for (int k = 0; k < kSamples; ++k) ex.y(k, 0) += noise(rng);
  // The node guess Fit takes with node_guess = "data": q measured, qd by central differences.
  const Eigen::MatrixXd guess = est::StatesFromData(problem, ex);
  std::printf("speed range [%.2f, %.2f] rad/s, torque range [%.2f, %.2f] N m\n",
              guess.col(1).minCoeff(), guess.col(1).maxCoeff(), ex.u.minCoeff(), ex.u.maxCoeff());

  const est::FitResult fit =
      est::Fit(problem, {est::MakeSplit("multisine", est::SplitRole::kEstimation, ex, x0)});
  std::cout << fit.BriefReport() << "\n"
            << fit.num_variables << " variables, " << fit.num_residuals
            << " residuals (outputs and continuity)\n";
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
  std::printf("\n%-11s %-10s %9s %9s %9s %21s %9s\n", "parameter", "unit", "start", "truth",
              "estimate", "95% interval", "rel.err");
  for (int i = 0; i < model.NumParameters(); ++i) {
    const est::FitParameter& e = fit.parameters[i];  // the model's order
    const double rel = (e.value - truth[i]) / truth[i];
    const bool within = std::fabs(rel) <= kTolerance;
    ok = ok && within;
    std::printf("%-11s %-10s %9.5f %9.5f %9.5f [%9.5f, %9.5f] %+8.3f%% %s\n", e.name.c_str(),
                e.unit.c_str(), e.initial, truth[i], e.value, e.ci_low, e.ci_high, 100.0 * rel,
                within ? "ok" : "FAIL");
  }
  std::printf("\ncheck: |relative error| <= %.0f%% on every parameter: %s\n", 100.0 * kTolerance,
              ok ? "passed" : "FAILED");
  return ok ? 0 : 1;
}
