// Model composition: signals, ordering, errors, and augmentation that leaves outputs unchanged.
#include <gtest/gtest.h>

#include <cmath>

#include "graybox/models/model.h"

namespace graybox::models {
namespace {

using expr::Expr;

// Test-local blocks (the registry's physical blocks are tested in their own suites).
// A rotating inertia: state omega, input torque; omega_dot = torque / J.
class Inertia : public BlockBase<Inertia> {
 public:
  Inertia() {
    info_.type = "test.inertia";
    info_.description = "rotating inertia";
    info_.reference = "Newton";
    info_.inputs = {{"torque", "N m", "applied torque", -1, 1}};
    info_.states = {{"omega", "rad/s", "speed", -1, 1}};
    info_.parameters = {{"J", "kg m^2", "inertia", 0.5, 1e-6, 10.0}};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    a.xdot[0] = a.u[0] / a.p[0];
  }
};

// A viscous brake: tau = b * qd, neutral at b = 0.
class Brake : public BlockBase<Brake> {
 public:
  Brake() {
    info_.type = "test.brake";
    info_.description = "viscous brake";
    info_.reference = "linear damping";
    info_.inputs = {{"qd", "rad/s", "speed", -1, 1}};
    info_.outputs = {{"tau", "N m", "braking torque", -1, 1}};
    ParameterInfo b{"b", "N m s/rad", "damping", 0.2, 0.0, 10.0};
    b.neutral = 0.0;
    info_.parameters = {b};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    a.y[0] = a.p[0] * a.u[0];
  }
};

// A static gain y = k u, neutral at k = 1 (for InsertOnSignal).
class Gain : public BlockBase<Gain> {
 public:
  Gain() {
    info_.type = "test.gain";
    info_.description = "gain";
    info_.reference = "y = k u";
    info_.inputs = {{"in", "1", "input", -1, 1}};
    info_.outputs = {{"out", "1", "output", -1, 1}};
    ParameterInfo k{"k", "1", "gain", 2.0, -10.0, 10.0};
    k.neutral = 1.0;
    info_.parameters = {k};
  }
  template <typename S>
  void Compute(const BlockArgs<S>& a) const {
    a.y[0] = a.p[0] * a.u[0];
  }
};

Model BrakedInertia() {
  Model m("braked");
  m.AddInput("u", "N m", "motor torque");
  m.AddBlock("load", std::make_shared<Inertia>(), {"u"}, {});
  m.AddBlock("brake", std::make_shared<Brake>(), {"load.omega"}, {"-u"});
  m.AddOutput("load.omega");
  return m;
}

// RK4 simulation of a built model with a sinusoidal input; returns the outputs per step.
std::vector<double> Simulate(const StateSpaceModel& ss, int steps) {
  constexpr double kDt = 0.01;
  Eigen::VectorXd x = Eigen::VectorXd::Constant(ss.NumStates(), 0.3);
  const Eigen::VectorXd p = ss.ParameterValues();
  std::vector<double> y;
  for (int k = 0; k < steps; ++k) {
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(ss.NumInputs(), std::sin(0.05 * k));
    auto f = [&](const Eigen::VectorXd& xs) { return ss.dynamics({xs, u, p})[0]; };
    const Eigen::VectorXd k1 = f(x), k2 = f(x + 0.5 * kDt * k1), k3 = f(x + 0.5 * kDt * k2),
                          k4 = f(x + kDt * k3);
    x += kDt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    y.push_back(ss.output({x, u, p})[0][0]);
  }
  return y;
}

TEST(Model, BuildsQualifiedStateSpaceModel) {
  const StateSpaceModel ss = BrakedInertia().Build();
  ASSERT_EQ(ss.NumStates(), 1);
  EXPECT_EQ(ss.states[0].name, "load.omega");
  EXPECT_EQ(ss.states[0].unit, "rad/s");
  ASSERT_EQ(ss.NumParameters(), 2);
  EXPECT_EQ(ss.parameters[0].name, "load.J");
  EXPECT_EQ(ss.parameters[1].name, "brake.b");
  // omega_dot = (u - b omega) / J at u = 1, omega = 2, J = 0.5, b = 0.2.
  const auto xdot = ss.dynamics({Eigen::VectorXd::Constant(1, 2.0),
                                 Eigen::VectorXd::Constant(1, 1.0), ss.ParameterValues()})[0];
  constexpr double kExact = 1e-15;  // three floating-point operations
  EXPECT_NEAR(xdot[0], (1.0 - 0.2 * 2.0) / 0.5, kExact);
}

TEST(Model, NeutralAugmentationLeavesOutputsUnchanged) {
  const std::vector<double> before = Simulate(BrakedInertia().Build(), 200);
  Model m = BrakedInertia();
  m.Augment("extra_brake", std::make_shared<Brake>(), {"load.omega"}, {"-u"});
  EXPECT_EQ(m.Parameter("extra_brake.b").value, 0.0);
  const std::vector<double> after = Simulate(m.Build(), 200);
  ASSERT_EQ(before.size(), after.size());
  for (std::size_t k = 0; k < before.size(); ++k) EXPECT_EQ(before[k], after[k]) << "step " << k;
  // Moving the new parameter away from neutral changes the output.
  m.SetParameter("extra_brake.b", 1.0);
  const std::vector<double> moved = Simulate(m.Build(), 200);
  EXPECT_GT(std::fabs(moved.back() - before.back()), 1e-3);
}

TEST(Model, InsertOnSignalAtNeutralLeavesOutputsUnchanged) {
  const std::vector<double> before = Simulate(BrakedInertia().Build(), 100);
  Model m = BrakedInertia();
  m.InsertOnSignal("u", "input_gain", std::make_shared<Gain>());
  const StateSpaceModel ss = m.Build();
  EXPECT_EQ(m.Parameter("input_gain.k").value, 1.0);
  const std::vector<double> after = Simulate(ss, 100);
  for (std::size_t k = 0; k < before.size(); ++k) EXPECT_EQ(before[k], after[k]) << "step " << k;
}

TEST(Model, InsertOnOutputActsOnTheChannelOnlyAndKeepsItsName) {
  Model m = BrakedInertia();
  m.InsertOnOutput("load.omega", "sensor", std::make_shared<Gain>());
  m.SetParameter("sensor.k", 2.0);
  const StateSpaceModel ss = m.Build();
  ASSERT_EQ(ss.NumOutputs(), 1);
  EXPECT_EQ(ss.outputs[0].name, "load.omega");
  EXPECT_EQ(ss.outputs[0].unit, "rad/s");
  EXPECT_EQ(m.Outputs()[0], (std::pair<std::string, std::string>{"load.omega", "sensor.out"}));
  // The brake still reads the true speed: xdot = (u - b omega) / J; the output is k omega.
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(1, 2.0),
                        u = Eigen::VectorXd::Constant(1, 1.0);
  constexpr double kExact = 1e-15;
  EXPECT_NEAR(ss.dynamics({x, u, ss.ParameterValues()})[0][0], (1.0 - 0.2 * 2.0) / 0.5, kExact);
  EXPECT_NEAR(ss.output({x, u, ss.ParameterValues()})[0][0], 4.0, kExact);
  // A listed reader reads the sensor: the brake then brakes with b k omega.
  Model r = BrakedInertia();
  r.InsertOnOutput("load.omega", "sensor", std::make_shared<Gain>(), {"brake"});
  r.SetParameter("sensor.k", 2.0);
  const StateSpaceModel rs = r.Build();
  EXPECT_NEAR(rs.dynamics({x, u, rs.ParameterValues()})[0][0], (1.0 - 0.2 * 4.0) / 0.5, kExact);
  EXPECT_THROW(m.InsertOnOutput("load.omegaa", "s2", std::make_shared<Gain>()),
               std::invalid_argument);
  EXPECT_THROW(m.InsertOnOutput("load.omega", "s3", std::make_shared<Gain>(), {"brak"}),
               std::invalid_argument);
}

TEST(Model, InsertForReadersLeavesOtherReadersAndOutputs) {
  // The gain on u for the inertia only: the brake writes to u, so the inertia reads k (u - b w).
  Model m("two_readers");
  m.AddInput("u", "N m", "motor torque");
  m.AddBlock("load", std::make_shared<Inertia>(), {"u"}, {});
  m.AddBlock("brake", std::make_shared<Brake>(), {"load.omega"}, {"-u"});
  m.AddBlock("monitor", std::make_shared<Gain>(), {"u"}, {"logged"});
  m.AddOutput("u");
  m.AddOutput("logged");
  m.InsertForReaders("u", "amp", std::make_shared<Gain>(), {"load"});
  m.SetParameter("amp.k", 3.0);
  const StateSpaceModel ss = m.Build();
  EXPECT_EQ(ss.outputs[0].name, "u");
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(1, 2.0),
                        u = Eigen::VectorXd::Constant(1, 1.0);
  const Eigen::VectorXd p = ss.ParameterValues();
  constexpr double kExact = 1e-15;
  EXPECT_NEAR(ss.dynamics({x, u, p})[0][0], 3.0 * (1.0 - 0.2 * 2.0) / 0.5, kExact);
  const Eigen::VectorXd y = ss.output({x, u, p})[0];
  EXPECT_NEAR(y[0], 1.0 - 0.2 * 2.0, kExact);          // the output keeps the signal
  EXPECT_NEAR(y[1], 2.0 * (1.0 - 0.2 * 2.0), kExact);  // the monitor (k = 2) too
  ASSERT_EQ(m.Blocks().size(), 4u);
  EXPECT_EQ(m.Blocks()[0].inputs[0], "amp.out");
  EXPECT_EQ(m.Blocks()[2].inputs[0], "u");
  EXPECT_EQ(m.Blocks()[3].type, "test.gain");
}

// An insert whose instance name is taken fails before it rewires anything.
TEST(Model, InsertWithATakenInstanceLeavesTheModelUnchanged) {
  Model m = BrakedInertia();
  EXPECT_THROW(m.InsertOnSignal("u", "brake", std::make_shared<Gain>()), std::invalid_argument);
  EXPECT_THROW(m.InsertForReaders("u", "load", std::make_shared<Gain>(), {"load"}),
               std::invalid_argument);
  EXPECT_THROW(m.InsertOnOutput("load.omega", "brake", std::make_shared<Gain>(), {"brake"}),
               std::invalid_argument);
  ASSERT_EQ(m.Blocks().size(), 2u);
  EXPECT_EQ(m.Blocks()[0].inputs, std::vector<std::string>{"u"});
  EXPECT_EQ(m.Blocks()[1].inputs, std::vector<std::string>{"load.omega"});
  EXPECT_EQ(m.Outputs()[0].second, "load.omega");
  EXPECT_EQ(m.parameters().size(), 2u);
}

// The registry-type overloads of the insert operations create the block from the registry.
TEST(Model, InsertOverloadsWithATypeCreateTheBlockFromTheRegistry) {
  Model m = BrakedInertia();
  BlockOptions unit;
  unit.words["unit"] = "rad/s";
  m.InsertOnOutput("load.omega", "offset", "sensor.offset", unit, {"brake"});
  m.InsertForReaders("u", "deadzone", "actuator.deadzone", {}, {"load"});
  ASSERT_EQ(m.Blocks().size(), 4u);
  EXPECT_EQ(m.Blocks()[2].type, "sensor.offset");
  EXPECT_EQ(m.Blocks()[1].inputs, std::vector<std::string>{"offset.out"});
  EXPECT_EQ(m.Blocks()[0].inputs, std::vector<std::string>{"deadzone.out"});
  EXPECT_EQ(m.Parameter("deadzone.b").value, 0.0);  // neutral
}

TEST(Model, UnknownSignalIsReportedWithASuggestion) {
  Model m("typo");
  m.AddInput("u", "N m");
  m.AddBlock("load", std::make_shared<Inertia>(), {"u"}, {});
  m.AddBlock("brake", std::make_shared<Brake>(), {"load.omgea"}, {"-u"});
  try {
    m.Build();
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("'load.omgea'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("did you mean 'load.omega'"), std::string::npos) << msg;
  }
}

// A friction block in its default rotational form on a slide (mechanics.mass, prismatic): its
// parameters would be reported in N m s/rad. Refused with the motion option to set.
TEST(Model, RotationalBlockOnAPrismaticAxisIsRefused) {
  BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  Model m("slide");
  m.AddInput("force", "N");
  m.AddBlock("load", "mechanics.mass", prismatic, {"force"}, {});
  m.AddBlock("viscous", "friction.viscous", {}, {"load.qd"}, {"-force"});
  m.AddOutput("load.q");
  try {
    m.Build();
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("block 'viscous' (friction.viscous) reads signal 'load.qd' in rad/s"),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("set motion = \"prismatic\""), std::string::npos) << msg;
  }
  Model ok("slide");
  ok.AddInput("force", "N");
  ok.AddBlock("load", "mechanics.mass", prismatic, {"force"}, {});
  ok.AddBlock("viscous", "friction.viscous", prismatic, {"load.qd"}, {"-force"});
  ok.AddOutput("load.q");
  EXPECT_NO_THROW(ok.Build());
}

TEST(Model, AlgebraicLoopIsRejected) {
  Model m("loop");
  m.AddInput("u", "1");
  m.AddBlock("g1", std::make_shared<Gain>(), {"a"}, {"b"});
  m.AddBlock("g2", std::make_shared<Gain>(), {"b"}, {"a"});
  m.AddOutput("a");
  EXPECT_THROW(
      {
        try {
          m.Build();
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("algebraic loop among blocks g1, g2"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      std::invalid_argument);
}

TEST(Model, BadConnectionsAndParametersAreRejected) {
  Model m = BrakedInertia();
  EXPECT_THROW(m.AddBlock("load", std::make_shared<Brake>(), {"u"}, {"-u"}), std::invalid_argument);
  EXPECT_THROW(m.AddBlock("x", std::make_shared<Brake>(), {"u", "u"}, {"-u"}),
               std::invalid_argument);
  EXPECT_THROW(m.AddBlock("w", std::make_shared<Brake>(), {"u"}, {"load.omega"}),
               std::invalid_argument);
  EXPECT_THROW(m.SetParameter("load.J", -1.0), std::invalid_argument);
  try {
    m.Parameter("brake.bb");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'brake.b'"), std::string::npos);
  }
}

// ReplaceBlock: a joint replaced by its backlash form keeps its connections, its parameters'
// values, free flags and bounds, and its place in the parameter order; the new gap starts at its
// neutral value, where the model is the old one exactly.
TEST(Model, ReplaceBlockKeepsConnectionsAndParameters) {
  Model m("joint");
  m.AddInput("tau", "N m", "motor torque", -0.4, 0.4);
  m.AddBlock("joint", "drive.two_mass", {}, {"tau", ""}, {"", "", "", "", "torque"});
  m.AddBlock("friction", "friction.viscous", {}, {"joint.qd_m"}, {"-tau"});
  m.AddOutput("joint.q_l");
  m.AddOutput("torque");
  m.SetParameter("joint.Ke", 5.0);
  m.Fix("joint.J");
  m.Parameter("joint.d").upper = 0.5;
  const StateSpaceModel before = m.Build();
  BlockOptions backlash;
  backlash.numbers["backlash"] = {1};
  Model r = m;
  r.ReplaceBlock("joint", "drive.two_mass", backlash);
  const StateSpaceModel after = r.Build();
  ASSERT_EQ(after.NumParameters(), before.NumParameters() + 1);
  std::vector<std::string> names;
  for (const auto& p : after.parameters) names.push_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"joint.J", "joint.I", "joint.Ke", "joint.d", "joint.b",
                                             "friction.fv"}));
  EXPECT_EQ(r.Parameter("joint.Ke").value, 5.0);
  EXPECT_FALSE(r.Parameter("joint.J").free);
  EXPECT_EQ(r.Parameter("joint.d").upper, 0.5);
  EXPECT_EQ(r.Parameter("joint.b").value, 0.0);  // neutral
  EXPECT_TRUE(r.Parameter("joint.b").free);
  const Eigen::Vector4d x(0.104, 1.5, 0.1, -0.7);
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 0.2);
  Eigen::VectorXd p_after(after.NumParameters());
  p_after << before.ParameterValues().head(4), 0.0, before.ParameterValues().tail(1);
  EXPECT_EQ(after.dynamics({x, u, p_after})[0],
            before.dynamics({x, u, before.ParameterValues()})[0]);
  EXPECT_EQ(after.output({x, u, p_after})[0], before.output({x, u, before.ParameterValues()})[0]);
  // Errors leave the model unchanged.
  EXPECT_THROW(r.ReplaceBlock("friction", "drive.two_mass", {}), std::invalid_argument);
  try {
    r.ReplaceBlock("joitn", "drive.two_mass", {});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'joint'"), std::string::npos) << e.what();
  }
  EXPECT_EQ(r.Build().NumParameters(), after.NumParameters());
}

// A contribution subtracted from a signal nobody reads, and an input nobody reads, are errors
// naming the block (or input) and the closest read signal; a signal written with "+" and read by
// nobody is an internal signal.
TEST(Model, UnreadSubtractionsAndInputsAreRejected) {
  Model m = BrakedInertia();
  m.AddBlock("drag", std::make_shared<Brake>(), {"load.omega"}, {"-torqe"});
  try {
    m.Build();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("block 'drag' output"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("subtracts from signal 'torqe'"), std::string::npos)
        << e.what();
  }
  Model unused = BrakedInertia();
  unused.AddInput("spare", "N m");
  EXPECT_THROW(unused.Build(), std::invalid_argument);
  Model internal = BrakedInertia();
  internal.AddBlock("watch", std::make_shared<Brake>(), {"load.omega"}, {"brake_torque"});
  EXPECT_NO_THROW(internal.Build());
}

}  // namespace
}  // namespace graybox::models
