// The batch runner (graybox/bench/suite.h, runner.h) and `graybox bench SUITE`: suite files with
// located errors, the cases of variations and seeds, filters and shards, each case in its own
// process with its record, a refused case recorded as an error, a case past its time limit killed
// and recorded, and the outputs of the command.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "graybox/bench/runner.h"
#include "graybox/bench/suite.h"
#include "test_util.h"

namespace graybox::bench {
namespace {

using apps_testing::PushedCsv;
using apps_testing::PushedProblem;
using apps_testing::ReadText;
using apps_testing::ScratchDir;
using apps_testing::WriteText;
namespace est = graybox::estimators;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

std::string ErrorOf(const std::string& text, const std::string& path) {
  try {
    ParseSuite(text, path);
  } catch (const est::ProblemFileError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ProblemFileError";
  return "";
}

class BenchSuite : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteText(dir_ / "pushed.csv", PushedCsv());
    WriteText(dir_ / "pushed.toml", PushedProblem());
  }
  std::string Path(const std::string& name) const { return dir_ / name; }
  ScratchDir dir_;
};

constexpr const char* kTwoByTwo =
    "[suite]\nname = \"pushed\"\nproblems = [\"pushed.toml\"]\ntime_limit = 60\n"
    "[variations]\n\"estimation.multiple_shooting.segment_length\" = [10, 25]\n"
    "\"estimation.solver\" = [\"ipopt\", \"ceres\"]\n";

TEST_F(BenchSuite, VariationsAndSeedsMakeOneCaseEachWithAnId) {
  const Suite s = ParseSuite(std::string(kTwoByTwo) +
                                 "[perturbation]\nrelative = 0.1\n"
                                 "seeds = [1, 2]\n",
                             Path("s.toml"));
  ASSERT_EQ(s.problems.size(), 1u);
  EXPECT_EQ(s.time_limit, 60.0);
  const std::vector<Case> cases = ExpandCases(s);
  ASSERT_EQ(cases.size(), 8u);  // 2 x 2 x 2
  std::set<std::string> ids;
  for (const Case& c : cases) {
    ids.insert(c.id);
    EXPECT_EQ(c.overrides.size(), 2u);
  }
  EXPECT_EQ(ids.size(), 8u);
  // Keys in order, the last varying fastest, seeds innermost.
  EXPECT_EQ(cases[0].id,
            "pushed/estimation.multiple_shooting.segment_length=10,estimation.solver=ipopt/seed=1");
  EXPECT_EQ(cases[1].seed, 2u);
  EXPECT_EQ(cases[2].overrides[1].value, "'ceres'");  // TOML text, as the override takes it
  EXPECT_EQ(FilterCases(cases, "*ceres*seed=2").size(), 2u);
  EXPECT_TRUE(FilterCases(cases, "nothing*").empty());
  for (std::size_t i = 0; i < cases.size(); ++i) EXPECT_EQ(cases[i].index, i);
  // Excluded combinations are not cases; the others keep consecutive places.
  const std::string head = kTwoByTwo;
  const std::string with_exclude = head.substr(0, head.find("time_limit")) +
                                   "exclude = [\"*=10,estimation.solver=ceres\"]\n" +
                                   head.substr(head.find("time_limit"));
  const std::vector<Case> kept = ExpandCases(ParseSuite(with_exclude, Path("s.toml")));
  ASSERT_EQ(kept.size(), 3u);
  for (std::size_t i = 0; i < kept.size(); ++i) {
    EXPECT_EQ(kept[i].index, i);
    EXPECT_FALSE(Contains(kept[i].id, "=10,estimation.solver=ceres")) << kept[i].id;
  }
  // With seeds the ids end in /seed=<s>; an exclusion written without them still holds.
  Suite seeded = ParseSuite(with_exclude, Path("s.toml"));
  seeded.seeds = {7, 8};
  seeded.seeds_stated = true;
  const std::vector<Case> seeded_cases = ExpandCases(seeded);
  ASSERT_EQ(seeded_cases.size(), 6u);
  EXPECT_TRUE(Contains(seeded_cases[0].id, "/seed=7")) << seeded_cases[0].id;
}

TEST_F(BenchSuite, ShardsPartitionTheCasesDeterministically) {
  const std::vector<Case> cases = ExpandCases(
      ParseSuite(std::string(kTwoByTwo) + "[perturbation]\nseeds = [1, 2, 3]\n", Path("s.toml")));
  ASSERT_EQ(cases.size(), 12u);
  std::vector<std::string> seen;
  for (int k = 1; k <= 5; ++k) {
    const std::vector<Case> shard = SelectShard(cases, k, 5);
    EXPECT_GE(shard.size(), 2u);  // 12 unit-cost cases over 5 shards: 3, 3, 2, 2, 2
    EXPECT_LE(shard.size(), 3u);
    std::vector<std::string> ids, again;
    for (const Case& c : shard) ids.push_back(c.id);
    for (const Case& c : SelectShard(cases, k, 5)) again.push_back(c.id);
    EXPECT_EQ(ids, again);  // the same cases on every call
    seen.insert(seen.end(), ids.begin(), ids.end());
  }
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(std::unique(seen.begin(), seen.end()), seen.end());  // disjoint
  EXPECT_EQ(seen.size(), cases.size());                          // and complete
  // By cost: the expensive case alone in one shard, the rest in the other.
  const std::vector<Case> heavy =
      SelectShard(cases, 1, 2, [&](const Case& c) { return c.id == cases[5].id ? 100.0 : 1.0; });
  ASSERT_EQ(heavy.size(), 1u);
  EXPECT_EQ(heavy[0].id, cases[5].id);
  EXPECT_THROW(SelectShard(cases, 3, 2), std::invalid_argument);
}

TEST_F(BenchSuite, DefectsAreLocated) {
  std::string e = ErrorOf("[suite]\nproblems = [\"pushed.toml\"]\ntime_limt = 5\n", Path("s.toml"));
  EXPECT_TRUE(Contains(e, "s.toml:3:1")) << e;
  EXPECT_TRUE(Contains(e, "did you mean 'time_limit'")) << e;
  e = ErrorOf("[suite]\nproblems = [\"pushd.toml\"]\n", Path("s.toml"));
  EXPECT_TRUE(Contains(e, "no problem file or folder 'pushd.toml'")) << e;
  e = ErrorOf("[suite]\nproblems = [\"pushed.toml\"]\n[variations]\n\"estimation.solver\" = []\n",
              Path("s.toml"));
  EXPECT_TRUE(Contains(e, "s.toml:4:1")) << e;
  EXPECT_TRUE(Contains(e, "non-empty array")) << e;
  e = ErrorOf("[suite]\nproblems = [\"pushed.toml\"]\n[perturbation]\nseeds = [-1]\n",
              Path("s.toml"));
  EXPECT_TRUE(Contains(e, "s.toml:4:")) << e;
  // An exclude glob that matches no case is a mistake, not a no-op.
  try {
    ExpandCases(ParseSuite("[suite]\nproblems = [\"pushed.toml\"]\nexclude = [\"pushd*\"]\n",
                           Path("s.toml")));
    ADD_FAILURE() << "expected a ProblemFileError";
  } catch (const est::ProblemFileError& x) {
    EXPECT_TRUE(Contains(x.what(), "'exclude': 'pushd*' matches no case")) << x.what();
  }
  e = ErrorOf("[variations]\n", Path("s.toml"));
  EXPECT_TRUE(Contains(e, "missing table [suite]")) << e;
  // A file named twice is one problem.
  EXPECT_EQ(ExpandCases(ParseSuite("[suite]\nproblems = [\"pushed.toml\", \"pushed.toml\"]\n",
                                   Path("s.toml")))
                .size(),
            1u);
}

// Each case in its own process: the records of the cases that ran, a case whose override the
// problem refuses is an error with the problem file's message, one past its time limit is killed.
TEST_F(BenchSuite, EachCaseRunsInItsOwnProcessWithItsRecord) {
  WriteText(Path("s.toml"),
            "[suite]\nname = \"pushed\"\nproblems = [\"pushed.toml\"]\ntime_limit = 120\n"
            "[variations]\n\"estimation.method\" = [\"multiple_shooting\", \"colocation\"]\n");
  const Suite suite = LoadSuite(Path("s.toml"));
  const std::vector<Case> cases = ExpandCases(suite);
  ASSERT_EQ(cases.size(), 2u);
  std::filesystem::create_directories(dir_ / "work");
  RunOptions options;
  options.jobs = 2;
  options.case_command = {GRAYBOX_EXECUTABLE, "bench", "case", Path("s.toml")};
  options.work_dir = Path("work");
  const std::vector<CaseRecord> records = RunSuite(suite, cases, options);
  ASSERT_EQ(records.size(), 2u);
  const CaseRecord& ok = records[0];
  EXPECT_EQ(ok.status, "ok") << ok.error;
  EXPECT_EQ(ok.exit_code, 0);
  EXPECT_EQ(ok.method, "multiple_shooting");
  EXPECT_GT(ok.iterations, 0);
  ASSERT_FALSE(ok.metrics.empty());
  // The record equals what RunCase gives in this process (metrics and parameters; times differ).
  const CaseRecord here = RunCase(suite, cases[0]);
  ASSERT_EQ(here.parameters.size(), ok.parameters.size());
  for (std::size_t i = 0; i < here.parameters.size(); ++i) {
    EXPECT_EQ(here.parameters[i].name, ok.parameters[i].name);
    EXPECT_EQ(here.parameters[i].value, ok.parameters[i].value) << ok.parameters[i].name;
  }
  ASSERT_EQ(here.metrics.size(), ok.metrics.size());
  for (std::size_t i = 0; i < here.metrics.size(); ++i) {
    EXPECT_EQ(here.metrics[i].nrmse, ok.metrics[i].nrmse) << ok.metrics[i].channel;
  }
  const CaseRecord& refused = records[1];
  EXPECT_EQ(refused.status, "error");
  EXPECT_TRUE(Contains(refused.error, "did you mean 'collocation'")) << refused.error;
  // A time limit the case cannot meet, no grace: killed and recorded; the suite goes on.
  Suite tight = suite;
  tight.time_limit = 1e-3;
  options.kill_grace = 0.0;
  options.jobs = 1;
  const std::vector<CaseRecord> killed = RunSuite(tight, {cases[0]}, options);
  ASSERT_EQ(killed.size(), 1u);
  EXPECT_EQ(killed[0].status, "timed_out") << killed[0].error;
  EXPECT_EQ(killed[0].exit_code, 128 + 9);
  // An interrupt while a case runs: it is killed and recorded, no further case starts.
  int polls = 0;
  options.kill_grace = 30.0;
  options.interrupted = [&polls]() { return ++polls >= 3; };
  const std::vector<CaseRecord> stopped = RunSuite(suite, cases, options);
  ASSERT_EQ(stopped.size(), 1u);
  EXPECT_EQ(stopped[0].id, cases[0].id);
  EXPECT_EQ(stopped[0].status, "interrupted") << stopped[0].error;
}

// The default: each case in a fork of the calling process; a case process that exits without a
// record is recorded as crashed, with its exit code or signal.
TEST_F(BenchSuite, ForkedCasesRecordAndCrashesAreRecorded) {
  WriteText(Path("s.toml"),
            "[suite]\nname = \"pushed\"\nproblems = [\"pushed.toml\"]\n"
            "[perturbation]\nrelative = 0.05\nseeds = [1, 2]\n");
  const Suite suite = LoadSuite(Path("s.toml"));
  const std::vector<Case> cases = ExpandCases(suite);
  ASSERT_EQ(cases.size(), 2u);
  std::filesystem::create_directories(dir_ / "work");
  RunOptions options;
  options.jobs = 2;
  options.work_dir = Path("work");
  options.revision = "r1";
  const std::vector<CaseRecord> forked = RunSuite(suite, cases, options);
  ASSERT_EQ(forked.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(forked[i].status, "ok") << forked[i].error;
    EXPECT_EQ(forked[i].exit_code, 0);
    EXPECT_EQ(forked[i].revision, "r1");
    EXPECT_GE(forked[i].seconds, forked[i].case_seconds);
    const CaseRecord here = RunCase(suite, cases[i]);
    ASSERT_EQ(here.parameters.size(), forked[i].parameters.size());
    for (std::size_t p = 0; p < here.parameters.size(); ++p) {
      EXPECT_EQ(here.parameters[p].value, forked[i].parameters[p].value);
    }
    EXPECT_TRUE(std::filesystem::exists(Path("work/cases/" + std::to_string(i) + ".log")));
  }
  // Programs that leave no record: an exit code, a signal.
  options.case_command = {"/bin/false"};
  const std::vector<CaseRecord> failed = RunSuite(suite, {cases[0]}, options);
  ASSERT_EQ(failed.size(), 1u);
  EXPECT_EQ(failed[0].status, "crashed");
  EXPECT_EQ(failed[0].exit_code, 1);
  EXPECT_TRUE(Contains(failed[0].error, "exited with code 1 without a record")) << failed[0].error;
  options.case_command = {"/bin/sh", "-c", "kill -9 $$", "sh"};
  const std::vector<CaseRecord> killed = RunSuite(suite, {cases[0]}, options);
  ASSERT_EQ(killed.size(), 1u);
  EXPECT_EQ(killed[0].status, "crashed");
  EXPECT_EQ(killed[0].exit_code, 128 + 9);
  EXPECT_TRUE(Contains(killed[0].error, "killed by signal 9")) << killed[0].error;
}

TEST_F(BenchSuite, TheCommandWritesBenchJsonCsvAndMarkdown) {
  WriteText(Path("s.toml"), std::string(kTwoByTwo));
  const apps_testing::RunResult r = apps_testing::RunGraybox(
      "bench s.toml --out out --jobs 2 --filter '*ipopt*'", Path("log.txt"), dir_.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(ReadText(Path("out/bench.json")));
  EXPECT_EQ(j.at("schema").get<int>(), 1);
  EXPECT_EQ(j.at("suite").at("name").get<std::string>(), "pushed");
  ASSERT_EQ(j.at("cases").size(), 2u);  // the two segment lengths on Ipopt
  for (const auto& c : j.at("cases")) {
    EXPECT_EQ(c.at("status").get<std::string>(), "ok");
    EXPECT_EQ(c.at("solver").get<std::string>(), "ipopt");
    for (const char* key : {"id", "problem", "variation", "seed", "exit_code", "seconds",
                            "iterations", "cost", "parameters", "metrics"}) {
      EXPECT_TRUE(c.contains(key)) << key;
    }
  }
  EXPECT_FALSE(j.at("machine").at("cpu").get<std::string>().empty());
  EXPECT_GE(j.at("machine").at("cores").get<int>(), 1);
  EXPECT_TRUE(j.at("run").contains("revision"));
  const std::string csv = ReadText(Path("out/bench.csv"));
  EXPECT_TRUE(Contains(csv, "suite,case,problem,variation,seed,status")) << csv;
  const std::string md = ReadText(Path("out/bench.md"));
  EXPECT_TRUE(Contains(md, "2 cases, 2 ok (100 %)")) << md;
  // Bad input: exit 2, nothing written.
  const apps_testing::RunResult bad = apps_testing::RunGraybox(
      "bench s.toml --out out2 --shard 3/2", Path("log2.txt"), dir_.path().string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_TRUE(Contains(bad.output, "--shard")) << bad.output;
  EXPECT_FALSE(std::filesystem::exists(Path("out2")));
}

// Ctrl-C during a run: the running case is stopped and recorded, the outputs of what was done are
// written, exit 130.
TEST_F(BenchSuite, AnInterruptedCommandWritesWhatWasDone) {
  const std::string problem =
      std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps/emps_closed_loop.toml";
  if (!std::filesystem::exists(std::string(GRAYBOX_SHARED_DATA_DIR) + "/emps/DATA_EMPS.mat")) {
    GTEST_SKIP() << "no EMPS data";
  }
  // Three closed-loop fits of 1 to 3 s each, one at a time; SIGINT after 1.5 s, when the first or
  // the second is running.
  WriteText(Path("s.toml"), "[suite]\nproblems = [\"" + problem +
                                "\"]\n[perturbation]\nrelative = 0.1\nseeds = [1, 2, 3]\n");
  const apps_testing::RunResult r =
      apps_testing::RunGraybox("bench s.toml --out out", Path("log.txt"), dir_.path().string(),
                               "timeout --preserve-status -s INT 1.5 ");
  EXPECT_EQ(r.exit_code, 130) << r.output;
  const nlohmann::json j = nlohmann::json::parse(ReadText(Path("out/bench.json")));
  EXPECT_EQ(j.at("run").at("interrupted").get<std::string>(), "true");
  const auto& cases = j.at("cases");
  ASSERT_GE(cases.size(), 1u) << r.output;
  ASSERT_LE(cases.size(), 2u) << r.output;
  EXPECT_EQ(cases.back().at("status").get<std::string>(), "interrupted");
  EXPECT_TRUE(
      Contains(r.output, "interrupted: " + std::to_string(cases.size()) + " of 3 cases recorded"))
      << r.output;
  // --resume runs what the interrupt left: the finished cases kept as recorded, the rest run.
  const std::size_t finished = cases.size() - 1;
  const apps_testing::RunResult resumed = apps_testing::RunGraybox(
      "bench s.toml --resume out", Path("log_resume.txt"), dir_.path().string());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_TRUE(Contains(resumed.output, std::to_string(finished) + " recorded, " +
                                           std::to_string(3 - finished) + " to run"))
      << resumed.output;
  const nlohmann::json k = nlohmann::json::parse(ReadText(Path("out/bench.json")));
  EXPECT_EQ(k.at("run").at("interrupted").get<std::string>(), "false");
  ASSERT_EQ(k.at("cases").size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(k.at("cases")[i].at("index").get<std::size_t>(), i);
    EXPECT_EQ(k.at("cases")[i].at("status").get<std::string>(), "ok");
    EXPECT_TRUE(std::filesystem::exists(Path("out/cases/" + std::to_string(i) + ".json")));
  }
  for (std::size_t i = 0; i < finished; ++i) EXPECT_EQ(k.at("cases")[i], cases[i]);
}

}  // namespace
}  // namespace graybox::bench
