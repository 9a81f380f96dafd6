// The finite-difference check of an assembled Nlp: a correct multiple-shooting problem passes
// every check (residuals, constraints, gradient, Hessian of the Lagrangian); a residual block with
// a wrong Jacobian column fails at exactly that column; a wrong size is rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/nlp/nlp_check.h"
#include "graybox/models/model.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

constexpr double kDt = 0.02;

// test_models.h's FrictionDrive on a spring, J qdd = tau - fv qd - fc tanh(qd / 0.05) - k q, at
// J = 0.8, fv = 0.4, fc = 0.3, k = 2: the data's parameters.
models::StateSpaceModel DriveModel() {
  testing::FrictionDriveOptions options;
  options.spring = true;
  options.inertia = 0.8;
  options.viscous = 0.4;
  options.coulomb = 0.3;
  options.stiffness = 2.0;
  return testing::FrictionDriveModel(options);
}

/// The initial state of the simulated experiment.
ExperimentSetup SimulatedSetup() {
  ExperimentSetup setup;
  setup.x0 = Eigen::Vector2d(0.05, 0.0);
  return setup;
}

Experiment SimulatedExperiment(const models::StateSpaceModel& model) {
  Experiment ex;
  ex.name = "sim";
  ex.dt = kDt;
  const int n = 200;
  ex.u.resize(n, 1);
  for (int k = 0; k < n; ++k) ex.u(k, 0) = std::sin(1.3 * k * kDt) + 0.5 * std::sin(4.1 * k * kDt);
  ex.y = MakeIntegrator(model, kDt)->Simulate(SimulatedSetup().x0, ex.u, model.ParameterValues()).y;
  return ex;
}

TEST(NlpCheck, CorrectMultipleShootingPassesEveryCheck) {
  const models::StateSpaceModel model = DriveModel();
  MultipleShootingOptions options;
  options.segment_length = 10;
  const ShootingProblem p =
      BuildMultipleShooting(model, {SimulatedExperiment(model)}, {SimulatedSetup()}, options);
  Eigen::VectorXd w = p.nlp.w0();
  w.head(4) *= 1.1;  // away from the data's parameters: nonzero residuals and constraints
  const auto results = CheckNlpDerivatives(p.nlp, w);
  ASSERT_EQ(results.size(), 4u);  // residuals, constraints, gradient, Hessian of the Lagrangian
  for (const auto& r : results) {
    EXPECT_TRUE(r.ok) << r.FullReport();
    EXPECT_GT(r.entries_checked, 0) << r.what;
  }
}

// A residual block r = (z0^2, z0 z1) whose Jacobian is wrong in column 1 (d r1 / d z1 given as
// 2 z0 instead of z0).
class WrongBlock final : public ResidualBlock {
 public:
  int NumResiduals() const override { return 2; }
  NlpEvalStatus Evaluate(const Eigen::VectorXd& z, Eigen::VectorXd* r,
                         Eigen::MatrixXd* jacobian) const override {
    *r = Eigen::Vector2d(z[0] * z[0], z[0] * z[1]);
    if (jacobian != nullptr) {
      jacobian->resize(2, 2);
      *jacobian << 2 * z[0], 0.0, z[1], 2 * z[0];
    }
    return {};
  }
};

TEST(NlpCheck, WrongJacobianColumnFailsAtThatColumn) {
  Nlp nlp(Eigen::Vector2d(1.5, -0.7), Eigen::Vector2d::Constant(-10),
          Eigen::Vector2d::Constant(10));
  nlp.AddResidualBlock("wrong", {0, 1}, std::make_shared<WrongBlock>());
  const auto results = CheckNlpDerivatives(nlp, nlp.w0());
  ASSERT_EQ(results.size(), 2u);  // residuals and gradient; no Hessian check for residual blocks
  EXPECT_FALSE(results[0].ok);
  ASSERT_FALSE(results[0].worst.empty());
  EXPECT_EQ(results[0].worst[0].row, 1);
  EXPECT_EQ(results[0].worst[0].col, 1);
  EXPECT_NEAR(results[0].worst[0].finite_difference, 1.5, 1e-8);
  EXPECT_FALSE(results[1].ok);  // the gradient J^T r inherits the error
  EXPECT_THROW(CheckNlpDerivatives(nlp, Eigen::VectorXd::Zero(3)), std::invalid_argument);
}

}  // namespace
}  // namespace graybox::estimators
