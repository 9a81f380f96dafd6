// Ipopt backend: a TNLP over graybox::estimators::Nlp.
#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "graybox/estimators/solvers/solvers.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::estimators {

namespace {

constexpr double kIpoptInfinity = 1e20;

double ToIpoptBound(double b) {
  if (b == std::numeric_limits<double>::infinity()) return kIpoptInfinity;
  if (b == -std::numeric_limits<double>::infinity()) return -kIpoptInfinity;
  return b;
}

const char* StatusName(Ipopt::SolverReturn s) {
  switch (s) {
    case Ipopt::SUCCESS:
      return "Solve_Succeeded";
    case Ipopt::MAXITER_EXCEEDED:
      return "Maximum_Iterations_Exceeded";
    case Ipopt::CPUTIME_EXCEEDED:
      return "Maximum_CpuTime_Exceeded";
    case Ipopt::STOP_AT_TINY_STEP:
      return "Search_Direction_Becomes_Too_Small";
    case Ipopt::STOP_AT_ACCEPTABLE_POINT:
      return "Solved_To_Acceptable_Level";
    case Ipopt::LOCAL_INFEASIBILITY:
      return "Infeasible_Problem_Detected";
    case Ipopt::USER_REQUESTED_STOP:
      return "User_Requested_Stop";
    case Ipopt::FEASIBLE_POINT_FOUND:
      return "Feasible_Point_Found";
    case Ipopt::DIVERGING_ITERATES:
      return "Diverging_Iterates";
    case Ipopt::RESTORATION_FAILURE:
      return "Restoration_Failed";
    case Ipopt::ERROR_IN_STEP_COMPUTATION:
      return "Error_In_Step_Computation";
    case Ipopt::INVALID_NUMBER_DETECTED:
      return "Invalid_Number_Detected";
    case Ipopt::TOO_FEW_DEGREES_OF_FREEDOM:
      return "Not_Enough_Degrees_Of_Freedom";
    case Ipopt::INVALID_OPTION:
      return "Invalid_Option";
    case Ipopt::OUT_OF_MEMORY:
      return "Insufficient_Memory";
    case Ipopt::INTERNAL_ERROR:
      return "Internal_Error";
    case Ipopt::UNASSIGNED:
      return "Unassigned";
  }
  return "Unknown";
}

SolverStatus StatusCode(Ipopt::SolverReturn status) {
  switch (status) {
    case Ipopt::SUCCESS:
      return SolverStatus::kConverged;
    case Ipopt::STOP_AT_ACCEPTABLE_POINT:
      return SolverStatus::kAcceptable;
    case Ipopt::MAXITER_EXCEEDED:
    case Ipopt::CPUTIME_EXCEEDED:
      return SolverStatus::kMaxIterations;
    case Ipopt::LOCAL_INFEASIBILITY:
      return SolverStatus::kInfeasible;
    case Ipopt::INVALID_NUMBER_DETECTED:
      return SolverStatus::kEvaluationError;
    case Ipopt::USER_REQUESTED_STOP:
      return SolverStatus::kUserInterrupt;
    case Ipopt::STOP_AT_TINY_STEP:
    case Ipopt::RESTORATION_FAILURE:
    case Ipopt::ERROR_IN_STEP_COMPUTATION:
    case Ipopt::DIVERGING_ITERATES:
      return SolverStatus::kNumericalFailure;
    default:
      return SolverStatus::kFailed;
  }
}

// Ipopt 3.11.9 with the sequential MUMPS is not known to be thread-safe: Ipopt's own code runs
// under this lock, one thread at a time; the adapter releases it while the model evaluates.
// A process forked while Ipopt runs in another thread would inherit the lock taken and Ipopt's
// state half-way: fork waits until no Ipopt code runs, and both processes release the lock.
std::mutex& IpoptLock() {
  static std::mutex* lock = [] {
    auto* m = new std::mutex();
    pthread_atfork([] { IpoptLock().lock(); }, [] { IpoptLock().unlock(); },
                   [] { IpoptLock().unlock(); });
    return m;
  }();
  return *lock;
}

class NlpAdapter : public Ipopt::TNLP {
 public:
  // `serial` holds IpoptLock() whenever Ipopt's code runs; the evaluation callbacks and the
  // iteration callback release it while they run (graybox code only) and take it back before
  // returning to Ipopt.
  NlpAdapter(const Nlp& nlp, SolverResult* result, const IpoptOptions& options,
             const WarmStart* start, std::unique_lock<std::mutex>* serial)
      : nlp_(nlp), result_(result), options_(options), start_(start), serial_(serial) {}

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g,
                    Ipopt::Index& nnz_h_lag, IndexStyleEnum& index_style) override {
    n = nlp_.NumVariables();
    m = nlp_.NumConstraints();
    nnz_jac_g = static_cast<Ipopt::Index>(nlp_.JacobianRows().size());
    nnz_h_lag = static_cast<Ipopt::Index>(nlp_.HessianRows().size());
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index m,
                       Ipopt::Number* g_l, Ipopt::Number* g_u) override {
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = ToIpoptBound(nlp_.lbw()[i]);
      x_u[i] = ToIpoptBound(nlp_.ubw()[i]);
    }
    const Eigen::VectorXd lb = nlp_.lbg(), ub = nlp_.ubg();
    for (Ipopt::Index i = 0; i < m; ++i) {
      g_l[i] = ToIpoptBound(lb[i]);
      g_u[i] = ToIpoptBound(ub[i]);
    }
    return true;
  }

  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool init_z,
                          Ipopt::Number* z_L, Ipopt::Number* z_U, Ipopt::Index m, bool init_lambda,
                          Ipopt::Number* lambda) override {
    const bool primal = start_ != nullptr && start_->w.size() == n;
    if (init_x) {
      for (Ipopt::Index i = 0; i < n; ++i) x[i] = primal ? start_->w[i] : nlp_.w0()[i];
    }
    if (init_z) {
      if (start_ == nullptr || start_->z_lower.size() != n || start_->z_upper.size() != n) {
        return false;  // warm start requested without bound multipliers
      }
      for (Ipopt::Index i = 0; i < n; ++i) {
        z_L[i] = start_->z_lower[i];
        z_U[i] = start_->z_upper[i];
      }
    }
    if (init_lambda) {
      if (start_ == nullptr || start_->lambda.size() != m) return false;
      for (Ipopt::Index i = 0; i < m; ++i) lambda[i] = start_->lambda[i];
    }
    return true;
  }

  bool eval_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number& f) override {
    return Record(Unlocked([&] { return nlp_.Objective(x, &f); }));
  }
  bool eval_grad_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number* g) override {
    return Record(Unlocked([&] { return nlp_.Gradient(x, g); }));
  }
  bool eval_g(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Index, Ipopt::Number* g) override {
    return Record(Unlocked([&] { return nlp_.Constraints(x, g); }));
  }
  bool eval_jac_g(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Index, Ipopt::Index nele,
                  Ipopt::Index* rows, Ipopt::Index* cols, Ipopt::Number* values) override {
    if (values == nullptr) {
      for (Ipopt::Index k = 0; k < nele; ++k) {
        rows[k] = nlp_.JacobianRows()[k];
        cols[k] = nlp_.JacobianCols()[k];
      }
      return true;
    }
    return Record(Unlocked([&] { return nlp_.JacobianValues(x, values); }));
  }
  bool eval_h(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number sigma, Ipopt::Index,
              const Ipopt::Number* lambda, bool, Ipopt::Index nele, Ipopt::Index* rows,
              Ipopt::Index* cols, Ipopt::Number* values) override {
    if (values == nullptr) {
      for (Ipopt::Index k = 0; k < nele; ++k) {
        rows[k] = nlp_.HessianRows()[k];
        cols[k] = nlp_.HessianCols()[k];
      }
      return true;
    }
    return Record(Unlocked([&] { return nlp_.HessianValues(x, sigma, lambda, values); }));
  }

  bool intermediate_callback(Ipopt::AlgorithmMode mode, Ipopt::Index iter, Ipopt::Number obj,
                             Ipopt::Number inf_pr, Ipopt::Number inf_du, Ipopt::Number /*mu*/,
                             Ipopt::Number /*d_norm*/, Ipopt::Number regularization_size,
                             Ipopt::Number /*alpha_du*/, Ipopt::Number /*alpha_pr*/, Ipopt::Index,
                             const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    IterationSummary s;
    s.iteration = static_cast<int>(iter);
    s.cost = obj;
    s.constraint_violation = inf_pr;
    s.optimality = inf_du;
    s.hessian_perturbation = regularization_size;
    s.restoration = mode == Ipopt::RestorationPhaseMode;
    s.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time_).count();
    result_->history.push_back(s);
    result_->iterations = static_cast<int>(iter);
    return !options_.callback || Unlocked([&] { return options_.callback(s); });
  }

  void finalize_solution(Ipopt::SolverReturn status, Ipopt::Index n, const Ipopt::Number* x,
                         const Ipopt::Number* z_L, const Ipopt::Number* z_U, Ipopt::Index m,
                         const Ipopt::Number* g, const Ipopt::Number* lambda,
                         Ipopt::Number obj_value, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    result_->status = StatusName(status);
    result_->status_code = StatusCode(status);
    result_->success = status == Ipopt::SUCCESS || status == Ipopt::STOP_AT_ACCEPTABLE_POINT;
    result_->z_lower = Eigen::Map<const Eigen::VectorXd>(z_L, n);
    result_->z_upper = Eigen::Map<const Eigen::VectorXd>(z_U, n);
    result_->w = Eigen::Map<const Eigen::VectorXd>(x, n);
    result_->lambda = Eigen::Map<const Eigen::VectorXd>(lambda, m);
    result_->cost = obj_value;
    const Eigen::VectorXd lb = nlp_.lbg(), ub = nlp_.ubg();
    double violation = 0.0;
    for (Ipopt::Index i = 0; i < m; ++i) {
      violation = std::max({violation, lb[i] - g[i], g[i] - ub[i]});
    }
    result_->constraint_violation = violation;
    if (!result_->success && result_->message.empty()) {
      result_->message = std::string("Ipopt stopped with ") + StatusName(status);
      if (!last_failure_.empty()) result_->message += "; last failed evaluation: " + last_failure_;
    }
  }

 private:
  // Runs fn() with the Ipopt lock released and takes it back (also when fn throws).
  template <typename Fn>
  std::invoke_result_t<Fn&> Unlocked(Fn&& fn) {
    struct Relock {
      std::unique_lock<std::mutex>* lock;
      ~Relock() { lock->lock(); }
    };
    serial_->unlock();
    const Relock relock{serial_};
    return fn();
  }
  bool Record(const NlpEvalStatus& s) {
    if (!s.ok) last_failure_ = s.message;
    return s.ok;
  }
  const Nlp& nlp_;
  SolverResult* result_;
  const IpoptOptions& options_;
  const WarmStart* start_;
  std::unique_lock<std::mutex>* serial_;
  std::chrono::steady_clock::time_point start_time_ = std::chrono::steady_clock::now();
  std::string last_failure_;
};

}  // namespace

void IpoptOptions::Validate() const {
  if (max_iterations < 0) {
    throw std::invalid_argument("IpoptOptions.max_iterations: expected >= 0, got " +
                                std::to_string(max_iterations));
  }
  if (!(tolerance > 0.0)) {
    throw std::invalid_argument("IpoptOptions.tolerance: expected > 0, got " +
                                std::to_string(tolerance));
  }
  if (print_level < 0 || print_level > 12) {
    throw std::invalid_argument("IpoptOptions.print_level: expected 0..12, got " +
                                std::to_string(print_level));
  }
}

SolverResult SolveWithIpopt(const Nlp& nlp, const IpoptOptions& options, const WarmStart* start) {
  options.Validate();
  nlp.CheckBounds();
  if (start != nullptr && start->w.size() != nlp.NumVariables()) {
    throw std::invalid_argument("SolveWithIpopt: warm start with " +
                                std::to_string(start->w.size()) + " variables, expected " +
                                std::to_string(nlp.NumVariables()));
  }
  std::unique_lock<std::mutex> serial(IpoptLock());
  SolverResult result;
  result.solver = "ipopt";
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetIntegerValue("print_level", options.print_level);
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetIntegerValue("max_iter", options.max_iterations);
  app->Options()->SetNumericValue("tol", options.tolerance);
  app->Options()->SetStringValue("hessian_approximation",
                                 options.exact_hessian ? "exact" : "limited-memory");
  const auto& registered = app->RegOptions()->RegisteredOptionsList();
  for (const auto& [key, value] : options.pass_through) {
    auto it = registered.find(key);
    if (it == registered.end()) {
      std::vector<std::string> names;
      for (const auto& [name, opt] : registered) names.push_back(name);
      const std::string hint = util::DidYouMean(key, names);
      throw std::invalid_argument("Ipopt option '" + key + "' is unknown" +
                                  (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
    }
    bool ok = false;
    switch (it->second->Type()) {
      case Ipopt::OT_Number: {
        char* end = nullptr;
        const double v = std::strtod(value.c_str(), &end);
        ok = end && *end == '\0' && app->Options()->SetNumericValue(key, v);
        break;
      }
      case Ipopt::OT_Integer: {
        char* end = nullptr;
        const long v = std::strtol(value.c_str(), &end, 10);
        ok = end && *end == '\0' && app->Options()->SetIntegerValue(key, static_cast<int>(v));
        break;
      }
      default:
        ok = app->Options()->SetStringValue(key, value);
    }
    if (!ok) {
      throw std::invalid_argument("Ipopt option '" + key + "': value '" + value +
                                  "' is not valid for this option");
    }
  }
  const bool with_multipliers = start != nullptr && start->lambda.size() == nlp.NumConstraints() &&
                                start->z_lower.size() == nlp.NumVariables() &&
                                start->z_upper.size() == nlp.NumVariables();
  if (with_multipliers && options.pass_through.count("warm_start_init_point") == 0) {
    // Start from the earlier primal-dual point with a small barrier parameter, so a re-solve
    // after a small change takes a few iterations instead of a cold start's.
    app->Options()->SetStringValue("warm_start_init_point", "yes");
    if (options.pass_through.count("mu_init") == 0)
      app->Options()->SetNumericValue("mu_init", 1e-6);
    if (options.pass_through.count("warm_start_bound_push") == 0) {
      app->Options()->SetNumericValue("warm_start_bound_push", 1e-9);
    }
    if (options.pass_through.count("warm_start_mult_bound_push") == 0) {
      app->Options()->SetNumericValue("warm_start_mult_bound_push", 1e-9);
    }
  }
  const auto start_time = std::chrono::steady_clock::now();
  if (app->Initialize() != Ipopt::Solve_Succeeded) {
    throw std::runtime_error("Ipopt failed to initialise");
  }
  Ipopt::SmartPtr<Ipopt::TNLP> adapter = new NlpAdapter(nlp, &result, options, start, &serial);
  app->OptimizeTNLP(adapter);
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  if (result.w.size() == 0) {
    result.w = nlp.w0();
    result.success = false;
    if (result.status.empty()) result.status = "Not_Started";
  }
  return result;
}

const char* SolverStatusName(SolverStatus status) {
  switch (status) {
    case SolverStatus::kConverged:
      return "converged";
    case SolverStatus::kAcceptable:
      return "acceptable";
    case SolverStatus::kMaxIterations:
      return "max_iterations";
    case SolverStatus::kInfeasible:
      return "infeasible";
    case SolverStatus::kEvaluationError:
      return "evaluation_error";
    case SolverStatus::kUserInterrupt:
      return "user_interrupt";
    case SolverStatus::kNumericalFailure:
      return "numerical_failure";
    case SolverStatus::kFailed:
      return "failed";
  }
  return "failed";
}

bool SolverResult::IsSolutionUsable() const {
  if (success) return true;
  const bool stopped =
      status_code == SolverStatus::kMaxIterations || status_code == SolverStatus::kUserInterrupt;
  return stopped && w.size() > 0 && w.allFinite() && std::isfinite(cost);
}

WarmStart SolverResult::AsWarmStart() const {
  WarmStart s;
  s.w = w;
  s.lambda = lambda;
  s.z_lower = z_lower;
  s.z_upper = z_upper;
  return s;
}

std::string SolverResult::BriefReport() const {
  char line[320];
  std::snprintf(line, sizeof line, "%s: %s (%s) after %d iterations, cost %.6e, %.3f s",
                solver.c_str(), SolverStatusName(status_code), status.c_str(), iterations, cost,
                seconds);
  return line;
}

std::string SolverResult::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  os << "  variables " << w.size() << ", constraints " << lambda.size()
     << ", max constraint violation " << constraint_violation << "\n";
  if (!message.empty()) os << "  " << message << "\n";
  os << "  iter  cost              constraint viol.  optimality    Hessian pert.  time [s]\n";
  for (const IterationSummary& s : history) {
    char line[200];
    std::snprintf(line, sizeof line, "  %4d%s %.10e  %.3e         %.3e     %.3e      %.3f",
                  s.iteration, s.restoration ? "r" : " ", s.cost, s.constraint_violation,
                  s.optimality, s.hessian_perturbation, s.seconds);
    os << line << "\n";
  }
  if (std::any_of(history.begin(), history.end(),
                  [](const IterationSummary& s) { return s.restoration; })) {
    os << "  (r: an iteration of Ipopt's restoration phase)\n";
  }
  return os.str();
}

}  // namespace graybox::estimators
