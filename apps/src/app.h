// Private interface of the `graybox` command-line tool: the commands (fit, simulate, check) called
// by graybox/main.cc (the only translation unit that sees CLI11), and the pieces they share.
//
// Exit codes (also in docs/problem-format.md):
//   0  success
//   1  internal error (an output could not be written, an unexpected exception)
//   2  bad input: a problem-file, data or parameter-file defect, or a bad command line; the
//      message names the file, the field or line, and what was expected; nothing is written
//   3  the solver failed (or the simulation diverged); result.json is still written and its
//      "status" says why
//   4  graybox bench compare: a regression against the baseline
//   130  graybox bench stopped by Ctrl-C (what was done is written)
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/util/write_file.h"

namespace graybox::app {

inline constexpr int kExitSuccess = 0;
inline constexpr int kExitInternalError = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitSolverFailure = 3;
/// `graybox bench compare`: a value outside its tolerance, a new failure, a missing case or a time
/// regression against the baseline.
inline constexpr int kExitRegression = 4;
/// `graybox bench` stopped by Ctrl-C (128 + SIGINT, as shells report it): what was done is written.
inline constexpr int kExitInterrupted = 130;

/// Options shared by the commands (filled by main.cc from the command line).
struct CommandOptions {
  std::string problem;   // path of the problem file
  std::string out;       // output directory
  std::string params;    // simulate --params / fit --from: result.json or TOML parameter file
  bool verbose = false;  // solver iteration lines
  bool check_derivatives = false;
  double max_seconds = 0.0;  // fit --max-seconds: wall-time limit of the solve (0: none)
  std::string command_line;  // recorded in result.json
  // diagnose only.
  int max_effects = 3;
  int refit_top = 5;
  int threads = 0;
  std::vector<std::string> effects;  // candidate effects to propose; empty: the default set
  bool no_reference = false;         // skip the flexible reference
  double refit_seconds = 0.0;        // budget of each re-fit (all its solves)
  bool refit_in_processes = false;   // Ipopt re-fits in child processes, not in threads
  // bench withheld only.
  bool fast = false;               // the CI subset
  std::vector<std::string> cases;  // name filters
  // bench SUITE and bench case.
  std::string suite;               // suite file or folder
  int jobs = 1;                    // cases at a time
  std::string shard;               // "K/N" or empty
  std::string filter;              // glob over case ids
  std::string case_id;             // bench case: the case to run
  std::string record;              // bench case: where its record goes
  std::string resume;              // bench SUITE --resume: an earlier output folder of this suite
  bool slurm = false;              // bench SUITE --slurm: a job array of shards and a merge job
  bool slurm_script_only = false;  // --slurm-script-only: write the scripts, do not submit
  int shards = 0;                  // --shards N: the array's tasks
  int array_parallel = 0;          // --array-parallel N: tasks at a time (0: no limit)
  std::string partition;           // --partition P
  std::string time_limit;          // --time LIMIT (sbatch's format)
  long seed = -1;     // bench SUITE --seed: every case with this seed (-1: the suite's)
  std::string costs;  // bench SUITE --costs: a bench output whose times balance shards
  std::vector<std::string> inputs;  // bench merge: shard outputs; baseline/compare: the run
  std::string baseline;             // bench compare: the baseline file
  // blocks only.
  std::string block_type;                  // empty: list every type
  std::vector<std::string> block_options;  // "key=value" ("key=1,2" numbers, else a word)
};

int RunFit(const CommandOptions& options);
int RunSimulate(const CommandOptions& options);
/// The gap analysis (diagnosis::Diagnose): writes DIR/diagnosis.json and DIR/report.html.
int RunDiagnose(const CommandOptions& options);
/// The diagnosis on the withheld-effect cases (bench/withheld): writes DIR/bench.json, prints the
/// confusion table and the pass marks.
int RunBenchWithheld(const CommandOptions& options);
/// The batch runner (bench/runner): every case of a suite in its own process; writes
/// DIR/bench.json, bench.csv, bench.md and DIR/cases/ (each case's record and log).
int RunBench(const CommandOptions& options);
/// The suite as a Slurm job array (bench::SaveSlurmScripts, bench::SubmitSlurm): writes
/// DIR/slurm/bench_array.sh and bench_merge.sh and submits them unless --slurm-script-only.
int RunBenchSlurm(const CommandOptions& options);
/// One case of a suite in this process (what RunBench starts per case): writes its record.
int RunBenchCase(const CommandOptions& options);
/// Shard outputs joined into one (bench::MergeShards), with the cases' records and logs.
int RunBenchMerge(const CommandOptions& options);
/// A run's bench.json written as a baseline file (bench::BaselineJson).
int RunBenchBaseline(const CommandOptions& options);
/// A run against a baseline (bench::CompareRuns): the findings; exit 4 on a regression.
int RunBenchCompare(const CommandOptions& options);
/// Lists the registered block types, or describes one (models::DescribeBlock).
int RunBlocks(const CommandOptions& options);
/// Parses the problem and reads its data without solving; prints a summary.
int RunCheck(const CommandOptions& options);

/// "v0.1.0-12-gabcdef-dirty" from `git describe --always --dirty` at build time, or "unknown".
const char* GitRevision();
const char* Version();

// ---- pieces shared by the commands -------------------------------------------------------------

/// Wall time since construction.
class Timer {
 public:
  double Seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

/// A line on standard output, through Printable.
void Progress(const std::string& line);
/// v with 6 significant digits (%.6g).
std::string Sci(double v);
/// Runs `body` and maps exceptions to exit codes: bad input (std::invalid_argument, including
/// ProblemFileError) -> 2, anything else -> 1; the message on standard error.
int Guarded(const std::function<int()>& body);
/// Progress lines stamped with the seconds since `total` started.
std::function<void(const std::string&)> StampedProgress(const Timer& total,
                                                        const std::string& indent);
/// The "run" object of diagnosis.json and bench.json: command line, revision, version.
std::vector<std::pair<std::string, std::string>> RunMetadata(const CommandOptions& o);

/// Parameter values from a result.json ("parameters": {name: {"value": v}}), a run folder holding
/// one, or a TOML file of "<instance>.<param>" = value (top level or in [parameters]); names
/// checked against the model, values finite and within the problem's bounds, at least one.
/// Throws estimators::ProblemFileError naming the file (and key).
std::map<std::string, double> LoadParameterValues(const std::string& path,
                                                  const models::StateSpaceModel& model);

/// `text` with its control characters (other than newline and tab) written as \xNN, so that
/// text from files (CSV headers, TOML strings) echoed in a message cannot drive the terminal
/// (an escape sequence that retitles it). Every line the command prints goes through it.
std::string Printable(const std::string& text);
/// True for the characters Printable escapes, newline and tab included (bytes < 0x20 and DEL).
bool IsControlCharacter(char c);

/// Writes `content` to `path` through a temporary file in the same folder and a rename, so a
/// reader never sees a half-written file (graybox/util/write_file.h). Throws std::runtime_error.
using util::WriteFileAtomically;

/// The outputs of one run as one unit: they are written into a fresh staging folder beside the
/// output folder DIR (".<name>.partial-<pid>") and swapped into place by Commit(), so that a
/// reader sees the earlier run whole or this run whole, never a mix (no file of an earlier run
/// is left beside this run's).
///   RunOutput out(o.out);          // before solving: checks that DIR can be written
///   Write(out.path() + "/result.json", ...);
///   Progress(out.Commit());        // "... replaced the earlier run in DIR" / "... created DIR"
/// Destroyed without Commit() (an error before the outputs were complete), the staging folder
/// is removed and DIR is untouched.
class RunOutput {
 public:
  /// Throws std::invalid_argument (exit 2) with the reason when DIR is empty or an existing
  /// file, or when the staging folder cannot be created beside it (a parent that is a file or
  /// not writable).
  explicit RunOutput(const std::string& dir);
  ~RunOutput();
  RunOutput(const RunOutput&) = delete;
  RunOutput& operator=(const RunOutput&) = delete;
  /// The folder to write into (the staging folder).
  const std::string& path() const { return staging_; }
  /// Moves the staging folder to DIR; an earlier DIR is moved aside first and removed after.
  /// Returns what happened, for the log. When DIR cannot be replaced (it or its parent is
  /// immutable) it throws std::runtime_error saying that the earlier run is untouched and
  /// where this run's outputs are (the staging folder is kept).
  std::string Commit();

 private:
  std::string dir_, staging_;
  bool done_ = false;
};

/// SVG plots of a split: measured against simulated outputs, and their residuals.
std::string PlotOutputs(const estimators::SplitEvaluation& e, const models::StateSpaceModel& model);
std::string PlotResiduals(const estimators::SplitEvaluation& e,
                          const models::StateSpaceModel& model);
/// Equation error: measured against predicted target (e.g. the force) and the residual.
std::string PlotEquation(const estimators::SplitEvaluation& e);

}  // namespace graybox::app
