// The transmission and drive blocks (drives.h) against closed forms: two-mass modes and momentum,
// the backlash dead zone, gear torque and reflected inertia, DC motor steady state, the delay's
// step and frequency responses, exact pass-through at neutral values, option checking, and
// derivatives in scaled coordinates.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "graybox/expr/derivative_check.h"
#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/drives.h"
#include "graybox/models/kuka_kr300.h"
#include "graybox/models/model.h"
#include "graybox/models/transmission_effects.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using expr::Expr;

// Evaluations of the same closed form by different exact routes agree to a few ulps.
constexpr double kRoundoff = 1e-13;

std::unique_ptr<Block> Make(const std::string& type, const BlockOptions& options = {}) {
  return BlockRegistry::Global().Create(type, options);
}

int ParameterIndex(const Block& b, const std::string& name) {
  for (int i = 0; i < b.NumParameters(); ++i) {
    if (b.info().parameters[i].name == name) return i;
  }
  throw std::invalid_argument("no parameter '" + name + "' in " + b.info().type);
}

VectorXd Parameters(const Block& b, const std::map<std::string, double>& values = {}) {
  const std::vector<double> nominal = b.NominalParameters();
  VectorXd p = Eigen::Map<const VectorXd>(nominal.data(), static_cast<int>(nominal.size()));
  for (const auto& [name, value] : values) p[ParameterIndex(b, name)] = value;
  return p;
}

struct Evaluation {
  VectorXd xdot, y;
};

Evaluation Evaluate(const Block& b, const VectorXd& x, const VectorXd& u, const VectorXd& p) {
  Evaluation e{VectorXd::Zero(b.NumStates()), VectorXd::Zero(b.NumOutputs())};
  b.Evaluate(BlockArgs<double>{x.data(), u.data(), p.data(), e.xdot.data(), e.y.data()});
  return e;
}

VectorXd Scalar1(double v) { return VectorXd::Constant(1, v); }

// One classical RK4 step of the block's states with the input held at u.
VectorXd Rk4Step(const Block& b, const VectorXd& x, const VectorXd& u, const VectorXd& p,
                 double h) {
  auto f = [&](const VectorXd& xs) { return Evaluate(b, xs, u, p).xdot; };
  const VectorXd k1 = f(x);
  const VectorXd k2 = f(x + 0.5 * h * k1);
  const VectorXd k3 = f(x + 0.5 * h * k2);
  const VectorXd k4 = f(x + h * k3);
  return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

// State-space matrices of a block that is affine in (x, u) at parameters p, read off by
// evaluating at unit vectors (exact for affine blocks).
struct Linear {
  MatrixXd A, B, C, D;
};
Linear Linearise(const Block& b, const VectorXd& p) {
  const int n = b.NumStates(), m = b.NumInputs(), r = b.NumOutputs();
  const VectorXd x0 = VectorXd::Zero(n), u0 = VectorXd::Zero(m);
  const Evaluation e0 = Evaluate(b, x0, u0, p);
  Linear l{MatrixXd(n, n), MatrixXd(n, m), MatrixXd(r, n), MatrixXd(r, m)};
  for (int j = 0; j < n; ++j) {
    const Evaluation e = Evaluate(b, VectorXd::Unit(n, j), u0, p);
    l.A.col(j) = e.xdot - e0.xdot;
    l.C.col(j) = e.y - e0.y;
  }
  for (int j = 0; j < m; ++j) {
    const Evaluation e = Evaluate(b, x0, VectorXd::Unit(m, j), p);
    l.B.col(j) = e.xdot - e0.xdot;
    l.D.col(j) = e.y - e0.y;
  }
  return l;
}

// ---- drive.two_mass -----------------------------------------------------------------------------

TEST(TwoMass, NominalValuesAreTheSeedsConstants) {
  const auto block = Make(kTwoMassDrive);
  const VectorXd p = Parameters(*block);
  EXPECT_EQ(p[ParameterIndex(*block, "J")], 1e-4);
  EXPECT_EQ(p[ParameterIndex(*block, "I")], 1.4e-3);
  EXPECT_EQ(p[ParameterIndex(*block, "Ke")], 8.459);
  EXPECT_EQ(block->NumParameters(), 4) << "no backlash parameter by default";
}

// Linearised: a double eigenvalue 0 (rigid-body motion) and the joint mode. Undamped the mode is
// +-i omega_n with omega_n = sqrt(Ke (1/J + 1/I)); damped its eigenvalues solve
// lambda^2 + d (1/J + 1/I) lambda + Ke (1/J + 1/I) = 0.
TEST(TwoMass, ModesOfTheLinearisedDynamics) {
  const auto block = Make(kTwoMassDrive);
  constexpr double kJ = 1e-4, kI = 1.4e-3, kKe = 8.459;
  const double inverse_inertia = 1.0 / kJ + 1.0 / kI;
  // Eigenvalues of a 4x4 with entries ~1e5: |error| ~ 1e-16 * ||A|| ~ 1e-11; the double zero
  // is defective (a Jordan block), so it is perturbed by ~sqrt(1e-16 ||A||) ~ 3e-6.
  constexpr double kEigenTolerance = 1e-9;  // relative, for the joint mode
  constexpr double kRigidModeTolerance = 1e-4;
  for (double d : {0.0, 0.02}) {
    const Linear l = Linearise(*block, Parameters(*block, {{"d", d}}));
    const Eigen::VectorXcd lambda = Eigen::EigenSolver<MatrixXd>(l.A).eigenvalues();
    const std::complex<double> expected =
        0.5 * (-d * inverse_inertia +
               std::sqrt(std::complex<double>(d * d * inverse_inertia * inverse_inertia -
                                              4.0 * kKe * inverse_inertia)));
    int rigid = 0, mode = 0;
    for (int i = 0; i < lambda.size(); ++i) {
      if (std::abs(lambda[i]) < kRigidModeTolerance) {
        ++rigid;
      } else if (std::abs(lambda[i] - expected) < kEigenTolerance * std::abs(expected) ||
                 std::abs(lambda[i] - std::conj(expected)) < kEigenTolerance * std::abs(expected)) {
        ++mode;
      }
    }
    EXPECT_EQ(rigid, 2) << "d = " << d << ", eigenvalues " << lambda.transpose();
    EXPECT_EQ(mode, 2) << "d = " << d << ", eigenvalues " << lambda.transpose();
    if (d == 0.0) {
      EXPECT_NEAR(std::abs(expected), std::sqrt(kKe * inverse_inertia), 1e-9);
    }
  }
  // 301 rad/s (47.9 Hz) at the seed's constants, as drives.h states.
  EXPECT_NEAR(std::sqrt(kKe * inverse_inertia), 301.05, 0.01);
}

// Free motion from a deflection: delta(t) = delta0 cos(omega_n t) and the momentum J qd_m + I qd_l
// stays 0 (RK4 conserves linear invariants up to rounding).
TEST(TwoMass, FreeOscillationAndMomentum) {
  const auto block = Make(kTwoMassDrive);
  const VectorXd p = Parameters(*block);
  const double omega_n = std::sqrt(8.459 * (1.0 / 1e-4 + 1.0 / 1.4e-3));
  constexpr double kDelta0 = 0.01;
  VectorXd x(4);
  x << kDelta0, 0.0, 0.0, 0.0;
  const VectorXd u = VectorXd::Zero(2);
  const double h = 1e-6;
  // Global RK4 error ~ t omega^5 h^4 / 120 = 1.2e-14 per unit of delta at t = 0.05 s.
  constexpr double kOscillationTolerance = 1e-12;
  for (int step = 1; step <= 50000; ++step) {
    x = Rk4Step(*block, x, u, p, h);
    if (step % 5000 == 0) {
      const double t = step * h;
      EXPECT_NEAR(x[0] - x[2], kDelta0 * std::cos(omega_n * t), kOscillationTolerance) << t;
      const double momentum = 1e-4 * x[1] + 1.4e-3 * x[3];
      // Rounding only: |J qd_m| <= 3e-4 kg m^2/s, 5e4 steps of relative 1e-16 each.
      EXPECT_NEAR(momentum, 0.0, 1e-14) << t;
    }
  }
}

TEST(TwoMass, OutputsTheStatesAndTheJointTorque) {
  const auto block = Make(kTwoMassDrive);
  const VectorXd p = Parameters(*block, {{"d", 0.01}});
  VectorXd x(4);
  x << 0.3, 2.0, 0.25, -1.0;
  const Evaluation e = Evaluate(*block, x, Eigen::Vector2d(0.2, -0.1), p);
  const double tau_s = 8.459 * 0.05 + 0.01 * 3.0;
  for (int i = 0; i < 4; ++i) EXPECT_EQ(e.y[i], x[i]);
  EXPECT_NEAR(e.y[4], tau_s, kRoundoff);
  EXPECT_NEAR(e.xdot[1], (0.2 - tau_s) / 1e-4, kRoundoff * 1e4);
  EXPECT_NEAR(e.xdot[3], (tau_s - 0.1) / 1.4e-3, kRoundoff * 1e3);
}

// With the backlash option no torque passes inside the gap, and outside it the spring sees the
// deflection minus the gap; at b = 0 it is the plain two-mass block exactly.
TEST(TwoMass, BacklashInTheJoint) {
  BlockOptions options;
  options.numbers["backlash"] = {1};
  const auto with = Make(kTwoMassDrive, options);
  const auto without = Make(kTwoMassDrive);
  constexpr double kB = 2e-3, kD = 0.01;
  const VectorXd p = Parameters(*with, {{"d", kD}, {"b", kB}});
  VectorXd x(4);
  const VectorXd u = Eigen::Vector2d(0.1, 0.0);
  // Inside, at delta = b/2: DZ = eps^2/(3b) + O(eps^4) and DZ' < 0.01, so
  // |tau_s| <= Ke eps^2/b + d 0.01 |delta_dot|.
  constexpr double kEps = kDefaultBacklashSmoothing;
  x << 1e-3, 0.5, 0.0, 0.0;
  EXPECT_LT(std::fabs(Evaluate(*with, x, u, p).y[4]), 8.459 * kEps * kEps / kB + kD * 0.5 * 0.01);
  // Outside: Ke (delta - b) + d delta_dot to within Ke eps^2 b / (2 (delta^2 - b^2)).
  x << 0.02, 0.5, 0.0, 0.0;
  const double delta = 0.02;
  const double tolerance = 8.459 * kEps * kEps * kB / (2.0 * (delta * delta - kB * kB)) + 1e-7;
  EXPECT_NEAR(Evaluate(*with, x, u, p).y[4], 8.459 * (delta - kB) + kD * 0.5, tolerance);
  // b = 0: identical to the block without backlash (DZ(x) = x and DZ' = 1 exactly).
  VectorXd p0 = p;
  p0[ParameterIndex(*with, "b")] = 0.0;
  const VectorXd p_plain = Parameters(*without, {{"d", kD}});
  for (double q_m : {-0.3, 0.001, 0.2}) {
    x << q_m, 0.4, 0.01, -0.2;
    const Evaluation a = Evaluate(*with, x, u, p0), b = Evaluate(*without, x, u, p_plain);
    EXPECT_EQ(a.y[4], b.y[4]);
    EXPECT_EQ(a.xdot[1], b.xdot[1]);
  }
}

// ---- drive.backlash -----------------------------------------------------------------------------

TEST(Backlash, NeutralGapIsAnExactPassThrough) {
  const auto block = Make(kBacklashDrive);
  ASSERT_EQ(block->info().parameters[0].neutral, 0.0);
  std::mt19937 rng(testing::TestSeed());
  for (int k = 0; k < 100; ++k) {
    const double delta = testing::Uniform(rng, -0.1, 0.1);
    EXPECT_EQ(Evaluate(*block, {}, Scalar1(delta), Scalar1(0.0)).y[0], delta);
  }
}

TEST(Backlash, SmoothDeadZone) {
  const auto block = Make(kBacklashDrive);
  constexpr double kB = 2e-3, kEps = kDefaultBacklashSmoothing;
  auto dz = [&](double delta) { return Evaluate(*block, {}, Scalar1(delta), Scalar1(kB)).y[0]; };
  // Inside the gap the slope is at most 1 - b / sqrt(b^2 + eps^2) + O(eps^2/(b - |delta|)^2)
  // (1.3e-3 and 1e-2 at |delta| = b/2): the output stays below 2e-2 |delta|.
  for (double delta : {-1e-3, -1e-4, 0.0, 5e-4, 1e-3}) {
    EXPECT_LE(std::fabs(dz(delta)), 2e-2 * std::fabs(delta)) << delta;
  }
  // Outside: delta -+ b to within eps^2 b / (2 (delta^2 - b^2)) (plus rounding).
  for (double delta : {-0.05, -0.01, 0.005, 0.02, 0.05}) {
    const double expected = delta - (delta > 0 ? kB : -kB);
    const double tolerance = kEps * kEps * kB / (2.0 * (delta * delta - kB * kB)) + 1e-17;
    EXPECT_NEAR(dz(delta), expected, tolerance) << delta;
    EXPECT_EQ(dz(-delta), -dz(delta)) << "odd";
  }
  // Monotone.
  double previous = dz(-0.01);
  for (int k = 1; k <= 400; ++k) {
    const double value = dz(-0.01 + k * 5e-5);
    EXPECT_GE(value, previous);
    previous = value;
  }
}

TEST(Backlash, SmoothingOption) {
  BlockOptions options;
  options.numbers["smoothing"] = {1e-6};
  const auto sharp = Make(kBacklashDrive, options);
  // delta_eff = delta - b + eps^2 b / (2 (delta^2 - b^2)) + O(eps^4): the leading term to 1e-3.
  constexpr double kEps = 1e-6, kB = 2e-3, kDelta = 4e-3;
  const double leading = kEps * kEps * kB / (2.0 * (kDelta * kDelta - kB * kB));
  EXPECT_NEAR(Evaluate(*sharp, {}, Scalar1(kDelta), Scalar1(kB)).y[0] - (kDelta - kB), leading,
              1e-3 * leading);
  options.numbers["smoothing"] = {-1.0};
  EXPECT_THROW(Make(kBacklashDrive, options), std::invalid_argument);
  BlockOptions two_mass;
  two_mass.numbers["smoothing"] = {1e-5};
  EXPECT_THROW(Make(kTwoMassDrive, two_mass), std::invalid_argument) << "smoothing w/o backlash";
}

// ---- drive.gear ---------------------------------------------------------------------------------

TEST(Gear, TorqueSpeedAndReflectedInertia) {
  const auto block = Make(kGearDrive);
  constexpr double kN = 100.0, kEta = 0.9, kJm = 0.01;
  const VectorXd p = Eigen::Vector3d(kN, kEta, kJm);
  const Evaluation e = Evaluate(*block, {}, Eigen::Vector3d(5.0, 1.5, 0.0), p);
  EXPECT_NEAR(e.y[0], kEta * kN * 5.0, kRoundoff * 500.0);
  EXPECT_NEAR(e.y[1], kN * 1.5, kRoundoff * 150.0);
  // Accelerating the joint with no motor torque costs eta N^2 J_m qdd.
  const Evaluation a = Evaluate(*block, {}, Eigen::Vector3d(0.0, 0.0, 2.0), p);
  EXPECT_NEAR(a.y[0], -kEta * kN * kN * kJm * 2.0, kRoundoff * 200.0);
}

TEST(Gear, NeutralValuesAreAnExactPassThrough) {
  const auto block = Make(kGearDrive);
  VectorXd p(3);
  for (int i = 0; i < 3; ++i) p[i] = block->info().parameters[i].neutral;
  EXPECT_EQ(p, Eigen::Vector3d(1.0, 1.0, 0.0));
  std::mt19937 rng(testing::TestSeed());
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d u(testing::Uniform(rng, -20, 20), testing::Uniform(rng, -2, 2),
                            testing::Uniform(rng, -10, 10));
    const Evaluation e = Evaluate(*block, {}, u, p);
    EXPECT_EQ(e.y[0], u[0]);
    EXPECT_EQ(e.y[1], u[1]);
  }
}

TEST(Gear, JointOptionSelectsTheKukaValues) {
  for (int joint = 1; joint <= kKukaDof; ++joint) {
    BlockOptions options;
    options.numbers["joint"] = {static_cast<double>(joint)};
    const VectorXd p = Parameters(*Make(kGearDrive, options));
    const auto j = static_cast<std::size_t>(joint - 1);
    EXPECT_EQ(p[0], kKukaGearRatios[j]);
    EXPECT_EQ(p[2], kKukaMotorInertias[j]);
  }
}

// ---- drive.dc_motor -----------------------------------------------------------------------------

TEST(DcMotor, NominalValuesAreTheSeedsTable5) {
  const auto block = Make(kDcMotorDrive);
  const std::map<std::string, double> table5 = {
      {"J_rs", 0.001}, {"J_os", 0.0379}, {"B_rs", 1.2539}, {"B_os", 0.3532}, {"Km", 0.6585},
      {"L", 0.001},    {"R", 1.3798},    {"Kb", 0.3938},   {"N", 10.0}};
  const VectorXd p = Parameters(*block);
  for (const auto& [name, value] : table5) EXPECT_EQ(p[ParameterIndex(*block, name)], value);
  EXPECT_TRUE(block->info().stiff);
}

// Constant voltage and load: omega_ss = (N Km u - R tau_load) / (R B + N^2 Km Kb) with
// B = B_os + N^2 B_rs, i_ss = (u - Kb N omega_ss) / R. Checked as an equilibrium (xdot = 0) and
// as the limit of a simulation from rest.
TEST(DcMotor, SteadyStateSpeedForConstantVoltage) {
  BlockOptions options;
  options.numbers["load_input"] = {1};
  const auto block = Make(kDcMotorDrive, options);
  ASSERT_EQ(block->NumStates(), 3);
  ASSERT_EQ(block->NumInputs(), 2);
  // A motor that reaches the measured ~30 rad/s at 12 V (mechanical time constant 23 ms), and
  // the seed's Table 5 values (eigenvalues -1146 +- 365i 1/s).
  const std::vector<VectorXd> parameter_sets = {Parameters(*block, {{"Kb", 0.035},
                                                                    {"Km", 0.035},
                                                                    {"J_rs", 1e-5},
                                                                    {"J_os", 1e-3},
                                                                    {"B_rs", 1e-5},
                                                                    {"B_os", 1e-3}}),
                                                Parameters(*block)};
  for (const VectorXd& p : parameter_sets) {
    const double L = p[0], R = p[1], kb = p[2], km = p[3], n = p[4];
    const double b = p[8] + n * n * p[7];
    for (double u : {3.0, 12.0}) {
      for (double load : {0.0, 0.05}) {
        const double omega = (n * km * u - R * load) / (R * b + n * n * km * kb);
        const double i = (u - kb * n * omega) / R;
        const Evaluation e =
            Evaluate(*block, Eigen::Vector3d(i, omega, 7.0), Eigen::Vector2d(u, load), p);
        // Cancellations of terms of size u / L and N Km i / J: relative rounding.
        EXPECT_NEAR(e.xdot[0], 0.0, kRoundoff * u / L);
        EXPECT_NEAR(e.xdot[1], 0.0, kRoundoff * 1e3);
        EXPECT_EQ(e.xdot[2], omega);
        EXPECT_EQ(e.y[0], 7.0);
        EXPECT_EQ(e.y[1], omega);
        EXPECT_EQ(e.y[2], i);
        // Simulation from rest: the slowest eigenvalue is below -40 1/s for both sets, so after
        // 1 s the transient is below exp(-40); RK4 at h = 2e-5 s is stable (|lambda| h < 0.03).
        VectorXd x = VectorXd::Zero(3);
        for (int step = 0; step < 50000; ++step) {
          x = Rk4Step(*block, x, Eigen::Vector2d(u, load), p, 2e-5);
        }
        constexpr double kSteadyStateTolerance = 1e-9;  // relative
        EXPECT_NEAR(x[1], omega, kSteadyStateTolerance * std::fabs(omega)) << u << " V";
        EXPECT_NEAR(x[0], i, kSteadyStateTolerance * (std::fabs(i) + 1e-3)) << u << " V";
      }
    }
  }
}

TEST(DcMotor, EquationsOfTheSeed) {
  const auto block = Make(kDcMotorDrive);
  const VectorXd p = Parameters(*block);
  const double L = p[0], R = p[1], kb = p[2], km = p[3], n = p[4];
  const double j = p[6] + n * n * p[5], b = p[8] + n * n * p[7];
  const Eigen::Vector3d x(1.2, 20.0, 3.0);
  const Evaluation e = Evaluate(*block, x, Scalar1(9.0), p);
  EXPECT_NEAR(e.xdot[0], (9.0 - kb * n * 20.0 - R * 1.2) / L, kRoundoff * 1e5);  // eq. 31
  EXPECT_NEAR(e.xdot[1], (n * km * 1.2 - b * 20.0) / j, kRoundoff * 1e5);        // eq. 33-34
  EXPECT_EQ(e.xdot[2], 20.0);
}

TEST(DcMotor, Options) {
  BlockOptions options;
  options.numbers["angle_state"] = {0};
  const auto block = Make(kDcMotorDrive, options);
  EXPECT_EQ(block->NumStates(), 2);
  EXPECT_EQ(block->NumInputs(), 1);
  ASSERT_EQ(block->NumOutputs(), 2);
  EXPECT_EQ(block->info().outputs[0].name, "omega");
  EXPECT_EQ(block->info().outputs[1].name, "i");
  options.numbers["angle_state"] = {2};
  EXPECT_THROW(Make(kDcMotorDrive, options), std::invalid_argument);
  BlockOptions typo;
  typo.numbers["load_inpt"] = {1};
  try {
    Make(kDcMotorDrive, typo);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'load_input'"), std::string::npos)
        << e.what();
  }
}

// ---- delay.first_order --------------------------------------------------------------------------

TEST(Delay, NeutralWeightIsAnExactPassThrough) {
  for (const char* form : {"lag", "pade"}) {
    BlockOptions options;
    options.words["form"] = form;
    const auto block = Make(kFirstOrderDelay, options);
    ASSERT_EQ(block->info().parameters[1].name, "w");
    ASSERT_EQ(block->info().parameters[1].neutral, 0.0);
    EXPECT_FALSE(block->info().parameters[0].HasNeutral());
    std::mt19937 rng(testing::TestSeed());
    for (int k = 0; k < 50; ++k) {
      const double u = testing::Uniform(rng, -5.0, 5.0), x = testing::Uniform(rng, -5.0, 5.0);
      const double T = testing::Uniform(rng, 1e-3, 1.0);
      EXPECT_EQ(Evaluate(*block, Scalar1(x), Scalar1(u), Eigen::Vector2d(T, 0.0)).y[0], u);
    }
  }
}

// Step from x(0) = 0: y(t) = u (1 - w exp(-t/T)).
TEST(Delay, StepResponse) {
  const auto block = Make(kFirstOrderDelay);
  constexpr double kT = 0.01, kU = 2.0;
  for (double w : {1.0, 0.5, 2.0}) {
    const VectorXd p = Eigen::Vector2d(kT, w);
    VectorXd x = VectorXd::Zero(1);
    EXPECT_EQ(Evaluate(*block, x, Scalar1(kU), p).y[0], kU * (1.0 - w));
    const double h = kT / 1000.0;
    for (int step = 1; step <= 3000; ++step) {
      x = Rk4Step(*block, x, Scalar1(kU), p, h);
      if (step % 1000 == 0) {
        const double t = step * h;
        // RK4 truncation with h/T = 1e-3 is ~3000 * 1e-15 / 120; the rounding of 3000 steps
        // (a few 1e-16 |x| each, times w) dominates.
        constexpr double kStepResponseTolerance = 1e-11;
        EXPECT_NEAR(Evaluate(*block, x, Scalar1(kU), p).y[0], kU * (1.0 - w * std::exp(-t / kT)),
                    kStepResponseTolerance)
            << "w = " << w << ", t = " << t;
      }
    }
  }
}

// G(s) = D + C (s - A)^-1 B: |G(i omega)| = 1 for Pade (w = 2) and a low-frequency delay of
// -arg G(i omega) / omega -> w T.
TEST(Delay, FrequencyResponse) {
  BlockOptions options;
  options.words["form"] = "pade";
  const auto block = Make(kFirstOrderDelay, options);
  EXPECT_EQ(Parameters(*block)[1], 2.0);
  constexpr double kT = 0.01;
  for (double w : {2.0, 1.0, 0.3}) {
    const Linear l = Linearise(*block, Eigen::Vector2d(kT, w));
    auto g = [&](double omega) {
      return l.D(0, 0) + l.C(0, 0) * l.B(0, 0) / (std::complex<double>(0.0, omega) - l.A(0, 0));
    };
    if (w == 2.0) {
      for (double omega : {1.0, 100.0, 1e4}) EXPECT_NEAR(std::abs(g(omega)), 1.0, 1e-14);
    }
    // -arg G / omega = w T + O((omega T)^2): at omega T = 1e-3 within 1e-6 relative.
    const double omega = 1e-3 / kT;
    EXPECT_NEAR(-std::arg(g(omega)) / omega, w * kT, 1e-6 * w * kT) << "w = " << w;
  }
}

TEST(Delay, Options) {
  BlockOptions options;
  options.words["form"] = "pde";
  try {
    Make(kFirstOrderDelay, options);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'pade'"), std::string::npos) << e.what();
  }
  BlockOptions unit;
  unit.words["unit"] = "N m";
  unit.numbers["typical_range"] = {-20.0, 20.0};
  const auto block = Make(kFirstOrderDelay, unit);
  EXPECT_EQ(block->info().inputs[0].unit, "N m");
  EXPECT_EQ(block->info().outputs[0].typical_max, 20.0);
  unit.numbers["typical_range"] = {20.0, -20.0};
  EXPECT_THROW(Make(kFirstOrderDelay, unit), std::invalid_argument);
}

// InsertOnSignal starts the delay at its neutral values: the model's outputs are unchanged.
TEST(Delay, InsertedAtNeutralLeavesAModelUnchanged) {
  Model plain("gear"), delayed("gear");
  for (Model* m : {&plain, &delayed}) {
    m->AddInput("tau_m", "N m", "motor torque", -20.0, 20.0);
    m->AddInput("qd", "rad/s", "joint speed", -2.0, 2.0);
    m->AddInput("qdd", "rad/s^2", "joint acceleration", -10.0, 10.0);
    m->AddBlock("gear", kGearDrive, {}, {"tau_m", "qd", "qdd"}, {"tau", "qd_m"});
    m->AddOutput("tau");
  }
  delayed.InsertOnSignal("tau_m", "delay", kFirstOrderDelay);
  const StateSpaceModel a = plain.Build(), b = delayed.Build();
  ASSERT_EQ(b.NumStates(), 1);
  const Eigen::Vector3d u(7.5, 0.3, -2.0);
  const VectorXd ya = a.output({VectorXd(0), u, a.ParameterValues()})[0];
  const VectorXd yb = b.output({Scalar1(-3.0), u, b.ParameterValues()})[0];
  EXPECT_EQ(ya[0], yb[0]);
}

// ---- All drive blocks ---------------------------------------------------------------------------

std::vector<std::string> DriveTypes() {
  std::vector<std::string> types;
  for (const auto& t : BlockRegistry::Global().Types()) {
    if (t.rfind("drive.", 0) == 0 || t.rfind("delay.", 0) == 0) types.push_back(t);
  }
  return types;
}

TEST(Drives, EveryBlockOfTheHeaderIsRegistered) {
  const std::vector<std::string> expected = {kTwoMassDrive, kBacklashDrive, kGearDrive,
                                             kDcMotorDrive, kFirstOrderDelay};
  const std::vector<std::string> types = DriveTypes();
  for (const auto& t : expected) {
    EXPECT_NE(std::find(types.begin(), types.end(), t), types.end()) << t;
  }
  EXPECT_EQ(types.size(), expected.size());
}

TEST(Drives, DerivativesMatchFiniteDifferencesInScaledCoordinates) {
  for (const std::string& type : DriveTypes()) {
    testing::ExpectBlockDerivativesMatch(*Make(type, BlockRegistry::Global().TestOptions(type)),
                                         testing::TestSeed());
    testing::ExpectBlockDerivativesMatch(*Make(type), testing::TestSeed());
  }
  BlockOptions motor;
  motor.numbers["angle_state"] = {0};
  motor.numbers["load_input"] = {1};
  testing::ExpectBlockDerivativesMatch(*Make(kDcMotorDrive, motor), testing::TestSeed());
}

// transmission.backlash added to a joint without backlash equals the joint with backlash.
TEST(BacklashCorrection, TurnsTheJointIntoItsBacklashForm) {
  auto joint = [](bool backlash) {
    Model m("joint");
    m.AddInput("tau", "N m", "motor torque", -0.4, 0.4);
    m.AddInput("load", "N m", "load torque", -0.4, 0.4);
    BlockOptions o;
    if (backlash) o.numbers["backlash"] = {1};
    m.AddBlock("joint", kTwoMassDrive, o, {"tau", "load"}, {"", "", "", "", "torque"});
    m.SetParameter("joint.d", 0.02);
    m.AddOutput("joint.q_l");
    m.AddOutput("torque");  // the joint torque a sensor in the spring measures
    return m;
  };
  Model with = joint(true);
  with.SetParameter("joint.b", 0.01);
  Model added = joint(false);
  BlockOptions c;
  c.numbers["stiffness"] = {added.Parameter("joint.Ke").value};
  c.numbers["damping"] = {0.02};
  added.Augment("backlash", kBacklashCorrection, c,
                {"joint.q_m", "joint.q_l", "joint.qd_m", "joint.qd_l"}, {"-tau", "load", "torque"});
  EXPECT_EQ(added.Parameter("backlash.b").value, 0.0);  // neutral
  const StateSpaceModel base = joint(false).Build();
  const StateSpaceModel neutral = added.Build();
  added.SetParameter("backlash.b", 0.01);
  const StateSpaceModel a = added.Build(), b = with.Build();
  // Inside the gap, at its edge and beyond; moving in both directions.
  constexpr double kRounding = 1e-12;  // the same terms summed in another order
  for (const double delta : {0.0, 0.004, 0.0101, -0.03}) {
    const Eigen::Vector4d x(0.1 + delta, 1.5, 0.1, -0.7);
    const Eigen::Vector2d u(0.2, -0.1);
    const Eigen::VectorXd fa = a.dynamics({x, u, a.ParameterValues()})[0];
    const Eigen::VectorXd fb = b.dynamics({x, u, b.ParameterValues()})[0];
    EXPECT_LE((fa - fb).lpNorm<Eigen::Infinity>(), kRounding * fb.lpNorm<Eigen::Infinity>())
        << "delta " << delta;
    // The reported joint torque too (tau_joint added to the joint's tau_s).
    const Eigen::VectorXd ya = a.output({x, u, a.ParameterValues()})[0];
    const Eigen::VectorXd yb = b.output({x, u, b.ParameterValues()})[0];
    EXPECT_LE((ya - yb).lpNorm<Eigen::Infinity>(), kRounding * yb.lpNorm<Eigen::Infinity>())
        << "delta " << delta;
    const Eigen::VectorXd f0 = base.dynamics({x, u, base.ParameterValues()})[0];
    const Eigen::VectorXd fn = neutral.dynamics({x, u, neutral.ParameterValues()})[0];
    EXPECT_EQ(fn, f0) << "delta " << delta;  // b = 0: exactly the joint without backlash
  }
}

}  // namespace
}  // namespace graybox::models
