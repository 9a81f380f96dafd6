// Slurm job arrays (graybox/bench/slurm.h) and `graybox bench SUITE --slurm`: the scripts' texts,
// their quoting, the options' checks, and the command's checks before anything is submitted. The
// run on a real single-node cluster is tools/slurm_test.sh (docs/slurm.md).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "graybox/bench/slurm.h"
#include "test_util.h"

namespace graybox::bench {
namespace {

using apps_testing::PushedCsv;
using apps_testing::PushedProblem;
using apps_testing::ReadText;
using apps_testing::RunGraybox;
using apps_testing::ScratchDir;
using apps_testing::WriteText;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

SlurmOptions Options() {
  SlurmOptions o;
  o.graybox = "/opt/gray box/bin/graybox";
  o.suite = "/shared/suites/it's.toml";
  o.out_dir = "/shared/runs/r1";
  o.shards = 3;
  o.array_parallel = 2;
  o.partition = "compute";
  o.time_limit = "01:00:00";
  o.jobs_per_task = 2;
  o.filter = "*x*'; rm -rf / #";
  o.costs = "/shared/runs/r0/bench.json";
  return o;
}

TEST(BenchSlurm, TheArrayAndMergeScriptsNameEveryShard) {
  const SlurmScripts s = WriteSlurmScripts(Options());
  const std::string& a = s.array_script;
  EXPECT_TRUE(Contains(a, "#SBATCH --job-name=graybox-bench-it_s\n")) << a;
  EXPECT_TRUE(Contains(a, "#SBATCH --array=1-3%2\n")) << a;
  EXPECT_TRUE(Contains(a, "#SBATCH --output=/shared/runs/r1/slurm/%A_%a.log\n")) << a;
  EXPECT_TRUE(Contains(a, "#SBATCH --partition=compute\n")) << a;
  EXPECT_TRUE(Contains(a, "#SBATCH --time=01:00:00\n")) << a;
  EXPECT_TRUE(Contains(a, "#SBATCH --cpus-per-task=2\n")) << a;
  // Paths and the filter are single words for bash, whatever they hold.
  EXPECT_TRUE(Contains(a, "exec '/opt/gray box/bin/graybox' bench '/shared/suites/it'\\''s.toml'"))
      << a;
  EXPECT_TRUE(Contains(a, "--shard \"$shard/3\" --jobs 2 --filter '*x*'\\''; rm -rf / #'")) << a;
  EXPECT_TRUE(Contains(a, "--costs '/shared/runs/r0/bench.json'")) << a;
  EXPECT_TRUE(Contains(a, "--out '/shared/runs/r1/shards/'\"$shard\"")) << a;
  const std::string& m = s.merge_script;
  EXPECT_TRUE(Contains(m, "bench merge")) << m;
  for (const char* k : {"1", "2", "3"}) {
    EXPECT_TRUE(Contains(m, std::string("'/shared/runs/r1/shards/") + k + "'")) << m;
  }
  EXPECT_TRUE(Contains(m, "--out '/shared/runs/r1/merged'")) << m;
  // Without a throttle, partition or time: no such lines.
  SlurmOptions plain = Options();
  plain.array_parallel = 0;
  plain.partition.clear();
  plain.time_limit.clear();
  const std::string p = WriteSlurmScripts(plain).array_script;
  EXPECT_TRUE(Contains(p, "#SBATCH --array=1-3\n")) << p;
  EXPECT_FALSE(Contains(p, "--partition")) << p;
  EXPECT_FALSE(Contains(p, "--time")) << p;
}

// The array script run by bash as an array task (SLURM_ARRAY_TASK_ID set) with a stub for graybox
// that writes its arguments one per line: each path and the hostile filter arrive as one word.
TEST(BenchSlurm, TheArrayScriptPassesEveryArgumentAsOneWord) {
  ScratchDir dir;
  std::filesystem::create_directories(dir.path() / "gray box");
  const std::string stub = (dir.path() / "gray box" / "graybox").string();
  const std::string args_file = (dir.path() / "args.txt").string();
  WriteText(stub,
            "#!/bin/sh\nfor a in \"$@\"; do printf '%s\\n' \"$a\"; done > '" + args_file + "'\n");
  std::filesystem::permissions(stub, std::filesystem::perms::owner_all);
  SlurmOptions o = Options();
  o.graybox = stub;
  o.out_dir = (dir.path() / "runs").string();
  o.seed = 9;
  const std::string script = (dir.path() / "array.sh").string();
  WriteText(script, WriteSlurmScripts(o).array_script);
  std::filesystem::create_directories(dir.path() / "runs" / "shards" / "2");
  ASSERT_EQ(std::system(("SLURM_ARRAY_TASK_ID=2 bash '" + script + "'").c_str()), 0);
  std::vector<std::string> args;
  std::istringstream lines(ReadText(args_file));
  for (std::string line; std::getline(lines, line);) args.push_back(line);
  const std::vector<std::string> expected = {
      "bench",  o.suite,  "--shard", "2/3",     "--jobs", "2",     "--filter",
      o.filter, "--seed", "9",       "--costs", o.costs,  "--out", o.out_dir + "/shards/2"};
  EXPECT_EQ(args, expected);
  // The task removed its shard folder of an earlier run before starting.
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "runs" / "shards" / "2"));
}

TEST(BenchSlurm, OptionsAnSbatchLineCannotHoldAreRefusedByName) {
  auto error = [](SlurmOptions o) {
    try {
      o.Validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  SlurmOptions o = Options();
  o.out_dir = "runs/r1";
  EXPECT_TRUE(Contains(error(o), "SlurmOptions.out_dir: expected an absolute path")) << error(o);
  o = Options();
  o.out_dir = "/shared/runs 1";
  EXPECT_TRUE(Contains(error(o), "SlurmOptions.out_dir")) << error(o);
  o = Options();
  o.time_limit = "01:00\n#SBATCH --x";
  EXPECT_TRUE(Contains(error(o), "SlurmOptions.time_limit")) << error(o);
  o = Options();
  o.shards = 0;
  EXPECT_TRUE(Contains(error(o), "SlurmOptions.shards: expected >= 1, got 0")) << error(o);
  o = Options();
  o.costs = "r0/bench.json";
  EXPECT_TRUE(Contains(error(o), "SlurmOptions.costs")) << error(o);
  EXPECT_EQ(error(Options()), "accepted");
}

TEST(BenchSlurm, TheCommandChecksTheSuiteAndWritesTheScripts) {
  ScratchDir dir;
  WriteText(dir / "pushed.csv", PushedCsv());
  WriteText(dir / "pushed.toml", PushedProblem());
  WriteText(dir / "s.toml",
            "[suite]\nproblems = [\"pushed.toml\"]\n[perturbation]\nseeds = [1, 2, 3]\n");
  auto run = [&](const std::string& args, const std::string& log) {
    return RunGraybox(args, dir / log, dir.path().string());
  };
  // Checked before anything is written or submitted.
  auto r = run("bench s.toml --slurm --out runs", "a.txt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(Contains(r.output, "expected --shards N")) << r.output;
  r = run("bench s.toml --slurm --shards 4 --out runs", "b.txt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(Contains(r.output, "--shards 4: expected at most 3")) << r.output;
  r = run("bench s.toml --shards 2 --out runs", "c.txt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(Contains(r.output, "--shards: expected with --slurm")) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "runs"));
  // The scripts alone.
  r = run("bench s.toml --slurm-script-only --shards 3 --out runs", "d.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string a = ReadText(dir / "runs/slurm/bench_array.sh");
  EXPECT_TRUE(Contains(a, "#SBATCH --array=1-3\n")) << a;
  EXPECT_TRUE(Contains(a, (dir.path() / "s.toml").string())) << a;  // absolute
  EXPECT_TRUE(Contains(ReadText(dir / "runs/slurm/bench_merge.sh"), "bench merge"));
  EXPECT_TRUE(Contains(r.output, "not submitted (--slurm-script-only)")) << r.output;
}

}  // namespace
}  // namespace graybox::bench
