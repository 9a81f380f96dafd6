// A bench run's results (results.h): records as JSON, bench.json / .csv / .md, read back,
// shards merged.
#include "graybox/bench/results.h"
#include "graybox/util/read_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <tuple>

#include <nlohmann/json.hpp>

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
  j["index"] = r.index;
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
  j["options"] = json::object();
  for (const auto& [k, v] : r.options) j["options"][k] = v;
  j["revision"] = r.revision;
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

namespace {

// A record from its JSON object; throws json::exception on a missing or mistyped field.
CaseRecord RecordFrom(const json& j) {
  CaseRecord r;
  r.suite = j.at("suite").get<std::string>();
  r.id = j.at("id").get<std::string>();
  r.index = j.at("index").get<std::size_t>();
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
  if (j.contains("options")) {  // absent in records written before it was added
    for (const auto& [k, v] : j.at("options").items()) {
      r.options.emplace_back(k, v.get<std::string>());
    }
  }
  r.revision = j.value("revision", std::string());
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
  return r;
}

json ToleranceObject(const Tolerance& t) {
  return {{"absolute", t.absolute}, {"relative", t.relative}, {"compare", t.compared}};
}

Tolerance ToleranceFrom(const json& j) {
  Tolerance t;
  t.absolute = j.at("absolute").get<double>();
  t.relative = j.at("relative").get<double>();
  t.compared = j.at("compare").get<bool>();
  return t;
}

}  // namespace

CaseRecord ParseCaseRecordJson(const std::string& text) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("case record: not JSON: ") + e.what());
  }
  try {
    return RecordFrom(j);
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("case record: ") + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("case record: ") + e.what());
  }
}

std::string BenchRun::Run(const std::string& key) const {
  for (const auto& [k, v] : run) {
    if (k == key) return v;
  }
  return "";
}

void BenchRun::SetRun(const std::string& key, const std::string& value) {
  for (auto& [k, v] : run) {
    if (k == key) {
      v = value;
      return;
    }
  }
  run.emplace_back(key, value);
}

std::string BenchJson(const BenchRun& b) {
  const Suite& suite = b.suite;
  const Tolerances& t = suite.tolerances;
  json j;
  j["schema"] = kBenchJsonSchema;
  j["suite"] = {{"name", suite.name},
                {"description", suite.description},
                {"path", suite.path},
                {"time_limit", suite.time_limit},
                {"relative_perturbation", suite.relative_perturbation},
                {"seeds", suite.seeds},
                {"tolerances",
                 {{"nrmse", ToleranceObject(t.nrmse)},
                  {"fit_percent", ToleranceObject(t.fit_percent)},
                  {"r2", ToleranceObject(t.r2)},
                  {"cost", ToleranceObject(t.cost)},
                  {"iterations", ToleranceObject(t.iterations)},
                  {"parameters", ToleranceObject(t.parameters)},
                  {"time", {{"factor", t.time_factor}, {"min_seconds", t.time_min_seconds}}}}}};
  j["run"] = json::object();
  for (const auto& [k, v] : b.run) j["run"][k] = v;
  j["machine"] = {{"cpu", b.machine.cpu}, {"cores", b.machine.cores}, {"os", b.machine.os}};
  j["cases"] = json::array();
  for (const CaseRecord& r : b.records) j["cases"].push_back(RecordObject(r));
  return j.dump(2) + "\n";
}

BenchRun ParseBenchJson(const std::string& text, const std::string& path) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw std::invalid_argument(path + ": not JSON: " + e.what());
  }
  BenchRun b;
  std::string at = "";
  try {
    const int schema = j.at("schema").get<int>();
    if (schema != kBenchJsonSchema) {
      throw std::invalid_argument(path + ": 'schema': expected " +
                                  std::to_string(kBenchJsonSchema) + ", got " +
                                  std::to_string(schema));
    }
    at = "suite";
    const json& s = j.at("suite");
    b.suite.name = s.at("name").get<std::string>();
    b.suite.description = s.at("description").get<std::string>();
    b.suite.path = s.at("path").get<std::string>();
    b.suite.time_limit = s.at("time_limit").get<double>();
    b.suite.relative_perturbation = s.at("relative_perturbation").get<double>();
    b.suite.seeds = s.at("seeds").get<std::vector<unsigned>>();
    const json& t = s.at("tolerances");
    Tolerances& tol = b.suite.tolerances;
    tol.nrmse = ToleranceFrom(t.at("nrmse"));
    tol.fit_percent = ToleranceFrom(t.at("fit_percent"));
    tol.r2 = ToleranceFrom(t.at("r2"));
    tol.cost = ToleranceFrom(t.at("cost"));
    tol.iterations = ToleranceFrom(t.at("iterations"));
    tol.parameters = ToleranceFrom(t.at("parameters"));
    tol.time_factor = t.at("time").at("factor").get<double>();
    tol.time_min_seconds = t.at("time").at("min_seconds").get<double>();
    at = "run";
    for (const auto& [k, v] : j.at("run").items()) b.run.emplace_back(k, v.get<std::string>());
    at = "machine";
    b.machine.cpu = j.at("machine").at("cpu").get<std::string>();
    b.machine.cores = j.at("machine").at("cores").get<int>();
    b.machine.os = j.at("machine").at("os").get<std::string>();
    const json& cases = j.at("cases");
    for (std::size_t i = 0; i < cases.size(); ++i) {
      at = "cases[" + std::to_string(i) + "]";
      try {
        b.records.push_back(RecordFrom(cases[i]));
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(path + ": '" + at + "': " + e.what());
      }
    }
  } catch (const json::exception& e) {
    throw std::invalid_argument(path + ": " + (at.empty() ? "" : "'" + at + "': ") + e.what());
  }
  return b;
}

BenchRun LoadBenchRun(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const std::string file =
      fs::is_directory(path, ec) ? (fs::path(path) / "bench.json").string() : path;
  const std::optional<std::string> text = util::ReadWholeFile(file);
  if (!text) {
    throw std::invalid_argument(file + ": cannot read the bench results: " +
                                (fs::exists(file, ec) ? "not a readable file"
                                                      : "no such file (a bench output folder "
                                                        "holds bench.json)"));
  }
  return ParseBenchJson(*text, file);
}

void SortByIndex(std::vector<CaseRecord>* records) {
  std::stable_sort(records->begin(), records->end(),
                   [](const CaseRecord& a, const CaseRecord& b) { return a.index < b.index; });
}

CostFunction RecordedCosts(const BenchRun& run) {
  std::map<std::string, double> seconds;
  std::vector<double> all;
  for (const CaseRecord& r : run.records) {
    if (!std::isfinite(r.seconds)) continue;
    seconds[r.id] = r.seconds;
    all.push_back(r.seconds);
  }
  double median = 1.0;
  if (!all.empty()) {
    std::sort(all.begin(), all.end());
    median = all.size() % 2 ? all[all.size() / 2]
                            : 0.5 * (all[all.size() / 2 - 1] + all[all.size() / 2]);
  }
  return [seconds = std::move(seconds), median](const Case& c) {
    const auto it = seconds.find(c.id);
    return it == seconds.end() ? median : it->second;
  };
}

BenchRun MergeShards(const std::vector<BenchRun>& shards, const std::vector<std::string>& names) {
  if (shards.empty()) throw std::invalid_argument("bench merge: expected shard outputs, got none");
  if (names.size() != shards.size()) {
    throw std::invalid_argument("MergeShards: expected one name per shard");
  }
  const BenchRun& first = shards.front();
  int count = 0;
  std::map<int, std::string> given;  // shard k -> the output it came from
  for (std::size_t i = 0; i < shards.size(); ++i) {
    const BenchRun& s = shards[i];
    if (s.suite.name != first.suite.name || s.suite.path != first.suite.path) {
      throw std::invalid_argument("bench merge: " + names[i] + " is a run of suite '" +
                                  s.suite.name + "' (" + s.suite.path + "), " + names[0] + " of '" +
                                  first.suite.name + "' (" + first.suite.path + ")");
    }
    // The same partition of the same cases: filter, seed and the costs that balanced it.
    for (const char* key : {"filter", "seed", "costs"}) {
      if (s.Run(key) != first.Run(key)) {
        throw std::invalid_argument("bench merge: " + names[i] + " ran --" + key + " '" +
                                    s.Run(key) + "', " + names[0] + " '" + first.Run(key) + "'");
      }
    }
    const std::string shard = s.Run("shard");
    int k = 1, n = 1;
    if (!shard.empty()) {
      try {
        std::tie(k, n) = ParseShard(shard);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument("bench merge: " + names[i] + ": run.shard: " + e.what());
      }
    }
    if (count == 0) count = n;
    if (n != count) {
      throw std::invalid_argument("bench merge: " + names[i] + " is shard " + shard + ", " +
                                  names[0] + " one of " + std::to_string(count));
    }
    if (given.count(k)) {
      throw std::invalid_argument("bench merge: shard " + std::to_string(k) + "/" +
                                  std::to_string(n) + " given twice: " + given[k] + " and " +
                                  names[i]);
    }
    given[k] = names[i];
  }
  std::string missing;
  for (int k = 1; k <= count; ++k) {
    if (!given.count(k)) {
      missing += (missing.empty() ? "" : ", ") + std::to_string(k) + "/" + std::to_string(count);
    }
  }
  if (!missing.empty()) {
    throw std::invalid_argument("bench merge: shard " + missing +
                                " missing (given: " + std::to_string(given.size()) + " of " +
                                std::to_string(count) + ")");
  }
  BenchRun merged;
  merged.suite = first.suite;
  merged.machine = first.machine;
  std::map<std::string, std::string> where;  // case id -> shard output
  std::set<std::string> revisions;
  std::string revision, from;
  double wall = 0.0;
  long planned = 0;
  bool interrupted = false;
  for (std::size_t i = 0; i < shards.size(); ++i) {
    const BenchRun& s = shards[i];
    for (const CaseRecord& r : s.records) {
      if (where.count(r.id)) {
        throw std::invalid_argument("bench merge: case '" + r.id + "' is in " + where[r.id] +
                                    " and in " + names[i]);
      }
      where[r.id] = names[i];
      merged.records.push_back(r);
    }
    if (revisions.insert(s.Run("revision")).second) {
      revision += (revision.empty() ? "" : " / ") + s.Run("revision");
    }
    from += (from.empty() ? "" : ", ") + names[i];
    wall = std::max(wall, std::atof(s.Run("wall_seconds").c_str()));
    planned += std::atol(s.Run("cases_planned").c_str());
    interrupted = interrupted || s.Run("interrupted") == "true";
  }
  SortByIndex(&merged.records);
  if (!interrupted && static_cast<long>(merged.records.size()) != planned) {
    throw std::invalid_argument("bench merge: the shards planned " + std::to_string(planned) +
                                " cases and recorded " + std::to_string(merged.records.size()) +
                                " without an interrupt: not shards of one run");
  }
  merged.run = {{"revision", revision},
                {"version", first.Run("version")},
                {"shard", ""},
                {"filter", first.Run("filter")},
                {"seed", first.Run("seed")},
                {"costs", first.Run("costs")},
                {"merged_from", from},
                {"cases_planned", std::to_string(planned)},
                {"wall_seconds", G(wall)},
                {"interrupted", interrupted ? "true" : "false"}};
  return merged;
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

Machine ThisMachine() {
  Machine m;
  m.cores = static_cast<int>(std::thread::hardware_concurrency());
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string line; std::getline(cpu, line);) {
    if (line.rfind("model name", 0) == 0) {
      const std::size_t colon = line.find(':');
      if (colon != std::string::npos) m.cpu = line.substr(line.find_first_not_of(' ', colon + 1));
      break;
    }
  }
  std::ifstream os("/etc/os-release");
  for (std::string line; std::getline(os, line);) {
    if (line.rfind("PRETTY_NAME=", 0) == 0) {
      m.os = line.substr(12);
      if (m.os.size() >= 2 && m.os.front() == '"') m.os = m.os.substr(1, m.os.size() - 2);
    }
  }
  return m;
}

}  // namespace graybox::bench
