// Problem files (graybox/estimators/problem/problem_file.h): the shipped EMPS problems and the
// examples of docs/problem-format.md parse and load; defects are reported with the file, the table,
// the line and a suggestion: unknown keys, block types and variables, NaN and non-monotone time in
// data, length mismatches, infeasible bounds, unknown Ipopt options, formulation/solver mismatches.
#include <gtest/gtest.h>

#include <filesystem>

#include <cmath>
#include <string>
#include <vector>

#include "graybox/estimators/data/mat_file.h"
#include "graybox/estimators/problem/problem_file.h"
#include "test_util.h"

namespace graybox::estimators {
namespace {

using apps_testing::PushedCsv;
using apps_testing::PushedProblem;
using apps_testing::ScratchDir;
using apps_testing::WriteText;

const std::string kEmpsDir = std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps";
const std::string kEmpsData = std::string(GRAYBOX_SHARED_DATA_DIR) + "/emps/DATA_EMPS.mat";
constexpr int kEmpsSamples = 24841;
constexpr double kEmpsGtau = 35.15065188248547;  // N/V, DATA_EMPS.mat gtau

bool HaveEmps() { return std::filesystem::exists(kEmpsData); }

// The error thrown by `f`, or a test failure.
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

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// 1-based line of the first line of `text` containing `needle`.
int LineOf(const std::string& text, const std::string& needle) {
  int line = 1;
  std::size_t pos = 0;
  const std::size_t hit = text.find(needle);
  while ((pos = text.find('\n', pos)) != std::string::npos && pos < hit) {
    ++line;
    ++pos;
  }
  return line;
}

TEST(ShippedProblems, EmpsIdimParsesAndLoads) {
  const Problem p = LoadProblem(kEmpsDir + "/emps_idim.toml");
  EXPECT_EQ(p.name, "emps_idim");
  EXPECT_EQ(p.built.NumStates(), 2);
  EXPECT_EQ(p.built.NumInputs(), 1);
  EXPECT_EQ(p.built.NumOutputs(), 1);
  EXPECT_EQ(p.estimation.method, "equation_error");
  EXPECT_EQ(p.estimation.solver, "ceres");
  const EquationErrorSpec& ee = p.estimation.equation_error;
  EXPECT_EQ(ee.form, "inverse");
  EXPECT_EQ(ee.differentiate.at("load.qd"), "load.q");  // inferred from dq/dt = qd
  EXPECT_EQ(ee.decimate, 10);
  EXPECT_EQ(ee.skip_samples, 49);
  ASSERT_EQ(p.data.size(), 2u);
  EXPECT_EQ(p.data[0].inputs[0].scale_variable, "gtau");
  EXPECT_EQ(p.data[1].splits[0].role, SplitRole::kTest);
  for (const auto& par : p.built.parameters) EXPECT_TRUE(par.free) << par.name;
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data at " << kEmpsData;
  const std::vector<SplitData> splits = LoadData(p);
  ASSERT_EQ(splits.size(), 2u);
  EXPECT_EQ(splits[0].experiment.NumSamples(), kEmpsSamples);
  EXPECT_NEAR(splits[0].experiment.dt, 1e-3, 1e-12);
  const Eigen::MatrixXd vir = ReadMatMatrix(kEmpsData, "vir");
  EXPECT_DOUBLE_EQ(splits[0].experiment.u(100, 0), kEmpsGtau * vir(100, 0));
}

TEST(ShippedProblems, EmpsClosedLoopFixesTheControllerSettings) {
  const Problem p = LoadProblem(kEmpsDir + "/emps_closed_loop.toml");
  const models::StateSpaceModel& m = p.built;
  EXPECT_EQ(m.NumStates(), 3);  // reference.y, load.q, load.qd
  for (const char* fixed : {"controller.kp", "controller.kv", "controller.limit", "drive.k"}) {
    EXPECT_FALSE(m.parameters[m.ParameterIndex(fixed)].free) << fixed;
  }
  for (const char* free : {"load.mass", "viscous.fv", "coulomb.fc", "offset.f_asym"}) {
    EXPECT_TRUE(m.parameters[m.ParameterIndex(free)].free) << free;
  }
  EXPECT_TRUE(p.estimation.multiple_shooting.continuity_as_constraints);
  EXPECT_TRUE(p.estimation.multiple_shooting.fix_initial_state);
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data";
  const std::vector<SplitData> splits = LoadData(p);
  ASSERT_EQ(splits.size(), 2u);
  const Eigen::MatrixXd qg = ReadMatMatrix(kEmpsData, "qg");
  const Experiment& e = splits[0].experiment;
  // rate = true: the forward difference, so its running sum reproduces qg at the samples.
  double r = splits[0].setup.x0[m.StateIndex("reference.y")];
  EXPECT_EQ(r, qg(0, 0));
  for (int k = 0; k < 1000; ++k) r += e.dt * e.u(k, m.InputIndex("qr_rate"));
  EXPECT_NEAR(r, qg(1000, 0), 1e-12);
  EXPECT_EQ(e.u.col(m.InputIndex("pulse")).cwiseAbs().maxCoeff(), 0.0);  // constant = 0.0
}

// The complete examples of docs/problem-format.md are the shipped files up to comments: they
// parse, with the same parameters, data mappings and formulation.
TEST(ShippedProblems, DocumentationExamplesMatchTheShippedFiles) {
  const std::string doc =
      apps_testing::ReadText(std::string(GRAYBOX_SOURCE_DIR) + "/docs/problem-format.md");
  // Each example: a heading "### `problems/<folder>/<file>.toml`" followed by a ```toml fence.
  const std::string heading = "### `problems/";
  const std::string problems = std::string(GRAYBOX_SOURCE_DIR) + "/problems/";
  int found = 0;
  for (std::size_t at = doc.find(heading); at != std::string::npos;
       at = doc.find(heading, at + 1)) {
    const std::size_t name_begin = at + heading.size();
    const std::size_t name_end = doc.find('`', name_begin);
    const std::size_t fence = doc.find("```toml\n", name_end);
    const std::size_t body_end = doc.find("```", fence + 8);
    ASSERT_NE(name_end, std::string::npos);
    ASSERT_NE(fence, std::string::npos);
    ASSERT_NE(body_end, std::string::npos);
    ++found;
    const std::string file = doc.substr(name_begin, name_end - name_begin);
    SCOPED_TRACE(file);
    const Problem doc_problem =
        ParseProblem(doc.substr(fence + 8, body_end - fence - 8), problems + file);
    const Problem shipped = LoadProblem(problems + file);
    ASSERT_EQ(doc_problem.built.NumParameters(), shipped.built.NumParameters());
    for (int i = 0; i < shipped.built.NumParameters(); ++i) {
      const auto& a = doc_problem.built.parameters[i];
      const auto& b = shipped.built.parameters[i];
      EXPECT_EQ(a.name, b.name);
      EXPECT_EQ(a.value, b.value) << a.name;
      EXPECT_EQ(a.free, b.free) << a.name;
      EXPECT_EQ(a.lower, b.lower) << a.name;
      EXPECT_EQ(a.upper, b.upper) << a.name;
      EXPECT_EQ(a.scale, b.scale) << a.name;
    }
    EXPECT_EQ(doc_problem.blocks, shipped.blocks);
    ASSERT_EQ(doc_problem.data.size(), shipped.data.size());
    for (std::size_t d = 0; d < shipped.data.size(); ++d) {
      EXPECT_EQ(doc_problem.data[d].path, shipped.data[d].path);
      ASSERT_EQ(doc_problem.data[d].inputs.size(), shipped.data[d].inputs.size());
      for (std::size_t i = 0; i < shipped.data[d].inputs.size(); ++i) {
        EXPECT_EQ(doc_problem.data[d].inputs[i].variable, shipped.data[d].inputs[i].variable);
        EXPECT_EQ(doc_problem.data[d].inputs[i].rate, shipped.data[d].inputs[i].rate);
      }
    }
    EXPECT_EQ(doc_problem.estimation.method, shipped.estimation.method);
    EXPECT_EQ(doc_problem.estimation.equation_error.lowpass_hz,
              shipped.estimation.equation_error.lowpass_hz);
    EXPECT_EQ(doc_problem.estimation.multiple_shooting.segment_length,
              shipped.estimation.multiple_shooting.segment_length);
  }
  // Every shipped problem file is documented.
  int shipped_files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(problems)) {
    if (entry.path().extension() == ".toml") ++shipped_files;
  }
  EXPECT_EQ(found, shipped_files);
}

class GeneratedProblem : public ::testing::Test {
 protected:
  void SetUp() override { WriteText(dir_ / "pushed.csv", PushedCsv()); }
  Problem Parse(const std::string& text) {
    WriteText(dir_ / "pushed.toml", text);
    return LoadProblem(dir_ / "pushed.toml");
  }
  ScratchDir dir_;
};

TEST_F(GeneratedProblem, LoadsSplitsWithInitialStates) {
  const Problem p = Parse(PushedProblem());
  const std::vector<SplitData> splits = LoadData(p);
  ASSERT_EQ(splits.size(), 2u);
  EXPECT_EQ(splits[0].experiment.NumSamples(), 150);
  EXPECT_EQ(splits[1].experiment.NumSamples(), 50);
  EXPECT_EQ(splits[1].role, SplitRole::kValidation);
  EXPECT_NEAR(splits[0].experiment.dt, apps_testing::kSampleTime, 1e-15);
  // x0 = (first measured position of the split, the given velocity).
  EXPECT_EQ(splits[1].setup.x0[p.built.StateIndex("load.q")], splits[1].experiment.y(0, 0));
  EXPECT_EQ(splits[1].setup.x0[p.built.StateIndex("load.qd")], 0.0);
}

TEST_F(GeneratedProblem, UnknownKeySuggestsTheClosestAndNamesTheLine) {
  const std::string text = PushedProblem() + "[estimation.ipopt]\nmax_iteration = 5\n";
  const ProblemFileError e = ErrorOf([&] { Parse(text); });
  EXPECT_TRUE(Contains(e.what(), "did you mean 'max_iterations'")) << e.what();
  const std::string typo = PushedProblem(
      "[estimation]\nmethod = \"multiple_shooting\"\n"
      "[estimation.multiple_shooting]\nsegment_lenght = 25\n");
  const ProblemFileError f = ErrorOf([&] { Parse(typo); });
  EXPECT_TRUE(Contains(f.what(), "unknown key 'segment_lenght'; did you mean 'segment_length'?"))
      << f.what();
  EXPECT_EQ(f.where().line, LineOf(typo, "segment_lenght"));
  EXPECT_EQ(f.where().table, "estimation.multiple_shooting");
  EXPECT_TRUE(Contains(f.where().file, "pushed.toml"));
  EXPECT_EQ(std::string(f.what()).rfind(dir_ / "pushed.toml", 0), 0u) << f.what();
}

TEST_F(GeneratedProblem, UnknownBlockTypeAndSignalAreSuggested) {
  std::string text = PushedProblem();
  text.replace(text.find("friction.viscous"), 16, "friction.viscus");
  const ProblemFileError e = ErrorOf([&] { Parse(text); });
  EXPECT_TRUE(Contains(e.what(), "did you mean 'friction.viscous'")) << e.what();
  EXPECT_EQ(e.where().line, LineOf(text, "friction.viscus"));
  std::string mapping = PushedProblem();
  mapping.replace(mapping.find("outputs = { \"load.q\""), 21, "outputs = { \"load.qq\"");
  const ProblemFileError f = ErrorOf([&] { Parse(mapping); });
  EXPECT_TRUE(Contains(f.what(), "did you mean 'load.q'")) << f.what();
}

TEST_F(GeneratedProblem, MissingColumnNamesTheMappingWithASuggestion) {
  std::string text = PushedProblem();
  text.replace(text.find("= \"pos\""), 7, "= \"poss\"");
  const Problem p = Parse(text);
  const ProblemFileError e = ErrorOf([&] { LoadData(p); });
  EXPECT_TRUE(Contains(e.what(), "'poss'")) << e.what();
  EXPECT_TRUE(Contains(e.what(), "did you mean 'pos'")) << e.what();
}

TEST_F(GeneratedProblem, MissingMatVariableNamesTheMappingLine) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data";
  std::string text = apps_testing::ReadText(kEmpsDir + "/emps_idim.toml");
  text.replace(text.find("\"load.q\" = \"qm\""), 15, "\"load.q\" = \"qmm\"");
  const Problem p = ParseProblem(text, kEmpsDir + "/emps_idim.toml");
  const ProblemFileError e = ErrorOf([&] { LoadData(p); });
  EXPECT_TRUE(Contains(e.what(), "did you mean 'qm'")) << e.what();
  EXPECT_EQ(e.where().line, LineOf(text, "\"qmm\""));
}

TEST_F(GeneratedProblem, NanInDataNamesChannelAndSample) {
  WriteText(dir_ / "pushed.csv", PushedCsv("nan"));
  const Problem p = Parse(PushedProblem());
  const ProblemFileError e = ErrorOf([&] { LoadData(p); });
  EXPECT_TRUE(Contains(e.what(), "sample 3")) << e.what();
  EXPECT_TRUE(Contains(e.what(), "load.q")) << e.what();
  EXPECT_TRUE(Contains(e.what(), "expected a finite value, got nan")) << e.what();
}

TEST_F(GeneratedProblem, NonMonotoneTimeIsRejected) {
  WriteText(dir_ / "pushed.csv", PushedCsv("", /*reverse_time_at_5=*/true));
  const Problem p = Parse(PushedProblem());
  const ProblemFileError e = ErrorOf([&] { LoadData(p); });
  EXPECT_TRUE(Contains(e.what(), "strictly increasing")) << e.what();
}

TEST_F(GeneratedProblem, VariablesOfDifferentLengthsAreRejected) {
  MatWriter w(dir_ / "short.mat");
  w.WriteMatrix("force", Eigen::VectorXd::Constant(100, 1.0));
  w.WriteMatrix("pos", Eigen::VectorXd::Zero(99));
  w.Close();
  std::string text = PushedProblem();
  text.replace(text.find("pushed.csv"), 10, "short.mat");
  text.replace(text.find("time = \"time\""), 13, "sample_time = 0.01");
  const Problem p = Parse(text);
  const ProblemFileError e = ErrorOf([&] { LoadData(p); });
  EXPECT_TRUE(Contains(e.what(), "has 100 samples, expected 99")) << e.what();
}

// A scale of 1e308 would freeze a free parameter (the solver moves value / scale): refused at
// the parameter's line; a fixed parameter's scale is not used and not checked.
TEST_F(GeneratedProblem, AScaleThatFreezesAFreeParameterIsRefused) {
  const std::string text = PushedProblem("[estimation]\nmethod = \"multiple_shooting\"\n",
                                         "\"load.mass\" = { value = 1.0, scale = 1e308 }\n");
  const ProblemFileError e = ErrorOf([&] { Parse(text); });
  EXPECT_TRUE(Contains(e.what(),
                       "'scale': expected a scale within a factor of 1e8 of the "
                       "parameter's magnitude"))
      << e.what();
  EXPECT_EQ(e.where().line, LineOf(text, "\"load.mass\""));
  EXPECT_NO_THROW(
      Parse(PushedProblem("[estimation]\nmethod = \"multiple_shooting\"\n",
                          "\"load.mass\" = { value = 1.0, scale = 1e308, free = false }\n"
                          "\"friction.fv\" = { value = 1.0, scale = 1.0 }\n")));
}

TEST_F(GeneratedProblem, InfeasibleBoundsAndOutOfBoundValues) {
  const std::string text =
      PushedProblem("[estimation]\nmethod = \"multiple_shooting\"\n",
                    "\"load.mass\" = { value = 1.0, lower = 5.0, upper = 2.0 }\n");
  const ProblemFileError e = ErrorOf([&] { Parse(text); });
  EXPECT_TRUE(Contains(e.what(),
                       "infeasible bounds: expected lower <= upper, got lower = 5 > "
                       "upper = 2"))
      << e.what();
  EXPECT_EQ(e.where().line, LineOf(text, "\"load.mass\""));
  const ProblemFileError f = ErrorOf([&] {
    Parse(PushedProblem("[estimation]\nmethod = \"multiple_shooting\"\n",
                        "\"load.mass\" = { value = 10.0, upper = 2.0 }\n"));
  });
  EXPECT_TRUE(Contains(f.what(), "expected a value in [1e-09, 2], got 10")) << f.what();
}

TEST_F(GeneratedProblem, UnknownIpoptOptionIsCaughtWhenLoading) {
  const std::string text = PushedProblem() + "[estimation.ipopt]\nmu_stratgy = \"adaptive\"\n";
  const ProblemFileError e = ErrorOf([&] { Parse(text); });
  EXPECT_TRUE(Contains(e.what(), "did you mean 'mu_strategy'")) << e.what();
  EXPECT_EQ(e.where().line, LineOf(text, "mu_stratgy"));
}

TEST_F(GeneratedProblem, FormulationAndSolverMustAgree) {
  const ProblemFileError e = ErrorOf([&] {
    Parse(
        PushedProblem("[estimation]\nmethod = \"multiple_shooting\"\nsolver = \"ceres\"\n"
                      "[estimation.multiple_shooting]\ncontinuity = \"constraints\"\n"));
  });
  EXPECT_TRUE(Contains(e.what(), "Ceres handles no constraints")) << e.what();
  const ProblemFileError f =
      ErrorOf([&] { Parse(PushedProblem("[estimation]\nmethod = \"colocation\"\n")); });
  EXPECT_TRUE(Contains(f.what(), "did you mean 'collocation'")) << f.what();
}

TEST_F(GeneratedProblem, SplitOutsideTheRecordIsRejected) {
  std::string text = PushedProblem();
  text.replace(text.find("begin = 150 }"), 13, "begin = 150, end = 400 }");
  const Problem p = Parse(text);
  const ProblemFileError e = ErrorOf([&] { LoadData(p); });
  EXPECT_TRUE(Contains(e.what(), "expected 0 <= begin < end <= 200")) << e.what();
}

TEST_F(GeneratedProblem, EquationErrorNeedsEveryStateFromData) {
  // Measure the velocity instead of the position: the position is no derivative of anything.
  std::string text = PushedProblem("[estimation]\nmethod = \"equation_error\"\n");
  text.replace(text.find("outputs = [\"load.q\"]"), 20, "outputs = [\"load.qd\"]");
  text.replace(text.find("{ \"load.q\" = \"pos\" }"), 20, "{ \"load.qd\" = \"pos\" }");
  const ProblemFileError e = ErrorOf([&] { Parse(text); });
  EXPECT_TRUE(Contains(e.what(), "state 'load.q' is neither a measured output")) << e.what();
}

TEST(ProblemFile, SyntaxErrorsCarryTomlsPosition) {
  const ProblemFileError e =
      ErrorOf([] { ParseProblem("[problem]\nname = \"x\n", "/tmp/broken.toml"); });
  EXPECT_TRUE(Contains(e.what(), "TOML syntax error")) << e.what();
  EXPECT_EQ(e.where().line, 2);
  const ProblemFileError f = ErrorOf([] { LoadProblem("/nonexistent/problem.toml"); });
  EXPECT_TRUE(Contains(f.what(), "file not found")) << f.what();
}

}  // namespace
}  // namespace graybox::estimators

namespace graybox::estimators {
namespace {

std::string WithParameters(const std::string& parameters) {
  return apps_testing::PushedProblem(
      "[estimation]\nmethod = \"multiple_shooting\"\nsolver = \"ipopt\"\n", parameters);
}

// Patterns ('*') apply first, exact names override them; a parameter matched twice and a pattern
// matching nothing are errors naming the line.
TEST(ProblemFile, ParameterPatternsApplyThenExactNamesOverride) {
  const Problem p = ParseProblem(WithParameters("\"*\" = { free = false, scale = 2.0 }\n"
                                                "\"load.mass\" = { value = 3.0, free = true }\n"),
                                 "pattern.toml");
  const models::StateSpaceModel& m = p.built;
  const auto& mass = m.parameters[m.ParameterIndex("load.mass")];
  const auto& fv = m.parameters[m.ParameterIndex("friction.fv")];
  EXPECT_TRUE(mass.free);
  EXPECT_EQ(mass.value, 3.0);
  EXPECT_EQ(mass.scale, 2.0);  // from the pattern, not overridden
  EXPECT_FALSE(fv.free);
  EXPECT_EQ(fv.scale, 2.0);

  const std::string twice = WithParameters("\"*\" = { free = false }\n\"fric*\" = 1.0\n");
  const ProblemFileError e = ErrorOf([&] { ParseProblem(twice, "twice.toml"); });
  EXPECT_TRUE(Contains(e.what(), "matched by the patterns '*' and 'fric*'")) << e.what();
  EXPECT_EQ(e.where().line, LineOf(twice, "\"fric*\""));

  const std::string none = WithParameters("\"motor.*\" = { free = false }\n");
  const ProblemFileError n = ErrorOf([&] { ParseProblem(none, "none.toml"); });
  EXPECT_TRUE(Contains(n.what(), "pattern 'motor.*' matches no model parameter")) << n.what();
}

}  // namespace
}  // namespace graybox::estimators
