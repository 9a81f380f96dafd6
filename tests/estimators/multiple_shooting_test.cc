// Multiple shooting recovers known parameters of a drive with friction from noisy simulated data,
// with Ipopt (continuity constraints) and Ceres (continuity residuals).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/solvers/solvers.h"
#include "graybox/models/model.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

constexpr unsigned kSeed = 11;
constexpr double kDt = 0.01;

// The drive is test_models.h's FrictionDrive: J qdd = tau - fv qd - fc tanh(qd / 0.05).
using testing::FrictionDriveModel;

struct Truth {
  Eigen::Vector3d p{0.8, 0.45, 0.35};
};

/// The initial state of the simulated experiments.
ExperimentSetup SimulatedSetup() {
  ExperimentSetup setup;
  setup.x0 = Eigen::Vector2d(0.1, 0.0);
  return setup;
}

Experiment SimulatedExperiment(const models::StateSpaceModel& model, int n, double noise,
                               std::mt19937* rng) {
  Experiment ex;
  ex.name = "sim";
  ex.dt = kDt;
  ex.u = testing::DriveTorque(n, kDt);
  const Trajectory t = SimulateRk4(model, SimulatedSetup().x0, ex.u, Truth().p, kDt, 2);
  std::normal_distribution<double> eps(0.0, noise);
  ex.y = t.y;
  for (int k = 0; k < n; ++k) ex.y(k, 0) += eps(*rng);
  return ex;
}

models::StateSpaceModel PerturbedModel() {
  models::StateSpaceModel model = FrictionDriveModel();
  const Truth truth;
  for (int i = 0; i < 3; ++i) model.parameters[i].value = truth.p[i] * (i % 2 ? 0.7 : 1.3);
  return model;
}

// Noise of 1e-3 rad on 1000 samples: the least-squares estimate lies within ~1e-2 relative.
constexpr double kRecoveryTolerance = 0.02;

TEST(MultipleShooting, IpoptRecoversFrictionParameters) {
  std::mt19937 rng(kSeed);
  const Experiment ex = SimulatedExperiment(FrictionDriveModel(), 1000, 1e-3, &rng);
  MultipleShootingOptions options;
  options.segment_length = 25;
  options.step.substeps = 2;
  const ShootingProblem problem =
      BuildMultipleShooting(PerturbedModel(), {ex}, {SimulatedSetup()}, options);
  EXPECT_EQ(problem.nlp.NumConstraints(), (1000 / 25 - 1) * 2);
  const SolverResult r = SolveWithIpopt(problem.nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  const Eigen::VectorXd p = problem.Parameters(r.w);
  const Truth truth;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(p[i] / truth.p[i], 1.0, kRecoveryTolerance) << "parameter " << i;
  }
  EXPECT_LT(r.constraint_violation, 1e-8);
}

TEST(MultipleShooting, CeresWithContinuityResidualsAgreesWithIpopt) {
  std::mt19937 rng(kSeed);
  const Experiment ex = SimulatedExperiment(FrictionDriveModel(), 1000, 1e-3, &rng);
  MultipleShootingOptions options;
  options.segment_length = 25;
  options.step.substeps = 2;
  const ShootingProblem with_constraints =
      BuildMultipleShooting(PerturbedModel(), {ex}, {SimulatedSetup()}, options);
  options.continuity_as_constraints = false;
  options.continuity_weight = 1e3;
  const ShootingProblem with_residuals =
      BuildMultipleShooting(PerturbedModel(), {ex}, {SimulatedSetup()}, options);
  const SolverResult ipopt = SolveWithIpopt(with_constraints.nlp);
  const SolverResult ceres = SolveWithCeres(with_residuals.nlp);
  ASSERT_TRUE(ipopt.success) << ipopt.FullReport();
  ASSERT_TRUE(ceres.success) << ceres.FullReport();
  const Eigen::VectorXd pi = with_constraints.Parameters(ipopt.w);
  const Eigen::VectorXd pc = with_residuals.Parameters(ceres.w);
  // Penalised continuity (weight 1e3 against unit-variance outputs) shifts the optimum by
  // O(1 / weight^2) relative to exact continuity.
  constexpr double kFormulationAgreement = 1e-4;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(pi[i], pc[i], kFormulationAgreement * pi[i]);
}

TEST(MultipleShooting, BadInputIsRejectedWithItsPlace) {
  Experiment ex;
  ex.name = "broken";
  ex.dt = kDt;
  ex.u = Eigen::MatrixXd::Zero(10, 1);
  ex.y = Eigen::MatrixXd::Zero(9, 1);
  ExperimentSetup setup;
  setup.x0 = Eigen::Vector2d::Zero();
  try {
    BuildMultipleShooting(FrictionDriveModel(), {ex}, {setup});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("experiment 'broken'"), std::string::npos) << e.what();
  }
  ex.y = Eigen::MatrixXd::Zero(10, 1);
  ex.y(3, 0) = std::nan("");
  ex.y_names = {"speed"};
  // The message names the channel, the sample and its time.
  try {
    BuildMultipleShooting(FrictionDriveModel(), {ex}, {setup});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("output 'speed' at sample 3 (t = 0.03 s) is NaN"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace graybox::estimators
