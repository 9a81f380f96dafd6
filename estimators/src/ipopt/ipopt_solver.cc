// Ipopt backend: a TNLP over graybox::estimators::Nlp.
#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "graybox/estimators/solvers.h"
#include "graybox/models/block.h"  // DidYouMean

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

class NlpAdapter : public Ipopt::TNLP {
 public:
  NlpAdapter(const Nlp& nlp, SolverResult* result) : nlp_(nlp), result_(result) {}

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

  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool /*init_z*/,
                          Ipopt::Number* /*z_L*/, Ipopt::Number* /*z_U*/, Ipopt::Index /*m*/,
                          bool /*init_lambda*/, Ipopt::Number* /*lambda*/) override {
    if (init_x) {
      for (Ipopt::Index i = 0; i < n; ++i) x[i] = nlp_.w0()[i];
    }
    return true;
  }

  bool eval_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number& f) override {
    return Record(nlp_.Objective(x, &f));
  }
  bool eval_grad_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number* g) override {
    return Record(nlp_.Gradient(x, g));
  }
  bool eval_g(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Index, Ipopt::Number* g) override {
    return Record(nlp_.Constraints(x, g));
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
    return Record(nlp_.JacobianValues(x, values));
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
    return Record(nlp_.HessianValues(x, sigma, lambda, values));
  }

  bool intermediate_callback(Ipopt::AlgorithmMode, Ipopt::Index iter, Ipopt::Number obj,
                             Ipopt::Number inf_pr, Ipopt::Number inf_du, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    char line[160];
    std::snprintf(line, sizeof line, "%4d  objective %.10e  inf_pr %.3e  inf_du %.3e",
                  static_cast<int>(iter), obj, inf_pr, inf_du);
    result_->log.emplace_back(line);
    result_->iterations = static_cast<int>(iter);
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn status, Ipopt::Index n, const Ipopt::Number* x,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Index m,
                         const Ipopt::Number* g, const Ipopt::Number* lambda,
                         Ipopt::Number obj_value, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    result_->status = StatusName(status);
    result_->success = status == Ipopt::SUCCESS || status == Ipopt::STOP_AT_ACCEPTABLE_POINT;
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
  bool Record(const NlpEvalStatus& s) {
    if (!s.ok) last_failure_ = s.message;
    return s.ok;
  }
  const Nlp& nlp_;
  SolverResult* result_;
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

SolverResult SolveWithIpopt(const Nlp& nlp, const IpoptOptions& options) {
  options.Validate();
  nlp.CheckBounds();
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
      const std::string hint = models::DidYouMean(key, names);
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
  const auto start = std::chrono::steady_clock::now();
  if (app->Initialize() != Ipopt::Solve_Succeeded) {
    throw std::runtime_error("Ipopt failed to initialise");
  }
  Ipopt::SmartPtr<Ipopt::TNLP> adapter = new NlpAdapter(nlp, &result);
  app->OptimizeTNLP(adapter);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (result.w.size() == 0) {
    result.w = nlp.w0();
    result.success = false;
    if (result.status.empty()) result.status = "Not_Started";
  }
  return result;
}

std::string SolverResult::BriefReport() const {
  char line[256];
  std::snprintf(line, sizeof line, "%s: %s after %d iterations, cost %.6e, %.3f s", solver.c_str(),
                status.c_str(), iterations, cost, seconds);
  return line;
}

std::string SolverResult::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  os << "  variables " << w.size() << ", constraints " << lambda.size()
     << ", max constraint violation " << constraint_violation << "\n";
  if (!message.empty()) os << "  " << message << "\n";
  for (const auto& l : log) os << "  " << l << "\n";
  return os.str();
}

}  // namespace graybox::estimators
