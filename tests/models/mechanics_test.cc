// Closed-form checks of the mechanics, control and signal blocks (graybox/models/mechanics.h):
// Newton's law of the mass, the cascaded P/P law and its smooth saturation against the formulas
// of the header, the step response of the closed EMPS loop against the second-order solution,
// the gain at its neutral value in series, the integrator as a first-order hold, and option
// validation. The shared suite
// (block_registry_test.cc) adds metadata, double == Expr and finite-difference checks.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/mechanics.h"
#include "graybox/models/model.h"
#include "test_util.h"

namespace graybox::models {
namespace {

// The same IEEE operations on both sides (one division, one product): equal to the last bit, a
// few ulps allowed for fused multiply-adds.
constexpr double kSameFormulaTolerance = 1e-14;
// The saturation's second-order expansion S(v) = v - eps^2 v / (2 (L^2 - v^2)) neglects
// O(eps^4 / L^3) terms: at eps = 1e-3, L = 10 that is 1e-15, so 1e-13 absolute covers rounding
// of the two square roots (~1e-15 each at |v + L| ~ 20) with margin.
constexpr double kExpansionTolerance = 1e-13;
// RK4 with h = 1e-4 s on a mode of 120 rad/s: local error ~ (h w)^5 / 120 ~ 2e-12 per step,
// 1000 steps, relative to the 1e-4 m step: 1e-8 leaves margin for the saturation's 6e-9
// relative deviation at 3.9 V.
constexpr double kStepResponseTolerance = 1e-8;

// EMPS values (../shared/data/emps/SOURCE.md and the published IDIM-LS mass).
constexpr double kMass = 95.1089;            // kg
constexpr double kGtau = 35.15065188248547;  // N/V
constexpr double kKp = 160.18;               // 1/s
constexpr double kKv = 243.45;               // V s/m

struct Evaluated {
  Eigen::VectorXd xdot, y;
};

Evaluated EvaluateBlock(const Block& b, const Eigen::VectorXd& x, const Eigen::VectorXd& u,
                        const Eigen::VectorXd& p) {
  Evaluated e{Eigen::VectorXd::Zero(b.NumStates()), Eigen::VectorXd::Zero(b.NumOutputs())};
  b.Evaluate(BlockArgs<double>{x.data(), u.data(), p.data(), e.xdot.data(), e.y.data()});
  return e;
}

double Saturation(double v, double limit, double eps) {
  return 0.5 * (std::sqrt((v + limit) * (v + limit) + eps * eps) -
                std::sqrt((v - limit) * (v - limit) + eps * eps));
}

TEST(MassBlock, NewtonsSecondLaw) {
  const auto block = BlockRegistry::Global().Create(kMassBlock);
  const Evaluated e =
      EvaluateBlock(*block, Eigen::Vector2d(0.1, -0.2), Eigen::VectorXd::Constant(1, 30.0),
                    Eigen::VectorXd::Constant(1, kMass));
  EXPECT_EQ(e.xdot[0], -0.2);
  EXPECT_NEAR(e.xdot[1], 30.0 / kMass, kSameFormulaTolerance);
  EXPECT_EQ(block->info().states[0].unit, "m");
  EXPECT_EQ(block->info().inputs[0].unit, "N");
  EXPECT_EQ(block->info().parameters[0].unit, "kg");
  EXPECT_FALSE(block->info().parameters[0].HasNeutral());
}

TEST(MassBlock, RotationalUnits) {
  BlockOptions options;
  options.words["motion"] = "rotational";
  const auto block = BlockRegistry::Global().Create(kMassBlock, options);
  EXPECT_EQ(block->info().states[0].unit, "rad");
  EXPECT_EQ(block->info().states[1].unit, "rad/s");
  EXPECT_EQ(block->info().inputs[0].unit, "N m");
  EXPECT_EQ(block->info().parameters[0].unit, "kg m^2");
}

TEST(MassBlock, RejectsAMisspeltMotion) {
  BlockOptions options;
  options.words["motion"] = "rotatoinal";
  try {
    BlockRegistry::Global().Create(kMassBlock, options);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'rotational'"), std::string::npos)
        << e.what();
  }
  BlockOptions unknown;
  unknown.numbers["mas"] = {1.0};
  EXPECT_THROW(BlockRegistry::Global().Create(kMassBlock, unknown), std::invalid_argument);
}

TEST(CascadeController, LinearRangeFollowsTheLawToSecondOrderInEps) {
  const auto block = BlockRegistry::Global().Create(kCascadePController);
  const Eigen::Vector3d p(kKp, kKv, 10.0);
  for (const double error : {-1e-4, 0.0, 5e-5, 1.1e-4}) {
    const double qd = 0.01;
    const Eigen::Vector3d u(0.1 + error, 0.1, qd);
    const double v = kKv * (kKp * (u[0] - u[1]) - qd);  // the rounded difference the block sees
    const double nu = EvaluateBlock(*block, {}, u, p).y[0];
    const double expansion =
        v - kDefaultSaturationSmoothing * kDefaultSaturationSmoothing * v / (2 * (100.0 - v * v));
    EXPECT_NEAR(nu, expansion, kExpansionTolerance) << "v = " << v;
  }
}

TEST(CascadeController, SaturatesSmoothlyAndOddly) {
  BlockOptions options;
  options.numbers["smoothing"] = {0.05};
  const auto block = BlockRegistry::Global().Create(kCascadePController, options);
  const double limit = 4.0, eps = 0.05;
  const Eigen::Vector3d p(kKp, kKv, limit);
  auto nu = [&](double error) {
    return EvaluateBlock(*block, {}, Eigen::Vector3d(error, 0.0, 0.0), p).y[0];
  };
  // Zero command gives exactly zero; the law is odd.
  EXPECT_EQ(nu(0.0), 0.0);
  EXPECT_NEAR(nu(3e-5), -nu(-3e-5), kSameFormulaTolerance);
  // At the corner v = L: S(L) = (sqrt(4 L^2 + eps^2) - eps) / 2 ~ L - eps/2.
  const double corner_error = limit / (kKp * kKv);
  EXPECT_NEAR(nu(corner_error), Saturation(limit, limit, eps), 1e-12);
  EXPECT_NEAR(nu(corner_error), limit - eps / 2, eps * eps / limit);
  // Far beyond: L - eps^2 L / (2 (v^2 - L^2)), strictly below L.
  const double v = 50.0;
  const double far = nu(v / (kKp * kKv));
  EXPECT_LT(far, limit);
  EXPECT_NEAR(far, limit - eps * eps * limit / (2 * (v * v - limit * limit)), 1e-9);
  EXPECT_NEAR(nu(-v / (kKp * kKv)), -far, kSameFormulaTolerance);
}

TEST(CascadeController, GainsAreSettingsFixedByDefault) {
  // The block's metadata says so, and Model::AddBlock starts exactly those parameters fixed.
  const auto controller = BlockRegistry::Global().Create(kCascadePController);
  for (const ParameterInfo& par : controller->info().parameters) {
    EXPECT_TRUE(par.fixed_by_default) << par.name;
  }
  Model m("loop");
  m.AddInput("qr", "m", "position reference");
  m.AddBlock("controller", kCascadePController, {}, {"qr", "load.q", "load.qd"}, {"nu"});
  m.AddBlock("drive", kGainBlock, {}, {"nu"}, {"force"});
  m.AddBlock("load", kMassBlock, {}, {"force"}, {});
  m.AddBlock("friction", "friction.viscous", {}, {"load.qd"}, {"-force"});
  for (const char* name : {"controller.kp", "controller.kv", "controller.limit"}) {
    EXPECT_FALSE(m.Parameter(name).free) << name;
  }
  for (const char* name : {"drive.k", "load.mass", "friction.fv"}) {
    EXPECT_TRUE(m.Parameter(name).free) << name;
  }
  m.Free("controller.kp");
  EXPECT_TRUE(m.Parameter("controller.kp").free);
  BlockOptions bad;
  bad.numbers["smoothing"] = {-1.0};
  EXPECT_THROW(BlockRegistry::Global().Create(kCascadePController, bad), std::invalid_argument);
}

// The EMPS loop without friction: M qdd = g kv (kp (qr - q) - qd), a damped oscillator
//   qdd + a qd + a kp q = a kp qr,  a = g kv / M,
// whose response to a step of qr from rest at q = 0 is
//   q(t) = qr (1 - exp(-z w t) (cos(wd t) + z w / wd sin(wd t))),  w^2 = a kp, 2 z w = a.
TEST(ClosedLoop, StepResponseOfTheEmpsLoopMatchesTheSecondOrderSolution) {
  Model m("emps_loop");
  m.AddInput("qr", "m", "position reference");
  m.AddBlock("controller", kCascadePController, {}, {"qr", "load.q", "load.qd"}, {"nu"});
  BlockOptions gain;
  gain.words = {{"input_unit", "V"}, {"output_unit", "N"}};
  m.AddBlock("drive", kGainBlock, gain, {"nu"}, {"force"});
  m.AddBlock("load", kMassBlock, {}, {"force"}, {});
  m.AddOutput("load.q");
  m.SetParameter("drive.k", kGtau);
  m.SetParameter("load.mass", kMass);
  const StateSpaceModel ss = m.Build();
  ASSERT_EQ(ss.NumStates(), 2);
  const Eigen::VectorXd p = ss.ParameterValues();
  const double qr = 1e-4;  // m: the command starts at kp kv qr = 3.9 V, inside the 10 V limit
  auto accel = [&](const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    const Eigen::Vector2d x(q[0], qd[0]);
    return Eigen::VectorXd::Constant(1,
                                     ss.dynamics({x, Eigen::VectorXd::Constant(1, qr), p})[0][1]);
  };
  const double a = kGtau * kKv / kMass;
  const double w = std::sqrt(a * kKp), z = a / (2 * w), wd = w * std::sqrt(1 - z * z);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(1), qd = Eigen::VectorXd::Zero(1);
  const double h = 1e-4;
  for (int k = 1; k <= 1000; ++k) {
    testing::Rk4Step(accel, h, &q, &qd);
    const double t = k * h;
    const double exact =
        qr * (1 - std::exp(-z * w * t) * (std::cos(wd * t) + z * w / wd * std::sin(wd * t)));
    ASSERT_NEAR(q[0], exact, kStepResponseTolerance * qr) << "t = " << t;
  }
}

TEST(Gain, ScalesAndIsTheIdentityAtNeutral) {
  const auto block = BlockRegistry::Global().Create(kGainBlock);
  EXPECT_EQ(EvaluateBlock(*block, {}, Eigen::VectorXd::Constant(1, 2.5),
                          Eigen::VectorXd::Constant(1, kGtau))
                .y[0],
            2.5 * kGtau);
  EXPECT_EQ(block->info().parameters[0].neutral, 1.0);
  BlockOptions units;
  units.words = {{"input_unit", "V"}, {"output_unit", "N"}};
  EXPECT_EQ(BlockRegistry::Global().Create(kGainBlock, units)->info().parameters[0].unit, "N/V");

  // In series on the force of a mass at neutral: the dynamics do not change.
  Model m("pushed");
  m.AddInput("force", "N", "applied force");
  m.AddBlock("load", kMassBlock, {}, {"force"}, {});
  m.AddOutput("load.q");
  m.SetParameter("load.mass", 2.0);
  const StateSpaceModel before = m.Build();
  m.InsertOnSignal("force", "force_error", kGainBlock);
  const StateSpaceModel after = m.Build();
  const Eigen::Vector2d x(0.3, -0.1);
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 7.0);
  EXPECT_EQ(before.dynamics({x, u, before.ParameterValues()})[0],
            after.dynamics({x, u, after.ParameterValues()})[0]);
}

// A first-order hold: the integrator driven by the forward difference of samples r[k] reproduces
// them at every sample (the increments telescope) and is linear in between.
TEST(Integrator, ForwardDifferencesReproduceTheSamples) {
  BlockOptions units;
  units.words = {{"input_unit", "m/s"}, {"output_unit", "m"}};
  const auto block = BlockRegistry::Global().Create(kIntegratorBlock, units);
  EXPECT_EQ(block->info().states[0].unit, "m");
  EXPECT_EQ(block->NumParameters(), 0);
  const std::vector<double> r = {0.0, 1e-4, 3e-4, 2.5e-4, 2.5e-4, 7e-4};
  const double dt = 1e-3;
  double y = r[0];
  for (std::size_t k = 0; k + 1 < r.size(); ++k) {
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, (r[k + 1] - r[k]) / dt);
    const Eigen::VectorXd x = Eigen::VectorXd::Constant(1, y);
    const double rate = EvaluateBlock(*block, x, u, {}).xdot[0];
    EXPECT_EQ(rate, u[0]);
    // Halfway through the sample the integral is the linear interpolation.
    EXPECT_NEAR(y + 0.5 * dt * rate, 0.5 * (r[k] + r[k + 1]), kSameFormulaTolerance);
    y += dt * rate;
    EXPECT_NEAR(y, r[k + 1], kSameFormulaTolerance);
  }
}

}  // namespace
}  // namespace graybox::models
