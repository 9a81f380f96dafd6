// Single shooting through an Integrator (single_shooting.h) and the Nlp residual blocks it is
// built on: derivatives against finite differences, recovery of known parameters with RK4 and
// CVODES, agreement with the symbolically unrolled single shooting and between Ceres and Ipopt,
// and failed simulations returned as statuses.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/formulations/single_shooting.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/solvers/solvers.h"
#include "graybox/models/model.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

constexpr unsigned kSeed = 23;
constexpr double kDt = 0.01;
constexpr int kSamples = 600;
constexpr double kNoise = 1e-3;  // rad

const Eigen::Vector4d kTruth(0.8, 0.45, 0.35, 3.0);

// test_models.h's FrictionDrive on a spring: J qdd = tau - fv qd - fc tanh(qd / 0.05) - k q.
models::StateSpaceModel SpringModel() {
  testing::FrictionDriveOptions options;
  options.spring = true;
  return testing::FrictionDriveModel(options);
}

models::StateSpaceModel PerturbedModel() {
  models::StateSpaceModel model = SpringModel();
  for (int i = 0; i < 4; ++i) model.parameters[i].value = kTruth[i] * (i % 2 ? 0.7 : 1.3);
  return model;
}

/// The initial state of the simulated experiments.
ExperimentSetup SimulatedSetup() {
  ExperimentSetup setup;
  setup.x0 = Eigen::Vector2d(0.1, 0.0);
  return setup;
}

Experiment Simulated(unsigned seed) {
  Experiment ex;
  ex.name = "sim";
  ex.dt = kDt;
  ex.u = testing::DriveTorque(kSamples, kDt);
  ex.y = SimulateRk4(SpringModel(), SimulatedSetup().x0, ex.u, kTruth, kDt, 4).y;
  std::mt19937 rng(seed);
  std::normal_distribution<double> eps(0.0, kNoise);
  for (int k = 0; k < kSamples; ++k) ex.y(k, 0) += eps(rng);
  return ex;
}

// Noise of 1e-3 rad on 600 samples of a ~0.3 rad response: estimates within ~1 %.
constexpr double kRecoveryTolerance = 0.02;

TEST(SingleShooting, ResidualBlockDerivativesMatchFiniteDifferences) {
  SingleShootingOptions options;
  options.fix_initial_state = false;
  options.integrator.fixed_step.substeps = 2;
  const ShootingProblem problem =
      BuildSingleShooting(PerturbedModel(), {Simulated(kSeed)}, {SimulatedSetup()}, options);
  const Nlp& nlp = problem.nlp;
  ASSERT_EQ(nlp.NumVariables(), 6);
  ASSERT_EQ(nlp.NumResiduals(), kSamples);
  const Eigen::VectorXd w = nlp.w0();
  Eigen::VectorXd r(nlp.NumResiduals()), grad(6);
  std::vector<double> jac(nlp.ResidualJacobianRows().size());
  ASSERT_TRUE(nlp.ResidualJacobianValues(w.data(), jac.data()).ok);
  ASSERT_TRUE(nlp.Gradient(w.data(), grad.data()).ok);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(nlp.NumResiduals(), 6);
  for (std::size_t e = 0; e < jac.size(); ++e) {
    dense(nlp.ResidualJacobianRows()[e], nlp.ResidualJacobianCols()[e]) += jac[e];
  }
  // Central differences with step h on O(1) scaled variables: truncation O(h^2 |r'''|) ~ 1e-10
  // against Jacobian entries of O(1).
  constexpr double kStep = 1e-5, kTolerance = 1e-6;
  for (int i = 0; i < 6; ++i) {
    Eigen::VectorXd wp = w, wm = w, rp(r.size()), rm(r.size());
    wp[i] += kStep;
    wm[i] -= kStep;
    ASSERT_TRUE(nlp.Residuals(wp.data(), rp.data()).ok);
    ASSERT_TRUE(nlp.Residuals(wm.data(), rm.data()).ok);
    const Eigen::VectorXd fd = (rp - rm) / (2.0 * kStep);
    const double scale = std::max(1.0, fd.cwiseAbs().maxCoeff());
    EXPECT_LT((dense.col(i) - fd).cwiseAbs().maxCoeff(), kTolerance * scale) << "variable " << i;
    double fp = 0.0, fm = 0.0;
    ASSERT_TRUE(nlp.Objective(wp.data(), &fp).ok);
    ASSERT_TRUE(nlp.Objective(wm.data(), &fm).ok);
    EXPECT_NEAR(grad[i], (fp - fm) / (2.0 * kStep), kTolerance * std::max(1.0, std::abs(grad[i])))
        << "variable " << i;
  }
  // The Gauss-Newton Hessian J^T J, lower triangle, scaled by sigma.
  std::vector<double> hess(nlp.HessianRows().size());
  const Eigen::VectorXd no_lambda;
  ASSERT_TRUE(nlp.HessianValues(w.data(), 2.0, no_lambda.data(), hess.data()).ok);
  const Eigen::MatrixXd gn = 2.0 * dense.transpose() * dense;
  for (std::size_t e = 0; e < hess.size(); ++e) {
    const int a = nlp.HessianRows()[e], b = nlp.HessianCols()[e];
    EXPECT_GE(a, b);
    EXPECT_NEAR(hess[e], gn(a, b), 1e-9 * gn.cwiseAbs().maxCoeff());
  }
}

TEST(SingleShooting, CeresAndIpoptRecoverTheParametersAndAgree) {
  const std::vector<Experiment> data = {Simulated(kSeed)};
  const std::vector<ExperimentSetup> setups = {SimulatedSetup()};
  SingleShootingOptions options;
  options.integrator.fixed_step.substeps = 4;
  const ShootingProblem problem = BuildSingleShooting(PerturbedModel(), data, setups, options);
  const SolverResult ceres = SolveWithCeres(problem.nlp);
  const SolverResult ipopt = SolveWithIpopt(problem.nlp);
  ASSERT_TRUE(ceres.success) << ceres.FullReport();
  ASSERT_TRUE(ipopt.success) << ipopt.FullReport();
  const Eigen::VectorXd pc = problem.Parameters(ceres.w);
  const Eigen::VectorXd pi = problem.Parameters(ipopt.w);
  // The same least-squares optimum reached by two solvers, each to its tolerances.
  constexpr double kSolverAgreement = 1e-5;
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(pc[i] / kTruth[i], 1.0, kRecoveryTolerance) << "parameter " << i;
    EXPECT_NEAR(pi[i], pc[i], kSolverAgreement * std::abs(pc[i])) << "parameter " << i;
  }
}

TEST(SingleShooting, EqualsTheUnrolledSingleShooting) {
  // 150 samples: the unrolled graph (and its exact Hessian) grows with the record.
  constexpr int kShort = 150;
  Experiment shortened = Simulated(kSeed + 1);
  shortened.u.conservativeResize(kShort, Eigen::NoChange);
  shortened.y.conservativeResize(kShort, Eigen::NoChange);
  const std::vector<Experiment> data = {shortened};
  const std::vector<ExperimentSetup> setups = {SimulatedSetup()};
  SingleShootingOptions options;
  options.integrator.fixed_step.substeps = 2;
  const ShootingProblem by_integrator =
      BuildSingleShooting(PerturbedModel(), data, setups, options);
  MultipleShootingOptions unrolled;
  unrolled.segment_length = kShort;
  unrolled.step.substeps = 2;
  unrolled.fix_initial_state = true;
  const ShootingProblem symbolic = BuildMultipleShooting(PerturbedModel(), data, setups, unrolled);
  // Same variables, same objective at the start (the same RK4 map evaluated two ways).
  ASSERT_EQ(by_integrator.nlp.NumVariables(), symbolic.nlp.NumVariables());
  double f1 = 0.0, f2 = 0.0;
  ASSERT_TRUE(by_integrator.nlp.Objective(by_integrator.nlp.w0().data(), &f1).ok);
  ASSERT_TRUE(symbolic.nlp.Objective(symbolic.nlp.w0().data(), &f2).ok);
  EXPECT_NEAR(f1, f2, 1e-10 * f2);
  const SolverResult a = SolveWithCeres(by_integrator.nlp);
  const SolverResult b = SolveWithCeres(symbolic.nlp);
  ASSERT_TRUE(a.success && b.success) << a.FullReport() << b.FullReport();
  constexpr double kSameOptimum = 1e-6;
  const Eigen::VectorXd pa = by_integrator.Parameters(a.w), pb = symbolic.Parameters(b.w);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(pa[i], pb[i], kSameOptimum * std::abs(pb[i]));
}

TEST(SingleShooting, CvodesRecoversTheParametersWithFreeInitialState) {
  const std::vector<Experiment> data = {Simulated(kSeed + 2)};
  const std::vector<ExperimentSetup> setups = {SimulatedSetup()};
  SingleShootingOptions options;
  options.integrator.method = IntegrationMethod::kCvodes;
  options.integrator.cvodes.relative_tolerance = 1e-9;
  options.integrator.cvodes.absolute_tolerance = 1e-11;
  options.fix_initial_state = false;
  const ShootingProblem problem = BuildSingleShooting(PerturbedModel(), data, setups, options);
  const SolverResult r = SolveWithCeres(problem.nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  const Eigen::VectorXd p = problem.Parameters(r.w);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(p[i] / kTruth[i], 1.0, kRecoveryTolerance) << "parameter " << i;
  }
  // x0 = (0.1, 0) recovered to the noise level.
  const Eigen::VectorXd x0 = problem.InitialState(r.w, 0);
  EXPECT_NEAR(x0[0], 0.1, 5.0 * kNoise);
}

TEST(SingleShooting, FailedSimulationIsAStatusNotACrash) {
  SingleShootingOptions options;
  const ShootingProblem problem =
      BuildSingleShooting(PerturbedModel(), {Simulated(kSeed)}, {SimulatedSetup()}, options);
  Eigen::VectorXd w = problem.nlp.w0();
  w[0] = 0.0;  // J = 0: division by zero in the dynamics
  double f = 0.0;
  const NlpEvalStatus s = problem.nlp.Objective(w.data(), &f);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("residual block 'simulation_sim'"), std::string::npos) << s.message;
  // The cache must not hand the failure out at a different point.
  EXPECT_TRUE(problem.nlp.Objective(problem.nlp.w0().data(), &f).ok);
}

TEST(SingleShooting, BadInputIsRejectedWithItsPlace) {
  Experiment ex = Simulated(kSeed);
  ex.name = "broken";
  ex.y.conservativeResize(ex.y.rows() - 1, Eigen::NoChange);
  try {
    BuildSingleShooting(SpringModel(), {ex}, {SimulatedSetup()});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("experiment 'broken'"), std::string::npos) << e.what();
  }
  SingleShootingOptions options;
  options.output_weights = Eigen::VectorXd::Ones(3);
  EXPECT_THROW(BuildSingleShooting(SpringModel(), {Simulated(kSeed)}, {SimulatedSetup()}, options),
               std::invalid_argument);
}

}  // namespace
}  // namespace graybox::estimators
