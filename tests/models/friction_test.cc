// The friction blocks (friction.h) against closed forms: Stribeck limits, LuGre steady state and
// transient, Dahl hysteresis loop, the continuous form of the Staubli dry friction against the
// seed's discrete updates, KUKA friction against kuka_kr300.h, zero torque at neutral values,
// option checking, and derivatives of the option variants the shared suite does not instantiate.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/derivative_check.h"
#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/friction.h"
#include "graybox/models/kuka_kr300.h"
#include "graybox/models/model.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using Eigen::VectorXd;
using expr::Expr;

// Evaluations of the same closed form by different but exact routes (a tanh saturated to 1.0, a
// product by an exact 1.0) agree to a few ulps of the torque.
constexpr double kRoundoff = 1e-13;
constexpr double kPi = 3.14159265358979323846;

std::unique_ptr<Block> Make(const std::string& type, const BlockOptions& options = {}) {
  return BlockRegistry::Global().Create(type, options);
}

int ParameterIndex(const Block& b, const std::string& name) {
  for (int i = 0; i < b.NumParameters(); ++i) {
    if (b.info().parameters[i].name == name) return i;
  }
  throw std::invalid_argument("no parameter '" + name + "' in " + b.info().type);
}

// Nominal parameters with some replaced by name.
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

double Output(const Block& b, const VectorXd& x, const VectorXd& u, const VectorXd& p) {
  return Evaluate(b, x, u, p).y[0];
}

VectorXd Scalar1(double v) { return VectorXd::Constant(1, v); }

// One classical RK4 step of the block's states with the input u(t) evaluated at the stages.
using InputFunction = std::function<VectorXd(double)>;
VectorXd Rk4Step(const Block& b, double t, const VectorXd& x, const InputFunction& u,
                 const VectorXd& p, double h) {
  auto f = [&](double s, const VectorXd& xs) { return Evaluate(b, xs, u(s), p).xdot; };
  const VectorXd k1 = f(t, x);
  const VectorXd k2 = f(t + 0.5 * h, x + 0.5 * h * k1);
  const VectorXd k3 = f(t + 0.5 * h, x + 0.5 * h * k2);
  const VectorXd k4 = f(t + h, x + h * k3);
  return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

std::vector<std::string> FrictionTypes() {
  std::vector<std::string> types;
  for (const auto& t : BlockRegistry::Global().Types()) {
    if (t.rfind("friction.", 0) == 0) types.push_back(t);
  }
  return types;
}

TEST(Friction, EveryBlockOfTheHeaderIsRegistered) {
  const std::vector<std::string> expected = {
      kViscousFriction,         kCoulombFriction,      kOffsetFriction, kAsymmetricFriction,
      kStribeckFriction,        kPowerViscousFriction, kDahlFriction,   kLuGreFriction,
      kTorqueDependentFriction, kRippleFriction,       kKukaFriction};
  const std::vector<std::string> types = FrictionTypes();
  for (const auto& t : expected) {
    EXPECT_NE(std::find(types.begin(), types.end(), t), types.end()) << t;
  }
  EXPECT_EQ(types.size(), expected.size());
}

// ---- Neutral values -----------------------------------------------------------------------------

// Adding a friction block at its neutral values adds zero torque: simulated from zero states
// under random inputs, the output is exactly 0 at every step (0 times anything finite is 0).
TEST(Friction, NeutralParametersGiveExactlyZeroTorque) {
  std::mt19937 rng(testing::TestSeed());
  for (const std::string& type : FrictionTypes()) {
    const auto block = Make(type, BlockRegistry::Global().TestOptions(type));
    VectorXd p = Parameters(*block);
    for (int i = 0; i < block->NumParameters(); ++i) {
      const ParameterInfo& par = block->info().parameters[i];
      if (par.HasNeutral()) p[i] = par.neutral;
    }
    // Piecewise-constant random inputs from the typical ranges.
    std::vector<VectorXd> levels;
    for (int k = 0; k < 20; ++k) {
      VectorXd u(block->NumInputs());
      for (int i = 0; i < u.size(); ++i) {
        const SignalInfo& s = block->info().inputs[static_cast<std::size_t>(i)];
        u[i] = testing::Uniform(rng, s.typical_min, s.typical_max);
      }
      levels.push_back(u);
    }
    constexpr double kStep = 1e-3;
    const InputFunction input = [&](double t) {
      return levels[std::min<std::size_t>(levels.size() - 1, static_cast<std::size_t>(t / 0.01))];
    };
    VectorXd x = VectorXd::Zero(block->NumStates());
    for (int step = 0; step < 200; ++step) {
      const double t = step * kStep;
      EXPECT_EQ(Output(*block, x, input(t), p), 0.0) << type << " at t = " << t;
      x = Rk4Step(*block, t, x, input, p, kStep);
    }
  }
}

TEST(Friction, EveryFrictionCoefficientIsNeutralAtZero) {
  for (const std::string& type : FrictionTypes()) {
    const auto block = Make(type, BlockRegistry::Global().TestOptions(type));
    int neutral = 0;
    for (const ParameterInfo& par : block->info().parameters) {
      if (par.HasNeutral()) {
        EXPECT_EQ(par.neutral, 0.0) << type << "." << par.name;
        ++neutral;
      }
    }
    EXPECT_GT(neutral, 0) << type;
  }
}

// ---- Static curves ------------------------------------------------------------------------------

TEST(Friction, ViscousAndOffset) {
  const auto viscous = Make(kViscousFriction);
  EXPECT_EQ(Output(*viscous, {}, Scalar1(3.0), Scalar1(0.25)), 0.75);
  const auto offset = Make(kOffsetFriction);
  EXPECT_EQ(Output(*offset, {}, Scalar1(-1.7), Scalar1(14.0625)), 14.0625);
  EXPECT_EQ(Output(*offset, {}, Scalar1(1.7), Scalar1(14.0625)), 14.0625);
}

// Beside a symmetric Coulomb-viscous term the forward and backward friction differ by 2 fd at
// speed and by 2 fvd per unit speed; at rest it is zero.
TEST(Friction, AsymmetricIsEvenInTheVelocityAndZeroAtRest) {
  BlockOptions o;
  o.numbers["steepness"] = {200.0};
  const auto asym = Make(kAsymmetricFriction, o);
  ASSERT_EQ(asym->NumParameters(), 3);
  const Eigen::Vector3d p(0.0, 3.0, 0.5);
  EXPECT_EQ(Output(*asym, {}, Scalar1(0.0), p), 0.0);
  EXPECT_EQ(Output(*asym, {}, Scalar1(0.0), Eigen::Vector3d(-1.25, 3.0, 0.5)), -1.25);
  for (const double qd : {0.001, 0.02, 0.7}) {
    const double t = std::tanh(200.0 * qd);
    EXPECT_NEAR(Output(*asym, {}, Scalar1(qd), p), 3.0 * t * t + 0.5 * qd * t, kRoundoff);
    EXPECT_NEAR(Output(*asym, {}, Scalar1(-qd), p), Output(*asym, {}, Scalar1(qd), p), kRoundoff);
  }
  // Fast enough that tanh is 1: forward 20 + 3 + (1 + 0.5) v, backward -(20 - 3) - (1 - 0.5) v.
  const double v = 0.7;
  const double forward = 20.0 + 1.0 * v + Output(*asym, {}, Scalar1(v), p);
  const double backward = -20.0 - 1.0 * v + Output(*asym, {}, Scalar1(-v), p);
  EXPECT_NEAR(forward, 23.0 + 1.5 * v, kRoundoff);
  EXPECT_NEAR(backward, -(17.0 + 0.5 * v), kRoundoff);
}

TEST(Friction, CoulombSteepnessIsAParameterUnlessFixedByTheOption) {
  const auto free = Make(kCoulombFriction);
  ASSERT_EQ(free->NumParameters(), 2);
  EXPECT_EQ(free->info().parameters[1].name, "steepness");
  EXPECT_EQ(free->info().parameters[1].nominal, kDefaultFrictionSteepness);
  BlockOptions fixed_options;
  fixed_options.numbers["steepness"] = {50.0};
  const auto fixed = Make(kCoulombFriction, fixed_options);
  ASSERT_EQ(fixed->NumParameters(), 1);
  for (double qd : {-0.3, -0.01, 0.0, 0.002, 0.05}) {
    const double expected = 0.02 * std::tanh(50.0 * qd);
    EXPECT_NEAR(Output(*free, {}, Scalar1(qd), Eigen::Vector2d(0.02, 50.0)), expected, kRoundoff);
    EXPECT_NEAR(Output(*fixed, {}, Scalar1(qd), Scalar1(0.02)), expected, kRoundoff);
  }
}

// Stribeck curve with a hump (fs > fc) and a sign steep enough to be exactly +-1 where tested.
class StribeckTest : public ::testing::Test {
 protected:
  static constexpr double kFc = 0.02, kFs = 0.05, kVs = 0.1, kFv = 0.01;
  StribeckTest() {
    BlockOptions options;
    options.numbers["steepness"] = {1e6};
    block_ = Make(kStribeckFriction, options);
    p_ = Parameters(*block_, {{"fc", kFc}, {"fs", kFs}, {"vs", kVs}, {"fv", kFv}});
  }
  double Tau(double qd) const { return Output(*block_, {}, Scalar1(qd), p_); }
  std::unique_ptr<Block> block_;
  VectorXd p_;
};

TEST_F(StribeckTest, StartsAtTheStaticLevel) {
  // At qd = vs/100 the curve is fs - (fs - fc)(qd/vs)^2 + fv qd + O(qd^4) (tanh(1e6 qd) is 1.0).
  constexpr double kQd = kVs / 100.0;
  const double expected = kFs - (kFs - kFc) * (kQd / kVs) * (kQd / kVs) + kFv * kQd;
  // The dropped terms are (fs - fc)(qd/vs)^4 / 2 = 1.5e-10 N m.
  constexpr double kTaylorTolerance = 2e-10;
  EXPECT_NEAR(Tau(kQd), expected, kTaylorTolerance);
  EXPECT_NEAR(Tau(-kQd), -expected, kTaylorTolerance);
  // tau(0+) -> fs: at qd = 1e-4 (tanh(100) is 1.0) only fv qd and (fs - fc)(qd/vs)^2 remain.
  EXPECT_NEAR(Tau(1e-4), kFs, kFv * 1e-4 + (kFs - kFc) * 1e-6);
}

TEST_F(StribeckTest, TendsToCoulombPlusViscous) {
  // exp(-(qd/vs)^2) underflows to 0 for qd >= 3 rad/s: exactly fc + fv qd.
  for (double qd : {3.0, 10.0, 20.0}) {
    EXPECT_NEAR(Tau(qd), kFc + kFv * qd, kRoundoff);
    EXPECT_NEAR(Tau(-qd), -(kFc + kFv * qd), kRoundoff);
  }
  // At qd = vs the Stribeck term is (fs - fc) / e.
  EXPECT_NEAR(Tau(kVs), kFc + (kFs - kFc) * std::exp(-1.0) + kFv * kVs, kRoundoff);
}

TEST_F(StribeckTest, OtherExponentsAreSmoothAtZero) {
  for (double exponent : {1.0, 1.5}) {
    BlockOptions options;
    options.numbers["steepness"] = {1e6};
    options.numbers["exponent"] = {exponent};
    const auto block = Make(kStribeckFriction, options);
    const double r = 0.7;
    // |r|^a is evaluated as (r^2 + 1e-6)^(a/2): relative error (a/2) 1e-6 / r^2 in the power.
    const double power = std::pow(r, exponent);
    const double expected = kFc + (kFs - kFc) * std::exp(-power) + kFv * r * kVs;
    constexpr double kSmoothingTolerance = 1e-7;  // (fs - fc) power (a/2) 1e-6 / r^2 < 5e-8
    EXPECT_NEAR(Output(*block, {}, Scalar1(r * kVs), p_), expected, kSmoothingTolerance);
    testing::ExpectBlockDerivativesMatch(*block, testing::TestSeed());
  }
}

TEST(Friction, StribeckNominalValuesAreTheSeedsCoulombStribeckColumn) {
  const auto block = Make(kStribeckFriction);
  const VectorXd p = Parameters(*block);
  EXPECT_EQ(p[ParameterIndex(*block, "fc")], 0.0145);
  EXPECT_EQ(p[ParameterIndex(*block, "fs")], 1.03e-5);
  EXPECT_EQ(p[ParameterIndex(*block, "vs")], 0.1677);
  EXPECT_EQ(p[ParameterIndex(*block, "fv")], 0.002);
}

TEST(Friction, PowerViscousFollowsThePowerLaw) {
  const auto block = Make(kPowerViscousFriction);
  // k = 1: exactly viscous ((qd^2 + eps^2)^0 = 1).
  for (double qd : {-250.0, -0.5, 0.0, 1e-4, 30.0}) {
    EXPECT_EQ(Output(*block, {}, Scalar1(qd), Eigen::Vector2d(0.01, 1.0)), 0.01 * qd);
  }
  // k = 0.5, 1.7: fv sign(qd) |qd|^k to within the smoothing, relative (k-1) eps^2 / (2 qd^2).
  for (double k : {0.5, 1.7}) {
    for (double qd : {-200.0, -2.0, 0.5, 40.0}) {
      const double expected = 0.01 * (qd > 0 ? 1.0 : -1.0) * std::pow(std::fabs(qd), k);
      const double tolerance = std::fabs(expected) * std::fabs(k - 1.0) * 1e-6 / (qd * qd) + 1e-15;
      EXPECT_NEAR(Output(*block, {}, Scalar1(qd), Eigen::Vector2d(0.01, k)), expected, tolerance)
          << "k = " << k << ", qd = " << qd;
    }
  }
}

TEST(Friction, RippleIsAFourierSeriesInPosition) {
  BlockOptions options;
  options.numbers["harmonics"] = {2};
  options.numbers["period"] = {0.5};
  const auto block = Make(kRippleFriction, options);
  ASSERT_EQ(block->NumParameters(), 5);
  EXPECT_EQ(block->info().parameters[0].name, "a1");
  EXPECT_EQ(block->info().parameters[3].name, "b2");
  // The period: the option's value, a parameter that starts fixed.
  EXPECT_EQ(block->info().parameters[4].name, "period");
  EXPECT_EQ(block->info().parameters[4].nominal, 0.5);
  EXPECT_TRUE(block->info().parameters[4].fixed_by_default);
  Eigen::VectorXd p(5);
  p << 0.1, -0.2, 0.03, 0.04, 0.5;  // a1, b1, a2, b2, period
  for (double q : {-3.0, -0.1, 0.0, 0.2, 1.3}) {
    const double w = 2.0 * kPi / 0.5;
    const double expected = 0.1 * std::cos(w * q) - 0.2 * std::sin(w * q) +
                            0.03 * std::cos(2 * w * q) + 0.04 * std::sin(2 * w * q);
    // The block computes k (2 pi / P) q, the test (2 pi / P) k q: a few ulps of 2 pi k q / P.
    constexpr double kPhaseRoundoff = 1e-14;
    EXPECT_NEAR(Output(*block, {}, Scalar1(q), p), expected, kPhaseRoundoff);
    EXPECT_NEAR(Output(*block, {}, Scalar1(q + 0.5), p), expected, 1e-13) << "periodic";
  }
  testing::ExpectBlockDerivativesMatch(*block, testing::TestSeed());
}

// f_a and f_b of roblue, SOURCE.md (roblue computes the term but leaves it out of its sum).
constexpr std::array<double, kKukaDof> kKukaFa = {20.47, 226.56, 453.59, 65.97, 47.41, 16.47};
constexpr std::array<double, kKukaDof> kKukaFb = {823.4, 29890.6, 39171.9, 4845.3, 2370.3, 2060.9};

// friction.kuka with f_a = 0 and s = 1 is roblue's friction (kuka_kr300.h), joint by joint; its
// nominal f_a, f_b are SOURCE.md's.
TEST(Friction, KukaMatchesTheRoblueFrictionOfEveryJoint) {
  const KukaFrictionParameters roblue = KukaRoblueFriction();
  for (int joint = 1; joint <= kKukaDof; ++joint) {
    BlockOptions options;
    options.numbers["joint"] = {static_cast<double>(joint)};
    const auto block = Make(kKukaFriction, options);
    const auto j = static_cast<std::size_t>(joint - 1);
    VectorXd p = Parameters(*block);
    EXPECT_EQ(p[0], roblue.f_asym[j]);
    EXPECT_EQ(p[1], roblue.f_vis[j]);
    EXPECT_EQ(p[2], roblue.f_coul[j]);
    EXPECT_EQ(p[3], kKukaFa[j]);
    EXPECT_EQ(p[4], kKukaFb[j]);
    p[ParameterIndex(*block, "f_a")] = 0.0;
    JointVector<double> qd = JointVector<double>::Zero(kKukaDof);
    for (double v : {-1.5, -0.01, 0.0, 0.3, 2.0}) {
      qd[j] = v;
      const double expected = KukaFriction(qd, roblue)[j];
      EXPECT_NEAR(Output(*block, {}, Scalar1(v), p), expected, kRoundoff * std::fabs(expected))
          << "joint " << joint << ", qd = " << v;
      // The fourth term roblue computes but leaves out: f_a tanh(f_b qd).
      VectorXd pa = p;
      pa[ParameterIndex(*block, "f_a")] = kKukaFa[j];
      const double with_fa = expected + kKukaFa[j] * std::tanh(kKukaFb[j] * v);
      EXPECT_NEAR(Output(*block, {}, Scalar1(v), pa), with_fa, kRoundoff * std::fabs(with_fa));
    }
  }
}

// ---- LuGre --------------------------------------------------------------------------------------

class LuGreTest : public ::testing::Test {
 protected:
  static constexpr double kSigma0 = 100.0, kSigma1 = 0.01, kSigma2 = 0.005;
  static constexpr double kFc = 0.02, kFs = 0.05, kVs = 0.1;
  LuGreTest() {
    block_ = Make(kLuGreFriction);
    p_ = Parameters(*block_, {{"sigma0", kSigma0},
                              {"sigma1", kSigma1},
                              {"sigma2", kSigma2},
                              {"fc", kFc},
                              {"fs", kFs},
                              {"vs", kVs}});
  }
  static double G(double v) { return kFc + (kFs - kFc) * std::exp(-(v / kVs) * (v / kVs)); }
  std::unique_ptr<Block> block_;
  VectorXd p_;
};

// sigma0 z_ss = g(v) sign(v): the state derivative vanishes there, and the friction is the
// Stribeck curve, equal to friction.stribeck with fv = sigma2 (its tanh is +-1 here).
TEST_F(LuGreTest, SteadyStateIsTheStribeckCurve) {
  BlockOptions options;
  options.numbers["steepness"] = {1e6};
  const auto stribeck = Make(kStribeckFriction, options);
  const VectorXd ps =
      Parameters(*stribeck, {{"fc", kFc}, {"fs", kFs}, {"vs", kVs}, {"fv", kSigma2}});
  for (double v : {-2.0, -0.3, -0.05, 0.01, 0.05, 0.3, 2.0}) {
    const double z_ss = G(v) * (v > 0 ? 1.0 : -1.0) / kSigma0;
    const Evaluation e = Evaluate(*block_, Scalar1(z_ss), Scalar1(v), p_);
    // zdot = v - sigma0 |v| z_ss / g: a cancellation of two terms of size |v|.
    EXPECT_NEAR(e.xdot[0], 0.0, kRoundoff * std::fabs(v)) << "v = " << v;
    EXPECT_NEAR(e.y[0], Output(*stribeck, {}, Scalar1(v), ps), kRoundoff) << "v = " << v;
  }
}

// Away from the steady state: seed 002 eq. 5-6 and 5-7 term by term.
TEST_F(LuGreTest, FollowsTheSeedsEquations) {
  for (double v : {-1.0, -0.02, 0.0, 0.07}) {
    for (double z : {-4e-4, 1e-4, 6e-4}) {
      const double zdot = v - kSigma0 * std::fabs(v) * z / G(v);  // eq. 5-7
      const Evaluation e = Evaluate(*block_, Scalar1(z), Scalar1(v), p_);
      EXPECT_NEAR(e.xdot[0], zdot, kRoundoff);
      EXPECT_NEAR(e.y[0], kSigma0 * z + kSigma1 * zdot + kSigma2 * v, kRoundoff);  // eq. 5-6
    }
  }
}

// At constant v the bristle equation is linear: z(t) = z_ss (1 - exp(-lambda t)) from z(0) = 0,
// lambda = sigma0 |v| / g(v).
TEST_F(LuGreTest, TransientAtConstantVelocity) {
  for (double v : {-0.4, 0.08}) {
    const double lambda = kSigma0 * std::fabs(v) / G(v);
    const double z_ss = G(v) * (v > 0 ? 1.0 : -1.0) / kSigma0;
    const int kStepsPerTimeConstant = 200;
    const double h = 1.0 / (lambda * kStepsPerTimeConstant);
    VectorXd x = VectorXd::Zero(1);
    const InputFunction u = [v](double) { return Scalar1(v); };
    for (int step = 1; step <= 3 * kStepsPerTimeConstant; ++step) {
      x = Rk4Step(*block_, (step - 1) * h, x, u, p_, h);
      if (step % kStepsPerTimeConstant == 0) {
        const double t = step * h;
        // RK4 global error ~ (lambda h)^4 / 120 per unit of lambda t: < 1e-11 relative.
        constexpr double kRk4Tolerance = 1e-10;
        EXPECT_NEAR(x[0], z_ss * (1.0 - std::exp(-lambda * t)), kRk4Tolerance * std::fabs(z_ss))
            << "v = " << v << ", lambda t = " << lambda * t;
      }
    }
  }
}

TEST(Friction, LuGreAndDahlAreStiffAtTheirNominalValues) {
  for (const char* type : {kLuGreFriction, kDahlFriction}) {
    const auto block = Make(type);
    EXPECT_TRUE(block->info().stiff) << type;
    // |d zdot/dz| = sigma0 |qd| / g at the largest typical speed, against the 500 Hz sampling.
    const VectorXd p = Parameters(*block);
    const double qd = block->info().inputs[0].typical_max;
    const double rate = -(Evaluate(*block, Scalar1(1e-6), Scalar1(qd), p).xdot[0] -
                          Evaluate(*block, Scalar1(0.0), Scalar1(qd), p).xdot[0]) /
                        1e-6;
    EXPECT_GT(rate, 10.0 * 500.0) << type;
  }
}

// ---- Dahl ---------------------------------------------------------------------------------------

// q = A sin(w t): after the initial transient the loop tau(q) reaches +-fc tanh(sigma0 A / fc) at
// q = +-A, and crosses q = 0 at +-(fc - (fc + tau_A) exp(-sigma0 A / fc)), the same at every
// frequency (rate independence).
// The presliding-length form is the same law: with delta = fc / sigma0 and zn = sigma0 z / fc the
// torques agree and dzn/dt = (sigma0 / fc) dz/dt; at fc = 0 it outputs 0 whatever zn.
TEST(Friction, DahlLengthFormIsTheStiffnessFormRescaled) {
  const auto stiffness = Make(kDahlFriction);
  BlockOptions o;
  o.words["form"] = "length";
  const auto length = Make(kDahlFriction, o);
  ASSERT_EQ(length->info().parameters[0].name, "fc");
  ASSERT_EQ(length->info().parameters[1].name, "delta");
  const double sigma0 = 40.0, fc = 0.03, delta = fc / sigma0;
  for (const double z : {-6e-4, 0.0, 2e-4, 7.4e-4}) {
    for (const double qd : {-1.3, -0.02, 0.0, 0.4}) {
      const Evaluation a = Evaluate(*stiffness, Scalar1(z), Scalar1(qd),
                                    Parameters(*stiffness, {{"sigma0", sigma0}, {"fc", fc}}));
      const Evaluation b = Evaluate(*length, Scalar1(sigma0 * z / fc), Scalar1(qd),
                                    Parameters(*length, {{"fc", fc}, {"delta", delta}}));
      EXPECT_NEAR(b.y[0], a.y[0], kRoundoff);
      EXPECT_NEAR(b.xdot[0], sigma0 / fc * a.xdot[0],
                  kRoundoff * std::max(1.0, std::fabs(b.xdot[0])));
    }
  }
  EXPECT_EQ(Output(*length, Scalar1(0.8), Scalar1(0.3),
                   Parameters(*length, {{"fc", 0.0}, {"delta", delta}})),
            0.0);
  o.words["form"] = "lenght";
  EXPECT_THROW(Make(kDahlFriction, o), std::invalid_argument);
}

TEST(Friction, DahlHysteresisLoopMatchesTheClosedForm) {
  constexpr double kSigma0 = 10.0, kFc = 0.02, kAmplitude = 2e-3;  // sigma0 A / fc = 1
  const auto block = Make(kDahlFriction);
  const VectorXd p = Parameters(*block, {{"sigma0", kSigma0}, {"fc", kFc}});
  const double tau_tip = kFc * std::tanh(kSigma0 * kAmplitude / kFc);
  const double tau_zero = kFc - (kFc + tau_tip) * std::exp(-kSigma0 * kAmplitude / kFc);
  // 10 cycles: the deviation from the periodic loop decays by exp(-2 sigma0 A / fc) per half
  // cycle (exp(-40) in all); RK4 with 4000 steps per period is exact to ~1e-12 relative.
  constexpr int kCycles = 10, kStepsPerPeriod = 4000;
  constexpr double kLoopTolerance = 1e-10;  // [N m]
  for (double frequency : {1.0, 5.0}) {
    const double w = 2.0 * kPi * frequency, h = 1.0 / (frequency * kStepsPerPeriod);
    const InputFunction u = [&](double t) { return Scalar1(kAmplitude * w * std::cos(w * t)); };
    VectorXd x = VectorXd::Zero(1);
    double tau_at_top = 0.0, tau_up_at_zero = 0.0, tau_down_at_zero = 0.0;
    for (int step = 0; step < (kCycles + 1) * kStepsPerPeriod; ++step) {
      x = Rk4Step(*block, step * h, x, u, p, h);
      const int k = (step + 1) % kStepsPerPeriod;  // position in the period after this step
      const double tau = kSigma0 * x[0];
      if (step + 1 >= kCycles * kStepsPerPeriod) {
        if (k == 0) tau_up_at_zero = tau;
        if (k == kStepsPerPeriod / 4) tau_at_top = tau;
        if (k == kStepsPerPeriod / 2) tau_down_at_zero = tau;
      }
    }
    EXPECT_NEAR(tau_at_top, tau_tip, kLoopTolerance) << frequency << " Hz";
    EXPECT_NEAR(tau_up_at_zero, tau_zero, kLoopTolerance) << frequency << " Hz";
    EXPECT_NEAR(tau_down_at_zero, -tau_zero, kLoopTolerance) << frequency << " Hz";
    EXPECT_GT(tau_up_at_zero - tau_down_at_zero, 0.01) << "the loop is open (hysteresis)";
  }
}

// ---- Torque-dependent dry friction (seed 001 eq. 5-8) ------------------------------------------

class TorqueDependentTest : public ::testing::Test {
 protected:
  static constexpr double kFc = 0.5, kFtau = 0.05, kDistance = 0.05, kTime = 0.1;
  static constexpr double kDt = 0.004;  // seed 001 controller sample (250 Hz)
  TorqueDependentTest() {
    block_ = Make(kTorqueDependentFriction);
    p_ = Parameters(*block_,
                    {{"fc", kFc}, {"ftau", kFtau}, {"distance", kDistance}, {"time", kTime}});
  }
  // Integrates over one controller sample with constant inputs (400 RK4 substeps).
  double Sample(double tau_d, double qd, double tau_load) const {
    constexpr int kSubsteps = 400;
    const InputFunction u = [&](double) { return Eigen::Vector2d(qd, tau_load).eval(); };
    VectorXd x = Scalar1(tau_d);
    for (int i = 0; i < kSubsteps; ++i) x = Rk4Step(*block_, 0.0, x, u, p_, kDt / kSubsteps);
    return x[0];
  }
  std::unique_ptr<Block> block_;
  VectorXd p_;
};

// While moving at constant speed the continuous form IS seed 001 eq. 5-7 (tanh(100 qd) and the
// smoothed |tau_load| are exactly 1 and |tau_load| in double at these values).
TEST_F(TorqueDependentTest, MovingReproducesTheSeedsDistanceRelaxation) {
  // RK4 on a linear decay errs by (lambda h)^5 / 120 per substep; the largest lambda h here is
  // |qd| (dt/400) / k5 = 4e-3 (qd = 20): 400 * 8.5e-15 = 3.4e-12 of the jump (about 1 N m).
  constexpr double kRelaxationTolerance = 1e-11;
  double continuous = -0.3, seed = -0.3;
  int sample = 0;
  for (double qd : {5.0, 5.0, 5.0, -2.0, -2.0, 20.0}) {
    const double tau_load = sample % 2 == 0 ? 3.0 : -1.0;
    const double target = (qd > 0 ? 1.0 : -1.0) * (kFc + kFtau * std::fabs(tau_load));
    seed = target + (seed - target) * std::exp(-std::fabs(qd * kDt) / kDistance);  // eq. 5-7
    continuous = Sample(continuous, qd, tau_load);
    EXPECT_NEAR(continuous, seed, kRelaxationTolerance) << "sample " << sample;
    ++sample;
  }
}

// At standstill the continuous form decays as exp(-t / k6); the seed's eq. 8 is its explicit
// Euler step and lags it by (dt/k6)^2 / 2 relative per sample.
TEST_F(TorqueDependentTest, StandstillDecaysInTime) {
  double continuous = 0.6, seed = 0.6;
  for (int n = 1; n <= 25; ++n) {
    continuous = Sample(continuous, 0.0, 4.0);
    seed *= 1.0 - kDt / kTime;  // eq. 8
    EXPECT_NEAR(continuous, 0.6 * std::exp(-n * kDt / kTime), 1e-12);
    EXPECT_NEAR(continuous, seed, 0.6 * n * 0.5 * (kDt / kTime) * (kDt / kTime) * 1.01);
  }
}

// With ftau = 0 and while moving, the law is the Dahl model with sigma0 = fc / distance.
TEST_F(TorqueDependentTest, ReducesToDahlWithoutLoadDependence) {
  const auto dahl = Make(kDahlFriction);
  const VectorXd pd = Parameters(*dahl, {{"sigma0", kFc / kDistance}, {"fc", kFc}});
  VectorXd p = p_;
  p[ParameterIndex(*block_, "ftau")] = 0.0;
  for (double qd : {-30.0, -1.0, 1.0, 250.0}) {
    for (double tau_d : {-0.4, 0.1, 0.45}) {
      const double xdot = Evaluate(*block_, Scalar1(tau_d), Eigen::Vector2d(qd, 3.0), p).xdot[0];
      // Dahl's state is z = tau / sigma0.
      const double z = tau_d / pd[0];
      const double dahl_xdot = pd[0] * Evaluate(*dahl, Scalar1(z), Scalar1(qd), pd).xdot[0];
      EXPECT_NEAR(xdot, dahl_xdot, kRoundoff * std::fabs(qd) * 20.0) << qd << " " << tau_d;
    }
  }
}

// ---- Options ------------------------------------------------------------------------------------

TEST(Friction, UnknownOptionsAreRejectedWithASuggestion) {
  BlockOptions options;
  options.numbers["steepnes"] = {10.0};
  try {
    Make(kStribeckFriction, options);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'steepness'"), std::string::npos)
        << e.what();
  }
  BlockOptions none;
  none.numbers["fv"] = {1.0};
  EXPECT_THROW(Make(kViscousFriction, none), std::invalid_argument);
}

TEST(Friction, InvalidOptionValuesAreRejected) {
  auto make_with = [](const char* type, const char* key, std::vector<double> value) {
    BlockOptions o;
    o.numbers[key] = std::move(value);
    return [type, o] { Make(type, o); };
  };
  EXPECT_THROW(make_with(kRippleFriction, "harmonics", {0})(), std::invalid_argument);
  EXPECT_THROW(make_with(kRippleFriction, "harmonics", {2.5})(), std::invalid_argument);
  EXPECT_THROW(make_with(kRippleFriction, "period", {-1.0})(), std::invalid_argument);
  EXPECT_THROW(make_with(kCoulombFriction, "steepness", {0.0})(), std::invalid_argument);
  EXPECT_THROW(make_with(kStribeckFriction, "exponent", {1.0, 2.0})(), std::invalid_argument);
  EXPECT_THROW(make_with(kKukaFriction, "joint", {7})(), std::invalid_argument);
  try {
    make_with(kLuGreFriction, "exponent", {-2.0})();
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("expected a number > 0, got -2"), std::string::npos)
        << e.what();
  }
}

// ---- Derivatives --------------------------------------------------------------------------------

// Every friction block, with its test options and with the variants the shared suite does not
// build, in scaled coordinates (see testing::ExpectBlockDerivativesMatch).
TEST(Friction, DerivativesMatchFiniteDifferencesInScaledCoordinates) {
  for (const std::string& type : FrictionTypes()) {
    testing::ExpectBlockDerivativesMatch(*Make(type, BlockRegistry::Global().TestOptions(type)),
                                         testing::TestSeed());
  }
  BlockOptions fixed;
  fixed.numbers["steepness"] = {30.0};
  testing::ExpectBlockDerivativesMatch(*Make(kCoulombFriction, fixed), testing::TestSeed());
  BlockOptions lugre;
  lugre.numbers["exponent"] = {1.0};
  testing::ExpectBlockDerivativesMatch(*Make(kLuGreFriction, lugre), testing::TestSeed());
  BlockOptions kuka;
  kuka.numbers["joint"] = {4};
  kuka.numbers["steepness"] = {100.0};
  testing::ExpectBlockDerivativesMatch(*Make(kKukaFriction, kuka), testing::TestSeed());
}

// motion = "prismatic" relabels the units of a sliding pair; the equations are unchanged.
TEST(FrictionMotion, PrismaticOptionRewritesUnitsOnly) {
  BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  const auto viscous = Make("friction.viscous", prismatic);
  EXPECT_EQ(viscous->info().inputs[0].unit, "m/s");
  EXPECT_EQ(viscous->info().outputs[0].unit, "N");
  EXPECT_EQ(viscous->info().parameters[0].unit, "N s/m");
  const auto lugre = Make("friction.lugre", prismatic);
  for (const auto& p : lugre->info().parameters) {
    EXPECT_EQ(p.unit.find("rad"), std::string::npos) << p.name << " " << p.unit;
    EXPECT_EQ(p.unit.find("N m"), std::string::npos) << p.name << " " << p.unit;
  }
  BlockOptions rotational;
  rotational.words["motion"] = "rotational";
  EXPECT_EQ(Make("friction.viscous", rotational)->info().parameters[0].unit, "N m s/rad");
  BlockOptions typo;
  typo.words["motion"] = "prismatc";
  try {
    Make("friction.coulomb", typo);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'prismatic'"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace graybox::models
