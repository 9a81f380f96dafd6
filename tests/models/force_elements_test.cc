// Force elements a first model needed (loads.h, drives.h, model.h): a spring-damper between two
// slides acts equal and opposite; to ground through an unconnected input (which reads 0); the
// gravity load of a pendulum and of a vertical slide; drive.two_mass on a linear axis.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "graybox/models/model.h"

namespace graybox::models {
namespace {

// The same operations in another order.
constexpr double kRounding = 1e-13;

BlockOptions Prismatic() {
  BlockOptions o;
  o.words["motion"] = "prismatic";
  return o;
}

Eigen::VectorXd Xdot(const StateSpaceModel& m, const Eigen::VectorXd& x, const Eigen::VectorXd& u) {
  return m.dynamics({x, u, m.ParameterValues()})[0];
}

TEST(ForceElements, SpringDamperActsEqualAndOpposite) {
  Model m("two slides");
  m.AddBlock("a", "mechanics.mass", Prismatic(), {"fa"}, {});
  m.AddBlock("b", "mechanics.mass", Prismatic(), {"fb"}, {});
  m.AddBlock("link", "mechanics.spring_damper", Prismatic(), {"a.q", "b.q", "a.qd", "b.qd"},
             {"fb", "fa"});
  m.SetParameter("a.mass", 2.0);
  m.SetParameter("b.mass", 4.0);
  m.SetParameter("link.k", 100.0);
  m.SetParameter("link.c", 3.0);
  m.AddOutput("b.q");
  const StateSpaceModel s = m.Build();
  EXPECT_EQ(s.parameters[s.ParameterIndex("link.k")].info.unit, "N/m");
  Eigen::VectorXd x(4);
  x << 0.3, 0.5, 0.1, -0.2;  // a.q, a.qd, b.q, b.qd
  const Eigen::VectorXd xdot = Xdot(s, x, Eigen::VectorXd(0));
  const double f = 100.0 * (0.3 - 0.1) + 3.0 * (0.5 + 0.2);  // on b, towards a
  EXPECT_NEAR(xdot[s.StateIndex("a.qd")], -f / 2.0, kRounding);
  EXPECT_NEAR(xdot[s.StateIndex("b.qd")], f / 4.0, kRounding);
}

TEST(ForceElements, UnconnectedInputsReadZero) {
  // A slide on a spring to ground: the spring's end b is not connected.
  Model m("slide on a spring");
  m.AddInput("u", "N");
  m.AddBlock("a", "mechanics.mass", Prismatic(), {"u"}, {});
  m.AddBlock("spring", "mechanics.spring_damper", Prismatic(), {"a.q", "", "a.qd", ""}, {"", "u"});
  m.SetParameter("spring.k", 50.0);
  m.AddOutput("a.q");
  const StateSpaceModel s = m.Build();
  Eigen::VectorXd x(2);
  x << 0.2, 0.0;
  const Eigen::VectorXd xdot = Xdot(s, x, Eigen::VectorXd::Constant(1, 4.0));
  EXPECT_NEAR(xdot[1], (4.0 - 50.0 * 0.2) / 1.0, kRounding);
  // An output must still name a signal.
  Model bad = m;
  bad.AddOutput("");
  EXPECT_THROW(bad.Build(), std::invalid_argument);
}

TEST(ForceElements, GravityOfAPendulumAndOfAVerticalSlide) {
  BlockOptions rot;
  rot.words["motion"] = "rotational";
  Model p("pendulum");
  p.AddInput("torque", "N m");
  p.AddBlock("arm", "mechanics.mass", rot, {"torque"}, {});
  p.AddBlock("weight", "mechanics.gravity", rot, {"arm.q"}, {"-torque"});
  p.SetParameter("arm.mass", 0.05);
  p.SetParameter("weight.mgl", 1.96);
  p.SetParameter("weight.q_down", 0.1);
  p.AddOutput("arm.q");
  const StateSpaceModel sp = p.Build();
  Eigen::VectorXd x(2);
  x << 0.4, 0.0;
  EXPECT_NEAR(Xdot(sp, x, Eigen::VectorXd::Zero(1))[1], -1.96 * std::sin(0.3) / 0.05, 1e-12);

  Model v("vertical slide");
  v.AddInput("force", "N");
  v.AddBlock("slide", "mechanics.mass", Prismatic(), {"force"}, {});
  v.AddBlock("weight", "mechanics.gravity", Prismatic(), {"slide.q"}, {"-force"});
  v.SetParameter("slide.mass", 3.0);
  v.SetParameter("weight.m", 3.0);
  v.AddOutput("slide.q");
  const StateSpaceModel sv = v.Build();
  EXPECT_EQ(sv.parameters[sv.ParameterIndex("weight.m")].info.unit, "kg");
  x << 0.0, 0.0;
  EXPECT_NEAR(Xdot(sv, x, Eigen::VectorXd::Constant(1, 40.0))[1], (40.0 - 3.0 * 9.80665) / 3.0,
              kRounding);
  BlockOptions bad = rot;
  bad.numbers["gravity"] = {9.81};
  EXPECT_THROW(BlockRegistry::Global().Create("mechanics.gravity", bad), std::invalid_argument);
}

TEST(ForceElements, TwoMassDriveOnALinearAxis) {
  const auto block = BlockRegistry::Global().Create("drive.two_mass", Prismatic());
  const BlockInfo& info = block->info();
  EXPECT_EQ(info.states[0].unit, "m");
  EXPECT_EQ(info.states[1].unit, "m/s");
  EXPECT_EQ(info.inputs[0].unit, "N");
  EXPECT_EQ(info.parameters[0].unit, "kg");   // J
  EXPECT_EQ(info.parameters[2].unit, "N/m");  // Ke
  EXPECT_EQ(info.parameters[3].unit, "N s/m");
}

}  // namespace
}  // namespace graybox::models
