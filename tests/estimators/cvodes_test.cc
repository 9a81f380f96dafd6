// CVODES integrator and the integrator interface: Robertson's stiff kinetics against reference
// values (dense and KLU), forward sensitivities against central differences (Robertson without
// input changes, the pneumatic arm with a restart at every sample), agreement with RK4 on a
// non-stiff model (states and sensitivities), RK4 sensitivities against differences of the
// discrete map, restarts only where the input changes (against the exact zero-order-hold
// solution), failure statuses (NaN in f from an input or from the state, too much work), the
// pneumatic arm where RK4 at the sample time is wrong, and the factory and option checks.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "graybox/estimators/integrators/cvodes_integrator.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/models/model.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

using models::BlockArgs;
using models::BlockBase;
using testing::LagModel;
using testing::RobertsonModel;
using testing::RobertsonOptions;

// A BDF code controls the local error per step; the global error accumulates over the steps.
// Every accuracy check below is one of these factors times the relative tolerance the integrator
// was asked for:
//  - one continuous integration: typically 10-100 (Robertson to t = 40: 2-6);
//  - a restart at every sample (input changing at every sample): each restart begins again at
//    order 1 with a fresh step estimate and the local errors of ~20 steps per sample add up
//    (measured: Duffing over 500 restarts 400x for the states, 1400x for the sensitivities;
//    pneumatic arm over 100 restarts 400x).
constexpr double kGlobalErrorFactor = 100.0;
constexpr double kRestartErrorFactor = 1e4;

// The seed of every random draw; override with GRAYBOX_SEED.
unsigned Seed() {
  const char* env = std::getenv("GRAYBOX_SEED");
  const unsigned seed = env ? static_cast<unsigned>(std::strtoul(env, nullptr, 10)) : 11u;
  std::cout << "[ seed ] GRAYBOX_SEED=" << seed << "\n";
  return seed;
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

// The per-sample sensitivity matrices stacked into one (N rows each) matrix, so ScaledError
// compares each column (each parameter or initial state) over the whole trajectory.
Eigen::MatrixXd Stack(const std::vector<Eigen::MatrixXd>& s) {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(s.size()) * s.at(0).rows(), s.at(0).cols());
  for (std::size_t k = 0; k < s.size(); ++k) {
    out.middleRows(static_cast<Eigen::Index>(k) * s[k].rows(), s[k].rows()) = s[k];
  }
  return out;
}

// ---- test models ------------------------------------------------------------------------------

// Robertson's kinetics (RobertsonModel, RobertsonOptions), the first-order lag (LagModel): see
// test_models.h.

// Hairer & Wanner's reference solution at t = 40, to the ten digits printed.
const Eigen::Vector3d kRobertsonAt40(0.7158270687, 9.185534764e-6, 0.2841637457);
constexpr double kReferenceRounding = 5e-11;  // half a unit in the tenth significant digit

// A Duffing oscillator: q'' = u - c q' - k q - k3 q^3 (non-stiff at these parameters).
class Duffing : public BlockBase<Duffing> {
 public:
  Duffing() {
    info_.type = "test.duffing";
    info_.description = "Duffing oscillator";
    info_.reference = "test";
    info_.inputs = {{"u", "N", "force", -1, 1}};
    info_.outputs = {{"energy", "J", "mechanical energy", 0, 1}};
    info_.states = {{"q", "m", "position", -1, 1}, {"qd", "m/s", "velocity", -1, 1}};
    info_.parameters = {{"c", "N s/m", "damping", 0.4, 0.0, 10.0},
                        {"k", "N/m", "stiffness", 4.0, 0.1, 100.0},
                        {"k3", "N/m^3", "cubic stiffness", 1.0, -10.0, 10.0}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    const S& q = a.x[0];
    const S& qd = a.x[1];
    a.xdot[0] = qd;
    a.xdot[1] = a.u[0] - a.p[0] * qd - a.p[1] * q - a.p[2] * q * q * q;
    a.y[0] = 0.5 * qd * qd + 0.5 * a.p[1] * q * q + 0.25 * a.p[2] * q * q * q * q;
  }
};

models::StateSpaceModel DuffingModel() {
  models::Model m("duffing");
  m.AddInput("u", "N");
  m.AddBlock("osc", std::make_shared<Duffing>(), {"u"}, {"energy"});
  m.AddOutput("osc.q");
  m.AddOutput("energy");
  return m.Build();
}

Eigen::MatrixXd DuffingInput(int n, double dt) {
  Eigen::MatrixXd u(n, 1);
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    u(k, 0) = 1.2 * std::sin(2.0 * t) + 0.6 * std::sin(7.3 * t);
  }
  return u;
}

// x' = -x + sqrt(u): f is NaN while the input is negative.
class SqrtInput : public BlockBase<SqrtInput> {
 public:
  SqrtInput() {
    info_.type = "test.sqrt_input";
    info_.description = "NaN for negative inputs";
    info_.reference = "test";
    info_.inputs = {{"u", "1", "input", 0, 1}};
    info_.states = {{"x", "1", "state", 0, 1}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    using std::sqrt;
    a.xdot[0] = -a.x[0] + sqrt(a.u[0]);
  }
};

// A clock c' = 1 and z' = sqrt(t_nan - c): f is NaN for every state past t = t_nan.
class NanAfter : public BlockBase<NanAfter> {
 public:
  NanAfter() {
    info_.type = "test.nan_after";
    info_.description = "NaN once the clock passes t_nan";
    info_.reference = "test";
    info_.states = {{"c", "s", "clock", 0, 1}, {"z", "1", "state", 0, 1}};
    info_.parameters = {{"t_nan", "s", "time from which f is NaN", 0.55, 0.0, 10.0}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    using std::sqrt;
    a.xdot[0] = S(1.0);
    a.xdot[1] = sqrt(a.p[0] - a.x[0]);
  }
};

// The pneumatic arm of seed 004 (models/pneumatics.h) with both valve commands as inputs.
models::StateSpaceModel ArmModel() {
  models::Model m("pneumatic_arm");
  m.AddInput("u1", "V", "valve 1 command", 0.0, 10.0);
  m.AddInput("u2", "V", "valve 2 command", 0.0, 10.0);
  m.AddBlock("arm", "pneumatic.arm", {}, {"u1", "u2"}, {"torque"});
  m.AddOutput("arm.q");
  m.AddOutput("torque");
  return m.Build();
}

// Staircase valve commands: a new uniform level in [low, high] V every `hold` samples, valve 2
// mirrored (10 - u1), so both chambers are driven towards supply or exhaust in turn.
Eigen::MatrixXd ArmStaircase(int n, int hold, double low, double high, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> level(low, high);
  Eigen::MatrixXd u(n, 2);
  double v = 5.0;
  for (int k = 0; k < n; ++k) {
    if (k % hold == 0) v = level(rng);
    u(k, 0) = v;
    u(k, 1) = 10.0 - v;
  }
  return u;
}

// Smooth commands that change at every sample (so CVODES restarts at every sample).
Eigen::MatrixXd ArmSine(int n, double dt) {
  Eigen::MatrixXd u(n, 2);
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    u(k, 0) = 5.0 + 1.5 * std::sin(2.0 * M_PI * 0.5 * t) + 0.5 * std::sin(2.0 * M_PI * 2.3 * t);
    u(k, 1) = 10.0 - u(k, 0);
  }
  return u;
}

// Hanging at rest with 300 kPa in both chambers.
const Eigen::Vector4d kArmX0(M_PI / 2.0, 0.0, 300.0, 300.0);
// Typical magnitudes of q [rad], qd [rad/s], p1, p2 [kPa], for absolute tolerances.
const Eigen::Vector4d kArmStateScale(1.0, 10.0, 300.0, 300.0);

CvodesOptions ArmOptions(double rtol) {
  CvodesOptions o;
  o.relative_tolerance = rtol;
  o.absolute_tolerances = rtol * kArmStateScale;
  return o;
}

// ---- Robertson --------------------------------------------------------------------------------

TEST(Cvodes, RobertsonMatchesTheReferenceWithDenseAndKlu) {
  const models::StateSpaceModel model = RobertsonModel();
  constexpr double kRtol = 1e-8;
  const double dt = 0.4;
  const int n = 101;  // t_100 = 40
  const Eigen::MatrixXd u(n, 0);
  const Eigen::Vector3d x0(1.0, 0.0, 0.0);
  CvodesOptions options = RobertsonOptions(kRtol);
  const Trajectory dense =
      CvodesIntegrator(model, dt, options).Simulate(x0, u, model.ParameterValues());
  options.linear_solver = CvodesOptions::LinearSolver::kKlu;
  const Trajectory klu =
      CvodesIntegrator(model, dt, options).Simulate(x0, u, model.ParameterValues());
  ASSERT_TRUE(dense.ok) << dense.summary.BriefReport();
  ASSERT_TRUE(klu.ok) << klu.summary.BriefReport();
  std::cout << dense.summary.FullReport() << klu.summary.BriefReport() << "\n";
  EXPECT_EQ(dense.summary.num_reinitializations, 0);  // no inputs: one continuous integration
  for (int i = 0; i < 3; ++i) {
    const double ref = kRobertsonAt40[i];
    const double tolerance =
        kGlobalErrorFactor * kRtol * std::fabs(ref) + kReferenceRounding * std::fabs(ref);
    EXPECT_NEAR(dense.x(n - 1, i), ref, tolerance) << "y" << i + 1 << " (dense)";
    EXPECT_NEAR(klu.x(n - 1, i), ref, tolerance) << "y" << i + 1 << " (klu)";
    std::cout << "y" << i + 1 << "(40): dense " << dense.x(n - 1, i) << " klu " << klu.x(n - 1, i)
              << " reference " << ref << " relative errors "
              << std::fabs(dense.x(n - 1, i) - ref) / ref << " "
              << std::fabs(klu.x(n - 1, i) - ref) / ref << "\n";
  }
  // Dense and KLU solve the same Newton systems; they differ by rounding, which the error
  // control keeps at the tolerance level.
  EXPECT_LT(ScaledError(klu.x, dense.x), kGlobalErrorFactor * kRtol);
  // Mass conservation y1 + y2 + y3 = 1 holds for BDF exactly up to the Newton tolerance.
  EXPECT_NEAR(dense.x.row(n - 1).sum(), 1.0, kGlobalErrorFactor * kRtol);
  // Outputs are h(x) = (y1, y3) at the samples.
  EXPECT_EQ(dense.y(n - 1, 0), dense.x(n - 1, 0));
  EXPECT_EQ(dense.y(n - 1, 1), dense.x(n - 1, 2));
}

// Central differences of repeated simulations: with simulations accurate to eps (relative; the
// error does not vary smoothly with the parameter, as the step sequence changes) and a relative
// step h, the difference quotient is off by about eps / h (integration noise) plus h^2
// (truncation); the sensitivities themselves by about the factor times their tolerance.
constexpr double kFdStep = 1e-4;
constexpr double kFdSimulationRtol = 1e-11;
constexpr double kSensitivityRtol = 1e-8;
constexpr double FdTolerance(double error_factor, double simulation_rtol) {
  return error_factor * (simulation_rtol / kFdStep + kSensitivityRtol) + kFdStep * kFdStep;
}

// Compares the columns of (dx_dp | dx_dx0) and (dy_dp | dy_dx0) with central differences of
// `precise` simulations, with steps relative_step * max(|value|, scale): the parameter's scale,
// or x0_scale for the initial states (only the x0_columns are compared).
void ExpectSensitivitiesMatchDifferences(const Integrator& precise, const SensitivityTrajectory& s,
                                         const Eigen::VectorXd& x0, const Eigen::MatrixXd& u,
                                         const Eigen::VectorXd& p,
                                         const std::vector<int>& x0_columns,
                                         const Eigen::VectorXd& x0_scale, double relative_step,
                                         double tolerance) {
  const int nx = static_cast<int>(x0.size());
  const int npc = static_cast<int>(s.parameters.size());
  const Eigen::Index n = u.rows();
  auto check = [&](const std::string& what, const Trajectory& plus, const Trajectory& minus,
                   double h, const std::function<Eigen::VectorXd(Eigen::Index, bool)>& analytic) {
    ASSERT_TRUE(plus.ok && minus.ok) << what;
    Eigen::MatrixXd fd_x = (plus.x - minus.x) / (2.0 * h);
    Eigen::MatrixXd fd_y = (plus.y - minus.y) / (2.0 * h);
    Eigen::MatrixXd an_x(n, nx), an_y(n, fd_y.cols());
    for (Eigen::Index k = 0; k < n; ++k) {
      an_x.row(k) = analytic(k, true).transpose();
      an_y.row(k) = analytic(k, false).transpose();
    }
    // Relative to the largest entry of each column (sensitivities of different states differ
    // by orders of magnitude; a missing or wrong term is off by O(1) of that).
    auto column_error = [](const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
      const double scale = std::max(b.cwiseAbs().maxCoeff(), 1e-300);
      return (a - b).cwiseAbs().maxCoeff() / scale;
    };
    const double ex = column_error(fd_x, an_x), ey = column_error(fd_y, an_y);
    EXPECT_LT(ex, tolerance) << "d x / d " << what;
    EXPECT_LT(ey, tolerance) << "d y / d " << what;
    std::cout << "  d/d " << what << ": relative difference states " << ex << ", outputs " << ey
              << "\n";
  };
  for (int j = 0; j < npc; ++j) {
    const int i = s.parameters[static_cast<std::size_t>(j)];
    const double h = relative_step * std::max(std::fabs(p[i]), precise.model().parameters[i].scale);
    Eigen::VectorXd pp = p, pm = p;
    pp[i] += h;
    pm[i] -= h;
    check(precise.model().parameters[i].name, precise.Simulate(x0, u, pp),
          precise.Simulate(x0, u, pm), h, [&](Eigen::Index k, bool states) -> Eigen::VectorXd {
            return states ? s.dx_dp[k].col(j) : s.dy_dp[k].col(j);
          });
  }
  for (int c : x0_columns) {
    const double h = relative_step * std::max(std::fabs(x0[c]), x0_scale[c]);
    Eigen::VectorXd xp = x0, xm = x0;
    xp[c] += h;
    xm[c] -= h;
    check("x0[" + std::to_string(c) + "]", precise.Simulate(xp, u, p), precise.Simulate(xm, u, p),
          h, [&](Eigen::Index k, bool states) -> Eigen::VectorXd {
            return states ? s.dx_dx0[k].col(c) : s.dy_dx0[k].col(c);
          });
  }
}

TEST(Cvodes, RobertsonSensitivitiesMatchCentralDifferences) {
  const models::StateSpaceModel model = RobertsonModel();
  const double dt = 0.4;
  const int n = 101;
  const Eigen::MatrixXd u(n, 0);
  const Eigen::Vector3d x0(1.0, 0.0, 0.0);
  const Eigen::VectorXd p = model.ParameterValues();
  const CvodesIntegrator integrator(model, dt, RobertsonOptions(kSensitivityRtol));
  const SensitivityTrajectory s = integrator.SimulateWithSensitivities(x0, u, p);
  ASSERT_TRUE(s.ok) << s.summary.BriefReport();
  std::cout << s.summary.FullReport();
  ASSERT_EQ(s.parameters, (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(s.dx_dp.size(), static_cast<std::size_t>(n));
  EXPECT_EQ(s.dx_dp[0], Eigen::MatrixXd::Zero(3, 3));
  EXPECT_EQ(s.dx_dx0[0], Eigen::MatrixXd::Identity(3, 3));
  EXPECT_EQ(s.summary.num_sensitivities, 6);
  EXPECT_GT(s.summary.num_sensitivity_rhs_evaluations, 0);
  const CvodesIntegrator precise(model, dt, RobertsonOptions(kFdSimulationRtol));
  // Not x0[1]: a negative initial y2 makes y2' = -k2 y2^2 + ... run away, so its central
  // difference does not exist at y2(0) = 0.
  ExpectSensitivitiesMatchDifferences(precise, s, x0, u, p, {0, 2}, Eigen::Vector3d(1, 1, 1),
                                      kFdStep, FdTolerance(kGlobalErrorFactor, kFdSimulationRtol));
}

// ---- pneumatic arm sensitivities: a restart at every sample --------------------------------

TEST(Cvodes, ArmSensitivitiesMatchCentralDifferencesAcrossRestarts) {
  const models::StateSpaceModel model = ArmModel();
  const double dt = 0.01;
  const int n = 101;
  const Eigen::MatrixXd u = ArmSine(n, dt);
  const Eigen::VectorXd p = model.ParameterValues();
  const std::vector<int> chosen = {
      model.ParameterIndex("arm.inertia"),  model.ParameterIndex("arm.damping"),
      model.ParameterIndex("arm.alpha"),    model.ParameterIndex("arm.valve1_gain"),
      model.ParameterIndex("arm.p_supply"), model.ParameterIndex("arm.gravity_torque")};
  const CvodesIntegrator integrator(model, dt, ArmOptions(kSensitivityRtol));
  const SensitivityTrajectory s = integrator.SimulateWithSensitivities(kArmX0, u, p, chosen);
  ASSERT_TRUE(s.ok) << s.summary.BriefReport();
  std::cout << s.summary.FullReport();
  EXPECT_EQ(s.summary.num_reinitializations, n - 2);  // the input changes at every sample
  EXPECT_EQ(s.parameters, chosen);
  // Restarted simulations are noisier in the parameters: difference them at a tighter rtol.
  constexpr double kArmFdSimulationRtol = 1e-12;
  const CvodesIntegrator precise(model, dt, ArmOptions(kArmFdSimulationRtol));
  ExpectSensitivitiesMatchDifferences(precise, s, kArmX0, u, p, {0, 1, 2, 3}, kArmStateScale,
                                      kFdStep,
                                      FdTolerance(kRestartErrorFactor, kArmFdSimulationRtol));

  // KLU with the simultaneous corrector solves the same sensitivity equations.
  CvodesOptions klu = ArmOptions(kSensitivityRtol);
  klu.linear_solver = CvodesOptions::LinearSolver::kKlu;
  klu.sensitivity_method = CvodesOptions::SensitivityMethod::kSimultaneous;
  const SensitivityTrajectory k =
      CvodesIntegrator(model, dt, klu).SimulateWithSensitivities(kArmX0, u, p, chosen);
  ASSERT_TRUE(k.ok) << k.summary.BriefReport();
  // Both are within the factor times the tolerance of the exact sensitivities.
  EXPECT_LT(ScaledError(Stack(k.dx_dp), Stack(s.dx_dp)),
            2.0 * kRestartErrorFactor * kSensitivityRtol);
  EXPECT_LT(ScaledError(Stack(k.dx_dx0), Stack(s.dx_dx0)),
            2.0 * kRestartErrorFactor * kSensitivityRtol);
}

// ---- RK4 and CVODES on a non-stiff model ---------------------------------------------------

FixedStepOptions Rk4(int substeps) {
  FixedStepOptions o;
  o.substeps = substeps;
  return o;
}

// RK4 with h = dt / 8 = 1.25e-3 on a model with |lambda| ~ 2: global error ~ (h |lambda|)^4 ~
// 1e-11 (measured < 4e-10 against CVODES), below CVODES's with restarts at rtol 1e-12; the two
// agree to the restart factor times rtol.
constexpr double kAgreementRtol = 1e-12;
constexpr int kAgreementSubsteps = 8;

TEST(Integrators, Rk4AndCvodesAgreeOnANonStiffModel) {
  const models::StateSpaceModel model = DuffingModel();
  const double dt = 0.01;
  const int n = 501;
  const Eigen::MatrixXd u = DuffingInput(n, dt);
  const Eigen::Vector2d x0(0.3, -0.2);
  const Eigen::VectorXd p = model.ParameterValues();
  const FixedStepIntegrator rk4(model, dt, Rk4(kAgreementSubsteps));
  CvodesOptions o;
  o.relative_tolerance = kAgreementRtol;
  o.absolute_tolerance = kAgreementRtol;
  const CvodesIntegrator cvodes(model, dt, o);
  const SensitivityTrajectory a = rk4.SimulateWithSensitivities(x0, u, p);
  const SensitivityTrajectory b = cvodes.SimulateWithSensitivities(x0, u, p);
  ASSERT_TRUE(a.ok) << a.summary.BriefReport();
  ASSERT_TRUE(b.ok) << b.summary.BriefReport();
  std::cout << a.summary.BriefReport() << "\n" << b.summary.BriefReport() << "\n";
  const double tolerance = kRestartErrorFactor * kAgreementRtol;
  const double ex = ScaledError(a.x, b.x), ey = ScaledError(a.y, b.y);
  const double ep = ScaledError(Stack(a.dx_dp), Stack(b.dx_dp));
  const double e0 = ScaledError(Stack(a.dx_dx0), Stack(b.dx_dx0));
  const double eyp = ScaledError(Stack(a.dy_dp), Stack(b.dy_dp));
  std::cout << "rk4 vs cvodes: states " << ex << ", outputs " << ey << ", dx/dp " << ep
            << ", dx/dx0 " << e0 << ", dy/dp " << eyp << "\n";
  EXPECT_LT(ex, tolerance);
  EXPECT_LT(ey, tolerance);
  EXPECT_LT(ep, tolerance);
  EXPECT_LT(e0, tolerance);
  EXPECT_LT(eyp, tolerance);
  // Simulate and SimulateWithSensitivities integrate the same states.
  EXPECT_EQ(rk4.Simulate(x0, u, p).x, a.x);
}

// The RK4 sensitivities are the exact derivatives of the discrete map, so central differences
// of the map agree up to truncation h^2 (times the third derivative) and rounding eps / h.
TEST(Integrators, Rk4SensitivitiesMatchDifferencesOfTheMap) {
  const models::StateSpaceModel model = DuffingModel();
  const double dt = 0.05;
  const int n = 101;
  const Eigen::MatrixXd u = DuffingInput(n, dt);
  const Eigen::Vector2d x0(0.3, -0.2);
  const Eigen::VectorXd p = model.ParameterValues();
  const FixedStepIntegrator rk4(model, dt, Rk4(2));
  const SensitivityTrajectory s = rk4.SimulateWithSensitivities(x0, u, p, {2, 0});
  ASSERT_TRUE(s.ok);
  EXPECT_EQ(s.summary.num_steps, 2 * (n - 1));
  EXPECT_EQ(s.summary.num_rhs_evaluations, 8 * (n - 1));
  // Truncation h^2 and rounding eps / h, times 1e3 for the third derivative and the growth of
  // both over 100 samples.
  constexpr double kMapStep = 1e-5;
  constexpr double kMapTolerance = 1e3 * (kMapStep * kMapStep + 1e-16 / kMapStep);
  ExpectSensitivitiesMatchDifferences(rk4, s, x0, u, p, {0, 1}, Eigen::Vector2d(1, 1), kMapStep,
                                      kMapTolerance);
}

// ---- restarts only where the input changes -------------------------------------------------

TEST(Cvodes, RestartsOnlyWhereTheInputChangesAndMatchesTheExactHold) {
  const models::StateSpaceModel model = LagModel();
  const double dt = 0.1, a = 2.0, b = 3.0;
  Eigen::MatrixXd u(10, 1);
  u << 1, 1, 1, 0, 0, 2, 2, 2, 2, -1;  // changes at samples 3, 5 (and 9, the last, which holds
                                       // over no interval)
  constexpr double kRtol = 1e-10;
  CvodesOptions o;
  o.relative_tolerance = kRtol;
  o.absolute_tolerance = 1e-14;
  const Trajectory t = CvodesIntegrator(model, dt, o)
                           .Simulate(Eigen::VectorXd::Constant(1, 0.5), u, Eigen::Vector2d(a, b));
  ASSERT_TRUE(t.ok) << t.summary.BriefReport();
  EXPECT_EQ(t.summary.num_reinitializations, 2);
  double x = 0.5;
  const double decay = std::exp(-a * dt);
  for (int k = 0; k < 10; ++k) {
    EXPECT_NEAR(t.x(k, 0), x, kGlobalErrorFactor * kRtol * std::max(std::fabs(x), 1.0)) << k;
    x = decay * x + (b / a) * (1.0 - decay) * u(k, 0);
  }
  // Pass-through settings reach CVODES: a maximum step of 1 ms forces >= 100 steps per sample.
  o.pass_through["max_step"] = 1e-3;
  const Trajectory fine =
      CvodesIntegrator(model, dt, o)
          .Simulate(Eigen::VectorXd::Constant(1, 0.5), u, Eigen::Vector2d(a, b));
  EXPECT_GE(fine.summary.num_steps, 9 * 100);
  EXPECT_LT(t.summary.num_steps, 9 * 100);
}

// ---- failures end in a status ----------------------------------------------------------------

TEST(Integrators, NanFromAnInputEndsInAStatusWithTheSample) {
  models::Model m("sqrt");
  m.AddInput("u", "1");
  m.AddBlock("s", std::make_shared<SqrtInput>(), {"u"}, {});
  m.AddOutput("s.x");
  const models::StateSpaceModel model = m.Build();
  Eigen::MatrixXd u = Eigen::MatrixXd::Ones(20, 1);
  u(7, 0) = -1.0;  // f is NaN over [t_7, t_8)
  for (IntegrationMethod method : {IntegrationMethod::kCvodes, IntegrationMethod::kFixedStep}) {
    IntegratorOptions o;
    o.method = method;
    const auto integrator = MakeIntegrator(model, 0.1, o);
    const SensitivityTrajectory t =
        integrator->SimulateWithSensitivities(Eigen::VectorXd::Zero(1), u, Eigen::VectorXd());
    std::cout << t.summary.BriefReport() << "\n";
    EXPECT_FALSE(t.ok);
    EXPECT_EQ(t.summary.status, IntegrationStatus::kNonFiniteValue);
    EXPECT_EQ(t.failed_at, 7);
    EXPECT_EQ(t.summary.failed_at, 7);
    EXPECT_TRUE(t.x.topRows(8).allFinite());
    EXPECT_TRUE(t.x.bottomRows(12).array().isNaN().all());
    EXPECT_TRUE(t.dx_dx0[7].allFinite());
    EXPECT_TRUE(t.dx_dx0[8].array().isNaN().all());
    EXPECT_NE(t.summary.BriefReport().find("non-finite value at sample 7"), std::string::npos)
        << t.summary.BriefReport();
  }
}

TEST(Cvodes, NanFromTheStateEndsInAFailureInTheRightInterval) {
  models::Model m("nan_after");
  m.AddBlock("n", std::make_shared<NanAfter>(), {}, {});
  m.AddOutput("n.z");
  const models::StateSpaceModel model = m.Build();
  const Trajectory t = SimulateCvodes(model, Eigen::Vector2d(0.0, 0.0), Eigen::MatrixXd(20, 0),
                                      model.ParameterValues(), 0.1);
  std::cout << t.summary.BriefReport() << "\n";
  EXPECT_FALSE(t.ok);
  EXPECT_EQ(t.failed_at, 5);  // t_nan = 0.55 lies in [t_5, t_6)
  EXPECT_TRUE(t.x.topRows(6).allFinite());
}

TEST(Cvodes, TooMuchWorkEndsInAStatus) {
  const models::StateSpaceModel model = RobertsonModel();
  CvodesOptions o = RobertsonOptions(1e-8);
  o.max_steps = 20;  // Robertson's initial transient needs far more steps than that
  const Trajectory t = SimulateCvodes(model, Eigen::Vector3d(1, 0, 0), Eigen::MatrixXd(11, 0),
                                      model.ParameterValues(), 4.0, o);
  std::cout << t.summary.BriefReport() << "\n";
  EXPECT_EQ(t.summary.status, IntegrationStatus::kTooMuchWork);
  EXPECT_EQ(t.failed_at, 0);
  EXPECT_NE(t.summary.message.find("CV_TOO_MUCH_WORK"), std::string::npos) << t.summary.message;
}

// ---- the stiff pneumatic arm -----------------------------------------------------------------

// Staircase commands over the whole 0..10 V range drive the chambers to supply and exhaust
// pressure, where the laminar orifice law makes d pdot / dp ~ -600 /s; with the arm swinging
// through the crank's dead centres, trajectory errors grow by ~1e3 over the 3 s (measured: rtol
// 1e-8 gives 4e-5), so the accuracy check allows that growth on top of the usual factor.
constexpr double kArmDt = 0.02;  // 50 Hz
constexpr double kArmRtol = 1e-8;
constexpr double kArmErrorGrowth = 1e3;
constexpr double kRk4WrongError = 0.01;  // 1% of a state's range: above the noise a fit resolves

TEST(Cvodes, PneumaticArmSimulatesWhereRk4AtTheSampleTimeIsWrong) {
  const models::StateSpaceModel model = ArmModel();
  ASSERT_TRUE(model.stiff);
  const int n = 151;  // 3 s
  const Eigen::MatrixXd u = ArmStaircase(n, 12, 0.0, 10.0, Seed());
  const Eigen::VectorXd p = model.ParameterValues();
  const Trajectory reference = SimulateCvodes(model, kArmX0, u, p, kArmDt, ArmOptions(1e-12));
  ASSERT_TRUE(reference.ok) << reference.summary.BriefReport();
  const Trajectory cvodes = SimulateCvodes(model, kArmX0, u, p, kArmDt, ArmOptions(kArmRtol));
  ASSERT_TRUE(cvodes.ok) << cvodes.summary.BriefReport();
  const double cvodes_error = ScaledError(cvodes.x, reference.x);
  std::cout << cvodes.summary.BriefReport() << ", error " << cvodes_error << "\n";
  EXPECT_LT(cvodes_error, kArmErrorGrowth * kGlobalErrorFactor * kArmRtol);

  const Trajectory rk4 = SimulateRk4(model, kArmX0, u, p, kArmDt, 1);
  const double rk4_error = rk4.ok ? ScaledError(rk4.x, reference.x) : INFINITY;
  std::cout << rk4.summary.BriefReport() << ", error " << rk4_error << "\n";
  EXPECT_GT(rk4_error, kRk4WrongError);

  // RK4 substeps (powers of two) needed to be as accurate as CVODES.
  int substeps = 1;
  double error = rk4_error;
  while (!(error <= cvodes_error) && substeps < 256) {
    substeps *= 2;
    const Trajectory t = SimulateRk4(model, kArmX0, u, p, kArmDt, substeps);
    error = t.ok ? ScaledError(t.x, reference.x) : INFINITY;
    std::cout << "  rk4 with " << substeps << " substeps: error " << error << "\n";
  }
  EXPECT_GE(substeps, 16);
}

// ---- factory and options ---------------------------------------------------------------------

TEST(Integrators, FactoryPicksTheMethod) {
  const models::StateSpaceModel model = DuffingModel();
  IntegratorOptions o;
  o.fixed_step.substeps = 3;
  EXPECT_EQ(MakeIntegrator(model, 0.01, o)->Name(), "rk4 (3 substeps)");
  o.fixed_step = {StepScheme::kRadauIIA, 1, 2};
  EXPECT_EQ(MakeIntegrator(model, 0.01, o)->Name(), "radau_iia (1 substep, 2 newton iterations)");
  o.method = IntegrationMethod::kCvodes;
  EXPECT_EQ(MakeIntegrator(model, 0.01, o)->Name(), "cvodes bdf (dense)");
  o.cvodes.linear_solver = CvodesOptions::LinearSolver::kKlu;
  const auto klu = MakeIntegrator(model, 0.01, o);
  EXPECT_EQ(klu->Name(), "cvodes bdf (klu)");
  EXPECT_EQ(klu->dt(), 0.01);
  EXPECT_EQ(ParseIntegrationMethod("cvodes"), IntegrationMethod::kCvodes);
  EXPECT_EQ(ParseIntegrationMethod(IntegrationMethodName(IntegrationMethod::kFixedStep)),
            IntegrationMethod::kFixedStep);
  EXPECT_EQ(IntegrationMethodName(IntegrationMethod::kFixedStep), std::string("fixed_step"));
  try {
    ParseIntegrationMethod("cvode");
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'cvodes'"), std::string::npos) << e.what();
  }
}

void ExpectInvalid(const std::function<void()>& f, const std::string& fragment) {
  try {
    f();
    ADD_FAILURE() << "expected std::invalid_argument containing '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(Integrators, InvalidOptionsAndArgumentsAreExplained) {
  const models::StateSpaceModel model = DuffingModel();
  CvodesOptions o;
  o.relative_tolerance = 0.0;
  ExpectInvalid([&] { o.Validate(); }, "relative_tolerance: expected a finite value > 0, got 0");
  o = CvodesOptions();
  o.max_order = 6;
  ExpectInvalid([&] { o.Validate(); }, "max_order: expected 1..5");
  o = CvodesOptions();
  o.pass_through["max_stpe"] = 1e-3;
  ExpectInvalid([&] { o.Validate(); },
                "unknown CVODES option 'max_stpe'; did you mean 'max_step'?");
  o = CvodesOptions();
  o.pass_through["max_nonlin_iters"] = 2.5;
  ExpectInvalid([&] { o.Validate(); }, "expected an integer");
  o = CvodesOptions();
  o.absolute_tolerances = Eigen::Vector3d(1, 1, 1);
  ExpectInvalid([&] { CvodesIntegrator(model, 0.01, o); }, "expected 2 entries");
  ExpectInvalid([&] { CvodesIntegrator(model, 0.0); }, "dt > 0");
  ExpectInvalid([&] { FixedStepIntegrator(model, 0.01, Rk4(0)); },
                "FixedStepOptions.substeps: expected >= 1, got 0");
  IntegratorOptions io;
  io.fixed_step.substeps = 0;
  ExpectInvalid([&] { MakeIntegrator(model, 0.01, io); }, "FixedStepOptions.substeps");

  const CvodesIntegrator integrator(model, 0.01);
  const Eigen::MatrixXd u = DuffingInput(5, 0.01);
  const Eigen::VectorXd p = model.ParameterValues();
  ExpectInvalid([&] { integrator.Simulate(Eigen::VectorXd::Zero(3), u, p); },
                "expected x0 of size 2");
  ExpectInvalid([&] { integrator.Simulate(Eigen::VectorXd::Zero(2), Eigen::MatrixXd(0, 1), p); },
                "at least one row");
  ExpectInvalid(
      [&] {
        integrator.SimulateWithSensitivities(Eigen::VectorXd::Zero(2), u, p, {0, 0});
      },
      "got 0 twice");
  ExpectInvalid([&] { integrator.SimulateWithSensitivities(Eigen::VectorXd::Zero(2), u, p, {3}); },
                "in [0, 3), got 3");
}

}  // namespace
}  // namespace graybox::estimators
