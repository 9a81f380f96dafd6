// Records as JSON and the bench outputs (runner.h): bench.json, bench.csv, bench.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "graybox/bench/runner.h"

namespace graybox::bench {

namespace {

using nlohmann::json;

constexpr int kBenchJsonSchema = 1;

// NaN and infinities as null (JSON has no such numbers), and back.
json Number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
double NumberOf(const json& j, const char* key) {
  const json& v = j.at(key);
  if (v.is_null()) return std::numeric_limits<double>::quiet_NaN();
  if (!v.is_number()) throw std::invalid_argument(std::string("'") + key + "': expected a number");
  return v.get<double>();
}

json RecordObject(const CaseRecord& r) {
  json j;
  j["suite"] = r.suite;
  j["id"] = r.id;
  j["problem"] = r.problem;
  j["problem_name"] = r.problem_name;
  j["variation"] = r.variation;
  j["seed"] = r.seed;
  j["status"] = r.status;
  j["exit_code"] = r.exit_code;
  j["error"] = r.error;
  j["seconds"] = Number(r.seconds);
  j["case_seconds"] = Number(r.case_seconds);
  j["method"] = r.method;
  j["solver"] = r.solver;
  j["solver_status"] = r.solver_status;
  j["iterations"] = r.iterations;
  j["cost"] = Number(r.cost);
  j["parameters"] = json::array();
  for (const ParameterRecord& p : r.parameters) {
    j["parameters"].push_back({{"name", p.name},
                               {"value", Number(p.value)},
                               {"std_error", Number(p.std_error)},
                               {"free", p.free}});
  }
  j["metrics"] = json::array();
  for (const ChannelRecord& m : r.metrics) {
    j["metrics"].push_back({{"split", m.split},
                            {"role", m.role},
                            {"channel", m.channel},
                            {"nrmse", Number(m.nrmse)},
                            {"fit_percent", Number(m.fit_percent)},
                            {"r2", Number(m.r2)}});
  }
  return j;
}

std::string Csv(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (const char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string G(double v) {
  if (!std::isfinite(v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

std::string Short(double v) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4g", v);
  return buf;
}

// The overall NRMSE of the first split of the highest role present (test, else validation, else
// estimation), and that split's role, for the per-case table.
std::pair<std::string, double> HeldOutNrmse(const CaseRecord& r) {
  for (const char* role : {"test", "validation", "estimation"}) {
    for (const ChannelRecord& m : r.metrics) {
      if (m.role == role && m.channel == "overall") return {m.split, m.nrmse};
    }
  }
  return {"", std::numeric_limits<double>::quiet_NaN()};
}

}  // namespace

std::string CaseRecordJson(const CaseRecord& r) { return RecordObject(r).dump(2) + "\n"; }

CaseRecord ParseCaseRecordJson(const std::string& text) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("case record: not JSON: ") + e.what());
  }
  CaseRecord r;
  try {
    r.suite = j.at("suite").get<std::string>();
    r.id = j.at("id").get<std::string>();
    r.problem = j.at("problem").get<std::string>();
    r.problem_name = j.at("problem_name").get<std::string>();
    r.variation = j.at("variation").get<std::vector<std::string>>();
    r.seed = j.at("seed").get<unsigned>();
    r.status = j.at("status").get<std::string>();
    r.exit_code = j.at("exit_code").get<int>();
    r.error = j.at("error").get<std::string>();
    r.seconds = NumberOf(j, "seconds");
    r.case_seconds = NumberOf(j, "case_seconds");
    r.method = j.at("method").get<std::string>();
    r.solver = j.at("solver").get<std::string>();
    r.solver_status = j.at("solver_status").get<std::string>();
    r.iterations = j.at("iterations").get<int>();
    r.cost = NumberOf(j, "cost");
    for (const json& p : j.at("parameters")) {
      r.parameters.push_back({p.at("name").get<std::string>(), NumberOf(p, "value"),
                              NumberOf(p, "std_error"), p.at("free").get<bool>()});
    }
    for (const json& m : j.at("metrics")) {
      r.metrics.push_back({m.at("split").get<std::string>(), m.at("role").get<std::string>(),
                           m.at("channel").get<std::string>(), NumberOf(m, "nrmse"),
                           NumberOf(m, "fit_percent"), NumberOf(m, "r2")});
    }
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("case record: ") + e.what());
  }
  return r;
}

std::string BenchJson(const Suite& suite, const std::vector<CaseRecord>& records,
                      const std::vector<std::pair<std::string, std::string>>& run) {
  json j;
  j["schema"] = kBenchJsonSchema;
  j["suite"] = {{"name", suite.name},
                {"description", suite.description},
                {"path", suite.path},
                {"time_limit", suite.time_limit},
                {"relative_perturbation", suite.relative_perturbation}};
  j["run"] = json::object();
  for (const auto& [k, v] : run) j["run"][k] = v;
  const Machine m = ThisMachine();
  j["machine"] = {{"cpu", m.cpu}, {"cores", m.cores}, {"os", m.os}};
  j["cases"] = json::array();
  for (const CaseRecord& r : records) j["cases"].push_back(RecordObject(r));
  return j.dump(2) + "\n";
}

std::string BenchCsv(const std::vector<CaseRecord>& records) {
  std::ostringstream o;
  o << "suite,case,problem,variation,seed,status,exit_code,seconds,case_seconds,iterations,cost,"
       "split,role,channel,nrmse,fit_percent,r2\n";
  for (const CaseRecord& r : records) {
    std::string variation;
    for (const std::string& v : r.variation) variation += (variation.empty() ? "" : "; ") + v;
    const std::string head = Csv(r.suite) + "," + Csv(r.id) + "," + Csv(r.problem) + "," +
                             Csv(variation) + "," + std::to_string(r.seed) + "," + r.status + "," +
                             std::to_string(r.exit_code) + "," + G(r.seconds) + "," +
                             G(r.case_seconds) + "," + std::to_string(r.iterations) + "," +
                             G(r.cost) + ",";
    if (r.metrics.empty()) o << head << ",,,,,\n";
    for (const ChannelRecord& m : r.metrics) {
      o << head << Csv(m.split) << "," << m.role << "," << Csv(m.channel) << "," << G(m.nrmse)
        << "," << G(m.fit_percent) << "," << G(m.r2) << "\n";
    }
  }
  return o.str();
}

std::string BenchMarkdown(const Suite& suite, const std::vector<CaseRecord>& records) {
  std::ostringstream o;
  o << "# Bench: " << suite.name << "\n\n";
  if (!suite.description.empty()) o << suite.description << "\n\n";
  o << "| case | status | seconds | iterations | cost | held-out split | overall NRMSE |\n"
       "|---|---|---:|---:|---:|---|---:|\n";
  std::map<std::string, int> by_status;
  double total = 0.0;
  for (const CaseRecord& r : records) {
    const auto [split, nrmse] = HeldOutNrmse(r);
    o << "| " << r.id << " | " << r.status << " | " << Short(r.seconds) << " | " << r.iterations
      << " | " << Short(r.cost) << " | " << (split.empty() ? "-" : split) << " | " << Short(nrmse)
      << " |\n";
    ++by_status[r.status];
    if (std::isfinite(r.seconds)) total += r.seconds;
  }
  o << "\n## Summary\n\n";
  const int n = static_cast<int>(records.size());
  const int ok = by_status.count("ok") ? by_status.at("ok") : 0;
  char line[160];
  std::snprintf(line, sizeof(line), "%d cases, %d ok (%.0f %%)", n, ok,
                n > 0 ? 100.0 * ok / n : 0.0);
  o << line;
  for (const auto& [status, count] : by_status) {
    if (status != "ok") o << ", " << status << " " << count;
  }
  o << "\n\nTotal case time " << Short(total) << " s (the sum over cases, not wall time).\n";
  std::vector<const CaseRecord*> slowest;
  for (const CaseRecord& r : records) slowest.push_back(&r);
  std::sort(slowest.begin(), slowest.end(),
            [](const CaseRecord* a, const CaseRecord* b) { return a->seconds > b->seconds; });
  if (!slowest.empty()) {
    o << "\nSlowest cases:\n\n";
    for (std::size_t i = 0; i < std::min<std::size_t>(3, slowest.size()); ++i) {
      o << "- " << slowest[i]->id << ": " << Short(slowest[i]->seconds) << " s ("
        << slowest[i]->status << ")\n";
    }
  }
  return o.str();
}

}  // namespace graybox::bench
