// The batch runner's overhead per case (docs/bench.md, "Overhead"): RunSuite runs the shortest
// shipped case (EMPS IDIM-LS, about 0.15 s of work) in its own process, either forked from the
// runner (the default) or as a fresh `graybox bench case` program (RunOptions::case_command).
// The counters are per case: overhead_ms = seconds - case_seconds (from just before the fork or
// the program's start to the record in place, less the case's own work: the fork or the
// program's loading and the suite, the record, the collection; not the process's teardown) and
// its share of the case's own time.
//   build/bench/runner_overhead_bench --benchmark_repetitions=5
//   --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>
#include <vector>

#include "graybox/bench/runner.h"
#include "graybox/bench/suite.h"

namespace bench = graybox::bench;
namespace fs = std::filesystem;

namespace {

void BM_RunnerOverhead(benchmark::State& state) {
  const bool fork_cases = state.range(0) == 0;
  const std::string suite_path = std::string(GRAYBOX_SOURCE_DIR) + "/bench/suites/emps.toml";
  const bench::Suite suite = bench::LoadSuite(suite_path);
  const std::vector<bench::Case> cases =
      bench::FilterCases(bench::ExpandCases(suite), "emps_idim/seed=1");
  const fs::path work = fs::temp_directory_path() / "graybox_runner_overhead_bench";
  fs::create_directories(work);
  bench::RunOptions options;
  options.work_dir = work.string();
  if (!fork_cases) options.case_command = {GRAYBOX_EXECUTABLE, "bench", "case", suite_path};
  double overhead = 0.0, work_seconds = 0.0;
  int runs = 0;
  for (auto _ : state) {
    const std::vector<bench::CaseRecord> records = bench::RunSuite(suite, cases, options);
    if (records.size() != 1 || records[0].status != "ok") {
      state.SkipWithError("the case did not run");
      break;
    }
    overhead += records[0].seconds - records[0].case_seconds;
    work_seconds += records[0].case_seconds;
    ++runs;
  }
  fs::remove_all(work);
  if (runs > 0) {
    state.counters["overhead_ms"] = 1e3 * overhead / runs;
    state.counters["case_ms"] = 1e3 * work_seconds / runs;
    state.counters["overhead_percent"] = 100.0 * overhead / work_seconds;
  }
  state.SetLabel(fork_cases ? "fork" : "exec graybox bench case");
}
BENCHMARK(BM_RunnerOverhead)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(20);

}  // namespace

BENCHMARK_MAIN();
