// The batch runner (runner.h): one case in this process, every case in its own process, shards.
#include "graybox/bench/runner.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <optional>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "graybox/bench/results.h"
#include "graybox/estimators/fit/fit.h"
#include "graybox/util/read_file.h"
#include "graybox/util/write_file.h"

extern char** environ;

namespace graybox::bench {

namespace fs = std::filesystem;
namespace est = graybox::estimators;

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string Fixed(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

// The file's text, "" when it cannot be read (a record or log the case did not write).
std::string ReadFile(const std::string& path) {
  return util::ReadWholeFile(path).value_or(std::string());
}

// The last `lines` lines of a text.
std::string Tail(const std::string& text, int lines) {
  std::size_t pos = text.size();
  while (pos > 0 && (text[pos - 1] == '\n')) --pos;
  for (int n = 0; n < lines && pos > 0; ++n) {
    const std::size_t nl = text.rfind('\n', pos - 1);
    pos = nl == std::string::npos ? 0 : nl;
  }
  std::string t = text.substr(pos);
  while (!t.empty() && t.front() == '\n') t.erase(t.begin());
  while (!t.empty() && t.back() == '\n') t.pop_back();
  return t;
}

// The child's side of a case: its own process group, output into the log, the case run and its
// record written; never returns.
[[noreturn]] void RunCaseInChild(const Suite& suite, const Case& c, const std::string& record,
                                 const std::string& log) {
  setpgid(0, 0);
  std::signal(SIGINT, SIG_DFL);
  const int out = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (out >= 0) {
    dup2(out, STDOUT_FILENO);
    dup2(out, STDERR_FILENO);
  }
  const int in = open("/dev/null", O_RDONLY | O_CLOEXEC);
  if (in >= 0) dup2(in, STDIN_FILENO);
  int code = 0;
  try {
    const CaseRecord r = RunCase(suite, c);
    std::printf("case %s: %s%s%s%s\n", c.id.c_str(), r.status.c_str(), r.error.empty() ? "" : " (",
                r.error.c_str(), r.error.empty() ? "" : ")");
    util::WriteFileAtomically(record, CaseRecordJson(r));
  } catch (const std::exception& e) {
    std::printf("case %s: %s\n", c.id.c_str(), e.what());
    code = 1;
  }
  std::fflush(nullptr);
  _exit(code);
}

// A case in a fork of this process (no program to load: the runner's overhead per case is the
// fork, the record and the exit).
pid_t ForkCase(const Suite& suite, const Case& c, const std::string& record,
               const std::string& log) {
  std::fflush(nullptr);  // buffered output would be written twice, once by the child
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("RunSuite: fork: ") + std::strerror(errno));
  if (pid == 0) RunCaseInChild(suite, c, record, log);
  setpgid(pid, pid);  // also in the parent: no window in which a Ctrl-C reaches the child
  return pid;
}

// A case as `command --case ID --record FILE` (RunOptions::case_command).
pid_t SpawnCase(const std::vector<std::string>& command, const std::string& id,
                const std::string& record, const std::string& log) {
  std::vector<std::string> args = command;
  args.insert(args.end(), {"--case", id, "--record", record});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  // Its own process group: a Ctrl-C at the terminal reaches the runner only, which stops the
  // cases itself and records them (RunOptions::interrupted).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, &attributes, argv.data(), environ);
  posix_spawnattr_destroy(&attributes);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    throw std::runtime_error("RunSuite: cannot start '" + args[0] + "': " + std::strerror(rc));
  }
  return pid;
}

// A case's process whose record is in place, not yet reaped.
struct Exiting {
  pid_t pid;
  std::size_t index;  // into the records
};

// The exit code as a shell reports it: the code, or 128 + the signal.
int ExitCode(int status) {
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// Reaps the processes of `exiting` that have ended and sets their records' exit codes; a process
// that failed after writing its record says so in the error.
void ReapExited(std::vector<Exiting>* exiting, std::vector<CaseRecord>* records) {
  for (std::size_t k = 0; k < exiting->size();) {
    int status = 0;
    const Exiting& e = (*exiting)[k];
    const pid_t w = waitpid(e.pid, &status, WNOHANG);
    if (w == 0) {
      ++k;
      continue;
    }
    CaseRecord& r = (*records)[e.index];
    if (w == e.pid) {
      r.exit_code = ExitCode(status);
      if (r.exit_code != 0) {
        r.error += std::string(r.error.empty() ? "" : "; ") + "the process exited with code " +
                   std::to_string(r.exit_code) + " after writing its record";
      }
    }
    exiting->erase(exiting->begin() + static_cast<std::ptrdiff_t>(k));
  }
}

// Kills a case's process group (the case and anything it started) and reaps the case.
void KillCase(pid_t pid, int* status) {
  kill(-pid, SIGKILL);
  kill(pid, SIGKILL);  // in case it had not yet made its own group
  waitpid(pid, status, 0);
}

}  // namespace

namespace {

// The record of a case whose process ended or was killed: the one it wrote, or one that says why
// there is none (interrupted, timed out, or crashed with its exit code or signal and the tail of
// its log).
CaseRecord EndedCaseRecord(const Suite& suite, const Case& c, const std::string& record,
                           const std::string& log, int status, bool timed_out, bool interrupted,
                           double seconds, double kill_grace) {
  CaseRecord r;
  bool have_record = false;
  if (!timed_out && !interrupted && WIFEXITED(status) && fs::exists(record)) {
    try {
      r = ParseCaseRecordJson(ReadFile(record));
      have_record = true;
    } catch (const std::exception& e) {
      r.error = std::string("unreadable record: ") + e.what();
    }
  }
  if (!have_record) {
    const std::string previous = r.error;
    r = RecordOf(suite, c);
    if (interrupted) {
      r.status = "interrupted";
      r.error = "stopped by an interrupt after " + Fixed("%.1f", seconds) + " s";
    } else if (timed_out) {
      r.status = "timed_out";
      r.error = "killed after " + Fixed("%.1f", seconds) + " s (time_limit " +
                Fixed("%g", suite.time_limit) + " s + " + Fixed("%g", kill_grace) + " s)";
    } else {
      r.status = "crashed";
      r.error = WIFSIGNALED(status) ? "killed by signal " + std::to_string(WTERMSIG(status)) +
                                          " (" + strsignal(WTERMSIG(status)) + ")"
                                    : "exited with code " + std::to_string(WEXITSTATUS(status)) +
                                          " without a record";
      if (!previous.empty()) r.error += "; " + previous;
    }
    r.case_seconds = std::numeric_limits<double>::quiet_NaN();
    const std::string tail = Tail(ReadFile(log), 5);
    if (!tail.empty()) r.error += "; log: " + tail;
  }
  return r;
}

}  // namespace

CaseRecord RecordOf(const Suite& suite, const Case& c) {
  CaseRecord r;
  r.suite = suite.name;
  r.id = c.id;
  r.index = c.index;
  r.problem = c.problem;
  r.problem_name = c.problem_name;
  r.seed = c.seed;
  for (const est::ProblemOverride& o : c.overrides) r.variation.push_back(o.ToString());
  return r;
}

CaseRecord RunCase(const Suite& suite, const Case& c) {
  const auto t0 = Clock::now();
  CaseRecord r = RecordOf(suite, c);
  try {
    est::Problem problem = est::LoadProblem(c.problem, c.overrides);
    if (c.seeded) problem.estimation.seed = c.seed;
    if (c.relative_perturbation > 0.0) {
      // value (1 + relative z), z ~ N(0, 1) from the case's seed, in parameter order.
      std::mt19937 rng(c.seed);
      std::normal_distribution<double> z(0.0, 1.0);
      for (models::ModelParameter& p : problem.built.parameters) {
        if (!p.free) continue;
        p.value = std::clamp(p.value * (1.0 + c.relative_perturbation * z(rng)), p.lower, p.upper);
        problem.model.SetParameter(p.name, p.value);
      }
    }
    const std::vector<est::SplitData> splits = est::LoadData(problem);
    est::FitOptions options;
    options.max_solve_seconds = suite.time_limit;
    const est::FitResult fit = est::Fit(problem, splits, options);
    r.method = fit.method;
    r.solver = fit.solver;
    r.solver_status = fit.solver_result.status;
    r.options = fit.formulation;
    r.iterations = fit.solver_result.iterations;
    r.cost = fit.solver_result.cost;
    r.status = fit.solver_result.success ? "ok"
               : fit.IsSolutionUsable()  ? "not_converged"
                                         : "failed";
    if (r.status != "ok") r.error = fit.solver_result.message;
    for (const est::FitParameter& p : fit.parameters) {
      r.parameters.push_back({p.name, p.value, p.std_error, p.free});
    }
    for (const est::SplitEvaluation& e : fit.evaluations) {
      const std::string role = est::SplitRoleName(e.role);
      for (const est::ChannelMetrics& m : e.simulation.channels) {
        r.metrics.push_back({e.name, role, m.name, m.nrmse, m.fit_percent, m.r2});
      }
      const est::ChannelMetrics& m = e.simulation.overall;
      r.metrics.push_back({e.name, role, "overall", m.nrmse, m.fit_percent, m.r2});
    }
  } catch (const std::exception& e) {
    r.status = "error";
    r.error = e.what();
  }
  r.case_seconds = SecondsSince(t0);
  r.seconds = r.case_seconds;
  return r;
}

void RunOptions::Validate() const {
  if (jobs < 1) {
    throw std::invalid_argument("RunOptions.jobs: expected >= 1, got " + std::to_string(jobs));
  }
  if (work_dir.empty() || !fs::is_directory(work_dir)) {
    throw std::invalid_argument("RunOptions.work_dir: expected an existing folder, got '" +
                                work_dir + "'");
  }
  if (!(kill_grace >= 0.0)) {
    throw std::invalid_argument("RunOptions.kill_grace: expected >= 0, got " +
                                Fixed("%g", kill_grace));
  }
}

std::vector<CaseRecord> RunSuite(const Suite& suite, const std::vector<Case>& cases,
                                 const RunOptions& options) {
  options.Validate();
  const fs::path dir = fs::path(options.work_dir) / "cases";
  fs::create_directories(dir);
  struct Running {
    std::size_t index;
    pid_t pid;
    Clock::time_point start;
  };
  std::vector<CaseRecord> records(cases.size());
  std::vector<bool> done(cases.size(), false);
  std::vector<Running> running;
  std::size_t next = 0, finished = 0, failed = 0;
  double busy_seconds = 0.0;
  const auto t0 = Clock::now();
  auto record_path = [&](std::size_t i) {
    return (dir / (std::to_string(cases[i].index) + ".json")).string();
  };
  auto log_path = [&](std::size_t i) {
    return (dir / (std::to_string(cases[i].index) + ".log")).string();
  };
  auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  auto launch = [&](std::size_t i) {
    std::error_code ec;
    fs::remove(record_path(i), ec);
    const std::string log = log_path(i);
    const auto start = Clock::now();  // before the fork or spawn: part of the overhead
    pid_t pid = -1;
    if (options.case_command.empty()) {
      pid = ForkCase(suite, cases[i], record_path(i), log);
    } else {
      pid = SpawnCase(options.case_command, cases[i].id, record_path(i), log);
    }
    running.push_back({i, pid, start});
  };
  auto finish = [&](const Running& run, int status, bool timed_out, bool interrupted) {
    const std::size_t i = run.index;
    const double seconds = SecondsSince(run.start);
    busy_seconds += seconds;
    CaseRecord r = EndedCaseRecord(suite, cases[i], record_path(i), log_path(i), status, timed_out,
                                   interrupted, seconds, options.kill_grace);
    r.exit_code = ExitCode(status);
    r.revision = options.revision;
    r.seconds = seconds;
    records[i] = std::move(r);
    done[i] = true;
    ++finished;
    const std::string& st = records[i].status;
    if (st != "ok") ++failed;
    const double elapsed = SecondsSince(t0);
    const std::size_t left = cases.size() - finished;
    const double per_case = busy_seconds / static_cast<double>(finished);
    const double eta = per_case * static_cast<double>(left) / options.jobs;
    progress("[" + std::to_string(finished) + "/" + std::to_string(cases.size()) + "] " +
             cases[i].id + ": " + st + " (" + Fixed("%.1f", seconds) + " s); running " +
             std::to_string(running.size() - 1) + ", not ok " + std::to_string(failed) +
             ", elapsed " + Fixed("%.0f", elapsed) + " s, left ~" + Fixed("%.0f", eta) + " s");
  };
  std::vector<Exiting> exiting;  // processes of finished cases not yet reaped
  // On an exception (a case that cannot be started, a file system error), no process of a case
  // may outlive the call: they are killed and reaped.
  struct Guard {
    std::vector<Running>* running;
    std::vector<Exiting>* exiting;
    bool armed = true;
    ~Guard() {
      if (!armed) return;
      int status = 0;
      for (const Running& r : *running) KillCase(r.pid, &status);
      for (const Exiting& e : *exiting) KillCase(e.pid, &status);
    }
  } guard{&running, &exiting};
  bool stop = false;
  while (finished < cases.size()) {
    if (!stop && options.interrupted && options.interrupted()) stop = true;
    while (!stop && next < cases.size() && static_cast<int>(running.size()) < options.jobs) {
      progress("starting " + cases[next].id);
      launch(next++);
    }
    if (stop && running.empty()) break;
    for (std::size_t k = 0; k < running.size();) {
      int status = 0;
      const Running run = running[k];
      const pid_t w = waitpid(run.pid, &status, WNOHANG);
      std::error_code ec;
      if (w == 0 && fs::exists(record_path(run.index), ec)) {
        // The record is complete (written whole, then renamed into place): the case is done,
        // even if its time ran out meanwhile. Its process is tearing down (a few milliseconds of
        // unmapping) and is reaped later without holding a slot; its exit code is set then.
        finish(run, 0, false, false);
        exiting.push_back({run.pid, run.index});
      } else if (w == 0 &&
                 (stop || SecondsSince(run.start) > suite.time_limit + options.kill_grace)) {
        KillCase(run.pid, &status);
        finish(run, status, !stop, stop);
      } else if (w == run.pid) {
        finish(run, status, false, false);
      } else if (w != 0) {
        finish(run, 0x7f00, false, false);  // lost child: "exited with code 127"
      } else {
        ++k;
        continue;
      }
      running.erase(running.begin() + static_cast<std::ptrdiff_t>(k));
    }
    ReapExited(&exiting, &records);
    // Polled every millisecond: the latency a finished case waits to be collected is part of
    // the runner's overhead (a 50 ms poll was a third of it on a 0.15 s case).
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // No process of a case outlives the run: those still exiting get options.kill_grace.
  const auto wait_start = Clock::now();
  while (!exiting.empty() && SecondsSince(wait_start) < options.kill_grace) {
    ReapExited(&exiting, &records);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  for (const Exiting& e : exiting) {
    int status = 0;
    KillCase(e.pid, &status);
  }
  guard.armed = false;
  std::vector<CaseRecord> out;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    if (done[i]) out.push_back(std::move(records[i]));
  }
  return out;
}

std::pair<int, int> ParseShard(const std::string& text) {
  int k = 0, n = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%d/%d%c", &k, &n, &tail) != 2 || n < 1 || k < 1 || k > n) {
    throw std::invalid_argument("--shard: expected K/N with 1 <= K <= N (e.g. 2/4), got '" + text +
                                "'");
  }
  return {k, n};
}

std::vector<Case> SelectShard(const std::vector<Case>& cases, int k, int n,
                              const CostFunction& cost_of) {
  if (n < 1 || k < 1 || k > n) {
    throw std::invalid_argument("SelectShard: expected 1 <= k <= n, got k = " + std::to_string(k) +
                                ", n = " + std::to_string(n));
  }
  std::vector<std::size_t> order(cases.size());
  std::vector<double> cost(cases.size(), 1.0);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    order[i] = i;
    if (cost_of) cost[i] = cost_of(cases[i]);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return cost[a] > cost[b]; });
  std::vector<double> load(static_cast<std::size_t>(n), 0.0);
  std::vector<int> shard_of(cases.size(), 0);
  for (const std::size_t i : order) {
    const auto lightest = std::min_element(load.begin(), load.end());
    shard_of[i] = static_cast<int>(lightest - load.begin());
    *lightest += cost[i];
  }
  std::vector<Case> out;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    if (shard_of[i] == k - 1) out.push_back(cases[i]);
  }
  return out;
}

}  // namespace graybox::bench
