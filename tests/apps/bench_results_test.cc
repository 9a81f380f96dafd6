// A bench run's results (graybox/bench/results.h, compare.h) and their commands: bench.json read
// back, shards merged into the whole run's records, tolerances from the suite, a run compared
// with a baseline (every value outside its tolerance, status changes, missing cases, time), and
// `graybox bench merge / baseline / compare` with their exit codes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "graybox/bench/compare.h"
#include "graybox/bench/results.h"
#include "graybox/bench/suite.h"
#include "test_util.h"

namespace graybox::bench {
namespace {

using apps_testing::PushedCsv;
using apps_testing::PushedProblem;
using apps_testing::ReadText;
using apps_testing::RunGraybox;
using apps_testing::ScratchDir;
using apps_testing::WriteText;
namespace est = graybox::estimators;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseSuite(text, "s.toml");
  } catch (const est::ProblemFileError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ProblemFileError";
  return "";
}

// A record of a converged case with one parameter and one metric.
CaseRecord Record(const std::string& id, std::size_t index, double mass, double nrmse) {
  CaseRecord r;
  r.suite = "s";
  r.id = id;
  r.index = index;
  r.status = "ok";
  r.iterations = 20;
  r.cost = 1.5;
  r.seconds = 2.0;
  r.case_seconds = 1.9;
  r.parameters = {{"load.mass", mass, 0.5, true}, {"load.g", 9.81, std::nan(""), false}};
  r.metrics = {{"test", "test", "overall", nrmse, 100.0 * (1.0 - nrmse), 1.0 - nrmse * nrmse}};
  return r;
}

BenchRun RunOf(const std::vector<CaseRecord>& records, const std::string& shard = "") {
  BenchRun b;
  b.suite.name = "s";
  b.suite.path = "s.toml";
  b.records = records;
  b.run = {{"revision", "abc"},
           {"shard", shard},
           {"filter", ""},
           {"interrupted", "false"},
           {"cases_planned", std::to_string(records.size())},
           {"wall_seconds", "3"}};
  return b;
}

// A suite's head naming a shipped problem file.
const std::string kHead = "[suite]\nproblems = [\"" + std::string(GRAYBOX_SOURCE_DIR) +
                          "/problems/emps/emps_idim.toml\"]\n";

TEST(BenchTolerances, TheSuiteSetsThemPerMetricWithLocatedErrors) {
  const Suite s = ParseSuite(kHead +
                                 "[tolerances]\nnrmse = { relative = 1e-2 }\n"
                                 "parameters = { digits = 3 }\ncost = { compare = false }\n"
                                 "time = { factor = 2, min_seconds = 0.5 }\n",
                             "s.toml");
  EXPECT_EQ(s.tolerances.nrmse.relative, 1e-2);
  EXPECT_EQ(s.tolerances.nrmse.absolute, 0.0);  // a metric's table replaces its default whole
  EXPECT_NEAR(s.tolerances.parameters.relative, 1e-3, 1e-18);
  EXPECT_FALSE(s.tolerances.cost.compared);
  EXPECT_EQ(s.tolerances.time_factor, 2.0);
  EXPECT_EQ(s.tolerances.iterations.absolute, Tolerances().iterations.absolute);  // default kept
  std::string e = ErrorOf(kHead + "[tolerances]\nnrmse = { relativ = 1 }\n");
  EXPECT_TRUE(Contains(e, "s.toml:4:")) << e;
  EXPECT_TRUE(Contains(e, "did you mean 'relative'")) << e;
  e = ErrorOf(kHead + "[tolerances]\nnrsme = { relative = 1 }\n");
  EXPECT_TRUE(Contains(e, "did you mean 'nrmse'")) << e;
  e = ErrorOf(kHead + "[tolerances]\nr2 = { absolute = -1 }\n");
  EXPECT_TRUE(Contains(e, "expected a number >= 0, got -1")) << e;
  e = ErrorOf(kHead + "[tolerances]\ntime = { factor = 0.5 }\n");
  EXPECT_TRUE(Contains(e, "'factor': expected a number >= 1")) << e;
}

TEST(BenchTolerances, AdmitAbsolutePlusRelative) {
  const Tolerance t{0.1, 0.01, true};
  EXPECT_TRUE(t.Admits(10.0, 10.2));   // 0.2 <= 0.1 + 0.1
  EXPECT_FALSE(t.Admits(10.0, 10.3));  // 0.3 > 0.2
  EXPECT_TRUE(t.Admits(std::nan(""), std::nan("")));
  EXPECT_FALSE(t.Admits(1.0, std::nan("")));
  EXPECT_TRUE(Tolerance({0.0, 0.0, false}).Admits(1.0, 2.0));
}

TEST(BenchResults, BenchJsonReadsBackAsItWasWritten) {
  BenchRun b = RunOf({Record("a", 0, 95.0, 0.1), Record("b", 1, 96.0, 0.2)}, "1/2");
  b.suite.tolerances.nrmse = {0.0, 0.05, true};
  b.machine = {"cpu", 2, "os"};
  b.records[1].status = "crashed";
  b.records[1].case_seconds = std::nan("");
  const BenchRun again = ParseBenchJson(BenchJson(b), "bench.json");
  EXPECT_EQ(BenchJson(again), BenchJson(b));
  EXPECT_EQ(again.Run("shard"), "1/2");
  EXPECT_TRUE(std::isnan(again.records[1].case_seconds));
  EXPECT_EQ(again.suite.tolerances.nrmse.relative, 0.05);
  // A malformed file names itself and the case.
  nlohmann::json j = nlohmann::json::parse(BenchJson(b));
  j["cases"][1].erase("status");
  try {
    ParseBenchJson(j.dump(), "x/bench.json");
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(Contains(e.what(), "x/bench.json: 'cases[1]'")) << e.what();
  }
  EXPECT_THROW(LoadBenchRun("/nonexistent/folder"), std::invalid_argument);
}

TEST(BenchResults, ShardsMergeIntoTheWholeRunOrRefuseWhatIsMissing) {
  const BenchRun one = RunOf({Record("a", 0, 1, 0.1), Record("c", 2, 1, 0.1)}, "1/2");
  const BenchRun two = RunOf({Record("b", 1, 1, 0.1)}, "2/2");
  const BenchRun merged = MergeShards({two, one}, {"d2", "d1"});
  ASSERT_EQ(merged.records.size(), 3u);
  EXPECT_EQ(merged.records[0].id, "a");
  EXPECT_EQ(merged.records[1].id, "b");
  EXPECT_EQ(merged.records[2].id, "c");
  EXPECT_EQ(merged.Run("merged_from"), "d2, d1");
  EXPECT_EQ(merged.Run("cases_planned"), "3");
  auto error = [](const std::vector<BenchRun>& runs, const std::vector<std::string>& names) {
    try {
      MergeShards(runs, names);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    ADD_FAILURE() << "expected std::invalid_argument";
    return std::string();
  };
  EXPECT_TRUE(Contains(error({one}, {"d1"}), "shard 2/2 missing")) << error({one}, {"d1"});
  EXPECT_TRUE(
      Contains(error({one, one, two}, {"d1", "x", "d2"}), "shard 1/2 given twice: d1 and x"));
  BenchRun stray = two;
  stray.records[0].id = "a";
  EXPECT_TRUE(Contains(error({one, stray}, {"d1", "d2"}), "case 'a' is in d1 and in d2"));
  BenchRun other = two;
  other.suite.name = "t";
  EXPECT_TRUE(Contains(error({one, other}, {"d1", "d2"}), "is a run of suite 't'"));
  BenchRun three = two;
  three.SetRun("shard", "2/3");
  EXPECT_TRUE(Contains(error({one, three}, {"d1", "d2"}), "one of 2"));
  BenchRun beyond = two;
  beyond.SetRun("shard", "3/2");
  EXPECT_TRUE(Contains(error({one, beyond}, {"d1", "d2"}), "d2: run.shard"))
      << error({one, beyond}, {"d1", "d2"});
  // Different partitions or runs: seeds, costs.
  BenchRun reseeded = two;
  reseeded.SetRun("seed", "5");
  EXPECT_TRUE(Contains(error({one, reseeded}, {"d1", "d2"}), "ran --seed '5'"));
  BenchRun costed = two;
  costed.SetRun("costs", "old/bench.json");
  EXPECT_TRUE(Contains(error({one, costed}, {"d1", "d2"}), "ran --costs"));
  // A shard that lost a case without an interrupt is refused; an interrupted one merges as
  // interrupted, and no baseline is made of it.
  BenchRun lost = two;
  lost.SetRun("cases_planned", "2");
  EXPECT_TRUE(Contains(error({one, lost}, {"d1", "d2"}), "planned 4 cases and recorded 3"));
  lost.SetRun("interrupted", "true");
  const BenchRun partial = MergeShards({one, lost}, {"d1", "d2"});
  EXPECT_EQ(partial.Run("interrupted"), "true");
  EXPECT_THROW(BaselineJson(partial, "merged"), std::invalid_argument);
}

TEST(BenchResults, RecordedTimesBalanceTheShards) {
  // Four recorded cases (8, 1, 1, 2 s) and one unrecorded (the median, 1.5 s).
  BenchRun earlier = RunOf({Record("a", 0, 1, 0.1), Record("b", 1, 1, 0.1), Record("c", 2, 1, 0.1),
                            Record("d", 3, 1, 0.1)});
  const std::vector<double> seconds = {8.0, 1.0, 1.0, 2.0};
  for (std::size_t i = 0; i < seconds.size(); ++i) earlier.records[i].seconds = seconds[i];
  const CostFunction cost = RecordedCosts(earlier);
  std::vector<Case> cases(5);
  for (std::size_t i = 0; i < cases.size(); ++i) cases[i].id = std::string(1, char('a' + i));
  EXPECT_EQ(cost(cases[0]), 8.0);
  EXPECT_EQ(cost(cases[4]), 1.5);
  // Longest first to the lightest shard: a (8) alone; d, e, b, c (5.5 s) in the other.
  const std::vector<Case> one = SelectShard(cases, 1, 2, cost);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].id, "a");
  EXPECT_EQ(SelectShard(cases, 2, 2, cost).size(), 4u);
}

TEST(BenchCompare, EveryValueOutsideItsToleranceIsAFinding) {
  const Tolerances t;
  const BenchRun base = RunOf({Record("a", 0, 95.0, 0.100), Record("b", 1, 95.0, 0.100),
                               Record("c", 2, 95.0, 0.100), Record("d", 3, 95.0, 0.100)});
  BenchRun run = base;
  // a: within every tolerance (mass 0.5 % off against 1 %, iterations +3 against 5 + 50 %).
  run.records[0].parameters[0].value = 95.0 * 1.005;
  run.records[0].iterations = 23;
  run.records[0].seconds = 5.0;  // 2.5 x: under the factor 3
  // b: NRMSE 2 % worse, the fixed parameter ignored, 4 x slower.
  run.records[1].metrics[0].nrmse = 0.102;
  run.records[1].parameters[1].value = 1.0;
  run.records[1].seconds = 8.0;
  // c: a new failure; d missing; e new.
  run.records[2].status = "failed";
  run.records.pop_back();
  run.records.push_back(Record("e", 4, 95.0, 0.1));
  const Comparison c = CompareRuns(base, run, t, "graybox bench baseline DIR --out F");
  EXPECT_EQ(c.cases_compared, 3);
  std::vector<std::string> kinds;
  for (const Finding& f : c.findings) kinds.push_back(f.case_id + ":" + f.kind);
  EXPECT_EQ(kinds,
            (std::vector<std::string>{"b:nrmse", "b:seconds", "c:status", "d:missing", "e:new"}));
  EXPECT_TRUE(c.HasRegression());
  EXPECT_EQ(c.findings[0].what, "test/overall");
  EXPECT_NEAR(c.findings[0].value, 0.102, 1e-15);
  const std::string report = c.FullReport();
  EXPECT_TRUE(Contains(report, "b: nrmse test/overall: 0.1 -> 0.102 (+0.002, 2 %)")) << report;
  EXPECT_TRUE(Contains(report, "c: status: ok -> failed")) << report;
  EXPECT_TRUE(Contains(report, "to accept this run as the baseline: graybox bench baseline"))
      << report;
  // The same run compared with itself: nothing; a new case alone is no regression.
  EXPECT_TRUE(CompareRuns(run, run, t).findings.empty());
  // A missing parameter counts only where parameters are compared; another suite is refused.
  BenchRun fewer = base;
  fewer.records[0].parameters.erase(fewer.records[0].parameters.begin());
  EXPECT_EQ(CompareRuns(base, fewer, t).findings.size(), 1u);
  Tolerances no_parameters = t;
  no_parameters.parameters.compared = false;
  EXPECT_TRUE(CompareRuns(base, fewer, no_parameters).findings.empty());
  BenchRun other = base;
  other.suite.name = "t";
  EXPECT_THROW(CompareRuns(base, other, t), std::invalid_argument);
  BenchRun more = base;
  more.records.push_back(Record("e", 4, 95.0, 0.1));
  const Comparison added = CompareRuns(base, more, t);
  ASSERT_EQ(added.findings.size(), 1u);
  EXPECT_FALSE(added.HasRegression());
  // An interrupted run is incomplete: no baseline from it.
  BenchRun cut = base;
  cut.SetRun("interrupted", "true");
  EXPECT_THROW(BaselineJson(cut, "x"), std::invalid_argument);
}

class BenchCommands : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteText(dir_ / "pushed.csv", PushedCsv());
    WriteText(dir_ / "pushed.toml", PushedProblem());
    WriteText(dir_ / "s.toml",
              "[suite]\nname = \"pushed\"\nproblems = [\"pushed.toml\"]\ntime_limit = 120\n"
              "[variations]\n\"estimation.multiple_shooting.segment_length\" = [10, 25]\n"
              "[perturbation]\nrelative = 0.05\nseeds = [1, 2]\n");
  }
  apps_testing::RunResult Graybox(const std::string& arguments, const std::string& log) {
    return RunGraybox(arguments, dir_ / log, dir_.path().string());
  }
  std::string Path(const std::string& name) const { return dir_ / name; }
  ScratchDir dir_;
};

// Records without their times (which differ between any two runs).
nlohmann::json Untimed(const std::string& bench_json) {
  nlohmann::json cases = nlohmann::json::parse(bench_json).at("cases");
  for (auto& c : cases) {
    c.erase("seconds");
    c.erase("case_seconds");
  }
  return cases;
}

TEST_F(BenchCommands, ShardsMergedEqualTheWholeRunAndCompareWithABaseline) {
  ASSERT_EQ(Graybox("bench s.toml --out whole --jobs 2", "whole.txt").exit_code, 0);
  for (const char* k : {"1", "2", "3"}) {
    const auto r = Graybox(std::string("bench s.toml --shard ") + k + "/3 --out shard" + k,
                           std::string("shard") + k + ".txt");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const auto missing = Graybox("bench merge shard1 shard3 --out merged", "m0.txt");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_TRUE(Contains(missing.output, "shard 2/3 missing")) << missing.output;
  EXPECT_FALSE(std::filesystem::exists(Path("merged")));
  const auto merged = Graybox("bench merge shard3 shard1 shard2 --out merged", "m.txt");
  ASSERT_EQ(merged.exit_code, 0) << merged.output;
  const nlohmann::json whole = Untimed(ReadText(Path("whole/bench.json")));
  ASSERT_EQ(whole.size(), 4u);
  // Each record names the formulation's options and the program's revision.
  EXPECT_EQ(whole[0].at("options").at("method").get<std::string>(), "multiple_shooting");
  EXPECT_FALSE(whole[0].at("revision").get<std::string>().empty());
  EXPECT_EQ(Untimed(ReadText(Path("merged/bench.json"))), whole);
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(std::filesystem::exists(Path("merged/cases/" + std::to_string(i) + ".json")));
  }
  // The merged run as the baseline: the whole run agrees with it (exit 0).
  ASSERT_EQ(Graybox("bench baseline merged --out base.json", "b.txt").exit_code, 0);
  const auto same = Graybox("bench compare whole --baseline base.json", "c.txt");
  EXPECT_EQ(same.exit_code, 0) << same.output;
  EXPECT_TRUE(Contains(same.output, "all within their tolerances")) << same.output;
  // A baseline whose golden mass differs by 5 %: exit 4, the case, the value, the amount and the
  // command that accepts the run.
  nlohmann::json base = nlohmann::json::parse(ReadText(Path("base.json")));
  for (auto& p : base["cases"][1]["parameters"]) {
    if (p["name"] == "load.mass") p["value"] = p["value"].get<double>() * 1.05;
  }
  WriteText(Path("base.json"), base.dump(2));
  const auto changed = Graybox("bench compare whole --baseline base.json", "c2.txt");
  EXPECT_EQ(changed.exit_code, 4) << changed.output;
  const std::string id = base["cases"][1]["id"].get<std::string>();
  EXPECT_TRUE(Contains(changed.output, id + ": parameter load.mass: ")) << changed.output;
  EXPECT_TRUE(Contains(changed.output, "-4.7619 %")) << changed.output;  // 1/1.05 - 1
  EXPECT_TRUE(Contains(changed.output, "graybox bench baseline whole --out base.json"))
      << changed.output;
  // --seed: every case once with that seed, in place of the suite's.
  ASSERT_EQ(Graybox("bench s.toml --seed 9 --out seeded", "s9.txt").exit_code, 0);
  const nlohmann::json seeded = nlohmann::json::parse(ReadText(Path("seeded/bench.json")));
  ASSERT_EQ(seeded.at("cases").size(), 2u);  // the two segment lengths
  for (const auto& c : seeded.at("cases")) {
    EXPECT_EQ(c.at("seed").get<unsigned>(), 9u);
    EXPECT_TRUE(Contains(c.at("id").get<std::string>(), "/seed=9")) << c.at("id");
  }
  // A file that is not a bench output: exit 2, naming it.
  const auto not_bench = Graybox("bench compare whole --baseline s.toml", "c4.txt");
  EXPECT_EQ(not_bench.exit_code, 2);
  EXPECT_TRUE(Contains(not_bench.output, "s.toml: not JSON")) << not_bench.output;
  // Tolerances read anew from a suite file: 10 % admits it.
  WriteText(Path("loose.toml"),
            "[suite]\nproblems = [\"pushed.toml\"]\n[tolerances]\n"
            "parameters = { relative = 0.1 }\n");
  EXPECT_EQ(
      Graybox("bench compare whole --baseline base.json --suite loose.toml", "c3.txt").exit_code,
      0);
}

}  // namespace
}  // namespace graybox::bench
