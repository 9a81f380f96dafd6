// [[model.augment]] in problem files (problem_file.h, augmentation_toml.h, docs/problem-format.md
// "Augmentations"): every kind parsed and applied leaves the simulated output unchanged at the
// neutral values and changes it once its parameter moves; [model.parameters] sets, frees and fixes
// the new parameters; AugmentationToml reads back to an equal augmentation and the same
// connections; defects name the file, the table with its index, the key's line and what was
// expected and found; the documentation's examples apply to the shipped problems; and `graybox
// fit` runs an augmented problem warm-started from the nominal result.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/problem/augmentation_toml.h"
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/models/augmentation.h"
#include "test_util.h"

namespace graybox::estimators {
namespace {

using apps_testing::PushedCsv;
using apps_testing::PushedProblem;
using apps_testing::ScratchDir;
using apps_testing::WriteText;
using Kind = models::Augmentation::Kind;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// 1-based line of the first line of `text` containing `needle`.
int LineOf(const std::string& text, const std::string& needle) {
  const std::size_t hit = text.find(needle);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + hit, '\n'));
}

template <typename F>
ProblemFileError ErrorOf(F f) {
  try {
    f();
  } catch (const ProblemFileError& e) {
    return e;
  }
  ADD_FAILURE() << "expected a ProblemFileError";
  return ProblemFileError({}, "");
}

// The pushed mass (test_util.h) simulated by RK4 at the data's sample time from rest under its
// constant force: the position per sample.
Eigen::VectorXd SimulatePushed(const models::StateSpaceModel& m, const Eigen::VectorXd& p) {
  const Eigen::MatrixXd u =
      Eigen::MatrixXd::Constant(apps_testing::kSamples, m.NumInputs(), apps_testing::kForce);
  const Trajectory t =
      SimulateRk4(m, Eigen::VectorXd::Zero(m.NumStates()), u, p, apps_testing::kSampleTime);
  EXPECT_TRUE(t.ok);
  return t.y.col(0);
}

// The [estimation] section of PushedProblem's default.
const std::string kEstimation =
    "[estimation]\n"
    "method = \"multiple_shooting\"\n"
    "solver = \"ipopt\"\n"
    "[estimation.multiple_shooting]\n"
    "segment_length = 25\n";

class AugmentedProblem : public ::testing::Test {
 protected:
  void SetUp() override { WriteText(dir_ / "pushed.csv", PushedCsv()); }
  Problem Parse(const std::string& text) {
    WriteText(dir_ / "pushed.toml", text);
    return LoadProblem(dir_ / "pushed.toml");
  }
  ScratchDir dir_;
};

// One table of each kind on the pushed mass (input force, blocks load and friction, output
// load.q), the parameter that moves it and a value away from neutral.
struct KindCase {
  std::string table;
  models::Augmentation expected;
  std::string parameter;
  double moved;
};

std::vector<KindCase> KindCases() {
  std::vector<KindCase> cases;
  models::Augmentation a;
  a.kind = Kind::kAdd;
  a.instance = "coulomb";
  a.type = "friction.coulomb";
  a.options.words["motion"] = "prismatic";
  a.options.numbers["steepness"] = {100.0};
  a.inputs = {"load.qd"};
  a.outputs = {"-force"};
  cases.push_back(
      {"[[model.augment]]\n"
       "instance = \"coulomb\"\n"
       "type = \"friction.coulomb\"\n"
       "options = { motion = \"prismatic\", steepness = 100 }\n"
       "inputs = [\"load.qd\"]\n"
       "outputs = [\"-force\"]\n",
       a, "coulomb.fc", 0.5});
  a = {};
  a.kind = Kind::kOnSignal;
  a.instance = "delay";
  a.type = "delay.first_order";
  a.options.words["unit"] = "N";
  a.options.numbers["typical_range"] = {-5.0, 5.0};
  a.signal = "force";
  cases.push_back(
      {"[[model.augment]]\n"
       "instance = \"delay\"\n"
       "type = \"delay.first_order\"\n"
       "options = { unit = \"N\", typical_range = [-5, 5.0] }\n"
       "on_signal = \"force\"\n",
       a, "delay.w", 1.0});
  a = {};
  a.kind = Kind::kOnOutput;
  a.instance = "offset";
  a.type = "sensor.offset";
  a.options.words["unit"] = "m";
  a.signal = "load.q";
  cases.push_back(
      {"[[model.augment]]\n"
       "instance = \"offset\"\n"
       "type = \"sensor.offset\"\n"
       "options = { unit = \"m\" }\n"
       "on_output = \"load.q\"\n",
       a, "offset.b", 0.01});
  a = {};
  a.kind = Kind::kForReaders;
  a.instance = "payload";
  a.type = "mechanics.payload";
  a.options.words["motion"] = "prismatic";
  a.options.numbers["axis_inertia"] = {1.0};
  a.signal = "force";
  a.readers = {"load"};
  a.extra_inputs = {"load.q"};
  cases.push_back(
      {"[[model.augment]]\n"
       "instance = \"payload\"\n"
       "type = \"mechanics.payload\"\n"
       "options = { motion = \"prismatic\", axis_inertia = 1.0 }\n"
       "for_readers = { signal = \"force\", readers = [\"load\"], "
       "extra_inputs = [\"load.q\"] }\n",
       a, "payload.m", 0.5});
  return cases;
}

// Every moved parameter changes the position by millimetres within the 2 s record; rounding
// would be ~1e-16.
constexpr double kVisibleChange = 1e-4;  // m

TEST_F(AugmentedProblem, EachKindIsParsedAppliedAndNeutral) {
  const Problem nominal = Parse(PushedProblem());
  const Eigen::VectorXd before = SimulatePushed(nominal.built, nominal.built.ParameterValues());
  for (const KindCase& c : KindCases()) {
    SCOPED_TRACE(c.expected.instance);
    // Appended after [estimation]: the table still belongs to [model].
    const Problem p = Parse(PushedProblem() + "\n" + c.table);
    ASSERT_EQ(p.augmentations.size(), 1u);
    EXPECT_EQ(p.augmentations[0], c.expected);
    EXPECT_EQ(p.blocks.back(), std::make_pair(c.expected.instance, c.expected.type));
    const int k = p.built.ParameterIndex(c.parameter);
    const models::ModelParameter& par = p.built.parameters[k];
    EXPECT_EQ(par.value, par.info.neutral);
    EXPECT_TRUE(par.free);
    // The nominal parameters keep the file's settings.
    EXPECT_EQ(p.built.parameters[p.built.ParameterIndex("load.mass")].value, 1.0);
    const Eigen::VectorXd after = SimulatePushed(p.built, p.built.ParameterValues());
    // The blocks are exact identities at their neutral values (their headers): bit for bit.
    for (int i = 0; i < before.size(); ++i) ASSERT_EQ(after[i], before[i]) << "sample " << i;
    Eigen::VectorXd values = p.built.ParameterValues();
    values[k] = c.moved;
    const Eigen::VectorXd changed = SimulatePushed(p.built, values);
    EXPECT_GT((changed - before).cwiseAbs().maxCoeff(), kVisibleChange);
  }
}

TEST_F(AugmentedProblem, ParametersTableSetsFreesAndFixesTheNewParameters) {
  // [model.parameters] stands before the augment tables in the file and still applies to them;
  // a pattern matches them too.
  const std::string text = PushedProblem(kEstimation,
                                         "\"load.mass\" = 1.0\n"
                                         "\"friction.fv\" = 1.0\n"
                                         "\"coulomb.fc\" = { value = 2.5, upper = 10.0 }\n"
                                         "\"delay.*\" = { free = false }\n") +
                           "\n" + KindCases()[0].table + "\n" + KindCases()[1].table;
  const Problem p = Parse(text);
  const auto& fc = p.built.parameters[p.built.ParameterIndex("coulomb.fc")];
  EXPECT_EQ(fc.value, 2.5);
  EXPECT_EQ(fc.upper, 10.0);
  EXPECT_TRUE(fc.free);
  const auto& w = p.built.parameters[p.built.ParameterIndex("delay.w")];
  EXPECT_FALSE(w.free);
  EXPECT_EQ(w.value, 0.0);
  EXPECT_FALSE(p.built.parameters[p.built.ParameterIndex("delay.T")].free);
  ASSERT_EQ(p.augmentations.size(), 2u);
  EXPECT_EQ(p.augmentations[1].instance, "delay");
  // A parameter of an augmentation that is not there is an unknown parameter, as ever.
  const std::string missing =
      PushedProblem(kEstimation, "\"load.mass\" = 1.0\n\"coulomb.fc\" = 2.0\n");
  const ProblemFileError e = ErrorOf([&] { Parse(missing); });
  EXPECT_TRUE(Contains(e.what(), "coulomb.fc")) << e.what();
}

void ExpectSameConnections(const models::Model& x, const models::Model& y) {
  const auto a = x.Blocks(), b = y.Blocks();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].instance, b[i].instance);
    EXPECT_EQ(a[i].type, b[i].type);
    EXPECT_EQ(a[i].inputs, b[i].inputs);
    EXPECT_EQ(a[i].outputs, b[i].outputs);
  }
  EXPECT_EQ(x.Outputs(), y.Outputs());
}

TEST_F(AugmentedProblem, AugmentationTomlReadsBackToTheSameAugmentation) {
  std::vector<models::Augmentation> all;
  for (const KindCase& c : KindCases()) all.push_back(c.expected);
  // Numbers that need every digit, whole numbers, a negative zero, exponents; a word that needs
  // escaping; readers with on_output.
  models::Augmentation d;
  d.kind = Kind::kOnSignal;
  d.instance = "delay2";
  d.type = "delay.first_order";
  d.options.words["unit"] = "N \"net\" \\ 1";
  d.options.words["form"] = "pade";
  d.options.numbers["typical_range"] = {-0.0, 1.0 / 3.0};
  d.signal = "force";
  all.push_back(d);
  models::Augmentation c;
  c.kind = Kind::kAdd;
  c.instance = "coulomb2";
  c.type = "friction.coulomb";
  c.options.words["motion"] = "prismatic";
  c.options.numbers["steepness"] = {1.0e6};
  c.inputs = {"load.qd"};
  c.outputs = {"-force"};
  all.push_back(c);
  c.instance = "coulomb3";
  c.options.numbers["steepness"] = {2.5e-7};
  all.push_back(c);
  for (const models::Augmentation& a : all) {
    const std::string table = AugmentationToml(a);
    SCOPED_TRACE(table);
    const Problem p = Parse(PushedProblem() + "\n" + table);
    ASSERT_EQ(p.augmentations.size(), 1u);
    EXPECT_EQ(p.augmentations[0], a);
    models::Model direct = Parse(PushedProblem()).model;
    models::ApplyAugmentation(&direct, a);
    ExpectSameConnections(p.model, direct);
  }
  // -0 stays negative (== does not tell).
  const Problem negative = Parse(PushedProblem() + "\n" + AugmentationToml(d));
  EXPECT_TRUE(std::signbit(negative.augmentations[0].options.numbers.at("typical_range")[0]));
  // The text itself: one key per line, numbers without needless digits.
  EXPECT_EQ(AugmentationToml(all[0]),
            "[[model.augment]]\n"
            "instance = \"coulomb\"\n"
            "type = \"friction.coulomb\"\n"
            "options = { motion = \"prismatic\", steepness = 100 }\n"
            "inputs = [\"load.qd\"]\n"
            "outputs = [\"-force\"]\n");
  EXPECT_EQ(AugmentationToml(all[3]),
            "[[model.augment]]\n"
            "instance = \"payload\"\n"
            "type = \"mechanics.payload\"\n"
            "options = { axis_inertia = 1, motion = \"prismatic\" }\n"
            "for_readers = { signal = \"force\", readers = [\"load\"], extra_inputs = "
            "[\"load.q\"] }\n");
  models::Augmentation o = all[2];
  o.readers = {"friction"};
  o.options = {};
  EXPECT_EQ(AugmentationToml(o),
            "[[model.augment]]\n"
            "instance = \"offset\"\n"
            "type = \"sensor.offset\"\n"
            "on_output = \"load.q\"\n"
            "readers = [\"friction\"]\n");
  // What the parser could not read back is refused.
  models::Augmentation bad = all[0];
  bad.options.numbers["steepness"] = {std::nan("")};
  EXPECT_THROW(AugmentationToml(bad), std::invalid_argument);
  bad = all[0];
  bad.options.numbers["motion"] = {1.0};
  EXPECT_THROW(AugmentationToml(bad), std::invalid_argument);
  bad = all[0];
  bad.signal = "force";
  EXPECT_THROW(AugmentationToml(bad), models::AugmentationError);
}

TEST_F(AugmentedProblem, DefectsNameTheTableTheKeyAndWhatWasExpected) {
  const std::string ok = KindCases()[0].table;
  struct Defect {
    std::string table;  // appended after a valid first table: reported as model.augment[1]
    std::string key_line;
    std::string table_path;
    std::vector<std::string> parts;
  };
  const std::vector<Defect> defects = {
      {"[[model.augment]]\ninstance = \"d\"\ntype = \"delay.first_order\"\non_singal = \"force\"\n",
       "on_singal",
       "model.augment[1]",
       {"unknown key 'on_singal'; did you mean 'on_signal'?"}},
      {"[[model.augment]]\ntype = \"delay.first_order\"\non_signal = \"force\"\n",
       "[[model.augment]]\ntype",
       "model.augment[1]",
       {"missing key 'instance'"}},
      {"[[model.augment]]\ninstance = \"d\"\ntype = \"delay.first_order\"\n",
       "[[model.augment]]\ninstance = \"d\"",
       "model.augment[1]",
       {"augmentation 'd': missing placement: expected exactly one of 'inputs' and 'outputs'",
        "got none of them"}},
      {"[[model.augment]]\ninstance = \"d\"\ntype = \"delay.first_order\"\non_signal = "
       "\"force\"\non_output = \"load.q\"\n",
       "on_output",
       "model.augment[1]",
       {"got both 'on_signal' and 'on_output'"}},
      {"[[model.augment]]\ninstance = \"d\"\ntype = \"delay.first_order\"\non_signal = "
       "\"forse\"\n",
       "on_signal = \"forse\"",
       "model.augment[1]",
       {"augmentation 'd': 'on_signal': expected a signal of model 'pushed', got 'forse'",
        "did you mean 'force'?"}},
      {"[[model.augment]]\ninstance = \"d\"\ntype = \"delay.first_order\"\non_signal = "
       "\"force\"\nreaders = [\"load\"]\n",
       "readers = [\"load\"]",
       "model.augment[1]",
       {"'readers' goes with 'on_output'"}},
      {"[[model.augment]]\ninstance = \"s\"\ntype = \"sensor.ofset\"\non_output = \"load.q\"\n",
       "sensor.ofset",
       "model.augment[1]",
       {"'type'", "unknown block type 'sensor.ofset'", "did you mean 'sensor.offset'?"}},
      {"[[model.augment]]\ninstance = \"s\"\ntype = \"sensor.offset\"\noptions = { unt = \"m\" "
       "}\non_output = \"load.q\"\n",
       "unt",
       "model.augment[1]",
       {"'options'", "did you mean 'unit'?"}},
      {"[[model.augment]]\ninstance = \"s\"\ntype = \"sensor.offset\"\non_output = \"load.qq\"\n",
       "load.qq",
       "model.augment[1]",
       {"'on_output': expected an output channel of model 'pushed' ('load.q'), got 'load.qq'",
        "did you mean 'load.q'?"}},
      {"[[model.augment]]\ninstance = \"s\"\ntype = \"sensor.offset\"\non_output = "
       "\"load.q\"\nreaders = [\"friction\"]\n",
       "readers = [\"friction\"]",
       "model.augment[1]",
       {"expected an instance that reads 'load.q', got 'friction', which does not"}},
      {"[[model.augment]]\ninstance = \"z\"\ntype = \"actuator.deadzone\"\n"
       "for_readers = { signal = \"force\", readers = [\"lod\"] }\n",
       "for_readers",
       "model.augment[1].for_readers",
       {"'for_readers.readers': entry 0: expected a block instance of model 'pushed', got "
        "'lod'",
        "did you mean 'load'?"}},
      {"[[model.augment]]\ninstance = \"z\"\ntype = \"actuator.deadzone\"\n"
       "for_readers = { signal = \"force\" }\n",
       "for_readers",
       "model.augment[1].for_readers",
       {"missing key 'readers'"}},
      {"[[model.augment]]\ninstance = \"z\"\ntype = \"actuator.deadzone\"\n"
       "for_readers = { signal = \"force\", readers = [\"load\"], extra_input = [] }\n",
       "for_readers",
       "model.augment[1].for_readers",
       {"unknown key 'extra_input'; did you mean 'extra_inputs'?"}},
      {"[[model.augment]]\ninstance = \"p\"\ntype = \"mechanics.payload\"\n"
       "options = { motion = \"prismatic\", axis_inertia = 1.0 }\n"
       "for_readers = { signal = \"force\", readers = [\"load\"] }\n",
       "for_readers",
       "model.augment[1].for_readers",
       {"'for_readers.extra_inputs': expected 1 extra input(s) after the signal", "got 0"}},
      {"[[model.augment]]\ninstance = \"friction\"\ntype = \"friction.viscous\"\n"
       "inputs = [\"load.qd\"]\noutputs = [\"-force\"]\n",
       "instance = \"friction\"",
       "model.augment[1]",
       {"'instance': expected a new instance name, got 'friction'"}},
      {"[[model.augment]]\ninstance = \"v\"\ntype = \"friction.viscous\"\n"
       "inputs = [\"load.qd\", \"load.q\"]\noutputs = [\"-force\"]\n",
       "inputs = [\"load.qd\", \"load.q\"]",
       "model.augment[1]",
       {"'inputs': expected 1 input connection(s)", "got 2"}},
      {"[[model.augment]]\ninstance = \"v\"\ntype = \"friction.viscous\"\n"
       "inputs = [\"load.qdd\"]\noutputs = [\"-force\"]\n",
       "inputs = [\"load.qdd\"]",
       "model.augment[1]",
       {"'inputs': entry 0: expected a signal of model 'pushed', got 'load.qdd'",
        "did you mean 'load.qd'?"}},
  };
  for (const Defect& d : defects) {
    SCOPED_TRACE(d.table);
    const std::string text = PushedProblem() + "\n" + ok + "\n" + d.table;
    const ProblemFileError e = ErrorOf([&] { Parse(text); });
    EXPECT_EQ(e.where().table, d.table_path) << e.what();
    EXPECT_EQ(e.where().line,
              LineOf(text, ok + "\n" + d.table) + LineOf(ok + "\n" + d.table, d.key_line) - 1)
        << e.what();
    EXPECT_TRUE(Contains(e.where().file, "pushed.toml"));
    for (const auto& part : d.parts) EXPECT_TRUE(Contains(e.what(), part)) << e.what();
  }
}

// The pushed problem without its friction block (a mass alone), with `augment` appended.
std::string MassOnly(const std::string& augment) {
  std::string text = PushedProblem(kEstimation, "\"load.mass\" = { value = 1.0, scale = 1.0 }\n");
  const std::string friction =
      "[[model.blocks]]\n"
      "instance = \"friction\"\n"
      "type = \"friction.viscous\"\n"
      "options = { motion = \"prismatic\" }\n"
      "inputs = [\"load.qd\"]\n"
      "outputs = [\"-force\"]\n"
      "\n";
  text.erase(text.find(friction), friction.size());
  return text + augment;
}

// The re-run of a candidate: the nominal model (a mass without the friction that generated the
// data) is fitted, then the friction is added by a [[model.augment]] table and the problem is
// fitted from the nominal result: the new parameter starts at its neutral 0, the others at the
// nominal fit, and the true values are recovered (the noise-free recovery of cli_test.cc).
TEST_F(AugmentedProblem, FitRunsTheAugmentedProblemFromTheNominalResult) {
  constexpr double kRecoveryTolerance = 1e-4;
  using Json = nlohmann::json;
  WriteText(dir_ / "nominal.toml", MassOnly(""));
  const apps_testing::RunResult nominal = apps_testing::RunGraybox(
      "fit nominal.toml --out nominal", dir_ / "log1.txt", dir_.path().string());
  ASSERT_EQ(nominal.exit_code, 0) << nominal.output;
  const Json n = Json::parse(apps_testing::ReadText(dir_ / "nominal/result.json"));
  WriteText(dir_ / "friction.toml", MassOnly("\n[[model.augment]]\n"
                                             "instance = \"friction\"\n"
                                             "type = \"friction.viscous\"\n"
                                             "options = { motion = \"prismatic\" }\n"
                                             "inputs = [\"load.qd\"]\n"
                                             "outputs = [\"-force\"]\n"));
  const apps_testing::RunResult again =
      apps_testing::RunGraybox("fit friction.toml --from nominal/result.json --out friction",
                               dir_ / "log2.txt", dir_.path().string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const Json r = Json::parse(apps_testing::ReadText(dir_ / "friction/result.json"));
  const Json& fv = r["parameters"]["friction.fv"];
  const Json& mass = r["parameters"]["load.mass"];
  EXPECT_EQ(fv["initial"].get<double>(), 0.0);
  EXPECT_TRUE(fv["free"].get<bool>());
  EXPECT_EQ(mass["initial"].get<double>(), n["parameters"]["load.mass"]["value"].get<double>());
  EXPECT_NEAR(mass["value"].get<double>(), apps_testing::kTrueMass,
              kRecoveryTolerance * apps_testing::kTrueMass);
  EXPECT_NEAR(fv["value"].get<double>(), apps_testing::kTrueViscous,
              kRecoveryTolerance * apps_testing::kTrueViscous);
  // The nominal problem does not take the augmented result: its friction.fv is unknown there.
  const apps_testing::RunResult back =
      apps_testing::RunGraybox("fit nominal.toml --from friction/result.json --out back",
                               dir_ / "log3.txt", dir_.path().string());
  EXPECT_EQ(back.exit_code, 2) << back.output;
  EXPECT_TRUE(Contains(back.output, "'friction.fv' is not a parameter")) << back.output;
}

// The examples of docs/problem-format.md "Augmentations" on the shipped problems they name.
TEST(AugmentationDocs, ExamplesApplyToTheShippedProblems) {
  const std::string root = std::string(GRAYBOX_SOURCE_DIR);
  const std::string doc = apps_testing::ReadText(root + "/docs/problem-format.md");
  const std::size_t section = doc.find("### Augmentations");
  ASSERT_NE(section, std::string::npos);
  std::vector<std::string> examples;  // the ```toml fences of the section
  const std::size_t end = doc.find("\n### ", section + 1);
  for (std::size_t at = doc.find("```toml\n", section); at < end;
       at = doc.find("```toml\n", at + 1)) {
    const std::size_t body_end = doc.find("```", at + 8);
    examples.push_back(doc.substr(at + 8, body_end - at - 8));
  }
  ASSERT_EQ(examples.size(), 2u);
  // Coulomb friction on the diagnosis's nominal model is emps_closed_loop.toml again.
  const std::string no_coulomb_path = root + "/problems/emps/emps_closed_loop_no_coulomb.toml";
  std::string text = apps_testing::ReadText(no_coulomb_path);
  text.replace(text.find("[model.parameters]\n"), 19,
               "[model.parameters]\n"
               "\"coulomb.fc\" = { value = 15.0, upper = 1000.0, scale = 10.0 }\n");
  const Problem augmented = ParseProblem(text + "\n" + examples[0], no_coulomb_path);
  const Problem shipped = LoadProblem(root + "/problems/emps/emps_closed_loop.toml");
  auto sorted = [](std::vector<std::pair<std::string, std::string>> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  EXPECT_EQ(sorted(augmented.blocks), sorted(shipped.blocks));
  ASSERT_EQ(augmented.built.NumParameters(), shipped.built.NumParameters());
  for (const auto& a : shipped.built.parameters) {
    const auto& b = augmented.built.parameters[augmented.built.ParameterIndex(a.name)];
    EXPECT_EQ(a.value, b.value) << a.name;
    EXPECT_EQ(a.free, b.free) << a.name;
    EXPECT_EQ(a.lower, b.lower) << a.name;
    EXPECT_EQ(a.upper, b.upper) << a.name;
    EXPECT_EQ(a.scale, b.scale) << a.name;
  }
  for (const auto& c : shipped.model.Blocks()) {
    for (const auto& d : augmented.model.Blocks()) {
      if (d.instance != c.instance) continue;
      EXPECT_EQ(d.inputs, c.inputs) << c.instance;
      EXPECT_EQ(d.outputs, c.outputs) << c.instance;
    }
  }
  // The delay on a KUKA torque, the sensor offset and the dead zone on EMPS: the second example
  // holds all three; each applies to the problem it names.
  const std::string second = examples[1];
  const std::size_t emps_part = second.find("[[model.augment]]\ninstance = \"sensor_offset\"");
  ASSERT_NE(emps_part, std::string::npos);
  const Problem emps = ParseProblem(
      apps_testing::ReadText(no_coulomb_path) + "\n" + second.substr(emps_part), no_coulomb_path);
  ASSERT_EQ(emps.augmentations.size(), 2u);
  EXPECT_EQ(emps.model.Outputs()[0].second, "sensor_offset.out");
  // The KUKA problem guesses its shooting nodes from the data, which cannot give the delay's
  // state: rejected naming it, and accepted with node_guess = "simulation" (as documented).
  const std::string kuka_path = root + "/problems/kuka/roblue_friction_ms.toml";
  std::string kuka_text = apps_testing::ReadText(kuka_path) + "\n" + second.substr(0, emps_part);
  const ProblemFileError e = ErrorOf([&] { ParseProblem(kuka_text, kuka_path); });
  EXPECT_TRUE(Contains(e.what(), "state 'input_delay.x'")) << e.what();
  const std::string data_guess = "node_guess = \"data\"";
  kuka_text.replace(kuka_text.find(data_guess), data_guess.size(), "node_guess = \"simulation\"");
  const Problem kuka = ParseProblem(kuka_text, kuka_path);
  ASSERT_EQ(kuka.augmentations.size(), 1u);
  EXPECT_EQ(kuka.model.Blocks()[0].inputs[0], "input_delay.out");
}

}  // namespace
}  // namespace graybox::estimators
