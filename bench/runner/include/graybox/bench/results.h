// A bench run's results (docs/bench.md): the records of its cases with the suite, the run's
// metadata and the machine, as DIR/bench.json, bench.csv and bench.md, read back, and shard
// outputs merged into one run.
//
//   BenchRun run{suite, metadata, ThisMachine(), records};
//   Write(dir + "/bench.json", BenchJson(run));
//   const BenchRun again = LoadBenchRun(dir);          // DIR/bench.json, or the file itself
//   const BenchRun whole = MergeShards({LoadBenchRun(a), LoadBenchRun(b)}, {a, b});
//
// Failure behaviour: ParseBenchJson / LoadBenchRun throw std::invalid_argument naming the file
// and the field; MergeShards throws std::invalid_argument naming the missing or duplicated
// shards, or the runs that are not shards of one suite.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "graybox/bench/runner.h"
#include "graybox/bench/suite.h"

namespace graybox::bench {

/// The machine a run ran on: the CPU model of /proc/cpuinfo, the hardware threads, the OS's
/// PRETTY_NAME ("AMD EPYC 7B13", 2, "Debian GNU/Linux 12 (bookworm)").
struct Machine {
  std::string cpu;
  int cores = 0;
  std::string os;
};
Machine ThisMachine();

/// One run of a suite (or one shard of it, or shards merged).
struct BenchRun {
  /// The suite as the run read it: name, description, path, time_limit,
  /// relative_perturbation, seeds and tolerances (problems and variations are not kept).
  Suite suite;
  /// "command_line", "revision", "version", "shard" ("K/N" or ""), "filter", "seed" (--seed, or
  /// ""), "costs" (--costs, or ""), "jobs", "cases_planned" (cases the run set out to run),
  /// "wall_seconds", "interrupted" ("true"/"false"); resumed runs add "resumed_from", merged
  /// runs "merged_from", baseline files "baseline_of".
  std::vector<std::pair<std::string, std::string>> run;
  Machine machine;
  std::vector<CaseRecord> records;  // by Case::index

  /// The metadata value of `key`, or "" when absent.
  std::string Run(const std::string& key) const;
  void SetRun(const std::string& key, const std::string& value);
};

/// A record as JSON, and back (throws std::invalid_argument naming the field).
std::string CaseRecordJson(const CaseRecord& r);
CaseRecord ParseCaseRecordJson(const std::string& json);

/// DIR/bench.json: {"schema", "suite", "run", "machine", "cases": [records]}.
std::string BenchJson(const BenchRun& run);
/// A bench.json (or a baseline written from one); `path` names it in messages.
BenchRun ParseBenchJson(const std::string& json, const std::string& path);
/// DIR/bench.json when `path` is a folder, else the file itself.
BenchRun LoadBenchRun(const std::string& path);

/// DIR/bench.csv: one row per case, split and channel (a case without metrics: one row).
std::string BenchCsv(const std::vector<CaseRecord>& records);
/// DIR/bench.md: one row per case, and the suite's summary (cases, success rate, total and
/// slowest cases).
std::string BenchMarkdown(const Suite& suite, const std::vector<CaseRecord>& records);

/// Orders records by Case::index (stable).
void SortByIndex(std::vector<CaseRecord>* records);

/// Costs for SelectShard from an earlier run or a baseline: a case's recorded `seconds` (by id);
/// a case it lacks, or one without a finite time, costs the median of the recorded times (1 when
/// none is).
CostFunction RecordedCosts(const BenchRun& run);

/// Shard outputs (`--shard K/N` runs; `names` label them in messages) joined into the run the
/// whole suite would have given: the records of every shard ordered by case index. Refused
/// (std::invalid_argument) when the runs are of different suites, filters or shard counts,
/// when a shard is missing, given twice or out of range, when a case appears twice, or when the
/// shards recorded fewer cases than they planned without an interrupt. The merged run's
/// metadata: "merged_from" (the names), "shard" empty, "wall_seconds" the longest shard's,
/// "cases_planned" the sum, "interrupted" when any shard was, "revision" the shards' (joined
/// with " / " when they differ).
BenchRun MergeShards(const std::vector<BenchRun>& shards, const std::vector<std::string>& names);

}  // namespace graybox::bench
