// Equation blocks in problem files (docs/problem-format.md "Equation blocks",
// models/equation_block.h): the shipped tank problem parses into the block it states and `graybox
// fit` recovers the synthetic data's parameters; every defect in the `equations` table is reported
// at its line and, inside an equation string, at the column of the offending character.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "graybox/estimators/problem/problem_file.h"
#include "test_util.h"

namespace graybox::estimators {
namespace {

using apps_testing::RunGraybox;
using apps_testing::RunResult;
using apps_testing::ScratchDir;

const std::string kTank = std::string(GRAYBOX_SOURCE_DIR) + "/problems/equations/tank.toml";
constexpr double kTrueKp = 30.0;  // cm^3/(s V), examples/equation_tank.cc
constexpr double kTrueA = 0.5;    // cm^2
// The synthetic level has 0.1 cm of noise on 2000 samples: the fit is far better than this.
constexpr double kRecoveryTolerance = 0.02;

std::string TankText() {
  std::ifstream in(kTank);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// `text` with the first occurrence of `from` replaced by `to`.
std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// 1-based line and column of the first occurrence of `needle` in `text`.
std::pair<int, int> PlaceOf(const std::string& text, const std::string& needle) {
  const std::size_t hit = text.find(needle);
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + hit, '\n'));
  const std::size_t line_start = text.rfind('\n', hit);
  const int column =
      static_cast<int>(hit - (line_start == std::string::npos ? 0 : line_start + 1)) + 1;
  return {line, column};
}

ProblemFileError ErrorOf(const std::string& text) {
  try {
    ParseProblem(text, kTank);
  } catch (const ProblemFileError& e) {
    return e;
  }
  ADD_FAILURE() << "expected a ProblemFileError";
  return ProblemFileError({}, "");
}

TEST(EquationFile, TheTankParsesIntoItsBlock) {
  const Problem p = LoadProblem(kTank);
  ASSERT_EQ(p.built.NumStates(), 1);
  EXPECT_EQ(p.built.states[0].name, "tank.h");
  EXPECT_EQ(p.built.states[0].unit, "cm");
  EXPECT_EQ(p.built.parameters[p.built.ParameterIndex("tank.kp")].info.unit, "cm^3/(s V)");
  EXPECT_EQ(p.built.parameters[p.built.ParameterIndex("tank.a")].upper, 10.0);
  ASSERT_EQ(p.blocks.size(), 1u);
  EXPECT_EQ(p.blocks[0].second, "equations");
  // dh/dt at h = 10 cm, u = 4 V with the nominal kp = 25, a = 0.3 (constants A, g, q_max).
  const Eigen::VectorXd xdot =
      p.built.dynamics({Eigen::VectorXd::Constant(1, 10.0), Eigen::VectorXd::Constant(1, 4.0),
                        p.built.ParameterValues()})[0];
  const double q_in = 0.5 * (100.0 + 160.0 - std::sqrt(60.0 * 60.0 + 1.0));
  const double q_out = 0.3 * std::sqrt(2.0 * 981.0 * 0.5 * (10.0 + std::sqrt(100.0 + 1e-4)));
  constexpr double kRounding = 1e-12;
  EXPECT_NEAR(xdot[0], (q_in - q_out) / 154.0, kRounding);
}

TEST(EquationFile, FitRecoversTheSyntheticTank) {
  ScratchDir dir;
  const RunResult r =
      RunGraybox("fit '" + kTank + "' --out '" + (dir / "out") + "'", dir / "log.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "out/result.json");
  const nlohmann::json result = nlohmann::json::parse(in);
  const double kp = result["parameters"]["tank.kp"]["value"].get<double>();
  const double a = result["parameters"]["tank.a"]["value"].get<double>();
  EXPECT_NEAR(kp, kTrueKp, kRecoveryTolerance * kTrueKp);
  EXPECT_NEAR(a, kTrueA, kRecoveryTolerance * kTrueA);
}

// docs/howto-csv.md's problem file, as the how-to tells a user to write it beside the CSV:
// check, fit and simulate as its steps say, with the estimates it prints.
TEST(EquationFile, TheHowToRunsAsWritten) {
  std::ifstream doc(std::string(GRAYBOX_SOURCE_DIR) + "/docs/howto-csv.md");
  std::ostringstream text;
  text << doc.rdbuf();
  const std::string md = text.str();
  const std::size_t begin = md.find("```toml\n");
  ASSERT_NE(begin, std::string::npos);
  const std::size_t end = md.find("```", begin + 8);
  ASSERT_NE(end, std::string::npos);
  ScratchDir dir;
  apps_testing::WriteText(dir / "my_tank.toml", md.substr(begin + 8, end - begin - 8));
  apps_testing::WriteText(dir / "tank.csv", apps_testing::ReadText(std::string(GRAYBOX_SOURCE_DIR) +
                                                                   "/problems/equations/tank.csv"));
  const std::string cwd = dir.path().string();
  EXPECT_EQ(RunGraybox("check my_tank.toml", dir / "check.txt", cwd).exit_code, 0);
  const RunResult fit = RunGraybox("fit my_tank.toml --out out/my_tank", dir / "fit.txt", cwd);
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  std::ifstream in(dir / "out/my_tank/result.json");
  const nlohmann::json result = nlohmann::json::parse(in);
  // The digits the how-to prints.
  constexpr double kPrinted = 1e-4;
  EXPECT_NEAR(result["parameters"]["tank.kp"]["value"].get<double>(), 30.0006, kPrinted);
  EXPECT_NEAR(result["parameters"]["tank.a"]["value"].get<double>(), 0.500049, kPrinted);
  const RunResult sim =
      RunGraybox("simulate my_tank.toml --params out/my_tank/result.json --out out/my_tank_sim",
                 dir / "sim.txt", cwd);
  EXPECT_EQ(sim.exit_code, 0) << sim.output;
}

TEST(EquationFile, DefectsAreReportedAtTheirLineAndColumn) {
  // Inside an equation: the column of the unknown name.
  {
    const std::string text = Replace(TankText(), "(q_in - q_out) / A", "(q_in - q_outt) / A");
    const ProblemFileError e = ErrorOf(text);
    const auto [line, column] = PlaceOf(text, "q_outt");
    EXPECT_EQ(e.where().line, line) << e.what();
    EXPECT_EQ(e.where().column, column) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown name 'q_outt'; did you mean 'q_out'?"),
              std::string::npos)
        << e.what();
  }
  {
    const std::string text = Replace(TankText(), "sqrt(2 * g", "sqrt(2, g");
    const ProblemFileError e = ErrorOf(text);
    const auto [line, column] = PlaceOf(text, "sqrt(2, g");
    EXPECT_EQ(e.where().line, line) << e.what();
    EXPECT_EQ(e.where().column, column) << e.what();
    EXPECT_NE(std::string(e.what()).find("'sqrt' takes 1 argument, got 2"), std::string::npos)
        << e.what();
  }
  // Declarations: a state without its equation, a name used twice, an unknown key.
  {
    const std::string text = Replace(TankText(), ", derivative = \"(q_in - q_out) / A\"", "");
    const ProblemFileError e = ErrorOf(text);
    EXPECT_EQ(e.where().line, PlaceOf(text, "states = [").first) << e.what();
    EXPECT_NE(std::string(e.what()).find("state 'h' has no equation"), std::string::npos)
        << e.what();
  }
  {
    const std::string text = Replace(TankText(), "{ name = \"a\",", "{ name = \"kp\",");
    const ProblemFileError e = ErrorOf(text);
    EXPECT_NE(std::string(e.what()).find("'kp' is used twice"), std::string::npos) << e.what();
  }
  {
    const std::string text = Replace(TankText(), "derivative = ", "derivativ = ");
    const ProblemFileError e = ErrorOf(text);
    EXPECT_EQ(e.where().line, PlaceOf(text, "derivativ = ").first) << e.what();
    EXPECT_NE(std::string(e.what()).find("did you mean 'derivative'"), std::string::npos)
        << e.what();
  }
  {
    const std::string text =
        Replace(TankText(), "[model.blocks.equations]", "[model.blocks.equation]");
    const ProblemFileError e = ErrorOf(text);
    EXPECT_NE(std::string(e.what()).find("did you mean 'equations'"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace graybox::estimators
