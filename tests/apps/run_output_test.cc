// The outputs of a run are one unit (issue 12): a second run into the same folder replaces the
// first whole (no file of the first is left beside the second's), an output folder that cannot
// be written is refused before solving, split names whose files would collide are refused, and
// --params is checked (a folder without result.json, a number out of range, a value outside the
// problem's bounds), and control characters from files are escaped in messages.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "test_util.h"

namespace graybox::apps_testing {
namespace {

namespace fs = std::filesystem;

class RunOutputCli : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteText(dir_ / "pushed.csv", PushedCsv());
    WriteText(dir_ / "pushed.toml", PushedProblem());
  }
  RunResult Graybox(const std::string& arguments, const std::string& log = "log.txt") {
    return RunGraybox(arguments, dir_ / log, dir_.path().string());
  }
  ScratchDir dir_;
};

TEST_F(RunOutputCli, ASecondRunReplacesTheFirstWhole) {
  ASSERT_EQ(Graybox("fit pushed.toml --out out").exit_code, 0);
  // A file of an earlier run (an equation plot the next run does not make), and a folder.
  WriteText(dir_ / "out/plots/stale_equation.svg", "<svg/>");
  const RunResult again = Graybox("fit pushed.toml --out out", "again.txt");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("replaced the earlier run in out"), std::string::npos)
      << again.output;
  EXPECT_FALSE(fs::exists(dir_ / "out/plots/stale_equation.svg"));
  EXPECT_TRUE(fs::exists(dir_ / "out/result.json"));
  EXPECT_TRUE(fs::exists(dir_ / "out/plots/first_outputs.svg"));
  // No staging or previous folder is left beside it.
  for (const auto& entry : fs::directory_iterator(dir_.path())) {
    EXPECT_EQ(entry.path().filename().string().find(".out."), std::string::npos) << entry.path();
  }
}

// The case of the issue: an output folder made immutable (chattr +i) while its subfolders stay
// writable. The second run cannot move the first aside, so it leaves it whole (result.json and
// the plots of the first run, byte for byte), exits nonzero and names where its own outputs are.
TEST_F(RunOutputCli, AnImmutableOutputFolderKeepsTheFirstRunWhole) {
  ASSERT_EQ(Graybox("fit pushed.toml --out out").exit_code, 0);
  const std::string result = ReadText(dir_ / "out/result.json");
  const std::string plot = ReadText(dir_ / "out/plots/first_outputs.svg");
  const std::string out = dir_ / "out";
  if (std::system(("chattr +i '" + out + "' 2>/dev/null").c_str()) != 0) {
    GTEST_SKIP() << "chattr +i is not available here (needs root and a file system with the "
                    "immutable attribute)";
  }
  // The same problem under another file name: the second run's result.json names it.
  WriteText(dir_ / "pushed_again.toml", PushedProblem());
  const RunResult again = Graybox("fit pushed_again.toml --out out", "again.txt");
  std::system(("chattr -i '" + out + "'").c_str());
  EXPECT_NE(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("cannot replace the earlier run in 'out'"), std::string::npos)
      << again.output;
  EXPECT_NE(again.output.find("it is left untouched"), std::string::npos) << again.output;
  EXPECT_EQ(ReadText(dir_ / "out/result.json"), result);
  EXPECT_EQ(ReadText(dir_ / "out/plots/first_outputs.svg"), plot);
  // This run's outputs are whole in the folder the message names, beside out.
  const auto named = again.output.find("this run's outputs are in '");
  ASSERT_NE(named, std::string::npos) << again.output;
  const auto begin = named + std::string("this run's outputs are in '").size();
  const fs::path staged = again.output.substr(begin, again.output.find('\'', begin) - begin);
  EXPECT_TRUE(fs::exists(staged / "result.json")) << staged;
  EXPECT_NE(ReadText(staged / "result.json").find("pushed_again.toml"), std::string::npos);
}

TEST_F(RunOutputCli, AnOutputFolderThatCannotBeWrittenIsRefusedBeforeSolving) {
  WriteText(dir_ / "file", "not a folder");
  const RunResult r = Graybox("fit pushed.toml --out file/sub");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--out 'file/sub'"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("ipopt"), std::string::npos) << r.output;  // nothing was solved
}

TEST_F(RunOutputCli, SplitNamesWhoseFilesCollideAreRefused) {
  std::string text = PushedProblem();
  const std::string splits =
      "splits = [{ name = \"first\", role = \"estimation\", end = 150 },\n"
      "          { name = \"last\", role = \"validation\", begin = 150 }]";
  const auto at = text.find(splits);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, splits.size(),
               "splits = [{ name = \"a/b\", role = \"estimation\", end = 150 },\n"
               "          { name = \"a_b\", role = \"validation\", begin = 150 }]");
  WriteText(dir_ / "pushed.toml", text);
  const RunResult r = Graybox("fit pushed.toml --out out");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("splits 'a/b' and 'a_b' would write the same plot and trace files"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(RunOutputCli, ParameterFilesAreChecked) {
  ASSERT_EQ(Graybox("fit pushed.toml --out out").exit_code, 0);
  // A run folder holds its result.json; a folder without one is bad input.
  EXPECT_EQ(Graybox("simulate pushed.toml --params out --out sim").exit_code, 0);
  fs::create_directories(dir_ / "empty");
  const RunResult folder = Graybox("simulate pushed.toml --params empty --out sim2", "folder.txt");
  EXPECT_EQ(folder.exit_code, 2) << folder.output;
  EXPECT_NE(folder.output.find("a folder without one"), std::string::npos) << folder.output;
  // A number out of double's range names the file.
  WriteText(dir_ / "huge.json", "{\"parameters\": {\"load.mass\": 1e999}}");
  const RunResult huge = Graybox("simulate pushed.toml --params huge.json --out sim3", "huge.txt");
  EXPECT_EQ(huge.exit_code, 2) << huge.output;
  EXPECT_NE(huge.output.find("huge.json"), std::string::npos) << huge.output;
  // A value outside the problem's bounds (the mass' lower bound is above 0).
  WriteText(dir_ / "negative.toml", "\"load.mass\" = -1.0\n");
  const RunResult out_of_bounds =
      Graybox("simulate pushed.toml --params negative.toml --out sim4", "bounds.txt");
  EXPECT_EQ(out_of_bounds.exit_code, 2) << out_of_bounds.output;
  EXPECT_NE(out_of_bounds.output.find("'load.mass' = -1: expected a value within the problem's "
                                      "bounds"),
            std::string::npos)
      << out_of_bounds.output;
  EXPECT_FALSE(fs::exists(dir_ / "sim4"));
}

// A wall-time limit ends the solve with exit 3 and every output written (the limit is checked at
// each iteration: a microsecond stops the first one); the problem file's max_seconds likewise.
TEST_F(RunOutputCli, AWallTimeLimitEndsTheSolveWithItsOutputs) {
  const RunResult r = Graybox("fit pushed.toml --out out --max-seconds 1e-6");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(fs::exists(dir_ / "out/result.json"));
  std::string text = PushedProblem();
  text.replace(text.find("solver = \"ipopt\"\n"), 17, "solver = \"ipopt\"\nmax_seconds = 1e-6\n");
  WriteText(dir_ / "limited.toml", text);
  const RunResult p = Graybox("fit limited.toml --out limited", "limited.txt");
  EXPECT_EQ(p.exit_code, 3) << p.output;
  EXPECT_TRUE(fs::exists(dir_ / "limited/result.json"));
}

// Text from files is echoed with its control characters escaped: a CSV header holding a terminal
// escape sequence (one that retitles the terminal) reaches the message as \x1b ... \x07.
TEST_F(RunOutputCli, ControlCharactersFromFilesAreEscapedInMessages) {
  std::string csv = PushedCsv();
  const std::string header = "time,force,pos";
  csv.replace(csv.find(header), header.size(), "time,force,\x1b]0;owned\x07");
  WriteText(dir_ / "pushed.csv", csv);
  const RunResult r = Graybox("check pushed.toml");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find('\x07'), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\\x1b]0;owned\\x07"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace graybox::apps_testing
