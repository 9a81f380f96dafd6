// Baselines and regressions (compare.h).
#include "graybox/bench/compare.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace graybox::bench {

namespace {

std::string G(double v) {
  if (std::isnan(v)) return "NaN";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

// A status with a usable solution.
bool Usable(const std::string& status) { return status == "ok" || status == "not_converged"; }

class Comparer {
 public:
  Comparer(const Tolerances& t, Comparison* out) : t_(t), out_(out) {}

  void Case(const CaseRecord& base, const CaseRecord& run) {
    ++out_->cases_compared;
    if (base.status != run.status) {
      // A new failure, or a case that now converges: either is a change to accept.
      Finding f = Make(run.id, "status", "");
      f.baseline_text = base.status;
      f.value_text = run.status;
      out_->findings.push_back(f);
    }
    // Values of a case without a usable solution on either side say nothing.
    if (!Usable(base.status) || !Usable(run.status)) return;
    Value(run.id, "iterations", "", base.iterations, run.iterations, t_.iterations);
    Value(run.id, "cost", "", base.cost, run.cost, t_.cost);
    std::map<std::string, const ParameterRecord*> params;
    for (const ParameterRecord& p : run.parameters) params[p.name] = &p;
    for (const ParameterRecord& p : base.parameters) {
      if (!p.free) continue;
      const auto it = params.find(p.name);
      if (it == params.end()) {
        if (!t_.parameters.compared) continue;
        Finding f = Make(run.id, "parameter", p.name);
        f.baseline = p.value;
        f.value = std::nan("");
        f.tolerance = "the run has no parameter of this name";
        out_->findings.push_back(f);
        continue;
      }
      Value(run.id, "parameter", p.name, p.value, it->second->value, t_.parameters);
    }
    std::map<std::string, const ChannelRecord*> metrics;
    for (const ChannelRecord& m : run.metrics) metrics[m.split + "/" + m.channel] = &m;
    for (const ChannelRecord& m : base.metrics) {
      const std::string what = m.split + "/" + m.channel;
      const auto it = metrics.find(what);
      if (it == metrics.end()) {
        if (!t_.nrmse.compared && !t_.fit_percent.compared && !t_.r2.compared) continue;
        Finding f = Make(run.id, "metrics", what);
        f.baseline = m.nrmse;
        f.value = std::nan("");
        f.tolerance = "the run has no metrics of this split and channel";
        out_->findings.push_back(f);
        continue;
      }
      Value(run.id, "nrmse", what, m.nrmse, it->second->nrmse, t_.nrmse);
      Value(run.id, "fit_percent", what, m.fit_percent, it->second->fit_percent, t_.fit_percent);
      Value(run.id, "r2", what, m.r2, it->second->r2, t_.r2);
    }
    if (std::isfinite(base.seconds) && std::isfinite(run.seconds)) {
      ++out_->values_compared;
      if (run.seconds > t_.time_factor * base.seconds &&
          run.seconds - base.seconds > t_.time_min_seconds) {
        Finding f = Make(run.id, "seconds", "");
        f.baseline = base.seconds;
        f.value = run.seconds;
        f.tolerance = "slower than " + G(t_.time_factor) + " x and by more than " +
                      G(t_.time_min_seconds) + " s";
        out_->findings.push_back(f);
      }
    }
  }

  Finding Make(const std::string& id, const std::string& kind, const std::string& what) const {
    Finding f;
    f.case_id = id;
    f.kind = kind;
    f.what = what;
    return f;
  }

 private:
  void Value(const std::string& id, const std::string& kind, const std::string& what, double base,
             double value, const Tolerance& tol) {
    if (!tol.compared) return;
    ++out_->values_compared;
    if (tol.Admits(base, value)) return;
    Finding f = Make(id, kind, what);
    f.baseline = base;
    f.value = value;
    f.tolerance = tol.ToString();
    out_->findings.push_back(f);
  }

  const Tolerances& t_;
  Comparison* out_;
};

std::string FindingLine(const Finding& f) {
  std::string line = f.case_id + ": " + f.kind + (f.what.empty() ? "" : " " + f.what) + ": ";
  if (f.kind == "status") return line + f.baseline_text + " -> " + f.value_text;
  if (f.kind == "missing") return line + "in the baseline, not in this run";
  if (f.kind == "new") return line + "in this run, not in the baseline (not compared)";
  line += G(f.baseline) + " -> " + G(f.value);
  if (std::isfinite(f.baseline) && std::isfinite(f.value)) {
    const double d = f.value - f.baseline;
    line += " (" + std::string(d >= 0 ? "+" : "") + G(d);
    if (f.baseline != 0.0) line += ", " + G(100.0 * d / std::abs(f.baseline)) + " %";
    line += ")";
  }
  return line + "; tolerance " + f.tolerance;
}

}  // namespace

bool Comparison::HasRegression() const {
  for (const Finding& f : findings) {
    if (f.regression) return true;
  }
  return false;
}

std::string Comparison::BriefReport() const {
  int outside = 0, status = 0, missing = 0, added = 0, slower = 0;
  for (const Finding& f : findings) {
    if (f.kind == "status") {
      ++status;
    } else if (f.kind == "missing") {
      ++missing;
    } else if (f.kind == "new") {
      ++added;
    } else if (f.kind == "seconds") {
      ++slower;
    } else {
      ++outside;
    }
  }
  std::ostringstream o;
  o << "compare: " << cases_compared << " cases, " << values_compared << " values: ";
  if (findings.empty()) return o.str() + "all within their tolerances";
  o << outside << " outside their tolerances, " << status << " statuses changed, " << slower
    << " time regressions, " << missing << " cases missing, " << added << " new cases";
  o << (HasRegression() ? " (regression)" : " (no regression)");
  return o.str();
}

std::string Comparison::FullReport() const {
  std::ostringstream o;
  for (const Finding& f : findings) o << FindingLine(f) << "\n";
  o << BriefReport() << "\n";
  if (HasRegression() && !accept_command.empty()) {
    o << "to accept this run as the baseline: " << accept_command << "\n";
  }
  return o.str();
}

Comparison CompareRuns(const BenchRun& baseline, const BenchRun& run, const Tolerances& tolerances,
                       const std::string& accept_command) {
  if (baseline.suite.name != run.suite.name) {
    throw std::invalid_argument("bench compare: the baseline is of suite '" + baseline.suite.name +
                                "', the run of suite '" + run.suite.name + "'");
  }
  Comparison out;
  out.accept_command = accept_command;
  Comparer comparer(tolerances, &out);
  std::map<std::string, const CaseRecord*> in_run;
  for (const CaseRecord& r : run.records) in_run[r.id] = &r;
  std::map<std::string, bool> in_baseline;
  for (const CaseRecord& b : baseline.records) {
    in_baseline[b.id] = true;
    const auto it = in_run.find(b.id);
    if (it == in_run.end()) {
      out.findings.push_back(comparer.Make(b.id, "missing", ""));
      continue;
    }
    comparer.Case(b, *it->second);
  }
  for (const CaseRecord& r : run.records) {
    if (in_baseline.count(r.id)) continue;
    Finding f = comparer.Make(r.id, "new", "");
    f.regression = false;
    out.findings.push_back(f);
  }
  return out;
}

std::string BaselineJson(const BenchRun& run, const std::string& source) {
  if (run.Run("interrupted") == "true") {
    throw std::invalid_argument(source +
                                ": the run was interrupted (run.interrupted); a baseline needs "
                                "a complete run (graybox bench SUITE --resume DIR completes it)");
  }
  BenchRun b = run;
  b.SetRun("baseline_of", source);
  return BenchJson(b);
}

}  // namespace graybox::bench
