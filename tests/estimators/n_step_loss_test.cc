// The N-step-ahead loss: its cost is the N-step NRMS of metrics.h, its Jacobian matches central
// differences, it recovers known parameters from noisy state measurements, numerical failures
// come back as statuses, and bad input is rejected with the place named.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "graybox/estimators/analysis/metrics.h"
#include "graybox/estimators/formulations/n_step_loss.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/solvers/solvers.h"
#include "graybox/models/model.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

constexpr unsigned kSeed = 23;
constexpr double kDt = 0.01;

// test_models.h's FrictionDrive, J qdd = tau - fv qd - fc tanh(qd / 0.05), with parameters p and
// the inertia bounded below by 0 so that J = 0 is an admissible trial point.
models::StateSpaceModel DriveModel(const Eigen::Vector3d& p) {
  testing::FrictionDriveOptions options;
  options.inertia_lower = 0.0;
  models::StateSpaceModel model = testing::FrictionDriveModel(options);
  for (int i = 0; i < 3; ++i) model.parameters[i].value = p[i];
  return model;
}

const Eigen::Vector3d kTruth(0.8, 0.45, 0.35);
const Eigen::Vector3d kStart(0.8 * 1.3, 0.45 * 0.7, 0.35 * 1.3);  // 30 % off

// A record of both states with noise `noise` (rad and rad/s): the measured states x, and the
// noisy position as the output.
Experiment Simulated(int n, double noise, unsigned seed) {
  Experiment ex;
  ex.name = "sim";
  ex.dt = kDt;
  ex.u = testing::DriveTorque(n, kDt);
  const Eigen::Vector2d x0(0.1, 0.0);
  const models::StateSpaceModel truth = DriveModel(kTruth);
  const Trajectory t = MakeIntegrator(truth, kDt)->Simulate(x0, ex.u, kTruth);
  std::mt19937 rng(seed);
  std::normal_distribution<double> eps(0.0, noise);
  ex.x = t.x;
  for (Eigen::Index k = 0; k < ex.x.size(); ++k) ex.x.data()[k] += eps(rng);
  ex.y = ex.x.col(0);
  return ex;
}

TEST(NStepLoss, CostIsTheNStepNrmsOfTheMetric) {
  const Experiment rec = Simulated(400, 1e-3, kSeed);
  NStepLossOptions options;
  options.steps = 30;
  options.stride = 7;
  const models::StateSpaceModel model = DriveModel(kStart);
  const NStepLossProblem problem = BuildNStepLoss(model, {rec}, options);
  double cost = 0.0;
  ASSERT_TRUE(problem.nlp.Objective(problem.nlp.w0().data(), &cost).ok);

  const std::unique_ptr<Integrator> integrator = MakeIntegrator(model, kDt);
  const Eigen::VectorXd p = problem.Parameters(problem.nlp.w0());
  const SimulateFromState simulate = [&](int start, const Eigen::VectorXd& x, int steps) {
    const Trajectory t = integrator->Simulate(x, rec.u.middleRows(start, steps + 1), p);
    return Eigen::MatrixXd(t.x.bottomRows(steps));
  };
  NStepOptions scoring;
  scoring.steps = options.steps;
  scoring.stride = options.stride;
  const NStepResult eta = NStepNrms(rec.x, simulate, scoring);
  EXPECT_EQ(eta.starts, problem.starts[0]);
  constexpr double kSameSums = 1e-12;  // two summation orders of the same squares
  EXPECT_NEAR(problem.Nrms(cost), eta.nrms, kSameSums * eta.nrms);
  EXPECT_EQ(problem.num_scored, static_cast<long>(eta.starts.size()) * 30 * 2);
}

TEST(NStepLoss, ZeroWeightsTakeTheDefault) {
  const Experiment rec = Simulated(300, 1e-3, kSeed);
  NStepLossOptions options;
  options.steps = 20;
  const models::StateSpaceModel model = DriveModel(kStart);
  const NStepLossProblem defaults = BuildNStepLoss(model, {rec}, options);
  options.weights = Eigen::Vector2d(0.0, 5.0);
  const NStepLossProblem mixed = BuildNStepLoss(model, {rec}, options);
  EXPECT_EQ(mixed.weights[0], defaults.weights[0]);  // 1 / std of q
  EXPECT_EQ(mixed.weights[1], 5.0);
  options.weights = Eigen::Vector2d(-1.0, 5.0);
  EXPECT_THROW(BuildNStepLoss(model, {rec}, options), std::invalid_argument);
}

TEST(NStepLoss, JacobianMatchesCentralDifferences) {
  const Experiment rec = Simulated(200, 1e-3, kSeed);
  NStepLossOptions options;
  options.steps = 25;
  options.stride = 10;
  options.channels = {1};
  options.num_threads = 2;
  const NStepLossProblem problem = BuildNStepLoss(DriveModel(kStart), {rec}, options);
  const Nlp& nlp = problem.nlp;
  const Eigen::VectorXd w = nlp.w0();
  Eigen::VectorXd values(static_cast<Eigen::Index>(nlp.ResidualJacobianRows().size()));
  ASSERT_TRUE(nlp.ResidualJacobianValues(w.data(), values.data()).ok);
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(nlp.NumResiduals(), nlp.NumVariables());
  for (Eigen::Index k = 0; k < values.size(); ++k) {
    jac(nlp.ResidualJacobianRows()[k], nlp.ResidualJacobianCols()[k]) += values[k];
  }
  // Central differences with step 1e-6 on order-one scaled variables: truncation ~1e-12,
  // round-off ~1e-16 / 1e-6 = 1e-10 relative to the residual magnitude.
  constexpr double kStep = 1e-6, kFdTolerance = 1e-6;
  for (int i = 0; i < nlp.NumVariables(); ++i) {
    Eigen::VectorXd wp = w, wm = w;
    wp[i] += kStep;
    wm[i] -= kStep;
    Eigen::VectorXd rp(nlp.NumResiduals()), rm(nlp.NumResiduals());
    ASSERT_TRUE(nlp.Residuals(wp.data(), rp.data()).ok);
    ASSERT_TRUE(nlp.Residuals(wm.data(), rm.data()).ok);
    const Eigen::VectorXd fd = (rp - rm) / (2 * kStep);
    EXPECT_LT((fd - jac.col(i)).norm(), kFdTolerance * (1.0 + jac.col(i).norm())) << "column " << i;
  }
}

// Noise of 1e-3 on both states, 1500 samples, windows of 50 samples every 10: the estimates lie
// within about 1e-2 relative of the generator's.
constexpr double kRecoveryTolerance = 0.02;

TEST(NStepLoss, CeresAndIpoptRecoverKnownParameters) {
  const Experiment rec = Simulated(1500, 1e-3, kSeed);
  NStepLossOptions options;
  options.steps = 50;
  options.stride = 10;
  options.num_threads = 2;
  const NStepLossProblem problem = BuildNStepLoss(DriveModel(kStart), {rec}, options);
  const SolverResult ceres = SolveWithCeres(problem.nlp);
  ASSERT_TRUE(ceres.success) << ceres.FullReport();
  const Eigen::VectorXd pc = problem.Parameters(ceres.w);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(pc[i] / kTruth[i], 1.0, kRecoveryTolerance) << "parameter " << i;
  }
  const SolverResult ipopt = SolveWithIpopt(problem.nlp);
  ASSERT_TRUE(ipopt.success) << ipopt.FullReport();
  const Eigen::VectorXd pi = problem.Parameters(ipopt.w);
  // Both solve the same least-squares problem to tight tolerances.
  constexpr double kSolversAgree = 1e-5;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(pi[i] / pc[i], 1.0, kSolversAgree) << "parameter " << i;
  // At the optimum the loss is the N-step NRMS of noise-only errors: of the order of the noise
  // over the state's spread, far below the 30 %-off start.
  double start_cost = 0.0;
  ASSERT_TRUE(problem.nlp.Objective(problem.nlp.w0().data(), &start_cost).ok);
  EXPECT_LT(problem.Nrms(ceres.cost), 0.05 * problem.Nrms(start_cost));
}

TEST(NStepLoss, NonFiniteSimulationIsAStatus) {
  const Experiment rec = Simulated(200, 1e-3, kSeed);
  NStepLossOptions options;
  options.steps = 20;
  const NStepLossProblem problem = BuildNStepLoss(DriveModel(kStart), {rec}, options);
  Eigen::VectorXd w = problem.nlp.w0();
  w[0] = 0.0;  // J = 0: qdd = (...) / 0
  double f = 0.0;
  const NlpEvalStatus s = problem.nlp.Objective(w.data(), &f);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("window from sample 0"), std::string::npos) << s.message;
}

TEST(NStepLoss, BadInputNamesThePlace) {
  const Experiment rec = Simulated(100, 1e-3, kSeed);
  const models::StateSpaceModel model = DriveModel(kStart);
  auto message = [&](const NStepLossOptions& options, const Eigen::MatrixXd& states) {
    Experiment ex = rec;
    ex.x = states;
    try {
      BuildNStepLoss(model, {ex}, options);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  NStepLossOptions options;
  options.steps = 100;
  EXPECT_NE(
      message(options, rec.x).find("expected more than first_start + steps = 100 samples, got 100"),
      std::string::npos);
  options.steps = 10;
  options.channels = {2};
  EXPECT_NE(message(options, rec.x).find("expected state indices in [0, 2), got 2"),
            std::string::npos);
  options.channels = {};
  EXPECT_NE(message(options, rec.x.leftCols(1)).find("measured states of N x 2"),
            std::string::npos);
  Eigen::MatrixXd bad = rec.x;
  bad(5, 1) = std::nan("");
  EXPECT_NE(message(options, bad).find("NaN"), std::string::npos);
  options.stride = 0;
  EXPECT_NE(message(options, rec.x).find("stride: expected >= 1, got 0"), std::string::npos);
}

}  // namespace
}  // namespace graybox::estimators
