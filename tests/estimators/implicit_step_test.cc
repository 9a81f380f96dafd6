// The implicit fixed-step schemes (integrators.h): each one-step map applies its stability
// function exactly on the linear test equation (real and complex z, stiff z = -1e6); observed
// orders 1, 2, 3 on a nonlinear pendulum; derivatives of the step Function against central
// differences; a stiff model (Robertson's kinetics) at the sample time against CVODES where RK4
// fails; FixedStepIntegrator sensitivities against differences of the map; N-step simulation
// honours the scheme; multiple shooting with Radau IIA recovers the parameters of a stiff drive
// from noisy data; options and names.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "graybox/estimators/analysis/covariance.h"
#include "graybox/estimators/analysis/metrics.h"
#include "graybox/estimators/analysis/n_step.h"
#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/integrators/cvodes_integrator.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/solvers/solvers.h"
#include "graybox/expr/derivative_check.h"
#include "graybox/models/model.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

using models::BlockArgs;
using models::BlockBase;
using testing::RobertsonModel;
using testing::RobertsonOptions;

// The seed of every random draw; override with GRAYBOX_SEED.
unsigned Seed() {
  const char* env = std::getenv("GRAYBOX_SEED");
  const unsigned seed = env ? static_cast<unsigned>(std::strtoul(env, nullptr, 10)) : 7u;
  std::cout << "[ seed ] GRAYBOX_SEED=" << seed << "\n";
  return seed;
}

constexpr StepScheme kImplicitSchemes[] = {StepScheme::kBackwardEuler, StepScheme::kTrapezoidal,
                                           StepScheme::kRadauIIA};

FixedStepOptions Scheme(StepScheme scheme, int substeps = 1, int newton_iterations = 4) {
  FixedStepOptions o;
  o.scheme = scheme;
  o.substeps = substeps;
  o.newton_iterations = newton_iterations;
  return o;
}

// Largest |a - b| relative to the largest |b| of each column, maximised over the columns.
double ScaledError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  double worst = 0.0;
  for (Eigen::Index j = 0; j < b.cols(); ++j) {
    const double scale = std::max(b.col(j).cwiseAbs().maxCoeff(), 1e-300);
    worst = std::max(worst, (a.col(j) - b.col(j)).cwiseAbs().maxCoeff() / scale);
  }
  return worst;
}

// ---- test models ------------------------------------------------------------------------------

// x' = A x with A = [[a, -w], [w, a]]: the test equation x' = lambda x for lambda = a + i w in
// real form (x1 + i x2). One step of size h from x = (1, 0) gives (Re R(z), Im R(z)), z = h lambda.
class ComplexLinear : public BlockBase<ComplexLinear> {
 public:
  ComplexLinear() {
    info_.type = "test.complex_linear";
    info_.description = "the linear test equation in real form";
    info_.reference = "test";
    info_.states = {{"x1", "1", "real part", -1, 1}, {"x2", "1", "imaginary part", -1, 1}};
    info_.parameters = {{"a", "1/s", "real part of lambda", -1.0, -1e9, 1e9},
                        {"w", "1/s", "imaginary part of lambda", 0.0, -1e9, 1e9}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    a.xdot[0] = a.p[0] * a.x[0] - a.p[1] * a.x[1];
    a.xdot[1] = a.p[1] * a.x[0] + a.p[0] * a.x[1];
  }
};

models::StateSpaceModel ComplexLinearModel() {
  models::Model m("linear");
  m.AddBlock("lin", std::make_shared<ComplexLinear>(), {}, {});
  m.AddOutput("lin.x1");
  m.AddOutput("lin.x2");
  return m.Build();
}

// A damped pendulum driven by a torque: theta'' = u - c theta' - g sin(theta) (non-stiff).
class Pendulum : public BlockBase<Pendulum> {
 public:
  Pendulum() {
    info_.type = "test.pendulum";
    info_.description = "damped driven pendulum";
    info_.reference = "test";
    info_.inputs = {{"u", "1/s^2", "torque over inertia", -1, 1}};
    info_.states = {{"theta", "rad", "angle", -1, 1}, {"omega", "rad/s", "speed", -1, 1}};
    info_.parameters = {{"c", "1/s", "damping", 0.3, 0.0, 10.0},
                        {"g", "1/s^2", "gravity over length", 9.81, 0.1, 100.0}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    using std::sin;
    a.xdot[0] = a.x[1];
    a.xdot[1] = a.u[0] - a.p[0] * a.x[1] - a.p[1] * sin(a.x[0]);
  }
};

models::StateSpaceModel PendulumModel() {
  models::Model m("pendulum");
  m.AddInput("u", "1/s^2");
  m.AddBlock("pend", std::make_shared<Pendulum>(), {"u"}, {});
  m.AddOutput("pend.theta");
  return m.Build();
}

// A drive behind a fast actuator: the actuator force f follows the command u with a time constant
// 1 / a = 2.5 ms (a stiff mode: at dt = 10 ms, h a = 4 is beyond RK4's stability limit 2.785),
// and moves a load with stiffness, viscous and smoothed Coulomb friction:
//     f' = a (u - f),   q' = v,   v' = g f - c v - k q - fc tanh(v / 0.1).
class StiffDrive : public BlockBase<StiffDrive> {
 public:
  StiffDrive() {
    info_.type = "test.stiff_drive";
    info_.description = "load behind a fast actuator lag";
    info_.reference = "test";
    info_.inputs = {{"u", "1", "command", -1, 1}};
    info_.states = {{"f", "1", "actuator force", -1, 1},
                    {"q", "m", "position", -1, 1},
                    {"v", "m/s", "speed", -1, 1}};
    info_.parameters = {{"a", "1/s", "actuator bandwidth", 400.0, 1.0, 1e4},
                        {"g", "1/s^2", "actuator gain", 20.0, 0.1, 1000.0},
                        {"c", "1/s", "viscous friction", 2.0, 0.0, 100.0},
                        {"k", "1/s^2", "stiffness", 40.0, 0.0, 1000.0},
                        {"fc", "m/s^2", "Coulomb friction", 1.5, 0.0, 100.0}};
    info_.stiff = true;
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    using std::tanh;
    a.xdot[0] = a.p[0] * (a.u[0] - a.x[0]);
    a.xdot[1] = a.x[2];
    a.xdot[2] = a.p[1] * a.x[0] - a.p[2] * a.x[2] - a.p[3] * a.x[1] - a.p[4] * tanh(a.x[2] / 0.1);
  }
};

models::StateSpaceModel StiffDriveModel() {
  models::Model m("stiff_drive");
  m.AddInput("u", "1");
  m.AddBlock("drive", std::make_shared<StiffDrive>(), {"u"}, {});
  m.AddOutput("drive.q");
  return m.Build();
}

// A multisine command that changes at every sample.
Eigen::MatrixXd Multisine(int n, double dt) {
  Eigen::MatrixXd u(n, 1);
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    u(k, 0) = 0.8 * std::sin(1.7 * t) + 0.5 * std::sin(4.9 * t + 0.3) + 0.3 * std::sin(11.3 * t);
  }
  return u;
}

// ---- (a) stability functions on the linear test equation -------------------------------------

std::complex<double> StabilityFunction(StepScheme scheme, std::complex<double> z) {
  switch (scheme) {
    case StepScheme::kRk4:
      return 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0;
    case StepScheme::kBackwardEuler:
      return 1.0 / (1.0 - z);
    case StepScheme::kTrapezoidal:
      return (1.0 + z / 2.0) / (1.0 - z / 2.0);
    case StepScheme::kRadauIIA:
      return (1.0 + z / 3.0) / (1.0 - 2.0 * z / 3.0 + z * z / 6.0);
  }
  return 0.0;
}

// One Newton iteration solves the stage equations of a linear model exactly, so the map is R(z)
// up to rounding: a few eps of the intermediate values. Backward Euler and Radau IIA start the
// iteration from K = 0, so their intermediates are O(|R|) and no O(|z|) quantity cancels.
constexpr double kStabilityFunctionTolerance = 1e-12;
// Trapezoidal's first stage is explicit, h K1 = z x, so x + h/2 (K1 + K2) cancels O(|z|) terms:
// its rounding is a few eps |z| (measured 3.8e-11 at z = -1e6).
constexpr double kExplicitStageRounding = 1e3 * 2.2e-16;

double StabilityTolerance(StepScheme scheme, std::complex<double> z, std::complex<double> r) {
  return kStabilityFunctionTolerance * std::max(1.0, std::abs(r)) +
         (scheme == StepScheme::kTrapezoidal ? kExplicitStageRounding * std::abs(z) : 0.0);
}

TEST(ImplicitStep, LinearTestEquationGivesTheStabilityFunctionExactly) {
  const models::StateSpaceModel model = ComplexLinearModel();
  const std::vector<std::complex<double>> zs = {{-0.1, 0.0},  {-1.0, 0.0}, {-2.5, 0.0},
                                                {-50.0, 0.0}, {-1e6, 0.0}, {-1.0, 10.0},
                                                {-1e3, 1e3},  {0.5, 0.0},  {0.0, 2.0}};
  const double dt = 0.1;  // z = dt lambda
  for (StepScheme scheme : kImplicitSchemes) {
    for (int iterations : {1, 4}) {
      const expr::Function step = MakeStepFunction(model, dt, Scheme(scheme, 1, iterations));
      for (const std::complex<double> z : zs) {
        const Eigen::Vector2d p(z.real() / dt, z.imag() / dt);
        const Eigen::VectorXd x = step({Eigen::Vector2d(1.0, 0.0), Eigen::VectorXd(), p})[0];
        const std::complex<double> r = StabilityFunction(scheme, z);
        const double tolerance = StabilityTolerance(scheme, z, r);
        EXPECT_NEAR(x[0], r.real(), tolerance)
            << StepSchemeName(scheme) << " z = " << z << ", " << iterations << " iterations";
        EXPECT_NEAR(x[1], r.imag(), tolerance)
            << StepSchemeName(scheme) << " z = " << z << ", " << iterations << " iterations";
      }
    }
  }
  // What that means for the stiffest mode, z = -1e6: backward Euler and Radau IIA (L-stable)
  // damp it to 1 / |z| and 2 / |z|, trapezoidal (A-stable only) keeps modulus ~1, and RK4
  // amplifies it by z^4 / 24 ~ 4e22.
  const double z_stiff = -1e6;
  auto one_step = [&](const FixedStepOptions& o) {
    return MakeStepFunction(model, dt, o)(
        {Eigen::Vector2d(1.0, 0.0), Eigen::VectorXd(), Eigen::Vector2d(z_stiff / dt, 0.0)})[0][0];
  };
  EXPECT_LT(std::fabs(one_step(Scheme(StepScheme::kBackwardEuler))), 1.0 / std::fabs(z_stiff));
  EXPECT_LT(std::fabs(one_step(Scheme(StepScheme::kRadauIIA))), 2.0 / std::fabs(z_stiff));
  EXPECT_GT(std::fabs(one_step(Scheme(StepScheme::kTrapezoidal))), 0.99);
  EXPECT_GT(std::fabs(one_step(Scheme(StepScheme::kRk4))), 1e22);
  // Substeps compose: n steps of z / n give R(z / n)^n.
  const std::complex<double> z(-3.0, 4.0);
  for (StepScheme scheme : kImplicitSchemes) {
    const Eigen::VectorXd x = MakeStepFunction(
        model, dt, Scheme(scheme, 3))({Eigen::Vector2d(1.0, 0.0), Eigen::VectorXd(),
                                       Eigen::Vector2d(z.real(), z.imag()) / dt})[0];
    const std::complex<double> r = std::pow(StabilityFunction(scheme, z / 3.0), 3);
    EXPECT_NEAR(x[0], r.real(), StabilityTolerance(scheme, z, r)) << StepSchemeName(scheme);
    EXPECT_NEAR(x[1], r.imag(), StabilityTolerance(scheme, z, r)) << StepSchemeName(scheme);
  }
}

// ---- (b) order of convergence on a nonlinear, non-stiff model --------------------------------

// Error of the whole trajectory against a reference, halving h four times: the observed order
// log2(e(h) / e(h / 2)) approaches the scheme's order as h -> 0; at these steps (h omega from 0.3
// down to 0.02) the next term of the error expansion still moves it by up to ~0.1 (measured over
// the last two halvings: backward Euler 0.90, 0.95; trapezoidal 2.00, 2.00; Radau IIA 2.99, 3.00).
constexpr double kOrderTolerance = 0.3;

TEST(ImplicitStep, ObservedOrdersAreOneTwoAndThree) {
  const models::StateSpaceModel model = PendulumModel();
  const double dt = 0.1;
  const int n = 31;  // 3 s, more than one period of the swing
  const Eigen::MatrixXd u = Multisine(n, dt);
  const Eigen::Vector2d x0(1.2, 0.0);  // large swing: sin(theta) is far from linear
  const Eigen::VectorXd p = model.ParameterValues();
  // RK4 with h = 1e-4: global error ~ (h omega)^4 ~ 1e-13, far below the errors measured here.
  const Trajectory reference = SimulateRk4(model, x0, u, p, dt, 1000);
  ASSERT_TRUE(reference.ok);
  const std::vector<std::pair<StepScheme, double>> orders = {{StepScheme::kBackwardEuler, 1.0},
                                                             {StepScheme::kTrapezoidal, 2.0},
                                                             {StepScheme::kRadauIIA, 3.0}};
  for (const auto& [scheme, order] : orders) {
    std::vector<double> errors;
    for (int substeps : {1, 2, 4, 8, 16}) {
      const Trajectory t = SimulateFixedStep(model, x0, u, p, dt, Scheme(scheme, substeps));
      ASSERT_TRUE(t.ok) << t.summary.BriefReport();
      errors.push_back((t.x - reference.x).cwiseAbs().maxCoeff());
    }
    std::cout << StepSchemeName(scheme) << ": errors";
    for (double e : errors) std::cout << " " << e;
    std::cout << "; observed orders";
    for (std::size_t i = 1; i < errors.size(); ++i) {
      std::cout << " " << std::log2(errors[i - 1] / errors[i]);
    }
    std::cout << "\n";
    // The last two halvings are in the asymptotic range.
    for (std::size_t i = errors.size() - 2; i < errors.size(); ++i) {
      EXPECT_NEAR(std::log2(errors[i - 1] / errors[i]), order, kOrderTolerance)
          << StepSchemeName(scheme) << " from " << (1 << (i - 1)) << " to " << (1 << i)
          << " substeps";
    }
  }
}

// ---- (c) derivatives of the step Function ---------------------------------------------------

TEST(ImplicitStep, StepDerivativesMatchCentralDifferences) {
  const models::StateSpaceModel pendulum = PendulumModel();
  const models::StateSpaceModel drive = StiffDriveModel();
  double worst = 0.0;
  for (StepScheme scheme : kImplicitSchemes) {
    for (int iterations : {1, 4}) {
      const FixedStepOptions o = Scheme(scheme, 2, iterations);
      const expr::Function a = MakeStepFunction(pendulum, 0.1, o);
      const std::vector<Eigen::VectorXd> pa = {Eigen::Vector2d(1.1, -0.7),
                                               Eigen::VectorXd::Constant(1, 0.4),
                                               pendulum.ParameterValues()};
      const expr::Function b = MakeStepFunction(drive, 0.01, o);
      const std::vector<Eigen::VectorXd> pb = {Eigen::Vector3d(0.3, -0.2, 0.15),
                                               Eigen::VectorXd::Constant(1, -0.5),
                                               drive.ParameterValues()};
      for (const char* in : {"x", "u", "p"}) {
        for (const auto& [f, point] : {std::make_pair(&a, &pa), std::make_pair(&b, &pb)}) {
          const expr::DerivativeCheckResult r = expr::CheckJacobian(*f, "x_next", in, *point);
          EXPECT_TRUE(r.ok) << StepSchemeName(scheme) << ", " << iterations << " iterations, "
                            << f->name() << " d/d" << in << ": " << r.FullReport();
          worst = std::max(worst, r.max_error);
        }
      }
    }
  }
  std::cout << "largest Jacobian check error " << worst << "\n";
  // The Hessian that Ipopt's exact Newton steps use (multiple shooting): of a scalar combination
  // of the Radau IIA step, so third derivatives of f are involved.
  const expr::Function step = MakeStepFunction(drive, 0.01, Scheme(StepScheme::kRadauIIA));
  const std::vector<expr::Expr> x = expr::Expr::Symbols("x", 3), u = expr::Expr::Symbols("u", 1),
                                p = expr::Expr::Symbols("p", 5);
  const std::vector<expr::Expr> next = step.Call({x, u, p})[0];
  const expr::Function scalar("scalar", {{"x", x}, {"u", u}, {"p", p}},
                              {{"s", {next[0] * next[1] + next[2] * next[2] - 0.3 * next[1]}}});
  for (const char* in : {"x", "p"}) {
    const expr::DerivativeCheckResult r =
        expr::CheckHessian(scalar, "s", in,
                           {Eigen::Vector3d(0.3, -0.2, 0.15), Eigen::VectorXd::Constant(1, -0.5),
                            drive.ParameterValues()});
    EXPECT_TRUE(r.ok) << "Hessian d2/d" << in << ": " << r.FullReport();
    std::cout << r.BriefReport() << "\n";
  }
}

// ---- (d) a stiff model at the sample time ----------------------------------------------------

// Robertson's kinetics (test_models.h): eigenvalues down to ~-1e4, so h |lambda| ~ 4e3 at
// h = 0.4.

// Errors over 100 samples of 0.4 s (to t = 40 s), relative to each species' largest value,
// against CVODES at rtol 1e-10. Measured: Radau IIA 3.7e-6 (CVODES at rtol 1e-6: 5.7e-6), backward
// Euler 9.9e-3 (order 1: h times the slow manifold's curvature); the bounds leave a factor 3.
constexpr double kRadauRobertsonError = 1.2e-5;
constexpr double kBackwardEulerRobertsonError = 0.03;
// Every Runge-Kutta step and every simplified-Newton iterate conserve the linear invariant
// y1 + y2 + y3 (e^T f = 0, hence e^T f_x = 0): exact up to the rounding of 100 steps.
constexpr double kMassConservation = 1e-13;

TEST(ImplicitStep, RobertsonAtTheSampleTimeStaysCloseToCvodesWhereRk4Fails) {
  const models::StateSpaceModel model = RobertsonModel();
  ASSERT_TRUE(model.stiff);
  const Eigen::VectorXd p = model.ParameterValues();
  // Start after the initial layer (y2 rises from 0 to 3.6e-5 within ~1e-3 s): from (1, 0, 0) the
  // Jacobian at the step's start (without the y2 terms) is no model of the step, and the
  // simplified Newton iteration diverges (integrators.h); that layer is CVODES's job.
  const Trajectory layer = SimulateCvodes(model, Eigen::Vector3d(1, 0, 0), Eigen::MatrixXd(2, 0), p,
                                          0.01, RobertsonOptions(1e-10));
  ASSERT_TRUE(layer.ok) << layer.summary.BriefReport();
  const Eigen::VectorXd x0 = layer.x.row(1).transpose();
  const double dt = 0.4;
  const int n = 101;
  const Eigen::MatrixXd u(n, 0);
  const Trajectory reference = SimulateCvodes(model, x0, u, p, dt, RobertsonOptions(1e-10));
  ASSERT_TRUE(reference.ok) << reference.summary.BriefReport();
  const Trajectory cvodes = SimulateCvodes(model, x0, u, p, dt, RobertsonOptions(1e-6));
  ASSERT_TRUE(cvodes.ok) << cvodes.summary.BriefReport();
  std::cout << cvodes.summary.BriefReport() << ", error " << ScaledError(cvodes.x, reference.x)
            << "\n";

  // RK4 at the sample time: |R(z)| ~ z^4 / 24 ~ 1e13 per step on the fast mode.
  const Trajectory rk4 = SimulateRk4(model, x0, u, p, dt);
  std::cout << rk4.summary.BriefReport() << "\n";
  EXPECT_FALSE(rk4.ok);
  EXPECT_EQ(rk4.summary.status, IntegrationStatus::kNonFiniteValue);

  auto simulate = [&](StepScheme scheme) {
    const Trajectory t = SimulateFixedStep(model, x0, u, p, dt, Scheme(scheme));
    const double e = t.ok ? ScaledError(t.x, reference.x) : INFINITY;
    std::cout << t.summary.BriefReport() << ", error " << e
              << ", |y1 + y2 + y3 - 1| <= " << (t.x.rowwise().sum().array() - 1.0).abs().maxCoeff()
              << "\n";
    EXPECT_TRUE(t.ok) << t.summary.BriefReport();
    EXPECT_LT((t.x.rowwise().sum().array() - x0.sum()).abs().maxCoeff(), kMassConservation)
        << StepSchemeName(scheme);
    return e;
  };
  EXPECT_LT(simulate(StepScheme::kRadauIIA), kRadauRobertsonError);
  EXPECT_LT(simulate(StepScheme::kBackwardEuler), kBackwardEulerRobertsonError);
}

// ---- (e) integrator sensitivities with an implicit scheme ------------------------------------

// The sensitivities are the exact derivatives of the discrete map, so central differences of the
// map agree up to truncation h^2 (times the third derivative) and rounding eps / h, both grown
// over the samples.
constexpr double kMapStep = 1e-5;
constexpr double kMapTolerance = 1e3 * (kMapStep * kMapStep + 1e-16 / kMapStep);

TEST(ImplicitStep, IntegratorSensitivitiesMatchDifferencesOfTheMap) {
  const models::StateSpaceModel model = StiffDriveModel();
  const double dt = 0.01;
  const int n = 101;
  const Eigen::MatrixXd u = Multisine(n, dt);
  const Eigen::Vector3d x0(0.1, 0.05, -0.1);
  const Eigen::VectorXd p = model.ParameterValues();
  for (StepScheme scheme : {StepScheme::kBackwardEuler, StepScheme::kRadauIIA}) {
    const FixedStepIntegrator integrator(model, dt, Scheme(scheme, 2, 3));
    const SensitivityTrajectory s = integrator.SimulateWithSensitivities(x0, u, p, {4, 0, 2});
    ASSERT_TRUE(s.ok) << s.summary.BriefReport();
    EXPECT_EQ(s.summary.num_steps, 2 * (n - 1));
    EXPECT_EQ(s.summary.num_linear_solver_setups, 2 * (n - 1));
    EXPECT_EQ(s.x, integrator.Simulate(x0, u, p).x);
    auto column_error = [](const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
      return (a - b).cwiseAbs().maxCoeff() / std::max(b.cwiseAbs().maxCoeff(), 1e-300);
    };
    // Stack the analytic columns per sample against the difference quotients.
    auto compare = [&](const std::string& what, const Trajectory& plus, const Trajectory& minus,
                       double h, const std::function<Eigen::VectorXd(int, bool)>& analytic) {
      ASSERT_TRUE(plus.ok && minus.ok) << what;
      Eigen::MatrixXd fd_x = (plus.x - minus.x) / (2.0 * h), fd_y = (plus.y - minus.y) / (2.0 * h);
      Eigen::MatrixXd an_x(fd_x.rows(), fd_x.cols()), an_y(fd_y.rows(), fd_y.cols());
      for (int k = 0; k < n; ++k) {
        an_x.row(k) = analytic(k, true).transpose();
        an_y.row(k) = analytic(k, false).transpose();
      }
      const double ex = column_error(an_x, fd_x), ey = column_error(an_y, fd_y);
      std::cout << "  " << StepSchemeName(scheme) << " d/d " << what << ": states " << ex
                << ", outputs " << ey << "\n";
      EXPECT_LT(ex, kMapTolerance) << what;
      EXPECT_LT(ey, kMapTolerance) << what;
    };
    for (std::size_t j = 0; j < s.parameters.size(); ++j) {
      const int i = s.parameters[j];
      const double h = kMapStep * std::max(1.0, std::fabs(p[i]));
      Eigen::VectorXd pp = p, pm = p;
      pp[i] += h;
      pm[i] -= h;
      compare(model.parameters[i].name, integrator.Simulate(x0, u, pp),
              integrator.Simulate(x0, u, pm), h, [&](int k, bool states) -> Eigen::VectorXd {
                return states ? s.dx_dp[k].col(static_cast<Eigen::Index>(j))
                              : s.dy_dp[k].col(static_cast<Eigen::Index>(j));
              });
    }
    for (int c = 0; c < 3; ++c) {
      Eigen::VectorXd xp = x0, xm = x0;
      xp[c] += kMapStep;
      xm[c] -= kMapStep;
      compare("x0[" + std::to_string(c) + "]", integrator.Simulate(xp, u, p),
              integrator.Simulate(xm, u, p), kMapStep, [&](int k, bool states) -> Eigen::VectorXd {
                return states ? s.dx_dx0[k].col(c) : s.dy_dx0[k].col(c);
              });
    }
  }
}

// ---- N-step simulation honours the scheme ------------------------------------------------------

TEST(ImplicitStep, NStepSimulationUsesTheScheme) {
  const models::StateSpaceModel model = StiffDriveModel();
  const double dt = 0.01;
  const int n = 300;
  const Eigen::MatrixXd u = Multisine(n, dt);
  const Eigen::VectorXd p = model.ParameterValues();
  const FixedStepOptions radau = Scheme(StepScheme::kRadauIIA);
  Eigen::MatrixXd x = SimulateFixedStep(model, Eigen::Vector3d::Zero(), u, p, dt, radau).x;
  for (int k = 0; k < n; ++k) x(k, k % 3) += 1e-3 * std::cos(0.3 * k);  // not a perfect model
  NStepSimulationOptions options;
  options.scoring.steps = 15;
  options.chunk = 64;
  options.step = radau;
  const NStepResult batched = NStepNrmsSimulated(model, x, u, p, dt, options);
  const expr::Function step = MakeStepFunction(model, dt, radau);
  const NStepResult sequential = NStepNrms(
      x,
      [&](int start, const Eigen::VectorXd& state, int steps) {
        Eigen::MatrixXd out(steps, 3);
        Eigen::VectorXd xs = state;
        for (int k = 0; k < steps; ++k) {
          xs = step({xs, u.row(start + k).transpose(), p})[0];
          out.row(k) = xs.transpose();
        }
        return out;
      },
      options.scoring);
  constexpr double kSameArithmetic = 1e-12;  // identical steps; sums combined in another order
  EXPECT_NEAR(batched.nrms, sequential.nrms, kSameArithmetic * sequential.nrms);
  EXPECT_GT(batched.nrms, 0.0);
  // RK4 at this step is unstable for the actuator mode: its N-step error is far larger.
  options.step = Scheme(StepScheme::kRk4);
  const double rk4 = NStepNrmsSimulated(model, x, u, p, dt, options).nrms;
  std::cout << "N-step NRMS: radau_iia " << batched.nrms << ", rk4 " << rk4 << "\n";
  EXPECT_FALSE(rk4 < 100.0 * batched.nrms);  // NaN (overflow) counts as far larger
}

// ---- (f) multiple shooting with an implicit scheme ---------------------------------------------

// 1000 samples with noise 0.5% of the position range. The estimate is checked against the truth in
// units of its own standard error (the Gauss-Newton covariance of the Radau IIA simulation, which
// the identification must also get right): a deterministic seed, and 4 sigma leaves no room for
// flakiness. The truth is a CVODES simulation, so a discretisation bias of Radau IIA at h = dt
// would show up as a miss of many sigma; measured over seeds 1..8: at most 1.6 sigma.
constexpr double kSigmas = 4.0;
// The data pin every free parameter down to a few percent (measured standard errors 0.09% for k
// to 2.3% for the Coulomb friction, which the viscous term partly mimics).
constexpr double kMaxRelativeStdError = 0.05;

TEST(ImplicitStep, MultipleShootingWithRadauRecoversAStiffDrive) {
  const models::StateSpaceModel truth_model = StiffDriveModel();
  const Eigen::VectorXd truth = truth_model.ParameterValues();
  const double dt = 0.01;
  const int n = 1000;
  Experiment ex;
  ex.name = "stiff";
  ex.dt = dt;
  ex.u = Multisine(n, dt);
  ExperimentSetup setup;
  setup.x0 = Eigen::Vector3d::Zero();
  CvodesOptions cvodes;
  cvodes.relative_tolerance = 1e-10;
  cvodes.absolute_tolerance = 1e-12;
  const Trajectory sim = SimulateCvodes(truth_model, setup.x0, ex.u, truth, dt, cvodes);
  ASSERT_TRUE(sim.ok) << sim.summary.BriefReport();
  const double range = sim.y.maxCoeff() - sim.y.minCoeff();
  std::mt19937 rng(Seed());
  std::normal_distribution<double> noise(0.0, 0.005 * range);
  ex.y = sim.y;
  for (int k = 0; k < n; ++k) ex.y(k, 0) += noise(rng);

  // Start 30% off; the actuator bandwidth stays known (a 2.5 ms lag is not identifiable from 10 ms
  // samples of the position).
  models::StateSpaceModel start = truth_model;
  start.parameters[0].free = false;
  for (int i = 1; i < 5; ++i) start.parameters[i].value = truth[i] * (i % 2 ? 1.3 : 0.7);

  MultipleShootingOptions options;
  options.segment_length = 20;
  options.fix_initial_state = true;
  // RK4 at the sample time cannot even simulate the initial guess (h a = 4 > 2.785).
  EXPECT_THROW(BuildMultipleShooting(start, {ex}, {setup}, options), std::invalid_argument);
  options.step = Scheme(StepScheme::kRadauIIA);
  const ShootingProblem problem = BuildMultipleShooting(start, {ex}, {setup}, options);
  const SolverResult r = SolveWithIpopt(problem.nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  std::cout << r.BriefReport() << "\n";
  EXPECT_LT(r.constraint_violation, 1e-8);
  const Eigen::VectorXd p = problem.Parameters(r.w);
  const UncertaintyReport u =
      SimulationCovariance(start, {ex}, p, {setup.x0}, problem.output_weights, options.step);
  std::cout << u.FullReport();
  for (int i = 1; i < 5; ++i) {
    const ParameterEstimate& e = u.parameters[static_cast<std::size_t>(i)];
    std::cout << "  " << e.name << ": " << (e.value - truth[i]) / e.std_error << " sigma\n";
    EXPECT_LT(std::fabs(e.value - truth[i]), kSigmas * e.std_error) << e.name;
    EXPECT_LT(e.std_error, kMaxRelativeStdError * truth[i]) << e.name;
  }
}

// ---- options, names, factory -------------------------------------------------------------------

void ExpectInvalid(const std::function<void()>& f, const std::string& fragment) {
  try {
    f();
    ADD_FAILURE() << "expected std::invalid_argument containing '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(ImplicitStep, NamesOptionsAndFactory) {
  for (StepScheme s : {StepScheme::kRk4, StepScheme::kBackwardEuler, StepScheme::kTrapezoidal,
                       StepScheme::kRadauIIA}) {
    EXPECT_EQ(ParseStepScheme(StepSchemeName(s)), s);
  }
  EXPECT_EQ(std::string(StepSchemeName(StepScheme::kRadauIIA)), "radau_iia");
  ExpectInvalid([] { ParseStepScheme("radau_ii"); }, "did you mean 'radau_iia'?");
  ExpectInvalid([] { ParseStepScheme("backward_euller"); }, "did you mean 'backward_euler'?");

  FixedStepOptions o = Scheme(StepScheme::kBackwardEuler, 1, 0);
  ExpectInvalid([&] { o.Validate(); },
                "FixedStepOptions.newton_iterations: expected >= 1 for the implicit scheme "
                "'backward_euler', got 0");
  o.scheme = StepScheme::kRk4;
  o.Validate();  // unused by the explicit scheme
  o.substeps = 0;
  ExpectInvalid([&] { o.Validate(); }, "FixedStepOptions.substeps: expected >= 1, got 0");
  const models::StateSpaceModel model = StiffDriveModel();
  ExpectInvalid([&] { MakeStepFunction(model, 0.01, o); }, "FixedStepOptions.substeps");
  ExpectInvalid([&] { MakeStepFunction(model, 0.0, Scheme(StepScheme::kRadauIIA)); }, "dt > 0");
  MultipleShootingOptions ms;
  ms.step.newton_iterations = 0;
  ms.step.scheme = StepScheme::kTrapezoidal;
  ExpectInvalid([&] { ms.Validate(); }, "newton_iterations");
  NStepSimulationOptions ns;
  ns.step.substeps = -1;
  ExpectInvalid([&] { ns.Validate(); }, "FixedStepOptions.substeps");

  IntegratorOptions io;
  io.fixed_step = Scheme(StepScheme::kBackwardEuler);
  EXPECT_EQ(MakeIntegrator(model, 0.01, io)->Name(),
            "backward_euler (1 substep, 4 newton iterations)");
  io.fixed_step = Scheme(StepScheme::kTrapezoidal, 2, 1);
  EXPECT_EQ(MakeIntegrator(model, 0.01, io)->Name(),
            "trapezoidal (2 substeps, 1 newton iteration)");
  EXPECT_EQ(FixedStepIntegrator(model, 0.01).Name(), "rk4 (1 substep)");
  EXPECT_EQ(MakeStepFunction(model, 0.01, Scheme(StepScheme::kRadauIIA)).name(),
            "stiff_drive_radau_iia");
  // The summary counts the f evaluations inside the map: Radau IIA reuses f(x) in its first
  // iteration (1 + 2 stages x 3 further iterations), trapezoidal does not (1 + 4 iterations).
  const Eigen::MatrixXd u = Multisine(11, 0.01);
  const Eigen::VectorXd p = model.ParameterValues();
  EXPECT_EQ(
      SimulateFixedStep(model, Eigen::Vector3d::Zero(), u, p, 0.01, Scheme(StepScheme::kRadauIIA))
          .summary.num_rhs_evaluations,
      10 * 7);
  EXPECT_EQ(SimulateFixedStep(model, Eigen::Vector3d::Zero(), u, p, 0.01,
                              Scheme(StepScheme::kTrapezoidal))
                .summary.num_rhs_evaluations,
            10 * 5);
}

}  // namespace
}  // namespace graybox::estimators
