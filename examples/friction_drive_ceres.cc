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
// i.e. continuity between the 20-sample segments is a residual with weight w_c = 1e3
// (continuity_as_constraints = false), so Ceres (trust-region Levenberg-Marquardt with a sparse
// Cholesky) can solve it. The fit starts from the blocks' nominal values, 2 to 7 times off the
// truth, with the shooting nodes initialised from the data (angle measured, speed by central
// differences). The 95% intervals are the Gauss-Newton output-error covariance (covariance.h).
//
// Check. Every estimate within kTolerance (2 %) of the truth; exit code 0 when all are.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "graybox/estimators/covariance.h"
#include "graybox/estimators/integrators.h"
#include "graybox/estimators/multiple_shooting.h"
#include "graybox/estimators/preprocessing.h"
#include "graybox/estimators/solvers.h"
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

models::StateSpaceModel DriveModel() {
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
  return m.Build();
}

}  // namespace

int main() {
  const models::StateSpaceModel model = DriveModel();
  Eigen::VectorXd truth = model.ParameterValues();
  for (const TrueValue& t : kTruth) truth[model.ParameterIndex(t.name)] = t.value;

  // Synthetic experiment.
  const unsigned seed = Seed();
  std::cout << "seed " << seed << " (override with GRAYBOX_SEED)\n";
  std::mt19937 rng(seed);
  est::ExperimentData ex;
  ex.name = "multisine";
  ex.dt = kDt;
  ex.u.resize(kSamples, 1);
  for (int k = 0; k < kSamples; ++k) {
    const double t = k * kDt;
    ex.u(k, 0) = 0.25 * std::sin(2.1 * t) + 0.12 * std::sin(5.3 * t) + 0.06 * std::sin(11.0 * t);
  }
  ex.x0 = Eigen::Vector2d::Zero();
  ex.y = est::SimulateRk4(model, ex.x0, ex.u, truth, kDt, 4).y;
  std::normal_distribution<double> noise(0.0, kNoise);
  for (int k = 0; k < kSamples; ++k) ex.y(k, 0) += noise(rng);
  // Node initialisation from the data: q measured, qd by central differences.
  ex.state_guess.resize(kSamples, 2);
  ex.state_guess.col(0) = ex.y.col(0);
  ex.state_guess.col(1) = est::CentralDifference(ex.y, kDt).col(0);
  std::printf("speed range [%.2f, %.2f] rad/s, torque range [%.2f, %.2f] N m\n",
              ex.state_guess.col(1).minCoeff(), ex.state_guess.col(1).maxCoeff(), ex.u.minCoeff(),
              ex.u.maxCoeff());

  // Multiple shooting with continuity as residuals, solved by Ceres.
  est::MultipleShootingOptions options;
  options.segment_length = 20;
  options.step.substeps = 2;
  options.continuity_as_constraints = false;
  options.continuity_weight = 1e3;
  const est::ShootingProblem problem = est::BuildMultipleShooting(model, {ex}, options);
  std::cout << "multiple shooting: " << problem.nlp.NumVariables() << " variables, "
            << problem.nlp.NumResiduals() << " residuals (outputs and continuity)\n";
  const est::SolverResult result = est::SolveWithCeres(problem.nlp);
  std::cout << result.BriefReport() << "\n";
  if (!result.success) {
    std::cout << result.FullReport() << "\nFAIL: the solver did not converge\n";
    return 1;
  }

  const Eigen::VectorXd p = problem.Parameters(result.w);
  const est::UncertaintyReport uncertainty = est::SimulationCovariance(
      model, {ex}, p, {problem.InitialState(result.w, 0)}, problem.output_weights, options.step);
  std::cout << uncertainty.BriefReport() << "\n";
  for (const std::string& w : uncertainty.warnings) std::cout << "  note: " << w << "\n";

  bool ok = true;
  std::printf("\n%-11s %-10s %9s %9s %9s %21s %9s\n", "parameter", "unit", "start", "truth",
              "estimate", "95% interval", "rel.err");
  for (int i = 0; i < model.NumParameters(); ++i) {
    const est::ParameterEstimate& e = uncertainty.parameters[i];
    const double rel = (e.value - truth[i]) / truth[i];
    const bool within = std::fabs(rel) <= kTolerance;
    ok = ok && within;
    std::printf("%-11s %-10s %9.5f %9.5f %9.5f [%9.5f, %9.5f] %+8.3f%% %s\n", e.name.c_str(),
                e.unit.c_str(), model.parameters[i].value, truth[i], e.value, e.ci_low, e.ci_high,
                100.0 * rel, within ? "ok" : "FAIL");
  }
  std::printf("\ncheck: |relative error| <= %.0f%% on every parameter: %s\n", 100.0 * kTolerance,
              ok ? "passed" : "FAILED");
  return ok ? 0 : 1;
}
