// Tests of the hybrid structures (hybrid.h): every seed 000 structure builds with the expected
// signals and parameter counts, reproduces the physics-only model EXACTLY with its networks at
// neutral (what the sim-to-real diagnosis relies on), and is wired as its equation says (checked
// against the physics and network blocks evaluated by hand, with the networks moved off neutral);
// the seed 001 residual inverse dynamics equals the rigid-body torque at neutral.
#include "graybox/models/hybrid.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/models/kuka_kr300.h"
#include "graybox/models/model.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "graybox/models/robot_blocks.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using testing::RandomVector;
using testing::TestSeed;

// Hybrid versus blocks evaluated one by one: the same operations, but the Model's expression graph
// may group the network sums differently (hash-consed nodes, a + b = b + a): rounding only.
constexpr double kWiringTol = 1e-12;
// The KUKA physics through the parameter vector versus KukaForwardDynamics (robot_blocks_test).
constexpr double kPhysicsTol = 1e-11;
constexpr int kNumPoints = 4;

// Small networks keep the expression graphs small; the structure is what is tested.
KukaHybridOptions SmallOptions() {
  KukaHybridOptions o;
  o.hidden = {4};
  o.joint_hidden = {3};
  o.network.numbers["seed"] = {7};
  return o;
}

int MlpParameters(std::vector<int> sizes) {
  int count = 0;
  for (std::size_t k = 0; k + 1 < sizes.size(); ++k)
    count += sizes[k] * sizes[k + 1] + sizes[k + 1];
  return count + sizes.front() * sizes.back();  // linear residual path
}

// Network inputs per structure (0 for 0.a).
int NetworkInputs(KukaHybridStructure s) {
  switch (s) {
    case KukaHybridStructure::kPhysicsOnly:
      return 0;
    case KukaHybridStructure::kNetworkOnly:
    case KukaHybridStructure::kNetworkPlusPhysics:
      return 18;
    case KukaHybridStructure::kPhysicsIntoNetwork:
      return 24;
    case KukaHybridStructure::kPartsIntoNetwork:
      return 31;
    case KukaHybridStructure::kScaledPartsIntoNetwork:
      return 36;
    default:
      return -1;  // per joint
  }
}

int ExpectedParameters(KukaHybridStructure s, const KukaHybridOptions& o) {
  const int physics = s == KukaHybridStructure::kNetworkOnly ? 0 : 84;
  if (s == KukaHybridStructure::kPhysicsOnly) return physics;
  if (s == KukaHybridStructure::kVelocityNetworkPerJoint ||
      s == KukaHybridStructure::kVelocityPositionsPerJoint) {
    std::vector<int> sizes = {s == KukaHybridStructure::kVelocityNetworkPerJoint ? 1 : 7};
    sizes.insert(sizes.end(), o.joint_hidden.begin(), o.joint_hidden.end());
    sizes.push_back(1);
    return physics + 6 * MlpParameters(sizes);
  }
  std::vector<int> sizes = {NetworkInputs(s)};
  sizes.insert(sizes.end(), o.hidden.begin(), o.hidden.end());
  sizes.push_back(6);
  return physics + MlpParameters(sizes);
}

struct Point {
  Eigen::VectorXd x, u;
};

Point RandomPoint(std::mt19937& rng) {
  Point p;
  p.x = RandomVector(rng, 12, -1.5, 1.5);
  p.u = RandomVector(rng, 6, -20.0, 20.0);
  return p;
}

Eigen::VectorXd Xdot(const StateSpaceModel& ss, const Point& pt, const Eigen::VectorXd& p) {
  return ss.dynamics({pt.x, pt.u, p})[0];
}

// Parameters of instance `prefix` ("ann.") moved to their nominal (Glorot) values: the network
// then outputs something nonzero.
Eigen::VectorXd NetworksAtNominal(const StateSpaceModel& ss, const std::string& prefix) {
  Eigen::VectorXd p = ss.ParameterValues();
  for (int i = 0; i < ss.NumParameters(); ++i) {
    if (ss.parameters[i].name.rfind(prefix, 0) == 0) {
      p[i] = ss.parameters[i].info.nominal;
      // Output biases are 0 at nominal: give them a value so every path is exercised.
      if (p[i] == 0.0) p[i] = 0.01 * (i % 7 + 1);
    }
  }
  return p;
}

std::vector<double> Slice(const Eigen::VectorXd& p, const StateSpaceModel& ss,
                          const std::string& prefix) {
  std::vector<double> out;
  for (int i = 0; i < ss.NumParameters(); ++i) {
    if (ss.parameters[i].name.rfind(prefix, 0) == 0) out.push_back(p[i]);
  }
  return out;
}

Eigen::VectorXd EvaluateBlock(const Block& b, const std::vector<double>& p,
                              const Eigen::VectorXd& u) {
  Eigen::VectorXd y(b.NumOutputs());
  b.Evaluate(BlockArgs<double>{nullptr, u.data(), p.data(), nullptr, y.data()});
  return y;
}

TEST(KukaHybrid, EveryStructureBuildsWithTheExpectedSignalsAndParameters) {
  const KukaHybridOptions o = SmallOptions();
  for (KukaHybridStructure s : AllKukaHybridStructures()) {
    SCOPED_TRACE(std::string(Label(s)) + " " + Name(s));
    const StateSpaceModel ss = KukaHybridModel(s, o).Build();
    EXPECT_EQ(ss.name, std::string(Label(s)) + " " + Name(s));
    EXPECT_EQ(ss.NumStates(), 12);
    EXPECT_EQ(ss.NumInputs(), 6);
    EXPECT_EQ(ss.NumOutputs(), 6);
    EXPECT_EQ(ss.states[0].name, "robot.q1");
    EXPECT_EQ(ss.states[11].name, "robot.qd6");
    EXPECT_EQ(ss.inputs[0].name, "tau_m1");
    EXPECT_EQ(ss.outputs[5].name, "robot.q6");
    EXPECT_EQ(ss.NumParameters(), ExpectedParameters(s, o));
    if (s != KukaHybridStructure::kNetworkOnly) {
      EXPECT_EQ(ss.parameters[0].name, "phy.l1.m");
      EXPECT_EQ(ss.parameters[83].name, "phy.f_vis6");
    }
    if (s != KukaHybridStructure::kPhysicsOnly) {
      const bool per_joint = s == KukaHybridStructure::kVelocityNetworkPerJoint ||
                             s == KukaHybridStructure::kVelocityPositionsPerJoint;
      EXPECT_NO_THROW(ss.ParameterIndex(per_joint ? "ann.j6.l0.w0_0" : "ann.l0.w0_0"));
    }
  }
  // With the seed's network sizes the counts are those of the paper's networks.
  KukaHybridOptions seed = SmallOptions();
  seed.hidden = {1000, 1000};
  EXPECT_EQ(ExpectedParameters(KukaHybridStructure::kNetworkOnly, seed),
            18 * 1000 + 1000 + 1000 * 1000 + 1000 + 1000 * 6 + 6 + 18 * 6);
  KukaHybridOptions velocities = SmallOptions();
  velocities.velocity_outputs = true;
  const StateSpaceModel v = KukaPhysicsOnlyModel(velocities).Build();
  ASSERT_EQ(v.NumOutputs(), 12);
  EXPECT_EQ(v.outputs[6].name, "robot.qd1");
}

TEST(KukaHybrid, NetworksAtNeutralReproduceThePhysicsOnlyModelExactly) {
  std::mt19937 rng(TestSeed());
  for (bool friction : {true, false}) {
    KukaHybridOptions o = SmallOptions();
    o.physics_friction = friction;
    const StateSpaceModel physics = KukaPhysicsOnlyModel(o).Build();
    for (KukaHybridStructure s : AllKukaHybridStructures()) {
      if (s == KukaHybridStructure::kNetworkOnly) continue;
      SCOPED_TRACE(std::string(Label(s)) + (friction ? " with friction" : " without friction"));
      const StateSpaceModel ss = KukaHybridModel(s, o).Build();
      for (int k = 0; k < kNumPoints; ++k) {
        const Point pt = RandomPoint(rng);
        const Eigen::VectorXd expected = Xdot(physics, pt, physics.ParameterValues());
        EXPECT_EQ(Xdot(ss, pt, ss.ParameterValues()), expected);
        EXPECT_EQ(ss.output({pt.x, pt.u, ss.ParameterValues()})[0], pt.x.head(6));
      }
    }
  }
}

TEST(KukaHybrid, PhysicsOnlyIsTheRoblueModel) {
  std::mt19937 rng(TestSeed());
  const StateSpaceModel ss = KukaPhysicsOnlyModel().Build();
  KukaHybridOptions no_friction;
  no_friction.physics_friction = false;
  const StateSpaceModel frictionless = KukaPhysicsOnlyModel(no_friction).Build();
  for (const char* f : {"phy.f_asym3", "phy.f_coul1", "phy.f_vis6"}) {
    const ModelParameter& p = frictionless.parameters[frictionless.ParameterIndex(f)];
    EXPECT_EQ(p.value, 0.0) << f;
    EXPECT_FALSE(p.free) << f;
  }
  KukaKr300Model model = KukaKr300RoblueModel(150.0);
  for (int k = 0; k < kNumPoints; ++k) {
    const Point pt = RandomPoint(rng);
    const JointVector<double> q = pt.x.head(6), qd = pt.x.tail(6), tau = pt.u;
    const Eigen::VectorXd xdot = Xdot(ss, pt, ss.ParameterValues());
    EXPECT_EQ(xdot.head(6), pt.x.tail(6));
    const Eigen::VectorXd expected = KukaForwardDynamics(model, q, qd, tau);
    EXPECT_LT((xdot.tail(6) - expected).cwiseAbs().maxCoeff(),
              kPhysicsTol * std::max(1.0, expected.cwiseAbs().maxCoeff()));
    model.friction_enabled = false;
    const Eigen::VectorXd expected_nf = KukaForwardDynamics(model, q, qd, tau);
    model.friction_enabled = true;
    const Eigen::VectorXd nf = Xdot(frictionless, pt, frictionless.ParameterValues()).tail(6);
    EXPECT_LT((nf - expected_nf).cwiseAbs().maxCoeff(),
              kPhysicsTol * std::max(1.0, expected_nf.cwiseAbs().maxCoeff()));
  }
}

TEST(KukaHybrid, NetworkOnlyAtNeutralHasZeroAcceleration) {
  std::mt19937 rng(TestSeed());
  const StateSpaceModel ss = KukaNetworkOnlyModel(SmallOptions()).Build();
  const Point pt = RandomPoint(rng);
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(12);
  expected.head(6) = pt.x.tail(6);
  EXPECT_EQ(Xdot(ss, pt, ss.ParameterValues()), expected);
}

// Each structure against its equation, with the networks away from neutral: the physics block and
// the network block evaluated one by one and combined by hand.
TEST(KukaHybrid, WiringFollowsTheEquationOfEachStructure) {
  std::mt19937 rng(TestSeed());
  const KukaHybridOptions o = SmallOptions();
  const BlockRegistry& registry = BlockRegistry::Global();
  for (KukaHybridStructure s : AllKukaHybridStructures()) {
    if (s == KukaHybridStructure::kPhysicsOnly) continue;
    SCOPED_TRACE(std::string(Label(s)) + " " + Name(s));
    const StateSpaceModel ss = KukaHybridModel(s, o).Build();
    const Eigen::VectorXd p = NetworksAtNominal(ss, "ann.");
    const std::vector<double> p_phy = Slice(p, ss, "phy.");
    const std::vector<double> p_ann = Slice(p, ss, "ann.");
    const bool per_joint = s == KukaHybridStructure::kVelocityNetworkPerJoint ||
                           s == KukaHybridStructure::kVelocityPositionsPerJoint;
    BlockOptions net = o.network;
    if (per_joint) {
      net.numbers["joints"] = {6};
      net.numbers["hidden"] = {3};
    } else {
      net.numbers["sizes"] = {static_cast<double>(NetworkInputs(s)), 4, 6};
    }
    const auto ann = registry.Create(per_joint ? (s == KukaHybridStructure::kVelocityNetworkPerJoint
                                                      ? "network.per_joint"
                                                      : "network.velocity_positions")
                                               : "network.mlp",
                                     net);
    ASSERT_EQ(ann->NumParameters(), static_cast<int>(p_ann.size()));
    KukaBlockOptions phy_options;
    phy_options.feature_outputs = s == KukaHybridStructure::kPhysicsIntoNetwork;
    if (s == KukaHybridStructure::kPartsIntoNetwork) phy_options.parts = DynamicsParts::kTorques;
    if (s == KukaHybridStructure::kScaledPartsIntoNetwork) {
      phy_options.parts = DynamicsParts::kAccelerations;
    }
    phy_options.joint_torque_inputs = per_joint;
    const auto phy = MakeKukaKr300AccelerationBlock(phy_options);
    for (int k = 0; k < kNumPoints; ++k) {
      const Point pt = RandomPoint(rng);
      Eigen::VectorXd qdd(6);
      if (per_joint) {
        Eigen::VectorXd ann_in = pt.x.tail(6);  // qd1..6
        if (s == KukaHybridStructure::kVelocityPositionsPerJoint) {
          ann_in.conservativeResize(12);
          ann_in.tail(6) = pt.x.head(6);  // then q1..6
        }
        const Eigen::VectorXd tau_ann = EvaluateBlock(*ann, p_ann, ann_in);
        Eigen::VectorXd phy_in(24);
        phy_in << pt.x, pt.u, tau_ann;
        qdd = EvaluateBlock(*phy, p_phy, phy_in);
      } else {
        Eigen::VectorXd phy_in(18);
        phy_in << pt.x, pt.u;
        const Eigen::VectorXd phy_out = s == KukaHybridStructure::kNetworkOnly
                                            ? Eigen::VectorXd::Zero(6)
                                            : Eigen::VectorXd(EvaluateBlock(*phy, p_phy, phy_in));
        Eigen::VectorXd ann_in(NetworkInputs(s));
        switch (s) {
          case KukaHybridStructure::kNetworkOnly:
          case KukaHybridStructure::kNetworkPlusPhysics:
            ann_in << pt.x, pt.u;
            break;
          case KukaHybridStructure::kPhysicsIntoNetwork:
            ann_in << pt.x, pt.u, phy_out.segment(6, 6);  // the copy of f_phy
            break;
          default:  // 3.a, 3.b: the parts after qdd
            ann_in << pt.x, phy_out.tail(NetworkInputs(s) - 12);
            break;
        }
        qdd = phy_out.head(6) + EvaluateBlock(*ann, p_ann, ann_in);
      }
      const Eigen::VectorXd xdot = Xdot(ss, pt, p);
      EXPECT_EQ(xdot.head(6), pt.x.tail(6));
      EXPECT_LT((xdot.tail(6) - qdd).cwiseAbs().maxCoeff(),
                kWiringTol * std::max(1.0, qdd.cwiseAbs().maxCoeff()));
      // And the network does move the model away from the physics.
      EXPECT_GT((xdot - Xdot(ss, pt, ss.ParameterValues())).cwiseAbs().maxCoeff(), 0.0);
    }
  }
}

TEST(KukaHybrid, StructuralNetworkOptionsAreRejected) {
  KukaHybridOptions o = SmallOptions();
  o.network.numbers["sizes"] = {18, 4, 6};
  EXPECT_THROW(KukaNetworkPlusPhysicsModel(o), std::invalid_argument);
  o = SmallOptions();
  o.network.words["activation"] = "relu";
  EXPECT_NO_THROW(KukaVelocityNetworkPerJointModel(o).Build());
}

// Seed 001: tau = tau_p + GRU residual; at neutral the output is the physics torque whatever the
// GRU states and inputs.
TEST(ResidualInverseDynamics, BuildsAndEqualsThePhysicsAtNeutral) {
  std::mt19937 rng(TestSeed());
  const SerialChain chain = RobotBlockTestArm();
  const int n = chain.dof();
  ResidualInverseDynamicsOptions o;
  o.hidden_state = 3;
  o.layers = 2;
  o.network.numbers["seed"] = {5};
  const StateSpaceModel ss = ResidualInverseDynamicsModel(chain, o).Build();
  EXPECT_EQ(ss.NumInputs(), 3 * n);
  EXPECT_EQ(ss.NumStates(), 2 * o.hidden_state);
  EXPECT_EQ(ss.NumOutputs(), n);
  EXPECT_EQ(ss.states[0].name, "gru1.h0");
  EXPECT_EQ(ss.outputs[0].name, "tau1");
  const int h = o.hidden_state;
  const auto gru = [](int n_in, int n_h, int n_out) {
    return 3 * n_h * (n_in + n_h + 1) + n_h + n_h * n_out + n_out;
  };
  EXPECT_EQ(ss.NumParameters(), 11 * n + gru(4 * n, h, h) + gru(h, h, n));
  for (int k = 0; k < kNumPoints; ++k) {
    const Eigen::VectorXd x = RandomVector(rng, ss.NumStates(), -0.9, 0.9);
    const Eigen::VectorXd u = RandomVector(rng, 3 * n, -2.0, 2.0);
    const Eigen::VectorXd y = ss.output({x, u, ss.ParameterValues()})[0];
    const JointVector<double> q = u.head(n), qd = u.segment(n, n), qdd = u.tail(n);
    const Eigen::VectorXd expected = InverseDynamics(chain, q, qd, qdd);
    EXPECT_LT((y - expected).cwiseAbs().maxCoeff(),
              kPhysicsTol * std::max(1.0, expected.cwiseAbs().maxCoeff()));
    // Off neutral the residual contributes.
    const Eigen::VectorXd moved = ss.output({x, u, NetworksAtNominal(ss, "gru2.out.")})[0];
    EXPECT_GT((moved - y).cwiseAbs().maxCoeff(), 0.0);
  }
  // Without the physics-torque feature and with one layer: fewer inputs to the GRU.
  ResidualInverseDynamicsOptions lean = o;
  lean.layers = 1;
  lean.physics_torque_feature = false;
  const StateSpaceModel l = ResidualInverseDynamicsModel(chain, lean).Build();
  EXPECT_EQ(l.NumParameters(), 11 * n + gru(3 * n, h, n));
  ResidualInverseDynamicsOptions empty = o;
  empty.hidden_state = 0;
  EXPECT_THROW(ResidualInverseDynamicsModel(chain, empty), std::invalid_argument);
}

TEST(ResidualInverseDynamics, JointFrictionFromTheRegistry) {
  const auto types = BlockRegistry::Global().Types();
  if (std::find(types.begin(), types.end(), "friction.viscous") == types.end()) {
    GTEST_SKIP() << "friction.viscous is not registered yet";
  }
  std::mt19937 rng(TestSeed());
  const SerialChain chain = RobotBlockTestArm();
  ResidualInverseDynamicsOptions o;
  o.hidden_state = 2;
  o.joint_friction = "friction.viscous";
  const StateSpaceModel ss = ResidualInverseDynamicsModel(chain, o).Build();
  const int fv = ss.ParameterIndex("f2.fv");
  const Eigen::VectorXd x = RandomVector(rng, ss.NumStates(), -0.9, 0.9);
  const Eigen::VectorXd u = RandomVector(rng, 9, -2.0, 2.0);
  const JointVector<double> q = u.head(3), qd = u.segment(3, 3), qdd = u.tail(3);
  Eigen::VectorXd expected = InverseDynamics(chain, q, qd, qdd);
  for (int j = 0; j < 3; ++j) {
    expected[j] +=
        ss.parameters[ss.ParameterIndex("f" + std::to_string(j + 1) + ".fv")].value * qd[j];
  }
  EXPECT_GT(ss.parameters[fv].value, 0.0);
  const Eigen::VectorXd y = ss.output({x, u, ss.ParameterValues()})[0];
  EXPECT_LT((y - expected).cwiseAbs().maxCoeff(),
            kPhysicsTol * std::max(1.0, expected.cwiseAbs().maxCoeff()));
}

}  // namespace
}  // namespace graybox::models
