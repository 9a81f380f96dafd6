// Tests of InverseDynamicsModel (inverse_dynamics_model.h): the rigid-body Function equals the
// Newton-Euler recursion, torque blocks add, augmentation at neutral leaves the torques unchanged,
// the Function is linear in the parameters (its Jacobian is [Y, friction regressor]) so IDIM-LS
// recovers the torques of perturbed parameters in one least-squares solve, and misuse is reported.
#include "graybox/models/inverse_dynamics_model.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/QR>

#include "graybox/models/kuka_kr300.h"
#include "graybox/models/regressor.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using testing::RandomChain;
using testing::RandomVector;
using testing::TestSeed;

// The Function evaluates the same recursion on the parameter vector (through the change of frame
// of body_parameters.h) as InverseDynamics on the chain's precomputed bodies: rounding only.
constexpr double kFunctionVersusRneaTol = 1e-12;
// Least-squares fit of exact (noise-free) data with a rank-deficient regressor: the fitted torques
// equal the data to the conditioning of the problem times rounding (~1e-9 relative here).
constexpr double kLeastSquaresTol = 1e-7;

double MaxRelDiff(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const double scale = std::max({1.0, a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff()});
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

// Test-local viscous friction tau = fv qd, neutral at fv = 0 (the registry's "friction.viscous" is
// another family's block; one test below uses it when it is registered).
class Viscous : public BlockBase<Viscous> {
 public:
  Viscous() {
    info_.type = "test.viscous";
    info_.description = "viscous friction";
    info_.reference = "tau = fv qd";
    info_.inputs = {{"qd", "rad/s", "joint velocity", -2, 2}};
    info_.outputs = {{"tau", "N m", "friction torque", -10, 10}};
    ParameterInfo fv{"fv", "N m s/rad", "viscous coefficient", 3.0, 0.0, 1e6};
    fv.neutral = 0.0;
    info_.parameters = {fv};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    a.y[0] = a.p[0] * a.u[0];
  }
};

// A block with a state, which an inverse-dynamics model must reject.
class Lag : public BlockBase<Lag> {
 public:
  Lag() {
    info_.type = "test.lag";
    info_.description = "first-order lag";
    info_.reference = "xdot = u - x";
    info_.inputs = {{"u", "N m", "in", -1, 1}};
    info_.states = {{"x", "N m", "state", -1, 1}};
    info_.outputs = {{"y", "N m", "out", -1, 1}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    a.xdot[0] = a.u[0] - a.x[0];
    a.y[0] = a.x[0];
  }
};

struct Sample {
  Eigen::VectorXd q, qd, qdd;
};

Sample RandomSample(std::mt19937& rng, int n) {
  return {RandomVector(rng, n, -3.0, 3.0), RandomVector(rng, n, -2.0, 2.0),
          RandomVector(rng, n, -5.0, 5.0)};
}

TEST(InverseDynamicsModel, RigidBodyFunctionEqualsNewtonEuler) {
  std::mt19937 rng(TestSeed());
  for (DhConvention convention : {DhConvention::kStandard, DhConvention::kModified}) {
    const SerialChain chain = RandomChain(rng, 5, convention, 4);
    const InverseDynamicsModel m = InverseDynamicsBuilder("random", chain).Build();
    const int n = chain.dof();
    ASSERT_EQ(m.NumJoints(), n);
    ASSERT_EQ(m.NumParameters(), 11 * n);
    EXPECT_EQ(m.parameters[0].name, "arm.l1.m");
    EXPECT_EQ(m.parameters[11 * n - 1].name, "arm.l5.Ia");
    EXPECT_EQ(m.ParameterIndex("arm.l2.Ixy"), 11 + kInertiaXY);
    EXPECT_EQ(m.positions[0].name, "q1");
    EXPECT_EQ(m.accelerations[n - 1].name, "qdd5");
    EXPECT_EQ(m.torques[3].unit, "N");  // joint 4 is prismatic
    EXPECT_EQ(m.inverse_dynamics.InputName(0), "q");
    EXPECT_EQ(m.inverse_dynamics.InputName(3), "p");
    EXPECT_EQ(m.inverse_dynamics.OutputName(0), "tau");
    EXPECT_EQ(m.ParameterValues(), InertialParameters(chain));
    for (int k = 0; k < 10; ++k) {
      const Sample s = RandomSample(rng, n);
      const JointVector<double> q = s.q, qd = s.qd, qdd = s.qdd;
      EXPECT_LT(MaxRelDiff(m.Torque(s.q, s.qd, s.qdd), InverseDynamics(chain, q, qd, qdd)),
                kFunctionVersusRneaTol);
    }
  }
}

TEST(InverseDynamicsModel, TorqueBlocksAddAndAugmentationStartsNeutral) {
  std::mt19937 rng(TestSeed());
  const SerialChain chain = KukaKr300R2500();
  InverseDynamicsBuilder b("kuka", chain);
  // Joints 1-3 get viscous friction at nominal fv = 3; joints 4-6 are augmented at neutral.
  for (int j = 1; j <= 3; ++j) {
    b.AddTorqueBlock("fv" + std::to_string(j), std::make_shared<Viscous>(),
                     {"qd" + std::to_string(j)}, {"tau" + std::to_string(j)});
  }
  const InverseDynamicsModel before = b.Build();
  for (int j = 4; j <= 6; ++j) {
    b.Augment("fv" + std::to_string(j), std::make_shared<Viscous>(), {"qd" + std::to_string(j)},
              {"tau" + std::to_string(j)});
  }
  const InverseDynamicsModel after = b.Build();
  EXPECT_EQ(before.NumParameters(), 66 + 3);
  EXPECT_EQ(after.NumParameters(), 66 + 6);
  EXPECT_EQ(after.parameters[after.ParameterIndex("fv5.fv")].value, 0.0);
  EXPECT_EQ(after.parameters[after.ParameterIndex("fv2.fv")].value, 3.0);
  b.SetParameter("fv5.fv", 7.0);
  const InverseDynamicsModel moved = b.Build();
  for (int k = 0; k < 5; ++k) {
    const Sample s = RandomSample(rng, 6);
    const JointVector<double> q = s.q, qd = s.qd, qdd = s.qdd;
    Eigen::VectorXd expected = InverseDynamics(chain, q, qd, qdd);
    for (int i = 0; i < 3; ++i) expected[i] += 3.0 * s.qd[i];
    EXPECT_LT(MaxRelDiff(before.Torque(s.q, s.qd, s.qdd), expected), kFunctionVersusRneaTol);
    EXPECT_EQ(after.Torque(s.q, s.qd, s.qdd), before.Torque(s.q, s.qd, s.qdd))
        << "augmented at neutral: bit-identical torques";
    expected[4] += 7.0 * s.qd[4];
    EXPECT_LT(MaxRelDiff(moved.Torque(s.q, s.qd, s.qdd), expected), kFunctionVersusRneaTol);
  }
}

// IDIM-LS: the Jacobian of tau with respect to p is [Y, diag(qd)] (tau is linear in p), and a
// least-squares fit of torques generated with perturbed parameters reproduces them exactly.
TEST(InverseDynamicsModel, LinearInParametersAndIdimLeastSquaresFitsExactly) {
  std::mt19937 rng(TestSeed());
  const SerialChain chain = RandomChain(rng, 3, DhConvention::kStandard);
  InverseDynamicsBuilder b("idim", chain);
  for (int j = 1; j <= 3; ++j) {
    b.AddTorqueBlock("fv" + std::to_string(j), std::make_shared<Viscous>(),
                     {"qd" + std::to_string(j)}, {"tau" + std::to_string(j)});
  }
  const InverseDynamicsModel m = b.Build();
  const int n = 3, np = m.NumParameters();
  ASSERT_EQ(np, 33 + 3);
  const expr::Function jac = m.inverse_dynamics.Jacobian("tau", "p");
  Eigen::VectorXd truth = m.ParameterValues();
  for (int i = 0; i < np; ++i) truth[i] *= 1.0 + 0.2 * testing::Uniform(rng, -1.0, 1.0);
  constexpr int kSamples = 60;
  Eigen::MatrixXd w(kSamples * n, np);
  Eigen::VectorXd tau(kSamples * n);
  for (int k = 0; k < kSamples; ++k) {
    const Sample s = RandomSample(rng, n);
    const Eigen::VectorXd p0 = m.ParameterValues();
    const auto jv = jac({s.q, s.qd, s.qdd, p0})[0];
    const expr::Sparsity& sp = jac.OutputSparsity(0);
    Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, np);
    for (int c = 0; c < np; ++c) {
      for (int e = sp.colind()[c]; e < sp.colind()[c + 1]; ++e) dense(sp.row()[e], c) = jv[e];
    }
    // The Jacobian is the regressor, then the friction columns diag(qd).
    const JointVector<double> q = s.q, qd = s.qd, qdd = s.qdd;
    Eigen::MatrixXd expected(n, np);
    expected << Eigen::MatrixXd(Regressor(chain, q, qd, qdd)), Eigen::MatrixXd(s.qd.asDiagonal());
    EXPECT_LT((dense - expected).cwiseAbs().maxCoeff(),
              kFunctionVersusRneaTol * std::max(1.0, expected.cwiseAbs().maxCoeff()));
    w.middleRows(k * n, n) = dense;
    tau.segment(k * n, n) = m.inverse_dynamics({s.q, s.qd, s.qdd, truth})[0];
  }
  // Linear: tau(truth) = W truth exactly (to rounding).
  EXPECT_LT(MaxRelDiff(w * truth, tau), kFunctionVersusRneaTol);
  // Least squares over the (rank-deficient: base parameters) regressor.
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(w);
  const Eigen::VectorXd fit = cod.solve(tau);
  EXPECT_LT(cod.rank(), np) << "the standard parameters are not all identifiable";
  EXPECT_LT(MaxRelDiff(w * fit, tau), kLeastSquaresTol);
}

TEST(InverseDynamicsModel, RegistryFrictionPerJoint) {
  const auto types = BlockRegistry::Global().Types();
  if (std::find(types.begin(), types.end(), "friction.viscous") == types.end()) {
    GTEST_SKIP() << "friction.viscous is not registered yet";
  }
  std::mt19937 rng(TestSeed());
  const SerialChain chain = KukaKr300R2500();
  InverseDynamicsBuilder b("kuka", chain);
  b.AugmentJointFriction("fv", "friction.viscous");
  const InverseDynamicsModel neutral = b.Build();
  EXPECT_EQ(neutral.NumParameters(), 66 + 6);
  for (int j = 1; j <= 6; ++j) b.SetParameter("fv" + std::to_string(j) + ".fv", 10.0 * j);
  const InverseDynamicsModel m = b.Build();
  const Sample s = RandomSample(rng, 6);
  const JointVector<double> q = s.q, qd = s.qd, qdd = s.qdd;
  Eigen::VectorXd expected = InverseDynamics(chain, q, qd, qdd);
  EXPECT_LT(MaxRelDiff(neutral.Torque(s.q, s.qd, s.qdd), expected), kFunctionVersusRneaTol);
  for (int i = 0; i < 6; ++i) expected[i] += 10.0 * (i + 1) * s.qd[i];
  EXPECT_LT(MaxRelDiff(m.Torque(s.q, s.qd, s.qdd), expected), kFunctionVersusRneaTol);
}

TEST(InverseDynamicsModel, PhysicsTorqueSignalsAndRotorOption) {
  std::mt19937 rng(TestSeed());
  const SerialChain chain = RandomChain(rng, 2, DhConvention::kModified);
  InverseDynamicsOptions options;
  options.rigid_body_instance = "rbd";
  options.parameters = InertialParameterSet::kRigidBody;
  options.physics_torque_signals = true;
  InverseDynamicsBuilder b("features", chain, options);
  // A block reading the physics torque: doubles it (tau = 2 tau_p on joint 1).
  b.AddTorqueBlock("echo", std::make_shared<Viscous>(), {"tau_p1"}, {"tau1"});
  b.SetParameter("echo.fv", 1.0);
  const InverseDynamicsModel m = b.Build();
  EXPECT_EQ(m.NumParameters(), 20 + 1);
  EXPECT_EQ(m.parameters[0].name, "rbd.l1.m");
  const Sample s = RandomSample(rng, 2);
  const JointVector<double> q = s.q, qd = s.qd, qdd = s.qdd;
  Eigen::VectorXd expected = InverseDynamics(chain, q, qd, qdd);
  expected[0] *= 2.0;
  EXPECT_LT(MaxRelDiff(m.Torque(s.q, s.qd, s.qdd), expected), kFunctionVersusRneaTol);
}

TEST(InverseDynamicsModel, MisuseIsReported) {
  const SerialChain chain = KukaKr300R2500();
  InverseDynamicsBuilder b("kuka", chain);
  try {
    b.AddTorqueBlock("lag", std::make_shared<Lag>(), {"tau1"}, {"tau1"});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("expected a static block"), std::string::npos) << e.what();
  }
  b.AddTorqueBlock("f", std::make_shared<Viscous>(), {"qdd7"}, {"tau1"});
  try {
    b.Build();
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("qdd7"), std::string::npos) << e.what();
  }
  EXPECT_THROW(b.Parameter("arm.l1.mass"), std::invalid_argument);
  InverseDynamicsBuilder c("kuka", chain);
  EXPECT_THROW(c.AddJointFriction("f", "test.unknown_block_type"), std::invalid_argument);
  try {
    c.Build().ParameterIndex("arm.l1.mm");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'arm.l1.m'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace graybox::models
