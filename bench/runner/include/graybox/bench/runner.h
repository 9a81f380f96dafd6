// The batch runner: runs a suite's cases (suite.h), each in its own process, up to `jobs` at a
// time, with a wall-time limit per case, and collects one record per case (docs/bench.md).
//
//   RunCase     one case in this process: LoadProblem with the case's overrides, the free
//               parameters' start values perturbed by the case's seed, LoadData, estimators::Fit
//               (its solve limited to the suite's time_limit); the record of what happened.
//               Errors of the problem or its data are recorded (status "error"), not thrown.
//   RunSuite    every case in a child process: by default a fork of the calling process, which
//               runs RunCase and writes the record as JSON (no program to load: the overhead per
//               case is a few milliseconds); with RunOptions::case_command, that command +
//               {"--case", id, "--record", FILE} (the command line's `graybox bench case SUITE`
//               does the same in a fresh program). A case whose process exits without a record
//               is "crashed" (with its exit code or signal), one past time_limit is killed
//               (SIGKILL) and "timed_out"; the run goes on. Each case in its own process because
//               Ipopt 3.11 with sequential MUMPS is not known to be thread-safe, and so that a
//               crash or a runaway solve takes only its case. Forking copies the caller: call
//               RunSuite from a program that has no other threads running (the command line
//               has none), or set case_command.
//   Records     RecordOf: a record's identity (suite, id, index, problem, variation, seed)
//               before the case runs.
//   Shards      SelectShard: the k-th of n parts of the cases, balanced by estimated cost
//               (greedy longest-first over RunOptions::cost_of, default 1 per case), deterministic.
//
// Statuses: "ok" (the solver converged), "not_converged" (a usable iterate: iteration or time
// limit), "failed" (no usable solution), "error" (the problem or its data were refused; the
// message in `error`), "crashed", "timed_out", "interrupted" (RunOptions::interrupted).
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "graybox/bench/suite.h"

namespace graybox::bench {

/// Metrics of one output channel (or "overall") of one split: the simulation metrics of
/// estimators::MetricReport (NRMSE = RMSE / std of the measured channel, FIT %, R^2).
struct ChannelRecord {
  std::string split;
  std::string role;     // "estimation", "validation", "test"
  std::string channel;  // output name, or "overall" (the split's combined metrics)
  double nrmse = 0.0, fit_percent = 0.0, r2 = 0.0;
};

struct ParameterRecord {
  std::string name;
  double value = 0.0;
  double std_error = 0.0;  // NaN without a covariance
  bool free = false;
};

/// What one case did.
struct CaseRecord {
  std::string suite;
  std::string id;
  std::size_t index = 0;               // Case::index: the case's place in the suite
  std::string problem;                 // the problem file
  std::string problem_name;            // [problem] name
  std::vector<std::string> variation;  // "key = value" per override
  unsigned seed = 1;
  std::string status;  // see the file comment
  int exit_code = 0;   // of the case's process (RunSuite; 128 + signal when killed); 0 in RunCase
  std::string error;   // why, for error / crashed / timed_out / failed
  /// RunSuite: wall time from just before the case's process started until its record was in
  /// place (or the process ended without one); RunCase: case_seconds.
  double seconds = 0.0;
  /// Wall time of RunCase (problem, data, fit); seconds - case_seconds is the runner's overhead
  /// (the fork or program start, the record, the collection).
  double case_seconds = 0.0;
  std::string method, solver, solver_status;
  /// The formulation's options as the fit used them (estimators::FitResult::formulation:
  /// method, segment length, scheme, decimation, ...).
  std::vector<std::pair<std::string, std::string>> options;
  std::string revision;  // RunOptions::revision: the program that ran the case
  int iterations = 0;
  double cost = 0.0;
  std::vector<ParameterRecord> parameters;
  std::vector<ChannelRecord> metrics;
};

/// A record with the case's identity and nothing else.
CaseRecord RecordOf(const Suite& suite, const Case& c);

/// The case in this process (file comment).
CaseRecord RunCase(const Suite& suite, const Case& c);

struct RunOptions {
  /// Cases at a time (>= 1).
  int jobs = 1;
  /// Empty (the default): each case runs in a fork of this process. Otherwise the command that
  /// runs one case and writes its record (argv, without "--case ID --record FILE"), such as
  /// {graybox, "bench", "case", SUITE}: a fresh program per case, for callers with threads of
  /// their own or a wrapper (a profiler, a container) around each case.
  std::vector<std::string> case_command;
  /// Folder for the cases' records and logs (DIR/cases/<index>.json, .log); must exist.
  std::string work_dir;
  /// Extra seconds past the suite's time_limit before a case's process is killed (the case's
  /// solve stops itself at time_limit and writes its record; this covers what follows it).
  double kill_grace = 30.0;
  /// Progress lines (cases done / total, running, failed, elapsed, estimated time left);
  /// called from the calling thread.
  std::function<void(const std::string&)> progress;
  /// Asked between polls: true stops launching cases and kills the running ones (recorded as
  /// "interrupted").
  std::function<bool()> interrupted;
  /// Stamped on every record (the command line passes its `git describe`).
  std::string revision;
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// Every case of `cases` in its own process (file comment); the records in the cases' order.
std::vector<CaseRecord> RunSuite(const Suite& suite, const std::vector<Case>& cases,
                                 const RunOptions& options);

/// "K/N" (1 <= K <= N) as {K, N}; throws std::invalid_argument quoting the text otherwise.
std::pair<int, int> ParseShard(const std::string& text);

/// A case's estimated cost for SelectShard.
using CostFunction = std::function<double(const Case&)>;

/// The k-th (1-based) of n shards of `cases`: cases are dealt longest-first (by `cost_of`, 1 per
/// case when empty) to the currently lightest shard, ties to the lower shard; the result keeps
/// the cases' order. Throws std::invalid_argument unless 1 <= k <= n.
std::vector<Case> SelectShard(const std::vector<Case>& cases, int k, int n,
                              const CostFunction& cost_of = {});

}  // namespace graybox::bench
