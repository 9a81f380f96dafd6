// Augmentations (graybox/models/augmentation.h): each kind applied to a small model of registered
// blocks leaves its simulated output unchanged at the neutral values and changes it once a new
// parameter moves; ApplyAugmentation connects the block exactly as the Model operation it
// stands for; defects name the instance, the field, and what was expected and found, and leave
// the model unchanged.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "graybox/models/augmentation.h"
#include "graybox/models/model.h"

namespace graybox::models {
namespace {

using Kind = Augmentation::Kind;

// u [V] -> drive (gain 2 N/V) -> force -> load (1 kg) with viscous friction; output load.q.
Model Slide() {
  Model m("slide");
  m.AddInput("u", "V", "command", -1.0, 1.0);
  BlockOptions volts;
  volts.words["input_unit"] = "V";
  volts.words["output_unit"] = "N";
  m.AddBlock("drive", "signal.gain", volts, {"u"}, {"force"});
  m.AddBlock("load", "mechanics.mass", {}, {"force"}, {});
  BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  m.AddBlock("viscous", "friction.viscous", prismatic, {"load.qd"}, {"-force"});
  m.AddOutput("load.q");
  m.SetParameter("drive.k", 2.0);
  m.SetParameter("viscous.fv", 0.5);
  return m;
}

// RK4 at 10 ms from rest under u = sin(2 t); the first output per step.
std::vector<double> Simulate(const StateSpaceModel& ss) {
  constexpr double kDt = 0.01;
  constexpr int kSteps = 300;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(ss.NumStates());
  const Eigen::VectorXd p = ss.ParameterValues();
  std::vector<double> y;
  for (int k = 0; k < kSteps; ++k) {
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(ss.NumInputs(), std::sin(2.0 * k * kDt));
    auto f = [&](const Eigen::VectorXd& xs) { return ss.dynamics({xs, u, p})[0]; };
    const Eigen::VectorXd k1 = f(x), k2 = f(x + 0.5 * kDt * k1), k3 = f(x + 0.5 * kDt * k2),
                          k4 = f(x + kDt * k3);
    x += kDt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    y.push_back(ss.output({x, u, p})[0][0]);
  }
  return y;
}

// One augmentation of every kind (and a second for_readers with an extra input), with the
// parameter moved away from neutral and its value.
struct Case {
  Augmentation augmentation;
  std::string moved;
  double value;
};

std::vector<Case> Cases() {
  std::vector<Case> cases;
  {
    Augmentation a;
    a.kind = Kind::kAdd;
    a.instance = "coulomb";
    a.type = "friction.coulomb";
    a.options.words["motion"] = "prismatic";
    a.options.numbers["steepness"] = {1000.0};
    a.inputs = {"load.qd"};
    a.outputs = {"-force"};
    cases.push_back({a, "coulomb.fc", 0.5});
  }
  {
    Augmentation a;
    a.kind = Kind::kOnSignal;
    a.instance = "input_delay";
    a.type = "delay.first_order";
    a.options.words["unit"] = "V";
    a.signal = "u";
    cases.push_back({a, "input_delay.w", 1.0});
  }
  {
    Augmentation a;
    a.kind = Kind::kOnOutput;
    a.instance = "sensor_offset";
    a.type = "sensor.offset";
    a.options.words["unit"] = "m";
    a.signal = "load.q";
    cases.push_back({a, "sensor_offset.b", 0.01});
  }
  {
    Augmentation a;
    a.kind = Kind::kForReaders;
    a.instance = "deadzone";
    a.type = "actuator.deadzone";
    a.options.words["unit"] = "V";
    a.signal = "u";
    a.readers = {"drive"};
    cases.push_back({a, "deadzone.b", 0.2});
  }
  {
    Augmentation a;
    a.kind = Kind::kForReaders;
    a.instance = "payload";
    a.type = "mechanics.payload";
    a.options.words["motion"] = "prismatic";
    a.options.numbers["axis_inertia"] = {1.0};
    a.signal = "force";
    a.readers = {"load"};
    a.extra_inputs = {"load.q"};
    cases.push_back({a, "payload.m", 0.5});
  }
  {
    Augmentation a;
    a.kind = Kind::kOnInput;
    a.instance = "command_delay";
    a.type = "delay.first_order";
    a.options.words["unit"] = "V";
    a.signal = "u";
    cases.push_back({a, "command_delay.w", 1.0});
  }
  return cases;
}

// A change of the output larger than rounding: every moved parameter changes the position by
// millimetres or more over the 3 s record.
constexpr double kVisibleChange = 1e-4;  // m

TEST(Augmentation, EachKindIsNeutralUntilItsParameterMoves) {
  const std::vector<double> before = Simulate(Slide().Build());
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.augmentation.instance);
    Model m = Slide();
    ApplyAugmentation(&m, c.augmentation);
    const ModelParameter& moved = m.Parameter(c.moved);
    EXPECT_EQ(moved.value, moved.info.neutral);
    EXPECT_TRUE(moved.free);
    const std::vector<double> after = Simulate(m.Build());
    ASSERT_EQ(after.size(), before.size());
    // At the neutral values the blocks are exact identities (their headers), so bit for bit.
    for (std::size_t k = 0; k < before.size(); ++k) ASSERT_EQ(after[k], before[k]) << "step " << k;
    m.SetParameter(c.moved, c.value);
    const std::vector<double> changed = Simulate(m.Build());
    double largest = 0.0;
    for (std::size_t k = 0; k < before.size(); ++k) {
      largest = std::max(largest, std::fabs(changed[k] - before[k]));
    }
    EXPECT_GT(largest, kVisibleChange);
  }
}

// On an input that a block subtracts from (a torque command with friction), InsertOnInput acts on
// the command alone: with a gain of 3 in series, the load's force is 3 u - fv v, where
// InsertOnSignal would give 3 (u - fv v).
TEST(Augmentation, OnInputActsBeforeTheBlocksThatAddToTheInput) {
  Model m("motor");
  m.AddInput("tau", "N", "force command", -1.0, 1.0);
  m.AddBlock("load", "mechanics.mass", {}, {"tau"}, {});
  BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  m.AddBlock("viscous", "friction.viscous", prismatic, {"load.qd"}, {"-tau"});
  m.AddOutput("load.q");
  m.SetParameter("load.mass", 1.0);
  m.SetParameter("viscous.fv", 0.5);
  Augmentation a;
  a.kind = Kind::kOnInput;
  a.instance = "gain";
  a.type = "signal.gain";
  a.options.words["input_unit"] = "N";
  a.options.words["output_unit"] = "N";
  a.signal = "tau";
  ApplyAugmentation(&m, a);
  m.SetParameter("gain.k", 3.0);
  for (const auto& b : m.Blocks()) {
    if (b.instance == "viscous") {
      EXPECT_EQ(b.outputs, std::vector<std::string>{"-gain.out"});
    }
    if (b.instance == "load") {
      EXPECT_EQ(b.inputs, std::vector<std::string>{"gain.out"});
    }
    if (b.instance == "gain") {
      EXPECT_EQ(b.inputs, std::vector<std::string>{"tau"});
    }
  }
  const StateSpaceModel ss = m.Build();
  const Eigen::VectorXd x = Eigen::Vector2d(0.1, 0.4);  // q, qd
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 2.0);
  const double qdd = ss.dynamics({x, u, ss.ParameterValues()})[0][ss.StateIndex("load.qd")];
  EXPECT_NEAR(qdd, 3.0 * 2.0 - 0.5 * 0.4, 1e-12);
  Augmentation not_an_input = a;
  not_an_input.instance = "gain_2";
  not_an_input.signal = "load.q";
  EXPECT_THROW(ApplyAugmentation(&m, not_an_input), AugmentationError);
}

TEST(Augmentation, ConnectsTheBlockAsTheModelOperationDoes) {
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.augmentation.instance);
    const Augmentation& a = c.augmentation;
    Model applied = Slide();
    ApplyAugmentation(&applied, a);
    Model direct = Slide();
    switch (a.kind) {
      case Kind::kAdd:
        direct.Augment(a.instance, a.type, a.options, a.inputs, a.outputs);
        break;
      case Kind::kOnSignal:
        direct.InsertOnSignal(a.signal, a.instance, a.type, a.options);
        break;
      case Kind::kOnInput:
        direct.InsertOnInput(
            a.signal, a.instance,
            std::shared_ptr<const Block>(BlockRegistry::Global().Create(a.type, a.options)));
        break;
      case Kind::kOnOutput:
        direct.InsertOnOutput(a.signal, a.instance, a.type, a.options, a.readers);
        break;
      case Kind::kForReaders:
        direct.InsertForReaders(a.signal, a.instance, a.type, a.options, a.readers, a.extra_inputs);
        break;
    }
    const auto x = applied.Blocks(), y = direct.Blocks();
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      EXPECT_EQ(x[i].instance, y[i].instance);
      EXPECT_EQ(x[i].type, y[i].type);
      EXPECT_EQ(x[i].inputs, y[i].inputs);
      EXPECT_EQ(x[i].outputs, y[i].outputs);
    }
    EXPECT_EQ(applied.Outputs(), direct.Outputs());
  }
  // What the kinds rewire: for_readers only its readers, on_output the channel and its readers.
  Model m = Slide();
  ApplyAugmentation(&m, Cases()[3].augmentation);
  EXPECT_EQ(m.Blocks()[0].inputs, std::vector<std::string>{"deadzone.out"});
  Model s = Slide();
  ApplyAugmentation(&s, Cases()[2].augmentation);
  EXPECT_EQ(s.Outputs()[0].first, "load.q");
  EXPECT_EQ(s.Outputs()[0].second, "sensor_offset.out");
  EXPECT_EQ(s.Blocks()[2].inputs, std::vector<std::string>{"load.qd"});
}

// The error of applying `a` to Slide(), which must be left unchanged.
AugmentationError ErrorOf(const Augmentation& a) {
  Model m = Slide();
  try {
    ApplyAugmentation(&m, a);
  } catch (const AugmentationError& e) {
    const Model fresh = Slide();
    EXPECT_EQ(m.Blocks().size(), fresh.Blocks().size());
    for (std::size_t i = 0; i < fresh.Blocks().size(); ++i) {
      EXPECT_EQ(m.Blocks()[i].inputs, fresh.Blocks()[i].inputs);
    }
    EXPECT_EQ(m.Outputs(), fresh.Outputs());
    EXPECT_EQ(m.parameters().size(), fresh.parameters().size());
    return e;
  }
  ADD_FAILURE() << "expected an AugmentationError";
  Augmentation none;
  return AugmentationError(none, "", "");
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(Augmentation, DefectsNameTheFieldAndWhatWasExpected) {
  const std::vector<Case> cases = Cases();
  struct Defect {
    Augmentation augmentation;
    std::string field;
    std::vector<std::string> parts;
  };
  std::vector<Defect> defects;
  auto with = [&](int i, auto change) {
    Augmentation a = cases[i].augmentation;
    change(a);
    return a;
  };
  defects.push_back(
      {with(0, [](Augmentation& a) { a.type = "friction.coulom"; }),
       "type",
       {"augmentation 'coulomb' (add), field 'type'", "did you mean 'friction.coulomb'?"}});
  defects.push_back({with(0, [](Augmentation& a) { a.options.words["motion"] = "sliding"; }),
                     "options",
                     {"sliding"}});
  defects.push_back({with(0, [](Augmentation& a) { a.instance = "viscous"; }),
                     "instance",
                     {"expected a new instance name, got 'viscous'"}});
  defects.push_back({with(0, [](Augmentation& a) { a.instance = "a.b"; }),
                     "instance",
                     {"without '.', got 'a.b'"}});
  defects.push_back({with(0,
                          [](Augmentation& a) {
                            a.inputs = {"load.qd", "load.q"};
                          }),
                     "inputs",
                     {"expected 1 input connection(s)", "got 2"}});
  defects.push_back({with(0, [](Augmentation& a) { a.outputs = {}; }),
                     "outputs",
                     {"expected 1 output connection(s)", "got 0"}});
  defects.push_back(
      {with(0, [](Augmentation& a) { a.inputs = {"load.qdd"}; }),
       "inputs",
       {"entry 0: expected a signal of model 'slide', got 'load.qdd'", "did you mean 'load.qd'?"}});
  defects.push_back({with(0, [](Augmentation& a) { a.outputs = {"-load.q"}; }),
                     "outputs",
                     {"writes to state signal 'load.q'"}});
  defects.push_back({with(0, [](Augmentation& a) { a.signal = "u"; }),
                     "signal",
                     {"kind 'add' does not use it, got 'u'"}});
  defects.push_back({with(1, [](Augmentation& a) { a.signal = "uu"; }),
                     "signal",
                     {"expected a signal of model 'slide', got 'uu'", "did you mean 'u'?"}});
  defects.push_back({with(1, [](Augmentation& a) { a.signal = ""; }), "signal", {"got ''"}});
  defects.push_back({with(1, [](Augmentation& a) { a.readers = {"drive"}; }),
                     "readers",
                     {"kind 'on_signal' does not use it, got 'drive'"}});
  defects.push_back({with(4,
                          [](Augmentation& a) {
                            a.kind = Kind::kOnSignal;
                            a.readers.clear();
                            a.extra_inputs.clear();
                          }),
                     "type",
                     {"expected a block with 1 input and 1 output, got type 'mechanics.payload' "
                      "with 2 (F, q) input(s) and 1 (F_eff) output(s)"}});
  defects.push_back({with(2, [](Augmentation& a) { a.signal = "load.qq"; }),
                     "signal",
                     {"expected an output channel of model 'slide' ('load.q'), got 'load.qq'",
                      "did you mean 'load.q'?"}});
  defects.push_back({with(2, [](Augmentation& a) { a.readers = {"viscous"}; }),
                     "readers",
                     {"expected an instance that reads 'load.q', got 'viscous', which does not"}});
  defects.push_back(
      {with(3, [](Augmentation& a) { a.readers = {"drve"}; }),
       "readers",
       {"expected a block instance of model 'slide', got 'drve'", "did you mean 'drive'?"}});
  defects.push_back({with(3, [](Augmentation& a) { a.readers = {}; }),
                     "readers",
                     {"expected at least one block instance that reads 'u', got none"}});
  defects.push_back({with(4, [](Augmentation& a) { a.extra_inputs = {}; }),
                     "extra_inputs",
                     {"expected 1 extra input(s) after the signal", "got 0"}});
  defects.push_back({with(4, [](Augmentation& a) { a.extra_inputs = {"load.x"}; }),
                     "extra_inputs",
                     {"entry 0: expected a signal of model 'slide', got 'load.x'"}});
  defects.push_back({with(4, [](Augmentation& a) { a.inputs = {"load.q"}; }),
                     "inputs",
                     {"kind 'for_readers' does not use it"}});
  for (const Defect& d : defects) {
    SCOPED_TRACE(d.augmentation.instance + " " + d.field);
    const AugmentationError e = ErrorOf(d.augmentation);
    EXPECT_EQ(e.field(), d.field) << e.what();
    EXPECT_TRUE(Contains(e.what(), "augmentation '" + d.augmentation.instance + "' (")) << e.what();
    EXPECT_TRUE(Contains(e.what(), "field '" + d.field + "'")) << e.what();
    for (const auto& part : d.parts) EXPECT_TRUE(Contains(e.what(), part)) << e.what();
  }
}

TEST(Augmentation, ValidateNeedsNoModelAndEqualityComparesEveryField) {
  Augmentation a = Cases()[3].augmentation;
  EXPECT_NO_THROW(a.Validate());
  EXPECT_EQ(a, Cases()[3].augmentation);
  a.options.numbers["typical_range"] = {-1.0, 1.0};
  EXPECT_NE(a, Cases()[3].augmentation);
  a.readers.clear();
  EXPECT_THROW(a.Validate(), AugmentationError);
  EXPECT_STREQ(AugmentationKindName(Kind::kForReaders), "for_readers");
  EXPECT_STREQ(AugmentationKindName(Kind::kOnOutput), "on_output");
}

}  // namespace
}  // namespace graybox::models
