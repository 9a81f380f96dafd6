// FitResult's lookups and reports.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "graybox/estimators/fit/fit.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::estimators {

namespace {

std::string Format(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

}  // namespace

const FitParameter& FitResult::Parameter(const std::string& name) const {
  std::vector<std::string> names;
  for (const FitParameter& p : parameters) {
    if (p.name == name) return p;
    names.push_back(p.name);
  }
  throw std::invalid_argument("fit result: no parameter '" + name + "'" +
                              util::DidYouMeanHint(name, names));
}

const SplitEvaluation& FitResult::Evaluation(const std::string& name) const {
  std::vector<std::string> names;
  for (const SplitEvaluation& e : evaluations) {
    if (e.name == name) return e;
    names.push_back(e.name);
  }
  throw std::invalid_argument("fit result: no split '" + name + "'" +
                              util::DidYouMeanHint(name, names));
}

std::string FitResult::BriefReport() const {
  std::string s = method + "/" + solver + ": " + SolverStatusName(solver_result.status_code) +
                  " after " + std::to_string(solver_result.iterations) + " iterations, cost " +
                  Format("%.6e", solver_result.cost);
  for (const SplitEvaluation& e : evaluations) {
    if (e.role == SplitRole::kEstimation) continue;
    s += "; " + e.name + ": " + e.simulation.BriefReport();
  }
  return s;
}

std::string FitResult::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  os << "problem '" << problem << "': " << num_variables << " variables, " << num_constraints
     << " constraints, " << num_residuals << " residuals\n";
  for (const auto& [k, v] : formulation) os << "  " << k << ": " << v << "\n";
  os << solver_result.FullReport();
  os << "parameters (value, standard error, 95 % interval):\n";
  for (const FitParameter& p : parameters) {
    char line[320];
    if (p.free) {
      std::snprintf(line, sizeof line, "  %-32s %14.6g %-10s +- %-11.4g [%.6g, %.6g]%s\n",
                    p.name.c_str(), p.value, p.unit.c_str(), p.std_error, p.ci_low, p.ci_high,
                    p.at_bound ? "  AT BOUND" : "");
    } else {
      std::snprintf(line, sizeof line, "  %-32s %14.6g %-10s (fixed)\n", p.name.c_str(), p.value,
                    p.unit.c_str());
    }
    os << line;
  }
  if (has_uncertainty) {
    os << uncertainty.FullReport();
  } else if (!uncertainty_error.empty()) {
    os << "no parameter uncertainty: " << uncertainty_error << "\n";
  }
  for (const SplitEvaluation& e : evaluations) os << e.BriefReport() << "\n";
  os << "seconds:";
  for (const auto& [phase, t] : seconds) os << " " << phase << " " << Format("%.3f", t);
  os << "\n";
  return os.str();
}

}  // namespace graybox::estimators
