// Tests of the robot blocks (robot_blocks.h): each block equals the dynamics function it wraps
// (ForwardDynamics, InverseDynamics, KukaForwardDynamics) at nominal parameters, the parts of the
// KUKA acceleration block add up to the acceleration, the full 84-parameter KUKA blocks pass the
// finite-difference derivative check (the shared registry suite checks them with the inertia fixed,
// to stay fast), and the blocks compose in a Model.
#include "graybox/models/robot_blocks.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/expr/derivative_check.h"
#include "graybox/expr/function.h"
#include "graybox/models/kuka_kr300.h"
#include "graybox/models/model.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using expr::Expr;
using expr::Function;
using testing::RandomChain;
using testing::RandomVector;
using testing::TestSeed;

// A block with nominal parameters against the function it wraps. The block rebuilds the joint-frame
// bodies from the link-frame parameter vector (body_parameters.h's change of frame), which differs
// from the chain's precomputed bodies by rounding (~1e-16 relative); the forward dynamics amplify
// that by the conditioning of M (the KUKA's M has condition number ~1e3 at most in its range).
constexpr double kBlockVersusFunctionTol = 1e-11;
// The same operations in a different grouping (parts summed by hand): rounding only.
constexpr double kPartsTol = 1e-11;
// Central differences at the default step: ~1e-10 relative for smooth blocks (block_registry_test).
constexpr double kFiniteDifferenceTolerance = 1e-6;

double MaxRelDiff(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const double scale = std::max({1.0, a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff()});
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

struct Eval {
  Eigen::VectorXd xdot, y;
};

Eval Evaluate(const Block& b, const Eigen::VectorXd& x, const Eigen::VectorXd& u,
              const Eigen::VectorXd& p) {
  Eval e;
  e.xdot.resize(b.NumStates());
  e.y.resize(b.NumOutputs());
  b.Evaluate(BlockArgs<double>{x.data(), u.data(), p.data(), e.xdot.data(), e.y.data()});
  return e;
}

Eigen::VectorXd Nominal(const Block& b) {
  const std::vector<double> p = b.NominalParameters();
  return Eigen::Map<const Eigen::VectorXd>(p.data(), static_cast<Eigen::Index>(p.size()));
}

Function AsFunction(const Block& b) {
  const std::vector<Expr> x = Expr::Symbols("x", b.NumStates());
  const std::vector<Expr> u = Expr::Symbols("u", b.NumInputs());
  const std::vector<Expr> p = Expr::Symbols("p", b.NumParameters());
  std::vector<Expr> xdot(b.NumStates()), y(b.NumOutputs());
  b.Evaluate(BlockArgs<Expr>{x.data(), u.data(), p.data(), xdot.data(), y.data()});
  return Function(b.info().type, {{"x", x}, {"u", u}, {"p", p}}, {{"xdot", xdot}, {"y", y}});
}

TEST(SerialChainBlock, EqualsForwardDynamicsOnRandomChains) {
  std::mt19937 rng(TestSeed());
  for (DhConvention convention : {DhConvention::kStandard, DhConvention::kModified}) {
    const SerialChain chain = RandomChain(rng, 5, convention, 3);
    const int n = chain.dof();
    SerialChainBlockOptions options;
    options.outputs = JointOutputs::kPositionsAndVelocities;
    const auto block = MakeSerialChainBlock(chain, options);
    EXPECT_EQ(block->info().type, kSerialChainBlock);
    ASSERT_EQ(block->NumStates(), 2 * n);
    ASSERT_EQ(block->NumInputs(), n);
    ASSERT_EQ(block->NumOutputs(), 2 * n);
    ASSERT_EQ(block->NumParameters(), 11 * n);
    EXPECT_EQ(block->info().parameters[11].name, "l2.m");
    EXPECT_EQ(block->info().states[n].name, "qd1");
    EXPECT_EQ(block->info().inputs[2].unit, "N");  // joint 3 is prismatic
    EXPECT_EQ(Nominal(*block), InertialParameters(chain));
    for (int k = 0; k < 5; ++k) {
      const Eigen::VectorXd x = RandomVector(rng, 2 * n, -2.0, 2.0);
      const Eigen::VectorXd tau = RandomVector(rng, n, -10.0, 10.0);
      const Eval e = Evaluate(*block, x, tau, Nominal(*block));
      const JointVector<double> q = x.head(n), qd = x.tail(n), t = tau;
      EXPECT_EQ(e.xdot.head(n), x.tail(n));
      EXPECT_LT(MaxRelDiff(e.xdot.tail(n), ForwardDynamics(chain, q, qd, t)),
                kBlockVersusFunctionTol);
      EXPECT_EQ(e.y, x);
    }
    // Without rotor parameters: 10 per link, the chain's rotor inertia stays in the dynamics.
    options.parameters = InertialParameterSet::kRigidBody;
    options.outputs = JointOutputs::kPositions;
    const auto rigid = MakeSerialChainBlock(chain, options);
    EXPECT_EQ(rigid->NumParameters(), 10 * n);
    EXPECT_EQ(rigid->NumOutputs(), n);
    const Eigen::VectorXd x = RandomVector(rng, 2 * n, -2.0, 2.0);
    const Eigen::VectorXd tau = RandomVector(rng, n, -10.0, 10.0);
    EXPECT_LT(MaxRelDiff(Evaluate(*rigid, x, tau, Nominal(*rigid)).xdot,
                         Evaluate(*block, x, tau, Nominal(*block)).xdot),
              kBlockVersusFunctionTol);
  }
}

TEST(InverseDynamicsBlock, EqualsInverseDynamicsAndCopiesFeatures) {
  std::mt19937 rng(TestSeed());
  const SerialChain chain = RandomChain(rng, 4, DhConvention::kModified, 2);
  const int n = chain.dof();
  InverseDynamicsBlockOptions options;
  options.feature_outputs = true;
  const auto block = MakeInverseDynamicsBlock(chain, options);
  ASSERT_EQ(block->NumStates(), 0);
  ASSERT_EQ(block->NumInputs(), 3 * n);
  ASSERT_EQ(block->NumOutputs(), 2 * n);
  EXPECT_EQ(block->info().outputs[n].name, "tau_p1");
  for (int k = 0; k < 5; ++k) {
    const Eigen::VectorXd u = RandomVector(rng, 3 * n, -2.0, 2.0);
    const Eval e = Evaluate(*block, {}, u, Nominal(*block));
    const JointVector<double> q = u.head(n), qd = u.segment(n, n), qdd = u.tail(n);
    EXPECT_LT(MaxRelDiff(e.y.head(n), InverseDynamics(chain, q, qd, qdd)), 1e-12)
        << "no solve: rounding of the parameter transform only";
    EXPECT_EQ(e.y.head(n), e.y.tail(n));
    // Linear in the parameters: the block at arbitrary theta is the regressor times theta.
    const Eigen::VectorXd theta = RandomVector(rng, 11 * n, -1.0, 1.0);
    const Eigen::VectorXd y_theta = Eigen::MatrixXd(Regressor(chain, q, qd, qdd)) * theta;
    EXPECT_LT(MaxRelDiff(Evaluate(*block, {}, u, theta).y.head(n), y_theta), 1e-12);
  }
}

TEST(JointIntegratorBlock, IntegratesAccelerations) {
  const auto block = MakeJointIntegratorBlock(3);
  ASSERT_EQ(block->NumStates(), 6);
  ASSERT_EQ(block->NumInputs(), 3);
  const Eigen::VectorXd x = (Eigen::VectorXd(6) << 1, 2, 3, 4, 5, 6).finished();
  const Eigen::VectorXd u = (Eigen::VectorXd(3) << 7, 8, 9).finished();
  EXPECT_EQ(Evaluate(*block, x, u, {}).xdot, (Eigen::VectorXd(6) << 4, 5, 6, 7, 8, 9).finished());
  EXPECT_THROW(MakeJointIntegratorBlock(0), std::invalid_argument);
}

TEST(KukaBlock, EqualsKukaForwardDynamicsAtNominalParameters) {
  std::mt19937 rng(TestSeed());
  for (InertiaReference reference :
       {InertiaReference::kLinkOrigin, InertiaReference::kCenterOfMass}) {
    for (double payload : {150.0, 0.0}) {
      KukaBlockOptions options;
      options.payload_kg = payload;
      options.inertia_reference = reference;
      const auto block = MakeKukaKr300Block(options);
      ASSERT_EQ(block->NumStates(), 12);
      ASSERT_EQ(block->NumInputs(), 6);
      ASSERT_EQ(block->NumParameters(), 66 + 18);
      EXPECT_EQ(block->info().parameters[66].name, "f_asym1");
      EXPECT_EQ(block->info().parameters[72].name, "f_coul1");
      EXPECT_EQ(block->info().parameters[83].name, "f_vis6");
      EXPECT_EQ(block->info().parameters[83].nominal, 1000.0);
      KukaKr300Model model = KukaKr300RoblueModel(payload);
      model.chain = KukaKr300R2500(payload, reference);
      for (int k = 0; k < 5; ++k) {
        const Eigen::VectorXd x = RandomVector(rng, 12, -1.5, 1.5);
        const Eigen::VectorXd u = RandomVector(rng, 6, -20.0, 20.0);
        const JointVector<double> q = x.head(6), qd = x.tail(6), tau = u;
        const Eigen::VectorXd expected = KukaForwardDynamics(model, q, qd, tau);
        const Eval e = Evaluate(*block, x, u, Nominal(*block));
        EXPECT_LT(MaxRelDiff(e.xdot.tail(6), expected), kBlockVersusFunctionTol);
        // Inertia as constants: the same numbers.
        KukaBlockOptions fixed = options;
        fixed.inertial_parameters = false;
        const auto fixed_block = MakeKukaKr300Block(fixed);
        ASSERT_EQ(fixed_block->NumParameters(), 18);
        EXPECT_LT(
            MaxRelDiff(Evaluate(*fixed_block, x, u, Nominal(*fixed_block)).xdot.tail(6), expected),
            kBlockVersusFunctionTol);
      }
    }
  }
}

TEST(KukaBlock, JointTorqueInputsAddAtTheJoints) {
  std::mt19937 rng(TestSeed());
  KukaBlockOptions options;
  options.joint_torque_inputs = true;
  const auto block = MakeKukaKr300Block(options);
  ASSERT_EQ(block->NumInputs(), 12);
  EXPECT_EQ(block->info().inputs[6].name, "tau_j1");
  const Eigen::VectorXd x = RandomVector(rng, 12, -1.0, 1.0);
  const Eigen::VectorXd u = RandomVector(rng, 12, -20.0, 20.0);
  // tau_j adds like u o tau_m: shift the motor torque by tau_j / u instead.
  Eigen::VectorXd shifted = u.head(6);
  for (int i = 0; i < 6; ++i) shifted[i] += u[6 + i] / kKukaGearRatios[static_cast<std::size_t>(i)];
  const auto plain = MakeKukaKr300Block();
  EXPECT_LT(MaxRelDiff(Evaluate(*block, x, u, Nominal(*block)).xdot,
                       Evaluate(*plain, x, shifted, Nominal(*plain)).xdot),
            kPartsTol);
}

TEST(KukaAccelerationBlock, EqualsStateSpaceBlockAndPartsAddUp) {
  std::mt19937 rng(TestSeed());
  const auto state_space = MakeKukaKr300Block();
  KukaBlockOptions options;
  options.parts = DynamicsParts::kAccelerations;
  const auto acc = MakeKukaKr300AccelerationBlock(options);
  options.feature_outputs = true;
  const auto with_features = MakeKukaKr300AccelerationBlock(options);
  EXPECT_EQ(with_features->info().outputs[6].name, "qdd_p1");
  options.feature_outputs = false;
  options.parts = DynamicsParts::kTorques;
  const auto torques = MakeKukaKr300AccelerationBlock(options);
  ASSERT_EQ(acc->NumStates(), 0);
  ASSERT_EQ(acc->NumInputs(), 18);
  ASSERT_EQ(acc->NumOutputs(), 6 + 24);
  ASSERT_EQ(torques->NumOutputs(), 6 + 19);
  EXPECT_EQ(acc->info().outputs[6].name, "qdd_u1");
  EXPECT_EQ(acc->info().outputs[29].name, "qdd_hwc6");
  EXPECT_EQ(torques->info().outputs[24].name, "tau_hwc2");
  // Friction off (parameters at their neutral 0) so that the parts are the whole right-hand side.
  Eigen::VectorXd p = Nominal(*acc);
  p.tail(18).setZero();
  for (int k = 0; k < 5; ++k) {
    const Eigen::VectorXd x = RandomVector(rng, 12, -1.5, 1.5);
    const Eigen::VectorXd tau_m = RandomVector(rng, 6, -20.0, 20.0);
    Eigen::VectorXd u(18);
    u << x, tau_m;
    const Eigen::VectorXd qdd = Evaluate(*state_space, x, tau_m, p).xdot.tail(6);
    const Eigen::VectorXd ya = Evaluate(*acc, {}, u, p).y;
    EXPECT_EQ(ya.head(6), qdd) << "the same computation";
    // qdd = M^-1 u tau_m - M^-1 C qd - M^-1 g - M^-1 e2 tau_hwc.
    const Eigen::VectorXd sum =
        ya.segment(6, 6) - ya.segment(12, 6) - ya.segment(18, 6) - ya.segment(24, 6);
    EXPECT_LT(MaxRelDiff(sum, qdd), kPartsTol);
    // M qdd = u tau_m - C qd - g - e2 tau_hwc.
    const Eigen::VectorXd yf = Evaluate(*with_features, {}, u, p).y;
    EXPECT_EQ(yf.head(6), qdd);
    EXPECT_EQ(yf.segment(6, 6), qdd) << "feature copies";
    EXPECT_EQ(yf.tail(24), ya.tail(24));
    const Eigen::VectorXd yt = Evaluate(*torques, {}, u, p).y;
    EXPECT_EQ(yt.head(6), qdd);
    Eigen::VectorXd rhs = yt.segment(6, 6) - yt.segment(12, 6) - yt.segment(18, 6);
    rhs[1] -= yt[24];
    const KukaKr300Model& model = DefaultKukaKr300Model();
    const JointVector<double> q = x.head(6);
    const Eigen::MatrixXd m = MassMatrix(model.chain, q);
    EXPECT_LT(MaxRelDiff(m * qdd, rhs), kPartsTol);
    for (int i = 0; i < 6; ++i) {
      EXPECT_EQ(yt[6 + i], kKukaGearRatios[static_cast<std::size_t>(i)] * tau_m[i]);
    }
  }
}

// The full blocks (84 parameters: inertial and friction) against central differences, at two
// points; the shared registry suite covers the same blocks with the inertia as constants.
TEST(KukaBlock, FullParameterDerivativesMatchFiniteDifferences) {
  std::mt19937 rng(TestSeed());
  expr::DerivativeCheckOptions options;
  options.tolerance = kFiniteDifferenceTolerance;
  KukaBlockOptions acc_options;
  acc_options.parts = DynamicsParts::kAccelerations;
  for (const auto& block : {MakeKukaKr300Block(), MakeKukaKr300AccelerationBlock(acc_options)}) {
    const auto start = std::chrono::steady_clock::now();
    const Function f = AsFunction(*block);
    for (int k = 0; k < 2; ++k) {
      const Eigen::VectorXd x = RandomVector(rng, block->NumStates(), -1.5, 1.5);
      Eigen::VectorXd u = RandomVector(rng, block->NumInputs(), -1.5, 1.5);
      for (int i = block->NumInputs() - 6; i < block->NumInputs(); ++i) u[i] *= 10.0;  // tau_m
      Eigen::VectorXd p = Nominal(*block);
      for (int i = 0; i < p.size(); ++i) p[i] *= 1.0 + 0.1 * testing::Uniform(rng, -1.0, 1.0);
      for (const char* out : {"xdot", "y"}) {
        for (const char* in : {"x", "u", "p"}) {
          if (f.OutputSize(f.OutputIndex(out)) == 0 || f.InputSize(f.InputIndex(in)) == 0) continue;
          const auto check = expr::CheckJacobian(f, out, in, {x, u, p}, options);
          EXPECT_TRUE(check.ok) << check.FullReport();
        }
      }
    }
    std::cout << "[ info     ] " << block->info().type << ": derivative check of "
              << block->NumParameters() << " parameters took "
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
              << " s\n";
  }
}

TEST(RobotBlocks, ComposeInAModel) {
  Model m("arm");
  const SerialChain chain = RobotBlockTestArm();
  for (int i = 1; i <= 3; ++i) {
    m.AddInput("tau" + std::to_string(i), i == 3 ? "N" : "N m", "drive torque");
  }
  m.AddBlock("arm", MakeSerialChainBlock(chain), {"tau1", "tau2", "tau3"}, {});
  m.AddOutput("arm.q1");
  m.AddOutput("arm.q3");
  const StateSpaceModel ss = m.Build();
  EXPECT_EQ(ss.NumStates(), 6);
  EXPECT_EQ(ss.NumParameters(), 33);
  EXPECT_EQ(ss.parameters[0].name, "arm.l1.m");
  EXPECT_EQ(ss.StateIndex("arm.qd2"), 4);
  const Eigen::VectorXd x = (Eigen::VectorXd(6) << 0.1, 0.2, 0.05, 0.3, -0.2, 0.1).finished();
  const Eigen::VectorXd u = (Eigen::VectorXd(3) << 1.0, 2.0, 3.0).finished();
  const Eigen::VectorXd xdot = ss.dynamics({x, u, ss.ParameterValues()})[0];
  const JointVector<double> q = x.head(3), qd = x.tail(3), tau = u;
  EXPECT_LT(MaxRelDiff(xdot.tail(3), ForwardDynamics(chain, q, qd, tau)), kBlockVersusFunctionTol);
}

TEST(RobotBlocks, RegistryOptionsAreChecked) {
  const BlockRegistry& r = BlockRegistry::Global();
  EXPECT_EQ(r.Create(kSerialChainBlock)->NumParameters(), 33);
  EXPECT_EQ(r.Create(kSerialChainBlock, {{{"rotor_inertia", {0.0}}}, {{"chain", "kuka_kr300"}}})
                ->NumParameters(),
            60);
  EXPECT_EQ(r.Create(kKukaKr300Block)->NumParameters(), 84);
  EXPECT_EQ(r.Create(kKukaKr300Block, {{{"payload", {0.0}}}, {{"outputs", "q_qd"}}})->NumOutputs(),
            12);
  EXPECT_EQ(r.Create(kJointIntegratorBlock)->NumStates(), 12);
  try {
    r.Create(kKukaKr300AccelerationBlock, {{}, {{"parts", "acceleration"}}});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'accelerations'"), std::string::npos)
        << e.what();
  }
  try {
    r.Create(kKukaKr300Block, {{{"paylod", {1.0}}}, {}});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'payload'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(r.Create(kKukaKr300Block, {{{"payload", {-1.0}}}, {}}), std::invalid_argument);
  EXPECT_THROW(r.Create(kSerialChainBlock, {{{"rotor_inertia", {0.5}}}, {}}),
               std::invalid_argument);
}

}  // namespace
}  // namespace graybox::models
