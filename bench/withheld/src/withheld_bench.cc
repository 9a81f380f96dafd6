#include "graybox/bench/withheld_bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include <stdexcept>
#include <string>
#include <vector>
#include "graybox/diagnosis/report_json.h"

#include <nlohmann/json.hpp>

namespace graybox::bench {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using Json = nlohmann::ordered_json;

bool Contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

bool Selected(const std::string& name, const std::vector<std::string>& filters) {
  if (filters.empty()) return true;
  for (const std::string& f : filters) {
    if (name.find(f) != std::string::npos) return true;
  }
  return false;
}

double Rate(int hits, int total) { return total > 0 ? static_cast<double>(hits) / total : kNaN; }

std::string Fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), f, v);
  return buf;
}

WithheldRecord Run(const WithheldCase& c, const diagnosis::DiagnoseOptions& options) {
  WithheldRecord r;
  r.name = c.name;
  r.base = c.base;
  r.truth_detail = c.truth_detail;
  r.withheld = c.withheld;
  r.in_library = c.in_library;
  r.oracle_validation_nrmse = c.oracle_validation_nrmse;
  r.nominal_validation_nrmse = r.final_validation_nrmse = r.reference_validation_nrmse = kNaN;
  r.shrinkage = r.achievable_shrinkage = r.shrinkage_error = kNaN;
  try {
    const diagnosis::DiagnosisReport d = diagnosis::Diagnose(c.nominal, c.splits, options);
    for (const diagnosis::AcceptedEffect& a : d.accepted) r.accepted.push_back(a.effect);
    r.top = r.accepted.empty() ? "none" : r.accepted.front();
    if (!d.accepted.empty()) {
      for (const std::string& alt : d.accepted.front().alternatives) {
        const std::string effect = alt.substr(0, alt.find(' '));
        if (!Contains(r.top_alternatives, effect)) r.top_alternatives.push_back(effect);
      }
    }
    r.explained = d.explained;
    r.structured_remaining = d.structured_remaining;
    r.verdict = d.verdict;
    r.diagnosis_json = diagnosis::DiagnosisJson(d, {{"case", c.name}});
    r.nominal_validation_nrmse = d.nominal_validation_nrmse;
    r.final_validation_nrmse = d.final_validation_nrmse;
    r.reference_validation_nrmse = d.reference.validation_nrmse;
    r.shrinkage = r.nominal_validation_nrmse - r.final_validation_nrmse;
    r.achievable_shrinkage = r.nominal_validation_nrmse - r.oracle_validation_nrmse;
    if (r.achievable_shrinkage > 0.0) {
      r.shrinkage_error = std::fabs(r.shrinkage / r.achievable_shrinkage - 1.0);
    }
    if (!c.in_library) {
      // The diagnosis' own verdict: no effect, or effects that leave most of the residual's
      // structure (DiagnosisReport::explained).
      r.pass = !d.explained;
    } else if (c.withheld.size() == 1) {
      r.pass = r.top == c.withheld.front();
      r.named_or_equivalent = r.pass || Contains(r.top_alternatives, c.withheld.front());
    } else {
      r.pass = true;
      for (const std::string& w : c.withheld) r.pass = r.pass && Contains(r.accepted, w);
    }
  } catch (const std::exception& e) {
    r.failure = e.what();
    r.pass = false;
  }
  return r;
}

}  // namespace

void WithheldBenchOptions::Validate() const {
  cases.Validate();
  diagnose.Validate();
  if (!(shrinkage_tolerance > 0.0)) {
    throw std::invalid_argument("WithheldBenchOptions.shrinkage_tolerance: expected > 0, got " +
                                Fmt("%g", shrinkage_tolerance));
  }
}

WithheldBench RunWithheldBench(const WithheldBenchOptions& options) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  WithheldBench b;
  std::vector<std::string> names;
  for (const std::string& n : WithheldCaseNames(options.cases)) {
    if (Selected(n, options.name_filters)) names.push_back(n);
  }
  if (names.empty()) throw std::invalid_argument("no withheld case matches the name filters");
  diagnosis::DiagnoseOptions diagnose = options.diagnose;
  int one_hits = 0, equivalent_hits = 0, two_hits = 0, outside_hits = 0, shrink_hits = 0,
      shrink_total = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string label =
        "case " + std::to_string(i + 1) + "/" + std::to_string(names.size()) + " " + names[i];
    diagnose.progress = [&](const std::string& line) {
      if (options.progress) options.progress("  " + line);
    };
    if (options.progress) options.progress(label + ": generating and diagnosing");
    WithheldRecord r;
    try {
      r = Run(MakeWithheldCase(names[i], options.cases.seed), diagnose);
    } catch (const std::exception& e) {
      r.name = names[i];
      r.failure = e.what();
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!r.failure.empty()) ++b.num_failed;
    if (!r.in_library) {
      ++b.num_outside;
      outside_hits += r.pass ? 1 : 0;
    } else if (r.withheld.size() == 1) {
      ++b.num_one_effect;
      one_hits += r.pass ? 1 : 0;
      equivalent_hits += r.named_or_equivalent ? 1 : 0;
    } else {
      ++b.num_two_effect;
      two_hits += r.pass ? 1 : 0;
    }
    if (r.in_library && r.pass && std::isfinite(r.shrinkage_error)) {
      ++shrink_total;
      shrink_hits += r.shrinkage_error <= options.shrinkage_tolerance ? 1 : 0;
    }
    if (options.progress) {
      options.progress(label + ": top " + r.top + (r.pass ? " (pass)" : " (FAIL)") +
                       (r.failure.empty() ? "" : " failure: " + r.failure) + ", " +
                       Fmt("%.1f s", r.seconds));
    }
    b.records.push_back(std::move(r));
  }
  b.top_ranked_rate = Rate(one_hits, b.num_one_effect);
  b.named_or_equivalent_rate = Rate(equivalent_hits, b.num_one_effect);
  b.both_found_rate = Rate(two_hits, b.num_two_effect);
  b.unexplained_rate = Rate(outside_hits, b.num_outside);
  b.shrinkage_within_rate = Rate(shrink_hits, shrink_total);
  b.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return b;
}

std::string WithheldBench::ConfusionTable() const {
  std::map<std::string, std::map<std::string, int>> cells;
  std::set<std::string> columns;
  for (const WithheldRecord& r : records) {
    if (r.withheld.size() != 1) continue;
    cells[r.withheld.front()][r.top] += 1;
    columns.insert(r.top);
  }
  std::ostringstream o;
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%-22s", "withheld \\ top");
  o << buf;
  for (const std::string& c : columns) {
    std::snprintf(buf, sizeof(buf), " %8.8s", c.c_str());
    o << buf;
  }
  o << "\n";
  for (const auto& [row, counts] : cells) {
    std::snprintf(buf, sizeof(buf), "%-22s", row.c_str());
    o << buf;
    for (const std::string& c : columns) {
      const auto it = counts.find(c);
      std::snprintf(buf, sizeof(buf), " %8s",
                    it == counts.end() ? "." : std::to_string(it->second).c_str());
      o << buf;
    }
    o << "\n";
  }
  return o.str();
}

std::string WithheldBench::Summary() const {
  std::ostringstream o;
  o << "withheld top-ranked (one effect, in library): " << Fmt("%.0f %%", 100.0 * top_ranked_rate)
    << " of " << num_one_effect
    << " (with indistinguishable alternatives: " << Fmt("%.0f %%", 100.0 * named_or_equivalent_rate)
    << ")\n";
  o << "both found (two effects): " << Fmt("%.0f %%", 100.0 * both_found_rate) << " of "
    << num_two_effect << "\n";
  o << "not explained by the library (outside): " << Fmt("%.0f %%", 100.0 * unexplained_rate)
    << " of " << num_outside << "\n";
  o << "shrinkage within tolerance (passing library cases): "
    << Fmt("%.0f %%", 100.0 * shrinkage_within_rate) << "\n";
  o << "failed to run: " << num_failed << "; total " << Fmt("%.0f s", seconds) << "\n";
  char line[512];
  for (const WithheldRecord& r : records) {
    std::string accepted;
    for (const std::string& a : r.accepted) accepted += (accepted.empty() ? "" : ",") + a;
    std::snprintf(
        line, sizeof(line),
        "  %-40s %-4s top %-20s accepted [%s] %s (structure left %s) shrinkage error %s\n",
        r.name.c_str(), r.pass ? "pass" : "FAIL", r.top.c_str(), accepted.c_str(),
        r.explained ? "explained" : "not explained",
        std::isfinite(r.structured_remaining) ? Fmt("%.2f", r.structured_remaining).c_str() : "n/a",
        std::isfinite(r.shrinkage_error) ? Fmt("%.2f", r.shrinkage_error).c_str() : "n/a");
    o << line;
  }
  return o.str();
}

std::string WithheldBenchJson(const WithheldBench& b,
                              const std::vector<std::pair<std::string, std::string>>& run) {
  Json j;
  Json run_json = Json::object();
  for (const auto& [k, v] : run) run_json[k] = v;
  j["run"] = run_json;
  Json s;
  s["top_ranked_rate"] = b.top_ranked_rate;
  s["named_or_equivalent_rate"] = b.named_or_equivalent_rate;
  s["both_found_rate"] = b.both_found_rate;
  s["unexplained_rate"] = b.unexplained_rate;
  s["shrinkage_within_rate"] = b.shrinkage_within_rate;
  s["num_one_effect"] = b.num_one_effect;
  s["num_two_effect"] = b.num_two_effect;
  s["num_outside"] = b.num_outside;
  s["num_failed"] = b.num_failed;
  s["seconds"] = b.seconds;
  j["summary"] = s;
  Json records = Json::array();
  for (const WithheldRecord& r : b.records) {
    Json x;
    x["case"] = r.name;
    x["base"] = r.base;
    std::string withheld;
    for (const std::string& w : r.withheld) withheld += (withheld.empty() ? "" : "+") + w;
    x["withheld"] = withheld;
    x["in_library"] = r.in_library;
    x["truth_detail"] = r.truth_detail;
    x["top"] = r.top;
    x["accepted"] = r.accepted;
    x["top_alternatives"] = r.top_alternatives;
    x["named_or_equivalent"] = r.named_or_equivalent;
    x["explained"] = r.explained;
    x["structured_remaining"] = r.structured_remaining;
    x["pass"] = r.pass;
    x["nominal_validation_nrmse"] = r.nominal_validation_nrmse;
    x["final_validation_nrmse"] = r.final_validation_nrmse;
    x["reference_validation_nrmse"] = r.reference_validation_nrmse;
    x["oracle_validation_nrmse"] = r.oracle_validation_nrmse;
    x["shrinkage"] = r.shrinkage;
    x["achievable_shrinkage"] = r.achievable_shrinkage;
    x["shrinkage_error"] = r.shrinkage_error;
    x["verdict"] = r.verdict;
    x["failure"] = r.failure;
    x["seconds"] = r.seconds;
    records.push_back(x);
  }
  j["records"] = records;
  return j.dump(2);
}

}  // namespace graybox::bench
