// The [diagnosis] table of problem files (problem_file.h DiagnosisSpec, candidates.h): a slide
// written from generic blocks (gains and integrators, no signal roles, so the metadata finds no
// axis) becomes diagnosable once its axis is named, and the withheld Stribeck friction of the
// shared slide truth is found on it; the effect selection (effects, add_effects, remove_effects),
// the sensor restriction, named actuators and metadata_axes; and every defect is reported with the
// file, the line and what was expected: unknown keys and effects with a suggestion, a velocity
// that is not a state, a force that does not act on the velocity, a missing motion, an unknown
// sensor channel, a bad ripple period.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "graybox/diagnosis/candidates.h"
#include "graybox/diagnosis/screening.h"
#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/problem/problem_file.h"
#include "slide_truth.h"

namespace graybox::diagnosis {
namespace {

// Re-fit budget [s] that the small synthetic problems here never reach (see its use).
constexpr double kRefitSecondsThatNeverBind = 600.0;

namespace est = graybox::estimators;

constexpr char kPath[] = "/nonexistent/generic_slide.toml";  // parsing reads no data

// A slide of mass 1 / inertia.k from generic blocks: net = force - damping.k v, acc =
// inertia.k net, integrated twice; its velocity measured. `diagnosis` is appended as written.
std::string GenericSlide(const std::string& diagnosis) {
  return "[problem]\n"
         "name = \"generic_slide\"\n"
         "[model]\n"
         "inputs = [{ name = \"force\", unit = \"N\", min = -5.0, max = 5.0 }]\n"
         "outputs = [\"vel.y\"]\n"
         "[[model.blocks]]\n"
         "instance = \"drive\"\n"
         "type = \"signal.gain\"\n"
         "inputs = [\"force\"]\n"
         "outputs = [\"net\"]\n"
         "[[model.blocks]]\n"
         "instance = \"inertia\"\n"
         "type = \"signal.gain\"\n"
         "inputs = [\"net\"]\n"
         "outputs = [\"acc\"]\n"
         "[[model.blocks]]\n"
         "instance = \"vel\"\n"
         "type = \"signal.integrator\"\n"
         "inputs = [\"acc\"]\n"
         "[[model.blocks]]\n"
         "instance = \"pos\"\n"
         "type = \"signal.integrator\"\n"
         "inputs = [\"vel.y\"]\n"
         "[[model.blocks]]\n"
         "instance = \"damping\"\n"
         "type = \"signal.gain\"\n"
         "inputs = [\"vel.y\"]\n"
         "outputs = [\"-net\"]\n"
         "[model.parameters]\n"
         "\"drive.k\" = { value = 1.0, free = false }\n"
         "\"inertia.k\" = { value = 1.0, lower = 0.01, upper = 100.0 }\n"
         "\"damping.k\" = { value = 1.0, lower = 0.0, upper = 100.0 }\n"
         "[[data]]\n"
         "name = \"slide\"\n"
         "file = \"slide.csv\"\n"
         "time = \"time\"\n"
         "inputs = { force = \"force\" }\n"
         "outputs = { \"vel.y\" = \"v\" }\n"
         "[estimation]\n"
         "method = \"multiple_shooting\"\n"
         "substeps = 4\n"
         "[estimation.multiple_shooting]\n"
         "segment_length = 20\n" +
         diagnosis;
}

const std::string kNamedAxis =
    "[diagnosis]\n"
    "effects = [\"coulomb\", \"stribeck\", \"power_law_viscous\", \"input_delay\"]\n"
    "[[diagnosis.axes]]\n"
    "velocity = \"vel.y\"\n"
    "force = \"net\"\n"
    "position = \"pos.y\"\n"
    "motion = \"linear\"\n";

std::vector<std::string> Effects(const std::vector<Candidate>& candidates) {
  std::vector<std::string> out;
  for (const auto& c : candidates) out.push_back(c.effect);
  return out;
}

template <typename F>
est::ProblemFileError ErrorOf(F f) {
  try {
    f();
  } catch (const est::ProblemFileError& e) {
    return e;
  }
  ADD_FAILURE() << "expected a ProblemFileError";
  return est::ProblemFileError({}, "");
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

int LineOf(const std::string& text, const std::string& needle) {
  const std::size_t hit = text.find(needle);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + hit, '\n'));
}

TEST(DiagnosisTable, GenericBlocksHaveNoAxisUntilOneIsNamed) {
  const est::Problem bare = est::ParseProblem(GenericSlide(""), kPath);
  EXPECT_TRUE(FindAxes(bare).empty());
  EXPECT_TRUE(Effects(EnumerateCandidates(bare, CandidateOptions{{"coulomb"}})).empty());

  const est::Problem named = est::ParseProblem(GenericSlide(kNamedAxis), kPath);
  ASSERT_EQ(named.diagnosis.axes.size(), 1u);
  const std::vector<MechanicalAxis> axes = FindAxes(named);
  ASSERT_EQ(axes.size(), 1u);
  EXPECT_EQ(axes[0].velocity, "vel.y");
  EXPECT_EQ(axes[0].connection, "-net");  // found by the probe: friction subtracts from net
  EXPECT_EQ(axes[0].position, "pos.y");
  EXPECT_TRUE(axes[0].prismatic);
  EXPECT_EQ(axes[0].inputs, std::vector<std::string>{"force"});  // the input feeding the axis
  // The table's effects, in the library's order; the sensors of the one channel are not listed.
  const std::vector<Candidate> candidates = EnumerateCandidates(named);
  const std::vector<std::string> expected = {"coulomb", "stribeck", "power_law_viscous",
                                             "input_delay"};
  EXPECT_EQ(Effects(candidates), expected);
  for (const auto& c : candidates) {
    if (c.effect == "coulomb") {
      EXPECT_EQ(c.attachment, "velocity vel.y -> force net");
    }
  }
  // Every candidate leaves the model's outputs unchanged at its neutral value.
  const models::StateSpaceModel& base = named.built;
  for (const auto& c : candidates) {
    models::Model a = named.model;
    c.apply(&a);
    const models::StateSpaceModel built = a.Build();
    Eigen::VectorXd x = Eigen::VectorXd::Zero(built.NumStates());
    x[base.StateIndex("vel.y")] = 0.2;
    x[base.StateIndex("pos.y")] = 0.3;
    for (int i = base.NumStates(); i < built.NumStates(); ++i) x[i] = 0.01;
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 1.5);
    const Eigen::VectorXd xdot = built.dynamics({x, u, built.ParameterValues()})[0];
    const Eigen::VectorXd xdot0 =
        base.dynamics({x.head(base.NumStates()), u, base.ParameterValues()})[0];
    constexpr double kNeutralTolerance = 1e-12;  // same expressions in another order
    EXPECT_NEAR((xdot.head(base.NumStates()) - xdot0).norm(), 0.0, kNeutralTolerance) << c.Name();
  }
}

// An equation block (models/equation_block.h) that declares the roles of its signals is an axis
// from metadata, like a registered mechanical block; without roles it needs [diagnosis] axes.
TEST(DiagnosisTable, AnEquationBlockWithRolesIsAnAxisFromMetadata) {
  auto text = [](const std::string& roles) {
    return "[model]\n"
           "inputs = [{ name = \"force\", unit = \"N\", min = -5.0, max = 5.0 }]\n"
           "outputs = [\"slide.v\"]\n"
           "[[model.blocks]]\n"
           "instance = \"slide\"\n"
           "type = \"equations\"\n"
           "inputs = [\"force\"]\n"
           "[model.blocks.equations]\n"
           "inputs = [{ name = \"f\", unit = \"N\"" +
           roles +
           " }]\n"
           "states = [{ name = \"q\", unit = \"m\", derivative = \"v\" },\n"
           "          { name = \"v\", unit = \"m/s\", derivative = \"(f - c * v) / m\"" +
           (roles.empty() ? std::string() : ", role = \"velocity\"") +
           " }]\n"
           "parameters = [{ name = \"m\", unit = \"kg\", nominal = 2.0, lower = 0.1, upper = "
           "10.0 },\n"
           "              { name = \"c\", unit = \"N s/m\", nominal = 3.0, lower = 0.0, upper = "
           "100.0 }]\n"
           "[[data]]\n"
           "file = \"x.csv\"\n"
           "time = \"t\"\n"
           "inputs = { force = \"f\" }\n"
           "outputs = { \"slide.v\" = \"v\" }\n"
           "[estimation]\n"
           "method = \"multiple_shooting\"\n";
  };
  EXPECT_TRUE(FindAxes(est::ParseProblem(text(""), kPath)).empty());
  const est::Problem p = est::ParseProblem(text(", role = \"force\""), kPath);
  const std::vector<MechanicalAxis> axes = FindAxes(p);
  ASSERT_EQ(axes.size(), 1u);
  EXPECT_EQ(axes[0].velocity, "slide.v");
  EXPECT_EQ(axes[0].force, "force");
  EXPECT_EQ(axes[0].connection, "-force");
  EXPECT_EQ(axes[0].position, "slide.q");  // in m, its derivative is v: found without a role
  const std::vector<Candidate> cs = EnumerateCandidates(p, CandidateOptions{{"coulomb"}});
  ASSERT_EQ(cs.size(), 1u);
  EXPECT_EQ(cs[0].attachment, "velocity slide.v -> force force");
}

TEST(DiagnosisTable, SelectsEffectsSensorsAndActuators) {
  const est::Problem p =
      est::ParseProblem(GenericSlide("[diagnosis]\n"
                                     "add_effects = [\"elasticity\"]\n"
                                     "remove_effects = [\"ripple\", \"sensor_scale\"]\n"
                                     "sensors = []\n"
                                     "[[diagnosis.axes]]\n"
                                     "velocity = \"vel.y\"\n"
                                     "force = \"net\"\n"
                                     "motion = \"rotary\"\n"
                                     "sign = \"subtract\"\n"
                                     "inputs = [\"acc\"]\n"),
                        kPath);
  std::vector<std::string> expected;
  for (const auto& e : DefaultEffects()) {
    if (e != "ripple" && e != "sensor_scale") expected.push_back(e);
  }
  expected.insert(std::find(expected.begin(), expected.end(), "backlash"), "elasticity");
  EXPECT_EQ(SelectedEffects(p, {}), expected);
  // A command-line list replaces `effects`; the table's additions and removals still apply.
  EXPECT_EQ(SelectedEffects(p, CandidateOptions{{"coulomb", "ripple"}}),
            (std::vector<std::string>{"coulomb", "elasticity"}));
  const std::vector<MechanicalAxis> axes = FindAxes(p);
  ASSERT_EQ(axes.size(), 1u);
  EXPECT_FALSE(axes[0].prismatic);
  EXPECT_EQ(axes[0].position, "");  // pos.y is in "1", not rad: not found without naming it
  EXPECT_TRUE(axes[0].inputs_named);
  const std::vector<Candidate> candidates = EnumerateCandidates(p);
  for (const auto& c : candidates) {
    EXPECT_NE(c.effect, "sensor_offset") << "sensors = [] lists no channel";
    EXPECT_NE(c.effect, "ripple");
    if (c.effect == "input_delay") {
      EXPECT_EQ(c.attachment, "input acc");
    }
    if (c.effect == "deadzone") {
      EXPECT_EQ(c.attachment, "command acc -> vel");
    }
  }
  EXPECT_EQ(std::count_if(candidates.begin(), candidates.end(),
                          [](const Candidate& c) { return c.effect == "input_delay"; }),
            1);
  EXPECT_EQ(std::count_if(candidates.begin(), candidates.end(),
                          [](const Candidate& c) { return c.effect == "deadzone"; }),
            1);
  // The delay on the block output `acc` leaves the outputs unchanged at its neutral value.
  for (const auto& c : candidates) {
    if (c.effect != "input_delay") continue;
    models::Model a = p.model;
    c.apply(&a);
    EXPECT_NO_THROW(a.Build());
  }
}

TEST(DiagnosisTable, MetadataAxesCanBeSwitchedOff) {
  // A mechanics.mass slide: its axis comes from metadata; naming another axis with
  // metadata_axes = false keeps only that one.
  const std::string text =
      "[model]\n"
      "inputs = [{ name = \"force\", unit = \"N\" }]\n"
      "outputs = [\"load.q\"]\n"
      "[[model.blocks]]\n"
      "instance = \"load\"\n"
      "type = \"mechanics.mass\"\n"
      "inputs = [\"force\"]\n"
      "[[model.blocks]]\n"
      "instance = \"friction\"\n"
      "type = \"friction.viscous\"\n"
      "options = { motion = \"prismatic\" }\n"
      "inputs = [\"load.qd\"]\n"
      "outputs = [\"-force\"]\n"
      "[[data]]\n"
      "file = \"x.csv\"\n"
      "time = \"t\"\n"
      "inputs = { force = \"f\" }\n"
      "outputs = { \"load.q\" = \"q\" }\n"
      "[estimation]\n"
      "method = \"multiple_shooting\"\n";
  EXPECT_EQ(FindAxes(est::ParseProblem(text, kPath)).size(), 1u);
  const est::Problem p = est::ParseProblem(text +
                                               "[diagnosis]\n"
                                               "metadata_axes = false\n"
                                               "[[diagnosis.axes]]\n"
                                               "velocity = \"load.qd\"\n"
                                               "force = \"force\"\n",
                                           kPath);
  const std::vector<MechanicalAxis> axes = FindAxes(p);
  ASSERT_EQ(axes.size(), 1u);
  EXPECT_EQ(axes[0].force, "force");
  EXPECT_EQ(axes[0].position, "load.q");
  EXPECT_EQ(axes[0].present_types, std::vector<std::string>{"friction.viscous"});
  const est::ProblemFileError none =
      ErrorOf([&] { est::ParseProblem(text + "[diagnosis]\nmetadata_axes = false\n", kPath); });
  EXPECT_TRUE(Contains(none.what(), "leaves no axis")) << none.what();
}

TEST(DiagnosisTable, DefectsNameThePlaceAndWhatWasExpected) {
  struct Bad {
    std::string table;
    std::string line_of;  // the text of the line the error must point at
    std::string message;  // part of the message
  };
  const std::vector<Bad> cases = {
      {"[diagnosis]\nefects = [\"coulomb\"]\n", "efects", "did you mean 'effects'"},
      {"[diagnosis]\n[[diagnosis.axes]]\nvelocity = \"vel.x\"\nforce = \"net\"\nmotion = "
       "\"linear\"\n",
       "velocity = \"vel.x\"", "did you mean 'vel.y'"},
      {"[diagnosis]\n[[diagnosis.axes]]\nvelocity = \"acc\"\nforce = \"net\"\n",
       "velocity = \"acc\"", "which a block output writes"},
      {"[diagnosis]\n[[diagnosis.axes]]\nvelocity = \"vel.y\"\nforce = \"pos.y\"\n",
       "force = \"pos.y\"", "got the state 'pos.y'"},
      {"[diagnosis]\n[[diagnosis.axes]]\nvelocity = \"vel.y\"\nforce = \"net\"\n",
       "[[diagnosis.axes]]", "expected 'motion'"},
      {"[diagnosis]\n[[diagnosis.axes]]\nvelocity = \"vel.y\"\nforce = \"net\"\nmotion = "
       "\"linear\"\ninputs = [\"forse\"]\n",
       "inputs = [\"forse\"]", "did you mean 'force'"},
      {"[diagnosis]\nsensors = [\"vel.z\"]\n", "sensors =", "did you mean 'vel.y'"},
      {"[diagnosis]\nripple_periods = [0.1, -2.0]\n", "ripple_periods", "expected a period > 0"},
      {"[diagnosis]\neffects = [\"coulomb\", \"coulomb\"]\n", "effects", "listed twice"},
  };
  for (const Bad& b : cases) {
    const std::string text = GenericSlide(b.table);
    const est::ProblemFileError e = ErrorOf([&] { est::ParseProblem(text, kPath); });
    EXPECT_TRUE(Contains(e.what(), b.message)) << e.what();
    EXPECT_EQ(e.where().file, kPath) << e.what();
    EXPECT_EQ(e.where().line, LineOf(text, b.line_of)) << e.what();
  }
  // Effect names are the diagnosis' own: checked by CheckDiagnosisSpec, at the element.
  const std::string text = GenericSlide("[diagnosis]\nadd_effects = [\"backlash\", \"colomb\"]\n");
  const est::Problem p = est::ParseProblem(text, kPath);
  const est::ProblemFileError e = ErrorOf([&] { CheckDiagnosisSpec(p); });
  EXPECT_TRUE(Contains(e.what(),
                       "'add_effects[1]': unknown effect 'colomb'; did you mean "
                       "'coulomb'?"))
      << e.what();
  EXPECT_EQ(e.where().line, LineOf(text, "add_effects"));
  EXPECT_THROW(EnumerateCandidates(p), est::ProblemFileError);
  // A named force that does not act on the velocity: the probe finds no change.
  const est::Problem q = est::ParseProblem(
      GenericSlide("[diagnosis]\n[[diagnosis.axes]]\nvelocity = \"pos.y\"\nforce = \"net\"\n"
                   "motion = \"linear\"\n"),
      kPath);
  const est::ProblemFileError f = ErrorOf([&] { FindAxes(q); });
  EXPECT_TRUE(Contains(f.what(), "expected the force 'net' to change d(pos.y)/dt")) << f.what();
}

// The shared slide truth with a Stribeck friction of exponent 1 and a hard sign, fitted with the
// generic-block model: on the named axis the screening and re-fits find a Coulomb-like friction
// and close most of the validation error, as on the mechanics.mass slide (screening_test.cc).
TEST(DiagnosisTable, WithheldFrictionIsFoundOnANamedAxis) {
  testing::SlideTruth truth;
  truth.friction = [](double v) {
    return (1.0 + 0.8 * std::exp(-std::fabs(v) / 0.05)) * std::tanh(v / 0.002);
  };
  std::mt19937 rng(testing::TestSeed(20261127u));
  std::vector<est::SplitData> splits = {
      testing::SlideSplit(truth, "estimation", est::SplitRole::kEstimation, 0.0, &rng),
      testing::SlideSplit(truth, "validation", est::SplitRole::kValidation, 0.7, &rng)};
  const est::Problem problem = est::ParseProblem(GenericSlide(kNamedAxis), kPath);
  // SlideSplit measures the velocity and starts both states at rest, as this model's (vel, pos).
  ASSERT_EQ(problem.built.NumStates(), 2);
  const est::FitResult nominal = est::Fit(problem, splits);
  ASSERT_TRUE(nominal.IsSolutionUsable()) << nominal.BriefReport();
  ScreeningOptions options;
  // A budget that binds stops a re-fit at an iteration that depends on the CPU time its iterations
  // take (cache and frequency effects of a loaded machine); one that never binds on these small
  // problems keeps the test deterministic.
  options.refit_max_seconds = kRefitSecondsThatNeverBind;
  options.progress = [](const std::string& line) { std::cout << line << "\n"; };
  const Diagnosis d = ScreenAndRefit(problem, splits, nominal, options);
  std::cout << d.FullReport();
  ASSERT_FALSE(d.refits.empty());
  const RefitResult& best = d.refits.front();
  EXPECT_TRUE(best.ok) << best.failure;
  EXPECT_TRUE(best.effect == "coulomb" || best.effect == "stribeck") << best.effect;
  // At least half of the nominal validation error removed (as on the mechanics.mass slide).
  constexpr double kMinRelativeGain = 0.5;
  EXPECT_GT(best.relative_gain, kMinRelativeGain);
}

}  // namespace
}  // namespace graybox::diagnosis
