// Initial states per state in problem files ([[data]] initial_state, docs/problem-format.md):
// held or estimated per state whatever the method's default, in multiple and single shooting and
// collocation, and a test record started from the state estimated on the estimation record
// (from_split); the errors of the table form name the place.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/problem/problem_file.h"
#include "test_util.h"

namespace graybox::estimators {
namespace {

using apps_testing::PushedCsv;
using apps_testing::PushedProblem;
using apps_testing::ScratchDir;
using apps_testing::WriteText;

// The pushed slide starts at rest at q = 0; the guess of its initial position is off by this.
constexpr double kWrongStart = 0.05;  // m
// Noise-free data: an estimated start is recovered far better than this.
constexpr double kRecovered = 1e-4;  // m

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The pushed problem with `initial_state` as its [[data]] initial_state and `estimation` as its
// [estimation] section.
Problem PushedWith(const ScratchDir& dir, const std::string& initial_state,
                   const std::string& estimation) {
  WriteText(dir / "pushed.csv", PushedCsv());
  const std::string text =
      Replace(PushedProblem(estimation), "initial_state = { \"load.qd\" = 0.0 }",
              "initial_state = " + initial_state);
  WriteText(dir / "pushed.toml", text);
  return LoadProblem(dir / "pushed.toml");
}

double State(const FitResult& fit, const Problem& p, const std::string& split,
             const std::string& state) {
  return fit.initial_states.at(split)[p.built.StateIndex(state)];
}

TEST(InitialStateFile, OneStateEstimatedTheOtherHeldInEveryFormulation) {
  const std::vector<std::pair<std::string, std::string>> methods = {
      // fix_initial_state = true: only load.q is estimated.
      {"multiple shooting",
       "[estimation]\nmethod = \"multiple_shooting\"\nsolver = \"ipopt\"\n"
       "[estimation.multiple_shooting]\nsegment_length = 25\nfix_initial_state = true\n"},
      {"single shooting",
       "[estimation]\nmethod = \"single_shooting\"\nsolver = \"ipopt\"\n"
       "[estimation.multiple_shooting]\nfix_initial_state = true\n"},
      {"collocation", "[estimation]\nmethod = \"collocation\"\nsolver = \"ipopt\"\n"}};
  for (const auto& [name, estimation] : methods) {
    SCOPED_TRACE(name);
    ScratchDir dir;
    // load.qd held at 0.0 explicitly; load.q estimated from a wrong start.
    const std::string spec = "{ \"load.q\" = { value = " + std::to_string(kWrongStart) +
                             ", free = true }, \"load.qd\" = { value = 0.0, free = false } }";
    const Problem p = PushedWith(dir, spec, estimation);
    const std::vector<SplitData> splits = LoadData(p);
    ASSERT_EQ(splits[0].setup.x0_free.size(), 2u);
    FitOptions o;
    o.compute_covariance = false;
    const FitResult fit = Fit(p, splits, o);
    ASSERT_TRUE(fit.solver_result.success) << fit.BriefReport();
    EXPECT_NEAR(State(fit, p, "first", "load.q"), 0.0, kRecovered);
    EXPECT_EQ(State(fit, p, "first", "load.qd"), 0.0);  // held exactly
  }
  // The same with the other state held at a wrong value: it stays there (and the fit is worse).
  ScratchDir dir;
  const Problem p = PushedWith(
      dir, "{ \"load.q\" = { value = 0.05, free = false }, \"load.qd\" = { free = true } }",
      methods[0].second);
  FitOptions o;
  o.compute_covariance = false;
  const FitResult fit = Fit(p, LoadData(p), o);
  EXPECT_EQ(State(fit, p, "first", "load.q"), kWrongStart);
}

TEST(InitialStateFile, ATestRecordStartsFromTheEstimationRecordsEstimate) {
  ScratchDir dir;
  WriteText(dir / "pushed.csv", PushedCsv());
  std::string text = PushedProblem(
      "[estimation]\nmethod = \"multiple_shooting\"\nsolver = \"ipopt\"\n"
      "[estimation.multiple_shooting]\nsegment_length = 25\n");
  text = Replace(text, "initial_state = { \"load.qd\" = 0.0 }",
                 "initial_state = { \"load.q\" = 0.05, \"load.qd\" = 0.0 }\n"
                 "\n[[data]]\nname = \"again\"\nfile = \"pushed.csv\"\ntime = \"time\"\n"
                 "inputs = { force = \"force\" }\noutputs = { \"load.q\" = \"pos\" }\n"
                 "splits = [{ name = \"replay\", role = \"test\" }]\n"
                 "initial_state = { \"load.q\" = { from_split = \"first\" }, "
                 "\"load.qd\" = { from_split = \"first\" } }");
  WriteText(dir / "pushed.toml", text);
  const Problem p = LoadProblem(dir / "pushed.toml");
  const std::vector<SplitData> splits = LoadData(p);
  ASSERT_EQ(splits.size(), 3u);
  EXPECT_EQ(splits[2].x0_from_split.size(), 2u);
  FitOptions o;
  o.compute_covariance = false;
  const FitResult fit = Fit(p, splits, o);
  ASSERT_TRUE(fit.solver_result.success) << fit.BriefReport();
  const Eigen::VectorXd& estimated = fit.initial_states.at("first");
  const SplitEvaluation& replay = fit.Evaluation("replay");
  // The replay starts exactly where the estimation record's estimate says (not at its own data).
  EXPECT_EQ(replay.x0[0], estimated[0]);
  EXPECT_EQ(replay.x0[1], estimated[1]);
  EXPECT_NEAR(replay.x0[p.built.StateIndex("load.q")], 0.0, kRecovered);
  EXPECT_EQ(InitialStateOf(splits[2], {}), splits[2].setup.x0);  // no estimate: its own
  // The named split must exist and be an estimation split.
  for (const auto& [from, expected] : std::vector<std::pair<std::string, std::string>>{
           {"frist", "no such split; did you mean 'first'?"},
           {"last",
            "expected an estimation split (whose initial state is estimated), got a "
            "validation split"}}) {
    SCOPED_TRACE(from);
    WriteText(dir / "bad.toml", Replace(text, "{ \"load.q\" = { from_split = \"first\" }",
                                        "{ \"load.q\" = { from_split = \"" + from + "\" }"));
    try {
      LoadData(LoadProblem(dir / "bad.toml"));
      ADD_FAILURE() << "expected a ProblemFileError";
    } catch (const ProblemFileError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
}

TEST(InitialStateFile, TableFormErrorsNameThePlace) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"{ \"load.q\" = { value = 0.1, variable = \"pos\" } }", "give 'value' or 'variable'"},
      {"{ \"load.q\" = { from_split = \"first\", free = true } }", "takes no 'value'"},
      {"{ \"load.q\" = { fre = true } }", "did you mean 'free'"},
      {"{ \"load.q\" = { } }", "expected 'value', 'variable', 'free' or 'from_split'"},
      {"{ \"load.q\" = { from_split = \"last\" } }", "an estimation split estimates its own"},
  };
  for (const auto& [spec, expected] : bad) {
    SCOPED_TRACE(spec);
    ScratchDir dir;
    try {
      const Problem p = PushedWith(dir, spec,
                                   "[estimation]\nmethod = \"multiple_shooting\"\n"
                                   "solver = \"ipopt\"\n");
      LoadData(p);
      ADD_FAILURE() << "expected a ProblemFileError";
    } catch (const ProblemFileError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(expected), std::string::npos) << msg;
      EXPECT_NE(msg.find("pushed.toml:"), std::string::npos) << msg;
    }
  }
}

}  // namespace
}  // namespace graybox::estimators
