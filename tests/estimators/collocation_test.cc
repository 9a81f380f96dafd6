// Collocation: the points are right, and collocation agrees with multiple shooting.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "graybox/estimators/formulations/collocation.h"
#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/solvers/solvers.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

using models::BlockArgs;
using models::BlockBase;

constexpr unsigned kSeed = 17;

TEST(Collocation, PointsMatchTheKnownValues) {
  constexpr double kRootTolerance = 1e-12;  // companion-matrix roots of a degree <= 3 polynomial
  const Eigen::VectorXd radau3 = CollocationPoints(CollocationScheme::kRadau, 3);
  EXPECT_NEAR(radau3[0], (4.0 - std::sqrt(6.0)) / 10.0, kRootTolerance);
  EXPECT_NEAR(radau3[1], (4.0 + std::sqrt(6.0)) / 10.0, kRootTolerance);
  EXPECT_EQ(radau3[2], 1.0);
  const Eigen::VectorXd gauss2 = CollocationPoints(CollocationScheme::kLegendre, 2);
  EXPECT_NEAR(gauss2[0], 0.5 - std::sqrt(3.0) / 6.0, kRootTolerance);
  EXPECT_NEAR(gauss2[1], 0.5 + std::sqrt(3.0) / 6.0, kRootTolerance);
  EXPECT_EQ(CollocationPoints(CollocationScheme::kRadau, 1)[0], 1.0);  // implicit Euler
  EXPECT_THROW(CollocationPoints(CollocationScheme::kRadau, 0), std::invalid_argument);
}

// A damped oscillator with a cubic spring: q'' = (u - c q' - k q - k3 q^3) / m.
class Oscillator : public BlockBase<Oscillator> {
 public:
  Oscillator() {
    info_.type = "test.oscillator";
    info_.description = "Duffing oscillator";
    info_.reference = "test";
    info_.inputs = {{"u", "N", "force", -1, 1}};
    info_.states = {{"q", "m", "position", -1, 1}, {"qd", "m/s", "velocity", -1, 1}};
    info_.parameters = {{"c", "N s/m", "damping", 0.4, 0.0, 10.0},
                        {"k", "N/m", "stiffness", 4.0, 0.1, 100.0},
                        {"k3", "N/m^3", "cubic stiffness", 1.0, -10.0, 10.0}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    a.xdot[0] = a.x[1];
    a.xdot[1] = a.u[0] - a.p[0] * a.x[1] - a.p[1] * a.x[0] - a.p[2] * a.x[0] * a.x[0] * a.x[0];
  }
};

TEST(Collocation, AgreesWithMultipleShooting) {
  models::Model m("osc");
  m.AddInput("u", "N");
  m.AddBlock("osc", std::make_shared<Oscillator>(), {"u"}, {});
  m.AddOutput("osc.q");
  const models::StateSpaceModel truth = m.Build();
  const Eigen::Vector3d p_true(0.4, 4.0, 1.0);
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  Experiment ex;
  ex.name = "osc";
  ex.dt = 0.02;
  const int n = 600;
  ex.u.resize(n, 1);
  for (int k = 0; k < n; ++k)
    ex.u(k, 0) = 2.0 * std::sin(0.9 * k * ex.dt) + std::sin(3.1 * k * ex.dt);
  ExperimentSetup setup;
  setup.x0 = Eigen::Vector2d(0.2, 0.0);
  ex.y = SimulateRk4(truth, setup.x0, ex.u, p_true, ex.dt, 4).y;
  for (int k = 0; k < n; ++k) ex.y(k, 0) += 1e-3 * g(rng);
  models::StateSpaceModel start = truth;
  start.parameters[0].value = 0.6;
  start.parameters[1].value = 3.0;
  start.parameters[2].value = 0.5;
  const CollocationProblem col = BuildCollocation(start, {ex}, {setup});
  const SolverResult rc = SolveWithIpopt(col.nlp);
  ASSERT_TRUE(rc.success) << rc.FullReport();
  MultipleShootingOptions ms_options;
  ms_options.segment_length = 10;
  ms_options.step.substeps = 4;
  const ShootingProblem ms = BuildMultipleShooting(start, {ex}, {setup}, ms_options);
  const SolverResult rm = SolveWithIpopt(ms.nlp);
  ASSERT_TRUE(rm.success) << rm.FullReport();
  const Eigen::VectorXd pc = col.Parameters(rc.w), pm = ms.Parameters(rm.w);
  // Radau-3 (order 5) and RK4 with 4 substeps (order 4) discretise the same ODE at dt = 0.02 s;
  // their estimates differ by discretisation error far below the noise-induced spread (~1e-3).
  constexpr double kDiscretisationAgreement = 1e-3;
  constexpr double kRecovery = 0.02;  // noise 1e-3 on 600 samples
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(pc[i], pm[i], kDiscretisationAgreement * std::fabs(pm[i])) << i;
    EXPECT_NEAR(pc[i], p_true[i], kRecovery * p_true[i]) << i;
  }
}

// A stiff model without a state guess: the initial states come from the L-stable Radau IIA map
// (4 substeps of 0.1 s, 2 Newton iterations), where RK4 at the same step overflows. Robertson's
// kinetics from t = 0.01 s (after the initial layer, state from CVODES), sampled every 0.4 s; the
// guess at t = 20 s agrees with CVODES to the scheme's accuracy (order 3 at h = 0.1 s: ~1e-4).
TEST(Collocation, StiffModelsAreInitialisedByAnImplicitScheme) {
  const models::StateSpaceModel model = testing::RobertsonModel();
  const Eigen::VectorXd p = model.ParameterValues();
  IntegratorOptions cvodes;
  cvodes.method = IntegrationMethod::kCvodes;
  cvodes.cvodes = testing::RobertsonOptions(1e-10);
  const Eigen::VectorXd start =
      MakeIntegrator(model, 0.01, cvodes)
          ->Simulate(Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::MatrixXd(2, 0), p)
          .x.row(1)
          .transpose();
  const int n = 51;
  Experiment ex;
  ex.name = "robertson";
  ex.dt = 0.4;
  ex.u = Eigen::MatrixXd(n, 0);
  ExperimentSetup setup;
  setup.x0 = start;
  const Trajectory reference = MakeIntegrator(model, ex.dt, cvodes)->Simulate(start, ex.u, p);
  ex.y = reference.y;
  EXPECT_FALSE(SimulateRk4(model, start, ex.u, p, ex.dt, 4).x.allFinite());
  CollocationOptions options;
  options.degree = 2;
  const CollocationProblem problem = BuildCollocation(model, {ex}, {setup}, options);
  const Eigen::VectorXd w0 = problem.nlp.w0();
  ASSERT_TRUE(w0.allFinite());
  constexpr double kGuessAccuracy = 1e-3;  // relative to each species' value at t = 20 s
  for (int i : {0, 2}) {
    const double guess = w0[problem.state_variables[0](n - 1, i)];
    EXPECT_NEAR(guess, reference.x(n - 1, i), kGuessAccuracy * std::fabs(reference.x(n - 1, i)))
        << "species " << i;
  }
}

}  // namespace
}  // namespace graybox::estimators
