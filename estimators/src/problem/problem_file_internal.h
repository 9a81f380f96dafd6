// Private to the problem-file parser (problem_file.cc: [problem], [model], entry points;
// problem_data.cc: [[data]] and the data loading; problem_estimation.cc: [estimation], [metrics];
// problem_diagnosis.cc: [diagnosis]; problem_equations.cc: equation blocks):
// the TOML section reader with located messages, and shared formatting helpers.
#pragma once

#include <toml++/toml.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "graybox/estimators/problem/problem_file.h"

namespace graybox::estimators::internal {

std::string Format(double v);
std::string Quoted(const std::vector<std::string>& words);
/// "; did you mean 'x'?" or "".
std::string Suggestion(const std::string& word, const std::vector<std::string>& candidates);
/// "a string", "an integer", ... for messages.
std::string TypeName(const toml::node& n);
/// The type and the value of a node for messages ("a string 'abc'").
std::string ValueText(const toml::node& n);
/// '*' matches any run of characters (possibly empty); every other character matches itself.
bool GlobMatch(const std::string& pattern, const std::string& text);
/// Sets each override's key in `root` (problem_overrides.cc; ParseProblem's contract).
void ApplyOverrides(const std::vector<ProblemOverride>& overrides, toml::table* root);
/// "key = value, key = value" for messages.
std::string OverridesText(const std::vector<ProblemOverride>& overrides);

// A TOML table being read: typed access with messages that name the file, the table path and the
// line, and a check that rejects unknown keys with a suggestion.
class Section {
 public:
  Section(std::string file, const toml::table& table, std::string path)
      : file_(std::move(file)), table_(&table), path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  const toml::table& table() const { return *table_; }

  SourceLocation Where() const { return Location(table_->source()); }
  SourceLocation Where(const std::string& key) const {
    for (auto&& [k, v] : *table_) {
      if (k.str() == key) return Location(k.source().begin.line > 0 ? k.source() : v.source());
    }
    return Where();
  }
  SourceLocation Location(const toml::source_region& region) const {
    SourceLocation w;
    w.file = file_;
    w.table = path_;
    w.line = static_cast<int>(region.begin.line);
    w.column = static_cast<int>(region.begin.column);
    return w;
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& message) const {
    throw ProblemFileError(key.empty() ? Where() : Where(key), message);
  }

  void Allow(const std::vector<std::string>& known) const {
    for (auto&& [k, v] : *table_) {
      const std::string key(k.str());
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        throw ProblemFileError(Location(k.source()), "unknown key '" + key + "'" +
                                                         Suggestion(key, known) +
                                                         " (known keys: " + Quoted(known) + ")");
      }
    }
  }

  bool Has(const std::string& key) const { return table_->contains(key); }
  const toml::node* Get(const std::string& key) const { return table_->get(key); }

  std::optional<std::string> String(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) Fail(key, "'" + key + "': expected a string, got " + ValueText(*n));
    return n->as_string()->get();
  }
  std::string RequiredString(const std::string& key) const {
    auto s = String(key);
    if (!s) Fail("", "missing key '" + key + "': expected a string");
    if (s->empty()) Fail(key, "'" + key + "': expected a non-empty string, got ''");
    return *s;
  }
  std::optional<double> Number(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    return NumberOf(*n, key);
  }
  double NumberOf(const toml::node& n, const std::string& key) const {
    double v = 0.0;
    if (const auto* i = n.as_integer()) {
      v = static_cast<double>(i->get());
    } else if (const auto* f = n.as_floating_point()) {
      v = f->get();
    } else {
      Fail(key, "'" + key + "': expected a number, got " + ValueText(n));
    }
    if (!std::isfinite(v)) Fail(key, "'" + key + "': expected a finite number, got " + Format(v));
    return v;
  }
  std::optional<double> PositiveNumber(const std::string& key) const {
    auto v = Number(key);
    if (v && !(*v > 0.0)) Fail(key, "'" + key + "': expected a number > 0, got " + Format(*v));
    return v;
  }
  std::optional<long> Integer(const std::string& key, long lo, long hi) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_integer()) {
      Fail(key, "'" + key + "': expected an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "], got " + ValueText(*n));
    }
    const long v = static_cast<long>(n->as_integer()->get());
    if (v < lo || v > hi) {
      Fail(key, "'" + key + "': expected an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "], got " + std::to_string(v));
    }
    return v;
  }
  std::optional<bool> Bool(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_boolean()) Fail(key, "'" + key + "': expected true or false, got " + ValueText(*n));
    return n->as_boolean()->get();
  }
  std::optional<std::string> Choice(const std::string& key,
                                    const std::vector<std::string>& allowed) const {
    auto s = String(key);
    if (s && std::find(allowed.begin(), allowed.end(), *s) == allowed.end()) {
      Fail(key, "'" + key + "': expected one of " + Quoted(allowed) + ", got '" + *s + "'" +
                    Suggestion(*s, allowed));
    }
    return s;
  }
  std::vector<std::string> Strings(const std::string& key) const {
    std::vector<std::string> out;
    const toml::node* n = Get(key);
    if (!n) return out;
    const toml::array* a = n->as_array();
    if (!a) Fail(key, "'" + key + "': expected an array of strings, got " + ValueText(*n));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      if (!e.is_string()) {
        throw ProblemFileError(
            Location(e.source()),
            "'" + key + "[" + std::to_string(i) + "]': expected a string, got " + ValueText(e));
      }
      out.push_back(e.as_string()->get());
    }
    return out;
  }
  std::optional<Section> Sub(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_table()) Fail(key, "'" + key + "': expected a table, got " + ValueText(*n));
    return Section(file_, *n->as_table(), Join(key));
  }
  std::vector<Section> SubArray(const std::string& key) const {
    std::vector<Section> out;
    const toml::node* n = Get(key);
    if (!n) return out;
    if (n->is_table()) {
      out.emplace_back(file_, *n->as_table(), Join(key));
      return out;
    }
    const toml::array* a = n->as_array();
    if (!a) Fail(key, "'" + key + "': expected an array of tables, got " + ValueText(*n));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      if (!e.is_table()) {
        throw ProblemFileError(
            Location(e.source()),
            "'" + key + "[" + std::to_string(i) + "]': expected a table, got " + ValueText(e));
      }
      out.emplace_back(file_, *e.as_table(), Join(key) + "[" + std::to_string(i) + "]");
    }
    return out;
  }
  std::string Join(const std::string& key) const {
    const bool plain = std::all_of(key.begin(), key.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
    });
    const std::string k = plain ? key : "\"" + key + "\"";
    return path_.empty() ? k : path_ + "." + k;
  }

 private:
  std::string file_;
  const toml::table* table_;
  std::string path_;
};

/// The sections, each filling its part of `problem` (the model must be parsed first).
/// What ResolveStateSources could not settle: the key and why (empty key: nothing).
struct StateSourceDefect {
  std::string key;
  std::string message;
};
/// Fills what a problem leaves to defaults in `spec` for `m`: the residual states (every state
/// whose derivative is not simply another state), the inverse input (the only input for one
/// residual state, form "inverse"), and `differentiate` for every state that is not a measured
/// output but the derivative of another state (dq/dt = qd). `states_only`: only the state
/// sources matter (node_guess = "data", the N-step loss). Shared by the problem-file parser and
/// MakeProblem.
StateSourceDefect ResolveStateSources(const models::StateSpaceModel& m, EquationErrorSpec* spec,
                                      bool states_only);

/// The default states of the N-step NRMS ([metrics] n_step_channels left out): those with a
/// model output of the same name, else all.
void DefaultNStepChannels(const models::StateSpaceModel& m, MetricsSpec* spec);

void ParseModel(const Section& root, Problem* problem);
void ParseData(const Section& root, Problem* problem);
/// For every input mapped with hold = "foh" (the same in every [[data]]): a new model input
/// "<input>_foh_rate" (the forward difference, mapped in every record), a signal.first_order_hold
/// "<input>_foh" in series on the input (Model::InsertOnInput), the model built again.
void ApplyFirstOrderHolds(Problem* problem);
void ParseEstimation(const Section& root, Problem* problem);
void ParseMetrics(const Section& root, Problem* problem);
/// The block of a [[model.blocks]] entry of type "equations", from its `equations` table
/// (problem_equations.cc); its defects as ProblemFileError at their place.
std::shared_ptr<const models::Block> EquationBlock(const Section& block);
/// [diagnosis] (problem_diagnosis.cc).
void ParseDiagnosis(const Section& root, Problem* problem);

}  // namespace graybox::estimators::internal
