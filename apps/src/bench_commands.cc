// The batch runner's commands (docs/bench.md): graybox bench SUITE (with --resume), bench case,
// bench merge, bench baseline, bench compare. Each parses its arguments, calls graybox::runner
// and writes files; outputs are one unit (RunOutput), bench.json last.
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <set>
#include <stdexcept>

#include "app.h"
#include "graybox/bench/compare.h"
#include "graybox/bench/results.h"
#include "graybox/bench/runner.h"
#include "graybox/bench/slurm.h"

namespace graybox::app {

namespace fs = std::filesystem;

namespace {

// This program's own path (the Slurm scripts run it).
std::string SelfExecutable() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot find this program's path (/proc/self/exe)");
  return self.string();
}

// Set by SIGINT or SIGTERM while `graybox bench` runs its cases.
volatile std::sig_atomic_t bench_interrupted = 0;
void OnBenchInterrupt(int) { bench_interrupted = 1; }

// Copies cases/<old>.json and .log of each {old, new} index pair from the output folder `from`
// to cases/<new>.* in `to` (missing files are skipped: a case interrupted before it wrote one).
void CopyCaseFiles(const std::string& from, const std::string& to,
                   const std::vector<std::pair<std::size_t, std::size_t>>& indices) {
  fs::create_directories(fs::path(to) / "cases");
  for (const auto& [old_index, new_index] : indices) {
    for (const char* ext : {".json", ".log"}) {
      const fs::path source = fs::path(from) / "cases" / (std::to_string(old_index) + ext);
      std::error_code ec;
      if (fs::exists(source, ec)) {
        fs::copy_file(source, fs::path(to) / "cases" / (std::to_string(new_index) + ext),
                      fs::copy_options::overwrite_existing);
      }
    }
  }
}

// {index, index} of each record: files kept under their names.
std::vector<std::pair<std::size_t, std::size_t>> SameIndices(
    const std::vector<bench::CaseRecord>& records) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const bench::CaseRecord& r : records) out.emplace_back(r.index, r.index);
  return out;
}

// bench.csv, bench.md and, last, bench.json of `run` into the folder `dir`.
void WriteBenchOutputs(const std::string& dir, const bench::BenchRun& run) {
  WriteFileAtomically((fs::path(dir) / "bench.csv").string(), bench::BenchCsv(run.records));
  WriteFileAtomically((fs::path(dir) / "bench.md").string(),
                      bench::BenchMarkdown(run.suite, run.records));
  // bench.json last: a reader that finds it finds the other outputs too.
  WriteFileAtomically((fs::path(dir) / "bench.json").string(), bench::BenchJson(run));
}

// The records of an earlier output of this suite that --resume keeps: every case recorded with
// a status other than "interrupted" that is among `cases`, its index set to the case's place in
// the suite as it is now (cases may have been added); `moved` gets the {earlier, now} index of
// each, for its files. Refused when the output is of another suite, shard, filter or seed.
std::vector<bench::CaseRecord> ResumedRecords(
    const CommandOptions& o, const bench::Suite& suite, const std::vector<bench::Case>& cases,
    std::vector<std::pair<std::size_t, std::size_t>>* moved) {
  const bench::BenchRun earlier = bench::LoadBenchRun(o.resume);
  if (earlier.suite.name != suite.name || earlier.suite.path != suite.path) {
    throw std::invalid_argument("--resume " + o.resume + ": a run of suite '" + earlier.suite.name +
                                "' (" + earlier.suite.path + "), expected '" + suite.name + "' (" +
                                suite.path + ")");
  }
  const std::string seed = o.seed >= 0 ? std::to_string(o.seed) : "";
  for (const auto& [key, value] : {std::pair<std::string, std::string>{"shard", o.shard},
                                   std::pair<std::string, std::string>{"filter", o.filter},
                                   std::pair<std::string, std::string>{"seed", seed}}) {
    if (earlier.Run(key) != value) {
      throw std::invalid_argument("--resume " + o.resume + ": that run's --" + key + " was '" +
                                  earlier.Run(key) + "', this one's is '" + value + "'");
    }
  }
  std::map<std::string, std::size_t> index_of;
  for (const bench::Case& c : cases) index_of[c.id] = c.index;
  std::vector<bench::CaseRecord> kept;
  for (const bench::CaseRecord& r : earlier.records) {
    const auto it = index_of.find(r.id);
    if (r.status == "interrupted" || it == index_of.end()) continue;
    moved->emplace_back(r.index, it->second);
    kept.push_back(r);
    kept.back().index = it->second;
  }
  return kept;
}

// The suite of the command line, with --seed in place of its seeds.
bench::Suite LoadCommandSuite(const CommandOptions& o) {
  bench::Suite suite = bench::LoadSuite(o.suite);
  if (o.seed >= 0) {
    suite.seeds = {static_cast<unsigned>(o.seed)};
    suite.seeds_stated = true;
  }
  return suite;
}

}  // namespace

int RunBench(const CommandOptions& o) {
  return Guarded([&]() -> int {
    for (const auto& [given, name] :
         {std::pair<bool, const char*>{o.shards > 0, "--shards"},
          std::pair<bool, const char*>{o.array_parallel > 0, "--array-parallel"},
          std::pair<bool, const char*>{!o.partition.empty(), "--partition"},
          std::pair<bool, const char*>{!o.time_limit.empty(), "--time"}}) {
      if (given) throw std::invalid_argument(std::string(name) + ": expected with --slurm");
    }
    const Timer total;
    const bench::Suite suite = LoadCommandSuite(o);
    const std::vector<bench::Case> all = bench::ExpandCases(suite);
    std::vector<bench::Case> cases = bench::FilterCases(all, o.filter);
    if (cases.empty()) {
      throw std::invalid_argument("suite '" + suite.name + "' (" + o.suite + "): no case of " +
                                  std::to_string(all.size()) + " matches --filter '" + o.filter +
                                  "'");
    }
    std::string shard_text;
    if (!o.shard.empty()) {
      const auto [k, n] = bench::ParseShard(o.shard);
      cases =
          bench::SelectShard(cases, k, n,
                             o.costs.empty() ? bench::CostFunction()
                                             : bench::RecordedCosts(bench::LoadBenchRun(o.costs)));
      shard_text = ", shard " + o.shard + (o.costs.empty() ? "" : " balanced by " + o.costs);
    } else if (!o.costs.empty()) {
      throw std::invalid_argument("--costs " + o.costs + ": expected with --shard K/N");
    }
    const std::size_t planned = cases.size();
    std::vector<bench::CaseRecord> kept;
    std::vector<std::pair<std::size_t, std::size_t>> moved;  // {earlier, now} index of kept cases
    if (!o.resume.empty()) {
      kept = ResumedRecords(o, suite, cases, &moved);
      std::set<std::string> done;
      for (const bench::CaseRecord& r : kept) done.insert(r.id);
      std::vector<bench::Case> left;
      for (const bench::Case& c : cases) {
        if (!done.count(c.id)) left.push_back(c);
      }
      cases = std::move(left);
    }
    RunOutput out(o.out);
    Progress("graybox bench: suite '" + suite.name + "' (" + o.suite +
             "): " + std::to_string(planned) + " of " + std::to_string(all.size()) + " cases" +
             shard_text + ", " + std::to_string(o.jobs) + " at a time" +
             (o.resume.empty() ? ""
                               : "; resuming " + o.resume + ": " + std::to_string(kept.size()) +
                                     " recorded, " + std::to_string(cases.size()) + " to run"));
    if (!kept.empty()) CopyCaseFiles(o.resume, out.path(), moved);
    bench::RunOptions options;
    options.jobs = o.jobs;
    options.work_dir = out.path();
    options.revision = GitRevision();
    options.progress = StampedProgress(total, "  ");
    // Ctrl-C (SIGINT) or SIGTERM (kill, a Slurm time limit or scancel): the running cases are
    // stopped and recorded as interrupted, what is done is written (the cases run in their own
    // process groups, so a terminal's signal reaches this process only).
    options.interrupted = []() { return bench_interrupted != 0; };
    bench_interrupted = 0;
    struct sigaction action = {}, previous_int = {}, previous_term = {};
    action.sa_handler = OnBenchInterrupt;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &previous_int);
    sigaction(SIGTERM, &action, &previous_term);
    auto restore = [&]() {
      sigaction(SIGINT, &previous_int, nullptr);
      sigaction(SIGTERM, &previous_term, nullptr);
    };
    std::vector<bench::CaseRecord> records;
    try {
      if (!cases.empty()) records = bench::RunSuite(suite, cases, options);
    } catch (...) {
      restore();
      throw;
    }
    restore();
    const bool interrupted = bench_interrupted != 0;
    bench::BenchRun run;
    run.suite = suite;
    run.machine = bench::ThisMachine();
    run.records = std::move(kept);
    run.records.insert(run.records.end(), records.begin(), records.end());
    bench::SortByIndex(&run.records);
    run.run = RunMetadata(o);
    run.SetRun("shard", o.shard);
    run.SetRun("filter", o.filter);
    run.SetRun("seed", o.seed >= 0 ? std::to_string(o.seed) : "");
    run.SetRun("costs", o.costs);
    run.SetRun("jobs", std::to_string(o.jobs));
    run.SetRun("cases_planned", std::to_string(planned));
    if (!o.resume.empty()) run.SetRun("resumed_from", o.resume);
    run.SetRun("wall_seconds", Sci(total.Seconds()));
    run.SetRun("interrupted", interrupted ? "true" : "false");
    WriteBenchOutputs(out.path(), run);
    const std::string md = bench::BenchMarkdown(suite, run.records);
    Progress(md.substr(md.find("## Summary")));
    Progress("wrote bench.json, bench.csv, bench.md and the cases' records and logs: " +
             out.Commit() + " (" + Sci(total.Seconds()) + " s)");
    if (interrupted) {
      Progress("interrupted: " + std::to_string(run.records.size()) + " of " +
               std::to_string(planned) + " cases recorded; graybox bench " + o.suite +
               " --resume " + o.out + " --out " + o.out + " runs the rest");
      return kExitInterrupted;
    }
    return kExitSuccess;
  });
}

int RunBenchSlurm(const CommandOptions& o) {
  return Guarded([&]() -> int {
    if (o.shards < 1) {
      throw std::invalid_argument("--slurm: expected --shards N (the array's tasks), got none");
    }
    if (!o.shard.empty() || !o.resume.empty()) {
      throw std::invalid_argument(std::string("--slurm: ") +
                                  (o.shard.empty() ? "--resume" : "--shard") +
                                  " is not for a Slurm run (each task runs its own shard)");
    }
    // The suite, its cases and the costs are checked here, before anything is submitted.
    const bench::Suite suite = LoadCommandSuite(o);
    const std::vector<bench::Case> cases = bench::FilterCases(bench::ExpandCases(suite), o.filter);
    if (cases.empty()) {
      throw std::invalid_argument("suite '" + suite.name + "' (" + o.suite +
                                  "): no case matches --filter '" + o.filter + "'");
    }
    if (static_cast<std::size_t>(o.shards) > cases.size()) {
      throw std::invalid_argument("--shards " + std::to_string(o.shards) + ": expected at most " +
                                  std::to_string(cases.size()) + ", the suite's cases");
    }
    if (!o.costs.empty()) bench::LoadBenchRun(o.costs);
    bench::SlurmOptions options;
    options.graybox = SelfExecutable();
    options.suite = fs::absolute(o.suite).lexically_normal().string();
    options.out_dir = fs::absolute(o.out).lexically_normal().string();
    options.shards = o.shards;
    options.array_parallel = o.array_parallel;
    options.partition = o.partition;
    options.time_limit = o.time_limit;
    options.jobs_per_task = o.jobs;
    options.filter = o.filter;
    options.seed = o.seed;
    if (!o.costs.empty()) options.costs = fs::absolute(o.costs).lexically_normal().string();
    bench::SlurmScripts scripts;
    try {
      scripts = bench::SaveSlurmScripts(options);
    } catch (const std::invalid_argument& e) {
      // SlurmOptions' field names, as the command line says them.
      throw std::invalid_argument(std::string("--slurm: ") + e.what());
    }
    Progress("graybox bench --slurm: suite '" + suite.name + "', " + std::to_string(cases.size()) +
             " cases in " + std::to_string(o.shards) + " array tasks; wrote " +
             scripts.array_script + " and " + scripts.merge_script);
    if (o.slurm_script_only) {
      Progress("not submitted (--slurm-script-only): sbatch " + scripts.array_script +
               ", then sbatch --dependency=afterany:<its job id> " + scripts.merge_script);
      return kExitSuccess;
    }
    const bench::SlurmSubmission jobs =
        bench::SubmitSlurm(scripts.array_script, scripts.merge_script);
    Progress("submitted: array job " + jobs.array_job + " (" + std::to_string(o.shards) +
             " tasks, shards in " + options.out_dir + "/shards), merge job " + jobs.merge_job +
             " (afterany:" + jobs.array_job + ", into " + options.out_dir + "/merged); squeue -j " +
             jobs.array_job + "," + jobs.merge_job);
    std::cout << "array_job " << jobs.array_job << "\nmerge_job " << jobs.merge_job << "\n";
    return kExitSuccess;
  });
}

int RunBenchCase(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const bench::Suite suite = LoadCommandSuite(o);
    for (const bench::Case& c : bench::ExpandCases(suite)) {
      if (c.id != o.case_id) continue;
      bench::CaseRecord r = bench::RunCase(suite, c);
      r.revision = GitRevision();
      Progress("case " + c.id + ": " + r.status + (r.error.empty() ? "" : " (" + r.error + ")"));
      WriteFileAtomically(o.record, bench::CaseRecordJson(r));
      return kExitSuccess;
    }
    throw std::invalid_argument("suite '" + suite.name + "' (" + o.suite + ") has no case '" +
                                o.case_id + "'");
  });
}

int RunBenchMerge(const CommandOptions& o) {
  return Guarded([&]() -> int {
    // Every unreadable shard at once (a Slurm task that failed leaves its folder without
    // bench.json).
    std::vector<bench::BenchRun> shards;
    std::string unreadable;
    for (const std::string& dir : o.inputs) {
      try {
        shards.push_back(bench::LoadBenchRun(dir));
      } catch (const std::invalid_argument& e) {
        unreadable += std::string(unreadable.empty() ? "" : "\n") + e.what();
      }
    }
    if (!unreadable.empty()) throw std::invalid_argument("bench merge: " + unreadable);
    bench::BenchRun merged = bench::MergeShards(shards, o.inputs);
    merged.run.insert(merged.run.begin(), {"command_line", o.command_line});
    RunOutput out(o.out);
    for (std::size_t i = 0; i < shards.size(); ++i) {
      CopyCaseFiles(o.inputs[i], out.path(), SameIndices(shards[i].records));
    }
    WriteBenchOutputs(out.path(), merged);
    Progress("graybox bench merge: " + std::to_string(shards.size()) + " shards of suite '" +
             merged.suite.name + "', " + std::to_string(merged.records.size()) + " cases" +
             (merged.Run("interrupted") == "true" ? " (a shard was interrupted)" : "") + ": " +
             out.Commit());
    return kExitSuccess;
  });
}

int RunBenchBaseline(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const std::string& dir = o.inputs.at(0);
    const bench::BenchRun run = bench::LoadBenchRun(dir);
    const fs::path parent = fs::absolute(o.out).parent_path();
    std::error_code ec;
    if (!fs::is_directory(parent, ec)) {
      throw std::invalid_argument("--out " + o.out + ": expected a file in an existing folder, '" +
                                  parent.string() + "' is not one");
    }
    WriteFileAtomically(o.out, bench::BaselineJson(run, dir));
    Progress("graybox bench baseline: " + std::to_string(run.records.size()) + " cases of suite '" +
             run.suite.name + "' from " + dir + " written to " + o.out);
    return kExitSuccess;
  });
}

int RunBenchCompare(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const std::string& dir = o.inputs.at(0);
    const bench::BenchRun run = bench::LoadBenchRun(dir);
    const bench::BenchRun baseline = bench::LoadBenchRun(o.baseline);
    // The tolerances of the suite as the run read it, or read anew from --suite.
    const bench::Tolerances tolerances =
        o.suite.empty() ? run.suite.tolerances : bench::LoadSuite(o.suite).tolerances;
    const bench::Comparison c = bench::CompareRuns(
        baseline, run, tolerances, "graybox bench baseline " + dir + " --out " + o.baseline);
    std::cout << Printable(c.FullReport());
    return c.HasRegression() ? kExitRegression : kExitSuccess;
  });
}

}  // namespace graybox::app
