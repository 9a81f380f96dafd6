// Internal signals of a built model (StateSpaceModel::signals, SignalFunction, EvaluateSignals):
// the friction force of a composed slider against its closed form, the list of signals with
// sources, producing blocks, units and roles, concurrent evaluation with one workspace per thread,
// the did-you-mean on unknown names and the size checks; then, over the whole registry, every
// block's inputs, states and outputs appear as model signals with the block's units and roles.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/friction.h"
#include "graybox/models/mechanics.h"
#include "graybox/models/model.h"

namespace graybox::models {
namespace {

// The signal Function evaluates the same IEEE operations as the closed form below (a product, a
// tanh, a sum, a difference, a quotient) on values of order 10: a few ulps of 10 are ~1e-14, so
// 1e-12 absolute leaves room for a different but equivalent operation order in the tape.
constexpr double kClosedFormTolerance = 1e-12;

// The slider's values: mass [kg], viscous [N s/m], Coulomb [N] and tanh steepness [s/m].
constexpr double kMass = 2.5;
constexpr double kFv = 0.8;
constexpr double kFc = 1.7;
constexpr double kSteepness = 40.0;

// A mass on a sliding axis driven by the external force "f", braked by viscous and Coulomb
// friction. The two friction forces add up to the signal "friction", which a gain of -1 subtracts
// from the net force "force" on the mass:
//   friction = fv qd + fc tanh(s qd),   force = f - friction,   qdd = force / m.
Model Slider() {
  BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  Model m("slider");
  m.AddInput("f", "N", "applied force", -10.0, 10.0);
  m.AddBlock("drive", kGainBlock, {}, {"f"}, {"force"});
  m.AddBlock("load", kMassBlock, {}, {"force"}, {});
  m.AddBlock("viscous", kViscousFriction, prismatic, {"load.qd"}, {"friction"});
  m.AddBlock("coulomb", kCoulombFriction, prismatic, {"load.qd"}, {"friction"});
  m.AddBlock("brake", kGainBlock, {}, {"friction"}, {"force"});
  m.AddOutput("load.q");
  m.SetParameter("load.mass", kMass);
  m.SetParameter("viscous.fv", kFv);
  m.SetParameter("coulomb.fc", kFc);
  m.SetParameter("coulomb.steepness", kSteepness);
  m.SetParameter("brake.k", -1.0);
  return m;
}

double Friction(double qd) { return kFv * qd + kFc * std::tanh(kSteepness * qd); }

// Trajectory points (rows): position, velocity (through the tanh's knee and beyond), force.
const Eigen::MatrixXd& Trajectory() {
  static const Eigen::MatrixXd t = [] {
    Eigen::MatrixXd m(6, 3);
    m << 0.00, 0.0, 1.0,   //
        0.01, 1e-3, -2.0,  //
        0.05, -0.02, 3.5,  //
        0.10, 0.05, 0.0,   //
        0.12, -0.3, -7.0,  //
        0.20, 0.25, 10.0;
    return m;
  }();
  return t;
}

TEST(ModelSignals, FrictionForceMatchesTheClosedForm) {
  const StateSpaceModel ss = Slider().Build();
  ASSERT_EQ(ss.NumStates(), 2);
  ASSERT_EQ(ss.NumInputs(), 1);
  const expr::Function f = ss.SignalFunction({"friction", "force", "load.qd"});
  EXPECT_EQ(f.OutputName(0), "signals");
  EXPECT_EQ(f.OutputSize(0), 3);
  const Eigen::VectorXd p = ss.ParameterValues();
  for (int k = 0; k < Trajectory().rows(); ++k) {
    const double q = Trajectory()(k, 0), qd = Trajectory()(k, 1), u = Trajectory()(k, 2);
    const Eigen::VectorXd s = f({Eigen::Vector2d(q, qd), Eigen::VectorXd::Constant(1, u), p})[0];
    EXPECT_NEAR(s[0], Friction(qd), kClosedFormTolerance) << "qd = " << qd;
    EXPECT_NEAR(s[1], u - Friction(qd), kClosedFormTolerance) << "qd = " << qd;
    EXPECT_EQ(s[2], qd);
    // The net force is what the dynamics divide by the mass.
    const Eigen::VectorXd xdot =
        ss.dynamics({Eigen::Vector2d(q, qd), Eigen::VectorXd::Constant(1, u), p})[0];
    EXPECT_NEAR(xdot[1], s[1] / kMass, kClosedFormTolerance);
  }
}

TEST(ModelSignals, EvaluateSignalsAlongATrajectoryEqualsPointwise) {
  const StateSpaceModel ss = Slider().Build();
  const Eigen::MatrixXd X = Trajectory().leftCols(2);
  const Eigen::MatrixXd U = Trajectory().rightCols(1);
  expr::EvalStatus status;
  const Eigen::MatrixXd s =
      ss.EvaluateSignals({"friction", "f", "load.q"}, X, U, ss.ParameterValues(), &status);
  EXPECT_TRUE(status.ok) << status.message;
  ASSERT_EQ(s.rows(), X.rows());
  ASSERT_EQ(s.cols(), 3);
  for (int k = 0; k < X.rows(); ++k) {
    EXPECT_NEAR(s(k, 0), Friction(X(k, 1)), kClosedFormTolerance) << "row " << k;
    EXPECT_EQ(s(k, 1), U(k, 0)) << "row " << k;
    EXPECT_EQ(s(k, 2), X(k, 0)) << "row " << k;
  }
  // No names: N x 0.
  EXPECT_EQ(ss.EvaluateSignals({}, X, U, ss.ParameterValues()).cols(), 0);
}

TEST(ModelSignals, NonFiniteValuesAreReportedNotThrown) {
  Model m = Slider();
  const StateSpaceModel ss = m.Build();
  Eigen::VectorXd p = ss.ParameterValues();
  p[ss.ParameterIndex("viscous.fv")] = std::numeric_limits<double>::infinity();
  expr::EvalStatus status;
  const Eigen::MatrixXd s = ss.EvaluateSignals({"load.q", "friction"}, Trajectory().leftCols(2),
                                               Trajectory().rightCols(1), p, &status);
  EXPECT_FALSE(status.ok);
  EXPECT_FALSE(status.message.empty());
  EXPECT_EQ(s(0, 0), Trajectory()(0, 0));
  EXPECT_FALSE(std::isfinite(s(1, 1)));  // inf * 1e-3
}

TEST(ModelSignals, ListsEverySignalWithSourceBlocksUnitAndRole) {
  const StateSpaceModel ss = Slider().Build();
  std::vector<std::string> names;
  for (const SignalDescription& s : ss.signals) names.push_back(s.info.name);
  // Inputs, states, then block-output signals in the order the blocks were added.
  EXPECT_EQ(names, (std::vector<std::string>{"f", "load.q", "load.qd", "force", "friction"}));
  EXPECT_EQ(ss.NumSignals(), 5);
  struct Expected {
    const char* name;
    SignalSource source;
    std::vector<std::string> blocks;
    const char* unit;
    SignalRole role;
  };
  const std::vector<Expected> expected = {
      // The external input: nobody declares a role and the gain reading it declares none.
      {"f", SignalSource::kInput, {}, "N", SignalRole::kNone},
      {"load.q", SignalSource::kState, {"load"}, "m", SignalRole::kPosition},
      {"load.qd", SignalSource::kState, {"load"}, "m/s", SignalRole::kVelocity},
      // Unit from the first producer (the drive gain, "1"); role from the mass reading it.
      {"force", SignalSource::kBlockOutput, {"drive", "brake"}, "1", SignalRole::kForce},
      {"friction", SignalSource::kBlockOutput, {"viscous", "coulomb"}, "N", SignalRole::kForce}};
  for (const Expected& e : expected) {
    const SignalDescription& s = ss.signals[ss.SignalIndex(e.name)];
    EXPECT_EQ(s.source, e.source) << e.name;
    EXPECT_EQ(s.blocks, e.blocks) << e.name;
    EXPECT_EQ(s.info.unit, e.unit) << e.name;
    EXPECT_EQ(s.info.role, e.role) << e.name << ": " << SignalRoleName(s.info.role);
    EXPECT_EQ(s.size, 1) << e.name;
  }
  // The declared output carries the same metadata.
  EXPECT_EQ(ss.outputs[0].role, SignalRole::kPosition);
}

TEST(ModelSignals, AnExternalInputTakesTheRoleOfTheBlocksReadingIt) {
  BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  Model m("measured_velocity");
  m.AddInput("v", "m/s", "measured velocity");
  m.AddBlock("friction", kViscousFriction, prismatic, {"v"}, {"tau"});
  m.AddOutput("tau");
  const StateSpaceModel ss = m.Build();
  EXPECT_EQ(ss.signals[ss.SignalIndex("v")].info.role, SignalRole::kVelocity);
  EXPECT_EQ(ss.signals[ss.SignalIndex("v")].source, SignalSource::kInput);
  EXPECT_EQ(ss.signals[ss.SignalIndex("tau")].info.role, SignalRole::kForce);
  EXPECT_EQ(ss.signals[ss.SignalIndex("tau")].info.unit, "N");
}

TEST(ModelSignals, ConcurrentEvaluationWithOneWorkspacePerThread) {
  const StateSpaceModel ss = Slider().Build();
  const expr::Function f = ss.SignalFunction({"friction"});
  const Eigen::VectorXd p = ss.ParameterValues();
  constexpr int kThreads = 2;
  constexpr int kPointsPerThread = 2000;
  std::vector<double> worst(kThreads, 0.0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      expr::Workspace ws = f.MakeWorkspace();
      double x[2] = {0.0, 0.0}, u = 1.0, out = 0.0;
      const double* in[3] = {x, &u, p.data()};
      double* outs[1] = {&out};
      for (int k = 0; k < kPointsPerThread; ++k) {
        x[1] = (t == 0 ? 1.0 : -1.0) * 1e-4 * k;
        f.Evaluate(in, outs, &ws);
        worst[t] = std::max(worst[t], std::fabs(out - Friction(x[1])));
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_LE(worst[t], kClosedFormTolerance) << "thread " << t;
}

TEST(ModelSignals, UnknownNamesSuggestTheClosest) {
  const StateSpaceModel ss = Slider().Build();
  for (const auto& call : std::vector<std::function<void()>>{
           [&] {
             ss.SignalFunction({"load.qd", "frictoin"});
           },
           [&] {
             ss.EvaluateSignals({"frictoin"}, Trajectory().leftCols(2), Trajectory().rightCols(1),
                                ss.ParameterValues());
           },
           [&] { ss.SignalIndex("frictoin"); }}) {
    try {
      call();
      ADD_FAILURE() << "expected std::invalid_argument";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(
                    "model 'slider': unknown signal 'frictoin'; did you mean 'friction'?"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(ModelSignals, WrongTrajectorySizesAreRejected) {
  const StateSpaceModel ss = Slider().Build();
  const Eigen::VectorXd p = ss.ParameterValues();
  const Eigen::MatrixXd X = Trajectory().leftCols(2), U = Trajectory().rightCols(1);
  auto message = [&](const Eigen::MatrixXd& x, const Eigen::MatrixXd& u, const Eigen::VectorXd& q) {
    try {
      ss.EvaluateSignals({"friction"}, x, u, q);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NE(message(X.transpose(), U, p).find("X: expected N x 2"), std::string::npos)
      << message(X.transpose(), U, p);
  EXPECT_NE(message(X, U.topRows(2), p).find("U: expected 6 x 1"), std::string::npos)
      << message(X, U.topRows(2), p);
  EXPECT_NE(message(X, U, p.head(2)).find("p: expected 6 parameters, got 2"), std::string::npos)
      << message(X, U, p.head(2));
}

// Every registered block alone in a model, inputs driven by external inputs and outputs connected
// to their own signals: each input, state and output appears among the model's signals with the
// block's unit and role.
TEST(ModelSignals, EveryRegisteredBlocksSignalsAppearWithUnits) {
  const BlockRegistry& registry = BlockRegistry::Global();
  ASSERT_FALSE(registry.Types().empty());
  for (const std::string& type : registry.Types()) {
    SCOPED_TRACE(type);
    std::shared_ptr<const Block> block = registry.Create(type, registry.TestOptions(type));
    const BlockInfo& info = block->info();
    Model m("alone");
    std::vector<std::string> in, out;
    for (const SignalInfo& s : info.inputs) {
      in.push_back("in_" + s.name);
      m.AddInput(in.back(), s.unit, s.description, s.typical_min, s.typical_max);
    }
    for (const SignalInfo& s : info.outputs) out.push_back("out_" + s.name);
    m.AddBlock("b", block, in, out);
    for (const std::string& o : out) m.AddOutput(o);
    const StateSpaceModel ss = m.Build();
    ASSERT_EQ(ss.NumSignals(), block->NumInputs() + block->NumStates() + block->NumOutputs());
    auto check = [&](const std::string& name, const SignalInfo& declared, SignalSource source) {
      const SignalDescription& s = ss.signals[ss.SignalIndex(name)];
      EXPECT_FALSE(s.info.unit.empty()) << name;
      EXPECT_EQ(s.info.unit, declared.unit) << name;
      EXPECT_EQ(s.info.role, declared.role) << name;
      EXPECT_EQ(s.source, source) << name;
      EXPECT_EQ(s.blocks, source == SignalSource::kInput ? std::vector<std::string>{}
                                                         : std::vector<std::string>{"b"})
          << name;
    };
    for (std::size_t k = 0; k < info.inputs.size(); ++k) {
      check(in[k], info.inputs[k], SignalSource::kInput);
    }
    for (const SignalInfo& s : info.states) check("b." + s.name, s, SignalSource::kState);
    for (std::size_t k = 0; k < info.outputs.size(); ++k) {
      check(out[k], info.outputs[k], SignalSource::kBlockOutput);
    }
  }
}

}  // namespace
}  // namespace graybox::models
