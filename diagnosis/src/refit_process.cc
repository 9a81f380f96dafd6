// RefitProcess (screening_internal.h): a re-fit in a child process, its result sent back through a
// socket pair as length-prefixed binary messages.
//
// Messages, child to parent: the stage-A summary (ok, at bound, validation NRMSE after, failure,
// whether a shape stage follows), then the final result. Parent to child: one command after the
// summary, 'B' (stage B), 'H' with the reason (shapes held) or 'F' (finish). Both sides are the
// same program, so doubles travel as their bytes.
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "screening_internal.h"

namespace graybox::diagnosis::internal {

namespace est = graybox::estimators;

namespace {

// The child's descriptor of its channel (after the standard streams).
constexpr int kChildChannelFd = 3;
// The longest message either side accepts (a re-fit's solver point is a few MB).
constexpr std::uint64_t kMaxMessageBytes = std::uint64_t{1} << 30;
// The parent waits for each message of a child at most kWaitBudgetFactor times the re-fit's CPU
// budget in wall time, at least kMinWaitSeconds (a loaded machine stretches the budget's wall
// time; a child that hangs must not hang the diagnosis).
constexpr double kWaitBudgetFactor = 20.0;
constexpr double kMinWaitSeconds = 600.0;
// The re-fit built again from the child's point validates as the child computed, to rounding
// (the same operations on the same data; only a changed computation would differ).
constexpr double kRebuiltValidationRelTol = 1e-9;

class Writer {
 public:
  void Put(double v) { Raw(&v, sizeof v); }
  void Put(std::int64_t v) { Raw(&v, sizeof v); }
  void Put(int v) { Put(static_cast<std::int64_t>(v)); }
  void Put(bool v) { Put(static_cast<std::int64_t>(v ? 1 : 0)); }
  void Put(const std::string& v) {
    Put(static_cast<std::int64_t>(v.size()));
    Raw(v.data(), v.size());
  }
  void Put(const Eigen::VectorXd& v) {
    Put(static_cast<std::int64_t>(v.size()));
    Raw(v.data(), sizeof(double) * static_cast<std::size_t>(v.size()));
  }
  const std::string& bytes() const { return bytes_; }

 private:
  void Raw(const void* p, std::size_t n) { bytes_.append(static_cast<const char*>(p), n); }
  std::string bytes_;
};

class Reader {
 public:
  explicit Reader(const std::string& bytes) : bytes_(bytes) {}
  double Double() {
    double v;
    Raw(&v, sizeof v);
    return v;
  }
  std::int64_t Int() {
    std::int64_t v;
    Raw(&v, sizeof v);
    return v;
  }
  bool Bool() { return Int() != 0; }
  std::string String() {
    const std::size_t n = Size(1);
    std::string v(bytes_.data() + pos_, n);
    pos_ += n;
    return v;
  }
  Eigen::VectorXd Vector() {
    const std::size_t n = Size(sizeof(double));
    Eigen::VectorXd v(static_cast<Eigen::Index>(n));
    Raw(v.data(), n * sizeof(double));
    return v;
  }

 private:
  std::size_t Size(std::size_t element) {
    const std::int64_t n = Int();
    if (n < 0 || static_cast<std::size_t>(n) > (bytes_.size() - pos_) / element) {
      throw std::runtime_error("a malformed message from the re-fit's process");
    }
    return static_cast<std::size_t>(n);
  }
  void Raw(void* p, std::size_t n) {
    if (bytes_.size() - pos_ < n) {
      throw std::runtime_error("a truncated message from the re-fit's process");
    }
    std::memcpy(p, bytes_.data() + pos_, n);
    pos_ += n;
  }
  const std::string& bytes_;
  std::size_t pos_ = 0;
};

bool WriteAll(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    // A socket, written without SIGPIPE: a peer that has gone is a failed send, not a signal.
    const ssize_t k = ::send(fd, p, n, MSG_NOSIGNAL);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k;
    n -= static_cast<std::size_t>(k);
  }
  return true;
}

bool ReadAll(int fd, char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t k = ::read(fd, p, n);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k;
    n -= static_cast<std::size_t>(k);
  }
  return true;
}

bool Send(int fd, const std::string& message) {
  const std::uint64_t n = message.size();
  return WriteAll(fd, reinterpret_cast<const char*>(&n), sizeof n) &&
         WriteAll(fd, message.data(), message.size());
}

// False when the other end closed before a whole message came, or the message is too long.
bool Receive(int fd, std::string* message) {
  std::uint64_t n = 0;
  if (!ReadAll(fd, reinterpret_cast<char*>(&n), sizeof n)) return false;
  if (n > kMaxMessageBytes) return false;
  message->assign(n, '\0');
  return ReadAll(fd, message->data(), n);
}

// Waits until `fd` is readable (a message or the other end closed): false when `seconds` of wall
// time pass first.
bool WaitReadable(int fd, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    const double left =
        std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (!(left > 0.0)) return false;
    pollfd readable{fd, POLLIN, 0};
    const int k = ::poll(&readable, 1, static_cast<int>(std::min(left * 1000.0 + 1.0, 60000.0)));
    if (k > 0) return true;
    if (k < 0 && errno != EINTR) return true;  // the read that follows reports it
  }
}

void PutSolverResult(Writer* w, const est::SolverResult& r) {
  w->Put(r.solver);
  w->Put(r.success);
  w->Put(static_cast<int>(r.status_code));
  w->Put(r.status);
  w->Put(r.message);
  w->Put(r.w);
  w->Put(r.lambda);
  w->Put(r.z_lower);
  w->Put(r.z_upper);
  w->Put(r.cost);
  w->Put(r.constraint_violation);
  w->Put(r.iterations);
  w->Put(r.seconds);
  w->Put(static_cast<int>(r.history.size()));
  for (const est::IterationSummary& it : r.history) {
    w->Put(it.iteration);
    w->Put(it.cost);
    w->Put(it.constraint_violation);
    w->Put(it.optimality);
    w->Put(it.seconds);
    w->Put(it.hessian_perturbation);
    w->Put(it.restoration);
  }
}

est::SolverResult GetSolverResult(Reader* r) {
  est::SolverResult s;
  s.solver = r->String();
  s.success = r->Bool();
  s.status_code = static_cast<est::SolverStatus>(r->Int());
  s.status = r->String();
  s.message = r->String();
  s.w = r->Vector();
  s.lambda = r->Vector();
  s.z_lower = r->Vector();
  s.z_upper = r->Vector();
  s.cost = r->Double();
  s.constraint_violation = r->Double();
  s.iterations = static_cast<int>(r->Int());
  s.seconds = r->Double();
  const std::int64_t n = r->Int();
  for (std::int64_t i = 0; i < n; ++i) {
    est::IterationSummary it;
    it.iteration = static_cast<int>(r->Int());
    it.cost = r->Double();
    it.constraint_violation = r->Double();
    it.optimality = r->Double();
    it.seconds = r->Double();
    it.hessian_perturbation = r->Double();
    it.restoration = r->Bool();
    s.history.push_back(it);
  }
  return s;
}

// The final result: every RefitResult field the parent does not know, and of the fit what
// FitSession::ResultOf needs to build it again.
std::string FinalMessage(const RefitResult& r, double variant_option) {
  Writer w;
  w.Put(r.ok);
  w.Put(r.at_bound);
  w.Put(r.failure);
  w.Put(static_cast<int>(r.stages.size()));
  for (const std::string& s : r.stages) w.Put(s);
  w.Put(r.validation_nrmse_after);
  w.Put(r.relative_gain);
  w.Put(r.aic);
  w.Put(r.bic);
  w.Put(static_cast<int>(r.candidate.augmentation.options.numbers.size()));
  for (const auto& [key, values] : r.candidate.augmentation.options.numbers) {
    w.Put(key);
    w.Put(Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(
        values.data(), static_cast<Eigen::Index>(values.size()))));
  }
  w.Put(variant_option);
  const bool has_fit = r.fit.solver_result.w.size() > 0 && !r.fit.parameters.empty();
  w.Put(has_fit);
  if (has_fit) {
    PutSolverResult(&w, r.fit.solver_result);
    w.Put(static_cast<int>(r.fit.parameters.size()));
    for (const est::FitParameter& p : r.fit.parameters) {
      w.Put(p.name);
      w.Put(p.initial);
      w.Put(p.free);
    }
    w.Put(static_cast<int>(r.fit.seconds.size()));
    for (const auto& [what, seconds] : r.fit.seconds) {
      w.Put(what);
      w.Put(seconds);
    }
  }
  return w.bytes();
}

[[noreturn]] void RunChild(int channel, pid_t parent, const est::Problem& problem,
                           const std::vector<est::SplitData>& splits, const est::FitResult& nominal,
                           const CandidateScore& screened, const std::string& role, double before,
                           double max_seconds) {
  int code = 0;
  try {
    RefitRun run(problem, splits, nominal, screened, role, before, max_seconds);
    run.RunStageA();
    Writer summary;
    summary.Put(run.result().ok);
    summary.Put(run.result().at_bound);
    summary.Put(run.result().validation_nrmse_after);
    summary.Put(run.result().failure);
    summary.Put(run.HasShapeStage());
    if (!Send(channel, summary.bytes())) _exit(3);
    // Waits for the command, watching that the parent lives (the channel's other end may live on
    // in a sibling re-fit's process, forked later, so its end alone does not tell).
    for (;;) {
      pollfd readable{channel, POLLIN, 0};
      const int k = ::poll(&readable, 1, 1000);
      if (k < 0 && errno != EINTR) _exit(3);
      if (k > 0) break;
      if (::getppid() != parent) _exit(5);
    }
    std::string command;
    if (!Receive(channel, &command)) _exit(3);
    Reader r(command);
    const std::string step = r.String();
    if (step == "B") {
      run.RunStageB();
    } else if (step == "H") {
      run.HoldShapes(r.String());
    }
    const double variant = run.variant_option();
    const RefitResult result = run.Finish();
    if (!Send(channel, FinalMessage(result, variant))) code = 3;
  } catch (...) {
    code = 2;
  }
  _exit(code);
}

void CloseFd(int* fd) {
  if (*fd >= 0) ::close(*fd);
  *fd = -1;
}

}  // namespace

bool RefitsInProcesses(const est::Problem& problem, int threads) {
  // A penalty toward the parameters' values at formulation (RegularizationReference::kInitial)
  // holds the values the child's session formulated with, which the parent cannot rebuild.
  for (const est::RegularizationTerm& t : problem.estimation.regularization.terms) {
    if (t.reference == est::RegularizationReference::kInitial) return false;
  }
  return problem.estimation.solver == "ipopt" && threads > 1;
}

RefitProcess::RefitProcess(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                           const est::FitResult& nominal, const CandidateScore& screened,
                           const std::string& role, double before, double max_seconds)
    : problem_(problem),
      splits_(splits),
      nominal_(nominal),
      screened_(screened),
      role_(role),
      wait_seconds_(std::max(kMinWaitSeconds, kWaitBudgetFactor * max_seconds)) {
  out_ = UnfittedResult(screened, before);
  int channel[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, channel) != 0) {
    throw std::runtime_error(std::string("re-fit process: socketpair: ") + std::strerror(errno));
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    ::close(channel[0]);
    ::close(channel[1]);
    throw std::runtime_error(std::string("re-fit process: fork: ") + std::strerror(e));
  }
  if (pid == 0) {
    // The child takes the default action on the signals that end a run (the parent's handlers
    // are the parent's) and never writes to the parent's streams; a parent that has gone is an
    // end of its channel, where the child stops.
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    // Only its own channel and the standard streams stay open: the ends of other re-fits'
    // channels, inherited from the parent, would keep those channels from seeing a process end.
    int own = channel[1];
    if (own != kChildChannelFd) {
      if (::dup2(own, kChildChannelFd) < 0) _exit(6);
      own = kChildChannelFd;
    }
    ::close_range(kChildChannelFd + 1, ~0U, 0);
    RunChild(own, parent, problem, splits, nominal, screened, role, before, max_seconds);
  }
  pid_ = pid;
  ::close(channel[1]);
  channel_ = channel[0];
}

RefitProcess::~RefitProcess() {
  CloseFd(&channel_);
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }
}

// Reaps the child and says how it ended.
std::string RefitProcess::ChildEnd() {
  CloseFd(&channel_);
  if (pid_ <= 0) return "";
  int status = 0;
  pid_t got;
  while ((got = ::waitpid(pid_, &status, 0)) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  if (got < 0) return "";
  if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
  if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
    return "exit code " + std::to_string(WEXITSTATUS(status));
  }
  return "";
}

void RefitProcess::Fail(const std::string& why) {
  if (pid_ > 0) ::kill(pid_, SIGKILL);  // it may be alive and waiting: end it before reaping
  const std::string end = ChildEnd();
  failed_ = true;
  has_shape_stage_ = false;
  out_.ok = false;
  out_.failure = "the re-fit's process " + why + (end.empty() ? "" : " (" + end + ")");
}

bool RefitProcess::ReceiveFromChild(std::string* message) {
  if (!WaitReadable(channel_, wait_seconds_)) {
    char why[120];
    std::snprintf(why, sizeof(why), "gave no result within %.0f s of wall time and was killed",
                  wait_seconds_);
    Fail(why);
    return false;
  }
  try {
    if (Receive(channel_, message)) return true;
  } catch (const std::bad_alloc&) {
  }
  Fail("ended without a result");
  return false;
}

void RefitProcess::RunStageA() {
  std::string message;
  if (!ReceiveFromChild(&message)) return;
  try {
    Reader r(message);
    out_.ok = r.Bool();
    out_.at_bound = r.Bool();
    out_.validation_nrmse_after = r.Double();
    out_.failure = r.String();
    has_shape_stage_ = r.Bool();
  } catch (const std::exception& e) {
    Fail(e.what());
  }
}

void RefitProcess::RunStageB() {
  if (failed_ || commanded_) return;
  Writer w;
  w.Put(std::string("B"));
  commanded_ = true;
  if (!Send(channel_, w.bytes())) Fail("did not take stage B");
}

void RefitProcess::HoldShapes(const std::string& reason) {
  if (failed_ || commanded_) return;
  Writer w;
  w.Put(std::string("H"));
  w.Put(reason);
  commanded_ = true;
  if (!Send(channel_, w.bytes())) Fail("did not take its last step");
}

RefitResult RefitProcess::Finish() {
  if (!failed_ && !commanded_) {
    Writer w;
    w.Put(std::string("F"));
    commanded_ = true;
    if (!Send(channel_, w.bytes())) Fail("did not take its last step");
  }
  std::string message;
  if (!failed_) ReceiveFromChild(&message);
  if (failed_) return std::move(out_);
  ChildEnd();
  RefitResult& out = out_;
  const Candidate& c = screened_.candidate;
  try {
    Reader r(message);
    out.ok = r.Bool();
    out.at_bound = r.Bool();
    out.failure = r.String();
    out.stages.clear();
    for (std::int64_t i = 0, n = r.Int(); i < n; ++i) out.stages.push_back(r.String());
    out.validation_nrmse_after = r.Double();
    out.relative_gain = r.Double();
    out.aic = r.Double();
    out.bic = r.Double();
    auto& numbers = out.candidate.augmentation.options.numbers;
    numbers.clear();
    for (std::int64_t i = 0, n = r.Int(); i < n; ++i) {
      const std::string key = r.String();
      const Eigen::VectorXd v = r.Vector();
      numbers[key] = std::vector<double>(v.data(), v.data() + v.size());
    }
    const double variant = r.Double();
    if (std::isfinite(variant)) {
      const auto apply_with_option = c.apply_with_option;
      out.candidate.apply = [apply_with_option, variant](models::Model* m) {
        apply_with_option(m, variant);
      };
    }
    if (!r.Bool()) return std::move(out);
    est::SolverResult solved = GetSolverResult(&r);
    // The augmented problem as the child's session held it at the fit's solve: its start values
    // and free set, set before the session formulates.
    est::Problem aug = AugmentedProblem(problem_, nominal_, out.candidate, false);
    for (std::int64_t i = 0, n = r.Int(); i < n; ++i) {
      const std::string name = r.String();
      const double initial = r.Double();
      const bool free = r.Bool();
      models::ModelParameter& p = aug.built.parameters[aug.built.ParameterIndex(name)];
      p.value = initial;
      p.free = free;
      aug.model.SetParameter(name, initial);
      if (free) {
        aug.model.Free(name);
      } else {
        aug.model.Fix(name);
      }
    }
    std::vector<std::pair<std::string, double>> seconds;
    for (std::int64_t i = 0, n = r.Int(); i < n; ++i) {
      std::string what = r.String();
      seconds.emplace_back(std::move(what), r.Double());
    }
    est::FitSession session(aug, AugmentedSplits(splits_, aug.built.NumStates()));
    out.fit = session.ResultOf(std::move(solved));
    out.fit.seconds = std::move(seconds);
    out.parameters.clear();
    for (const auto& q : c.parameters) out.parameters.push_back(out.fit.Parameter(q));
    const double validation = ValidationNrmse(out.fit.evaluations, role_);
    const double sent = out.validation_nrmse_after;
    if (std::isfinite(sent) && !(std::fabs(validation - sent) <=
                                 kRebuiltValidationRelTol * std::max(std::fabs(sent), 1e-300))) {
      char line[200];
      std::snprintf(line, sizeof(line),
                    "the fit built again from the re-fit's process validates at %.9g, the "
                    "process at %.9g",
                    validation, sent);
      out.ok = false;
      out.failure = line;
    }
  } catch (const std::exception& e) {
    out.ok = false;
    out.failure =
        std::string("the re-fit's result could not be taken from its process: ") + e.what();
  }
  return std::move(out);
}

}  // namespace graybox::diagnosis::internal
