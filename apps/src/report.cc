// result.json / simulation.json (nlohmann_json, insertion-ordered; NaN and Inf become null), CSV
// traces, and the atomic writing of every output.
#include "report.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

namespace graybox::app {

using Json = nlohmann::ordered_json;

namespace {

Json ChannelJson(const estimators::ChannelMetrics& c) {
  Json j;
  j["unit"] = c.unit;
  j["rmse"] = c.rmse;
  j["nrmse"] = c.nrmse;
  j["fit_percent"] = c.fit_percent;
  j["r2"] = c.r2;
  j["vaf_percent"] = c.vaf_percent;
  j["mae"] = c.mae;
  j["nmae"] = c.nmae;
  j["nmse"] = c.nmse;
  // ||y - y_hat|| / ||y||, the "relative error" of the EMPS benchmark.
  j["relative_error_percent"] = 100.0 * std::sqrt(c.nmse);
  return j;
}

Json MetricsJson(const estimators::MetricReport& r) {
  Json j;
  j["samples"] = r.samples;
  j["skipped"] = r.skipped;
  Json channels = Json::object();
  for (const auto& c : r.channels) channels[c.name] = ChannelJson(c);
  j["channels"] = channels;
  j["overall"] = ChannelJson(r.overall);
  return j;
}

Json StateJson(const models::StateSpaceModel& m, const Eigen::VectorXd& x) {
  Json j = Json::object();
  for (int i = 0; i < m.NumStates() && i < x.size(); ++i) j[m.states[i].name] = x[i];
  return j;
}

std::string SafeName(const std::string& name) {
  std::string s;
  for (char c : name) {
    s +=
        (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.') ? c : '_';
  }
  return s;
}

}  // namespace

std::string ReportJson(const RunReport& report) {
  const estimators::Problem& problem = *report.problem;
  const models::StateSpaceModel& m = problem.built;
  Json j;
  j["graybox"] = {{"version", Version()}, {"git_revision", GitRevision()}};
  j["command"] = report.command;
  j["command_line"] = report.command_line;
  j["problem"] = {
      {"path", problem.path},
      {"absolute_path", std::filesystem::absolute(problem.path).lexically_normal().string()},
      {"name", problem.name},
      {"description", problem.description}};
  j["method"] = report.command == "fit" ? problem.estimation.method : "simulation";
  j["solver"] = report.has_fit ? report.fit.solver : "";
  j["seed"] = report.seed;
  Json status;
  status["result"] = report.status;
  status["exit_code"] = report.exit_code;
  status["message"] = report.message;
  if (report.has_fit) {
    status["solver_success"] = report.fit.solver_result.success;
    status["solver_status"] = report.fit.solver_result.status;
    status["solver_status_code"] =
        estimators::SolverStatusName(report.fit.solver_result.status_code);
    status["solution_usable"] = report.fit.solver_result.IsSolutionUsable();
    status["solver_message"] = report.fit.solver_result.message;
    status["iterations"] = report.fit.solver_result.iterations;
    status["cost"] = report.fit.solver_result.cost;
    status["constraint_violation"] = report.fit.solver_result.constraint_violation;
    status["solver_seconds"] = report.fit.solver_result.seconds;
    status["brief_report"] = report.fit.solver_result.BriefReport();
  }
  j["status"] = status;
  if (report.command == "fit") {
    Json f;
    for (const auto& [k, v] : report.fit.formulation) f[k] = v;
    f["variables"] = report.fit.num_variables;
    f["constraints"] = report.fit.num_constraints;
    f["residuals"] = report.fit.num_residuals;
    j["formulation"] = f;
    if (!report.parameter_file.empty()) j["from"] = report.parameter_file;  // fit --from
  } else {
    j["parameter_file"] = report.parameter_file;
  }
  Json seconds = Json::object();
  for (const auto& [k, v] : report.seconds) seconds[k] = v;
  j["seconds"] = seconds;
  // Parameters: every model parameter, by qualified name.
  Json params = Json::object();
  for (int i = 0; i < m.NumParameters(); ++i) {
    const models::ModelParameter& mp = m.parameters[i];
    Json p;
    p["value"] = report.parameters.size() > i ? report.parameters[i] : mp.value;
    p["unit"] = mp.info.unit;
    p["free"] = mp.free;
    if (report.initial_parameters.size() > i) p["initial"] = report.initial_parameters[i];
    p["lower"] = mp.lower;
    p["upper"] = mp.upper;
    if (report.fit.has_uncertainty) {
      for (const auto& e : report.fit.uncertainty.parameters) {
        if (e.name != mp.name) continue;
        p["std_error"] = e.std_error;
        const double relative = e.RelativeStdPercent();
        p["relative_std_percent"] = std::isfinite(relative) ? Json(relative) : Json(nullptr);
        p["ci95"] = {e.ci_low, e.ci_high};
      }
    }
    p["description"] = mp.info.description;
    params[mp.name] = p;
  }
  j["parameters"] = params;
  if (report.command == "fit") {
    Json u;
    if (report.fit.has_uncertainty) {
      const auto& r = report.fit.uncertainty;
      u["residual_variance"] = r.residual_variance;
      u["num_residuals"] = r.num_residuals;
      u["condition_number"] = r.condition_number;
      u["warnings"] = r.warnings;
      u["unidentifiable"] = r.unidentifiable;
      Json noise = Json::array();
      for (const estimators::ChannelNoise& c : r.channels) {
        noise.push_back({{"channel", c.name},
                         {"unit", c.unit},
                         {"sigma", c.sigma},
                         {"weight", c.weight},
                         {"num_residuals", c.num_residuals}});
      }
      u["noise"] = noise;
      Json names = Json::array();
      for (int i : r.free_indices) names.push_back(m.parameters[i].name);
      u["free_parameters"] = names;
      Json corr = Json::array();
      for (Eigen::Index a = 0; a < r.correlation.rows(); ++a) {
        Json row = Json::array();
        for (Eigen::Index b = 0; b < r.correlation.cols(); ++b) row.push_back(r.correlation(a, b));
        corr.push_back(row);
      }
      u["correlation"] = corr;
      u["brief_report"] = r.BriefReport();
    } else {
      u["error"] = report.fit.uncertainty_error;  // "the covariance could not be computed because"
    }
    j["uncertainty"] = u;
    Json states = Json::object();
    for (const auto& [split, x] : report.fit.initial_states) states[split] = StateJson(m, x);
    j["initial_states"] = states;
  }
  Json metrics = Json::object();
  for (const estimators::SplitEvaluation& e : report.evaluations) {
    Json s;
    s["data"] = e.data_name;
    s["role"] = estimators::SplitRoleName(e.role);
    s["samples"] = static_cast<int>(e.time.size());
    s["x0"] = StateJson(m, e.x0);
    Json sim = MetricsJson(e.simulation);
    sim["ok"] = e.simulation_ok;
    sim["failed_at"] = e.failed_at >= 0 ? Json(e.failed_at) : Json(nullptr);
    s["simulation"] = sim;
    if (e.has_equation) s["equation"] = MetricsJson(e.equation);
    if (e.has_n_step) {
      Json n;
      n["steps"] = e.n_step.steps;
      n["starts"] = static_cast<int>(e.n_step.starts.size());
      n["nrms"] = e.n_step.nrms;  // seed 000 eq. 7: the mean over steps 1..N
      n["nrms_at_step_n"] = e.n_step.NrmsAtStep(e.n_step.steps);  // step N alone
      Json channels = Json::object();
      for (std::size_t c = 0; c < e.n_step.channels.size(); ++c) {
        channels[m.states[static_cast<std::size_t>(e.n_step.channels[c])].name] =
            e.n_step.channel_nrms[static_cast<Eigen::Index>(c)];
      }
      n["channels"] = channels;  // the scored states ([metrics] n_step_channels) and their NRMS
      s["n_step"] = n;
    }
    metrics[e.name] = s;
  }
  j["metrics"] = metrics;
  if (!report.derivative_checks.empty()) {
    Json checks = Json::array();
    for (const auto& c : report.derivative_checks) {
      checks.push_back({{"what", c.what}, {"ok", c.ok}, {"max_error", c.max_error}});
    }
    j["derivative_checks"] = checks;
  }
  if (report.has_fit) {
    Json history = Json::array();
    for (const estimators::IterationSummary& it : report.fit.solver_result.history) {
      history.push_back({{"iteration", it.iteration},
                         {"cost", it.cost},
                         {"constraint_violation", it.constraint_violation},
                         {"optimality", it.optimality},
                         {"hessian_perturbation", it.hessian_perturbation},
                         {"restoration", it.restoration},
                         {"seconds", it.seconds}});
    }
    j["solver_history"] = history;
  }
  return j.dump(2) + "\n";
}

std::string TraceCsv(const estimators::SplitEvaluation& e, const models::StateSpaceModel& model) {
  std::ostringstream os;
  os << "time";
  for (const auto& o : model.outputs) os << "," << o.name << ".measured," << o.name << ".simulated";
  os << "\n";
  char buf[64];
  for (Eigen::Index k = 0; k < e.time.size(); ++k) {
    std::snprintf(buf, sizeof buf, "%.9g", e.time[k]);
    os << buf;
    for (int j = 0; j < model.NumOutputs(); ++j) {
      std::snprintf(buf, sizeof buf, ",%.12g", e.measured(k, j));
      os << buf;
      std::snprintf(buf, sizeof buf, ",%.12g", e.simulated(k, j));
      os << buf;
    }
    os << "\n";
  }
  return os.str();
}

void CheckSplitFileNames(const std::vector<estimators::SplitData>& splits) {
  std::map<std::string, std::string> by_file;
  for (const estimators::SplitData& s : splits) {
    for (const char c : s.name) {
      if (IsControlCharacter(c)) {
        throw std::invalid_argument("split '" + SafeName(s.name) + "' (data '" + s.data_name +
                                    "'): expected a printable name, got control characters");
      }
    }
    const std::string file = SafeName(s.name);
    const auto [it, fresh] = by_file.emplace(file, s.name);
    if (!fresh) {
      throw std::invalid_argument("splits '" + it->second + "' and '" + s.name +
                                  "' would write the same plot and trace files ('" + file +
                                  "_outputs.svg'); expected split names that differ in letters, "
                                  "digits, '-', '_' or '.'");
    }
  }
}

std::vector<std::string> WriteOutputs(const std::string& dir, const std::string& json_name,
                                      const RunReport& report) {
  namespace fs = std::filesystem;
  const fs::path root(dir);
  fs::create_directories(root / "plots");
  fs::create_directories(root / "traces");
  std::vector<std::string> written;
  const models::StateSpaceModel& m = report.problem->built;
  for (const estimators::SplitEvaluation& e : report.evaluations) {
    const std::string base = SafeName(e.name);
    const fs::path outputs = root / "plots" / (base + "_outputs.svg");
    WriteFileAtomically(outputs.string(), PlotOutputs(e, m));
    written.push_back(outputs.string());
    const fs::path residuals = root / "plots" / (base + "_residuals.svg");
    WriteFileAtomically(residuals.string(), PlotResiduals(e, m));
    written.push_back(residuals.string());
    if (e.has_equation) {
      const fs::path eq = root / "plots" / (base + "_equation.svg");
      WriteFileAtomically(eq.string(), PlotEquation(e));
      written.push_back(eq.string());
    }
    const fs::path trace = root / "traces" / (base + ".csv");
    WriteFileAtomically(trace.string(), TraceCsv(e, m));
    written.push_back(trace.string());
  }
  // The JSON last: its presence says the run completed.
  const fs::path json = root / json_name;
  WriteFileAtomically(json.string(), ReportJson(report));
  written.push_back(json.string());
  return written;
}

}  // namespace graybox::app
